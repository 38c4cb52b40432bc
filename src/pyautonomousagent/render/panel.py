"""The animation's text panel: the lines beside the map, each a fixed label and a value that
changes from frame to frame, with the widest text each value takes over the run (so that the
frame can be laid out once, wide enough for every value; :mod:`.animation`).

The iteration, the followed agent's active behaviour (when recorded), its state (position,
speed, heading, energy, damage, radiation and the motion model's columns) and its blackboard
(``x_K``/``y_K`` pairs as one point). Labels carry the unit (see :data:`UNITS`); keys that
were not recorded are left out, so the labels are the same for every row of a run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pyautonomousagent.recording import Recorder

UNITS = {"world unit": "u", "world unit / iteration": "u/it", "degree": "deg", "percent": "%"}
"""Short forms of the recorded columns' units (``Recorder.docs``) in the panel."""
LABELS = {"number_ticks": "leaf ticks so far"}
"""Panel labels that differ from the column name."""
NO_LEAF = "(none yet)"
"""The active behaviour before the agent's first leaf."""


@dataclass(frozen=True)
class PanelLine:
    """One line of the panel.

    Attributes:
        label: the fixed text at the line's left ("" for a value on its own line, indented;
            "" without a value: a blank line).
        value: the value's text at a record row ("" for a heading).
        widest: the most characters the value takes at any record row of the run.
    """

    label: str
    value: Callable[[int], str]
    widest: int


def _fixed(label: str, text: str = "") -> PanelLine:
    return PanelLine(label, lambda row: text, len(text))


def panel_lines(recorder: Recorder, agent: int = 0) -> list[PanelLine]:
    """The panel's lines for agent ``agent`` (index) of the run in ``recorder``."""
    columns, count = recorder.columns, recorder.count
    iterations, last = recorder.iterations, int(recorder.iterations[count - 1])
    name = recorder.names[agent] if recorder.names else "agent 1"
    lines = [
        PanelLine("Iteration", lambda row: f"{int(iterations[row])} of {last}",
                  len(f"{last} of {last}")),
        _fixed("Following", name),
    ]  # fmt: skip
    if recorder.behaviour is not None:
        lines += [_fixed("Active behaviour (leaf)"), _leaf_line(recorder, agent)]
    lines += [_fixed(""), _fixed(f"State of {name}")]
    state = [k for k in recorder.groups.get("state", []) if not k.startswith("requested_")]
    model = recorder.groups.get("model", [])
    shown = [k for k in state + model if k in columns]
    lines += _value_lines(columns, shown, agent, count, recorder.docs)
    board = [k for k in recorder.groups.get("blackboard", []) if k in columns]
    if board:
        lines += [_fixed(""), _fixed("Blackboard")]
        lines += _value_lines(columns, board, agent, count, recorder.docs)
    return lines


def panel_rows(recorder: Recorder, row: int, agent: int = 0) -> list[tuple[str, str]]:
    """The panel of record ``row`` for agent ``agent`` as (label, value) lines."""
    return [(line.label, line.value(row)) for line in panel_lines(recorder, agent)]


def _leaf_line(recorder: Recorder, agent: int) -> PanelLine:
    """The active leaf's name, on its own line."""
    assert recorder.behaviour is not None
    codes, nodes = recorder.behaviour[:, agent], recorder.nodes

    def leaf(row: int) -> str:
        code = int(codes[row])
        return nodes[code].name if code >= 0 else NO_LEAF

    seen = np.unique(codes[: recorder.count]).tolist()
    return PanelLine("", leaf, max(len(nodes[c].name) if c >= 0 else len(NO_LEAF) for c in seen))


def _value_lines(
    columns: Mapping[str, np.ndarray],
    keys: Sequence[str],
    agent: int,
    count: int,
    docs: Mapping[str, tuple[str, str]],
) -> list[PanelLine]:
    """Lines for ``keys``: ``x_K, y_K`` (or ``x, y``) pairs as one point, with ``z_K`` (or
    ``z``) where it is recorded too (a 3-D point); others alone. ``count``: the records."""
    lines: list[PanelLine] = []
    done: set[str] = set()
    for key in keys:
        if key in done:
            continue
        if key in ("x", "y") or key.startswith(("x_", "y_")):
            partner = ("y" if key[0] == "x" else "x") + key[1:]
            if partner in columns and partner in keys:
                xk, yk = (key, partner) if key[0] == "x" else (partner, key)
                zk = "z" + key[1:]
                point = [xk, yk, *([zk] if zk in columns and zk in keys else [])]
                done.update(point)
                stem = key[2:] if len(key) > 1 else "position"
                label = _label(stem.removesuffix("_position") or "position", docs.get(xk))
                lines.append(_values_line(label, [columns[k][:, agent] for k in point], count))
                continue
        lines.append(_values_line(_label(key, docs.get(key)), [columns[key][:, agent]], count))
    return lines


def _values_line(label: str, axes: list[np.ndarray], count: int) -> PanelLine:
    """One value, or a point ``(x, y)`` or ``(x, y, z)``, of the columns ``axes`` (records,)
    each."""
    if len(axes) == 1:
        return PanelLine(label, lambda row: _number(axes[0][row]), _widest(axes[0][:count]))

    def point(row: int) -> str:
        return "(" + ", ".join(_number(a[row]) for a in axes) + ")"

    return PanelLine(label, point, 2 * len(axes) + sum(_widest(a[:count]) for a in axes))


def _number(value: np.generic) -> str:
    """An integer as it is, any other number with two decimals."""
    if isinstance(value, np.integer):
        return f"{int(value)}"
    return f"{float(value):.2f}"


def _widest(values: np.ndarray) -> int:
    """The most characters :func:`_number` writes for any of ``values``: the text grows with
    the magnitude on either side of zero, so the largest and the smallest bound it (and
    "nan", "inf", "-inf" where there are such)."""
    finite = values[np.isfinite(values)] if values.dtype.kind == "f" else values
    widths = [len(_number(v)) for v in (finite.max(), finite.min())] if finite.size else [0]
    return max(widths + ([4] if finite.size < values.size else []))


def _label(key: str, doc: tuple[str, str] | None) -> str:
    """``"  speed [u/it]"``: the key in words, with its short unit."""
    words = LABELS.get(key, key.replace("_", " "))
    unit = UNITS.get(doc[0], doc[0]) if doc else ""
    return f"  {words}" + (f" [{unit}]" if unit and key not in LABELS else "")
