"""Sweeps on real backends: the local pool, an interrupted and resumed sweep, and a Dask
cluster (a real scheduler and two workers on 127.0.0.1) that loses a worker mid-sweep."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from pyautonomousagent.experiments import Experiment, sweep
from pyautonomousagent.experiments.backends import PoolBackend
from pyautonomousagent.experiments.store import JOURNAL, Journal
from tests.test_experiments import same_rows

#: 24 runs: 3 thresholds x 2 refuel rates x 4 seeds of patrol, 5 drones x 400 iterations.
EXPERIMENT = {
    "scenario": "patrol",
    "iterations": 400,
    "set": {"agents": 5},
    "vary": {"low_energy_threshold": [96, 98, 99], "refuel_rate": [1, 2]},
    "seeds": 4,
    "measures": ["refuels", "time_to_first_refuel", "minimum_energy", "distance_flown",
                 {"low": "mean(energy < 95)"}],
}  # fmt: skip


@pytest.fixture(scope="module")
def on_pool(tmp_path_factory) -> pa.Table:
    """The sweep's results on the local pool of two processes."""
    out = tmp_path_factory.mktemp("pool") / "sweep"
    result = sweep(Experiment.from_mapping(EXPERIMENT), out, "pool", workers=2)
    assert result.counts == {"ok": 24, "failed": 0, "skipped": 0}
    return result.table


def journal_ids(out: Path) -> list[str]:
    """The run_id of every row in the sweep's journal (a run done twice appears twice)."""
    tables = [pq.read_table(p) for p in sorted((out / JOURNAL).glob("part-*.parquet"))]
    return [i for t in tables for i in t["run_id"].to_pylist()]


def test_pool_gives_the_same_numbers_as_this_process(on_pool, tmp_path) -> None:
    serial = sweep(Experiment.from_mapping(EXPERIMENT), tmp_path / "s", "serial").table
    assert same_rows(serial, on_pool, ignore=("seconds",))
    assert sorted(on_pool["refuels"].to_pylist()) != [0.0] * 24  # the measures vary


def test_an_interrupted_sweep_resumes_without_repeating_or_losing_runs(on_pool, tmp_path):
    out = tmp_path / "sweep"
    experiment = Experiment.from_mapping(EXPERIMENT)
    seen: list[str] = []

    def interrupt(row: dict) -> None:
        seen.append(row["run_id"])
        if len(seen) == 7:
            raise KeyboardInterrupt

    backend = PoolBackend(2)
    with pytest.raises(KeyboardInterrupt):
        sweep(experiment, out, backend, on_result=interrupt, flush_every=1)
    backend.close()
    before = journal_ids(out)
    assert before == seen and len(set(before)) == 7  # journaled as they finished, once each
    resumed = sweep(experiment, out, "pool", workers=2, resume=True)
    assert resumed.counts == {"ok": 17, "failed": 0, "skipped": 7}
    after = journal_ids(out)
    assert len(after) == 24 and len(set(after)) == 24  # no run done twice, none missing
    assert same_rows(resumed.table, on_pool, ignore=("seconds",))
    assert Journal(out, resumed.table.schema).finished() == set(after)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _dask_command() -> list[str]:
    script = Path(sys.executable).with_name("dask")
    return [str(script)] if script.exists() else [sys.executable, "-m", "dask"]


def _start(args: list[str], log: Path) -> subprocess.Popen:
    handle = log.open("w")
    return subprocess.Popen(
        [*_dask_command(), *args],
        stdout=handle,
        stderr=subprocess.STDOUT,
        start_new_session=True,  # its own process group: killed as a whole
    )


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=10)


def test_dask_cluster_losing_a_worker_gives_every_result_once(on_pool, tmp_path, capsys) -> None:
    pytest.importorskip("distributed")
    from pyautonomousagent.experiments.backends import BackendError, DaskBackend

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    common = ["--no-dashboard"]
    processes = [_start(["scheduler", "--host", "127.0.0.1", "--port", str(port), *common],
                        tmp_path / "scheduler.log")]  # fmt: skip
    backend = None
    try:
        for i in range(2):
            worker = ["worker", address, "--nthreads", "1", "--no-nanny", "--memory-limit",
                      "2GiB", "--host", "127.0.0.1", "--name", f"w{i}", *common]  # fmt: skip
            processes.append(_start(worker, tmp_path / f"worker{i}.log"))
        deadline = time.monotonic() + 60
        while True:  # the scheduler takes a moment to listen
            try:
                backend = DaskBackend(address, timeout=5)
                break
            except BackendError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        backend.client.wait_for_workers(2, timeout=60)
        assert backend.workers() == 2
        seen: list[str] = []
        killed: list[int] = []

        def on_result(row: dict) -> None:
            seen.append(row["run_id"])
            if len(seen) == 6:  # kill a worker (and its process group) mid-sweep
                _stop(processes[1])
                killed.append(len(seen))

        result = sweep(Experiment.from_mapping(EXPERIMENT), tmp_path / "d", backend,
                       on_result=on_result)  # fmt: skip
        assert killed == [6] and processes[1].poll() is not None  # killed mid-sweep
        assert len(seen) == 24 and len(set(seen)) == 24
        assert result.counts == {"ok": 24, "failed": 0, "skipped": 0}
        assert len(journal_ids(tmp_path / "d")) == 24
        assert same_rows(result.table, on_pool, ignore=("seconds",))
        assert len(backend.client.scheduler_info()["workers"]) == 1
        assert "Remove worker" in (tmp_path / "scheduler.log").read_text()
        lost = json.loads((tmp_path / "d" / "experiment.json").read_text())["backend"]
        assert lost["workers_seen"] == 2 and lost["workers_lost"] == 1, lost
        assert re.search(rf"dask worker {re.escape(lost['lost'][0])} lost", capsys.readouterr().err)
    finally:
        if backend is not None:
            backend.close()
        for process in reversed(processes):
            _stop(process)


def test_ctrl_c_stops_pyaa_sweep_and_resume_finishes_it(tmp_path) -> None:
    out = tmp_path / "s"
    # --engine batched: the compiled engine (where cached) would end before the Ctrl-C
    command = [sys.executable, "-m", "pyautonomousagent.cli", "sweep", "patrol", "--vary",
               "low_energy_threshold=96:99:1", "--agents", "5", "--iterations", "400",
               "--seeds", "20", "--measure", "refuels", "--serial", "--out", str(out),
               "--engine", "batched"]  # fmt: skip
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while not (out / "experiment.json").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.7)  # a few runs finish
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130 and "run the same command with --resume" in err
    before = journal_ids(out)
    assert 0 < len(before) < 80 and len(set(before)) == len(before)
    finished = subprocess.run([*command, "--resume"], capture_output=True, text=True, timeout=60)
    assert finished.returncode == 0, finished.stderr
    assert f"({80 - len(before)} ok, 0 failed, {len(before)} done before)" in finished.stdout
    after = journal_ids(out)
    assert len(after) == len(set(after)) == 80 and after[: len(before)] == before


def test_an_unreachable_scheduler_is_one_line() -> None:
    pytest.importorskip("distributed")
    from pyautonomousagent.experiments.backends import BackendError, DaskBackend

    address = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(BackendError, match="cannot reach a Dask scheduler at 'tcp://127.0.0.1:"):
        DaskBackend(address, timeout=1)


def test_a_local_dask_cluster_does_not_warn_when_port_8787_is_taken() -> None:
    """The local cluster's scheduler serves HTTP on a free port: with 8787 taken (another
    cluster, a sweep on another worker) it prints no warning into a lesson or a log."""
    pytest.importorskip("distributed")
    from pyautonomousagent.experiments.backends import DaskBackend

    taken = socket.socket()
    try:
        taken.bind(("", 8787))
        taken.listen()
    except OSError:
        pass  # already taken by someone else: the case under test
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            backend = DaskBackend(workers=1)
        try:
            assert [str(w.message) for w in caught if "8787" in str(w.message)] == []
            assert backend._cluster is not None
            assert backend._cluster.scheduler.http_server.port != 8787
        finally:
            backend.close()
    finally:
        taken.close()
