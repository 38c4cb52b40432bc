"""What the paper's drone missions share: sensors, Table 3's blackboard, refuelling slots,
and the "sharing data" message.

:class:`DroneMission` is written only with the public mission API; gathering and patrol
subclass it.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.datalink import Delivery
from pyautonomousagent.kernels import SensorKernel
from pyautonomousagent.missions.drones.kernels import drain_energy as drain_energy_of_one
from pyautonomousagent.missions.drones.leaves import (
    DESTINATION,
    REFUELING,
    SHARING_DATA,
    SURVEILLANCE,
)
from pyautonomousagent.missions.drones.sensors import (
    RadiationSource,
    accumulate_damage,
    drain_energy,
    radiation_level,
)
from pyautonomousagent.missions.drones.shared_data import SharedData
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation import MessageType, Mission, Param, SimulationView, WorldObject
from pyautonomousagent.simulation.params import Point, Reader
from pyautonomousagent.simulation.scenario import check_point_in_world
from pyautonomousagent.simulation.scenario_view import ScenarioView
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

SLOT_COLOUR = "#9ecae1"
"""Light blue of the refuelling slots (Fig. 5)."""
TARGET_COLOUR = "#333333"
"""The surveillance marks' colour."""
SOURCE_COLOUR = "#ff7f00"
"""Orange of an active radiation source."""


def read_radiation_sources(reader: Reader, data: Any, path: str) -> tuple[RadiationSource, ...]:
    """``[{x, y, range, active}]`` as radiation sources."""
    if not isinstance(data, list):
        raise reader.fail(path, "a list", data)
    sources = []
    for i, item in enumerate(data):
        where = f"{path}[{i}]"
        item = reader.keys(item, where, ["x", "y", "range", "active"], ["x", "y", "range"])
        x, y = (reader.number(item[key], f"{where}.{key}") for key in "xy")
        reach = reader.number(item["range"], f"{where}.range", above=0)
        active = reader.flag(item.get("active", False), f"{where}.active")
        sources.append(RadiationSource(x, y, reach, active))
    return tuple(sources)


def cycled(points: tuple[Point, ...], n: int) -> np.ndarray:
    """Points given to agents 1..n in turn, shape (n, 2)."""
    return np.asarray([points[i % len(points)] for i in range(n)], dtype=np.float64)


def distinct(points: Any) -> list[tuple[float, ...]]:
    """The points (x, y[, z]) without repeats, in order."""
    return list(dict.fromkeys(tuple(float(v) for v in point) for point in points))


class DroneMission(Mission):
    """The paper's drones: energy, radiation and damage sensors; Table 3's blackboard; agents
    start full on their refuelling slots and share their state with "sharing data".

    Run state: :attr:`shared`, what each drone last heard from each other drone.
    """

    agent_prefix = "drone"
    #: The blackboard keys of the surveillance position and the destination (x, y[, z]).
    surveillance: ClassVar[tuple[str, ...]] = SURVEILLANCE
    destination: ClassVar[tuple[str, ...]] = DESTINATION
    #: The world object holding the surveillance (or patrol) positions.
    points: ClassVar[str]
    parameters: ClassVar[tuple[Param, ...]] = (
        Param("reference_speed", 0.1, "world units per iteration (m/s for the X8)",
              "cruise speed the navigation leaves request", minimum=0.0),
        Param("energy_use", 0.05, "percent per iteration", "energy used every iteration",
              minimum=0.0, maximum=100.0),
        Param("refuel_rate", 2.0, "percent per iteration", "energy gained while refuelling",
              minimum=0.0, maximum=100.0),
        Param("low_energy_threshold", 40.0, "percent",
              "energy at or below which a drone goes to refuel", minimum=0.0, maximum=100.0),
        Param("destination_tolerance", 0.5, "world units",
              "distance at which a destination counts as reached", minimum=0.0),
        Param("radiation_damage_factor", 0.1, "percent per iteration at 100 % radiation",
              "damage growth under radiation", minimum=0.0, maximum=100.0),
        Param("radiation_threshold", 0.0, "percent", "radiation level that counts as detected",
              minimum=0.0, maximum=100.0),
        Param("damage_limit", 70.0, "percent", "damage at or above which a drone is damaged",
              minimum=0.0, maximum=100.0),
        Param("repair_rate", 1.0, "percent per iteration", "damage repaired while repairing",
              minimum=0.0, maximum=100.0),
    )  # fmt: skip
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        WorldObject("refueling_positions", Reader.points,
                    doc="refuelling slots [x, y], used in turn by drones 1, 2, ... (cycled)"),
        WorldObject("radiation_sources", read_radiation_sources, (),
                    "radiation sources {x, y, range, active}: level 100 (1 - d / range) %"),
    )  # fmt: skip
    columns: ClassVar[dict[str, Any]] = {
        "energy": np.float64,  # percent, [0, 100]
        "damage": np.float64,  # percent, [0, 100]
        "radiation": np.float64,  # percent, [0, 100], last sensor reading
    }

    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        "energy": ("percent", "energy left, 0 to 100; at 0 the agent stops and reads no sensor"),
        "damage": ("percent", "accumulated radiation damage, 0 to 100"),
        "radiation": ("percent", "last radiation sensor reading, 0 to 100"),
        "x_surveillance_position": ("world unit", "blackboard: surveillance position, east"),
        "y_surveillance_position": ("world unit", "blackboard: surveillance position, north"),
        "x_refueling_position": ("world unit", "blackboard: own refuelling slot, east"),
        "y_refueling_position": ("world unit", "blackboard: own refuelling slot, north"),
        "x_current_destination_position": ("world unit", "blackboard: current destination, east"),
        "y_current_destination_position": ("world unit", "blackboard: current destination, north"),
    }

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """The refuelling slots and the points ``world.<points>`` lie in the world."""
        for key in ("refueling_positions", cls.points):
            for i, point in enumerate(getattr(scenario.objects, key)):
                check_point_in_world(reader, scenario, point, f"world.{key}[{i}]")

    def blackboard(self) -> dict[str, Any]:
        """Table 3: the surveillance, refuelling and destination positions."""
        return {k: np.float64 for k in SURVEILLANCE + REFUELING + DESTINATION}

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """Drones start full of energy on their refuelling slots (:meth:`slots`), at rest."""
        self.shared = SharedData(swarm.size)
        refuel = self.slots(swarm.size)
        s, bb = swarm.columns, swarm.blackboard
        s["x"][:], s["y"][:] = refuel[:, 0], refuel[:, 1]
        s["energy"][:] = 100.0
        bb["x_refueling_position"][:], bb["y_refueling_position"][:] = refuel[:, 0], refuel[:, 1]

    def slots(self, n: int) -> np.ndarray:
        """The refuelling slots of drones 1..n, shape (n, 2): the scenario's, cycled."""
        return cycled(self.scenario.objects.refueling_positions, n)

    def set_surveillance(self, swarm: Swarm, points: np.ndarray) -> None:
        """Each drone's surveillance position, and its first destination, shape (N, axes):
        the keys :attr:`surveillance` and :attr:`destination`, x, y (and z in 3-D)."""
        bb = swarm.blackboard
        for axis, keys in enumerate(zip(self.surveillance, self.destination, strict=True)):
            for key in keys:
                bb[key][:] = points[:, axis]

    def sense(self, sim: SimulationView) -> np.ndarray:
        """Energy drains; a drone with energy reads radiation and takes damage from it.

        Returns:
            The drones with energy (the others do not move and raise an alert once).
        """
        s, p = sim.swarm.columns, self.params
        s["energy"][:] = drain_energy(s["energy"], p.energy_use)
        powered = s["energy"] > 0.0
        sources = sim.world.objects.radiation_sources
        if any(source.active for source in sources):
            np.copyto(s["radiation"], radiation_level(s["x"], s["y"], sources), where=powered)
            s["damage"][:] = accumulate_damage(
                s["damage"], s["radiation"], p.radiation_damage_factor
            )
        # else: no source is active, so every reading is 0 and damage does not grow
        if not powered.all():
            self._stopped(sim, np.flatnonzero(~powered))
        return powered

    def compiled_sensors(self, sim: SimulationView) -> SensorKernel | None:
        """:meth:`sense` for one drone (``kernels.drain_energy``) while no radiation source
        is active; None otherwise, or where a subclass senses otherwise."""
        if type(self).sense is not DroneMission.sense:
            return None
        return self.drone_sensors(sim)

    def drone_sensors(self, sim: SimulationView) -> SensorKernel | None:
        """:meth:`DroneMission.sense` compiled (``kernels.drain_energy``) while no radiation
        source is active, else None; for subclasses that sense more only at times."""
        if any(source.active for source in sim.world.objects.radiation_sources):
            return None
        return SensorKernel(
            drain_energy_of_one, ("energy",), (self.params.energy_use,), self._stopped
        )

    def _stopped(self, sim: SimulationView, rows: np.ndarray) -> None:
        sim.alert(rows, "zero energy", "zero energy: sensors off, not moving")

    def message_types(self) -> list[MessageType]:
        """ "sharing data": each receiver keeps the latest state per sender."""
        kernel = self.shared.kernel() if hasattr(self, "shared") else None  # set by place()
        return [
            MessageType(SHARING_DATA, self.store_shared_data, doc="the sender's state",
                        kernel=kernel)
        ]  # fmt: skip

    def store_shared_data(self, sim: SimulationView, delivery: Delivery) -> None:
        """Remember the latest "sharing data" per sender (sent last iteration)."""
        self.shared.store(delivery, sim.world.iteration - 1)

    def marks(self) -> list[Mark]:
        """Refuelling slots R1.. (light-blue circles) and active radiation sources."""
        w, h = self.scenario.world
        radius = 0.0375 * max(w, h)
        slots = distinct(self.scenario.objects.refueling_positions)
        marks = [
            Mark("circle", x, y, f"R{i}", size=radius, colour=SLOT_COLOUR, fill=True,
                 legend="refuelling slot")
            for i, (x, y) in enumerate(slots, start=1)
        ]  # fmt: skip
        for source in self.scenario.objects.radiation_sources:
            if source.active:
                marks.append(
                    Mark("circle", source.x, source.y, "", size=source.range,
                         colour=SOURCE_COLOUR, legend="radiation source")
                )  # fmt: skip
        return marks

    def surveillance_marks(self, points: Any) -> list[Mark]:
        """Surveillance positions S1.. as "x" markers; in 3-D labelled with their altitude."""
        altitude = " (altitude)" if len(self.surveillance) == 3 else ""
        return [
            Mark("point", p[0], p[1], f"S{i}" + "".join(f" z={z:g}" for z in p[2:]),
                 colour=TARGET_COLOUR, symbol="x", legend=f"surveillance position{altitude}")
            for i, p in enumerate(distinct(points), start=1)
        ]  # fmt: skip
