"""Phase 6: recording the swarm into preallocated arrays, and exporting them.

A :class:`Recorder` keeps one array of shape ``(records, N)`` per recorded column, where
``records = iterations // every + 1`` (the initial state, then every ``every``-th
iteration): nothing grows record by record. :func:`to_table` and :func:`trace_table` turn
the arrays into long tables (one row per record and agent) for Parquet, CSV or pandas.
"""

from __future__ import annotations

import contextlib
import json
import mmap
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from pyautonomousagent.bt.limits import check_size
from pyautonomousagent.bt.spec import Node, TreeError
from pyautonomousagent.bt.status import INVALID, NAMES, RUNNING
from pyautonomousagent.inputs import InputError, shown
from pyautonomousagent.names import AgentNames
from pyautonomousagent.state import CONTROL_COLUMNS, MOTION_COLUMNS, Swarm

#: Agents traced by default: all of a swarm this small, else the first this many.
DEFAULT_TRACED = 10

#: Unit and meaning of the columns every run records: name -> (unit, meaning). Units: "" for
#: dimensionless counts and indices; world units are the scenario's (metres for the X8). A
#: mission documents its own columns and blackboard keys (``Mission.meanings``).
COLUMN_DOCS: dict[str, tuple[str, str]] = {
    "iteration": ("iteration", "the loop iteration of this record; 0 is the initial state"),
    "agent": ("", "the agent's name (drone1, drone2, ...)"),
    "x": ("world unit", "east position"),
    "y": ("world unit", "north position"),
    "speed": ("world unit / iteration", "speed over ground (the X8: airspeed, m/s)"),
    "heading": ("degree", "heading, clockwise from north (+y), in [0, 360)"),
    "requested_speed": ("world unit / iteration", "speed the tree asks the control system for"),
    "requested_heading": ("degree", "heading the tree asks the control system for"),
    "behaviour": (
        "",
        "active behaviour: the leaf RUNNING after the tick, else the last leaf "
        "ticked (empty before the first tick)",
    ),
    "number_ticks": ("", "blackboard: leaf ticks so far (each leaf tick counts one)"),
    "altitude": ("m", "X8: altitude above ground"),
    "airspeed": ("m/s", "X8: airspeed"),
    "roll": ("degree", "X8: roll angle, right wing down positive"),
    "pitch": ("degree", "X8: pitch angle, nose up positive"),
}


#: Swarms of at least this many agents keep records compact (:class:`RecordedColumns`):
#: columns stored in full only once agents differ. Smaller swarms preallocate every column at
#: set-up, as comparing each record would cost more than the memory it saves.
COMPACT_AGENTS = 1 << 16


class Recorder:
    """Preallocated columnar storage of the swarm's state and blackboard.

    Args:
        swarm: the agents (its columns and blackboard keys are recorded).
        iterations: the run's length in iterations.
        every: record iteration t when ``t % every == 0`` (decimation); 1 records all.
        extra: more columns to record (e.g. a motion model's state), name -> shape (N,).
        tree: the tree the engine ticks; given, :meth:`record` takes the node statuses and
            keeps the traces and the active behaviour.
        traced: indices of the agents whose node statuses are kept.
        docs: unit and meaning of the mission's columns, name -> (unit, meaning).

    Attributes:
        docs: unit and meaning of every column: :data:`COLUMN_DOCS` and the mission's.
        groups: the recorded column names by origin: "state", "blackboard", "model".
        nodes: the tree's nodes in tick order (``Node.walk()``), or [] without a tree.
        leaf_rows: the node indices of the leaves, ascending, shape (L,), int16.
        traced: indices of the traced agents, shape (K,).
        traces: node statuses of the traced agents, shape (records, nodes, K), int8.
        behaviour: active leaf per agent as a node index, shape (records, N), int16; -1 when
            none was ticked; None without a tree.
        codes: the active behaviours as recorded columns (one, ``"behaviour"``), to write in
            place where stored in full; None without a tree.
        listeners: called with the number of records after each record is written whole
            (e.g. :class:`~pyautonomousagent.streaming.StatesStream`).
    """

    def __init__(
        self,
        swarm: Swarm,
        iterations: int,
        every: int = 1,
        extra: Mapping[str, np.ndarray] | None = None,
        tree: Node | None = None,
        traced: Sequence[int] = (),
        docs: Mapping[str, tuple[str, str]] | None = None,
    ) -> None:
        if every < 1:
            raise ValueError(f"record_every must be >= 1, got {every}")
        self.every = every
        self.docs = {**COLUMN_DOCS, **(docs or {})}
        self.names = swarm.names if isinstance(swarm.names, AgentNames) else list(swarm.names)
        records = iterations // every + 1
        self.iterations = np.zeros(records, dtype=np.int64)
        sources = {**swarm.columns, **swarm.blackboard, **(extra or {})}
        dtypes = {k: v.dtype for k, v in sources.items()}
        compact = swarm.size >= COMPACT_AGENTS
        self.columns = RecordedColumns(dtypes, records, swarm.size, compact)
        self.groups = {
            "state": list(swarm.columns),
            "blackboard": list(swarm.blackboard),
            "model": [k for k in dtypes if k not in swarm.columns and k not in swarm.blackboard],
        }
        self.nodes: list[Node] = list(tree.walk()) if tree is not None else []
        if check_size(len(self.nodes)):  # a node index is recorded as an int16
            raise TreeError(f"the tree {check_size(len(self.nodes))} in a recorded run")
        self.leaf_rows = _leaf_rows(self.nodes)
        self.traced = np.asarray(traced if tree is not None else (), dtype=np.intp)
        self.traces = preallocated((records, len(self.nodes), self.traced.size), np.dtype(np.int8))
        codes = {"behaviour": np.dtype(np.int16)}
        self.codes = RecordedColumns(codes, records, swarm.size, compact) if tree else None
        self.count = 0
        self.listeners: list[Callable[[int], None]] = []

    @property
    def wants_statuses(self) -> bool:
        """Whether :meth:`record` needs the engine's node statuses (a tree was given)."""
        return self.codes is not None

    @property
    def behaviour(self) -> np.ndarray | None:
        """Active leaf per agent as a node index, shape (records, N), int16 (see the class)."""
        return None if self.codes is None else self.codes["behaviour"]

    def behaviour_block(self, start: int, stop: int) -> np.ndarray:
        """Records ``start`` to ``stop`` of :attr:`behaviour`, shape (stop - start, N), without
        storing them all (:meth:`RecordedColumns.block`); requires a tree."""
        if self.codes is None:
            raise ValueError("this recorder has no tree, so no active behaviours")
        return self.codes.block("behaviour", start, stop)

    def due(self, iteration: int) -> bool:
        """Whether ``iteration`` is recorded."""
        return iteration % self.every == 0

    def record(
        self,
        iteration: int,
        swarm: Swarm,
        extra: Mapping[str, np.ndarray] | None = None,
        statuses: np.ndarray | None = None,
    ) -> None:
        """Copy the swarm's current state (and the ``extra`` columns) into the next record.

        ``statuses``: the engine's node statuses after this iteration's tick, shape
        (nodes, N) int8; required when the recorder has a tree.
        """
        row = self.count
        self.iterations[row] = iteration
        sources = {**swarm.columns, **swarm.blackboard, **(extra or {})}
        self.columns.store_record(row, sources)
        if self.codes is not None:
            if statuses is None:
                raise ValueError("this recorder keeps traces: pass the engine's node statuses")
            self.traces[row] = statuses[:, self.traced]
            self.codes.store(row, "behaviour", active_leaf(statuses, self.leaf_rows))
        self.count += 1
        for listener in self.listeners:
            listener(self.count)

    def store_group(
        self,
        row0: int,
        columns: Mapping[str, np.ndarray],
        traces: np.ndarray | None,
        behaviour: np.ndarray | None = None,
    ) -> None:
        """Store records ``row0`` .. ``row0 + rows - 1`` written elsewhere (e.g. by a GPU
        kernel, or a fused loop's block: :class:`~pyautonomousagent.record_blocks.RecordBlock`),
        as :meth:`record` stores them one by one (compact columns stay compact, and the same
        ones are stored in full); the bookkeeping (``iterations``, ``count``, listeners) is
        the caller's.

        Args:
            row0: the first record's number.
            columns: recorded columns, name -> values of shape (rows, N); a column left out
                was written in place (into :meth:`RecordedColumns.full`).
            traces: the traced agents' node statuses, shape (rows, nodes, K), int8; None
                where they were written in place.
            behaviour: the active leaves, shape (rows, N), int16; with a tree, required
                unless they were written in place (their array stored in full).
        """
        self.columns.store_rows(row0, columns)
        if traces is not None:
            self.traces[row0 : row0 + len(traces)] = traces
        if self.codes is not None and behaviour is not None:
            self.codes.store_rows(row0, {"behaviour": behaviour})
        elif self.codes is not None and self.codes.full("behaviour") is None:
            raise ValueError("this recorder keeps traces: pass the active behaviours")

    def trace(self, agent: int | str) -> np.ndarray:
        """The node statuses of one traced agent (index or name), shape (records so far, nodes)."""
        index = self.names.index(agent) if isinstance(agent, str) else agent
        found = np.flatnonzero(self.traced == index)
        if found.size == 0:
            traced = ", ".join(self.names[i] for i in self.traced) or "none"
            raise KeyError(f"agent {self.names[index]!r} was not traced (traced: {traced})")
        return self.traces[: self.count, :, found[0]]

    def column(self, key: str) -> np.ndarray:
        """The recorded values of ``key``, shape (records so far, N)."""
        return self.columns[key][: self.count]


def _leaf_rows(nodes: Sequence[Node]) -> np.ndarray:
    """The node indices of the leaves among ``nodes`` (tick order), ascending, int16."""
    return np.array([i for i, node in enumerate(nodes) if not node.is_control], dtype=np.int16)


def active_leaf(statuses: np.ndarray, leaf_rows: np.ndarray) -> np.ndarray:
    """Each agent's active leaf as a node index, shape (N,) int16; -1 where no leaf was ticked.

    The active leaf is the first leaf (in tick order) that is RUNNING, or else the last leaf
    whose status is not INVALID (the last one ticked).

    Args:
        statuses: node statuses, shape (nodes, N), int8.
        leaf_rows: node indices of the leaves, ascending, shape (L,).
    """
    count = leaf_rows.size
    if count == 0:
        return np.full(statuses.shape[1], -1, dtype=np.int16)
    if statuses.shape[1] <= FEW_AGENTS:
        return _active_leaf_each(statuses, leaf_rows)
    # Rank of leaf p: 2L - p if RUNNING (an earlier RUNNING leaf ranks higher, above any
    # ticked one), p + 1 if ticked (a later one higher), 0 if INVALID; the highest rank wins.
    # Elementwise products and a maximum over rows: no argmax across rows (8x faster).
    kind = np.int8 if 2 * count < 128 else np.int16
    p = np.arange(count)[:, None]
    leaves = statuses[leaf_rows]
    rank = (leaves != INVALID).astype(kind) * (p + 1).astype(kind)
    rank += (leaves == RUNNING).astype(kind) * (2 * count - 2 * p - 1).astype(kind)
    best = rank.max(axis=0).astype(np.int32)
    position = np.where(best > count, 2 * count - best, best - 1)
    return np.where(best > 0, leaf_rows[np.maximum(position, 0)], -1).astype(np.int16)


#: Swarms up to this size find their active leaves agent by agent in Python (:func:`active_leaf`):
#: cheaper than NumPy's cost per call for a few agents.
FEW_AGENTS = 16


def _active_leaf_each(statuses: np.ndarray, leaf_rows: np.ndarray) -> np.ndarray:
    """:func:`active_leaf` agent by agent (the same result; for a few agents)."""
    rows = leaf_rows.tolist()
    found = []
    for agent in statuses[leaf_rows].T.tolist():
        if RUNNING in agent:  # the usual case, found by list methods in C
            found.append(rows[agent.index(RUNNING)])
            continue
        best = -1
        for row, status in zip(rows, agent, strict=True):
            if status != INVALID:
                best = row
        found.append(best)
    return np.array(found, dtype=np.int16)


def traced_agents(names: Sequence[str], trace: int | str | Sequence[str] | None) -> list[int]:
    """Indices of the agents to trace, ascending.

    Args:
        names: every agent's name, in order.
        trace: None (the default: every agent of a swarm of at most :data:`DEFAULT_TRACED`,
            else the first that many), a count (the first ``trace`` agents; 0 traces none),
            or a list (or one comma-separated string) of names, counts and "all", whose
            agents are all traced: ``"4,drone57"`` is the first four and drone57.

    Raises:
        ValueError: a name that is no agent's, a negative count, or an empty item (``",,"``);
            the message names it.
    """
    if trace is None:
        trace = DEFAULT_TRACED
    if isinstance(trace, int):
        if trace < 0:
            raise ValueError(f"trace: a count of agents must be >= 0, got {trace}")
        return list(range(min(trace, len(names))))
    items = trace.split(",") if isinstance(trace, str) else list(trace)
    if not all(str(item).strip() for item in items):
        raise ValueError(
            f"trace: give agent names, counts or 'all' separated by commas, got {shown(trace)}"
        )
    index = {name: i for i, name in enumerate(names)}
    chosen: set[int] = set()
    for item in (str(t).strip() for t in items):
        if item == "all":
            chosen.update(range(len(names)))
        elif item.isdigit():
            chosen.update(range(min(int(item), len(names))))
        elif item in index:
            chosen.add(index[item])
        elif item:
            known = f"agents are {names[0]}..{names[-1]}" if names else "the swarm has no agents"
            raise ValueError(f"trace: no agent named {item!r}; {known} (or give a count, or 'all')")
    return sorted(chosen)


class RecordedColumns(Mapping[str, np.ndarray]):
    """The recorded columns, name -> values of shape (records, N), stored when they differ.

    Until a column's values differ between agents in a record, only one value per record
    is kept, shape (records,); the first record in which they differ allocates the whole
    column (:func:`preallocated`) and fills the earlier records in: a column the same for
    every agent throughout (a shared patrol point) is never stored in full. A record of a
    column equal to the same record of a column stored in full (the requested heading is
    the heading at the start) is kept as a reference to it. Values are compared bit by bit,
    so NaNs and -0.0 come back as they were recorded.

    Reading a column (``columns[key]``) stores it in full; :meth:`block` does not. With
    ``compact=False`` every column is stored in full at once (no comparisons per record).
    """

    def __init__(
        self, dtypes: Mapping[str, np.dtype], records: int, agents: int, compact: bool = True
    ) -> None:
        self.records, self.agents = records, agents
        self.dtypes = {k: np.dtype(v) for k, v in dtypes.items()}
        self._same = {k: np.zeros(records, dtype) for k, dtype in self.dtypes.items()}
        self._full: dict[str, np.ndarray] = {}
        self._twins: dict[str, dict[int, str]] = {k: {} for k in self.dtypes}
        if not compact:
            for key in self.dtypes:
                self._stored(key, 0)

    @classmethod
    def of(cls, arrays: Mapping[str, np.ndarray]) -> RecordedColumns:
        """Columns already recorded in full, each of shape (records, N)."""
        shapes = {v.shape for v in arrays.values()} or {(0, 0)}
        records, agents = shapes.pop()
        columns = cls({k: v.dtype for k, v in arrays.items()}, records, agents)
        columns._full.update(arrays)
        return columns

    def store(self, row: int, key: str, values: np.ndarray) -> None:
        """Record ``values`` (shape (N,)) as record ``row`` of column ``key``."""
        full = self._full.get(key)
        if full is None:
            if self.agents == 0:
                return
            if same_everywhere(values):
                self._same[key][row] = values[0]
                return
            twin = self._twin(row, values)
            if twin is not None:
                self._twins[key][row] = twin
                return
            full = self._stored(key, row)
        full[row] = values

    def store_rows(self, row0: int, blocks: Mapping[str, np.ndarray]) -> None:
        """Record ``blocks[key]`` (shape (rows, N)) as records ``row0``.. of each column
        ``key`` given: at once for a column stored in full, the others record by record and,
        within a record, column by column in this mapping's column order, as
        :meth:`store_record` does (so the same columns end up stored in full)."""
        rest = [key for key in self.dtypes if key in blocks and key not in self._full]
        for key, values in blocks.items():
            if key not in rest:
                self._full[key][row0 : row0 + len(values)] = values
        rows = max((len(blocks[key]) for key in rest), default=0)
        for r in range(rows):
            for key in rest:
                self.store(row0 + r, key, blocks[key][r])

    def full(self, key: str) -> np.ndarray | None:
        """Column ``key``'s array of shape (records, N) where it is stored in full, else None
        (without storing it: see :meth:`__getitem__`)."""
        return self._full.get(key)

    def store_record(self, row: int, sources: Mapping[str, np.ndarray]) -> None:
        """Record ``sources[key]`` (shape (N,)) as record ``row`` of every column ``key``."""
        if len(self._full) == len(self.dtypes):  # all stored in full: no comparisons
            for key, full in self._full.items():
                full[row] = sources[key]
            return
        for key in self.dtypes:
            self.store(row, key, sources[key])

    def _twin(self, row: int, values: np.ndarray) -> str | None:
        """A column stored in full whose record ``row`` has the bits of ``values``, or None."""
        for key, full in list(self._full.items()):
            if full.dtype == values.dtype and same_bits(full[row], values):
                return key
        return None

    @property
    def stored(self) -> list[str]:
        """The columns stored in full so far."""
        return list(self._full)

    def block(self, key: str, start: int, stop: int) -> np.ndarray:
        """Records ``start`` to ``stop`` of ``key``, shape (stop - start, N), not stored in
        full for it (a column stored in full is returned as a view)."""
        full = self._full.get(key)
        if full is not None:
            return full[start:stop]
        block = np.repeat(self._same[key][start:stop], self.agents).reshape(-1, self.agents)
        self._fill_twins(key, block, start)
        return block

    def _stored(self, key: str, rows: int) -> np.ndarray:
        """Store ``key`` in full, its first ``rows`` records filled in; the array."""
        full = preallocated((self.records, self.agents), self.dtypes[key])
        full[:rows] = self._same[key][:rows, None]
        self._fill_twins(key, full[:rows], 0)
        self._full[key] = full  # published once filled in (a writing thread may read)
        return full

    def _fill_twins(self, key: str, block: np.ndarray, start: int) -> None:
        """Copy into ``block`` (records ``start``.. of ``key``) the records kept as twins."""
        for row, twin in list(self._twins[key].items()):
            if start <= row < start + len(block):
                block[row - start] = self._full[twin][row]

    def __getitem__(self, key: str) -> np.ndarray:
        full = self._full.get(key)
        return full if full is not None else self._stored(key, self.records)

    def __iter__(self) -> Iterator[str]:
        return iter(self.dtypes)

    def __len__(self) -> int:
        return len(self.dtypes)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether arrays ``a`` and ``b`` of one dtype and shape (N,) hold the same bits."""
    size = a.dtype.itemsize
    if a.shape != b.shape or size not in (1, 2, 4, 8) or a.dtype.hasobject:
        return False
    x, y = np.ascontiguousarray(a).view(f"u{size}"), np.ascontiguousarray(b).view(f"u{size}")
    return x.size == 0 or (bool(x[0] == y[0]) and bool(np.array_equal(x, y)))


def same_everywhere(values: np.ndarray) -> bool:
    """Whether every element of ``values`` (shape (N,), N >= 1) has the same bits."""
    size = values.dtype.itemsize
    if not values.flags.c_contiguous or size not in (1, 2, 4, 8) or values.dtype.hasobject:
        return False
    bits = values.view(f"u{size}")
    return bool(bits[-1] == bits[0]) and bool((bits == bits[0]).all())


def preallocated(shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """A zero-filled array whose memory is committed at once (Linux: ``MAP_POPULATE``), not
    page by page on first writes as ``numpy.zeros`` does (on a virtual machine, three times
    slower). Small arrays, and systems without ``MAP_POPULATE``, get ``numpy.zeros``."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dtype.itemsize
    populate = getattr(mmap, "MAP_POPULATE", None)
    if populate is None or nbytes < 1 << 20:
        return np.zeros(shape, dtype)
    flags = mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | populate
    return np.frombuffer(mmap.mmap(-1, nbytes, flags=flags), dtype=dtype).reshape(shape)


def to_table(recorder: Recorder, start: int = 0, stop: int | None = None) -> pa.Table:
    """The records ``start`` to ``stop`` (record numbers; default: all recorded so far) as a
    long table: ``iteration, agent``, the state, ``behaviour`` (when the recorder has a
    tree), the blackboard and model columns; ``(stop - start) x N`` rows.

    The numeric columns share the recorder's memory (no copy). Each field's metadata holds
    its ``unit`` and ``description`` (:data:`COLUMN_DOCS`).
    """
    stop = recorder.count if stop is None else stop
    records, n = stop - start, len(recorder.names)
    data: dict[str, pa.Array] = {
        "iteration": pa.array(np.repeat(recorder.iterations[start:stop], n)),
        "agent": _agent_column(recorder.names, records),
    }
    keys = list(recorder.columns)
    if recorder.wants_statuses:  # right after the requested heading (at the end if none)
        at = keys.index("requested_heading") + 1 if "requested_heading" in keys else len(keys)
        keys.insert(at, "behaviour")
    for key in keys:
        if key == "behaviour":
            data[key] = _behaviour_column(recorder, start, stop)
        else:
            data[key] = pa.array(recorder.columns.block(key, start, stop).reshape(-1))
    groups = {key: group for group, keys in recorder.groups.items() for key in keys}
    return _documented(pa.table(data), docs=recorder.docs, groups=groups)


def recorder_from_tables(
    states: pa.Table, traces: pa.Table | None = None, nodes: Sequence[Mapping[str, Any]] = ()
) -> Recorder:
    """A :class:`Recorder` holding a written run again (for replays of an existing run).

    Args:
        states: the states table (:func:`to_table`, as written; CSV reads back too).
        traces: the traces table (:func:`trace_table`), or None.
        nodes: the tree's nodes (:func:`node_list`); by default from the traces' metadata.
    """
    iteration = states.column("iteration").to_numpy()
    records = int(np.unique(iteration).size)
    n = states.num_rows // max(records, 1)
    recorder = Recorder.__new__(Recorder)
    recorder.every = int(np.diff(iteration[::n]).min()) if records > 1 else 1
    recorder.count = records
    recorder.listeners = []
    recorder.iterations = iteration[::n].astype(np.int64)
    recorder.names = [str(a) for a in states.column("agent").to_pylist()[:n]]
    kept = [k for k in states.column_names if k not in ("iteration", "agent", "behaviour")]
    recorder.columns = RecordedColumns.of(
        {k: states.column(k).to_numpy().reshape(records, n) for k in kept}
    )
    recorder.groups = {"state": [], "blackboard": [], "model": []}
    recorder.docs = dict(COLUMN_DOCS)
    for name in recorder.columns:
        meta = states.schema.field(name).metadata or {}
        if meta.get(b"description"):
            recorder.docs[name] = (meta.get(b"unit", b"").decode(), meta[b"description"].decode())
        group = meta.get(b"group", b"").decode() or (
            "state" if name in MOTION_COLUMNS or name in CONTROL_COLUMNS else "model"
        )
        recorder.groups.setdefault(group, []).append(name)
    if not nodes and traces is not None and traces.schema.metadata:
        nodes = json.loads(traces.schema.metadata.get(b"pyautonomousagent.nodes", b"[]"))
    recorder.nodes = _rebuild(nodes)
    recorder.leaf_rows = _leaf_rows(recorder.nodes)
    recorder.codes = _behaviour_codes(states, recorder.nodes, records, n)
    names = [str(a) for a in traces.column("agent").to_pylist()] if traces is not None else []
    k = len(dict.fromkeys(names))
    recorder.traced = np.array([recorder.names.index(a) for a in names[:k]], dtype=np.intp)
    recorder.traces = np.zeros((records, len(recorder.nodes), k), dtype=np.int8)
    for j, node in enumerate(recorder.nodes):
        if traces is not None:
            recorder.traces[:, j, :] = traces.column(node.name).to_numpy().reshape(records, k)
    return recorder


def _rebuild(nodes: Sequence[Mapping[str, Any]]) -> list[Node]:
    """:class:`Node` objects (in tick order) from :func:`node_list`'s dicts."""
    children: dict[int, list[int]] = {i: [] for i in range(len(nodes))}
    for i, node in enumerate(nodes):
        if int(node["parent"]) >= 0:
            children[int(node["parent"])].append(i)
    built: dict[int, Node] = {}
    for i in reversed(range(len(nodes))):
        kids = tuple(built[c] for c in children[i])
        params = dict(nodes[i].get("params") or {})
        built[i] = Node(str(nodes[i]["type"]), str(nodes[i]["name"]), kids, params)
    return [built[i] for i in range(len(nodes))]


def _behaviour_codes(
    states: pa.Table, nodes: Sequence[Node], records: int, n: int
) -> RecordedColumns | None:
    """The ``behaviour`` column as node indices (records, N), -1 for none (as
    :attr:`Recorder.codes`); None if absent."""
    if "behaviour" not in states.column_names or not nodes:
        return None
    index = {node.name: i for i, node in enumerate(nodes)}
    names = states.column("behaviour").to_pylist()
    codes = np.array([index.get(v, -1) if v else -1 for v in names], dtype=np.int16)
    return RecordedColumns.of({"behaviour": codes.reshape(records, n)})


def trace_table(recorder: Recorder) -> pa.Table:
    """The traced agents' node statuses: one row per record and traced agent, columns
    ``iteration, agent`` and one int8 column per node (named by the node, in tick order).

    The schema metadata holds ``pyautonomousagent.nodes`` (JSON: per node its name, type,
    parent index and depth) and ``pyautonomousagent.status_codes`` (JSON: code -> name).
    """
    records, k = recorder.count, recorder.traced.size
    names = [recorder.names[i] for i in recorder.traced]
    data: dict[str, pa.Array] = {
        "iteration": pa.array(np.repeat(recorder.iterations[:records], k)),
        "agent": _agent_column(names, records),
    }
    statuses = recorder.traces[:records]  # (records, nodes, K)
    for j, node in enumerate(recorder.nodes):
        data[node.name] = pa.array(np.ascontiguousarray(statuses[:, j, :]).reshape(-1))
    status = (
        "status code",
        "the node's status after the tick: 0 INVALID (not ticked), 1 SUCCESS, 2 FAILURE, 3 RUNNING",
    )
    metadata = {
        "pyautonomousagent.nodes": json.dumps(node_list(recorder.nodes)),
        "pyautonomousagent.status_codes": json.dumps(NAMES),
    }
    return _documented(pa.table(data, metadata=metadata), {n.name: status for n in recorder.nodes})


def node_list(nodes: Sequence[Node]) -> list[dict[str, object]]:
    """Nodes in tick order as plain dicts: name, type, parent index (-1: the root), depth and
    parameters (ports)."""
    parent, depth = [-1] * len(nodes), [0] * len(nodes)
    for i, node in enumerate(nodes):
        child = i + 1
        for sub in node.children:
            parent[child], depth[child] = i, depth[i] + 1
            child += sum(1 for _ in sub.walk())
    return [
        {
            "name": n.name,
            "type": n.type,
            "parent": parent[i],
            "depth": depth[i],
            "params": json.loads(json.dumps(dict(n.params), default=str)),
        }
        for i, n in enumerate(nodes)
    ]


def _agent_column(names: Sequence[str], records: int) -> pa.DictionaryArray:
    """Agent names repeated per record, dictionary-encoded (int32 indices)."""
    indices = np.tile(np.arange(len(names), dtype=np.int32), records)
    return pa.DictionaryArray.from_arrays(pa.array(indices), pa.array(list(names), pa.string()))


def _behaviour_column(recorder: Recorder, start: int, stop: int) -> pa.DictionaryArray:
    """The active leaf's name per record ``start`` to ``stop`` and agent; null where none
    was ticked."""
    codes = recorder.behaviour_block(start, stop).reshape(-1).astype(np.int32)
    indices = pa.array(codes, mask=codes < 0)
    dictionary = pa.array([node.name for node in recorder.nodes], pa.string())
    return pa.DictionaryArray.from_arrays(indices, dictionary)


def _documented(
    table: pa.Table, docs: Mapping[str, tuple[str, str]], groups: Mapping[str, str] | None = None
) -> pa.Table:
    """``table`` with each column's unit and description as field metadata, from ``docs``
    or else :data:`COLUMN_DOCS` (unknown columns get empty strings), and its ``group``
    (state, blackboard, model) where ``groups`` gives one."""
    docs = {**COLUMN_DOCS, **docs}
    groups = groups or {}
    fields = []
    for field in table.schema:
        unit, text = docs.get(field.name, ("", ""))
        group = {"group": groups[field.name]} if field.name in groups else {}
        fields.append(field.with_metadata({"unit": unit, "description": text, **group}))
    return table.cast(pa.schema(fields, metadata=table.schema.metadata))


def write_table(table: pa.Table, path: Path, fmt: str = "parquet") -> Path:
    """Write ``table`` as ``path`` in ``fmt`` ("parquet" or "csv"); return the path."""
    if fmt == "parquet":
        import pyarrow.parquet as pq

        pq.write_table(table, path, **parquet_options(table.schema))
    elif fmt == "csv":
        import pyarrow.csv as pcsv

        pcsv.write_csv(table.cast(_plain_agent(table.schema)), path)
    else:
        raise ValueError(f"unknown format {fmt!r}; use 'parquet' or 'csv'")
    return path


def parquet_options(schema: pa.Schema) -> dict[str, Any]:
    """How the records are written to Parquet (``pyarrow.parquet.write_table`` options).

    Dictionary encoding only for the dictionary-typed columns (agent, behaviour): on float
    columns pyarrow gives up on a dictionary after 1 MiB and writes plain, twice as slowly.
    Statistics (which readers use to skip row groups) for ``iteration`` only: on every column
    they cost a sixth of the writing. Measured: docs/performance.md.
    """
    dictionary = [f.name for f in schema if pa.types.is_dictionary(f.type)]
    statistics = [name for name in ("iteration",) if name in schema.names]
    return {"use_dictionary": dictionary, "write_statistics": statistics, "compression": "snappy"}


def read_table(path: Path) -> pa.Table:
    """A table written by :func:`write_table` (by the file's ending: .parquet or .csv)."""
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq

        return pq.read_table(path)
    import pyarrow.csv as pcsv

    return pcsv.read_csv(path)


def _plain_agent(schema: pa.Schema) -> pa.Schema:
    """The schema with dictionary-encoded columns (agent, behaviour) as plain strings (CSV)."""
    plain = [f.with_type(pa.string()) if pa.types.is_dictionary(f.type) else f for f in schema]
    return pa.schema(plain, metadata=schema.metadata)


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``; elsewhere the
    physical memory), or None if unknown."""
    with contextlib.suppress(OSError, ValueError, IndexError), open("/proc/meminfo") as meminfo:
        for line in meminfo:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    with contextlib.suppress(AttributeError, ValueError, OSError):
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    return None


def check_memory(agents: int, iterations: int, every: int, columns: int, per_agent: int = 0) -> int:
    """Refuse a run whose records cannot fit in the available memory; return its estimate.

    The estimate is a lower bound: ``agents x (iterations // every + 1) x columns x 8``
    bytes of records, plus ``per_agent`` bytes of working state (tree, names) per agent.

    Raises:
        InputError: the estimate is above the available memory, with the figure and the fix.
    """
    records = iterations // every + 1
    needed = agents * (records * columns * 8 + per_agent)
    available = available_memory()
    if available is not None and needed > available:
        raise InputError(
            f"the run needs at least {needed / 1e9:.3g} GB ({agents} agents x {records} "
            f"records x {columns} columns x 8 bytes, plus the trees), more than the "
            f"{available / 1e9:.3g} GB available; record less often (--record-every K, "
            "record_every=K), or simulate fewer agents or iterations"
        )
    return needed
