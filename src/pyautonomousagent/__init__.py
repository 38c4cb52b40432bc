"""pyAutonomousAgent: model how autonomous agents sense, decide and act, with behaviour trees.

The usual entry points::

    from pyautonomousagent import Simulation, load
    sim = Simulation.create(load("gathering"), seed=0).run()
    table = sim.table()          # one row per recorded iteration and agent
"""

from importlib import metadata

from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Parameters, Scenario, ScenarioError, Simulation

try:
    __version__ = metadata.version("pyautonomousagent")
except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = ["Parameters", "Scenario", "ScenarioError", "Simulation", "__version__", "load"]
