"""The paper's drones, shared by the gathering and patrol missions: leaves, sensors, messages."""

from pyautonomousagent.missions.drones import leaves, measures, trees
from pyautonomousagent.missions.drones.mission import DroneMission
from pyautonomousagent.missions.drones.shared_data import SharedData

__all__ = ["DroneMission", "SharedData", "leaves", "measures", "trees"]
