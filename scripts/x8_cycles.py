"""Land, refuel and take off again, over and over: the x8-patrol scenario checked every iteration.

Runs x8-patrol (vectorised X8 unless ``--implementation pyfly``) and watches every aircraft
after each iteration (``models/x8_flight_log.FlightLog``): cycles completed, ground strikes,
sink rate and airspeed at touchdown, lowest altitude, lowest airspeed while airborne against
the model's stall speed. Prints the figures and exits 1 if a limit is broken. With
``--figure`` it draws the first complete cycle of UAV 1 (altitude and airspeed against time,
phases shaded).

    python scripts/x8_cycles.py --agents 4 --iterations 200000 --figure docs/images/x8-cycle.png
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from pyautonomousagent import Simulation, load
from pyautonomousagent.models import x8_modes as modes
from pyautonomousagent.models.x8_flight_log import FlightLog, stall_speed

SHADES = {
    modes.APPROACH: "#deebf7",
    modes.FLARE: "#9ecae1",
    modes.ROLLOUT: "#fdd0a2",
    modes.PARKED: "#d9d9d9",
    modes.GROUND_ROLL: "#c7e9c0",
    modes.CLIMB_OUT: "#74c476",
}


def fly(agents: int, iterations: int, engine: str, implementation: str | None, seed: int):
    """Run the scenario, watching it; returns the log, agent 0's trace and the seconds."""
    scenario = load("x8-patrol").with_overrides(agents=agents, iterations=iterations)
    sim = Simulation.create(
        scenario, seed=seed, engine=engine, record_every=1000, implementation=implementation
    )
    log = FlightLog(agents)
    trace = np.empty((3, iterations))  # altitude, airspeed, phase of agent 0
    start = time.perf_counter()
    for i in range(iterations):
        sim.step()
        log.watch(sim.model)
        f = sim.model.flight
        trace[:, i] = f.altitude[0], f.airspeed[0], sim.model.phase[0]
    return log, trace, time.perf_counter() - start, sim.events


def first_cycle(phase: np.ndarray) -> tuple[int, int]:
    """Iterations from 10 s before UAV 1's first approach to 10 s after its climb-out."""
    start = int(np.argmax(phase == modes.APPROACH))
    climbed = np.flatnonzero((phase[1:] == modes.FLIGHT) & (phase[:-1] == modes.CLIMB_OUT))
    end = int(climbed[0]) + 1 if climbed.size else len(phase)
    return max(start - 1000, 0), min(end + 1000, len(phase))


def draw(trace: np.ndarray, dt: float, stall: float, path: str) -> None:
    """Altitude and airspeed of UAV 1 over its first cycle, phases shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, b = first_cycle(trace[2])
    t = np.arange(a, b) * dt
    altitude, airspeed, phase = trace[0, a:b], trace[1, a:b], trace[2, a:b]
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(9, 5.5))
    for ax in (top, bottom):
        changes = np.flatnonzero(np.diff(phase)) + 1
        edges = [0, *changes.tolist(), len(phase)]
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            shade = SHADES.get(int(phase[lo]))
            if shade:
                ax.axvspan(t[lo], t[hi - 1], color=shade, lw=0)
        ax.grid(alpha=0.3)
    top.plot(t, altitude, color="black", lw=1.2)
    top.set_ylabel("altitude (m)")
    bottom.plot(t, airspeed, color="black", lw=1.2)
    bottom.axhline(stall, color="red", lw=0.8, ls="--")
    bottom.text(t[0], stall + 0.4, f"stall {stall:.1f} m/s", color="red", fontsize=8)
    bottom.set_ylabel("airspeed (m/s)")
    bottom.set_xlabel("time (s)")
    handles = [
        plt.Rectangle((0, 0), 1, 1, color=c, label=modes.PHASES[p]) for p, c in SHADES.items()
    ]
    top.legend(handles=handles, ncol=3, fontsize=7, loc="lower left")
    top.set_title("x8-patrol, UAV 1: approach, flare, roll-out, refuel, take-off, climb-out")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--agents", type=int, default=4)
    parser.add_argument("--iterations", type=int, default=200_000)
    parser.add_argument("--engine", default="batched")
    parser.add_argument("--implementation", choices=["pyfly", "vectorised"], default=None)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--figure", help="PNG of UAV 1's first cycle")
    args = parser.parse_args(argv)
    log, trace, seconds, events = fly(
        args.agents, args.iterations, args.engine, args.implementation, args.seed
    )
    stall = stall_speed()
    print(f"x8-patrol, {args.engine} engine, seed {args.seed}, {seconds:.1f} s")
    print(log.summary(stall))
    print(f"alerts: {len(events)}")
    if args.figure:
        draw(trace, 0.01, stall, args.figure)
        print(f"figure: {args.figure}")
    problems = log.problems(stall) + (["alerts"] if events else [])
    if problems or not (log.cycles >= 1).all():
        print("FAILED:", "; ".join(problems) or "an aircraft completed no cycle")
        return 1
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
