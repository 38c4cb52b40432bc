"""Acceptance: the paper's gathering scenario (Fig. 6-10), on the full 8000-iteration run."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.csv as pcsv
import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.trees import tree_by_name
from pyautonomousagent.cli import main
from pyautonomousagent.missions.drones.leaves import GATHERING

GATHER_POINT = (50.0, 50.0)
STATE = ["x", "y", "speed", "heading", "energy", "damage"]


def column(sim: Simulation, key: str) -> np.ndarray:
    return sim.recorder.column(key)


def on_refuelling_trip(sim: Simulation) -> np.ndarray:
    """(records, N): the destination is the drone's refuelling slot."""
    return (
        column(sim, "x_current_destination_position") == column(sim, "x_refueling_position")
    ) & (column(sim, "y_current_destination_position") == column(sim, "y_refueling_position"))


def distance_to_gather_point(sim: Simulation) -> np.ndarray:
    return np.hypot(column(sim, "x") - GATHER_POINT[0], column(sim, "y") - GATHER_POINT[1])


def test_every_iteration_is_recorded(gathering_run):
    assert gathering_run.world.iteration == 8000
    assert gathering_run.recorder.count == 8001
    np.testing.assert_array_equal(gathering_run.recorder.iterations, np.arange(8001))


def test_drone1_sends_exactly_one_gathering_message_at_5000(gathering_run):
    messages = [e for e in gathering_run.events if e["event"] == "message"]
    assert messages == [
        {"iteration": 5000, "event": "message", "type": GATHERING, "sender": "drone1",
         "receivers": "all", "data": {"x": 50.0, "y": 50.0}},
    ]  # fmt: skip
    assert [e for e in gathering_run.events if e["event"] == "alert"] == []


def test_surveillance_positions_before_the_gathering(gathering_run):
    xs, ys = (
        column(gathering_run, "x_surveillance_position"),
        column(gathering_run, "y_surveillance_position"),
    )
    for t in (0, 1, 4999, 5000):  # at 5000 the message is only delivered (Phase 5)
        assert list(zip(xs[t], ys[t], strict=True)) == [(50, 50), (70, 80), (40, 70), (60, 25)], t


def test_everyone_adopts_the_gathering_point_from_iteration_5001(gathering_run):
    xs, ys = (
        column(gathering_run, "x_surveillance_position"),
        column(gathering_run, "y_surveillance_position"),
    )
    gathered = np.all((xs == 50.0) & (ys == 50.0), axis=1)
    # the message of iteration 5000 is acted on in Phase 2 of iteration 5001
    assert int(np.flatnonzero(gathered)[0]) == 5001
    assert gathered[5001:].all()
    assert not gathered[5000]


def test_every_drone_reaches_the_gathering_point(gathering_run):
    d = distance_to_gather_point(gathering_run)[5001:]
    assert (d.min(axis=0) <= 1.0).all(), d.min(axis=0)


def test_drones_orbit_the_gathering_point_between_refuelling_trips(gathering_run):
    d = distance_to_gather_point(gathering_run)
    trip = on_refuelling_trip(gathering_run)
    energy = column(gathering_run, "energy")
    # a refuelling trip starts only when the energy is low
    starts = trip[1:] & ~trip[:-1]
    assert starts.any()
    assert (energy[1:][starts] <= 40.0).all()
    for agent in range(4):
        on_station = False
        checked = 0
        for t in range(5001, gathering_run.recorder.count):
            if trip[t, agent]:
                on_station = False  # left for the slot
                continue
            if not on_station and d[t, agent] <= 1.0:
                on_station = True  # first arrival since the gathering or since refuelling
            if on_station:
                checked += 1
                assert d[t, agent] <= 12.0, (agent, t, d[t, agent])
        assert checked > 1000, (agent, checked)


def test_each_drone_refuels_at_least_once(gathering_run):
    energy = column(gathering_run, "energy")
    for agent in range(4):
        low = np.flatnonzero(energy[:, agent] <= 40.0)
        assert low.size > 0, agent
        assert (energy[low[0] :, agent] == 100.0).any(), agent  # back to full after running low


def test_refuelling_happens_at_the_slot_standing_still(gathering_run):
    energy = column(gathering_run, "energy")
    x, y, speed = (
        column(gathering_run, "x"),
        column(gathering_run, "y"),
        column(gathering_run, "speed"),
    )
    rx, ry = (
        column(gathering_run, "x_refueling_position"),
        column(gathering_run, "y_refueling_position"),
    )
    rising = np.zeros_like(energy, dtype=bool)
    rising[1:] = energy[1:] > energy[:-1]
    assert rising.any()
    # it arrives within 0.5 and drifts at most one more step (0.1) while it brakes
    assert (np.hypot(x - rx, y - ry)[rising] <= 0.6).all()
    # from its second iteration of refuelling on, the drone stands still
    still = rising.copy()
    still[1:] &= rising[:-1]
    still[0] = False
    assert still.any()
    assert (speed[still] == 0.0).all()
    full_again = rising & (energy == 100.0)
    assert full_again.sum(axis=0).min() >= 1


def test_no_drone_runs_out_of_energy(gathering_run):
    energy = column(gathering_run, "energy")
    assert energy.min() > 0.0
    assert not [e for e in gathering_run.events if e["event"] == "alert"]


def test_number_ticks_grows_every_iteration(gathering_run):
    ticks = column(gathering_run, "number_ticks")
    assert (ticks[0] == 0).all()
    steps = np.diff(ticks, axis=0)
    # the root's first leaf (transmit) plus at least one behaviour leaf, never every leaf
    assert steps.min() >= 2
    assert steps.max() < len(tree_by_name("gathering").leaves())


def test_same_seed_gives_identical_data(gathering_run):
    short = Simulation.create(load("gathering").with_overrides(iterations=600), seed=0).run(
        progress=False
    )
    again = Simulation.create(load("gathering").with_overrides(iterations=600), seed=0).run(
        progress=False
    )
    assert short.table().equals(again.table())
    for key in gathering_run.recorder.columns:
        np.testing.assert_array_equal(
            short.recorder.column(key), column(gathering_run, key)[:601], key
        )


def test_same_seed_identical_and_other_seed_different_with_random_headings():
    scenario = load("patrol").with_overrides(agents=3, iterations=200)
    one = Simulation.create(scenario, seed=7).run(progress=False).table()
    two = Simulation.create(scenario, seed=7).run(progress=False).table()
    other = Simulation.create(scenario, seed=8).run(progress=False).table()
    assert one.equals(two)
    assert not one.equals(other)


# --------------------------------------------------------------------------- pyaa run


EXPECTED_COLUMNS = [
    "iteration", "agent", "x", "y", "speed", "heading", "energy", "damage", "number_ticks",
    "x_surveillance_position", "y_surveillance_position", "x_refueling_position",
    "y_refueling_position", "x_current_destination_position", "y_current_destination_position",
]  # fmt: skip


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "tmp"
    code = main(
        ["run", "gathering", "--no-gif", "--out", str(out), "--iterations", "300", "--quiet"]
    )
    return code, out


def test_cli_run_writes_parquet_and_run_json(cli_run):
    code, out = cli_run
    assert code == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["replay.html", "run.json", "states.parquet", "traces.parquet"]
    table = pq.read_table(out / "states.parquet")
    assert set(EXPECTED_COLUMNS) <= set(table.column_names)
    assert table.column_names[:2] == ["iteration", "agent"]
    assert table.num_rows == 301 * 4  # the initial state plus 300 iterations, 4 drones
    iterations = table.column("iteration").to_numpy()
    agents = table.column("agent").to_pylist()
    np.testing.assert_array_equal(iterations, np.repeat(np.arange(301), 4))
    assert agents == ["drone1", "drone2", "drone3", "drone4"] * 301
    pairs = set(zip(iterations.tolist(), agents, strict=True))
    assert len(pairs) == table.num_rows  # one row per recorded iteration and agent
    first = table.slice(0, 4).to_pydict()
    assert first["x"] == [20.0, 20.0, 20.0, 20.0]
    assert first["y"] == [65.0, 55.0, 45.0, 35.0]
    assert first["energy"] == [100.0] * 4
    assert first["number_ticks"] == [0] * 4


def test_cli_run_data_equals_the_simulation(cli_run, gathering_run):
    _, out = cli_run
    table = pq.read_table(out / "states.parquet")
    for key in ["x", "y", "speed", "heading", "energy", "number_ticks"]:
        np.testing.assert_array_equal(
            table.column(key).to_numpy(), column(gathering_run, key)[:301].reshape(-1), key
        )


def test_cli_run_json(cli_run):
    _, out = cli_run
    summary = json.loads((out / "run.json").read_text())
    assert {"scenario", "seed", "engine", "versions", "timings_s", "events"} <= set(summary)
    assert summary["scenario"]["name"] == "gathering"
    assert summary["scenario"]["iterations"] == 300
    assert summary["scenario"]["agents"] == 4
    assert summary["seed"] == 0
    # auto: compiled where this tree's loop was compiled before on this machine, else batched
    assert summary["engine"] in ("batched", "compiled")
    assert {"python", "numpy", "py_trees", "pyarrow"} <= set(summary["versions"])
    assert {"setup", "simulate", "write_data"} <= set(summary["timings_s"])
    assert summary["events"] == []  # the gathering order comes at 5000, after the end


def test_cli_run_csv_with_record_every(tmp_path, capsys):
    out = tmp_path / "csv"
    argv = ["run", "gathering", "--no-gif", "--out", str(out), "--iterations", "300",
            "--format", "csv", "--record-every", "10"]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "wrote" in printed and "states.csv" in printed
    files = sorted(p.name for p in out.iterdir())
    assert files == ["replay.html", "run.json", "states.csv", "traces.csv"]
    table = pcsv.read_csv(out / "states.csv")
    assert set(EXPECTED_COLUMNS) <= set(table.column_names)
    assert table.num_rows == (300 // 10 + 1) * 4
    np.testing.assert_array_equal(
        table.column("iteration").to_numpy(), np.repeat(np.arange(0, 301, 10), 4)
    )
    assert table.column("agent").to_pylist()[:4] == ["drone1", "drone2", "drone3", "drone4"]
    assert json.loads((out / "run.json").read_text())["record_every"] == 10


def test_cli_run_record_every_parquet_and_events(tmp_path):
    out = tmp_path / "p"
    argv = ["run", "gathering", "--no-gif", "--out", str(out), "--iterations", "40", "--quiet",
            "--record-every", "7", "--set", "gathering_iteration=20"]  # fmt: skip
    assert main(argv) == 0
    table = pq.read_table(out / "states.parquet")
    assert table.num_rows == (40 // 7 + 1) * 4
    assert sorted(set(table.column("iteration").to_pylist())) == [0, 7, 14, 21, 28, 35]
    events = json.loads((out / "run.json").read_text())["events"]
    assert [(e["iteration"], e["sender"], e["type"]) for e in events] == [(20, "drone1", GATHERING)]
