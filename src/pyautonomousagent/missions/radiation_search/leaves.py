"""The radiation-search drones' leaves: wander, detect, report ``found``, fly to the report.

Written with array expressions on an :class:`~pyautonomousagent.mission.AgentView`, so the
same code runs for one drone (py_trees engine) or many at once (batched engine); each leaf's
``kernel`` is its form for one drone on the compiled engine (``kernels.py``). Suffix ``_S``:
synchronous (SUCCESS/FAILURE); suffix ``_A``: asynchronous (RUNNING).
"""

from __future__ import annotations

from typing import Any

from pyautonomousagent.arrays import bearing, choose
from pyautonomousagent.bt import RUNNING, SUCCESS, Leaf, Port, register_leaf, success_if
from pyautonomousagent.kernels import ITERATION, LeafKernel, Sends
from pyautonomousagent.mission import AgentView, World
from pyautonomousagent.missions.drones.leaves import (
    ActionNavigateToDestinationA,
    ConditionDestinationReached,
    ConditionRadiationDetected,
)
from pyautonomousagent.missions.radiation_search import kernels as k
from pyautonomousagent.randomness import seed_halves

FOUND = "found"
"""The message type a drone broadcasts when it detects the source: ``x``, ``y`` where."""
REPORTED = ("source_reported", "x_reported_position", "y_reported_position")
"""Blackboard keys: whether the drone knows a reported position (0/1), and where it is."""
REPORTED_ARRAYS = dict(zip(("reported", "to_x", "to_y"), REPORTED, strict=True))
"""The same as the kernels' parameters ``reported, to_x, to_y`` take them (parameter -> key)."""
SPEED = Port("speed", float, "search_speed", 0.0, "world units per iteration")


@register_leaf
class ConditionRadiationAboveThreshold(ConditionRadiationDetected):
    """SUCCESS if the radiation sensor reads more than ``threshold`` percent."""

    type_name = "Condition_Radiation_Above_Threshold"
    above = (k.above,)


@register_leaf
class ConditionSourceReported(Leaf):
    """SUCCESS if the drone knows a reported source position (its own or a ``found``)."""

    type_name = "Condition_Source_Reported"
    keys = REPORTED

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(agents.blackboard.source_reported == 1)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.source_reported, {"reported": REPORTED[0]})


@register_leaf
class ConditionAtReportedPosition(ConditionDestinationReached):
    """SUCCESS if the drone is within ``distance`` of the reported position."""

    type_name = "Condition_At_Reported_Position"
    ports = (Port("distance", float, "source_tolerance", 0.0, "world units"),)
    keys = REPORTED
    target = REPORTED[1:]
    reached = (k.at_reported_position,)


@register_leaf
class ActionReportSourceS(Leaf):
    """Broadcast ``found`` with the drone's position and remember that position; SUCCESS."""

    type_name = "Action_Report_Source_S"
    keys = REPORTED

    def evaluate(self, agents: AgentView, world: World) -> Any:
        self.broadcast(agents, world, FOUND, {"x": agents.x, "y": agents.y})
        bb = agents.blackboard
        bb.source_reported = 1
        bb.x_reported_position = agents.x
        bb.y_reported_position = agents.y
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        names = {"x": "x", "y": "y", **REPORTED_ARRAYS}
        return LeafKernel(k.report_source, names, sends=Sends(FOUND, ("x", "y")))


@register_leaf
class ActionFlyToReportedPositionA(ActionNavigateToDestinationA):
    """Request the heading toward the reported position at ``speed``; RUNNING."""

    type_name = "Action_Fly_To_Reported_Position_A"
    ports = (SPEED,)
    keys = REPORTED
    target = REPORTED[1:]
    fly = (k.fly,)


@register_leaf
class ActionHoverS(Leaf):
    """Request speed 0, keeping the heading; SUCCESS."""

    type_name = "Action_Hover_S"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        agents.requested_speed = 0.0
        agents.requested_heading = agents.heading
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.hover, ("heading", "requested_speed", "requested_heading"))


@register_leaf
class ActionWanderA(Leaf):
    """Fly at ``speed`` on a random heading, drawn anew every ``period`` iterations; within
    ``margin`` of the world's edge, head for the world's centre instead; RUNNING.

    The headings come from :meth:`Leaf.uniform`: the same on both engines for a seed.
    """

    type_name = "Action_Wander_A"
    ports = (
        SPEED,
        Port("period", int, "wander_period", 1, "iterations between new random headings"),
        Port("margin", float, "edge_margin", 0.0,
             "world units: nearer the edge than this, a drone heads for the centre"),
    )  # fmt: skip
    speed: float
    period: int
    margin: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        heading = agents.requested_heading
        if world.iteration % self.period == 0:
            heading = self.uniform(agents, world, 0.0, 360.0)
        x, y, m = agents.x, agents.y, self.margin
        near_edge = (x < m) | (x > world.width - m) | (y < m) | (y > world.height - m)
        centre = bearing(x, y, world.width / 2, world.height / 2)
        agents.requested_heading = choose(near_edge, centre, heading)
        agents.requested_speed = self.speed
        return RUNNING

    def kernel(self, world: World) -> LeafKernel:
        m = float(self.margin)
        constants = (
            *seed_halves(world.random.seed), self.stream, self.period, m,
            world.width - m, world.height - m, world.width / 2, world.height / 2, self.speed,
        )  # fmt: skip
        names = {"t": ITERATION, "x": "x", "y": "y", "requested_speed": "requested_speed",
                 "requested_heading": "requested_heading"}  # fmt: skip
        return LeafKernel(k.wander, names, constants)
