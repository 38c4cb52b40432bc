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
from pyautonomousagent.kernels import bearing
from pyautonomousagent.proximity import CellList


@dataclass(frozen=True)
class Reading:
    """One iteration's proximity sensing.

    Attributes:
        distance: distance to the nearest other agent within the sensor's range, world
            units, shape (N,); the range itself where none is within it.
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
    """The pairs within the collision radius at the last check, for counting on entry.

    Args:
        agents: the swarm's size N.
        radius: agents closer than this collide (world units); 0: no collisions.
        sensor_range: the proximity sensor's range (world units); 0: the sensor reads
            nothing (distance 0 is never reported: the range, 0, is).
    """

    def __init__(self, agents: int, radius: float, sensor_range: float) -> None:
        self.agents = agents
        self.radius = float(radius)
        self.range = float(sensor_range)
        self.touching = np.zeros(0, dtype=np.int64)  # pair keys first * N + second, sorted
        if self.active:  # compile (or load from numba's cache) now, in the run's set-up
            CellList((np.zeros(2), np.ones(2)), 1.0).near(1.0, 1.0)

    @property
    def active(self) -> bool:
        """Whether anything is sensed or detected (a radius or a range above 0)."""
        return max(self.radius, self.range) > 0.0

    def sense(self, coordinates: Sequence[np.ndarray]) -> Reading:
        """The proximity readings and the new collisions at the agents' positions.

        Args:
            coordinates: x, y (and z) of every agent, world units, shape (N,) each.
        """
        grid = CellList(coordinates, max(self.radius, self.range))
        near = grid.near(self.range, self.radius, none=self.range)
        heading = np.empty(self.agents)
        bearings(coordinates[0], coordinates[1], near.nearest, heading)
        distance = near.distance
        keys = near.first * self.agents + near.second
        new = ~_members(keys, self.touching)
        self.touching = keys
        return Reading(
            distance, heading, near.first[new], near.second[new], near.pair_distance[new]
        )


@njit
def bearings(x: np.ndarray, y: np.ndarray, nearest: np.ndarray, out: np.ndarray) -> None:
    """``out[i]``: the bearing from agent i to agent ``nearest[i]`` (degrees clockwise from
    north, :func:`pyautonomousagent.kernels.bearing`, the bits of
    :func:`pyautonomousagent.arrays.bearing`), 0 where ``nearest[i]`` is -1; shape (N,)."""
    for i in range(x.size):
        j = nearest[i]
        out[i] = bearing(x[i], y[i], x[j], y[j]) if j >= 0 else 0.0


def _members(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """Which of ``keys`` are in ``sorted_keys`` (ascending), shape of ``keys``."""
    if sorted_keys.size == 0 or keys.size == 0:
        return np.zeros(keys.shape, dtype=bool)
    at = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[at] == keys


def collisions_per_agent(first: np.ndarray, second: np.ndarray, agents: int) -> np.ndarray:
    """How many of the pairs each agent is in, shape (N,) int64."""
    return np.bincount(first, minlength=agents) + np.bincount(second, minlength=agents)
