"""Radiation search: drones wander until one detects a radiation source, then all fly to it.

Drones (``drone1``, ``drone2``, ...; motion model ``drone2d``) start on their start positions
and wander: a new random heading every ``wander_period`` iterations (drawn with
:meth:`~pyautonomousagent.bt.Leaf.uniform`, so a seed gives the same flight on every engine),
turning back toward the centre near the world's edge. Each reads a radiation sensor; the
first to read more than ``radiation_threshold`` percent broadcasts a ``found`` message with
its position (a message type of this mission, recorded as an event) and stays there. A
drone that receives ``found`` (:meth:`RadiationSearchMission.store_reported_position`, in its
next Phase 2) stores the position on its blackboard and flies there; drones already knowing
a position keep theirs. The tree is ``radiation-search.xml``.

Written with the public API (:mod:`pyautonomousagent.mission`, :mod:`pyautonomousagent.bt`,
:mod:`pyautonomousagent.arrays`), two of the paper's drones' leaves
(:mod:`pyautonomousagent.missions.drones`), and, for the compiled engine, the
documented kernel API (:mod:`pyautonomousagent.kernels`, ``randomness.uniform_of_one`` and
``jit.njit``): every leaf has a ``kernel``, the sensor a ``compiled_sensors`` form and
``found`` a ``HandlerKernel`` (``kernels.py``), so the compiled engine runs whole iterations
fused (it stops after an iteration that sends ``found``, a recorded type, for Python to
deliver it and record the events). Its world objects, parameters, columns, blackboard keys
and marks are described where :class:`RadiationSearchMission` declares them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.arrays import hypot
from pyautonomousagent.kernels import HandlerKernel, Receive, SensorKernel
from pyautonomousagent.mission import (
    Delivery,
    Mark,
    MessageType,
    Mission,
    Param,
    Reader,
    ScenarioView,
    SimulationView,
    Swarm,
    World,
    WorldObject,
    check_point_in_world,
    register_mission,
)
from pyautonomousagent.missions.drones.mission import cycled
from pyautonomousagent.missions.radiation_search import leaves
from pyautonomousagent.missions.radiation_search.kernels import (
    radiation_reading,
    store_found_everyone,
    take_found,
)
from pyautonomousagent.missions.radiation_search.leaves import FOUND, REPORTED_ARRAYS

__all__ = ["FOUND", "RadiationSearchMission", "Source", "leaves", "radiation_level"]

SOURCE_COLOUR = "#ff7f00"
"""Orange of the radiation source."""
START_COLOUR = "#31a354"
"""Green of the start positions."""


@dataclass(frozen=True)
class Source:
    """A radiation source at (x, y) that irradiates within ``range`` world units."""

    x: float
    y: float
    range: float


def read_source(reader: Reader, data: Any, path: str) -> Source:
    """``{x, y, range}``, world units."""
    given = reader.keys(data, path, ["x", "y", "range"], ["x", "y", "range"])
    x, y = (reader.number(given[key], f"{path}.{key}") for key in "xy")
    return Source(x, y, reader.number(given["range"], f"{path}.range", above=0.0))


def radiation_level(x: np.ndarray, y: np.ndarray, source: Source) -> np.ndarray:
    """The level read at (x, y), shape (N,): ``100 (1 - d / range)`` percent within the range
    of the source (d: distance to it), 0 outside."""
    distance = hypot(x - source.x, y - source.y)
    return np.where(distance < source.range, 100.0 * (1.0 - distance / source.range), 0.0)


@register_mission
class RadiationSearchMission(Mission):
    """Wandering drones, a radiation sensor, and the ``found`` message."""

    name = "radiation-search"
    description = "drones wander until one detects radiation and calls the others to it"
    agent_prefix = "drone"
    parameters: ClassVar[tuple[Param, ...]] = (
        Param("search_speed", 0.4, "world units per iteration",
              "speed the wander and fly leaves request", minimum=0.0),
        Param("radiation_threshold", 50.0, "percent",
              "reading above which a drone reports the source", minimum=0.0, maximum=100.0),
        Param("wander_period", 40, "iterations", "iterations between new random headings",
              minimum=1),
        Param("edge_margin", 6.0, "world units",
              "nearer the world's edge than this, a wandering drone heads for the centre",
              minimum=0.0),
        Param("source_tolerance", 1.0, "world units",
              "distance at which the reported position counts as reached", minimum=0.0),
    )  # fmt: skip
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        WorldObject("radiation_source", read_source,
                    doc="the source {x, y, range}: level 100 (1 - d / range) % within range"),
        WorldObject("start_positions", Reader.points,
                    doc="start positions [x, y], used in turn by drones 1, 2, ... (cycled)"),
    )  # fmt: skip
    columns: ClassVar[dict[str, Any]] = {"radiation": np.float64}  # percent, [0, 100]
    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        "radiation": ("percent", "last radiation sensor reading, 0 to 100"),
        "source_reported": ("", "blackboard: 1 once a source position is known"),
        "x_reported_position": ("world unit", "blackboard: reported source position, east"),
        "y_reported_position": ("world unit", "blackboard: reported source position, north"),
    }

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """The source and the start positions lie in the world."""
        source = scenario.objects.radiation_source
        check_point_in_world(reader, scenario, (source.x, source.y), "world.radiation_source")
        for i, point in enumerate(scenario.objects.start_positions):
            check_point_in_world(reader, scenario, point, f"world.start_positions[{i}]")

    def blackboard(self) -> dict[str, Any]:
        """Whether a source position is known (0/1) and where."""
        return {
            "source_reported": np.int64,
            "x_reported_position": np.float64,
            "y_reported_position": np.float64,
        }

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """Drones on their start positions, at rest, knowing no source, with a first radiation
        reading."""
        start = cycled(self.scenario.objects.start_positions, swarm.size)
        s = swarm.columns
        s["x"][:], s["y"][:] = start[:, 0], start[:, 1]
        s["radiation"][:] = radiation_level(s["x"], s["y"], self.scenario.objects.radiation_source)

    def sense(self, sim: SimulationView) -> None:
        """Every drone reads the radiation level at its position; all of them move."""
        s = sim.swarm.columns
        s["radiation"][:] = radiation_level(s["x"], s["y"], self.scenario.objects.radiation_source)

    def compiled_sensors(self, sim: SimulationView) -> SensorKernel:
        """:meth:`sense` for one drone (``kernels.radiation_reading``)."""
        source = self.scenario.objects.radiation_source
        constants = (float(source.x), float(source.y), float(source.range))
        return SensorKernel(radiation_reading, ("x", "y", "radiation"), constants)

    def message_types(self) -> list[MessageType]:
        """``found`` (recorded): receivers store the reported position."""
        return [
            MessageType(FOUND, self.store_reported_position, recorded=True,
                        doc="x, y: where the sender detected the source",
                        kernel=HandlerKernel(store_found_everyone, ("x", "y"), REPORTED_ARRAYS,
                                             receive=Receive(take_found))),
        ]  # fmt: skip

    def store_reported_position(self, sim: SimulationView, delivery: Delivery) -> None:
        """A receiver that knows no position yet takes the first ``found`` it received (in
        canonical order: by sender); one that knows a position keeps it."""
        bb = sim.swarm.blackboard
        receivers, rows = delivery.pairs(sim.swarm.size)
        receivers, first = np.unique(receivers, return_index=True)
        rows = rows[first]
        new = bb["source_reported"][receivers] == 0
        receivers, rows = receivers[new], rows[new]
        bb["source_reported"][receivers] = 1
        bb["x_reported_position"][receivers] = delivery.messages.data["x"][rows]
        bb["y_reported_position"][receivers] = delivery.messages.data["y"][rows]

    def marks(self) -> list[Mark]:
        """The source's range (orange circle) and centre (star); the start positions (green
        squares, unlabelled: they are usually close together)."""
        source = self.scenario.objects.radiation_source
        marks = [
            Mark("circle", source.x, source.y, size=source.range, colour=SOURCE_COLOUR,
                 legend="radiation range"),
            Mark("point", source.x, source.y, "source", size=12, colour=SOURCE_COLOUR,
                 symbol="*", legend="radiation source"),
        ]  # fmt: skip
        for x, y in dict.fromkeys(self.scenario.objects.start_positions):
            marks.append(Mark("point", x, y, size=5, colour=START_COLOUR, symbol="s",
                              legend="start position"))  # fmt: skip
        return marks
