"""The batched engine against the py_trees engine: same statuses, ticks and states."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyautonomousagent import Simulation, jit, load
from pyautonomousagent.bt import leaf, sequence
from pyautonomousagent.bt.spec import Node, TreeError
from pyautonomousagent.engines.pytrees import BEHAVIOUR_TYPES, AgentBehaviour, register_behaviour
from pyautonomousagent.testing import scoped_registrations

from .conftest import make_harness
from .strategies import trees

TICKS, AGENTS = 8, 3


def assert_same_ticks(tree: Node, ticks: int, agents: int) -> None:
    reference = make_harness(tree, agents, engine="pytrees")
    batched = make_harness(tree, agents, engine="batched")
    names = reference.names()
    for tick in range(1, ticks + 1):
        expected, got = reference.tick(), batched.tick()
        for row, name in enumerate(names):
            assert list(got[row]) == list(expected[row]), f"tick {tick}, node {name}"
        assert list(batched.swarm.blackboard["number_ticks"]) == list(
            reference.swarm.blackboard["number_ticks"]
        ), f"tick {tick}, number_ticks"


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(TICKS, AGENTS))
def test_random_trees_tick_alike(tree: Node) -> None:
    assert_same_ticks(tree, TICKS, AGENTS)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_trees_with_many_agents(data: st.DataObject) -> None:
    agents = data.draw(st.integers(1, 12))
    assert_same_ticks(data.draw(trees(5, agents, max_leaves=8)), 5, agents)


def run_both(scenario_name: str, **overrides: object) -> tuple[Simulation, Simulation]:
    scenario = load(scenario_name).with_overrides(**overrides)
    runs = []
    for engine in ("pytrees", "batched"):
        sim = Simulation.create(scenario, seed=7, engine=engine, record_every=1)
        sim.run(progress=False)
        runs.append(sim)
    return runs[0], runs[1]


@pytest.mark.parametrize(
    ("scenario", "overrides"),
    [
        ("gathering", {}),
        ("patrol", {"agents": 12, "iterations": 4000}),
        ("patrol-3d", {"agents": 4, "iterations": 2600}),
        ("gathering-3d", {"iterations": 2400, "gathering_iteration": 900}),
    ],
)
def test_scenarios_give_the_same_data(scenario: str, overrides: dict[str, object]) -> None:
    reference, batched = run_both(scenario, **overrides)
    assert reference.events == batched.events
    for key, expected in reference.recorder.columns.items():
        assert np.array_equal(batched.recorder.columns[key], expected), key  # the same bits


@pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
def test_radiation_search_gives_the_same_data_on_every_cpu_engine() -> None:
    """py_trees, batched and compiled (fused) through the detection (iteration 256)."""
    scenario = load("radiation-search").with_overrides(iterations=300)
    runs = [
        Simulation.create(scenario, seed=7, engine=engine).run(progress=False)
        for engine in ("pytrees", "batched", "compiled")
    ]
    assert [e["type"] for e in runs[0].events if e["event"] == "message"] == ["found"]
    for other in runs[1:]:
        assert other.events == runs[0].events, other.engine.name
        assert np.array_equal(other.recorder.traces, runs[0].recorder.traces)
        for key, expected in runs[0].recorder.columns.items():
            assert np.array_equal(other.recorder.columns[key], expected), (other.engine.name, key)


def test_scenario_status_traces_are_identical() -> None:
    scenario = load("gathering").with_overrides(iterations=6000)
    sims = [Simulation.create(scenario, seed=1, engine=e) for e in ("pytrees", "batched")]
    for iteration in range(scenario.iterations):
        for sim in sims:
            sim.step()
        if iteration % 7 == 0 or 4995 <= iteration <= 5010:
            a, b = (sim.engine.node_statuses() for sim in sims)
            assert np.array_equal(a, b), f"iteration {iteration + 1}"


def test_cli_runs_give_identical_parquet(tmp_path) -> None:
    import pyarrow.parquet as pq

    from pyautonomousagent.cli import main

    for engine in ("pytrees", "batched"):
        out = tmp_path / engine
        args = ["run", "gathering", "--engine", engine, "--no-gif", "--quiet", "--out", str(out)]
        assert main(args) == 0
    a = pq.read_table(tmp_path / "pytrees" / "states.parquet")
    b = pq.read_table(tmp_path / "batched" / "states.parquet")
    assert a.column_names == b.column_names
    assert a.equals(b)  # the same bits in every column


def test_hand_written_behaviour_is_refused_by_the_batched_engine() -> None:
    class HandWritten(AgentBehaviour):
        def update(self):  # pragma: no cover - never ticked here
            raise AssertionError

    with scoped_registrations():
        register_behaviour("Test_Hand_Written")(HandWritten)
        tree = sequence(
            "root", leaf("Condition_Low_Energy_Level"), leaf("Test_Hand_Written", "mine")
        )
        make_harness(tree, 2, engine="pytrees")  # the py_trees engine accepts it
        with pytest.raises(TreeError, match="'mine'.*no batched form"):
            make_harness(tree, 2, engine="batched")
    assert "Test_Hand_Written" not in BEHAVIOUR_TYPES
