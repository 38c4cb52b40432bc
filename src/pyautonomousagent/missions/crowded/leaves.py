"""The proximity leaves: ``Condition_Collision_Risk`` and ``Action_Avoid_Collision``.

They read the proximity sensor's columns (``neighbour_distance``, ``neighbour_bearing``:
:mod:`pyautonomousagent.missions.crowded.collisions`), written with array expressions for the
py_trees and batched engines and as kernels for the compiled engine (same operations, same
bits: ``+``, ``-``, comparisons).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyautonomousagent.arrays import choose, wrap_degrees
from pyautonomousagent.bt.leaf import Leaf, Port, register_leaf
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS, success_if
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import LeafKernel
from pyautonomousagent.kernels import wrap_degrees as wrap_degrees_of_one
from pyautonomousagent.missions.drones.leaves import SPEED
from pyautonomousagent.state import AgentView
from pyautonomousagent.world import World

#: A neighbour lies ahead when its bearing is within this many degrees of the heading.
AHEAD = 90.0


@njit(inline="always")
def closer_than(a: int, neighbour_distance: np.ndarray, threshold: float) -> int:
    """Condition_Collision_Risk: SUCCESS if ``neighbour_distance[a] < threshold``."""
    return SUCCESS if neighbour_distance[a] < threshold else FAILURE


@njit(inline="always")
def avoid(a: int, heading: np.ndarray, neighbour_bearing: np.ndarray,
          requested_speed: np.ndarray, requested_heading: np.ndarray,
          cruise: float) -> int:  # fmt: skip
    """Action_Avoid_Collision."""
    turn = wrap_degrees_of_one(neighbour_bearing[a] - heading[a])
    ahead = turn < AHEAD or turn > 360.0 - AHEAD
    requested_speed[a] = 0.0 if ahead else cruise
    requested_heading[a] = wrap_degrees_of_one(neighbour_bearing[a] + 180.0)
    return RUNNING


@register_leaf
class ConditionCollisionRisk(Leaf):
    """SUCCESS if the nearest neighbour is closer than ``distance`` (the proximity sensor's
    reading; the sensor sees no farther than its range, ``proximity_range``)."""

    type_name = "Condition_Collision_Risk"
    ports = (Port("distance", float, "collision_risk_distance", 0.0, "world units"),)
    distance: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(agents.neighbour_distance < self.distance)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(closer_than, ("neighbour_distance",), (self.distance,))


@register_leaf
class ActionAvoidCollision(Leaf):
    """Turn away from the nearest neighbour (request the bearing opposite to it); stand
    still while it lies ahead (within 90 degrees of the heading), else fly at ``speed``;
    always RUNNING."""

    type_name = "Action_Avoid_Collision"
    ports = (SPEED,)
    speed: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        towards = agents.neighbour_bearing
        turn = wrap_degrees(towards - agents.heading)
        ahead = (turn < AHEAD) | (turn > 360.0 - AHEAD)
        agents.requested_speed = choose(ahead, 0.0, self.speed)
        agents.requested_heading = wrap_degrees(towards + 180.0)
        return RUNNING

    def kernel(self, world: World) -> LeafKernel:
        names = ("heading", "neighbour_bearing", "requested_speed", "requested_heading")
        return LeafKernel(avoid, names, (self.speed,))
