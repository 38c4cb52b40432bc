"""What a sweep costs: the worked example (100 runs of patrol, 100 drones x 4000 iterations) on
1 and on 2 local workers, against single ``pyaa run`` commands measured in the same session.

    python scripts/sweep_timing.py [EXPERIMENT.yaml] [--workers 1,2] [--single 3]

prints, per worker count, the sweep's wall-clock time, the time per run (wall x workers /
runs), the mean time a run took on its worker, the overhead per run (their difference:
start-up of the workers, sending runs and results, journaling) and the CPU time per run (this
process and its workers, so less sensitive to other work on the machine); then a single
``pyaa run`` of the same scenario (a new process each, median of ``--single``), wall and CPU.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pyautonomousagent.experiments import Experiment, sweep

ROOT = Path(__file__).resolve().parents[1]


def cpu_seconds() -> float:
    """CPU time (user + system) of this process and of its children that have ended."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def single_runs(count: int, experiment: Experiment) -> tuple[float, float]:
    """Median wall-clock and CPU seconds of ``pyaa run`` of the experiment's scenario."""
    walls, cpus = [], []
    for _ in range(count):
        with tempfile.TemporaryDirectory() as out:
            command = [sys.executable, "-m", "pyautonomousagent.cli", "run", experiment.scenario,
                       "--no-gif", "--quiet", "--out", out]  # fmt: skip
            if "agents" in experiment.fixed:
                command += ["--agents", str(experiment.fixed["agents"])]
            if experiment.iterations:
                command += ["--iterations", str(experiment.iterations)]
            start, cpu = time.perf_counter(), cpu_seconds()
            subprocess.run(command, check=True)
            walls.append(time.perf_counter() - start)
            cpus.append(cpu_seconds() - cpu)
    return statistics.median(walls), statistics.median(cpus)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("experiment", nargs="?", default=ROOT / "examples/threshold-sweep.yaml")
    parser.add_argument("--workers", default="1,2", help="worker counts, e.g. 1,2")
    parser.add_argument("--single", type=int, default=3, help="single pyaa runs to time")
    args = parser.parse_args()
    experiment = Experiment.from_file(args.experiment)
    runs = len(experiment.runs())
    load = os.getloadavg()[0]
    print(f"{experiment.name}: {runs} runs of {experiment.scenario}; load {load:.2f}", flush=True)
    for workers in (int(w) for w in args.workers.split(",")):
        with tempfile.TemporaryDirectory() as out:
            start, cpu = time.perf_counter(), cpu_seconds()
            result = sweep(experiment, Path(out) / "sweep", "pool", workers=workers)
            wall, cpu = time.perf_counter() - start, cpu_seconds() - cpu
        per_run = wall * workers / runs
        on_worker = statistics.mean(result.table["seconds"].to_pylist())
        print(
            f"  {workers} worker(s): {wall:.1f} s for {runs} runs; {per_run:.3f} s per run "
            f"(x workers); a run took {on_worker:.3f} s on its worker; overhead "
            f"{per_run - on_worker:.3f} s per run; CPU {cpu / runs:.3f} s per run; "
            f"load {os.getloadavg()[0]:.2f}",
            flush=True,
        )
    wall, cpu = single_runs(args.single, experiment)
    print(f"  single pyaa run (new process, writes states.parquet): {wall:.3f} s, CPU {cpu:.3f} s")


if __name__ == "__main__":
    main()
