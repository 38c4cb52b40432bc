"""Helpers of scripts/gpu_figures.sh (issue 20's figures on a GPU machine).

python scripts/gpu_figures.py check          # exit 2 with the reason where no GPU is usable
python scripts/gpu_figures.py device         # device, driver, CuPy and numba-cuda versions
python scripts/gpu_figures.py bandwidth      # measured device copy bandwidth, GB/s
python scripts/gpu_figures.py bytes          # bytes of state per drone (patrol)
python scripts/gpu_figures.py rate FILE GBS  # drone-iterations/s of a bench JSON, vs GBS
python scripts/gpu_figures.py memory N       # device memory of an N-drone patrol run
python scripts/gpu_figures.py crossover [ITERATIONS EVERY REPEATS]
                                             # smallest swarm where gpu beats compiled
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np


def check() -> int:
    from pyautonomousagent.engines.gpu import gpu_problem

    problem = gpu_problem()
    if problem is not None:
        print(f"gpu_figures: {problem}: the GPU figures need a CUDA device", file=sys.stderr)
        return 2
    return 0


def device() -> int:
    import cupy
    import numba
    from numba import cuda

    props = cupy.cuda.runtime.getDeviceProperties(0)
    driver = cupy.cuda.runtime.driverGetVersion()
    print(f"device: {props['name'].decode()}, {props['totalGlobalMem'] / 2**30:.1f} GiB")
    print(f"CUDA driver {driver // 1000}.{driver % 1000 // 10}, CuPy {cupy.__version__}, "
          f"numba {numba.__version__}, numba.cuda from {cuda.__file__}")  # fmt: skip
    return 0


def bandwidth() -> int:
    """Device-to-device copy of 2 GiB, best of 20: bytes read plus written per second."""
    import cupy

    source = cupy.ones(2**28, dtype=np.float64)
    target = cupy.empty_like(source)
    best = float("inf")
    for _ in range(20):
        cupy.cuda.Device().synchronize()
        start = time.perf_counter()
        cupy.copyto(target, source)
        cupy.cuda.Device().synchronize()
        best = min(best, time.perf_counter() - start)
    print(f"{2 * source.nbytes / best / 1e9:.0f}")
    return 0


def _state_bytes() -> float:
    """Bytes of state per drone the patrol kernel reads and writes every iteration."""
    from pyautonomousagent import Simulation, load

    sim = Simulation.create(load("patrol").with_overrides(agents=1000, iterations=10),
                            engine="compiled")  # fmt: skip
    engine = sim.engine
    arrays = [engine.status, engine.current, engine.pending, *engine.arrays]
    arrays += [sim.model.u_speed, sim.model.u_heading]
    return sum(a.nbytes for a in arrays) / sim.swarm.size


def state_bytes() -> int:
    s = _state_bytes()
    print(f"patrol state: {s:.0f} bytes per drone; each iteration reads and writes it: "
          f"{2 * s:.0f} bytes per drone-iteration (an upper bound: a column not written is "
          f"only read), plus the records every 100 iterations")  # fmt: skip
    return 0


def rate(path: str, gbs: str) -> int:
    """Each row's drone-iterations per second, and the bytes per drone-iteration the bench
    counted from the kernel's arrays (state read and written each iteration, records every
    K) at that rate, against the measured bandwidth ``gbs`` (above 100 %: part of the state
    stays in the caches between iterations, as one thread runs all the iterations of its
    drone)."""
    with open(path) as file:
        rows = json.load(file)
    for row in rows:
        if row["error"]:
            print(f"{row['engine']} {row['agents']}: {row['error']}")
            continue
        per_second = row["agents"] * row["iterations"] / row["loop_s"]
        moved = row["bytes_per_drone_iteration"] * per_second / 1e9
        print(
            f"{row['engine']} {row['agents']} x {row['iterations']}: "
            f"set-up {row['setup_s']:.2f} s, loop {row['loop_s']:.3f} s = "
            f"{per_second:.3g} drone-iterations/s; parts {row.get('gpu_s')}; "
            f"{row['bytes_per_drone_iteration']:.0f} bytes/drone-iteration = {moved:.0f} GB/s "
            f"= {moved / float(gbs):.0%} of the measured {gbs} GB/s"
        )
    return 0


def crossover(iterations: str = "1000", every: str = "100", repeats: str = "3") -> int:
    """The smallest patrol swarm whose whole run (set-up, the CUDA compile included, and
    loop) is faster on the GPU than on the compiled engine (all this machine's cores; its
    cache warm): swarms doubled from 1000 until the GPU wins, then bisected to 5 %; each
    size runs the two engines interleaved ``repeats`` times, each in a fresh process
    (``pyaa bench``'s), and compares their best. Prints the value for
    ``engines.gpu.AUTO_DRONE_ITERATIONS``."""
    from pyautonomousagent.bench import Case, measure

    its, k, r = int(iterations), int(every), int(repeats)

    def gpu_wins(agents: int) -> bool:
        best = {"compiled": float("inf"), "gpu": float("inf")}
        for _ in range(r):
            for engine in best:
                result = measure(Case("patrol", engine, agents, its, k))
                if result.seconds is None:
                    raise SystemExit(f"crossover: {engine} at {agents} drones: {result.error}")
                best[engine] = min(best[engine], result.seconds)
        print(f"  {agents} drones x {its}: compiled {best['compiled']:.3f} s, "
              f"gpu {best['gpu']:.3f} s (best of {r})", file=sys.stderr)  # fmt: skip
        return best["gpu"] < best["compiled"]

    low, high = 0, 1000  # the GPU loses at low (0: none tried), wins at high once found
    while not gpu_wins(high):
        low, high = high, high * 2
        if high > 10**8:
            print("crossover: the GPU did not win up to 100,000,000 drones")
            return 1
    while high - low > max(1, high // 20):
        middle = (low + high) // 2
        low, high = (low, middle) if gpu_wins(middle) else (middle, high)
    print(f"crossover: {high} drones x {its} iterations (record every {k}); "
          f"AUTO_DRONE_ITERATIONS = {high * its}")  # fmt: skip
    return 0


def memory(agents: str) -> int:
    from numba import cuda

    from pyautonomousagent import Simulation, load

    n = int(agents)
    free0, total = cuda.current_context().get_memory_info()
    scenario = load("patrol").with_overrides(agents=n, iterations=100)
    sim = Simulation.create(scenario, engine="gpu", record_every=100).run(progress=False)
    free1, _ = cuda.current_context().get_memory_info()
    used = free0 - free1
    print(f"patrol {n} drones x 100 on the GPU: device memory in use {used / 2**30:.1f} GiB "
          f"of {total / 2**30:.1f} GiB = {used / n:.0f} bytes per drone; "
          f"{sim.world.iteration} iterations done")  # fmt: skip
    return 0


def main(argv: list[str]) -> int:
    commands = {"check": check, "device": device, "bandwidth": bandwidth, "bytes": state_bytes,
                "rate": rate, "memory": memory, "crossover": crossover}  # fmt: skip
    if not argv or argv[0] not in commands:
        print(__doc__, file=sys.stderr)
        return 2
    return commands[argv[0]](*argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
