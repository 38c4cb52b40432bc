"""Recorded node-status traces, the active behaviour, and the documented schema."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from pyautonomousagent.bt.spec import leaf, reactive_fallback, sequence
from pyautonomousagent.bt.status import FAILURE, INVALID, NAMES, RUNNING, SUCCESS
from pyautonomousagent.cli import main
from pyautonomousagent.recording import (
    DEFAULT_TRACED,
    active_leaf,
    recorder_from_tables,
    trace_table,
    traced_agents,
    write_table,
)
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation


@pytest.fixture(scope="module")
def run() -> Simulation:
    """300 iterations of gathering, drone1 and drone3 traced, every 2nd iteration recorded."""
    scenario = load("gathering").with_overrides(iterations=300)
    return Simulation.create(scenario, seed=0, record_every=2, trace="drone1,drone3").run(
        progress=False
    )


def test_traces_hold_the_engines_statuses_of_the_traced_agents_on_recorded_iterations():
    scenario = load("gathering").with_overrides(iterations=12)
    sim = Simulation.create(scenario, seed=0, record_every=3, trace=["drone2", "drone4"])
    expected = [np.zeros((len(sim.recorder.nodes), 2), dtype=np.int8)]  # before any tick
    for _ in range(12):
        sim.step()
        if sim.world.iteration % 3 == 0:
            expected.append(sim.engine.node_statuses()[:, [1, 3]])
    recorder = sim.recorder
    assert recorder.traces.dtype == np.int8
    assert [recorder.names[i] for i in recorder.traced] == ["drone2", "drone4"]
    assert recorder.iterations[: recorder.count].tolist() == [0, 3, 6, 9, 12]
    np.testing.assert_array_equal(recorder.traces[: recorder.count], np.stack(expected))
    np.testing.assert_array_equal(recorder.trace("drone4"), np.stack(expected)[:, :, 1])
    with pytest.raises(KeyError, match="drone1.*not traced.*drone2, drone4"):
        recorder.trace("drone1")


def test_default_traces_a_small_swarm_whole_and_the_first_of_a_large_one():
    names = [f"drone{i}" for i in range(1, 31)]
    assert traced_agents(names[:4], None) == [0, 1, 2, 3]
    assert traced_agents(names, None) == list(range(DEFAULT_TRACED))
    assert traced_agents(names, 0) == []
    assert traced_agents(names, "all") == list(range(30))
    assert traced_agents(names, "2,drone30,drone5") == [0, 1, 4, 29]
    with pytest.raises(ValueError, match="no agent named 'drone31'.*drone1..drone30"):
        traced_agents(names, "drone31")
    with pytest.raises(ValueError, match=">= 0"):
        traced_agents(names, -1)


def test_active_leaf_is_the_running_one_else_the_last_ticked():
    # nodes: 0 root, 1 leaf a, 2 composite, 3 leaf b, 4 leaf c; four agents (columns).
    statuses = np.array(
        [
            [RUNNING, SUCCESS, FAILURE, INVALID],
            [SUCCESS, SUCCESS, FAILURE, INVALID],
            [RUNNING, SUCCESS, INVALID, INVALID],
            [RUNNING, FAILURE, INVALID, INVALID],
            [INVALID, SUCCESS, INVALID, INVALID],
        ],
        dtype=np.int8,
    )
    leaves = np.array([1, 3, 4], dtype=np.int16)
    assert active_leaf(statuses, leaves).tolist() == [3, 4, 1, -1]


def test_states_gain_the_active_behaviour_and_every_column_is_documented(run, tmp_path):
    path = write_table(run.table(), tmp_path / "states.parquet")
    table = pq.read_table(path)
    behaviour = table.column("behaviour").to_pylist()
    assert behaviour[:4] == [None] * 4  # iteration 0: nothing ticked yet
    leaves = {n.name for n in run.recorder.nodes if not n.is_control}
    assert set(behaviour[4:]) <= leaves and len(set(behaviour[4:])) >= 1
    codes = run.recorder.behaviour[: run.recorder.count].reshape(-1)
    names = [run.recorder.nodes[c].name if c >= 0 else None for c in codes]
    assert behaviour == names
    for field in table.schema:
        meta = field.metadata or {}
        assert meta.get(b"description"), f"{field.name} has no description"
        assert b"unit" in meta
        assert field.name in run.recorder.docs
    assert table.schema.field("energy").metadata[b"unit"] == b"percent"
    assert table.schema.field("x").metadata[b"group"] == b"state"
    assert table.schema.field("number_ticks").metadata[b"group"] == b"blackboard"


def test_trace_table_schema_names_nodes_and_codes(run, tmp_path):
    path = write_table(trace_table(run.recorder), tmp_path / "traces.parquet")
    table = pq.read_table(path)
    nodes = run.recorder.nodes
    assert table.column_names == ["iteration", "agent", *[n.name for n in nodes]]
    assert table.num_rows == run.recorder.count * 2
    assert table.column("agent").to_pylist()[:4] == ["drone1", "drone3", "drone1", "drone3"]
    assert all(table.schema.field(n.name).type == "int8" for n in nodes)
    meta = table.schema.metadata
    listed = json.loads(meta[b"pyautonomousagent.nodes"])
    assert [n["name"] for n in listed] == [n.name for n in nodes]
    assert listed[0]["parent"] == -1 and listed[1]["parent"] == 0 and listed[1]["depth"] == 1
    assert json.loads(meta[b"pyautonomousagent.status_codes"]) == {
        str(k): v for k, v in NAMES.items()
    }
    row = table.slice(2 * 50 + 1, 1).to_pylist()[0]  # record 50, drone3
    assert row["iteration"] == 100
    assert [row[n.name] for n in nodes] == run.recorder.trace("drone3")[50].tolist()


def test_written_run_reads_back_into_an_equal_recorder(run, tmp_path):
    states = write_table(run.table(), tmp_path / "s.parquet")
    traces = write_table(trace_table(run.recorder), tmp_path / "t.parquet")
    back = recorder_from_tables(pq.read_table(states), pq.read_table(traces))
    original = run.recorder
    assert back.names == original.names and back.every == 2
    np.testing.assert_array_equal(back.iterations, original.iterations[: original.count])
    for key, values in original.columns.items():
        np.testing.assert_array_equal(back.columns[key], values[: original.count], err_msg=key)
    np.testing.assert_array_equal(back.traces, original.traces[: original.count])
    np.testing.assert_array_equal(back.behaviour, original.behaviour[: original.count])
    assert [n.name for n in back.nodes] == [n.name for n in original.nodes]
    assert back.nodes[0] == original.nodes[0]  # the whole tree, parameters included
    assert back.groups == original.groups


def test_traced_scripted_statuses_reach_the_table():
    tree = reactive_fallback(
        "root",
        sequence("seq", leaf("Scripted", "c", statuses=[[FAILURE], [SUCCESS]]),
                 leaf("Scripted", "a", statuses=[[SUCCESS], [RUNNING]])),
        leaf("Scripted", "b", statuses=[[RUNNING], [SUCCESS]]),
    )  # fmt: skip
    scenario = load("gathering").with_overrides(agents=1, iterations=2)
    sim = Simulation.create(scenario, tree=tree).run(progress=False)
    rows = trace_table(sim.recorder).to_pylist()
    assert [(r["c"], r["a"], r["b"]) for r in rows] == [
        (INVALID, INVALID, INVALID),
        (FAILURE, INVALID, RUNNING),
        (SUCCESS, RUNNING, INVALID),
    ]
    assert sim.table().column("behaviour").to_pylist() == [None, "b", "a"]


def test_cli_trace_option_and_its_errors(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["run", "gathering", "--iterations", "20", "--no-gif", "--no-replay", "--quiet"]
    assert main([*args, "--out", str(out), "--trace", "drone3"]) == 0
    traces = pq.read_table(out / "traces.parquet")
    assert set(traces.column("agent").to_pylist()) == {"drone3"}
    assert main([*args, "--out", str(tmp_path / "none"), "--trace", "0"]) == 0
    assert not (tmp_path / "none" / "traces.parquet").exists()
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "bad"), "--trace", "drone9"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("pyaa: error: --trace: no agent named 'drone9'") and "\n" not in error


@pytest.mark.parametrize("agents", [1, 5, 16, 17, 200])
def test_active_leaf_agent_by_agent_agrees_with_the_array_form(agents: int) -> None:
    """A few agents take the Python path of active_leaf; it finds the same leaves."""
    from pyautonomousagent import recording

    rng = np.random.default_rng(agents)
    statuses = rng.choice(np.array([INVALID, SUCCESS, FAILURE, RUNNING], dtype=np.int8),
                          size=(9, agents), p=[0.4, 0.25, 0.25, 0.1])  # fmt: skip
    leaves = np.array([1, 2, 4, 5, 8], dtype=np.int16)
    each = recording._active_leaf_each(statuses, leaves)
    assert each.dtype == active_leaf(statuses, leaves).dtype == np.int16
    if agents > recording.FEW_AGENTS:  # the array form ran: compare it with the Python form
        assert active_leaf(statuses, leaves).tolist() == each.tolist()
    else:  # enough copies of each agent force the array form
        copies = recording.FEW_AGENTS + 1
        wide = np.repeat(statuses, copies, axis=1)
        assert active_leaf(wide, leaves)[::copies].tolist() == each.tolist()
