"""What a large swarm holds: names made when asked, and records stored only where agents
differ, with the same bits as arrays stored in full."""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent import Simulation, load, recording
from pyautonomousagent.names import AgentIndex, AgentNames, agent_index
from pyautonomousagent.recording import RecordedColumns, same_everywhere, to_table


def test_names_read_like_the_list_they_replace():
    names = AgentNames("drone", 12)
    listed = [f"drone{i + 1}" for i in range(12)]
    assert names == listed and list(names) == listed and len(names) == 12
    assert names[0] == "drone1" and names[-1] == "drone12" and names[2:4] == ["drone3", "drone4"]
    assert names.index("drone12") == 11 and "drone7" in names
    for missing in ("drone13", "drone0", "drone01", "drone", "drone1x", "uav1", 1, "drone٣"):
        assert missing not in names
        with pytest.raises(ValueError):
            names.index(missing)
    with pytest.raises(IndexError):
        names[12]
    assert AgentNames("uav1", 20).index("uav112") == 11  # a prefix ending in a digit


def test_the_name_index_finds_rows_without_a_dictionary():
    index = agent_index(AgentNames("drone", 5))
    assert isinstance(index, AgentIndex)
    assert index["drone5"] == 4 and index.get("drone6", -1) == -1 and len(index) == 5
    assert dict(index) == agent_index(["drone1", "drone2", "drone3", "drone4", "drone5"])


def test_a_simulation_names_its_agents_lazily():
    sim = Simulation.create(load("patrol").with_overrides(agents=30, iterations=5))
    assert isinstance(sim.swarm.names, AgentNames) and sim.recorder.names == sim.swarm.names
    assert sim.world.agent_index["drone30"] == 29
    assert list(sim.swarm.agents(np.array([0, 29])).name) == ["drone1", "drone30"]


def test_records_alike_are_kept_as_one_value_with_their_bits():
    columns = RecordedColumns({"a": np.dtype(float), "b": np.dtype(np.int16)}, 3, 4)
    columns.store(0, "a", np.full(4, -0.0))
    columns.store(0, "b", np.full(4, 7, dtype=np.int16))
    columns.store(1, "a", np.full(4, np.nan))
    assert columns.stored == []
    columns.store(2, "a", np.array([0.0, 1.0, 2.0, 3.0]))
    a = columns["a"]
    assert np.signbit(a[0]).all() and np.isnan(a[1]).all() and a[2].tolist() == [0, 1, 2, 3]
    assert columns.block("b", 0, 1).tolist() == [[7, 7, 7, 7]]
    assert not same_everywhere(np.array([0.0, -0.0])) and same_everywhere(np.ones(3))


def test_the_initial_state_of_agents_alike_is_not_stored_in_full(monkeypatch):
    monkeypatch.setattr(recording, "COMPACT_AGENTS", 1)
    sim = Simulation.create(
        load("patrol").with_overrides(agents=50, iterations=100),
        record_every=101,
        engine="batched",  # the compiled engine writes its records in full
    )
    stored = set(sim.recorder.columns.stored)
    assert stored == {"heading"}  # the drones start alike but for it (requested: its twin)
    sim.run(progress=False)
    assert len(to_table(sim.recorder)) == 2 * 50  # record_every past the end: first and last


def test_a_long_bearing_in_pieces_has_the_bits_of_one_piece():
    from pyautonomousagent import arrays

    rng = np.random.default_rng(3)
    n = arrays.CHUNK * 2 + 17
    x, y = rng.normal(size=n) * 100, rng.normal(size=n) * 100
    x[:5], y[:5] = 0.0, [-0.0, 0.0, 1.0, -1.0, 0.0]
    whole = arrays._bearing(0.0 - x, 5.0 - y)
    pieces = arrays.bearing(x, y, 0.0, 5.0)
    assert pieces.tobytes() == whole.tobytes()
    assert pieces[7] == arrays.bearing(float(x[7]), float(y[7]), 0.0, 5.0)


def test_a_record_equal_to_another_column_is_kept_as_a_reference():
    columns = RecordedColumns({"a": np.dtype(float), "b": np.dtype(float)}, 2, 3)
    first = np.array([1.0, -0.0, 3.0])
    columns.store(0, "a", first)
    columns.store(0, "b", first.copy())
    assert columns.stored == ["a"]
    assert columns.block("b", 0, 1).tobytes() == first.tobytes()
    columns.store(1, "a", np.zeros(3))
    columns.store(1, "b", np.array([0.0, 0.0, 0.0 + 1e-300]))
    assert columns.stored == ["a", "b"]
    assert columns["b"][0].tobytes() == first.tobytes() and columns["b"][1, 2] == 1e-300


def test_behaviours_alike_are_not_stored_in_full(monkeypatch):
    monkeypatch.setattr(recording, "COMPACT_AGENTS", 1)
    # the batched engine: the compiled one writes its records in full
    sim = Simulation.create(
        load("patrol").with_overrides(agents=20, iterations=3), engine="batched"
    )
    assert sim.recorder.behaviour_block(0, 1).tolist() == [[-1] * 20]
    assert sim.recorder.codes is not None and sim.recorder.codes.stored == []
    sim.run(progress=False)
    assert sim.recorder.behaviour is not None and sim.recorder.behaviour.shape == (4, 20)


def test_small_swarms_store_every_column_at_set_up():
    sim = Simulation.create(load("patrol").with_overrides(agents=20, iterations=3))
    assert sorted(sim.recorder.columns.stored) == sorted(sim.recorder.columns)


@pytest.mark.parametrize("compact", [1, 1 << 30])
def test_compact_and_full_records_give_the_same_table(monkeypatch, compact):
    scenario = load("patrol").with_overrides(agents=30, iterations=25)
    full = to_table(Simulation.create(scenario).run(progress=False).recorder)
    monkeypatch.setattr(recording, "COMPACT_AGENTS", compact)
    again = to_table(Simulation.create(scenario).run(progress=False).recorder)
    assert again.equals(full, check_metadata=True)


def test_a_group_of_records_is_stored_as_record_by_record(monkeypatch):
    """``Recorder.store_group`` (the GPU engine's copied-back rows) keeps compact columns
    compact, as ``record`` one record at a time does."""
    monkeypatch.setattr(recording, "COMPACT_AGENTS", 1)
    scenario = load("patrol").with_overrides(agents=6, iterations=8)
    one = Simulation.create(scenario, seed=2, engine="batched").run(progress=False).recorder
    group = Simulation.create(scenario, seed=2, engine="batched").recorder  # record 0 only
    assert group.count == 1
    rows = {k: one.columns.block(k, 1, 9) for k in one.columns}
    group.store_group(1, rows, one.traces[1:9], one.behaviour_block(1, 9))
    group.iterations[:], group.count = one.iterations, one.count
    assert group.columns.stored == one.columns.stored != list(one.columns)
    assert group.codes is not None and one.codes is not None
    assert group.codes.stored == one.codes.stored
    assert to_table(group).equals(to_table(one), check_metadata=True)
    assert np.array_equal(group.traces, one.traces)
