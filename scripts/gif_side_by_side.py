"""Time and size of the gathering GIF, two versions of the code side by side.

Each round writes the full gathering run's GIF (8000 iterations, a frame every 10) once with
each version, interleaved, each in its own process (only the GIF's writing is timed); the minimum
of the rounds is printed, since a shared machine is noisy::

    git worktree add /tmp/old 16cdfcf        # the code before the new animation
    python scripts/gif_side_by_side.py --old /tmp/old/src --rounds 3
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

CODE = r"""
import inspect, json, sys
from pyautonomousagent import Simulation, load
from pyautonomousagent.render import animation
write = getattr(animation, "write_gif", None) or animation.write_animation  # old code: write_gif
scenario = load("gathering")
sim = Simulation.create(scenario, seed=0).run(progress=False)
new = "options" in inspect.signature(write).parameters  # marks events when it can
options = {"events": sim.events} if new else {}
stats = write(sim.recorder, scenario, sys.argv[1], frame_every=scenario.frame_every,
              progress=False, **options)
print(json.dumps({"frames": stats.frames, "seconds": stats.seconds, "bytes": stats.bytes}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, required=True, help="src/ folder of the old code")
    parser.add_argument("--new", type=Path, default=Path(__file__).parents[1] / "src")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    sources = {"old": args.old, "new": args.new}
    results: dict[str, list[dict[str, float]]] = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(args.rounds):
            for which, src in sources.items():
                out = subprocess.run(
                    [sys.executable, "-c", CODE, str(Path(folder) / f"{which}.gif")],
                    env={"PYTHONPATH": str(src)},
                    capture_output=True,
                    text=True,
                    check=True,
                )
                results[which].append(json.loads(out.stdout.strip().splitlines()[-1]))
    for which, runs in results.items():
        times = [round(r["seconds"], 2) for r in runs]
        print(
            f"{which}: {int(runs[0]['frames'])} frames, {min(times):.2f} s (min of {times}), "
            f"{runs[0]['bytes'] / 1e6:.2f} MB"
        )


if __name__ == "__main__":
    main()
