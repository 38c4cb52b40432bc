"""The X8 goals measured side by side: PyFly, and the batched engine of this tree and of another
source tree (e.g. an older commit), each case in a fresh process, interleaved, minimum of
several runs.

    git archive fd65695 src | tar -x -C /tmp/base    # the source tree to compare with
    python scripts/x8_side_by_side.py --baseline /tmp/base/src [--agents 1,10,100] [--repeat 3]

For each fleet size it prints the loop seconds per UAV-iteration of PyFly (scaled from
``--pyfly-iterations``, minimum of two runs, fleets of at most 10 UAVs), of this tree and the
baseline (4000 iterations, minimum of ``--repeat``), both also without numba (one run each,
``PYAA_NO_JIT=1``), the ratios, and this tree's loop seconds for 4000 iterations. Cases are
run by ``pyautonomousagent.bench`` (the case runner of ``pyaa bench``).

    python scripts/x8_side_by_side.py --model [--agents 1,100,1000]

times the X8 model alone instead (``advance`` and ``control``, 200 iterations, minimum of
``--repeat``), agent by agent (compiled where numba is installed) and NumPy, and for fleets of
at most 10 UAVs PyFly's reference model (20 iterations), in this process.

    python scripts/x8_side_by_side.py --phases [--agents 1]

times each phase of the batched engine's loop (microseconds per iteration, 4000 iterations)
for ``x8-patrol`` and the 2-D ``patrol``, in this process.

    python scripts/x8_side_by_side.py --cycle

flies the ``x8-landing`` scenario (one landing, refuelling and take-off) with PyFly and with
the vectorised model and prints their largest differences and the iteration each phase
begins in, in this process.

    python scripts/x8_side_by_side.py --landing-cost [--agents 1,4,100]

times the batched engine's loop (20,000 iterations, recording every 100th) on x8-patrol as it
is (landing to refuel) and as the paper flew it (the patrol tree, refuelling in flight at
40 %, airspeed floor 18 m/s), in this process.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1] / "src"


def loop_per_uav_iteration(
    src: Path, engine: str, agents: int, iterations: int, jit: bool
) -> float:
    """Loop seconds per UAV-iteration of one x8-patrol case run with the sources in ``src``."""
    env = dict(os.environ, PYTHONPATH=str(src), PYAA_NO_JIT="0" if jit else "1")
    case = {
        "scenario": "x8-patrol",
        "engine": engine,
        "agents": agents,
        "iterations": iterations,
        "record_every": 1,
        "full_iterations": 4000,
    }
    done = subprocess.run(
        [sys.executable, "-m", "pyautonomousagent.bench", json.dumps(case)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    return (figures["seconds"] - figures["setup"]) / (agents * iterations)


def measure(agents: int, baseline: Path, repeat: int, pyfly_iterations: int) -> dict[str, float]:
    """Minimum seconds per UAV-iteration of each variant for one fleet size."""
    runs: dict[str, list[float]] = {"pyfly": [], "baseline": [], "this": []}
    runs.update({"baseline, no jit": [], "this, no jit": []})
    for r in range(repeat):
        if agents <= 10 and r < 2:
            runs["pyfly"].append(
                loop_per_uav_iteration(HERE, "pyfly", agents, pyfly_iterations, True)
            )
        runs["baseline"].append(loop_per_uav_iteration(baseline, "batched", agents, 4000, True))
        runs["this"].append(loop_per_uav_iteration(HERE, "batched", agents, 4000, True))
        if r == 0:
            for name, src in (("baseline, no jit", baseline), ("this, no jit", HERE)):
                runs[name].append(loop_per_uav_iteration(src, "batched", agents, 4000, False))
    return {name: min(values) for name, values in runs.items() if values}


def model_seconds(agents: int, agent_by_agent: bool | None, repeat: int) -> float:
    """Seconds per iteration of the X8 model alone (Phases 2 and 4), minimum of ``repeat``;
    ``agent_by_agent`` None times PyFly's reference model (20 iterations a repeat)."""
    from pyautonomousagent.models.x8 import X8Settings, X8Vectorised
    from pyautonomousagent.models.x8_pyfly import X8PyFly

    rng = np.random.default_rng(0)
    s = {key: rng.uniform(0, 360, agents) for key in ("x", "y", "heading", "requested_heading")}
    s["speed"], s["requested_speed"] = np.zeros(agents), np.full(agents, 22.0)
    if agent_by_agent is None:
        model: X8Vectorised | X8PyFly = X8PyFly(X8Settings(), s)
    else:
        model = X8Vectorised(X8Settings(), s, agent_by_agent=agent_by_agent)
    moving = np.ones(agents, dtype=bool)
    steps = 20 if agent_by_agent is None else 200
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(steps):
            model.advance(s, moving)
            model.control(s)
        best = min(best, (time.perf_counter() - start) / steps)
    return best


def phase_microseconds(scenario: str, agents: int) -> dict[str, float]:
    """Microseconds per iteration of each phase of the batched engine's loop (4000 its)."""
    from pyautonomousagent.scenarios import load
    from pyautonomousagent.simulation import Simulation, phases

    full = load(scenario).with_overrides(agents=agents, iterations=4000)
    sim = Simulation.create(full, seed=0, engine="batched", record_every=1)
    names = ("estimate_state", "decide", "control", "deliver_messages", "record")
    totals = dict.fromkeys(names, 0.0)
    for _ in range(4000):
        sim.world.iteration += 1
        for name in names:
            start = time.perf_counter()
            getattr(phases, name)(sim)
            totals[name] += time.perf_counter() - start
    return {name: seconds / 4000 * 1e6 for name, seconds in totals.items()}


def cycle() -> None:
    """x8-landing with both implementations: differences and phase changes."""
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.models.x8_modes import PHASES

    traces = {}
    for implementation in ("pyfly", "vectorised"):
        scenario = load("x8-landing")
        sim = Simulation.create(scenario, engine="pytrees", implementation=implementation)
        trace = np.empty((5, scenario.iterations))
        start = time.perf_counter()
        for i in range(scenario.iterations):
            sim.step()
            f = sim.model.flight
            trace[:, i] = f.east[0], f.north[0], f.altitude[0], f.airspeed[0], sim.model.phase[0]
        traces[implementation] = trace
        sink = sim.model.touchdown_sink[0]
        print(f"{implementation:>10}: {time.perf_counter() - start:.1f} s, touchdown sink "
              f"{sink:.4f} m/s at {sim.model.touchdown_speed[0]:.3f} m/s")  # fmt: skip
    a, b = traces["pyfly"], traces["vectorised"]
    print(f"largest differences: position {np.hypot(a[0] - b[0], a[1] - b[1]).max():.2e} m, "
          f"altitude {np.abs(a[2] - b[2]).max():.2e} m, airspeed "
          f"{np.abs(a[3] - b[3]).max():.2e} m/s")  # fmt: skip
    for phase, name in enumerate(PHASES):
        begins = [int(np.argmax(t[4] == phase)) if (t[4] == phase).any() else -1 for t in (a, b)]
        print(f"{name:>12} begins at iteration: PyFly {begins[0]}, vectorised {begins[1]}")


def landing_cost(agents: int, iterations: int = 20_000) -> dict[str, float]:
    """Loop seconds per iteration of x8-patrol, landing and as the paper flew it."""
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.simulation.scenario import Scenario, to_mapping

    data = to_mapping(load("x8-patrol"))
    data["tree"] = "patrol"
    data["parameters"]["low_energy_threshold"] = 40
    data["x8"]["min_airspeed"] = 18
    cases = {"in flight (paper)": Scenario.from_mapping(data), "landing": load("x8-patrol")}
    out = {}
    for name, scenario in cases.items():
        scenario = scenario.with_overrides(agents=agents, iterations=iterations)
        sim = Simulation.create(scenario, engine="batched", record_every=100)
        start = time.perf_counter()
        sim.run(progress=False)
        out[name] = (time.perf_counter() - start) / iterations
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="the other tree's src/")
    parser.add_argument("--model", action="store_true", help="time the X8 model alone")
    parser.add_argument("--phases", action="store_true", help="time the loop's phases")
    parser.add_argument("--cycle", action="store_true", help="PyFly vs vectorised: one landing")
    parser.add_argument("--landing-cost", action="store_true", help="landing vs in-flight refuel")
    parser.add_argument("--agents", default="1,10,100")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--pyfly-iterations", type=int, default=400)
    args = parser.parse_args()
    if args.cycle:
        cycle()
        return
    if args.landing_cost:
        for agents in (int(a) for a in args.agents.split(",")):
            us = {k: v * 1e6 for k, v in landing_cost(agents).items()}
            parts = ", ".join(f"{k} {v:.0f} us/it" for k, v in us.items())
            print(f"{agents:>5} UAVs: {parts}", flush=True)
        return
    if args.phases:
        for agents in (int(a) for a in args.agents.split(",")):
            for scenario in ("x8-patrol", "patrol"):
                us = phase_microseconds(scenario, agents)
                parts = "  ".join(f"{name} {value:.1f}" for name, value in us.items())
                print(f"{scenario:>9} {agents:>5}: {parts}  total {sum(us.values()):.1f} us/it")
        return
    if args.model:
        for agents in (int(a) for a in args.agents.split(",")):
            kernel, numpy = (model_seconds(agents, k, args.repeat) for k in (True, False))
            line = f"{agents:>5} UAVs  agent by agent {kernel * 1e6:.1f} us/it, NumPy "
            line += f"{numpy * 1e6:.1f} us/it, {kernel / agents * 1e6:.2f} us per UAV-iteration"
            if agents <= 10:
                pyfly = model_seconds(agents, None, args.repeat)
                line += f", PyFly {pyfly * 1e6:.0f} us/it ({pyfly / kernel:.0f}x)"
            print(line, flush=True)
        return
    if args.baseline is None:
        parser.error("--baseline is required (or --model)")
    for agents in (int(a) for a in args.agents.split(",")):
        m = measure(agents, args.baseline, args.repeat, args.pyfly_iterations)
        line = f"{agents:>5} UAVs  " + "  ".join(f"{k}: {v:.2e}" for k, v in m.items())
        if "pyfly" in m:
            line += f"  | pyfly/this {m['pyfly'] / m['this']:.0f}x"
            line += f", pyfly/baseline {m['pyfly'] / m['baseline']:.0f}x"
        line += f"  | baseline/this {m['baseline'] / m['this']:.1f}x"
        print(f"{line}  | loop of 4000 iterations: {m['this'] * agents * 4000:.2f} s", flush=True)


if __name__ == "__main__":
    main()
