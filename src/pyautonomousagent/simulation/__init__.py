"""The simulation loop, its phases, missions and the scenario description."""

from pyautonomousagent.simulation.mission import (
    MISSIONS,
    MessageType,
    Mission,
    WorldObject,
    register_mission,
)
from pyautonomousagent.simulation.params import Param, ScenarioError, Values
from pyautonomousagent.simulation.run import ENGINES, Simulation
from pyautonomousagent.simulation.scenario import Scenario
from pyautonomousagent.simulation.view import SimulationView

__all__ = [
    "ENGINES",
    "MISSIONS",
    "MessageType",
    "Mission",
    "Param",
    "Scenario",
    "ScenarioError",
    "Simulation",
    "SimulationView",
    "Values",
    "WorldObject",
    "register_mission",
]
