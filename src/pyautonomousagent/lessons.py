"""Helpers for the lesson notebooks (notebooks/NN_*.ipynb): :func:`tick_table`, every node's
status per tick as a coloured table, and :func:`check_exercise`, the check cell at the end of
each lesson, which works the answer out itself (the notebook holds no answer).
"""

from __future__ import annotations

import bisect
import difflib
import html
import inspect
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.status import CODES, COLOURS, NAMES
from pyautonomousagent.inputs import shown

__all__ = [
    "CHECKS",
    "EmbeddedReplay",
    "ExerciseError",
    "TickTable",
    "check_exercise",
    "embedded_replay",
    "tick_table",
]


def _pale(colour: str) -> str:
    """``colour`` (``#rrggbb``) a quarter strength over white, as a ``#rrggbb`` string."""
    channels = (int(colour[i : i + 2], 16) for i in (1, 3, 5))
    return "#" + "".join(f"{round(255 - (255 - c) / 4):02x}" for c in channels)


#: Background colours of the statuses (by name) in :class:`TickTable`'s HTML: the views'
#: colours (``bt/status.COLOURS``), pale enough to read the names on.
STATUS_COLOURS = {NAMES[code]: _pale(colour) for code, colour in COLOURS.items()}
CELL_STYLE = "text-align:center;padding:2px 8px"


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
                f'<td style="background:{STATUS_COLOURS[row[k]]};{CELL_STYLE}">{row[k]}</td>'
                for row in self.statuses
            )
            label = "&nbsp;" * 4 * depth + html.escape(name)
            rows.append(f'<tr><td style="text-align:left;font-family:monospace">{label}</td>'
                        f"{cells}</tr>")  # fmt: skip
        return (
            '<table class="pyaa-tick-table"><thead><tr><th>node</th>'
            f"{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
        )


@dataclass(frozen=True, repr=False)
class EmbeddedReplay:
    """A replay page (``replay.html``, :func:`~pyautonomousagent.render.replay.write_replay`)
    shown in a notebook: as wide as the notebook's (or the documentation site's) content,
    most of the window high, with a button that opens it full page in a tab of its own.

    Attributes:
        name: the page's file name (the frame's title).
        page: the page's HTML, self-contained.
    """

    name: str
    page: str

    def __repr__(self) -> str:
        """What a plain-text front end shows (not the page)."""
        return f"{self.name}: a replay of {len(self.page) // 1000} kB (open it in a browser)"

    def _repr_html_(self) -> str:
        title = html.escape(f"replay {self.name}")
        return (
            f'<div class="pyaa-replay"><iframe title="{title}" srcdoc="{html.escape(self.page)}"'
            f' style="{REPLAY_FRAME_STYLE}"></iframe>'
            f'<button type="button" onclick="{html.escape(OPEN_FULL_PAGE)}">'
            "Open the replay full page</button></div>"
        )


#: The embedded replay's frame: the content's width, most of the window's height (the replay
#: lays itself out in the frame's height).
REPLAY_FRAME_STYLE = (
    "display:block;width:100%;height:85vh;min-height:600px;max-height:1000px;"
    "border:1px solid #ccc;margin-bottom:4px"
)
#: The button's script: the frame's page in a new tab (a blob: address of its HTML).
#: ``window.URL``: in an inline handler a bare ``URL`` is the document's address.
OPEN_FULL_PAGE = (
    "const page = this.parentElement.querySelector('iframe').srcdoc;"
    "window.open(window.URL.createObjectURL(new Blob([page], {type: 'text/html'})), '_blank');"
)


def embedded_replay(path: str | Path) -> EmbeddedReplay:
    """The replay page at ``path`` for a notebook to show (the cell's last expression)."""
    path = Path(path)
    return EmbeddedReplay(path.name, path.read_text(encoding="utf-8"))


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
    try:
        return [[CODES[s.upper()]] for s in statuses]
    except KeyError as error:
        raise ValueError(
            f"unknown status {error.args[0]!r}; use SUCCESS, FAILURE or RUNNING"
        ) from None


def check_exercise(lesson: str | int, **answers: Any) -> None:
    """Check a lesson's exercise: print a friendly verdict, or raise :class:`ExerciseError`
    with a hint.

    Args:
        lesson: the lesson's number (``2`` or ``"02"``).
        answers: the lesson's answer variables by name, as its exercise cell asks.

    Raises:
        ExerciseError: an answer is missing, of the wrong kind (a word where a number is
            due, ...) or wrong; or there is no such lesson or answer name. Its message is
            the hint; a notebook shows no traceback.
    """
    number = _lesson_number(lesson)
    check = CHECKS[number]
    known = list(inspect.signature(check).parameters)
    for name in answers:
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1)
            hint = f" (did you mean `{close[0]}`?)" if close else ""
            raise ExerciseError(f"Lesson {number}'s check has no answer `{name}`{hint}; give "
                                f"{', '.join(f'{k}=...' for k in known)}.")  # fmt: skip
    print(f"\u2714 Well done! {check(**answers)}")


def _lesson_number(lesson: Any) -> str:
    """``lesson`` as a key of :data:`CHECKS` ("02"), or ExerciseError naming the lessons."""
    text = str(lesson).strip() if isinstance(lesson, int | str) else ""
    number = f"{int(text):02d}" if text.isascii() and text.isdigit() else ""
    if isinstance(lesson, bool) or number not in CHECKS:
        raise ExerciseError(f"There is no exercise for lesson {shown(lesson)}: give a lesson's "
                            f"number, one of {', '.join(sorted(CHECKS))}.")  # fmt: skip
    return number


def _given(name: str, value: Any, what: str) -> Any:
    """``value``, or ExerciseError if the student left it as None / ``...``."""
    if value is None or value is Ellipsis:
        raise ExerciseError(f"Not answered yet: set `{name}` to {what} in the exercise cell, "
                            "run it, then run this cell again.")  # fmt: skip
    return value


def _number(name: str, value: Any, what: str) -> float:
    """``value`` as a float, or ExerciseError if it is missing, a word or no number."""
    value = _given(name, value, what)
    number: float | None = None
    if not isinstance(value, bool | str | bytes):
        try:
            number = float(value)
        except (TypeError, ValueError, OverflowError):
            number = None
    if number is None:
        raise ExerciseError(f"`{name}` should be {what}, got {shown(value)}.")
    return number


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


def _check_02(root_statuses: Any = None) -> str:
    ticks = len(L02_SCRIPTS["door_open"])
    got = _status_list("root_statuses", root_statuses, ticks)
    expected = tick_table(l02_tree(), ticks).column("enter_room")
    wrong = next((i for i, (a, b) in enumerate(zip(got, expected, strict=True)) if a != b), None)
    if wrong is not None:
        raise ExerciseError(
            f"Not quite: the root's status after tick {wrong + 1} is not {got[wrong]}.\n"
            "Hint: work tick by tick. A fallback stops at its first child that does not fail;"
            "\na reactive sequence starts again from its first child on every tick."
        )
    return f"The root's statuses over {ticks} ticks are {', '.join(got)}."


# --- Lesson 06: experiments -----------------------------------------------------------------


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
    best = _number("best", best, "the energy_use value with the lowest mean minimum energy")
    if not np.isclose(best, expected):
        raise ExerciseError(f"Not quite: energy_use = {best} does not have the lowest mean "
                            "minimum energy in your table.\nHint: group the rows by energy_use "
                            "and average minimum_energy over the seeds.")  # fmt: skip
    return (f"{len(rows)} runs; the lowest mean minimum energy, {means[expected]:.1f} %, "
            f"is at energy_use = {expected}.")  # fmt: skip


# --- Lesson 01: one drone -------------------------------------------------------------------


def _coordinates(name: str, value: Any, length: int) -> np.ndarray:
    """``value`` as ``length`` finite numbers, or ExerciseError."""
    value = _given(name, value, f"{length} numbers")
    try:
        numbers = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError, OverflowError):
        raise ExerciseError(f"`{name}` should be {length} numbers, got {shown(value)}.") from None
    if numbers.size != length or not np.isfinite(numbers).all():
        raise ExerciseError(f"`{name}` should be {length} finite numbers, got {value!r}.")
    return numbers


def _check_01(position: Any = None) -> str:
    from pyautonomousagent.models.drone2d import DroneParameters, advance

    got = _coordinates("position", position, 2)
    x, y, v, a = (np.array([value]) for value in (50.0, 50.0, 0.0, 0.0))
    for _ in range(180):
        x, y, v, a = advance(x, y, v, a, np.array([0.01]), np.array([2.0]), DroneParameters())
    expected = np.array([x[0], y[0]])
    if not np.allclose(got, expected, atol=1e-6):
        off = float(np.hypot(*(got - expected)))
        raise ExerciseError(
            f"Not quite: ({got[0]:.4f}, {got[1]:.4f}) is {off:.3g} units from where the drone "
            "is.\nHint: start at rest, heading 0; apply u_v = 0.01 and u_a = 2 on all 180 "
            "iterations; advance keeps the speed at most max_speed (0.1)."
        )
    return f"After 180 iterations the drone is at ({got[0]:.4f}, {got[1]:.4f})."


# --- Lesson 03: the blackboard and the datalink ---------------------------------------------


def gathering_order_receivers(datalink_range: float) -> list[str]:
    """Names of the drones that receive drone1's gathering order (iteration 5000 of the
    gathering scenario, seed 0) when the datalink's range is ``datalink_range``."""
    from pyautonomousagent.scenarios import load
    from pyautonomousagent.simulation.run import Simulation

    scenario = load("gathering").with_overrides(datalink_range=datalink_range)
    sim = Simulation.create(scenario, seed=0)
    while sim.world.iteration < scenario.parameters.gathering_iteration:
        sim.step()
    receivers = [
        i for d in sim.inbox if d.messages.type == "gathering" for i in d.pairs(sim.swarm.size)[0]
    ]
    return [sim.swarm.names[int(i)] for i in receivers]


def _check_03(heard: Any = None) -> str:
    heard = _given("heard", heard, "a list of drone names, e.g. ['drone2']")
    if isinstance(heard, str) or not isinstance(heard, Sequence):
        raise ExerciseError(f"`heard` should be a list of drone names, got {heard!r}.")
    names = [str(h) for h in heard]
    known = {"drone1", "drone2", "drone3", "drone4"}
    if not set(names) <= known:
        wrong = sorted(set(names) - known)[0]
        raise ExerciseError(
            f"{wrong!r} is not a drone of the gathering scenario ({sorted(known)})."
        )
    expected = gathering_order_receivers(25.0)
    if sorted(names) != sorted(expected):
        raise ExerciseError(
            f"Not quite: at range 25 the gathering order does not reach exactly {names}.\n"
            "Hint: step to iteration 5000 (`while sim.world.iteration < 5000: sim.step()`), "
            "then look at the 'gathering' delivery in `sim.inbox`; the sender never receives "
            "its own message."
        )
    return f"At range 25 the gathering order reaches {', '.join(sorted(names)) or 'no one'}."


# --- Lesson 05: tree files ------------------------------------------------------------------


def _gathering_tree_with(ports: dict[str, dict[str, float]]) -> Node:
    """The gathering tree (Fig. 6) with ``ports`` set: node name or type -> port values."""
    from dataclasses import replace

    from pyautonomousagent.missions.drones.trees import gathering_tree

    def edited(node: Node) -> Node:
        extra = ports.get(node.name, ports.get(node.type, {}))
        return replace(node, params={**node.params, **extra},
                       children=tuple(edited(child) for child in node.children))  # fmt: skip

    return edited(gathering_tree())


def l05_expected_tree() -> Node:
    """Lesson 05's answer: the gathering tree with the last branch cruising at 0.05."""
    return _gathering_tree_with({"action_navigate_to_destination_a_2": {"speed": 0.05}})


def _tree_file(
    value: Any, what: str, example: str, suffixes: tuple[str, ...], how: str, where: str
) -> Path:
    """The tree file a student named (``tree_file``), or ExerciseError: no name, a name not
    ending in one of ``suffixes`` (``how`` to make one), or no such file (``where`` it comes
    from)."""
    given = _given("tree_file", value, f"the name of {what}")
    if not isinstance(given, str | os.PathLike) or not str(given).strip():
        raise ExerciseError(f"`tree_file` should be the name of {what}, like {example!r}, got "
                            f"{shown(given)}.")  # fmt: skip
    path = Path(given)
    if path.suffix not in suffixes:
        raise ExerciseError(f"{path} is not {how}.")
    if not path.is_file():
        raise ExerciseError(f"There is no file {path} here: {where}.")
    return path


def _load_tree(path: Path) -> Node:
    """The tree of the student's file, or ExerciseError with the file's mistake."""
    from pyautonomousagent.bt.files import load_tree

    try:
        return load_tree(path)
    except Exception as error:  # the file's mistake, in its own words
        raise ExerciseError(f"Your file does not load: {error}") from None


def _check_05(tree_file: Any = None) -> str:
    path = _tree_file(tree_file, "your YAML tree file", "slow.yaml", (".yaml", ".yml"),
                      "a YAML file: save your tree as slow.yaml",
                      "write it first (Path.write_text)")  # fmt: skip
    keys = ("x", "y", "speed", "energy")
    got, expected = (_flight(t, 600, keys) for t in (_load_tree(path), l05_expected_tree()))
    for key, a, b in zip(keys, got, expected, strict=True):
        if not np.array_equal(a, b):
            raise ExerciseError(
                f"Not quite: with {path} the drones' {key} is not what it should be.\n"
                "Hint: only the last branch's Action_Navigate_To_Destination_A gets `speed: "
                "0.05`; the refuelling branch's navigate action keeps the scenario's speed."
            )
    return f"{path} makes the drones cruise at 0.05 units per iteration to their positions."


# --- Lesson 07: swarms at scale -------------------------------------------------------------


def smallest_compiled_swarm(iterations: int) -> int:
    """The fewest agents for which the batched loop's estimate reaches the seconds from which
    engine "auto" compiles (:data:`~pyautonomousagent.simulation.costs.AUTO_COMPILE_SECONDS`)."""
    from pyautonomousagent.simulation.costs import AUTO_COMPILE_SECONDS, batched_seconds

    def worth_it(agents: int) -> bool:
        return batched_seconds(agents, iterations) >= AUTO_COMPILE_SECONDS

    return 1 + bisect.bisect_left(range(1, 10**12), True, key=worth_it)


def _check_07(agents: Any = None) -> str:
    got = _number("agents", agents, "a whole number of drones")
    if not got.is_integer():
        raise ExerciseError(f"`agents` should be a whole number of drones, got {agents!r}.")
    expected = smallest_compiled_swarm(4000)
    if int(got) != expected:
        where = (
            "the estimate is still below AUTO_COMPILE_SECONDS"
            if got < expected
            else "that is more than needed: fewer drones already reach AUTO_COMPILE_SECONDS"
        )
        raise ExerciseError(
            f"Not quite: with {int(got):,d} drones {where}.\nHint: batched_seconds(agents, 4000)"
            " is 4000 * (a + agents * b); find the first whole number of agents where it is >= "
            "AUTO_COMPILE_SECONDS."
        )
    return f"From {expected:,d} drones a 4000-iteration run is worth compiling."


# --- Lesson 04: your own mission ------------------------------------------------------------


def _check_04(leaf_type: Any = None, scenario: Any = None) -> str:
    from pyautonomousagent.bt.leaf import LEAF_TYPES, Leaf
    from pyautonomousagent.bt.spec import inverter, leaf, reactive_sequence
    from pyautonomousagent.bt.status import FAILURE, SUCCESS
    from pyautonomousagent.simulation.run import Simulation
    from pyautonomousagent.simulation.scenario import Scenario
    from pyautonomousagent.testing import check_leaf

    name = "Condition_Shelter_Near"
    leaf_type = _given("ConditionShelterNear", leaf_type, "your leaf class")
    if not (isinstance(leaf_type, type) and issubclass(leaf_type, Leaf)):
        raise ExerciseError(f"`ConditionShelterNear` should be a class derived from Leaf, "
                            f"got {leaf_type!r}.")  # fmt: skip
    if getattr(leaf_type, "type_name", None) != name:
        raise ExerciseError(f"Give your leaf `type_name = {name!r}`.")
    if LEAF_TYPES.get(name) is not leaf_type:
        raise ExerciseError("Your leaf is not registered: put `@register_leaf` above the class.")
    scenario = _given("scenario", scenario, "the lesson's scenario")
    if not isinstance(scenario, Scenario):
        kind = type(scenario).__name__
        raise ExerciseError(f"`scenario` should be the lesson's Scenario (load(...) of its "
                            f"scenario file), got {kind} {shown(scenario)}.")  # fmt: skip
    distance = 30.0
    probe = reactive_sequence(
        "probe_tree",
        inverter("not_near", leaf(name, "probe", distance=distance)),
        leaf("Action_Navigate_To_Destination_A"),
    )
    try:
        sim = Simulation.create(scenario.with_overrides(iterations=700), tree=probe,
                                engine="pytrees")  # fmt: skip
        row = [node.name for node in probe.walk()].index("probe")
        for _ in range(700):
            sim.step()
            got = sim.engine.node_statuses()[row]
            near = sim.swarm.columns["shelter_distance"] <= distance
            if not np.array_equal(got, np.where(near, SUCCESS, FAILURE)):
                agent = int(np.flatnonzero(got != np.where(near, SUCCESS, FAILURE))[0])
                d = float(sim.swarm.columns["shelter_distance"][agent])
                raise ExerciseError(
                    f"Not quite: at iteration {sim.world.iteration}, {sim.swarm.names[agent]}'s "
                    f"nearest shelter is {d:.2f} units away and the port distance is {distance}, "
                    f"but your leaf returned {NAMES[int(got[agent])]}.\nHint: "
                    "success_if(agents.shelter_distance <= self.distance)."
                )
        check_leaf(leaf_type, scenario, agents=6, iterations=40, distance=distance)
    except ExerciseError:
        raise
    except Exception as error:  # the leaf's own mistake, in one line
        first = str(error).splitlines()[0] if str(error) else ""
        raise ExerciseError(f"Your leaf fails when ticked: {type(error).__name__}: {first}\n"
                            "Hint: use only array expressions and success_if, no `if` on a "
                            "drone's value.") from None  # fmt: skip
    return f"{name} is right for every drone and tick, and both engines agree on it."


# --- Lesson 08: the Skywalker X8 ------------------------------------------------------------


def x8_climb_time(altitude: float, within: float = 1.0, iterations: int = 3000) -> float:
    """Seconds from launch until one X8 of scenario x8-patrol (seed 0, batched engine) sent to
    ``altitude`` metres is first within ``within`` metres of it (NaN if never)."""
    from pyautonomousagent.scenarios import load
    from pyautonomousagent.simulation.run import Simulation
    from pyautonomousagent.simulation.scenario import to_mapping

    base = load("x8-patrol")
    scenario = base.with_overrides(
        agents=1, iterations=iterations, x8={**to_mapping(base)["x8"], "altitude": altitude}
    )
    run = Simulation.create(scenario, seed=0).run(progress=False)
    heights = run.recorder.column("altitude")[:, 0]
    close = np.flatnonzero(np.abs(heights - altitude) <= within)
    if close.size == 0:
        return float("nan")
    return float(run.recorder.iterations[close[0]] * 0.01)


def _check_08(climb_time: Any = None) -> str:
    seconds = _number("climb_time", climb_time, "a number of seconds")
    expected = x8_climb_time(60.0)
    if not abs(seconds - expected) < 0.005:
        hint = "later" if seconds < expected else "earlier"
        raise ExerciseError(
            f"Not quite: the X8 is not first within 1 m of 60 m at {seconds:g} s (it is {hint}).\n"
            "Hint: seconds_flown, altitude = fly(altitude=60); then the first seconds_flown "
            "where abs(altitude - 60) <= 1 (np.argmax of that condition)."
        )
    return f"The X8 first comes within 1 m of 60 m after {expected:.2f} s."


# --- Lesson 09: blocks in the studio --------------------------------------------------------

#: Lesson 09's exercise: the refuelling threshold (percent) and rate (percent per iteration).
L09_THRESHOLD, L09_RATE = 60.0, 5.0


def l09_expected_tree(threshold: float = L09_THRESHOLD, rate: float = L09_RATE) -> Node:
    """The gathering tree (Fig. 6) with ``Condition_Low_Energy_Level``'s threshold (percent)
    and ``Action_Refuel_A``'s rate (percent per iteration) set."""
    return _gathering_tree_with({"Condition_Low_Energy_Level": {"threshold": threshold},
                                 "Action_Refuel_A": {"rate": rate}})  # fmt: skip


def _flight(
    tree: Node, iterations: int = 3000, keys: Sequence[str] = ("x", "y", "energy")
) -> list[np.ndarray]:
    """``keys`` of the gathering scenario's drones (seed 0, ``iterations`` iterations) flying
    ``tree``: arrays of shape (records, agents)."""
    from pyautonomousagent.scenarios import load
    from pyautonomousagent.simulation.run import Simulation

    scenario = load("gathering").with_overrides(iterations=iterations)
    recorder = Simulation.create(scenario, seed=0, tree=tree).run(progress=False).recorder
    return [recorder.column(key) for key in keys]


def _same_flight(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return all(np.array_equal(u, v) for u, v in zip(a, b, strict=True))


def _check_09(tree_file: Any = None) -> str:
    path = _tree_file(tree_file, "the XML file you saved from the studio", "refuel-early.xml",
                      (".xml",), "an XML file: press Save XML in the studio, and give the name it "
                      "wrote (NAME.xml)", "type a name in the studio's name box and press Save "
                      "XML (it writes NAME.xml next to this notebook)")  # fmt: skip
    got = _flight(_load_tree(path))
    if _same_flight(got, _flight(l09_expected_tree())):
        return (f"{path} makes the drones refuel at {L09_THRESHOLD:g} %, {L09_RATE:g} % per "
                "iteration.")  # fmt: skip
    raise ExerciseError(_l09_hint(path, got))


def _l09_hint(path: Path, got: list[np.ndarray]) -> str:
    """What is wrong with the tree that flew ``got``: one of the two fields, both, or more."""
    from pyautonomousagent.scenarios import load

    params = load("gathering").parameters
    scenario_values = (float(params.low_energy_threshold), float(params.refuel_rate))
    cases = (
        ((L09_THRESHOLD, scenario_values[1]), f"the refuel rate is not {L09_RATE:g}"),
        ((scenario_values[0], L09_RATE), f"the threshold is not {L09_THRESHOLD:g}"),
        (scenario_values, "the drones fly as with the scenario's own tree: neither field is set"),
    )
    for (threshold, rate), what in cases:
        if _same_flight(got, _flight(l09_expected_tree(threshold, rate))):
            return (f"Not quite: with {path} {what}.\nHint: type {L09_THRESHOLD:g} in "
                    f"Condition_Low_Energy_Level's threshold field and {L09_RATE:g} in "
                    "Action_Refuel_A's rate field, then press Save XML again.")  # fmt: skip
    return (f"Not quite: with {path} the drones do not fly as they should.\nHint: start from "
            "the gathering tree (Fig. 6: Scenario's tree, or your fig6 blocks) and change only "
            f"those two fields: threshold {L09_THRESHOLD:g}, rate {L09_RATE:g}.")  # fmt: skip


#: Lesson number -> its check: takes the answers, returns the verdict's text, raises
#: ExerciseError when an answer is missing or wrong.
CHECKS: dict[str, Callable[..., str]] = {
    "01": _check_01,
    "02": _check_02,
    "03": _check_03,
    "04": _check_04,
    "05": _check_05,
    "06": _check_06,
    "07": _check_07,
    "08": _check_08,
    "09": _check_09,
}
