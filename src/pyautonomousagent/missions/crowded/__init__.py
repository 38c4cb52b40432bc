"""Crowded surveillance: groups of drones share one surveillance position each, so they meet
there and may collide; the proximity sensor and its leaves let them avoid each other.

Scenarios ``crowded`` (the gathering drones' tree without avoidance: drones collide) and
``crowded-avoid`` (the same with ``Condition_Collision_Risk`` and ``Action_Avoid_Collision``
first: no collision). Collisions raise the damage level and are events of the run
(:mod:`pyautonomousagent.missions.crowded.collisions`, docs/data.md).
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.kernels import SensorKernel, SwarmSensorKernel
from pyautonomousagent.missions.crowded import leaves  # noqa: F401  (registers them)
from pyautonomousagent.missions.crowded.collisions import (
    COLUMNS,
    Collisions,
    Reading,
    sense_plane,
    take_reading,
)
from pyautonomousagent.missions.drones.mission import (
    SLOT_COLOUR,
    DroneMission,
    read_radiation_sources,
)
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation import Param, SimulationView, WorldObject, register_mission
from pyautonomousagent.simulation.params import Point, Reader
from pyautonomousagent.simulation.scenario_view import ScenarioView
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

log = logging.getLogger("pyautonomousagent")


def layout(
    agents: int, group_size: int, spacing: float, slot_radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """Where the drones refuel and what they watch, shape (N, 2) each, world units.

    Drone k (0-based) belongs to group ``k // group_size``; group g's surveillance position
    is cell g of a square lattice of ``ceil(sqrt(groups))`` columns, ``spacing`` apart,
    starting at (spacing / 2, spacing / 2); its drones' refuelling slots lie evenly on a
    circle of ``slot_radius`` around it (the first due north, then clockwise).
    """
    k = np.arange(agents)
    group, member = k // group_size, k % group_size
    groups = -(-agents // group_size)
    columns = max(1, math.isqrt(groups - 1) + 1) if groups else 1
    points = np.column_stack(
        ((group % columns + 0.5) * spacing, (group // columns + 0.5) * spacing)
    )
    angle = member * (2.0 * np.pi / group_size)
    slots = points + slot_radius * np.column_stack((np.sin(angle), np.cos(angle)))
    return slots, points


def lattice_extent(groups: int, spacing: float, slot_radius: float) -> Point:
    """The smallest world (width, height), world units, that holds :func:`layout`'s first
    ``groups`` (>= 1) positions with their circles of slots (and so the way between slot
    and position): ``ceil(sqrt(groups))`` columns and as many rows as they fill, ``spacing``
    apart, the first at ``spacing / 2``, each circle of radius ``slot_radius``."""
    columns = math.isqrt(groups - 1) + 1
    rows = (groups - 1) // columns + 1
    return (columns - 0.5) * spacing + slot_radius, (rows - 0.5) * spacing + slot_radius


def largest_swarm(world: Point, group_size: int, spacing: float, slot_radius: float) -> int:
    """The most drones (whole groups of ``group_size``) whose :func:`layout` lies in the world
    [0, width] x [0, height] (``world``, world units), for ``slot_radius <= spacing / 2``."""

    def fits(groups: int) -> bool:
        width, height = lattice_extent(groups, spacing, slot_radius)
        return width <= world[0] and height <= world[1]

    low, high = 0, (int(world[0] // spacing) + 2) ** 2  # more columns than the width holds
    while high - low > 1:  # fits(low), not fits(high): fitting is monotonic in the groups
        middle = (low + high) // 2
        low, high = (middle, high) if fits(middle) else (low, middle)
    return low * group_size


@register_mission
class CrowdedMission(DroneMission):
    """The paper's drones, in groups that share a surveillance position, with collisions
    and a proximity sensor."""

    name = "crowded"
    description = "groups of drones share surveillance positions; collisions raise damage"
    parameters: ClassVar[tuple[Param, ...]] = (
        *DroneMission.parameters,
        Param("collision_radius", 0.5, "world units",
              "agents closer than this collide (on entry); 0: no collision detection",
              minimum=0.0),
        Param("collision_damage", 10.0, "percent per collision",
              "damage each agent of a colliding pair takes", minimum=0.0, maximum=100.0),
        Param("proximity_range", 3.0, "world units",
              "the proximity sensor's range (nearest neighbour); 0: no sensor", minimum=0.0),
        Param("collision_risk_distance", 2.0, "world units",
              "nearest-neighbour distance below which Condition_Collision_Risk holds "
              "(at most proximity_range)", minimum=0.0),
        Param("group_size", 6, "drones", "drones sharing one surveillance position", minimum=1),
        Param("point_spacing", 60.0, "world units",
              "distance between neighbouring surveillance positions (a square lattice)",
              minimum=1e-9),
        Param("slot_radius", 20.0, "world units",
              "radius of the circle of a group's refuelling slots around its position",
              minimum=0.0),
    )  # fmt: skip
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        WorldObject("radiation_sources", read_radiation_sources, (),
                    "radiation sources {x, y, range, active}: level 100 (1 - d / range) %"),
    )  # fmt: skip
    columns: ClassVar[dict[str, Any]] = {
        **DroneMission.columns,
        "neighbour_distance": np.float64,
        "neighbour_bearing": np.float64,
        "collisions": np.int64,
    }
    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        **DroneMission.meanings,
        "damage": ("percent", "accumulated damage (radiation and collisions), 0 to 100"),
        "neighbour_distance": ("world unit", "proximity sensor: distance to the nearest other "
                               "agent; proximity_range when none is within it"),
        "neighbour_bearing": ("degree", "proximity sensor: bearing to the nearest other agent, "
                              "clockwise from north; 0 when none is within range"),
        "collisions": ("", "collisions of this agent so far (counted on entry into the radius)"),
    }  # fmt: skip

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """The risk distance lies within the sensor's range; every group's circle of slots lies
        in the world, else name the largest swarm that fits and the world this one needs."""
        p, agents = scenario.parameters, scenario.agents
        if p.collision_risk_distance > p.proximity_range:
            raise reader.fail(
                "parameters.collision_risk_distance",
                f"at most proximity_range ({p.proximity_range:g} world units)",
                p.collision_risk_distance,
            )
        if p.slot_radius > p.point_spacing / 2:
            raise reader.fail(
                "parameters.slot_radius",
                f"at most point_spacing / 2 ({p.point_spacing / 2:g}) so that the first "
                "group's slots lie in the world",
                p.slot_radius,
            )
        most = largest_swarm(scenario.world, p.group_size, p.point_spacing, p.slot_radius)
        if agents > most:
            width, height = cls.world_for(scenario, agents)
            raise reader.fail(
                "agents",
                f"at most {most} to keep crowded's lattice of surveillance positions "
                f"(group_size {p.group_size}, point_spacing {p.point_spacing:g}, slot_radius "
                f"{p.slot_radius:g}) in the world {scenario.world[0]:g} x "
                f"{scenario.world[1]:g}; {agents} need world.size at least [{width:g}, "
                f"{height:g}]",
                agents,
            )

    @classmethod
    def world_for(cls, scenario: ScenarioView, agents: int) -> Point:
        """The scenario's world, grown where the lattice of ``agents`` drones needs more."""
        p = scenario.parameters
        groups = -(-agents // p.group_size)
        width, height = lattice_extent(groups, p.point_spacing, p.slot_radius)
        return max(scenario.world[0], width), max(scenario.world[1], height)

    def _layout(self) -> tuple[np.ndarray, np.ndarray]:
        p = self.params
        return layout(self.scenario.agents, p.group_size, p.point_spacing, p.slot_radius)

    def slots(self, n: int) -> np.ndarray:
        """The groups' refuelling slots (:func:`layout`), shape (n, 2)."""
        return self._layout()[0]

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """Drones full of energy on their slots, at rest; destination: the group's position."""
        super().place(swarm, world, rng)
        self.set_surveillance(swarm, self._layout()[1])
        p = self.params
        self.collisions = Collisions(swarm.size, p.collision_radius, p.proximity_range)
        swarm.columns["neighbour_distance"][:] = p.proximity_range

    def sense(self, sim: SimulationView) -> np.ndarray:
        """The drones' sensors, then the proximity sensor and collisions (each colliding
        agent's damage rises by ``collision_damage`` per new collision; an event each)."""
        powered = super().sense(sim)
        if not self.collisions.active:
            return powered
        s = sim.swarm.columns
        reading = self.collisions.sense((s["x"], s["y"]))
        everyone = bool(powered.all())  # then a plain copy: cheaper than a masked one
        np.copyto(s["neighbour_distance"], reading.distance, where=True if everyone else powered)
        np.copyto(s["neighbour_bearing"], reading.bearing, where=True if everyone else powered)
        if reading.first.size:
            self._collided(sim, reading)
        return powered

    def _collided(self, sim: SimulationView, reading: Reading) -> None:
        """Damage, counts and one ``collision`` event per new colliding pair (the new
        collisions per agent are the check's :attr:`Collisions.hits`)."""
        s, counts = sim.swarm.columns, self.collisions.hits
        hit = np.flatnonzero(counts)
        s["collisions"][hit] += counts[hit]
        damage = s["damage"][hit] + counts[hit] * self.params.collision_damage
        s["damage"][hit] = np.minimum(damage, 100.0)
        t = np.full(reading.first.size, sim.world.iteration, dtype=np.int64)
        self._events(sim, t, reading.first, reading.second, reading.pair_distance)

    def _events(
        self, sim: SimulationView, t: np.ndarray, first: np.ndarray, second: np.ndarray,
        distance: np.ndarray,
    ) -> None:  # fmt: skip
        """One ``collision`` event per pair (``first[k]``, ``second[k]``) colliding at
        iteration ``t[k]`` ``distance[k]`` world units apart, in order."""
        names = sim.swarm.names
        for u, a, b, d in zip(t.tolist(), first.tolist(), second.tolist(), distance.tolist(),
                              strict=True):  # fmt: skip
            sim.events.append(
                {"iteration": u, "event": "collision", "agent": names[a], "other": names[b],
                 "distance": d, "message": f"collided with {names[b]} ({d:.3g} world units)"}
            )  # fmt: skip
        if t.size:
            log.debug("iterations %d to %d: %d collision(s)", t[0], t[-1], t.size)

    def _collect(self, sim: SimulationView, through: int) -> None:
        """The collisions the fused loop found up to iteration ``through``, as events; then
        room for what it found too little room for."""
        t, pairs, distance = self.collisions.take(through)
        self._events(sim, t, pairs[0], pairs[1], distance)
        self.collisions.make_room()

    def compiled_sensors(self, sim: SimulationView) -> SensorKernel | None:
        """The drones' compiled sensors, with the proximity sensor and collisions as a
        sensor of the whole swarm (:class:`~pyautonomousagent.kernels.SwarmSensorKernel`:
        the same :func:`~pyautonomousagent.missions.crowded.collisions.detect`) where
        they are on; None where the drones' own sensors have no compiled form."""
        sensors = self.drone_sensors(sim)
        if sensors is None or not self.collisions.active:
            return sensors
        c, p = self.collisions, self.params
        constants = (c.radius, c.range, p.collision_damage)
        swarm = SwarmSensorKernel(sense_plane, take_reading, COLUMNS, c.state, constants,
                                  self._collect)  # fmt: skip
        return replace(sensors, swarm=swarm)

    def marks(self) -> list[Mark]:
        """The groups' refuelling slots (small light-blue circles) and positions S1.."""
        slots, points = self._layout()
        size = 0.015 * max(self.scenario.world)
        marks = [
            Mark("circle", float(x), float(y), "", size=size, colour=SLOT_COLOUR, fill=True,
                 legend="refuelling slot")
            for x, y in slots[: 64 * self.params.group_size]
        ]  # fmt: skip
        return [*marks, *self.surveillance_marks(points[:: self.params.group_size][:64])]
