"""Two checkouts of the project measured side by side: ``pyaa bench`` of each, alternated.

The machine is shared and noisy, so the two revisions' runs alternate (A B B A A B ...: the
run that goes first in a round was measured faster, whichever it was) and each
case keeps its best and its median loop time and its peak memory; the table gives B's ratio
to A's (of a sub-second loop, one lucky run can move the best by 10 % or more: the median of
many rounds is the steadier figure). Each run
is ``python -m pyautonomousagent.cli bench ... --json`` with ``PYTHONPATH=<checkout>/src``,
so both use this interpreter's packages (numba, NumPy) and differ only in the project's code.

    python scripts/bench_revisions.py /tmp/before . --repeat 3 -- patrol --agents 1000 \
        --iterations 4000 --engines batched,compiled

Prints one line per case: scenario, engine, agents x iterations, record rate, A's and B's best
loop seconds and B/A, their median loop seconds and B/A, A's and B's peak MB and B/A.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

Case = tuple[str, str, int, int, int]


def bench(checkout: Path, arguments: list[str]) -> list[dict[str, Any]]:
    """``pyaa bench ARGUMENTS --json`` run on ``checkout``'s code; its rows."""
    env = {**os.environ, "PYTHONPATH": str(checkout.resolve() / "src")}
    command = [sys.executable, "-m", "pyautonomousagent.cli", "bench", *arguments, "--json"]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"bench on {checkout} failed ({done.returncode}): {done.stderr.strip()[-500:]}")
    rows: list[dict[str, Any]] = json.loads(done.stdout)
    for row in rows:
        if row["error"]:
            sys.exit(f"bench on {checkout}: {row['engine']} x {row['agents']}: {row['error']}")
    return rows


def case(row: dict[str, Any]) -> Case:
    return (row["scenario"], row["engine"], row["agents"], row["iterations"], row["record_every"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("a", type=Path, help="the first checkout (the reference)")
    parser.add_argument("b", type=Path, help="the second checkout")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each, alternated")
    parser.epilog = "then --, then the arguments of pyaa bench"
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    args, arguments = parser.parse_args(argv[:split]), argv[split + 1 :]
    if args.repeat < 1 or not arguments:
        parser.error("give --repeat >= 1 and, after --, the arguments of pyaa bench")
    loops: dict[str, dict[Case, list[float]]] = {"a": defaultdict(list), "b": defaultdict(list)}
    peaks: dict[str, dict[Case, list[float]]] = {"a": defaultdict(list), "b": defaultdict(list)}
    for r in range(args.repeat):
        for side in ("a", "b") if r % 2 == 0 else ("b", "a"):  # A B, B A: neither always first
            for row in bench(getattr(args, side), arguments):
                loops[side][case(row)].append(row["loop_s"])
                peaks[side][case(row)].append(row["peak_mb"])
            print(f"# round {r + 1}/{args.repeat}: {side} done", file=sys.stderr, flush=True)
    print("scenario engine agents x iterations every | best loop s: a  b  b/a "
          "| median loop s: a  b  b/a | peak MB: a  b  b/a")  # fmt: skip
    for key in loops["a"]:
        la, lb = min(loops["a"][key]), min(loops["b"][key])
        ma, mb = statistics.median(loops["a"][key]), statistics.median(loops["b"][key])
        pa, pb = max(peaks["a"][key]), max(peaks["b"][key])
        scenario, engine, agents, iterations, every = key
        print(f"{scenario} {engine} {agents} x {iterations} {every} | {la:.3f} {lb:.3f} "
              f"{lb / la:.3f} | {ma:.3f} {mb:.3f} {mb / ma:.3f} | {pa:.0f} {pb:.0f} "
              f"{pb / pa:.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
