"""A finished run folder read back as untrusted input (``pyaa replay``).

A run folder may have been edited, truncated or copied half-way, so everything in it is
checked (:func:`read_summary`, :func:`read_recorder`) before anything is drawn, and each
failure is one :class:`~pyautonomousagent.inputs.InputError` line naming the file and the
field.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa

from pyautonomousagent.bt.limits import MAX_TREE_DEPTH, MAX_TREE_NODES
from pyautonomousagent.inputs import InputError, clip, finite, load_json, read_parquet, read_text
from pyautonomousagent.recording import Recorder, recorder_from_tables

#: Largest run.json read, bytes (its events grow with the run: a generous bound).
MAX_SUMMARY_BYTES = 256_000_000
#: The columns of a states table that a replay draws.
STATES_COLUMNS = ("iteration", "agent", "x", "y", "heading")
FIX = "give a folder that pyaa run wrote, or run it again"


def read_summary(folder: Path) -> dict[str, Any]:
    """``folder``'s run.json, checked: bounded, UTF-8 and valid JSON, a mapping whose
    ``scenario`` is a mapping, ``events`` a list of events and ``trace.nodes`` a tree in tick
    order (:func:`check_nodes`).

    Raises:
        InputError: no run.json, or one that is unreadable or not what pyaa run writes.
    """
    path = folder / "run.json"
    if not path.is_file():
        raise InputError(f"{folder}: no run.json here; {FIX}")
    summary = load_json(read_text(path, "run summary", MAX_SUMMARY_BYTES), str(path))
    if not isinstance(summary, dict):
        raise InputError(f"{path}: must be a JSON object (a mapping), got a {_kind(summary)}")
    if not isinstance(summary.get("scenario"), dict):
        raise InputError(
            f"{path}: 'scenario' must be a mapping, got {_kind(summary.get('scenario'))}"
        )
    _check_events(summary.get("events", []), path)
    trace = summary.get("trace", {})
    if not isinstance(trace, dict):
        raise InputError(f"{path}: 'trace' must be a mapping, got a {_kind(trace)}")
    check_nodes(trace.get("nodes", []), f"{path}: trace.nodes")
    return summary


def _kind(value: Any) -> str:
    """The JSON name of ``value``'s type, for messages."""
    names = {dict: "mapping", list: "list", str: "string", bool: "boolean", type(None): "null"}
    return names.get(type(value), "number")


def _check_events(events: Any, path: Path) -> None:
    """Events are mappings whose ``iteration`` is a whole number and whose ``data`` (a
    message's) is a mapping of finite numbers."""
    if not isinstance(events, list):
        raise InputError(f"{path}: 'events' must be a list, got a {_kind(events)}")
    for i, event in enumerate(events):
        where = f"{path}: events[{i}]"
        if not isinstance(event, dict):
            raise InputError(f"{where} must be a mapping, got a {_kind(event)}")
        iteration = event.get("iteration", 0)
        if isinstance(iteration, bool) or not isinstance(iteration, int):
            raise InputError(f"{where}.iteration must be a whole number, got {_kind(iteration)}")
        data = event.get("data") or {}
        if not isinstance(data, dict):
            raise InputError(f"{where}.data must be a mapping, got a {_kind(data)}")
        for key in ("x", "y"):
            if key in data and not finite(data[key]) and data[key] is not None:
                raise InputError(f"{where}.data.{key} must be a number")
        if not isinstance(event.get("receivers", "all"), str | list):
            raise InputError(f"{where}.receivers must be a name or a list of names")


def check_nodes(nodes: Any, where: str) -> None:
    """A tree in tick order as :func:`~pyautonomousagent.recording.node_list` writes it:
    mappings with a ``name`` and ``type`` (text) and the ``parent``'s index (-1 for the first,
    the root; else an earlier node), at most :data:`MAX_TREE_NODES` nodes and
    :data:`MAX_TREE_DEPTH` levels.

    Raises:
        InputError: naming ``where`` and the node.
    """
    if not isinstance(nodes, list):
        raise InputError(f"{where} must be a list of nodes, got a {_kind(nodes)}")
    if len(nodes) > MAX_TREE_NODES:
        raise InputError(f"{where} has {len(nodes)} nodes, more than {MAX_TREE_NODES}")
    depth: list[int] = []
    for i, node in enumerate(nodes):
        if not isinstance(node, dict):
            raise InputError(f"{where}[{i}] must be a mapping, got a {_kind(node)}")
        for key in ("name", "type"):
            if not isinstance(node.get(key), str):
                raise InputError(f"{where}[{i}].{key} must be text")
        parent = node.get("parent")
        if not isinstance(parent, int) or isinstance(parent, bool) or not -1 <= parent < i:
            raise InputError(f"{where}[{i}].parent must be the index of an earlier node")
        if (parent == -1) != (i == 0):
            raise InputError(f"{where}[{i}].parent: only the first node is the root (-1)")
        depth.append(0 if parent < 0 else depth[parent] + 1)
        if depth[-1] >= MAX_TREE_DEPTH:
            raise InputError(f"{where}[{i}] is more than {MAX_TREE_DEPTH} levels deep")
        if not isinstance(node.get("params") or {}, dict):
            raise InputError(f"{where}[{i}].params must be a mapping")


def read_recorder(folder: Path, nodes: list[Mapping[str, Any]]) -> Recorder:
    """The recorder of ``folder``'s states (and traces) table, with the tree ``nodes``.

    Raises:
        InputError: no states table, one that is damaged or lacks a column, or tables that
            do not fit together.
    """
    for fmt in ("parquet", "csv"):
        path = folder / f"states.{fmt}"
        if path.is_file():
            states = _table(path, "states table", STATES_COLUMNS)
            traces_path = folder / f"traces.{fmt}"
            traces = _table(traces_path, "traces table") if traces_path.is_file() else None
            break
    else:
        raise InputError(f"{folder}: no states.parquet or states.csv; {FIX}")
    _check_numbers(states, path)
    if not nodes and traces is not None and traces.schema.metadata:
        text = traces.schema.metadata.get(b"pyautonomousagent.nodes", b"[]")
        nodes = load_json(text.decode("utf-8", "replace"), f"{traces_path} (metadata)")
        check_nodes(nodes, f"{traces_path}: the nodes in its metadata")
    try:
        return recorder_from_tables(states, traces, nodes)
    except (ValueError, TypeError, KeyError, IndexError, pa.ArrowException) as error:
        raise InputError(
            f"{path}: the tables do not fit together ({clip(str(error), 160)}); {FIX}"
        ) from None


def _check_numbers(states: pa.Table, path: Path) -> None:
    """The iteration must be whole numbers, the positions and headings numbers."""
    for name in STATES_COLUMNS:
        kind = states.schema.field(name).type
        whole = pa.types.is_integer(kind)
        if name != "agent" and not (whole or (name != "iteration" and pa.types.is_floating(kind))):
            must = "whole numbers" if name == "iteration" else "numbers"
            raise InputError(f"{path}: column {name!r} must hold {must}, not {kind}; {FIX}")


def _table(path: Path, what: str, columns: tuple[str, ...] = ()) -> pa.Table:
    """A Parquet or CSV table of a run folder, with ``columns``."""
    if path.suffix == ".parquet":
        return read_parquet(path, what, columns)
    import pyarrow.csv as pcsv

    try:
        table = pcsv.read_csv(path)
    except (OSError, pa.ArrowException) as error:
        raise InputError(f"{path}: the {what} cannot be read ({clip(str(error), 160)})") from None
    missing = [name for name in columns if name not in table.column_names]
    if missing:
        raise InputError(f"{path}: the {what} has no column {missing[0]!r}; {FIX}")
    return table
