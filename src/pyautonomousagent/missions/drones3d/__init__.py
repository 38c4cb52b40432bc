"""The paper's drones in three dimensions: ``gathering-3d`` and ``patrol-3d``, flown by the
3-D drone (``model: drone3d``, docs/drone3d.md).

Surveillance and patrol positions are ``[x, y, z]`` (z: altitude, world units above the
ground); the refuelling slots are on the ground (z = 0): a drone lands to refuel. Climbing
costs energy (``climb_energy_use``, percent per world unit climbed) on top of the paper's
``energy_use`` per iteration. Written with the public mission API only; the leaves are in
:mod:`pyautonomousagent.missions.drones3d.leaves`.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.kernels import SensorKernel
from pyautonomousagent.missions.drones.mission import DroneMission
from pyautonomousagent.missions.drones.sensors import drain_energy
from pyautonomousagent.missions.drones3d.kernels import (
    adopt_point_3d,
    adopt_point_everyone_3d,
    drain_energy_3d,
)
from pyautonomousagent.missions.drones3d.leaves import (
    DESTINATION_3D,
    PATROL_3D,
    REFUELING_3D,
    SURVEILLANCE_3D,
)
from pyautonomousagent.missions.gathering import GatheringMission
from pyautonomousagent.missions.patrol import PatrolMission
from pyautonomousagent.models.drone3d import COLUMNS_3D, MEANINGS_3D
from pyautonomousagent.simulation import Param, SimulationView, WorldObject, register_mission
from pyautonomousagent.simulation.params import Reader
from pyautonomousagent.simulation.scenario_view import ScenarioView

#: A point with an altitude: (x, y, z), world units.
Point3D = tuple[float, float, float]

PARAMETERS_3D: tuple[Param, ...] = (
    Param("climb_energy_use", 0.5, "percent per world unit climbed",
          "energy used to climb, on top of energy_use (descending costs nothing)",
          minimum=0.0, maximum=100.0),
    Param("descent_slope", 0.4, "world units down per world unit flown",
          "steepest glide path toward a lower destination (max_climb_rate / reference_speed "
          "is the drone's own steepest)", minimum=0.0),
    Param("cruise_altitude", 20.0, "world units",
          "altitude Action_Request_Altitude_S requests by default", minimum=0.0),
)  # fmt: skip

COLUMNS: dict[str, Any] = {
    "z": COLUMNS_3D["z"],
    "climb_rate": COLUMNS_3D["climb_rate"],
    **DroneMission.columns,
    "requested_altitude": COLUMNS_3D["requested_altitude"],
}

MEANINGS: dict[str, tuple[str, str]] = {
    **MEANINGS_3D,
    "z_surveillance_position": ("world unit", "blackboard: surveillance position, altitude"),
    "z_refueling_position": ("world unit", "blackboard: own refuelling slot, altitude (0)"),
    "z_current_destination_position": ("world unit", "blackboard: current destination, altitude"),
}


def read_point_3d(reader: Reader, value: Any, path: str) -> Point3D:
    """``[x, y, z]``: finite numbers, z (the altitude) at or above the ground."""
    if not isinstance(value, list | tuple) or len(value) != 3:
        raise reader.fail(path, "a point [x, y, z] (z: altitude above the ground)", value)
    x, y, z = (reader.number(v, f"{path}[{i}]") for i, v in enumerate(value))
    if z < 0:
        raise reader.fail(f"{path}[2]", "an altitude >= 0 (at or above the ground)", z)
    return (x, y, z)


def read_points_3d(
    reader: Reader, data: Any, path: str, least: int = 1, most: int | None = None
) -> tuple[Point3D, ...]:
    """A list of ``least``..``most`` points ``[x, y, z]``."""
    if not isinstance(data, list | tuple) or len(data) < least or (most and len(data) > most):
        count = f"exactly {least}" if least == most else f"at least {least}"
        raise reader.fail(path, f"a list of {count} points [x, y, z]", data)
    return tuple(read_point_3d(reader, p, f"{path}[{i}]") for i, p in enumerate(data))


class Drone3DMission(DroneMission):
    """What the 3-D missions add to their 2-D namesakes (which come after this class in
    their bases): altitudes in the blackboard, the climb's energy, the checks of the 3-D
    drone and of the altitudes of the points ``world.<points>``."""

    surveillance = SURVEILLANCE_3D
    destination = DESTINATION_3D
    columns: ClassVar[dict[str, Any]] = COLUMNS

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """The 2-D mission's checks; the 3-D drone; altitudes below the ceiling."""
        super().check(scenario, reader)
        if scenario.model != "drone3d":
            raise reader.fail("model", "drone3d (a 3-D mission flies the 3-D drone)",
                              scenario.model)  # fmt: skip
        ceiling = scenario.parameters.max_altitude
        for i, point in enumerate(getattr(scenario.objects, cls.points)):
            if point[2] > ceiling:
                where = f"world.{cls.points}[{i}][2]"
                raise reader.fail(where, f"an altitude <= max_altitude ({ceiling:g})", point[2])

    def blackboard(self) -> dict[str, Any]:
        """The 2-D mission's keys (Table 3's) with altitudes."""
        altitudes = dict.fromkeys(DESTINATION_3D + SURVEILLANCE_3D + REFUELING_3D, np.float64)
        return {**super().blackboard(), **altitudes}

    def sense(self, sim: SimulationView) -> np.ndarray:
        """Phase 2: climbing costs ``climb_energy_use`` percent per world unit climbed this
        iteration (the climb rate about to be flown); then the drones' sensors."""
        s = sim.swarm.columns
        climbed = np.maximum(s["climb_rate"], 0.0)
        s["energy"][:] = drain_energy(s["energy"], self.params.climb_energy_use * climbed)
        return super().sense(sim)

    def compiled_sensors(self, sim: SimulationView) -> SensorKernel | None:
        """:meth:`sense` for one drone (``kernels.drain_energy_3d``) while no radiation
        source is active; None otherwise."""
        if any(source.active for source in sim.world.objects.radiation_sources):
            return None
        p = self.params
        return SensorKernel(
            drain_energy_3d, ("energy", "climb_rate"), (p.energy_use, p.climb_energy_use),
            self._stopped,
        )  # fmt: skip


@register_mission
class Gathering3DMission(Drone3DMission, GatheringMission):
    """Fig. 6's mission in 3-D: surveillance positions with altitudes, refuelling on the
    ground, the gathering order carrying the altitude."""

    name = "gathering-3d"
    description = "3-D drones hover at surveillance positions, land to refuel, and gather"
    parameters: ClassVar[tuple[Param, ...]] = (*GatheringMission.parameters, *PARAMETERS_3D)
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        *DroneMission.world_objects,
        WorldObject("surveillance_positions", read_points_3d,
                    doc="surveillance positions [x, y, z], used in turn by drones 1, 2, ..."),
    )  # fmt: skip
    meanings: ClassVar[dict[str, tuple[str, str]]] = {**GatheringMission.meanings, **MEANINGS}
    adopt_kernels = (adopt_point_everyone_3d, adopt_point_3d)


@register_mission
class Patrol3DMission(Drone3DMission, PatrolMission):
    """Fig. 12's mission in 3-D: two patrol positions at their altitudes, refuelling on the
    ground."""

    name = "patrol-3d"
    description = "3-D drones patrol between two positions at their altitudes, land to refuel"
    parameters: ClassVar[tuple[Param, ...]] = (*PatrolMission.parameters, *PARAMETERS_3D)
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        *DroneMission.world_objects,
        WorldObject("patrol_positions", lambda r, d, p: read_points_3d(r, d, p, 2, 2),
                    doc="the two positions [x, y, z] patrolled by every drone"),
    )  # fmt: skip
    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        **PatrolMission.meanings,
        **MEANINGS,
        "z_surveillance_position_1": ("world unit", "blackboard: patrol position 1, altitude"),
        "z_surveillance_position_2": ("world unit", "blackboard: patrol position 2, altitude"),
    }
    patrol = PATROL_3D

    def blackboard(self) -> dict[str, Any]:
        """The patrol's keys with altitudes."""
        return {**super().blackboard(), **dict.fromkeys(PATROL_3D[1:], np.float64)}
