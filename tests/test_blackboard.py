"""Per-agent blackboards: rows of arrays that never leak between agents."""

from __future__ import annotations

import numpy as np
import py_trees
import pytest

from pyautonomousagent.bt import leaf, sequence
from pyautonomousagent.state import Swarm


def test_writes_to_one_agent_do_not_leak(swarm_world):
    swarm, _ = swarm_world(3)
    first, second = swarm.agent(0).blackboard, swarm.agent(1).blackboard
    second.x_surveillance_position = 7.0
    first.x_surveillance_position = 42.0
    first.number_ticks = 5
    assert first.x_surveillance_position == 42.0
    assert second.x_surveillance_position == 7.0
    assert swarm.agent(2).blackboard.x_surveillance_position == 0.0
    assert second.number_ticks == 0
    assert swarm.blackboard["x_surveillance_position"].tolist() == [42.0, 7.0, 0.0]


def test_group_view_writes_only_its_rows(swarm_world):
    swarm, _ = swarm_world(4)
    group = swarm.agents(np.array([1, 3])).blackboard
    group.y_refueling_position = np.array([5.0, 6.0])
    assert swarm.blackboard["y_refueling_position"].tolist() == [0.0, 5.0, 0.0, 6.0]
    np.testing.assert_array_equal(group.y_refueling_position, [5.0, 6.0])
    assert swarm.agent(1).blackboard.y_refueling_position == 5.0


def test_agent_view_state_columns_are_rows(swarm_world):
    swarm, _ = swarm_world(2)
    one = swarm.agent(1)
    one.energy = 55.0
    one.heading = 12.0
    assert swarm.columns["energy"].tolist() == [0.0, 55.0]
    assert swarm.columns["heading"].tolist() == [0.0, 12.0]
    assert one.name == "drone2"
    assert swarm.agents().name.tolist() == ["drone1", "drone2"]


def test_unknown_key_raises_attribute_error_naming_it(swarm_world):
    swarm, _ = swarm_world(1)
    board = swarm.agent(0).blackboard
    with pytest.raises(AttributeError, match="'batery'") as info:
        _ = board.batery
    assert "number_ticks" in str(info.value)  # lists the known keys
    with pytest.raises(AttributeError, match="'new_key'"):
        board.new_key = 1.0
    assert "new_key" not in swarm.blackboard  # nothing was created
    assert not hasattr(board, "other")


def test_keys_and_as_dict(swarm_world):
    swarm, _ = swarm_world(2)
    swarm.agent(1).blackboard.x_refueling_position = 20.0
    board = swarm.agent(1).blackboard
    assert set(board.keys()) == set(swarm.blackboard)
    assert board.as_dict()["x_refueling_position"] == 20.0
    assert swarm.agent(0).blackboard.as_dict()["x_refueling_position"] == 0.0


def test_swarm_create_dtypes():
    swarm = Swarm.create(["a", "b"], {"number_ticks": np.int64, "x": np.float64})
    assert swarm.size == 2
    assert swarm.blackboard["number_ticks"].dtype == np.int64
    assert swarm.blackboard["x"].dtype == np.float64
    assert all(v.shape == (2,) for v in swarm.columns.values())


def test_engine_leaves_write_only_their_agents_row(harness):
    tree = sequence(
        "root",
        leaf("Action_Set_Destination_Equal_To_Refueling_S"),
        leaf("Action_Navigate_To_Destination_A"),
    )
    h = harness(tree, n=3)
    bb = h.swarm.blackboard
    bb["x_refueling_position"][:] = [1.0, 2.0, 3.0]
    bb["y_refueling_position"][:] = [4.0, 5.0, 6.0]
    h.tick()
    assert bb["x_current_destination_position"].tolist() == [1.0, 2.0, 3.0]
    assert bb["y_current_destination_position"].tolist() == [4.0, 5.0, 6.0]
    assert bb["number_ticks"].tolist() == [2, 2, 2]


def test_py_trees_global_blackboard_is_not_used(harness):
    tree = sequence("root", leaf("Action_Set_Destination_Equal_To_Surveillance_S"))
    h = harness(tree, n=2)
    h.tick()
    assert py_trees.blackboard.Blackboard.storage == {}


def test_patrol_agents_keep_their_own_surveillance_index(patrol_run):
    record = patrol_run.recorder
    index = record.column("index_current_surveillance_position")
    xs, ys = record.column("x_surveillance_position"), record.column("y_surveillance_position")
    differ = np.flatnonzero(index.min(axis=1) != index.max(axis=1))
    assert differ.size > 0, "random headings should put the drones out of step"
    # wherever the indices differ, each drone's surveillance position follows its own index
    rows = index[differ]
    np.testing.assert_array_equal(xs[differ], np.full(rows.shape, 70.0))
    np.testing.assert_array_equal(ys[differ], np.where(rows == 1, 80.0, 20.0))
    # and across the whole run, for every drone
    np.testing.assert_array_equal(ys[1:], np.where(index[1:] == 1, 80.0, 20.0))


def test_patrol_agents_differ_per_agent_after_the_run(patrol_run):
    board = patrol_run.swarm.blackboard
    # different random headings -> different paths -> different tick counts and positions
    assert len(set(patrol_run.swarm.columns["x"].tolist())) == patrol_run.swarm.size
    assert len(set(board["number_ticks"].tolist())) > 1
    # the values shared by all come from the scenario, on every row
    assert set(board["x_refueling_position"].tolist()) == {10.0}
    assert set(board["y_surveillance_position_2"].tolist()) == {20.0}
