"""Helpers for the lesson notebooks (notebooks/NN_*.ipynb): tick tables and exercise checks.

- :func:`tick_table`: tick a small tree a few times and show every node's status per tick,
  as a coloured table in a notebook (plain text elsewhere);
- :func:`check_exercise`: the check cell at the end of each lesson. It works the answer out
  itself (the answer is not in the notebook), prints a friendly verdict, and raises
  :class:`ExerciseError` with a hint when the answer is missing or wrong.

Both are also importable from :mod:`pyautonomousagent.testing`.
"""

from __future__ import annotations

import html
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.status import NAMES

__all__ = ["ExerciseError", "TickTable", "check_exercise", "tick_table", "CHECKS"]

#: Background colours of the statuses in :class:`TickTable`'s HTML (as in the replay).
STATUS_COLOURS = {
    "SUCCESS": "#c8e6c9",
    "FAILURE": "#ffcdd2",
    "RUNNING": "#fff3c4",
    "INVALID": "#eeeeee",
}


class ExerciseError(AssertionError):
    """A missing or wrong exercise answer; a notebook shows only its message (no traceback)."""

    def _render_traceback_(self) -> list[str]:
        """What IPython prints instead of a traceback."""
        return [f"\u2718 {line}" if i == 0 else f"  {line}" for i, line in
                enumerate(str(self).splitlines())]  # fmt: skip


@dataclass(frozen=True)
class TickTable:
    """Node statuses per tick of one agent.

    Attributes:
        names: node names in tick order (depth first), length K.
        depths: each node's depth in the tree (0 for the root), length K.
        statuses: status names, shape (ticks, K), e.g. ``statuses[0][0]`` is the root's
            status after tick 1.
    """

    names: tuple[str, ...]
    depths: tuple[int, ...]
    statuses: tuple[tuple[str, ...], ...]

    def column(self, name: str) -> list[str]:
        """One node's status after each tick."""
        k = self.names.index(name)
        return [row[k] for row in self.statuses]

    def __str__(self) -> str:
        width = max(len("  " * d + n) for n, d in zip(self.names, self.depths, strict=True))
        ticks = range(1, len(self.statuses) + 1)
        lines = [" " * width + "".join(f"  tick {t:<3d}" for t in ticks)]
        for k, (name, depth) in enumerate(zip(self.names, self.depths, strict=True)):
            cells = "".join(f"  {row[k]:<8s}" for row in self.statuses)
            lines.append(f"{'  ' * depth + name:<{width}s}{cells}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        head = "".join(f"<th>tick {t}</th>" for t in range(1, len(self.statuses) + 1))
        rows = []
        for k, (name, depth) in enumerate(zip(self.names, self.depths, strict=True)):
            cells = "".join(
                f'<td style="background:{STATUS_COLOURS[row[k]]};text-align:center">{row[k]}</td>'
                for row in self.statuses
            )
            label = "&nbsp;" * 4 * depth + html.escape(name)
            rows.append(f'<tr><td style="text-align:left;font-family:monospace">{label}</td>'
                        f"{cells}</tr>")  # fmt: skip
        return (
            '<table class="pyaa-tick-table"><thead><tr><th>node</th>'
            f"{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
        )


def tick_table(tree: Node, ticks: int, engine: str = "pytrees") -> TickTable:
    """Tick ``tree`` ``ticks`` times for one agent (no motion, only the tree) and return every
    node's status after each tick. Leaves of the scenario gathering's mission may be used, and
    the ``Scripted`` leaf, whose ``statuses`` give its status per tick."""
    from pyautonomousagent.testing import make_harness

    harness = make_harness(tree, agents=1, engine=engine)
    rows = [tuple(NAMES[int(code)] for code in harness.tick()[:, 0]) for _ in range(ticks)]
    return TickTable(tuple(harness.names()), tuple(_depths(tree)), tuple(rows))


def _depths(node: Node, depth: int = 0) -> list[int]:
    return [depth] + [d for child in node.children for d in _depths(child, depth + 1)]


def scripted(*statuses: str) -> list[list[int]]:
    """A ``Scripted`` leaf's ``statuses`` port for one agent from status names, e.g.
    ``scripted("RUNNING", "SUCCESS")`` -> ``[[3], [1]]``."""
    codes = {name: code for code, name in NAMES.items()}
    try:
        return [[codes[s.upper()]] for s in statuses]
    except KeyError as error:
        raise ValueError(
            f"unknown status {error.args[0]!r}; use SUCCESS, FAILURE or RUNNING"
        ) from None


#: Lesson number ("01".."08") -> its check: takes the answers, returns the verdict's text,
#: raises ExerciseError when an answer is missing or wrong.
CHECKS: dict[str, Callable[..., str]] = {}


def _lesson(number: str) -> Callable[[Callable[..., str]], Callable[..., str]]:
    def add(check: Callable[..., str]) -> Callable[..., str]:
        CHECKS[number] = check
        return check

    return add


def check_exercise(lesson: str | int, **answers: Any) -> None:
    """Check a lesson's exercise: print a friendly verdict, or raise :class:`ExerciseError`
    with a hint.

    Args:
        lesson: the lesson's number (``2`` or ``"02"``).
        answers: the lesson's answer variables by name, as its exercise cell asks.
    """
    number = f"{int(lesson):02d}"
    if number not in CHECKS:
        raise ValueError(f"no exercise for lesson {lesson!r}; lessons are {sorted(CHECKS)}")
    print(f"\u2714 Well done! {CHECKS[number](**answers)}")


def _given(name: str, value: Any, what: str) -> Any:
    """``value``, or ExerciseError if the student left it as None / ``...``."""
    if value is None or value is Ellipsis:
        raise ExerciseError(f"Not answered yet: set `{name}` to {what} in the exercise cell, "
                            "run it, then run this cell again.")  # fmt: skip
    return value


def _status_list(name: str, value: Any, length: int) -> list[str]:
    """A list of ``length`` status names (any case), or ExerciseError."""
    value = _given(name, value, f"a list of {length} statuses")
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ExerciseError(f"`{name}` should be a list of {length} statuses, "
                            f"like ['RUNNING', 'SUCCESS', ...]; got {value!r}.")  # fmt: skip
    names = [str(getattr(v, "name", v)).upper() for v in value]
    unknown = [v for v in names if v not in ("SUCCESS", "FAILURE", "RUNNING", "INVALID")]
    if unknown:
        raise ExerciseError(f"{unknown[0]!r} is not a status: use SUCCESS, FAILURE, RUNNING "
                            "(or INVALID for a node that was not ticked).")  # fmt: skip
    if len(names) != length:
        raise ExerciseError(f"`{name}` has {len(names)} statuses; give one per tick ({length}).")
    return names


def _first_wrong(got: Sequence[Any], expected: Sequence[Any]) -> int | None:
    for i, (a, b) in enumerate(zip(got, expected, strict=True)):
        if a != b:
            return i
    return None


# --- Lesson 02: behaviour trees -------------------------------------------------------------

#: Lesson 02's exercise: the statuses of the three leaves, one row per tick.
L02_SCRIPTS = {
    "door_open": ("FAILURE", "FAILURE", "SUCCESS", "SUCCESS", "FAILURE"),
    "open_door": ("RUNNING", "SUCCESS", "SUCCESS", "SUCCESS", "RUNNING"),
    "walk_through": ("RUNNING", "RUNNING", "RUNNING", "SUCCESS", "SUCCESS"),
}


def l02_tree() -> Node:
    """Lesson 02's exercise tree: R→( ?(door_open, open_door), walk_through )."""
    from pyautonomousagent.bt.spec import fallback, leaf, reactive_sequence

    def scripted_leaf(name: str) -> Node:
        return leaf("Scripted", name, statuses=scripted(*L02_SCRIPTS[name]))

    return reactive_sequence(
        "enter_room",
        fallback("door", scripted_leaf("door_open"), scripted_leaf("open_door")),
        scripted_leaf("walk_through"),
    )


@_lesson("02")
def _check_02(root_statuses: Any = None) -> str:
    ticks = len(L02_SCRIPTS["door_open"])
    got = _status_list("root_statuses", root_statuses, ticks)
    expected = tick_table(l02_tree(), ticks).column("enter_room")
    wrong = _first_wrong(got, expected)
    if wrong is not None:
        raise ExerciseError(
            f"Not quite: the root's status after tick {wrong + 1} is not {got[wrong]}.\n"
            "Hint: work tick by tick. A fallback stops at its first child that does not fail;"
            "\na reactive sequence starts again from its first child on every tick."
        )
    return f"The root's statuses over {ticks} ticks are {', '.join(got)}."


# --- Lesson 06: experiments -----------------------------------------------------------------


@_lesson("06")
def _check_06(table: Any = None, best: Any = None) -> str:
    import pyarrow as pa

    table = _given("table", table, "the results table of your sweep (`result.table`)")
    if not isinstance(table, pa.Table):
        raise ExerciseError(f"`table` should be a sweep's results table (`result.table`), "
                            f"got {type(table).__name__}.")  # fmt: skip
    needed = {"energy_use", "seed", "minimum_energy", "status"}
    missing = sorted(needed - set(table.column_names))
    if missing:
        raise ExerciseError(f"Your sweep's table has no column {missing[0]!r}: vary "
                            "energy_use and measure minimum_energy.")  # fmt: skip
    rows = table.to_pylist()
    values = sorted({r["energy_use"] for r in rows})
    seeds = {v: {r["seed"] for r in rows if r["energy_use"] == v} for v in values}
    if len(values) < 3 or any(len(s) < 3 for s in seeds.values()):
        raise ExerciseError("Vary energy_use over at least 3 values, with at least 3 seeds each.")
    if any(r["status"] != "ok" for r in rows):
        raise ExerciseError("Some runs failed: look at the table's `error` column.")
    means = {v: float(np.mean([r["minimum_energy"] for r in rows if r["energy_use"] == v]))
             for v in values}  # fmt: skip
    expected = min(means, key=lambda v: means[v])
    best = _given("best", best, "the energy_use value with the lowest mean minimum energy")
    if not np.isclose(float(best), expected):
        raise ExerciseError(f"Not quite: energy_use = {best} does not have the lowest mean "
                            "minimum energy in your table.\nHint: group the rows by energy_use "
                            "and average minimum_energy over the seeds.")  # fmt: skip
    return (f"{len(rows)} runs; the lowest mean minimum energy, {means[expected]:.1f} %, "
            f"is at energy_use = {expected}.")  # fmt: skip
