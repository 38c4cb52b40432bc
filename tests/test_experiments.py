"""Experiments: the expression language, measures, experiment validation, sweeps, plots, CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.cli import main
from pyautonomousagent.experiments import (
    MEASURES,
    Experiment,
    ExperimentError,
    Expression,
    ExpressionError,
    Measure,
    RunData,
    plot_measure,
    sweep,
)
from pyautonomousagent.experiments import measures as m
from pyautonomousagent.experiments.plot import summarize, t95
from pyautonomousagent.experiments.spec import inclusive_range, parse_vary
from pyautonomousagent.experiments.sweeps import base_scenario, check
from pyautonomousagent.missions.drones import measures as drone_measures
from pyautonomousagent.missions.gathering import measures as gathering_measures

#: A tiny patrol sweep: 5 drones x 400 iterations, thresholds high enough to refuel.
TINY = {
    "scenario": "patrol",
    "iterations": 400,
    "set": {"agents": 5},
    "vary": {"low_energy_threshold": [96, 99]},
    "seeds": 2,
    "measures": ["refuels", "alerts", "minimum_energy", {"low": "mean(energy < 95)"}],
}


def run_data(energy: list[list[float]], x=None, y=None, events=None, every: int = 1) -> RunData:
    """A RunData of hand-made columns, shape (records, N)."""
    e = np.asarray(energy, dtype=float)
    zeros = np.zeros_like(e)
    columns = {
        "energy": e,
        "x": zeros if x is None else np.asarray(x, float),
        "y": zeros if y is None else np.asarray(y, float),
    }
    scenario = load("gathering").with_overrides(agents=e.shape[1], iterations=every * (len(e) - 1))
    return RunData(scenario, 0, np.arange(len(e)) * every, columns, events or [])


def same_rows(a: pa.Table, b: pa.Table, ignore: tuple[str, ...] = ()) -> bool:
    """Equal tables, NaN equal to NaN, leaving out the ``ignore`` columns."""

    def rows(t: pa.Table) -> list[dict]:
        kept = t.drop_columns([c for c in ignore if c in t.column_names])
        return [{k: "NaN" if isinstance(v, float) and math.isnan(v) else v for k, v in r.items()}
                for r in kept.to_pylist()]  # fmt: skip

    return a.schema == b.schema and rows(a) == rows(b)


# --- the expression language -------------------------------------------------------------


def test_expressions_compute_over_columns() -> None:
    energy = np.array([[100.0, 50.0], [20.0, 40.0], [10.0, 90.0]])
    values = {"energy": energy, "agents": 2.0}
    assert Expression("mean(energy < 30)").evaluate(values) == pytest.approx(2 / 6)
    assert Expression("min(last(energy))").evaluate(values) == 10.0
    assert Expression("max(first(energy)) - 1").evaluate(values) == 99.0
    assert Expression("sum(energy) / agents").evaluate(values) == pytest.approx(155.0)
    assert Expression("count(20 <= energy <= 50)").evaluate(values) == 3
    assert Expression("-2 ** 2 + 10 % 4 + 7 // 2").evaluate(values) == -4 + 2 + 3
    assert Expression("sqrt(abs(-16))").evaluate(values) == 4.0


@pytest.mark.parametrize(
    "text",
    [
        "__import__('os').system('true')",
        "energy.__class__",
        "open('/etc/passwd')",
        "[e for e in energy]",
        "(lambda: 1)()",
        "energy[0]",
        "'text'",
        "mean(energy, axis=0)",
        "mean(energy, energy)",
        "_hidden",
        "energy if 1 else 2",
        "a and b",
        "9 ** 9 ** 9 ** 9; 1",
    ],
)
def test_unsafe_or_unknown_syntax_is_refused_in_one_line(text: str) -> None:
    with pytest.raises(ExpressionError) as caught:
        Expression(text)
    message = str(caught.value)
    assert "\n" not in message and ("not allowed" in message or "syntax error" in message)


def test_expression_errors_name_the_problem() -> None:
    with pytest.raises(ExpressionError, match="did you mean 'energy'"):
        Expression("mean(enrgy)").evaluate({"energy": np.ones((2, 2))})
    with pytest.raises(ExpressionError, match="gives 2 values, not one"):
        Expression("last(energy)").evaluate({"energy": np.ones((2, 2))})
    with pytest.raises(ExpressionError, match="longer than"):
        Expression("1 + " * 200 + "1")
    assert Expression("9.0 ** 9 ** 9").evaluate({}) == math.inf  # floats: no huge integers


# --- measures ----------------------------------------------------------------------------


def test_builtin_measures_on_known_data() -> None:
    # agent 0 falls to 96, refuels (2 records), falls, refuels again; agent 1 never refuels
    energy = [[100, 100], [98, 99], [96, 98], [98, 97], [100, 96], [99, 95], [100, 94]]
    x = [[0, 0], [3, 0], [3, 0], [3, 0], [3, 0], [3, 0], [3, 0]]
    y = [[0, 0], [4, 0], [4, 0], [4, 0], [4, 0], [4, 0], [4, 1]]
    run = run_data(energy, x, y, events=[{"event": "alert", "agent": "drone2"}], every=10)
    assert drone_measures.refuels(run) == 2
    # the record at iteration 30 is the first rise
    assert drone_measures.time_to_first_refuel(run) == 30
    assert drone_measures.minimum_energy(run) == 94
    assert m.distance_flown(run) == 5 + 1
    assert m.alerts(run) == 1
    assert drone_measures.fraction_refuelling(run) == pytest.approx(3 / 12)
    assert math.isnan(gathering_measures.gathering_time(run))  # no gathering order
    flat = run_data([[100, 100], [99, 99]])
    assert drone_measures.refuels(flat) == 0
    assert math.isnan(drone_measures.time_to_first_refuel(flat))


def test_gathering_time_is_when_the_last_agent_arrives() -> None:
    order = {"event": "message", "type": "gathering", "iteration": 2, "data": {"x": 5.0, "y": 5.0}}
    x = [[5, 0], [5, 0], [0, 0], [5, 1], [0, 5]]  # agent 0 is near before the order: ignored
    run = run_data([[100, 100]] * 5, x, [[5, 0], [5, 0], [0, 0], [5, 0], [5, 5]], [order])
    assert gathering_measures.gathering_time(run) == 4 - 2  # agent 0 at iteration 3, agent 1 at 4
    never = run_data([[100, 100]] * 3, events=[order])
    assert math.isnan(gathering_measures.gathering_time(never))


def test_gathering_time_of_the_gathering_scenario(gathering_run: Simulation) -> None:
    run = RunData.from_simulation(gathering_run)
    arrived = 5000 + gathering_measures.gathering_time(run)  # the order is given at iteration 5000
    assert 5000 < arrived < 8000
    row = int(np.flatnonzero(run.iterations == arrived)[0])
    x, y = run.columns["x"], run.columns["y"]
    near = np.hypot(x[5000 : row + 1] - 50.0, y[5000 : row + 1] - 50.0) <= 0.5  # drone1's point
    assert near.any(axis=0).all() and not near[:-1].any(axis=0).all()


def test_measures_of_a_real_run_agree_with_its_events_and_table() -> None:
    scenario = load("patrol").with_overrides(agents=5, iterations=150, energy_use=1.0)
    sim = Simulation.create(scenario, seed=0).run(progress=False)
    run = RunData.from_simulation(sim)
    table = sim.table()
    assert m.alerts(run) == 5  # every drone runs dry at 1 % per iteration
    assert drone_measures.minimum_energy(run) == 0.0 == pa.compute.min(table["energy"]).as_py()
    assert math.isnan(drone_measures.time_to_first_refuel(run))
    expected = Expression("mean(energy == 0)").evaluate(run.expression_values())
    zero = pa.compute.equal(table["energy"], 0.0)
    assert expected == pa.compute.sum(zero).as_py() / table.num_rows


def test_time_per_behaviour_from_the_recorded_active_leaf() -> None:
    scenario = load("patrol").with_overrides(agents=5, iterations=400, low_energy_threshold=96)
    run = RunData.from_simulation(Simulation.create(scenario, seed=0).run(progress=False))
    fractions = m.behaviour_fractions(run)
    assert set(fractions) <= set(run.nodes) and "action_refuel_a" in fractions
    assert sum(fractions.values()) == pytest.approx(1 - 1 / 401)  # iteration 0: no tick yet
    refuelling = Expression("mean(in_action_refuel_a)").evaluate(run.expression_values())
    assert refuelling == fractions["action_refuel_a"] > 0
    # while the refuel action runs, the energy rises
    acting = run.behaviour[1:] == run.nodes.index("action_refuel_a")
    assert (np.diff(run.columns["energy"], axis=0)[acting] > 0).all()


def test_a_mission_registers_its_own_measure() -> None:
    def final_energy(run: RunData) -> float:
        return float(run.columns["energy"][-1].mean())

    with MEASURES.override("final_energy", Measure("final_energy", final_energy, "", "%")):
        experiment = Experiment.from_mapping({**TINY, "measures": ["final_energy"]})
        assert experiment.measures[0].fn is final_energy
    assert "final_energy" not in MEASURES
    with pytest.raises(ExperimentError, match="unknown measure 'final_energy'"):
        Experiment.from_mapping({**TINY, "measures": ["final_energy"]})


# --- the experiment description ----------------------------------------------------------


def test_grid_ranges_samples_and_run_keys() -> None:
    assert inclusive_range(20, 50, 10) == [20, 30, 40, 50]
    assert inclusive_range(0.1, 0.3, 0.1) == [0.1, 0.2, 0.3]
    sampled = {
        **TINY,
        "vary": {"refuel_rate": [1, 2]},
        "sample": {
            "count": 3,
            "seed": 7,
            "parameters": {
                "energy_use": {"uniform": [0.03, 0.07]},
                "agents": {"integers": [2, 4]},
                "low_energy_threshold": {"choice": [30, 40]},
            },
        },
    }
    experiment = Experiment.from_mapping(sampled)
    points = experiment.points()
    assert len(points) == 2 * 3 and experiment.points() == points  # same seed, same points
    assert all(0.03 <= p["energy_use"] <= 0.07 and 2 <= p["agents"] <= 4 for p in points)
    assert experiment.parameters == ["refuel_rate", "energy_use", "agents", "low_energy_threshold"]
    runs = experiment.runs()
    assert len(runs) == 12 and len({r.run_id for r in runs}) == 12
    again = Experiment.from_mapping(experiment.to_mapping())
    assert [r.run_id for r in again.runs()] == [r.run_id for r in runs]
    assert parse_vary(["a=1,2", "b=0.5:1.5:0.5"]) == {
        "a": [1, 2],
        "b": {"from": 0.5, "to": 1.5, "step": 0.5},
    }


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"sedes": 3}, "unknown key 'sedes' (did you mean 'seeds'?)"),
        ({"scenario": None}, "scenario must be a non-empty string"),
        ({"vary": {}}, "nothing varies"),
        ({"vary": {"refuel_rate": {"from": 1, "to": 3}}}, "vary.refuel_rate must be"),
        ({"vary": {"refuel_rate": {"from": 1, "to": 3, "step": 0}}}, "step > 0"),
        ({"vary": {"refuel_rate": [1, 1]}}, "without repeated values"),
        ({"vary": {"refuel_rate": [1, "a"]}}, "values of one kind"),
        ({"vary": {"refuel_rate": []}}, "non-empty list"),
        ({"seeds": 0}, "seeds must be a count from 1"),
        ({"seeds": [1, -2]}, "seeds[1] must be a whole number >= 0"),
        ({"measures": ["refules"]}, "did you mean 'refuels'"),
        ({"measures": [{"low": "__import__('os')"}]}, "measures[0]: expression"),
        ({"measures": [{"seed": "mean(energy)"}]}, "measure 'seed' is a result column"),
        ({"vary": {"seed": [1, 2]}}, "parameter 'seed' is a result column"),
        ({"vary": {"agents": {"from": 1, "to": 10**7, "step": 1}}}, "at most 1000000"),
        ({"record_every": 0}, "record_every must be a whole number >= 1"),
        ({"set": {"iterations": 9}}, "iterations given twice, as 'iterations' and in 'set'"),
        (
            {
                "set": {},
                "vary": {"agents": list(range(1, 1001)), "refuel_rate": list(range(1001))},
            },
            "at most 1000000 runs",
        ),
        (
            {"sample": {"count": 10**12, "seed": 1, "parameters": {"a": {"uniform": [0, 1]}}}},
            "sample.count must be a whole number from 1 to 1000000",
        ),
        ({"sample": {"count": 2, "seed": 1, "parameters": {"a": {"normal": 1}}}}, "uniform"),
    ],
)
def test_bad_experiments_are_refused_in_one_line(change: dict, message: str) -> None:
    with pytest.raises(ExperimentError) as caught:
        Experiment.from_mapping({**TINY, **change}, source="exp.yaml")
    text = str(caught.value)
    assert message in text and text.startswith("exp.yaml: ") and "\n" not in text


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"vary": {"low_energy_thresold": [1, 2]}}, "did you mean 'low_energy_threshold'"),
        ({"set": {}, "vary": {"agents": [2, -1]}}, "agents must be a whole number >= 1, got -1"),
        ({"measures": [{"low": "mean(enrgy)"}]}, "unknown column 'enrgy' (did you mean"),
        ({"scenario": "patrl"}, "did you mean 'patrol'"),
        ({"vary": {"tree": ["nothere.xml"]}}, "tree: no file 'nothere.xml'"),
        ({"iterations": None, "set": {"iterations": "x"}}, "iterations must be a whole number"),
    ],
)
def test_sweep_checks_against_the_scenario_before_running(tmp_path, change, message) -> None:
    experiment = Experiment.from_mapping({**TINY, **change})
    with pytest.raises(ExperimentError, match=message.replace("(", r"\(")):
        sweep(experiment, tmp_path / "out", "serial")
    assert not (tmp_path / "out").exists()


def test_iterations_may_be_set_in_set(tmp_path) -> None:
    experiment = Experiment.from_mapping({**TINY, "iterations": None, "set": {"iterations": 7}})
    assert base_scenario(experiment).iterations == 7


def test_the_worked_example_file_is_valid() -> None:
    path = Path(__file__).parents[1] / "examples" / "threshold-sweep.yaml"
    experiment = Experiment.from_file(path)
    assert len(experiment.runs()) == 100 and experiment.parameters[1] == "energy_use"
    probe = check(experiment, base_scenario(experiment))
    assert "energy" in probe.columns and base_scenario(experiment).agents == 100
    assert "in_action_refuel_a" in probe.expression_values()


def test_experiment_file_errors(tmp_path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("scenario: patrol\nvary: [1, 2\n")
    with pytest.raises(ExperimentError, match=r"bad.yaml:\d+: not valid YAML"):
        Experiment.from_file(path)
    with pytest.raises(ExperimentError, match="cannot read experiment file"):
        Experiment.from_file(tmp_path / "missing.yaml")


#: 2**40 values from 40 lines of YAML aliases.
ALIAS_BOMB = "a0: &a0 [1, 1]\n" + "".join(
    f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}]\n" for i in range(1, 40)
)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("scenario: patrol\nscenario: gathering\n", "'scenario' is given twice"),
        (ALIAS_BOMB, "aliases .* expand the document"),
        (b"scenario: p\xe9trol\n", "not UTF-8"),
    ],
)
def test_experiment_files_are_read_with_the_input_limits(tmp_path, text, message) -> None:
    """Experiment files go through the same guarded YAML reader as scenarios (issue 9)."""
    path = tmp_path / "bad.yaml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(ExperimentError, match=message):
        Experiment.from_file(path)


def test_vary_values_are_read_with_the_input_limits() -> None:
    assert parse_vary(["x=1,2.5,a"]) == {"x": [1, 2.5, "a"]}
    assert parse_vary(["x=[1,"]) == {"x": ["[1"]}  # text, for the parameter's schema to refuse
    with pytest.raises(ExperimentError, match="--vary x"):
        parse_vary(["x=2024-02-30"])


# --- sweeps in this process --------------------------------------------------------------


def test_a_failing_run_is_recorded_and_the_sweep_goes_on(tmp_path) -> None:
    def fragile(run: RunData) -> float:
        if run.seed == 1 and run.scenario.parameters.low_energy_threshold == 99:
            raise ValueError("seed 1 broke\nsecond line")
        return 1.0

    with MEASURES.override("fragile", Measure("fragile", fragile)):
        experiment = Experiment.from_mapping({**TINY, "measures": ["fragile", "refuels"]})
    result = sweep(experiment, tmp_path / "s", "serial", save_runs=True)
    rows = result.table.to_pylist()
    assert result.counts == {"ok": 3, "failed": 1, "skipped": 0}
    failed = [r for r in rows if r["status"] == "failed"]
    assert [(r["low_energy_threshold"], r["seed"]) for r in failed] == [(99, 1)]
    assert failed[0]["error"] == "ValueError: seed 1 broke" and math.isnan(failed[0]["fragile"])
    assert failed[0]["agents"] == 5 and failed[0]["energy_use"] == 0.05
    assert all(r["fragile"] == 1.0 for r in rows if r["status"] == "ok")
    assert same_rows(pq.read_table(tmp_path / "s" / "results.parquet"), result.table)
    # per-run data: one hive-partitioned dataset, parameters and seed as columns
    data = ds.dataset(tmp_path / "s" / "runs", partitioning="hive").to_table()
    assert set(data.column_names) >= {"low_energy_threshold", "seed", "iteration", "energy"}
    assert data.num_rows == 3 * 401 * 5  # the failed run wrote nothing
    one = data.filter((ds.field("low_energy_threshold") == 96) & (ds.field("seed") == 1))
    scenario = load("patrol").with_overrides(agents=5, iterations=400, low_energy_threshold=96)
    expected = Simulation.create(scenario, seed=1).run(progress=False).table()
    assert one.sort_by([("iteration", "ascending")])["x"].equals(expected["x"])


def test_sweep_refuses_another_sweeps_folder_and_a_changed_experiment(tmp_path) -> None:
    small = Experiment.from_mapping({**TINY, "iterations": 20, "measures": ["minimum_energy"]})
    sweep(small, tmp_path / "s", "serial")
    with pytest.raises(ExperimentError, match="already holds a sweep; pass --resume"):
        sweep(small, tmp_path / "s", "serial")
    changed = Experiment.from_mapping({**TINY, "iterations": 30, "measures": ["minimum_energy"]})
    with pytest.raises(ExperimentError, match=r"different experiment \(iterations changed\)"):
        sweep(changed, tmp_path / "s", "serial", resume=True)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(ExperimentError, match="is not empty and holds no sweep"):
        sweep(small, tmp_path / "other", "serial")
    again = sweep(small, tmp_path / "s", "serial", resume=True)
    assert again.counts == {"ok": 0, "failed": 0, "skipped": 4}
    manifest = json.loads((tmp_path / "s" / "experiment.json").read_text())
    assert manifest["results"] == {"ok": 4, "failed": 0} and manifest["status"] == "finished"
    assert manifest["runs"] == 4 and manifest["experiment"] == small.to_mapping()


def test_a_measure_the_pool_cannot_receive_is_refused_before_running(tmp_path) -> None:
    with MEASURES.override("here", Measure("here", lambda run: 1.0)):
        experiment = Experiment.from_mapping({**TINY, "measures": ["here"]})
    with pytest.raises(ExperimentError, match="cannot be sent to the pool's processes"):
        sweep(experiment, tmp_path / "s", "pool", workers=1)
    assert not (tmp_path / "s").exists()
    assert sweep(experiment, tmp_path / "t", "serial").counts["ok"] == 4


def test_a_run_too_large_for_a_worker_is_refused(tmp_path) -> None:
    from pyautonomousagent.experiments.backends import SerialBackend

    class Small(SerialBackend):
        def memory_per_worker(self) -> int:
            return 64 * 2**20

    experiment = Experiment.from_mapping(TINY)
    with pytest.raises(ExperimentError, match=r"needs about \d+ MiB .*\(--record-every\)"):
        sweep(experiment, tmp_path / "s", Small())


# --- plots -------------------------------------------------------------------------------


def test_summary_mean_and_intervals() -> None:
    table = pa.table({
        "p": [1, 1, 1, 2, 2, 2],
        "q": ["a", "a", "a", "a", "a", "b"],
        "score": [1.0, 2.0, 3.0, 10.0, 10.0, float("nan")],
        "status": ["ok"] * 5 + ["ok"],
    })  # fmt: skip
    rows = summarize(table, "score", "p")
    assert [(r["x"], r["n"], r["mean"]) for r in rows] == [(1, 3, 2.0), (2, 2, 10.0)]
    assert rows[0]["high"] - 2.0 == pytest.approx(t95(2) * 1.0 / math.sqrt(3))
    assert t95(2) == 4.303 and t95(1000) == 1.96
    assert summarize(table, "score", "p", interval="range")[0]["low"] == 1.0
    assert summarize(table, "score", "p", interval="sd")[0]["high"] == pytest.approx(3.0)
    assert [r["by"] for r in summarize(table, "score", "p", by="q")] == ["a", "a"]
    with pytest.raises(ExperimentError, match="unknown parameter 'pp' \\(did you mean 'p'"):
        summarize(table, "score", "pp")


def test_plot_is_written_as_png_and_svg(tmp_path) -> None:
    table = pa.table({
        "threshold": [20, 20, 30, 30, 20, 20, 30, 30],
        "rate": [1, 1, 1, 1, 2, 2, 2, 2],
        "refuels": [3.0, 4.0, 5.0, 6.0, 1.0, 2.0, 2.0, 3.0],
        "status": ["ok"] * 8,
    })  # fmt: skip
    png = plot_measure(table, "refuels", "threshold", by="rate", out=tmp_path / "r.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000
    svg = plot_measure(table, "refuels", "threshold", out=tmp_path / "r.svg", interval="sd")
    assert "<svg" in svg.read_text()
    trees = table.append_column("tree", pa.array(["a/x.xml", "b.yaml"] * 4))
    categories = plot_measure(trees, "refuels", "tree", by="rate", out=tmp_path / "t.svg")
    assert "x.xml" in categories.read_text() and "a/x.xml" not in categories.read_text()
    with pytest.raises(ExperimentError, match="use a .png or .svg name"):
        plot_measure(table, "refuels", "threshold", out=tmp_path / "r.gif")


# --- the command line --------------------------------------------------------------------


def test_cli_sweep_then_plot(tmp_path, capsys) -> None:
    out = tmp_path / "s"
    code = main([
        "sweep", "patrol", "--vary", "low_energy_threshold=96:99:3", "--agents", "5",
        "--iterations", "400", "--seeds", "2", "--measure", "refuels",
        "--measure", "low=mean(energy < 95)", "--serial", "--quiet", "--out", str(out),
    ])  # fmt: skip
    assert code == 0
    table = pq.read_table(out / "results.parquet")
    assert table.column_names[:4] == ["run", "run_id", "low_energy_threshold", "seed"]
    assert table["low_energy_threshold"].to_pylist() == [96, 96, 99, 99]
    assert table["agents"].to_pylist() == [5] * 4 and table["iterations"].to_pylist() == [400] * 4
    assert table["refuel_rate"].to_pylist() == [2.0] * 4  # every parameter is a column
    assert main(["plot", str(out), "--measure", "low", "--x", "low_energy_threshold"]) == 0
    printed = capsys.readouterr().out
    assert "low_energy_threshold=96.0: n=2" in printed  # a float parameter: a float column
    assert (out / "low-vs-low_energy_threshold.png").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["sweep", "patrol", "--vary", "refuel_rate"], "--vary needs NAME="),
        (["sweep", "patrol", "--vary", "x=1,2", "--serial"], "unknown parameter 'x'"),
        (["sweep", "patrol", "--vary", "refuel_rate=1,2", "--measure", "y=open('f')"],
         "not allowed"),
        (["plot", "nowhere", "--measure", "a", "--x", "b"], "no sweep results"),
    ],
)  # fmt: skip
def test_cli_bad_input_is_one_line_exit_2(tmp_path, capsys, argv, message) -> None:
    assert main([*argv, *(["--out", str(tmp_path / "o")] if argv[0] == "sweep" else [])]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and err.startswith("pyaa: error: ")


def test_dask_is_imported_only_for_a_dask_backend() -> None:
    import subprocess
    import sys

    code = (
        "import sys, pyautonomousagent.cli, pyautonomousagent.experiments.backends as b;"
        "b.make_backend('pool', 1).close();"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))"
    )
    found = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert found.stdout.strip() == "[]"
