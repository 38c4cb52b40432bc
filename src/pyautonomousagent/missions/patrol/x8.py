"""The Skywalker X8's patrol with landing (scenario ``x8-patrol``): at low energy the UAV flies
an approach to its base's runway, lands, refuels on the ground and takes off again.

The mission declares the columns through which its leaves talk to the X8's autopilot
(:mod:`pyautonomousagent.models.x8_modes`): the requested mode and glide-path altitude, and
the phase the autopilot reports. The aircraft's side (flare, touchdown, roll-out, take-off
roll, rotation) is the model's; the approach's geometry (approach fix, glide path toward the
runway) is this mission's.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.arrays import bearing, choose, minimum
from pyautonomousagent.bt.leaf import Leaf, Port, register_leaf
from pyautonomousagent.bt.status import RUNNING, SUCCESS, status_if
from pyautonomousagent.kernels import LeafKernel
from pyautonomousagent.missions.drones.leaves import SPEED
from pyautonomousagent.missions.patrol import x8_kernels as k
from pyautonomousagent.missions.patrol.mission import PatrolMission
from pyautonomousagent.models.x8_modes import (
    ALTITUDE_COLUMN,
    CRUISE,
    FLIGHT,
    LAND,
    MODE_COLUMN,
    PARKED,
    PHASE_COLUMN,
    TAKE_OFF,
)
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation import WorldObject, register_mission
from pyautonomousagent.simulation.params import Param, Reader
from pyautonomousagent.simulation.scenario import check_point_in_world
from pyautonomousagent.simulation.scenario_view import ScenarioView
from pyautonomousagent.state import AgentView
from pyautonomousagent.world import World

#: The blackboard key of the approach's leg: 0 toward the approach fix, 1 on final.
LEG = "approach_leg"


@dataclass(frozen=True)
class Runway:
    """Where the UAVs land: the aim point (x east, y north, m) and the landing direction
    (degrees clockwise from north)."""

    x: float
    y: float
    heading: float

    def direction(self) -> tuple[float, float]:
        """The landing direction as a unit vector (east, north)."""
        angle = math.radians(self.heading)
        return math.sin(angle), math.cos(angle)

    def fix(self, distance: float) -> tuple[float, float]:
        """The approach fix: ``distance`` m before the aim point on the extended centre line."""
        east, north = self.direction()
        return self.x - distance * east, self.y - distance * north


def read_runway(reader: Reader, data: Any, path: str) -> Runway:
    """``{x, y, heading}``: finite numbers (m, m, degrees)."""
    given = reader.keys(data, path, ["x", "y", "heading"], ["x", "y", "heading"])
    x, y, heading = (reader.number(given[key], f"{path}.{key}") for key in ("x", "y", "heading"))
    return Runway(x, y, heading % 360.0)


@register_mission
class X8PatrolMission(PatrolMission):
    """Fig. 12's patrol, refuelling by landing at the base's runway (Skywalker X8)."""

    name = "x8-patrol"
    description = "X8 UAVs patrol, and land at their base's runway to refuel"
    parameters: ClassVar[tuple[Param, ...]] = (
        *PatrolMission.parameters,
        Param("approach_speed", 15.0, "m/s", "airspeed requested on final", minimum=0.0),
        Param("glide_slope", 3.0, "degrees", "glide path angle toward the aim point",
              minimum=0.5, maximum=15.0),
        Param("approach_distance", 450.0, "m",
              "distance of the approach fix before the aim point", minimum=0.0),
        Param("approach_altitude", 20.0, "m",
              "highest altitude of the glide path (the cruise altitude)", minimum=0.0),
        Param("approach_capture", 50.0, "m",
              "distance at which the approach fix counts as reached", minimum=0.0),
    )  # fmt: skip
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        *PatrolMission.world_objects,
        WorldObject("runway", read_runway,
                    doc="where the UAVs land: {x, y} aim point (m), heading (degrees)"),
    )  # fmt: skip
    columns: ClassVar[dict[str, Any]] = {
        **PatrolMission.columns,
        **dict.fromkeys((MODE_COLUMN, ALTITUDE_COLUMN, PHASE_COLUMN), np.float64),
    }
    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        **PatrolMission.meanings,
        MODE_COLUMN: ("", "requested autopilot mode: 0 cruise, 1 land, 2 take off"),
        ALTITUDE_COLUMN: ("m", "glide path altitude requested while landing"),
        PHASE_COLUMN: ("", "autopilot phase: 0 flight, 1 approach, 2 flare, 3 roll-out, "
                       "4 parked, 5 take-off roll, 6 climb-out"),
        LEG: ("", "blackboard: approach leg, 0 toward the approach fix, 1 on final"),
    }  # fmt: skip

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """The runway's aim point and approach fix lie in the world."""
        super().check(scenario, reader)
        runway = scenario.objects.runway
        check_point_in_world(reader, scenario, (runway.x, runway.y), "world.runway")
        fix = runway.fix(scenario.parameters.approach_distance)
        if not (0.0 <= fix[0] <= scenario.world[0] and 0.0 <= fix[1] <= scenario.world[1]):
            raise reader.fail(
                "world.runway",
                "placed so that its approach fix (approach_distance before it, against "
                f"its heading), ({fix[0]:g}, {fix[1]:g}), lies in the world",
                asdict(runway),
            )

    def blackboard(self) -> dict[str, Any]:
        """The patrol's keys and the approach leg."""
        return {**super().blackboard(), LEG: np.int64}

    def marks(self) -> list[Mark]:
        """The patrol's marks and the runway's aim point (R) and approach fix (F)."""
        runway = self.scenario.objects.runway
        fx, fy = runway.fix(self.scenario.parameters.approach_distance)
        return [
            *super().marks(),
            Mark("point", runway.x, runway.y, "runway", colour="#444444", symbol="s",
                 legend="runway aim point"),
            Mark("point", fx, fy, "F", colour="#444444", symbol="+", legend="approach fix"),
        ]  # fmt: skip


@register_leaf
class ActionLandA(Leaf):
    """Fly to the runway's approach fix, then along the glide path to its aim point, and land;
    RUNNING until the aircraft stands still (parked), then SUCCESS.

    Toward the fix: cruise (mode CRUISE) at ``speed``. Once within ``capture`` of it: mode
    LAND at ``approach_speed``, heading for the aim point, with the glide path's altitude
    ``min(ceiling, tan(slope) d)`` at a distance ``d`` from it (the autopilot flares below its
    flare height and rolls out to a stop).
    """

    type_name = "Action_Land_A"
    ports = (
        SPEED,
        Port("approach_speed", float, "approach_speed", 0.0, "airspeed on final, m/s"),
        Port("slope", float, "glide_slope", 0.0, "glide path angle, degrees"),
        Port("distance", float, "approach_distance", 0.0, "approach fix before the aim point, m"),
        Port("ceiling", float, "approach_altitude", 0.0, "highest glide path altitude, m"),
        Port("capture", float, "approach_capture", 0.0, "approach fix reached within, m"),
    )
    keys = (LEG,)
    speed: float
    approach_speed: float
    slope: float
    distance: float
    ceiling: float
    capture: float

    def constants(self, world: World) -> tuple[float, ...]:
        """Aim point x, y, approach fix x, y (m), tan(slope), in the kernel's order."""
        runway = world.objects.runway
        fx, fy = runway.fix(self.distance)
        return runway.x, runway.y, fx, fy, math.tan(math.radians(self.slope))

    def evaluate(self, agents: AgentView, world: World) -> Any:
        x, y, fx, fy, tangent = self.constants(world)
        bb = agents.blackboard
        dx, dy = fx - agents.x, fy - agents.y
        leg = choose(dx * dx + dy * dy <= self.capture * self.capture, 1, bb.approach_leg)
        final = leg == 1
        dx, dy = x - agents.x, y - agents.y
        glide = tangent * np.sqrt(dx * dx + dy * dy)
        to_fix = bearing(agents.x, agents.y, fx, fy)
        agents.requested_heading = choose(final, bearing(agents.x, agents.y, x, y), to_fix)
        agents.requested_speed = choose(final, self.approach_speed, self.speed)
        agents.requested_altitude = minimum(self.ceiling, glide)
        agents.autopilot_mode = choose(final, float(LAND), float(CRUISE))
        parked = agents.flight_phase == PARKED
        bb.approach_leg = choose(parked, 0, leg)
        return status_if(parked, SUCCESS, RUNNING)

    def kernel(self, world: World) -> LeafKernel:
        names = {"x": "x", "y": "y", "phase": PHASE_COLUMN, "mode": MODE_COLUMN,
                 "heading": "requested_heading", "speed": "requested_speed",
                 "altitude": ALTITUDE_COLUMN, "leg": LEG}  # fmt: skip
        return LeafKernel(
            k.land, names,
            (*self.constants(world), self.capture, self.ceiling, self.approach_speed,
             self.speed),
        )  # fmt: skip


@register_leaf
class ActionTakeOffA(Leaf):
    """Take off and climb to the cruise altitude: mode TAKE_OFF, straight ahead, until the
    autopilot is back in flight (then mode CRUISE and SUCCESS); RUNNING meanwhile."""

    type_name = "Action_Take_Off_A"
    ports = (SPEED,)
    speed: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        flying = agents.flight_phase == FLIGHT
        agents.autopilot_mode = choose(flying, float(CRUISE), float(TAKE_OFF))
        agents.requested_speed = self.speed
        agents.requested_heading = agents.heading
        return status_if(flying, SUCCESS, RUNNING)

    def kernel(self, world: World) -> LeafKernel:
        names = {"phase": PHASE_COLUMN, "mode": MODE_COLUMN, "heading": "heading",
                 "requested_heading": "requested_heading", "speed": "requested_speed"}  # fmt: skip
        return LeafKernel(k.take_off, names, (self.speed,))
