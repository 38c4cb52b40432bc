"""A user's mission outside the package, with a sensor and leaves of its own, runs fused on the
compiled engine (whole iterations in compiled code) with no edit under engines/ or the loop,
and records the batched engine's bits (issue 26).

The mission ("beacon") lives in a temporary folder, as a user's would: a mission.py with its
sensor (NumPy form and per-agent kernel side by side) and two leaves (each with its kernel),
a tree file and a scenario file.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.testing import check_same_runs, scoped_registrations

pytest.importorskip("numba")

MISSION = '''
"""Drones fly to a beacon and hover once they are near it."""

import numpy as np

from pyautonomousagent.arrays import bearing, hypot
from pyautonomousagent.bt import FAILURE, RUNNING, SUCCESS, Leaf, Port, register_leaf, success_if
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import LeafKernel, Later, SensorKernel
from pyautonomousagent.kernels import bearing as bearing_of_one
from pyautonomousagent.kernels import hypot as hypot_of_one
from pyautonomousagent.mission import Mission, Param, register_mission


@njit
def sense_beacon(a, x, y, beacon_distance, beacon_x, beacon_y):
    """The beacon-distance sensor of agent a; it can always move."""
    beacon_distance[a] = hypot_of_one(x[a] - beacon_x[a], y[a] - beacon_y[a])
    return True


@njit
def near(a, beacon_distance, radius):
    return SUCCESS if beacon_distance[a] <= radius else FAILURE


@njit
def hover(a, requested_speed):
    requested_speed[a] = 0.0
    return RUNNING


@njit
def fly(a, requested_speed, cruise):
    requested_speed[a] = cruise
    return RUNNING


@register_mission
class BeaconMission(Mission):
    name = "beacon"
    description = "drones fly to a beacon and hover near it"
    parameters = (
        Param("beacon_radius", 4.0, "world units", "distance at which the beacon is reached",
              minimum=0.0),
        Param("cruise_speed", 0.7, "world units per iteration", "speed toward the beacon",
              minimum=0.0),
    )
    columns = {"beacon_distance": np.float64}
    meanings = {"beacon_distance": ("world unit", "distance to the beacon")}

    def blackboard(self):
        return {"beacon_x": np.float64, "beacon_y": np.float64}

    def place(self, swarm, world, rng) -> None:
        width, height = self.scenario.world
        swarm.columns["x"][:] = rng.uniform(0.0, width, swarm.size)
        swarm.columns["y"][:] = rng.uniform(0.0, height, swarm.size)
        swarm.blackboard["beacon_x"][:] = width / 2
        swarm.blackboard["beacon_y"][:] = height / 2

    def sense(self, sim):
        s, bb = sim.swarm.columns, sim.swarm.blackboard
        s["beacon_distance"][:] = hypot(s["x"] - bb["beacon_x"], s["y"] - bb["beacon_y"])
        return None

    def compiled_sensors(self, sim):
        return SensorKernel(sense_beacon, ("x", "y", "beacon_distance", "beacon_x", "beacon_y"))


@register_leaf
class ConditionNearBeacon(Leaf):
    type_name = "Condition_Near_Beacon"
    ports = (Port("radius", float, "beacon_radius", 0.0, "world units"),)

    def evaluate(self, agents, world):
        return success_if(agents.beacon_distance <= self.radius)

    def kernel(self, world):
        return LeafKernel(near, ("beacon_distance",), (self.radius,))


@register_leaf
class ActionHoverA(Leaf):
    type_name = "Action_Hover_A"

    def evaluate(self, agents, world):
        agents.requested_speed = 0.0
        return RUNNING

    def kernel(self, world):
        return LeafKernel(hover, ("requested_speed",))


@register_leaf
class ActionFlyToBeaconA(Leaf):
    type_name = "Action_Fly_To_Beacon_A"
    ports = (Port("speed", float, "cruise_speed", 0.0, "world units per iteration"),)

    def evaluate(self, agents, world):
        bb = agents.blackboard
        agents.requested_heading = bearing(agents.x, agents.y, bb.beacon_x, bb.beacon_y)
        agents.requested_speed = self.speed
        return RUNNING

    def kernel(self, world):
        toward = {"x": "x", "y": "y", "to_x": "beacon_x", "to_y": "beacon_y"}  # by parameter
        heading = Later(bearing_of_one, toward, "requested_heading")
        return LeafKernel(fly, ("requested_speed",), (self.speed,), later=heading)
'''

TREE = """<root BTCPP_format="4" main_tree_to_execute="Beacon">
  <BehaviorTree ID="Beacon">
    <ReactiveFallback name="root">
      <Sequence name="arrived">
        <Condition_Near_Beacon name="near"/>
        <Action_Hover_A name="hover"/>
      </Sequence>
      <Action_Fly_To_Beacon_A name="fly"/>
    </ReactiveFallback>
  </BehaviorTree>
</root>
"""

SCENARIO = """name: beacon
description: 40 drones fly to a beacon
mission: mission.py
tree: beacon.xml
agents: 40
iterations: 300
world:
  size: [60, 60]
parameters:
  max_speed: 0.7
  turn_step: 15
"""


@pytest.fixture
def scenario(tmp_path: Path):
    for name, text in (("mission.py", MISSION), ("beacon.xml", TREE), ("scenario.yaml", SCENARIO)):
        (tmp_path / name).write_text(text, encoding="utf-8")
    with scoped_registrations():
        yield load(str(tmp_path / "scenario.yaml"))


def test_a_users_mission_runs_fused_on_the_compiled_engine_with_the_batched_bits(scenario):
    compiled = Simulation.create(scenario, seed=3, engine="compiled")
    assert compiled.engine.why_not_fused(compiled) == ""  # whole iterations in compiled code
    compiled.run()
    batched = Simulation.create(scenario, seed=3, engine="batched")
    batched.run()
    check_same_runs(batched, compiled, ("batched", "compiled"))
    # the mission did something: every drone reached the beacon and hovers there
    columns = compiled.recorder.columns
    assert columns["beacon_distance"][-1].max() <= 4.0
    assert (columns["speed"][-1] == 0.0).all()
    assert columns["beacon_distance"][1].max() > 10.0  # (record 0: before the first sensing)
