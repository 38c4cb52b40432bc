"""Today's missions' marks and events, until the missions supply their own.

The animation and the replay draw a ``list[Mark]`` and a list of events given to them; they
know nothing of refuelling or surveillance. This module is the one place that derives the
paper's marks (refuelling slots R1.., surveillance or patrol positions S1.., active radiation
sources) from a recorded run and its scenario. When missions become plug-ins, their
``marks(...)`` replaces :func:`default_marks`.
"""

from __future__ import annotations

from collections.abc import Iterable

from pyautonomousagent.recording import Recorder
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation.scenario import Point, Scenario

SLOT_COLOUR = "#9ecae1"
"""Light blue of the refuelling slots."""
SLOT_RADIUS = 0.0375
"""A refuelling slot's radius as a fraction of the world's larger side."""
SURVEILLANCE_COLOUR = "#222222"
"""Black of the surveillance-position crosses."""
RADIATION_COLOUR = "#fdae6b"
"""Orange of an active radiation source's range."""


def default_marks(recorder: Recorder, scenario: Scenario) -> list[Mark]:
    """The marks of the paper's Fig. 5: slots R1.., surveillance positions S1.., and the range
    of each active radiation source (world units)."""
    slot = SLOT_RADIUS * max(scenario.world)
    marks = [
        Mark(
            "circle",
            x,
            y,
            f"R{i}",
            size=slot,
            colour=SLOT_COLOUR,
            fill=True,
            legend="refuelling slot",
        )
        for i, (x, y) in enumerate(refuelling_slots(recorder, scenario), start=1)
    ]
    marks += [
        Mark(
            "point",
            x,
            y,
            f"S{i}",
            size=7.0,
            colour=SURVEILLANCE_COLOUR,
            symbol="x",
            legend="patrol position" if scenario.patrol_positions else "surveillance position",
        )
        for i, (x, y) in enumerate(surveillance_marks(recorder, scenario), start=1)
    ]
    marks += [
        Mark(
            "circle",
            s.x,
            s.y,
            "radiation",
            size=s.range,
            colour=RADIATION_COLOUR,
            legend="radiation source range",
        )
        for s in scenario.radiation_sources
        if s.active
    ]
    return marks


def refuelling_slots(recorder: Recorder, scenario: Scenario) -> list[Point]:
    """Distinct refuelling slots (world units), in agent order, from the first record.

    Falls back to ``scenario.refueling_positions`` when the blackboard was not recorded.
    """
    return _distinct(_first_points(recorder, "refueling_position") or scenario.refueling_positions)


def surveillance_marks(recorder: Recorder, scenario: Scenario) -> list[Point]:
    """Distinct surveillance positions to mark (world units).

    Patrol scenarios: the two patrol positions. Otherwise each agent's initial surveillance
    position from the first record, or ``scenario.surveillance_positions`` if not recorded.
    """
    if scenario.patrol_positions:
        return _distinct(scenario.patrol_positions)
    recorded = _first_points(recorder, "surveillance_position")
    return _distinct(recorded or scenario.surveillance_positions)


def _first_points(recorder: Recorder, name: str) -> list[Point]:
    """The blackboard points ``x_<name>, y_<name>`` of every agent at row 0, or []."""
    keys = f"x_{name}", f"y_{name}"
    if recorder.count == 0 or not all(k in recorder.columns for k in keys):
        return []
    xs, ys = (recorder.columns[k][0] for k in keys)
    return [(float(x), float(y)) for x, y in zip(xs, ys, strict=True)]


def _distinct(points: Iterable[Point]) -> list[Point]:
    """``points`` without repeats, first occurrence first."""
    return list(dict.fromkeys((float(x), float(y)) for x, y in points))
