"""The simulation loop, its phases and the scenario description."""

from pyautonomousagent.simulation.run import Simulation
from pyautonomousagent.simulation.scenario import Parameters, Scenario, ScenarioError

__all__ = ["Parameters", "Scenario", "ScenarioError", "Simulation"]
