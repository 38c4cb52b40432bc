"""The public mission API: everything a user's mission file imports.

A mission (agents, sensors, messages, world objects, marks) is a subclass of
:class:`Mission`; its leaves are :class:`~pyautonomousagent.bt.leaf.Leaf` subclasses
registered with :func:`~pyautonomousagent.bt.leaf.register_leaf`. See docs/missions.md.
"""

from pyautonomousagent.datalink import Delivery
from pyautonomousagent.models.drone2d import next_position
from pyautonomousagent.recording import Recorder
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation.mission import (
    MISSIONS,
    MessageType,
    Mission,
    WorldObject,
    register_mission,
)
from pyautonomousagent.simulation.params import Param, Point, Reader, ScenarioError, Values
from pyautonomousagent.simulation.run import Simulation
from pyautonomousagent.simulation.scenario import Scenario, check_point_in_world
from pyautonomousagent.simulation.scenario_view import ScenarioView
from pyautonomousagent.simulation.view import SimulationView
from pyautonomousagent.state import AgentView, Swarm
from pyautonomousagent.world import World

__all__ = [
    "MISSIONS",
    "AgentView",
    "Delivery",
    "Mark",
    "MessageType",
    "Mission",
    "Param",
    "Point",
    "Reader",
    "Recorder",
    "Scenario",
    "ScenarioError",
    "ScenarioView",
    "Simulation",
    "SimulationView",
    "Swarm",
    "Values",
    "World",
    "WorldObject",
    "check_point_in_world",
    "next_position",
    "register_mission",
]
