"""Collisions and the proximity sensor, over the whole swarm (Phase 2), in 2 or 3 dimensions.

One :class:`~pyautonomousagent.proximity.CellList` of the agents' positions per iteration
serves both: every agent's nearest neighbour within the sensor's range, and the pairs closer
than the collision radius. Time and memory grow with the agents plus the pairs in
neighbouring cells, not with N**2.

A collision is counted on entry: a pair collides at the first iteration its distance is below
the radius, and again only after it has been apart (at or beyond the radius) for an
iteration. A pair that stays within the radius is one collision, not one per iteration.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import bearing, np_minimum
from pyautonomousagent.proximity import FRESH, near_all, workspace


@dataclass(frozen=True)
class Reading:
    """One iteration's proximity sensing.

    Attributes:
        distance: distance to the nearest other agent within the sensor's range, world
            units, shape (N,); the range itself where none is within it. (This and
            ``bearing`` are the :class:`Collisions`' own arrays: valid until its next check.)
        bearing: the bearing to it, degrees clockwise from north in [0, 360), shape (N,);
            0 where none is within range.
        first, second: the pairs that collide now (entered the radius), first < second,
            shape (C,) int64, sorted.
        pair_distance: their distances, world units, shape (C,).
    """

    distance: np.ndarray
    bearing: np.ndarray
    first: np.ndarray
    second: np.ndarray
    pair_distance: np.ndarray


class Collisions:
    """The pairs within the collision radius at the last check, for counting on entry, and
    the buffers that :func:`detect` fills (the NumPy path and the compiled engine's fused loop
    call it alike, through :meth:`sense` and ``CrowdedMission.compiled_sensors``).

    Args:
        agents: the swarm's size N.
        radius: agents closer than this collide (world units); 0: no collisions.
        sensor_range: the proximity sensor's range (world units); 0: the sensor reads
            nothing (distance 0 is never reported: the range, 0, is).

    Attributes:
        distance, bearing, hits: the last check's reading, shape (N,) each: the nearest
            neighbour's distance and bearing, and the new collisions of each agent (int64).
        touching: the keys ``first * N + second`` of the pairs within the radius, sorted, in
            the first ``fill[0]`` places (room for more).
        fill: int64 (4,): the pairs touching, the collisions buffered, and the room
            :func:`detect` asked for where it had too little (touching, collisions; else 0).
        events: the buffered collisions (iteration (E,), pair (2, E), distance (E,)), in order
            of iteration, then pair; the first ``fill[1]`` are new.
        work: the grid's scratch arrays (:func:`~pyautonomousagent.proximity.workspace`)
            for a compiled loop, made on its first use of :attr:`state` and kept from check
            to check. :meth:`sense`, between NumPy's operations, has the grid allocate its
            arrays anew instead (:data:`~pyautonomousagent.proximity.FRESH`: faster there).
    """

    def __init__(self, agents: int, radius: float, sensor_range: float) -> None:
        self.agents = agents
        self.radius = float(radius)
        self.range = float(sensor_range)
        self.distance = np.full(agents, self.range)
        self.bearing = np.zeros(agents)
        self.hits = np.zeros(agents, dtype=np.int64)
        self.fill = np.zeros(4, dtype=np.int64)
        self.touching = np.zeros(max(64, agents // 4), dtype=np.int64)
        room = max(1024, agents)
        self.events = (np.zeros(room, np.int64), np.zeros((2, room), np.int64), np.zeros(room))
        self.work = FRESH  # until a compiled loop asks for the state
        if self.active:  # compile (or load from numba's cache) now, in the run's set-up
            Collisions(2, 0.0, 0.0).sense((np.zeros(2), np.ones(2)))

    @property
    def active(self) -> bool:
        """Whether anything is sensed or detected (a radius or a range above 0)."""
        return max(self.radius, self.range) > 0.0

    @property
    def buffers(self) -> tuple[np.ndarray, ...]:
        """The arrays :func:`detect` reads and writes after the coordinates, in order, but
        the grid's workspace."""
        return (self.distance, self.bearing, self.hits, self.touching, self.fill, *self.events)

    @property
    def state(self) -> tuple[np.ndarray, ...]:
        """:attr:`buffers` and the grid's workspace for agents in the plane, for a compiled
        loop that calls :func:`detect` every iteration."""
        if self.work is FRESH:
            self.work = workspace(self.agents, 2, max(self.radius, self.range))
        return (*self.buffers, *self.work)

    def sense(self, coordinates: Sequence[np.ndarray]) -> Reading:
        """The proximity readings and the new collisions at the agents' positions.

        Args:
            coordinates: x, y (and z) of every agent, world units, shape (N,) each.
        """
        axes = tuple(np.ascontiguousarray(c, dtype=np.float64) for c in coordinates)
        while detect(0, axes, self.radius, self.range, *self.buffers, *FRESH):
            self.make_room()
        t, pairs, distance = self.take(np.iinfo(np.int64).max)
        return Reading(self.distance, self.bearing, pairs[0], pairs[1], distance)

    def make_room(self) -> None:
        """Enlarge the buffers :func:`detect` found too small (to twice what it asked)."""
        touching, events = int(self.fill[2]), int(self.fill[3])
        if touching:
            self.touching = np.resize(self.touching, 2 * touching)
        if events:
            t, pairs, distance = self.events
            self.events = (np.resize(t, 2 * events), np.zeros((2, 2 * events), np.int64),
                           np.resize(distance, 2 * events))  # fmt: skip
            self.events[1][:, : pairs.shape[1]] = pairs
        self.fill[2:] = 0

    def take(self, through: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Remove the buffered collisions of iterations up to ``through`` and return them:
        iteration (C,), pair (2, C) (first < second), distance (C,), in order."""
        t, pairs, distance = self.events
        count = int(self.fill[1])
        k = int(np.searchsorted(t[:count], through, side="right"))
        taken = t[:k].copy(), pairs[:, :k].copy(), distance[:k].copy()
        rest = slice(k, count)
        t[: count - k], distance[: count - k] = t[rest], distance[rest]
        pairs[:, : count - k] = pairs[:, rest]
        self.fill[1] = count - k
        return taken


@njit
def detect(
    t: int,
    axes: tuple[np.ndarray, ...],
    radius: float,
    sensor_range: float,
    distance: np.ndarray,
    heading: np.ndarray,
    hits: np.ndarray,
    touching: np.ndarray,
    fill: np.ndarray,
    event_t: np.ndarray,
    event_pairs: np.ndarray,
    event_distance: np.ndarray,
    work: np.ndarray,
    scratch: np.ndarray,
) -> int:
    """One check at iteration ``t`` of the agents at ``axes`` (x, y (, z), shape (N,) each):
    each agent's nearest neighbour within ``sensor_range`` into ``distance`` and ``heading``
    (its bearing), the pairs now closer than ``radius`` into ``touching`` (the state of
    :class:`Collisions`, sorted keys), and those not touching before (collisions, counted on
    entry) into ``hits`` and appended to the buffered events; ``work``, ``scratch``: the
    grid's (:func:`~pyautonomousagent.proximity.workspace`, or
    :data:`~pyautonomousagent.proximity.FRESH`). Returns 0; or 1, changing
    nothing but ``fill[2:]`` (the room asked for) and the scratch, where a buffer is too
    small."""
    n = axes[0].shape[0]
    found = near_all(axes, sensor_range, radius, sensor_range, work, scratch)
    nearest, near, first, second, pair_distance = found
    keys = first * n + second
    before = touching[: fill[0]]
    new = np.empty(keys.size, dtype=np.bool_)
    at = 0
    for p in range(keys.size):  # both sorted: one walk along them
        while at < before.size and before[at] < keys[p]:
            at += 1
        new[p] = not (at < before.size and before[at] == keys[p])
    events = fill[1] + new.sum()
    if keys.size > touching.size or events > event_t.size:
        fill[2] = keys.size if keys.size > touching.size else 0
        fill[3] = events if events > event_t.size else 0
        return 1
    distance[:] = near
    bearings(axes[0], axes[1], nearest, heading)
    hits[:] = 0
    e = fill[1]
    for p in range(keys.size):
        touching[p] = keys[p]
        if new[p]:
            a, b = first[p], second[p]
            hits[a] += 1
            hits[b] += 1
            event_t[e] = t
            event_pairs[0, e] = a
            event_pairs[1, e] = b
            event_distance[e] = pair_distance[p]
            e += 1
    fill[0] = keys.size
    fill[1] = e
    return 0


#: The columns :func:`sense_plane` and :func:`take_reading` get, in order.
COLUMNS = ("x", "y", "neighbour_distance", "neighbour_bearing", "collisions", "damage")


@njit
def sense_plane(
    t: int, x: np.ndarray, y: np.ndarray, neighbour_distance: np.ndarray,
    neighbour_bearing: np.ndarray, collisions: np.ndarray, damage: np.ndarray,
    distance: np.ndarray, heading: np.ndarray, hits: np.ndarray, touching: np.ndarray,
    fill: np.ndarray, event_t: np.ndarray, event_pairs: np.ndarray,
    event_distance: np.ndarray, work: np.ndarray, scratch: np.ndarray, radius: float,
    sensor_range: float, damage_per_hit: float,
) -> int:  # fmt: skip
    """:func:`detect` of the agents in the plane (``SwarmSensorKernel.detect``: the arrays
    :data:`COLUMNS`, the state :attr:`Collisions.state`, then radius, range and damage)."""
    return detect(t, (x, y), radius, sensor_range, distance, heading, hits, touching, fill,
                  event_t, event_pairs, event_distance, work, scratch)  # fmt: skip


@njit(inline="always")
def take_reading(
    a: int, moving: bool, x: np.ndarray, y: np.ndarray, neighbour_distance: np.ndarray,
    neighbour_bearing: np.ndarray, collisions: np.ndarray, damage: np.ndarray,
    distance: np.ndarray, heading: np.ndarray, hits: np.ndarray, touching: np.ndarray,
    fill: np.ndarray, event_t: np.ndarray, event_pairs: np.ndarray,
    event_distance: np.ndarray, work: np.ndarray, scratch: np.ndarray, radius: float,
    sensor_range: float, damage_per_hit: float,
) -> None:  # fmt: skip
    """Agent ``a``'s reading (``SwarmSensorKernel.apply``): the proximity sensor's columns
    where it is powered (``moving``), and ``damage_per_hit`` percent damage (at most 100)
    per new collision: ``CrowdedMission.sense``'s operations for one agent."""
    if moving:
        neighbour_distance[a] = distance[a]
        neighbour_bearing[a] = heading[a]
    count = hits[a]
    if count:
        collisions[a] += count
        damage[a] = np_minimum(damage[a] + count * damage_per_hit, 100.0)


@njit
def bearings(x: np.ndarray, y: np.ndarray, nearest: np.ndarray, out: np.ndarray) -> None:
    """``out[i]``: the bearing from agent i to agent ``nearest[i]`` (degrees clockwise from
    north, :func:`pyautonomousagent.kernels.bearing`, the bits of
    :func:`pyautonomousagent.arrays.bearing`), 0 where ``nearest[i]`` is -1; shape (N,)."""
    for i in range(x.size):
        j = nearest[i]
        out[i] = bearing(x[i], y[i], x[j], y[j]) if j >= 0 else 0.0
