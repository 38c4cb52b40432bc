"""Every leaf of the library, for one agent and for a batch, with every side effect.

A batch is an :class:`AgentView` with an index array; it leaves the other agents' rows alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent import load
from pyautonomousagent.bt import leaf, sequence
from pyautonomousagent.bt.leaf import LEAF_TYPES, Leaf, LeafError, leaf_type
from pyautonomousagent.bt.spec import TreeError
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.bt.vocabulary import BTCPP_LEAVES
from pyautonomousagent.engines.pytrees import PyTreesEngine
from pyautonomousagent.missions.drones.leaves import GATHERING, SHARING_DATA
from pyautonomousagent.scenarios import names as scenario_names

from .conftest import default_parameters, on_channel

DEFAULTS = default_parameters()
BATCH = np.array([0, 2])  # agents 0 and 2 of three; agent 1 must stay untouched

#: Leaf types covered by this file (kept in step with the registry, see the last test).
COVERED = {
    "Condition_Destination_Reached",
    "Condition_Low_Energy_Level",
    "Condition_Gathering_Moment",
    "Condition_Radiation_Detected",
    "Condition_High_Damage_Level",
    "Action_Navigate_To_Destination_A",
    "Action_Set_Destination_Equal_To_Surveillance_S",
    "Action_Set_Destination_Equal_To_Refueling_S",
    "Action_Set_Destination_Equal_To_Other_Surveillance_S",
    "Action_Set_Destination_Equal_To_Current_Surveillance_S",
    "Action_Transmit_Gathering_Message_S",
    "Action_Transmit_Shared_Data_S",
    "Action_Refuel_A",
    "Action_Repair_Damage_A",
}
#: Mission packages whose leaves are tested in their mission's own test file
#: (tests/test_vacuum.py, tests/test_radiation_search.py, tests/test_x8_landing.py,
#: tests/test_drone3d.py, tests/test_collisions.py).
OWN_TESTS = (
    "pyautonomousagent.missions.vacuum",
    "pyautonomousagent.missions.radiation_search",
    "pyautonomousagent.missions.patrol.x8",
    "pyautonomousagent.missions.drones3d",
    "pyautonomousagent.missions.crowded",
)


def make(type_name: str, **params) -> Leaf:
    assert type_name in COVERED
    return leaf_type(type_name).create(params, DEFAULTS, where=f"test {type_name}")


def statuses(result, n: int) -> list[int]:
    """A leaf's result for a batch of ``n`` agents as a list of codes."""
    return [int(s) for s in np.broadcast_to(result, (n,))]


def snapshot(swarm):
    return (
        {k: v.copy() for k, v in swarm.columns.items()},
        {k: v.copy() for k, v in swarm.blackboard.items()},
    )


def assert_unchanged(swarm, before, rows=None, except_columns=(), except_keys=()):
    """Nothing changed in ``rows`` (all rows if None) besides the named columns/keys."""
    columns, board = before
    sel = slice(None) if rows is None else rows
    for k, v in swarm.columns.items():
        if k not in except_columns:
            np.testing.assert_array_equal(v[sel], columns[k][sel], err_msg=k)
    for k, v in swarm.blackboard.items():
        if k not in except_keys:
            np.testing.assert_array_equal(v[sel], board[k][sel], err_msg=k)


# --------------------------------------------------------------------------- conditions


class TestConditionDestinationReached:
    T = "Condition_Destination_Reached"

    def place(self, swarm, i, x, y, dx, dy):
        swarm.columns["x"][i], swarm.columns["y"][i] = x, y
        swarm.blackboard["x_current_destination_position"][i] = dx
        swarm.blackboard["y_current_destination_position"][i] = dy

    def test_default_tolerance_from_parameters(self):
        assert make(self.T).distance == 0.5

    @pytest.mark.parametrize(
        ("x", "y", "expected"),
        [
            (10.0, 10.0, SUCCESS),  # on the destination
            (10.5, 10.0, SUCCESS),  # exactly 0.5 east
            (10.0, 9.5, SUCCESS),  # exactly 0.5 south
            (9.5, 10.0, SUCCESS),
            (10.500001, 10.0, FAILURE),  # just outside
            (10.0, 10.500001, FAILURE),
            (10.36, 10.36, FAILURE),  # 0.509 diagonally
            (10.35, 10.35, SUCCESS),  # 0.495 diagonally
        ],
    )
    def test_one_agent(self, swarm_world, x, y, expected):
        swarm, world = swarm_world(1)
        self.place(swarm, 0, x, y, 10.0, 10.0)
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == expected
        assert_unchanged(swarm, before)
        assert world.datalink.channel == []

    def test_exact_boundary_with_overridden_distance(self, swarm_world):
        swarm, world = swarm_world(1)
        # 0.375**2 + 0.5**2 == 0.625**2 exactly in binary floating point
        self.place(swarm, 0, 1.375, 2.5, 1.0, 2.0)
        assert make(self.T, distance=0.625).evaluate(swarm.agent(0), world) == SUCCESS
        assert make(self.T, distance=0.624).evaluate(swarm.agent(0), world) == FAILURE
        assert make(self.T).evaluate(swarm.agent(0), world) == FAILURE

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        self.place(swarm, 0, 10.5, 10.0, 10.0, 10.0)  # exactly 0.5: reached
        self.place(swarm, 1, 10.0, 10.0, 10.0, 10.0)
        self.place(swarm, 2, 50.0, 50.0, 10.0, 10.0)  # far
        before = snapshot(swarm)
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, FAILURE]
        assert_unchanged(swarm, before)


class TestConditionLowEnergyLevel:
    T = "Condition_Low_Energy_Level"

    @pytest.mark.parametrize(
        ("energy", "expected"),
        [(40.0, SUCCESS), (39.99, SUCCESS), (0.0, SUCCESS), (40.000001, FAILURE), (100.0, FAILURE)],
    )
    def test_one_agent(self, swarm_world, energy, expected):
        swarm, world = swarm_world(1)
        swarm.columns["energy"][0] = energy
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == expected
        assert_unchanged(swarm, before)

    def test_threshold_default_and_override(self, swarm_world):
        assert make(self.T).threshold == 40.0
        swarm, world = swarm_world(1)
        swarm.columns["energy"][0] = 45.0
        assert make(self.T).evaluate(swarm.agent(0), world) == FAILURE
        assert make(self.T, threshold=50).evaluate(swarm.agent(0), world) == SUCCESS
        assert make(self.T, threshold=45.0).evaluate(swarm.agent(0), world) == SUCCESS

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        swarm.columns["energy"][:] = [40.0, 10.0, 40.5]
        before = snapshot(swarm)
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, FAILURE]
        assert_unchanged(swarm, before)


class TestConditionGatheringMoment:
    T = "Condition_Gathering_Moment"

    def test_defaults(self):
        node = make(self.T)
        assert (node.iteration, node.sender) == (5000, "drone1")

    @pytest.mark.parametrize(
        ("iteration", "agent", "expected"),
        [(5000, 0, SUCCESS), (4999, 0, FAILURE), (5001, 0, FAILURE), (5000, 1, FAILURE)],
    )
    def test_one_agent(self, swarm_world, iteration, agent, expected):
        swarm, world = swarm_world(2)
        world.iteration = iteration
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(agent), world) == expected
        assert_unchanged(swarm, before)

    def test_overridden_ports(self, swarm_world):
        swarm, world = swarm_world(3)
        world.iteration = 7
        node = make(self.T, iteration=7, sender="drone3")
        assert [node.evaluate(swarm.agent(i), world) for i in range(3)] == [
            FAILURE,
            FAILURE,
            SUCCESS,
        ]

    def test_unknown_sender_never_succeeds(self, swarm_world):
        swarm, world = swarm_world(2)
        world.iteration = 5000
        node = make(self.T, sender="nobody")
        assert [node.evaluate(swarm.agent(i), world) for i in range(2)] == [FAILURE, FAILURE]

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        world.iteration = 5000
        before = snapshot(swarm)
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, FAILURE]
        world.iteration = 4999
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [FAILURE, FAILURE]
        result = make(self.T, sender="drone3", iteration=4999).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [FAILURE, SUCCESS]
        assert_unchanged(swarm, before)


class TestConditionRadiationDetected:
    T = "Condition_Radiation_Detected"

    @pytest.mark.parametrize(
        ("level", "expected"), [(0.0, FAILURE), (0.001, SUCCESS), (100.0, SUCCESS)]
    )
    def test_one_agent(self, swarm_world, level, expected):
        swarm, world = swarm_world(1)
        swarm.columns["radiation"][0] = level
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == expected
        assert_unchanged(swarm, before)

    def test_threshold_override_is_strict(self, swarm_world):
        swarm, world = swarm_world(1)
        swarm.columns["radiation"][0] = 20.0
        assert make(self.T, threshold=20).evaluate(swarm.agent(0), world) == FAILURE
        assert make(self.T, threshold=19.9).evaluate(swarm.agent(0), world) == SUCCESS

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        swarm.columns["radiation"][:] = [0.0, 50.0, 5.0]
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [FAILURE, SUCCESS]


class TestConditionHighDamageLevel:
    T = "Condition_High_Damage_Level"

    @pytest.mark.parametrize(
        ("damage", "expected"),
        [(70.0, SUCCESS), (69.999, FAILURE), (100.0, SUCCESS), (0.0, FAILURE)],
    )
    def test_one_agent(self, swarm_world, damage, expected):
        swarm, world = swarm_world(1)
        swarm.columns["damage"][0] = damage
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == expected
        assert_unchanged(swarm, before)

    def test_threshold_override(self, swarm_world):
        swarm, world = swarm_world(1)
        swarm.columns["damage"][0] = 10.0
        assert make(self.T, threshold=10).evaluate(swarm.agent(0), world) == SUCCESS

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        swarm.columns["damage"][:] = [10.0, 90.0, 70.0]
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [FAILURE, SUCCESS]


# --------------------------------------------------------------------------- navigation


class TestActionNavigateToDestinationA:
    T = "Action_Navigate_To_Destination_A"

    @pytest.mark.parametrize(
        ("dest", "heading"),
        [((10.0, 20.0), 0.0), ((20.0, 10.0), 90.0), ((10.0, 0.0), 180.0), ((0.0, 10.0), 270.0),
         ((20.0, 20.0), 45.0), ((0.0, 0.0), 225.0), ((0.0, 20.0), 315.0)],
    )  # fmt: skip
    def test_one_agent_requests_bearing_and_cruise_speed(self, swarm_world, dest, heading):
        swarm, world = swarm_world(1)
        swarm.columns["x"][0], swarm.columns["y"][0] = 10.0, 10.0
        swarm.columns["heading"][0], swarm.columns["speed"][0] = 123.0, 0.05
        bb = swarm.agent(0).blackboard
        bb.x_current_destination_position, bb.y_current_destination_position = dest
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == RUNNING
        assert swarm.columns["requested_heading"][0] == pytest.approx(heading, abs=1e-12)
        assert swarm.columns["requested_speed"][0] == 0.1
        assert_unchanged(swarm, before, except_columns=("requested_heading", "requested_speed"))
        assert world.datalink.channel == []

    def test_speed_port_override(self, swarm_world):
        swarm, world = swarm_world(1)
        swarm.blackboard["y_current_destination_position"][0] = 5.0
        assert make(self.T, speed=0.05).evaluate(swarm.agent(0), world) == RUNNING
        assert swarm.columns["requested_speed"][0] == 0.05
        assert swarm.columns["requested_heading"][0] == 0.0

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        swarm.columns["x"][:] = [10.0, 10.0, 10.0]
        swarm.columns["y"][:] = [10.0, 10.0, 10.0]
        swarm.blackboard["x_current_destination_position"][:] = [20.0, 0.0, 10.0]
        swarm.blackboard["y_current_destination_position"][:] = [10.0, 0.0, 0.0]
        swarm.columns["requested_heading"][1] = 7.0
        swarm.columns["requested_speed"][1] = 0.02
        before = snapshot(swarm)
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [RUNNING, RUNNING]
        np.testing.assert_allclose(
            swarm.columns["requested_heading"], [90.0, 7.0, 180.0], atol=1e-12
        )
        np.testing.assert_array_equal(swarm.columns["requested_speed"], [0.1, 0.02, 0.1])
        assert_unchanged(swarm, before, except_columns=("requested_heading", "requested_speed"))


class TestSetDestination:
    def setup_board(self, swarm):
        bb = swarm.blackboard
        bb["x_surveillance_position"][:] = [50.0, 70.0, 40.0][: swarm.size]
        bb["y_surveillance_position"][:] = [51.0, 80.0, 70.0][: swarm.size]
        bb["x_refueling_position"][:] = [20.0, 20.0, 20.0][: swarm.size]
        bb["y_refueling_position"][:] = [65.0, 55.0, 45.0][: swarm.size]
        bb["x_current_destination_position"][:] = -1.0
        bb["y_current_destination_position"][:] = -2.0

    @pytest.mark.parametrize(
        ("type_name", "source"),
        [
            ("Action_Set_Destination_Equal_To_Surveillance_S", "surveillance"),
            ("Action_Set_Destination_Equal_To_Refueling_S", "refueling"),
        ],
    )
    def test_one_agent(self, swarm_world, type_name, source):
        swarm, world = swarm_world(1)
        self.setup_board(swarm)
        before = snapshot(swarm)
        assert make(type_name).evaluate(swarm.agent(0), world) == SUCCESS
        bb = swarm.agent(0).blackboard
        assert bb.x_current_destination_position == bb.as_dict()[f"x_{source}_position"]
        assert bb.y_current_destination_position == bb.as_dict()[f"y_{source}_position"]
        expected = {"surveillance": (50.0, 51.0), "refueling": (20.0, 65.0)}[source]
        assert (bb.x_current_destination_position, bb.y_current_destination_position) == expected
        assert_unchanged(swarm, before, except_keys=("x_current_destination_position",
                                                     "y_current_destination_position"))  # fmt: skip

    @pytest.mark.parametrize(
        ("type_name", "xs", "ys"),
        [
            (
                "Action_Set_Destination_Equal_To_Surveillance_S",
                [50.0, -1.0, 40.0],
                [51.0, -2.0, 70.0],
            ),
            ("Action_Set_Destination_Equal_To_Refueling_S", [20.0, -1.0, 20.0], [65.0, -2.0, 45.0]),
        ],
    )
    def test_batch(self, swarm_world, type_name, xs, ys):
        swarm, world = swarm_world(3)
        self.setup_board(swarm)
        before = snapshot(swarm)
        result = make(type_name).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, SUCCESS]
        np.testing.assert_array_equal(swarm.blackboard["x_current_destination_position"], xs)
        np.testing.assert_array_equal(swarm.blackboard["y_current_destination_position"], ys)
        assert_unchanged(swarm, before, except_keys=("x_current_destination_position",
                                                     "y_current_destination_position"))  # fmt: skip


class TestPatrolDestinations:
    OTHER = "Action_Set_Destination_Equal_To_Other_Surveillance_S"
    CURRENT = "Action_Set_Destination_Equal_To_Current_Surveillance_S"
    CHANGED = (
        "index_current_surveillance_position",
        "x_surveillance_position",
        "y_surveillance_position",
        "x_current_destination_position",
        "y_current_destination_position",
    )

    def setup_board(self, swarm, indices):
        bb = swarm.blackboard
        bb["x_surveillance_position_1"][:], bb["y_surveillance_position_1"][:] = 70.0, 80.0
        bb["x_surveillance_position_2"][:], bb["y_surveillance_position_2"][:] = 71.0, 20.0
        bb["index_current_surveillance_position"][:] = indices
        bb["x_surveillance_position"][:] = -5.0
        bb["y_surveillance_position"][:] = -6.0
        bb["x_current_destination_position"][:] = -1.0
        bb["y_current_destination_position"][:] = -2.0

    @pytest.mark.parametrize(
        ("type_name", "index", "new_index", "point"),
        [
            (OTHER, 1, 2, (71.0, 20.0)),
            (OTHER, 2, 1, (70.0, 80.0)),
            (CURRENT, 1, 1, (70.0, 80.0)),
            (CURRENT, 2, 2, (71.0, 20.0)),
        ],
    )
    def test_one_agent(self, swarm_world, type_name, index, new_index, point):
        swarm, world = swarm_world(1)
        self.setup_board(swarm, [index])
        before = snapshot(swarm)
        assert make(type_name).evaluate(swarm.agent(0), world) == SUCCESS
        bb = swarm.agent(0).blackboard
        assert bb.index_current_surveillance_position == new_index
        assert (bb.x_surveillance_position, bb.y_surveillance_position) == point
        assert (bb.x_current_destination_position, bb.y_current_destination_position) == point
        assert_unchanged(swarm, before, except_keys=self.CHANGED)

    def test_other_twice_returns_to_the_first(self, swarm_world):
        swarm, world = swarm_world(1)
        self.setup_board(swarm, [1])
        node = make(self.OTHER)
        node.evaluate(swarm.agent(0), world)
        node.evaluate(swarm.agent(0), world)
        bb = swarm.agent(0).blackboard
        assert bb.index_current_surveillance_position == 1
        assert (bb.x_current_destination_position, bb.y_current_destination_position) == (
            70.0,
            80.0,
        )

    def test_batch_other(self, swarm_world):
        swarm, world = swarm_world(3)
        self.setup_board(swarm, [1, 1, 2])
        before = snapshot(swarm)
        result = make(self.OTHER).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, SUCCESS]
        bb = swarm.blackboard
        np.testing.assert_array_equal(bb["index_current_surveillance_position"], [2, 1, 1])
        np.testing.assert_array_equal(bb["x_surveillance_position"], [71.0, -5.0, 70.0])
        np.testing.assert_array_equal(bb["y_surveillance_position"], [20.0, -6.0, 80.0])
        np.testing.assert_array_equal(bb["x_current_destination_position"], [71.0, -1.0, 70.0])
        np.testing.assert_array_equal(bb["y_current_destination_position"], [20.0, -2.0, 80.0])
        assert_unchanged(swarm, before, except_keys=self.CHANGED)
        assert_unchanged(swarm, before, rows=1)

    def test_batch_current(self, swarm_world):
        swarm, world = swarm_world(3)
        self.setup_board(swarm, [2, 1, 1])
        before = snapshot(swarm)
        result = make(self.CURRENT).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, SUCCESS]
        bb = swarm.blackboard
        np.testing.assert_array_equal(bb["index_current_surveillance_position"], [2, 1, 1])
        np.testing.assert_array_equal(bb["x_current_destination_position"], [71.0, -1.0, 70.0])
        np.testing.assert_array_equal(bb["y_current_destination_position"], [20.0, -2.0, 80.0])
        np.testing.assert_array_equal(bb["y_surveillance_position"], [20.0, -6.0, 80.0])
        assert_unchanged(swarm, before, except_keys=self.CHANGED)
        assert_unchanged(swarm, before, rows=1)


# --------------------------------------------------------------------------- transmission


class TestTransmit:
    GATHER = "Action_Transmit_Gathering_Message_S"
    SHARE = "Action_Transmit_Shared_Data_S"

    def setup_state(self, swarm):
        s = swarm.columns
        s["x"][:] = [1.0, 2.0, 3.0][: swarm.size]
        s["y"][:] = [4.0, 5.0, 6.0][: swarm.size]
        s["speed"][:] = [0.1, 0.0, 0.05][: swarm.size]
        s["heading"][:] = [10.0, 20.0, 30.0][: swarm.size]
        s["damage"][:] = [0.0, 1.0, 2.0][: swarm.size]
        s["energy"][:] = [100.0, 90.0, 80.0][: swarm.size]
        swarm.blackboard["x_surveillance_position"][:] = [50.0, 70.0, 40.0][: swarm.size]
        swarm.blackboard["y_surveillance_position"][:] = [50.0, 80.0, 70.0][: swarm.size]

    def test_gathering_one_agent(self, swarm_world):
        swarm, world = swarm_world(2)
        self.setup_state(swarm)
        before = snapshot(swarm)
        assert make(self.GATHER).evaluate(swarm.agent(1), world) == SUCCESS
        assert on_channel(world.datalink) == [
            (1, GATHERING, {"x": 70.0, "y": 80.0}, (2.0, 5.0), None)
        ]
        assert_unchanged(swarm, before)

    def test_gathering_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        self.setup_state(swarm)
        before = snapshot(swarm)
        result = make(self.GATHER).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, SUCCESS]
        assert on_channel(world.datalink) == [
            (0, GATHERING, {"x": 50.0, "y": 50.0}, (1.0, 4.0), None),
            (2, GATHERING, {"x": 40.0, "y": 70.0}, (3.0, 6.0), None),
        ]
        assert_unchanged(swarm, before)

    def test_shared_data_one_agent(self, swarm_world):
        swarm, world = swarm_world(3)
        self.setup_state(swarm)
        before = snapshot(swarm)
        assert make(self.SHARE).evaluate(swarm.agent(2), world) == SUCCESS
        data = {"x": 3.0, "y": 6.0, "speed": 0.05, "heading": 30.0, "damage": 2.0, "energy": 80.0}
        assert on_channel(world.datalink) == [(2, SHARING_DATA, data, (3.0, 6.0), None)]
        assert_unchanged(swarm, before)

    def test_shared_data_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        self.setup_state(swarm)
        before = snapshot(swarm)
        result = make(self.SHARE).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, SUCCESS]
        first = {"x": 1.0, "y": 4.0, "speed": 0.1, "heading": 10.0, "damage": 0.0, "energy": 100.0}
        third = {"x": 3.0, "y": 6.0, "speed": 0.05, "heading": 30.0, "damage": 2.0, "energy": 80.0}
        assert on_channel(world.datalink) == [
            (0, SHARING_DATA, first, (1.0, 4.0), None),
            (2, SHARING_DATA, third, (3.0, 6.0), None),
        ]
        assert_unchanged(swarm, before)

    def test_messages_are_snapshots(self, swarm_world):
        swarm, world = swarm_world(1)
        self.setup_state(swarm)
        make(self.SHARE).evaluate(swarm.agent(0), world)
        swarm.columns["x"][0] = 99.0
        ((_, _, data, position, _),) = on_channel(world.datalink)
        assert (data["x"], position) == (1.0, (1.0, 4.0))

    def test_delivered_to_the_other_agents(self, swarm_world):
        swarm, world = swarm_world(3)
        self.setup_state(swarm)
        make(self.GATHER).evaluate(swarm.agent(0), world)
        (delivery,) = world.datalink.deliver(swarm.columns["x"], swarm.columns["y"])
        receivers, rows = delivery.pairs(3)
        assert receivers.tolist() == [1, 2]
        assert delivery.messages.senders[rows].tolist() == [0, 0]


# --------------------------------------------------------------------------- refuel / repair


class TestActionRefuelA:
    T = "Action_Refuel_A"

    def test_defaults(self):
        node = make(self.T)
        assert (node.rate, node.speed) == (2.0, 0.1)

    @pytest.mark.parametrize(
        ("energy", "after", "expected", "requested_speed"),
        [
            (50.0, 52.0, RUNNING, 0.0),
            (97.0, 99.0, RUNNING, 0.0),
            (97.95, 99.95, RUNNING, 0.0),  # not yet full
            (98.0, 100.0, SUCCESS, 0.1),  # reaches exactly 100
            (99.5, 100.0, SUCCESS, 0.1),  # clipped to 100
            (100.0, 100.0, SUCCESS, 0.1),
            (0.0, 2.0, RUNNING, 0.0),
        ],
    )
    def test_one_agent(self, swarm_world, energy, after, expected, requested_speed):
        swarm, world = swarm_world(1)
        s = swarm.columns
        s["energy"][0], s["heading"][0], s["speed"][0] = energy, 123.0, 0.1
        s["requested_heading"][0], s["requested_speed"][0] = 300.0, 0.07
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == expected
        assert s["energy"][0] == after
        assert s["requested_speed"][0] == requested_speed
        assert s["requested_heading"][0] == 123.0  # keeps its heading
        assert_unchanged(
            swarm, before, except_columns=("energy", "requested_speed", "requested_heading")
        )

    def test_rate_and_speed_override(self, swarm_world):
        swarm, world = swarm_world(1)
        swarm.columns["energy"][0] = 90.0
        node = make(self.T, rate=10, speed=0.05)
        assert node.evaluate(swarm.agent(0), world) == SUCCESS
        assert swarm.columns["energy"][0] == 100.0
        assert swarm.columns["requested_speed"][0] == 0.05

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        s = swarm.columns
        s["energy"][:] = [98.0, 10.0, 50.0]
        s["heading"][:] = [10.0, 20.0, 30.0]
        s["requested_heading"][:] = [1.0, 2.0, 3.0]
        s["requested_speed"][:] = [0.03, 0.04, 0.05]
        before = snapshot(swarm)
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [SUCCESS, RUNNING]
        np.testing.assert_array_equal(s["energy"], [100.0, 10.0, 52.0])
        np.testing.assert_array_equal(s["requested_speed"], [0.1, 0.04, 0.0])
        np.testing.assert_array_equal(s["requested_heading"], [10.0, 2.0, 30.0])
        assert_unchanged(
            swarm, before, except_columns=("energy", "requested_speed", "requested_heading")
        )


class TestActionRepairDamageA:
    T = "Action_Repair_Damage_A"

    def test_defaults(self):
        node = make(self.T)
        assert (node.rate, node.speed) == (1.0, 0.1)

    @pytest.mark.parametrize(
        ("damage", "after", "expected", "requested_speed"),
        [
            (5.0, 4.0, RUNNING, 0.0),
            (1.5, 0.5, RUNNING, 0.0),  # not yet repaired
            (1.0, 0.0, SUCCESS, 0.1),  # repaired to exactly 0
            (0.5, 0.0, SUCCESS, 0.1),  # clipped at 0
            (0.0, 0.0, SUCCESS, 0.1),
            (70.0, 69.0, RUNNING, 0.0),
        ],
    )
    def test_one_agent(self, swarm_world, damage, after, expected, requested_speed):
        swarm, world = swarm_world(1)
        s = swarm.columns
        s["damage"][0], s["heading"][0] = damage, 45.0
        s["requested_heading"][0], s["requested_speed"][0] = 300.0, 0.07
        before = snapshot(swarm)
        assert make(self.T).evaluate(swarm.agent(0), world) == expected
        assert s["damage"][0] == after
        assert s["requested_speed"][0] == requested_speed
        assert s["requested_heading"][0] == 45.0
        assert_unchanged(
            swarm, before, except_columns=("damage", "requested_speed", "requested_heading")
        )

    def test_rate_override(self, swarm_world):
        swarm, world = swarm_world(1)
        swarm.columns["damage"][0] = 30.0
        assert make(self.T, rate=30.0).evaluate(swarm.agent(0), world) == SUCCESS
        assert swarm.columns["damage"][0] == 0.0

    def test_batch(self, swarm_world):
        swarm, world = swarm_world(3)
        s = swarm.columns
        s["damage"][:] = [10.0, 50.0, 1.0]
        s["heading"][:] = [10.0, 20.0, 30.0]
        s["requested_speed"][:] = [0.03, 0.04, 0.05]
        s["requested_heading"][:] = [1.0, 2.0, 3.0]
        before = snapshot(swarm)
        result = make(self.T).evaluate(swarm.agents(BATCH), world)
        assert statuses(result, 2) == [RUNNING, SUCCESS]
        np.testing.assert_array_equal(s["damage"], [9.0, 50.0, 0.0])
        np.testing.assert_array_equal(s["requested_speed"], [0.0, 0.04, 0.1])
        np.testing.assert_array_equal(s["requested_heading"], [10.0, 2.0, 30.0])
        assert_unchanged(
            swarm, before, except_columns=("damage", "requested_speed", "requested_heading")
        )


# --------------------------------------------------------------------------- ports and errors


def test_port_defaults_come_from_the_given_parameters():
    params = vars(
        load("gathering").with_overrides(low_energy_threshold=25.0, reference_speed=0.07).parameters
    )
    low = leaf_type("Condition_Low_Energy_Level").create({}, params, "t")
    nav = leaf_type("Action_Navigate_To_Destination_A").create({}, params, "t")
    assert (low.threshold, nav.speed) == (25.0, 0.07)
    # a port given in the tree wins over the default
    low = leaf_type("Condition_Low_Energy_Level").create({"threshold": 30}, params, "t")
    assert low.threshold == 30.0
    assert type(low.threshold) is float


def test_every_port_default_names_a_parameter():
    names = set().union(*(vars(load(name).parameters) for name in scenario_names()))
    for cls in LEAF_TYPES.values():
        for port in cls.ports:
            assert port.default in names, (cls.type_name, port.name)


def test_unknown_port_names_the_leaf_and_the_known_ports():
    with pytest.raises(LeafError, match=r"unknown port\(s\) \['treshold'\]") as info:
        leaf_type("Condition_Low_Energy_Level").create({"treshold": 3}, DEFAULTS, "leaf 'low'")
    assert "leaf 'low'" in str(info.value)
    assert "threshold" in str(info.value)


@pytest.mark.parametrize(
    ("type_name", "params", "message"),
    [
        ("Condition_Low_Energy_Level", {"threshold": "forty"}, "must be a number"),
        ("Condition_Low_Energy_Level", {"threshold": True}, "must be a number"),
        ("Condition_Low_Energy_Level", {"threshold": None}, "must be a number"),
        ("Condition_Low_Energy_Level", {"threshold": -1}, "must be >= 0"),
        ("Action_Refuel_A", {"rate": -2.0}, "must be >= 0"),
        ("Action_Navigate_To_Destination_A", {"speed": "fast"}, "must be a number"),
        ("Condition_Gathering_Moment", {"iteration": 2.5}, "must be a whole number"),
        ("Condition_Gathering_Moment", {"sender": 1}, "must be a string"),
    ],
)
def test_bad_port_value(type_name, params, message):
    with pytest.raises(LeafError, match=message) as info:
        leaf_type(type_name).create(params, DEFAULTS, "leaf 'x'")
    assert repr(next(iter(params))) in str(info.value)  # names the port


def test_whole_float_accepted_for_int_port():
    node = leaf_type("Condition_Gathering_Moment").create({"iteration": 12.0}, DEFAULTS, "t")
    assert node.iteration == 12
    assert type(node.iteration) is int


def test_missing_default_raises():
    with pytest.raises(LeafError, match="'threshold' has no value and no default"):
        leaf_type("Condition_Low_Energy_Level").create({}, {}, "leaf 'low'")


def test_unknown_leaf_type_with_did_you_mean():
    with pytest.raises(LeafError, match="unknown leaf type 'Action_Refuel'") as info:
        leaf_type("Action_Refuel")
    assert "did you mean 'Action_Refuel_A'" in str(info.value)
    with pytest.raises(LeafError) as info:
        leaf_type("Zzzz")
    assert "did you mean" not in str(info.value)


def test_engine_reports_leaf_errors_as_tree_errors(swarm_world):
    swarm, world = swarm_world(1)
    bad_type = sequence("root", leaf("Condition_Low_Energy_Leve", "low"))
    with pytest.raises(TreeError, match="did you mean 'Condition_Low_Energy_Level'") as info:
        PyTreesEngine(bad_type, swarm, world, DEFAULTS)
    assert "'low'" in str(info.value)  # a TreeError names the node
    bad_port = sequence("root", leaf("Condition_Low_Energy_Level", "low", level=3))
    with pytest.raises(TreeError, match="leaf 'low'.*unknown port"):
        PyTreesEngine(bad_port, swarm, world, DEFAULTS)
    bad_value = sequence("root", leaf("Action_Refuel_A", "refuel", rate="x"))
    with pytest.raises(TreeError, match="leaf 'refuel'.*'rate' must be a number"):
        PyTreesEngine(bad_value, swarm, world, DEFAULTS)


def test_engine_reports_missing_blackboard_keys():
    from pyautonomousagent.datalink import Datalink
    from pyautonomousagent.state import Swarm
    from pyautonomousagent.world import World

    swarm = Swarm.create(["drone1"], {"number_ticks": np.int64})
    world = World(10.0, 10.0, Datalink(10.0))
    tree = sequence("root", leaf("Action_Set_Destination_Equal_To_Refueling_S", "go"))
    with pytest.raises(TreeError, match="'go'.*x_current_destination_position"):
        PyTreesEngine(tree, swarm, world, DEFAULTS)


def test_every_library_leaf_is_tested():
    # a new leaf type needs its own tests here (Scripted is the test helper itself; the
    # BehaviorTree.CPP built-ins, e.g. Script or Sleep, are tested in test_btcpp_nodes)
    elsewhere = {name for name, cls in LEAF_TYPES.items() if cls.__module__.startswith(OWN_TESTS)}
    assert set(LEAF_TYPES) - {"Scripted"} - BTCPP_LEAVES - elsewhere == COVERED


@pytest.mark.parametrize("type_name", sorted(COVERED))
def test_numpy_integer_index_is_one_agent(swarm_world, type_name):
    # AgentView: "with an integer index it is one agent"; a NumPy integer is an integer index
    params = {"sender": "drone2"} if type_name == "Condition_Gathering_Moment" else {}
    outcomes = []
    for index in (1, np.int64(1)):
        swarm, world = swarm_world(2)
        world.iteration = 5000
        swarm.columns["energy"][:] = 40.0
        swarm.blackboard["index_current_surveillance_position"][:] = 1
        status = make(type_name, **params).evaluate(swarm.agent(index), world)
        assert np.ndim(status) == 0, f"index {index!r}: status {status!r} is not one status"
        assert status in (SUCCESS, FAILURE, RUNNING)
        columns, board = snapshot(swarm)
        state = {k: v.tolist() for k, v in {**columns, **board}.items()}
        outcomes.append((int(status), state, on_channel(world.datalink)))
    assert outcomes[0] == outcomes[1]


@pytest.mark.parametrize("n", [1, 3, 8, 9, 40])
def test_bearing_of_a_few_agents_has_the_bits_of_one_agent_at_a_time(n: int) -> None:
    """Small arrays take the scalar path element by element; the bits are those of the array
    path and of one agent at a time (what keeps the engines identical)."""
    from pyautonomousagent import arrays

    rng = np.random.default_rng(n)
    x, y, to_x, to_y = (rng.normal(size=n) * 10.0 ** rng.integers(-3, 4, n) for _ in range(4))
    to_x[::3] = x[::3]  # due north or south
    one_by_one = [arrays.bearing(*(float(v[i]) for v in (x, y, to_x, to_y))) for i in range(n)]
    assert arrays.bearing(x, y, to_x, to_y).tolist() == one_by_one
    assert arrays.bearing(x, y, to_x[0], to_y[0]).tolist() == [
        arrays.bearing(float(x[i]), float(y[i]), float(to_x[0]), float(to_y[0])) for i in range(n)
    ]
