"""The mission API's edges: unhandled messages, reproducible leaf randomness on both engines,
a scalar-only leaf on the batched engine, and the ways a scenario names its mission."""

from __future__ import annotations

import logging
import sys
import types
from typing import Any

import numpy as np
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt import RUNNING, SUCCESS, Leaf, leaf, reactive_sequence, register_leaf
from pyautonomousagent.bt.leaf import LEAF_TYPES
from pyautonomousagent.bt.spec import TreeError
from pyautonomousagent.mission import Mission, ScenarioError, register_mission
from pyautonomousagent.randomness import CounterRandom, stream_key
from pyautonomousagent.simulation import mission as mission_module
from pyautonomousagent.simulation.mission import MISSIONS, resolve_mission
from pyautonomousagent.testing import check_leaf, scoped_registrations


def test_counter_random_is_the_same_for_one_agent_and_for_many():
    random = CounterRandom(7)
    rows = np.arange(1000)
    many = random.uniform(3, rows, 12)
    one = [random.uniform(3, int(r), 12) for r in rows]
    assert isinstance(one[0], float)
    assert np.array_equal(many, np.asarray(one))  # the same bits
    assert many.min() >= 0.0 and many.max() < 1.0
    assert abs(many.mean() - 0.5) < 0.05
    # every key changes the numbers
    for other in (CounterRandom(8).uniform(3, rows, 12), random.uniform(4, rows, 12),
                  random.uniform(3, rows, 13), random.uniform(3, rows, 12, draw=1)):  # fmt: skip
        assert np.mean(other == many) < 0.01
    assert stream_key("a") == stream_key("a") != stream_key("b")


def test_leaf_randomness_is_identical_on_both_engines():
    class ActionWanderA(Leaf):
        """Request a random heading; RUNNING."""

        type_name = "Action_Test_Wander_A"

        def evaluate(self, agents: Any, world: Any) -> Any:
            agents.requested_heading = self.uniform(agents, world, 0.0, 360.0)
            agents.requested_speed = 0.1
            return RUNNING

    with scoped_registrations():
        register_leaf(ActionWanderA)
        check_leaf(ActionWanderA, "patrol", agents=9, iterations=40)
        tree = leaf("Action_Test_Wander_A", "wander")
        runs = [
            Simulation.create(load("patrol").with_overrides(agents=5, iterations=30), seed=s,
                              engine=e, tree=tree).run(progress=False)
            for s, e in ((1, "pytrees"), (1, "batched"), (2, "batched"))
        ]  # fmt: skip
        headings = [r.recorder.column("requested_heading") for r in runs]
        assert np.array_equal(headings[0], headings[1])
        assert not np.array_equal(headings[1], headings[2])  # another seed, other numbers
    assert "Action_Test_Wander_A" not in LEAF_TYPES


def test_a_scalar_only_leaf_on_the_batched_engine_names_the_node_and_the_fix():
    class ConditionScalarOnly(Leaf):
        type_name = "Condition_Test_Scalar_Only"

        def evaluate(self, agents: Any, world: Any) -> Any:
            return SUCCESS if agents.energy > 50 else 2

    with scoped_registrations():
        register_leaf(ConditionScalarOnly)
        tree = reactive_sequence("root", leaf("Condition_Test_Scalar_Only", "half_full"))
        scenario = load("patrol").with_overrides(agents=3, iterations=2)
        Simulation.create(scenario, engine="pytrees", tree=tree).run(progress=False)  # fine
        sim = Simulation.create(scenario, engine="batched", tree=tree)
        with pytest.raises(TreeError, match=r"leaf 'half_full' .* works on one agent only.*"
                           r"status_if/success_if.*engine='pytrees'"):  # fmt: skip
            sim.run(progress=False)


class Talker(Mission):
    """Sends a message type nobody handles."""

    name = "test-talker"
    agent_prefix = "t"


class ActionShout(Leaf):
    type_name = "Action_Test_Shout_S"

    def evaluate(self, agents: Any, world: Any) -> Any:
        world.datalink.send(
            agents.indices, "shout", {}, (agents.compact(agents.x), agents.compact(agents.y))
        )
        return SUCCESS


def talker_scenario(**changes: Any):
    data = {"name": "talk", "mission": "test-talker", "tree": "unused.xml", "agents": 3,
            "iterations": 5, "world": [10, 10], **changes}  # fmt: skip
    from pyautonomousagent import Scenario

    return Scenario.from_mapping(data)


def test_a_delivered_message_no_handler_takes_is_logged_once(caplog):
    with scoped_registrations():
        register_leaf(ActionShout)
        register_mission(Talker)
        tree = leaf("Action_Test_Shout_S", "shout")
        with caplog.at_level(logging.WARNING, logger="pyautonomousagent"):
            sim = Simulation.create(talker_scenario(), tree=tree).run(progress=False)
        warnings = [r.getMessage() for r in caplog.records if "shout" in r.getMessage()]
        assert len(warnings) == 1
        assert "mission 'test-talker' has no handler" in warnings[0]
        assert sim.events == []
    assert "test-talker" not in MISSIONS and "Action_Test_Shout_S" not in LEAF_TYPES


def test_register_mission_refuses_what_is_no_mission():
    with pytest.raises(TypeError, match="Mission subclass with a name"):
        register_mission(int)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Mission subclass with a name"):
        register_mission(Mission)


def test_a_mission_named_by_module_and_class_and_by_entry_point(monkeypatch):
    module = types.ModuleType("my_test_missions")

    class Mine(Mission):
        name = "mine-by-module"

    Mine.__module__ = module.__name__
    module.Mine = Mine  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, module.__name__, module)
    assert resolve_mission("my_test_missions:Mine") is Mine
    with pytest.raises(ScenarioError, match="'Nope' is not a Mission subclass"):
        resolve_mission("my_test_missions:Nope")
    with pytest.raises(ScenarioError, match="cannot import 'no_such_module_xyz'"):
        resolve_mission("no_such_module_xyz:Mine")

    class EntryPoint:
        name = "from-entry-point"

        def load(self) -> type:
            return Mine

    monkeypatch.setattr(mission_module.metadata, "entry_points", lambda group: [EntryPoint()])
    assert resolve_mission("from-entry-point") is Mine
    with pytest.raises(ScenarioError, match="unknown mission 'gatherin'; did you mean"):
        resolve_mission("gatherin")


@pytest.mark.parametrize("name", ["gathering", "patrol", "vacuum", "radiation-search"])
def test_every_recorded_column_of_the_shipped_missions_has_a_unit_and_meaning(name):
    sim = Simulation.create(load(name).with_overrides(agents=2, iterations=3)).run(progress=False)
    for field in sim.table().schema:
        assert field.metadata[b"description"], (name, field.name)
        assert b"unit" in field.metadata
