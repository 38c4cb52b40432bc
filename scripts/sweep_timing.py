"""What a sweep costs: the worked example (100 runs of patrol, 100 drones x 4000 iterations) on
1 and on 2 local workers, against single ``pyaa run`` commands measured in the same session.

    python scripts/sweep_timing.py [EXPERIMENT.yaml] [--workers 1,2] [--single 3]

prints, per worker count, the sweep's wall-clock time, the time per run (wall x workers /
runs), the mean time a run took on its worker, and the overhead per run (their difference:
start-up of the workers, sending runs and results, journaling); then a single ``pyaa run
patrol --agents 100 --no-gif`` (a new process each, median of ``--single``).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pyautonomousagent.experiments import Experiment, sweep

ROOT = Path(__file__).resolve().parents[1]


def single_runs(count: int, experiment: Experiment) -> float:
    """Median wall-clock seconds of ``pyaa run`` of the experiment's scenario (new process)."""
    times = []
    for _ in range(count):
        with tempfile.TemporaryDirectory() as out:
            command = [sys.executable, "-m", "pyautonomousagent.cli", "run", experiment.scenario,
                       "--no-gif", "--quiet", "--out", out]  # fmt: skip
            if "agents" in experiment.fixed:
                command += ["--agents", str(experiment.fixed["agents"])]
            if experiment.iterations:
                command += ["--iterations", str(experiment.iterations)]
            start = time.perf_counter()
            subprocess.run(command, check=True)
            times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("experiment", nargs="?", default=ROOT / "examples/threshold-sweep.yaml")
    parser.add_argument("--workers", default="1,2", help="worker counts, e.g. 1,2")
    parser.add_argument("--single", type=int, default=3, help="single pyaa runs to time")
    args = parser.parse_args()
    experiment = Experiment.from_file(args.experiment)
    runs = len(experiment.runs())
    print(f"{experiment.name}: {runs} runs of {experiment.scenario}", flush=True)
    for workers in (int(w) for w in args.workers.split(",")):
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            result = sweep(experiment, Path(out) / "sweep", "pool", workers=workers)
            wall = time.perf_counter() - start
        per_run = wall * workers / runs
        on_worker = statistics.mean(result.table["seconds"].to_pylist())
        print(
            f"  {workers} worker(s): {wall:.1f} s for {runs} runs; {per_run:.3f} s per run "
            f"(x workers); a run took {on_worker:.3f} s on its worker; overhead "
            f"{per_run - on_worker:.3f} s per run",
            flush=True,
        )
    single = single_runs(args.single, experiment)
    print(f"  single pyaa run (new process, writes states.parquet): {single:.3f} s (median)")


if __name__ == "__main__":
    main()
