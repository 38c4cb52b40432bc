"""pyAutonomousAgent: model how autonomous agents sense, decide and act, with behaviour trees.

The usual entry points::

    from pyautonomousagent import Simulation, load
    sim = Simulation.create(load("gathering"), seed=0).run()
    table = sim.table()          # one row per recorded iteration and agent

Missions (what a user adds: agents, sensors, messages, world objects) are in
:mod:`pyautonomousagent.mission`; leaves in :mod:`pyautonomousagent.bt`.
"""

from importlib import metadata

from pyautonomousagent import missions  # noqa: F401  (registers the built-in missions)
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Scenario, ScenarioError, Simulation

try:
    __version__ = metadata.version("pyautonomousagent")
except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = ["Scenario", "ScenarioError", "Simulation", "__version__", "load"]
