"""The X8 from outside: `pyaa run` on both engines, settings, turbulence, memory, `pyaa bench`."""

from __future__ import annotations

import re

import numpy as np
import pyarrow.parquet as pq
import pytest

pytest.importorskip("pyfly", reason="needs the [x8] extra (pyfly-fixed-wing)")

from pyautonomousagent import (  # noqa: E402
    Simulation,
    bench,  # noqa: E402
    load,
)
from pyautonomousagent.cli import main  # noqa: E402
from pyautonomousagent.models import x8_pyfly  # noqa: E402
from pyautonomousagent.simulation.scenario import (  # noqa: E402
    Scenario,
    ScenarioError,
    to_mapping,
)

X8_COLUMNS = {"altitude", "airspeed", "roll", "pitch"}


@pytest.mark.parametrize(("engine", "iterations"), [("pytrees", 40), ("batched", 400)])
def test_pyaa_run_writes_data_and_animation(engine, iterations, tmp_path, capsys):
    out = tmp_path / engine
    argv = ["run", "x8-patrol", "--agents", "4", "--engine", engine, "--out", str(out)]
    assert main([*argv, "--iterations", str(iterations), "--frame-every", "20", "--quiet"]) == 0
    table = pq.read_table(out / "states.parquet")
    assert set(table.column_names) >= X8_COLUMNS
    assert table.num_rows == 4 * (iterations + 1)
    altitude = np.asarray(table.column("altitude")).reshape(-1, 4)
    assert altitude[0].tolist() == [10.0] * 4 and (altitude[-1] > 10.0).all()  # climbing out
    gif = (out / "animation.gif").read_bytes()
    assert gif[:6] == b"GIF89a" and len(gif) > 1000
    assert '"model": "x8"' in (out / "run.json").read_text()


def test_scenario_round_trip_and_x8_settings_are_checked():
    scenario = load("x8-patrol")
    assert Scenario.from_mapping(to_mapping(scenario), source="x8") == scenario
    data = to_mapping(scenario)
    for key, value, message in [
        ("altitud", 20, "unknown key 'x8.altitud' (did you mean 'altitude'?)"),
        ("turbulence", "yes", "x8.turbulence must be true or false"),
        ("turbulence_intensity", "strong", "x8.turbulence_intensity must be one of"),
        ("dt", 0, "x8.dt must be a number > 0"),
        ("course_kp", -1, "x8.course_kp must be a number >= 0"),
    ]:
        bad = {**data, "x8": {**data["x8"], key: value}}
        with pytest.raises(ScenarioError, match=re.escape(message)):
            Scenario.from_mapping(bad, source="x8")
    known = r"unknown motion model 'x9' \(known: drone2d, drone3d, x8\)"
    with pytest.raises(ScenarioError, match=known):
        Scenario.from_mapping({**data, "model": "x9"}, source="x8")
    with pytest.raises(ScenarioError, match="unknown key 'x8'"):  # drone2d has no settings
        Scenario.from_mapping({**data, "model": "drone2d"}, source="x8")


def first_flight(turbulence: bool, seed: int, iterations: int = 20) -> np.ndarray:
    """x, y, altitude, airspeed of two UAVs launched alike (heading 45), shape (4, its + 1, 2)."""
    data = to_mapping(load("x8-patrol"))
    data["x8"]["turbulence"] = turbulence
    data["initial_heading"] = 45.0
    scenario = Scenario.from_mapping(data).with_overrides(agents=2, iterations=iterations)
    sim = Simulation.create(scenario, seed=seed, engine="pytrees").run(progress=False)
    return np.array([sim.recorder.column(k) for k in ("x", "y", "altitude", "airspeed")])


def test_turbulence_is_off_by_default_switchable_and_seeded():
    still, still_again = first_flight(False, 0), first_flight(False, 5)
    np.testing.assert_array_equal(still, still_again)  # no randomness in still air
    gusty = first_flight(True, 0)
    assert np.abs(gusty - still).max() > 1e-3
    np.testing.assert_array_equal(gusty, first_flight(True, 0))  # same seed, same gusts
    assert np.abs(first_flight(True, 1) - gusty).max() > 1e-6
    assert np.abs(gusty[:, :, 0] - gusty[:, :, 1]).max() > 1e-6  # each UAV its own gusts


def test_without_the_x8_extra_the_error_says_what_to_install(monkeypatch, capsys, tmp_path):
    from pyautonomousagent.simulation import motion

    monkeypatch.setattr(motion, "pyfly_installed", lambda: False)
    argv = ["run", "x8-patrol", "--iterations", "1", "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 2
    assert 'needs the [x8] extra: pip install "pyautonomousagent[x8]"' in capsys.readouterr().err


def test_vectorised_x8_refuses_turbulence():
    data = to_mapping(load("x8-patrol"))
    data["x8"]["turbulence"] = True
    scenario = Scenario.from_mapping(data)
    with pytest.raises(ScenarioError, match="PyFly reference model only"):
        Simulation.create(scenario, engine="batched")


@pytest.mark.parametrize("engine", ["pytrees", "batched"])
def test_an_x8_without_energy_is_grounded_where_it_is(engine):
    sim = Simulation.create(
        load("x8-patrol").with_overrides(agents=2, iterations=20), engine=engine
    )
    columns, moving = sim.swarm.columns, np.array([True, False])
    before = {k: v.copy() for k, v in columns.items()}
    altitude = sim.model.columns()["altitude"].copy()
    for _ in range(5):
        sim.model.advance(columns, moving)
        sim.model.control(columns)
    assert (columns["x"][1], columns["y"][1]) == (before["x"][1], before["y"][1])
    assert columns["speed"][1] == 0.0 and sim.model.columns()["altitude"][1] == altitude[1]
    assert columns["y"][0] != before["y"][0] and columns["speed"][0] > 15.0


def test_pyfly_histories_are_trimmed(monkeypatch):
    monkeypatch.setattr(x8_pyfly, "HISTORY_KEPT", 10)
    scenario = load("x8-patrol").with_overrides(agents=1, iterations=25)
    sim = Simulation.create(scenario, engine="pytrees")
    sim.run(progress=False)
    aircraft = sim.model.aircraft[0]  # type: ignore[attr-defined]
    assert len(aircraft.state["roll"].history) <= 11
    assert len(aircraft.state["elevon_left"].history["value"]) <= 11
    # PyFly appends the attitude at every evaluation of its right-hand side (~20 a step)
    assert len(aircraft.state["attitude"].history) <= 40 * 10


def test_a_benchmark_case_runs_in_its_own_process():
    case = bench.Case("x8-patrol", "batched", 3, 10, 1, full_iterations=100)
    result = bench.measure(case)
    assert result.error == "" and result.seconds > 0 and result.peak_mb > 10
    assert result.per_agent_iteration == (result.seconds - result.setup) / 30
    assert 0 < result.setup < result.seconds


def fake(case: bench.Case, timeout=None, budget_mb=None) -> bench.Result:
    per_uav_mb = {"pyfly": 10.0, "batched": 0.01}[case.engine]
    seconds = (3e-3 if case.engine == "pyfly" else 3e-5) * case.agents * case.iterations
    return bench.Result(case, seconds, 100 + per_uav_mb * case.agents)


def test_pyaa_bench_prints_the_table_with_a_scaled_reference(monkeypatch, capsys):
    monkeypatch.setattr(bench, "measure", fake)
    argv = ["bench", "x8-patrol", "--agents", "1,10", "--reference-iterations", "400"]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = {(line.split()[0], line.split()[1]): line for line in lines[2:]}
    assert lines[0].split()[:2] == ["agents", "engine"] and "paper" in lines[0]
    assert "~12.000" in rows[("1", "pyfly")]  # 3 ms x 4000 iterations, scaled from 400
    assert "100x" in rows[("10", "batched")] and "210.97" in rows[("10", "batched")]


def test_pyaa_bench_stress_skips_pyfly_and_finds_the_batched_limit(monkeypatch, capsys):
    monkeypatch.setattr(bench, "measure", fake)
    assert main(["bench", "x8-patrol", "--stress", "--stress-start", "1000"]) == 0
    out = capsys.readouterr().out
    assert "pyfly: skipped" in out
    # 100 MB + 0.01 MB per UAV fits 5.12 GB (5242.88 MB) up to 514,288 UAVs, within 2 %
    largest = int(out.split("at most ")[1].split()[0])
    assert 0.98 * 514_288 <= largest <= 514_288
