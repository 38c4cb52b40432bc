"""The paper's performance scenario (Fig. 11-12, Tables 4 and 5): drones patrol between two
surveillance positions and refuel at low energy (also flown by the Skywalker X8)."""

from pyautonomousagent.missions.patrol import x8
from pyautonomousagent.missions.patrol.mission import PatrolMission

__all__ = ["PatrolMission", "x8"]
