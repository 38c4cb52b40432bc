"""Sweep time series (``--every K``), results that explain themselves, and progress lines.

The time-series table is held equal to the same runs saved whole (``--save-runs``), cut at
each checkpoint and reduced by the same measure functions; bad input is one line, exit 2,
nothing written."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest

from pyautonomousagent.cli import main
from pyautonomousagent.experiments import Experiment, sweep
from pyautonomousagent.experiments.measures import Measure, RunData
from pyautonomousagent.experiments.runner import partition_dir
from pyautonomousagent.experiments.series import TIMESERIES, checkpoints
from pyautonomousagent.experiments.spec import ExperimentError
from pyautonomousagent.experiments.sweeps import base_scenario
from pyautonomousagent.progress import Progress
from tests.test_experiments import same_rows

#: 6 runs of patrol, 3 drones x 400 iterations, every 50 iterations; drones refuel.
EXPERIMENT = {
    "scenario": "patrol",
    "iterations": 400,
    "set": {"agents": 3},
    "vary": {"low_energy_threshold": {"from": 96, "to": 99, "step": 3}},
    "seeds": 3,
    "every": 50,
    "measures": ["refuels", "minimum_energy", "distance_flown", "fraction_refuelling",
                 {"low": "mean(energy < 90)"}],
}  # fmt: skip


@pytest.fixture(scope="module")
def swept(tmp_path_factory) -> Path:
    """The experiment swept in this process, each run also saved whole."""
    out = tmp_path_factory.mktemp("series") / "sweep"
    result = sweep(Experiment.from_mapping(EXPERIMENT), out, "serial", save_runs=True)
    assert result.counts == {"ok": 6, "failed": 0, "skipped": 0}
    return out


def saved_run(path: Path, experiment: Experiment, seed: int, until: int) -> RunData:
    """A run's saved data (one row per record and agent) up to iteration ``until``, as the
    measures read it: each column shape (records, N)."""
    table = pq.read_table(path)
    table = table.filter(pc.less_equal(table["iteration"], until))
    agents = len(set(table["agent"].to_pylist()))
    iterations = np.asarray(table["iteration"].to_numpy()[::agents])
    columns = {
        name: table[name].to_numpy().astype(float).reshape(-1, agents)
        for name in table.column_names
        if pa.types.is_floating(table.schema.field(name).type)
    }
    return RunData(base_scenario(experiment), seed, iterations, columns)


def reduced(measure: Measure, data: RunData) -> float:
    """The measure of ``data``, NaN where it raises (too few records yet)."""
    try:
        return measure(data)
    except Exception:
        return math.nan


def test_time_series_equals_the_saved_runs_reduced(swept) -> None:
    experiment = Experiment.from_mapping(EXPERIMENT)
    series = pq.read_table(swept / TIMESERIES)
    results = pq.read_table(swept / "results.parquet")
    assert series.column_names == ["run_id", "iteration", "measure", "value"]
    assert series.num_rows == 6 * len(experiment.measures) * 9  # iterations 0, 50, ..., 400
    kept = {(r["run_id"], r["iteration"], r["measure"]): r["value"] for r in series.to_pylist()}
    refuelled = 0.0
    for run in experiment.runs():
        path = partition_dir(swept / "runs", run) / "data.parquet"
        for until in range(0, 401, 50):
            data = saved_run(path, experiment, run.seed, until)
            for measure in experiment.measures:
                expected = reduced(measure, data)
                got = kept[(run.run_id, until, measure.name)]
                assert got == pytest.approx(expected, nan_ok=True), (run, until, measure.name)
        row = results.filter(pc.equal(results["run_id"], run.run_id)).to_pylist()[0]
        for measure in experiment.measures:  # the last checkpoint is the run's result
            assert kept[(run.run_id, 400, measure.name)] == pytest.approx(
                row[measure.name], nan_ok=True
            )
        refuelled += row["refuels"]
    assert refuelled > 0  # the runs refuel: the series are not all zeros


def test_checkpoints_are_multiples_and_the_last_iteration() -> None:
    assert checkpoints(np.arange(0, 11), 4).tolist() == [0, 4, 8, 10]
    assert checkpoints(np.arange(0, 13, 3), 6).tolist() == [0, 6, 12]
    assert checkpoints(np.array([], np.int64), 5).tolist() == []


def test_every_must_be_a_multiple_of_record_every() -> None:
    with pytest.raises(ExperimentError, match="every must be a multiple of record_every"):
        Experiment.from_mapping({**EXPERIMENT, "record_every": 3, "every": 50})
    assert Experiment.from_mapping({**EXPERIMENT, "record_every": 5}).every == 50


def test_results_and_series_explain_themselves(swept) -> None:
    results = pq.read_table(swept / "results.parquet")
    threshold = results.schema.field("low_energy_threshold")
    assert threshold.type == pa.float64()  # a float parameter, though varied as 96:99:3
    assert threshold.metadata[b"unit"] == b"percent"
    assert results.schema.field("refuels").metadata[b"unit"] == b"refuels"
    assert results.schema.field("seconds").metadata[b"unit"] == b"s"
    assert all(f.metadata and b"description" in f.metadata for f in results.schema)
    assert set(results["engine"].to_pylist()) <= {"batched", "compiled", "gpu", "pytrees"}
    assert None not in results["engine"].to_pylist()
    series = pq.read_table(swept / TIMESERIES)
    assert series.schema.field("iteration").metadata[b"unit"] == b"iterations"
    units = json.loads(series.schema.metadata[b"measures"])
    assert units["minimum_energy"]["unit"] == "%"


def test_plot_over_time_draws_a_band_per_parameter_value(swept, tmp_path, capsys) -> None:
    out = tmp_path / "energy.png"
    argv = ["plot", str(swept), "--measure", "minimum_energy", "--over-time", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "low_energy_threshold=96.0 iteration 400: n=3" in printed
    assert "low_energy_threshold=99.0 iteration 400: n=3" in printed
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--every", "0"], "--every must be a whole number >= 1"),
        (["--every", "-5"], "--every must be a whole number >= 1"),
        (["--every", "10", "--measure", "nope"], "unknown measure 'nope'"),
        (["--every", "10", "--record-every", "3"], "every must be a multiple of record_every"),
    ],
)
def test_bad_time_series_input_is_one_line_and_writes_nothing(tmp_path, capsys, argv, message):
    out = tmp_path / "sweep"
    code = main(["sweep", "patrol", "--vary", "low_energy_threshold=60,80", "--out", str(out)]
                + argv)  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2
    assert message in err and err.count("\n") == 1, err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_plot_over_time_bad_input_is_one_line(swept, tmp_path, capsys) -> None:
    out = tmp_path / "x.png"
    for argv, message in [
        (["--measure", "refuel"], "unknown measure 'refuel' in the time series (did you mean"),
        (["--measure", "refuels", "--x", "seed"], "leave out --x"),
    ]:
        assert main(["plot", str(swept), "--over-time", "--out", str(out), *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err
    assert main(["plot", str(swept), "--measure", "refuels", "--out", str(out)]) == 2
    assert "--x is needed" in capsys.readouterr().err  # a plot against a parameter needs it
    assert not out.exists()


def test_a_sweep_without_series_says_how_to_get_one(tmp_path, capsys) -> None:
    out = tmp_path / "plain"
    experiment = {**EXPERIMENT, "iterations": 20, "seeds": 1}
    del experiment["every"]
    sweep(Experiment.from_mapping(experiment), out, "serial", progress=False)
    assert not (out / TIMESERIES).exists()
    assert main(["plot", str(out), "--measure", "refuels", "--over-time"]) == 2
    assert "run the sweep with --every K" in capsys.readouterr().err


def test_a_sweep_into_a_file_prints_progress_lines(tmp_path, capsys) -> None:
    out = tmp_path / "sweep"
    argv = ["sweep", "patrol", "--vary", "low_energy_threshold=60,70,80,90", "--iterations",
            "20", "--agents", "2", "--serial", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    err = capsys.readouterr().err  # not a terminal: lines, not a bar
    lines = re.findall(r"^sweep patrol-sweep: (\d)/4 runs \((\d+) %\), \d+ s", err, re.M)
    assert [done for done, _ in lines] == ["1", "2", "3", "4"]
    assert "\r" not in err


def test_pyaa_sweep_with_its_output_redirected_to_a_file_writes_progress_lines(tmp_path) -> None:
    log = tmp_path / "sweep.log"
    argv = [sys.executable, "-m", "pyautonomousagent.cli", "sweep", "patrol", "--vary",
            "low_energy_threshold=60,70,80", "--iterations", "20", "--agents", "2", "--serial",
            "--out", str(tmp_path / "sweep")]  # fmt: skip
    with log.open("w") as err:
        done = subprocess.run(argv, stderr=err, stdout=subprocess.DEVNULL, timeout=300, check=False)
    assert done.returncode == 0
    text = log.read_text()
    assert re.findall(r"^sweep patrol-sweep: (\d)/3 runs", text, re.M) == ["1", "2", "3"], text


def test_progress_lines_come_every_5_percent_or_10_seconds(monkeypatch, tmp_path) -> None:
    clock = [0.0]
    monkeypatch.setattr("pyautonomousagent.progress.time.perf_counter", lambda: clock[0])
    with (tmp_path / "log").open("w") as log:
        bar = Progress(1000, "work", stream=log, lines=True, unit="items")
        for done in range(1, 1001):
            clock[0] = done * 0.001 if done < 500 else 0.5 + (done - 500) * 1.0
            bar.update(done)
        bar.close()
    text = (tmp_path / "log").read_text().splitlines()
    firsts = [int(line.split()[1].split("/")[0]) for line in text]
    assert firsts[:10] == [50, 100, 150, 200, 250, 300, 350, 400, 450, 500]  # 5 % each
    assert firsts[10:12] == [510, 520]  # then 10 s each, the slower work
    assert firsts[-1] == 1000 and text[-1].startswith("work: 1000/1000 items (100 %)")


def _kill_once(run: RunData) -> float:
    """A measure whose first call in a marked run kills its worker process (a lost worker)."""
    marker = Path(os.environ["PYAA_TEST_KILL_MARKER"])
    if run.seed == 1 and not marker.exists():
        marker.write_text("killed")
        os.kill(os.getpid(), signal.SIGKILL)
    return 1.0


def test_a_lost_pool_worker_is_named_and_counted(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setenv("PYAA_TEST_KILL_MARKER", str(tmp_path / "killed"))
    experiment = {**EXPERIMENT, "iterations": 20, "seeds": [0, 1, 2]}
    killing = (Measure("kill_once", _kill_once, "kills its worker once"),)
    chosen = dataclasses.replace(Experiment.from_mapping(experiment), measures=killing)
    out = tmp_path / "sweep"
    result = sweep(chosen, out, "pool", workers=2)
    assert result.counts == {"ok": 6, "failed": 0, "skipped": 0}
    err = capsys.readouterr().err
    assert re.search(r"pool worker process \d+ died \(exit code -9\); \d run\(s\) given again", err)
    backend = json.loads((out / "experiment.json").read_text())["backend"]
    assert backend["workers_lost"] == 1 and backend["runs_retried"] >= 1
    assert backend["workers_seen"] >= 3  # two at the start, one started after the loss


def test_an_interrupted_sweep_resumes_to_the_same_time_series(swept, tmp_path) -> None:
    experiment = Experiment.from_mapping(EXPERIMENT)
    out = tmp_path / "sweep"
    seen: list[str] = []

    def interrupt(row: dict) -> None:
        seen.append(row["run_id"])
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(experiment, out, "serial", on_result=interrupt, flush_every=1, progress=False)
    partial = pq.read_table(out / TIMESERIES)
    assert set(partial["run_id"].to_pylist()) == set(seen)  # the journaled runs' series
    sweep(experiment, out, "serial", resume=True, progress=False)
    resumed, whole = pq.read_table(out / TIMESERIES), pq.read_table(swept / TIMESERIES)
    assert resumed.schema.equals(whole.schema, check_metadata=True)
    assert same_rows(resumed, whole)  # NaN where a measure is undefined at iteration 0


def test_the_start_log_reads_each_dask_start_once() -> None:
    from pyautonomousagent.experiments.backends import StartLog

    def start(when: float, key: str, worker: str) -> tuple[float, dict[str, str]]:
        return when, {"key": key, "worker": worker}

    log = StartLog()
    pushed = [start(1.0, "k0", "a"), start(1.0, "k1", "b"), start(2.0, "k2", "a")]
    assert log.read(pushed) == []
    assert log.read(pushed) == []  # read again (the scheduler's whole log): nothing new
    later = [start(3.0, "k0", "b"), start(3.0, "k3", "b")]  # k0 again, on another worker
    assert log.read([*pushed, *later]) == [("k0", "b", "a")]
    assert log.read(later[::-1]) == []
    assert log.read([start(3.0, "k2", "b")]) == [("k2", "b", "a")]  # same time, not read yet


@pytest.mark.parametrize(("seconds", "expected"), [(5.0, []), (40.0, list(range(250, 1001, 50)))])
def test_a_run_writes_progress_lines_once_it_has_taken_10_seconds(
    monkeypatch, tmp_path, seconds, expected
) -> None:
    clock = [0.0]
    monkeypatch.setattr("pyautonomousagent.progress.time.perf_counter", lambda: clock[0])
    with (tmp_path / "log").open("w") as log:
        bar = Progress(1000, "patrol", stream=log, lines=True, unit="iterations",
                       first_line_after=10.0)  # fmt: skip
        for done in range(50, 1001, 50):  # pyaa run updates every 50 iterations
            clock[0] = done * seconds / 1000
            bar.update(done)
        bar.close()
    text = (tmp_path / "log").read_text().splitlines()
    assert [int(line.split()[1].split("/")[0]) for line in text] == expected
