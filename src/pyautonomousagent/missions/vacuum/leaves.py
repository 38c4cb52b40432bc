"""The vacuum robot's leaves (the paper's Fig. 2): collision condition, avoid, navigate, vacuum.

Written with array expressions on an :class:`~pyautonomousagent.mission.AgentView`, so the
same code runs for one robot (py_trees engine) or many at once (batched engine); each leaf's
``kernel`` is its form for one robot on the compiled engine (``kernels.py``). As in Fig. 2,
every action returns SUCCESS when it is ticked.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyautonomousagent.arrays import choose, maximum, minimum, wrap_degrees
from pyautonomousagent.bt import SUCCESS, Leaf, Port, register_leaf, success_if
from pyautonomousagent.kernels import ITERATION, LeafKernel
from pyautonomousagent.mission import AgentView, World
from pyautonomousagent.missions.vacuum import kernels as k
from pyautonomousagent.randomness import seed_halves

CRUISE = ("cruise_heading",)
"""The blackboard key of the heading a robot holds while navigating (degrees)."""


@register_leaf
class ConditionCollision(Leaf):
    """SUCCESS if the sonar reads less than ``distance``: an obstacle or wall is close ahead."""

    type_name = "Condition_Collision"
    ports = (Port("distance", float, "collision_distance", 0.0,
                  "world units: sonar readings below it are a collision situation"),)  # fmt: skip
    distance: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(agents.sonar < self.distance)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.collision, ("sonar",), (self.distance,))


@register_leaf
class ActionAvoidObstacleS(Leaf):
    """Stop and turn left or right, away from the obstacle ahead; SUCCESS.

    When the robot holds its cruise heading (its last turn is complete), it draws a side
    (left or right, even odds) and an angle in [``min_angle``, ``max_angle``] and makes the
    turned heading its new cruise heading; while that turn is under way it keeps it. Angles
    are whole multiples of ``step`` (the motion model's ``turn_step``; ``step * floor(angle
    / step)``, correctly rounded operations that give the same bits on every CPU and a GPU,
    where a float remainder may not): a robot starting on whole degrees then turns exactly
    onto its target. The draws use :meth:`Leaf.uniform`, so they are the same on all
    engines.
    """

    type_name = "Action_Avoid_Obstacle_S"
    ports = (
        Port("min_angle", float, "avoid_min_angle", 0.0, "degrees: the smallest turn"),
        Port("max_angle", float, "avoid_max_angle", 0.0, "degrees: the largest turn"),
        Port("step", float, "turn_step", 0.0,
             "degrees: turns are whole multiples of it (the motion model's turn per iteration)"),
    )  # fmt: skip
    keys = CRUISE
    min_angle: float
    max_angle: float
    step: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        heading, cruise = agents.heading, bb.cruise_heading
        off = wrap_degrees(heading - cruise)
        off = minimum(off, 360.0 - off)  # degrees still to turn, [0, 180]
        settled = off < self.step if self.step > 0.0 else off <= 0.0
        right = self.uniform(agents, world, draw=0) < 0.5
        angle = self.uniform(agents, world, self.min_angle, self.max_angle, draw=1)
        if self.step > 0.0:
            angle = maximum(self.step * np.floor(angle / self.step), self.step)
        turned = wrap_degrees(heading + choose(right, angle, -angle))
        cruise = choose(settled, turned, cruise)
        bb.cruise_heading = cruise
        agents.requested_heading = cruise
        agents.requested_speed = 0.0
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        names = {"t": ITERATION, "heading": "heading", "cruise_heading": CRUISE[0],
                 "requested_speed": "requested_speed",
                 "requested_heading": "requested_heading"}  # fmt: skip
        constants = (*seed_halves(world.random.seed), self.stream, float(self.min_angle),
                     float(self.max_angle), float(self.step))  # fmt: skip
        return LeafKernel(k.avoid, names, constants)


@register_leaf
class ActionNavigateS(Leaf):
    """Drive straight ahead on the cruise heading at ``speed``; SUCCESS."""

    type_name = "Action_Navigate_S"
    ports = (Port("speed", float, "robot_speed", 0.0, "world units per iteration"),)
    keys = CRUISE
    speed: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        agents.requested_heading = agents.blackboard.cruise_heading
        agents.requested_speed = self.speed
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        names = (*CRUISE, "requested_speed", "requested_heading")
        return LeafKernel(k.navigate, names, (float(self.speed),))


@register_leaf
class ActionVacuumS(Leaf):
    """Switch the brush on for this iteration (the cell under the robot is cleaned); SUCCESS."""

    type_name = "Action_Vacuum_S"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        agents.vacuuming = 1
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.brush, ("vacuuming",))
