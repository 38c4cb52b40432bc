"""Helpers of scripts/gpu_figures.sh (issue 20's figures on a GPU machine).

python scripts/gpu_figures.py check          # exit 2 with the reason where no GPU is usable
python scripts/gpu_figures.py fma            # exit 1 where no_fma leaves FMA in the PTX
python scripts/gpu_figures.py lto            # a * b + c on the device, with and without LTO
python scripts/gpu_figures.py identity       # per column, the GPU's largest difference
python scripts/gpu_figures.py device         # device, driver, CuPy and numba-cuda versions
python scripts/gpu_figures.py bandwidth      # measured device copy bandwidth, GB/s
python scripts/gpu_figures.py bytes          # bytes of state per drone (patrol)
python scripts/gpu_figures.py rate FILE GBS  # drone-iterations/s of a bench JSON, vs GBS
python scripts/gpu_figures.py memory N [N]   # device memory of N-drone patrol runs
python scripts/gpu_figures.py crossover ITERATIONS EVERY SIZE [SIZE ...]
                                             # the swarm where gpu starts to beat compiled
python scripts/gpu_figures.py auto THRESHOLD      # what auto picks with that AUTO_DRONE_ITERATIONS
python scripts/gpu_figures.py spread [ENGINE AGENTS ITERATIONS NEIGHBOURS]
                                             # gathering spread at constant density
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np


def check() -> int:
    from pyautonomousagent.engines.gpu import gpu_problem

    problem = gpu_problem()
    if problem is not None:
        print(f"gpu_figures: {problem}: the GPU figures need a CUDA device", file=sys.stderr)
        return 2
    return 0


def fma() -> int:
    """Exit 1 where :func:`~pyautonomousagent.engines.gpu.no_fma` does not keep this
    numba-cuda's NVVM from contracting ``a * b + c`` (a version that compiles otherwise)."""
    from numba import cuda

    from pyautonomousagent.engines.gpu import no_fma

    def multiply_add(a, b, c, out):  # type: ignore[no-untyped-def]
        out[0] = a[0] * b[0] + c[0]

    signature = "(float64[:], float64[:], float64[:], float64[:])"
    with no_fma():
        ptx, _ = cuda.compile_ptx(multiply_add, signature, cc=(9, 0))
    contracted = "fma." in ptx
    print(f"no_fma with this numba-cuda: {'FMA still in the PTX' if contracted else 'no FMA'}")
    return int(contracted)


def lto() -> int:
    """``a * b + c`` run on the device, compiled inside ``no_fma`` with numba-cuda's LTO and
    without: whether each rounds twice, as NumPy does (exit 1 where the engine's way,
    without LTO, does not). a = 1 + 2**-30, b = 1 - 2**-30, c = -1: a * b rounds to 1.0,
    so NumPy gives 0.0; a fused multiply-add gives -2**-60. Also prints what explains a
    contraction: the NVVM unit classes ``no_fma`` patches, the options each NVVM compile
    of the launch got, and the launched kernel's PTX and SASS (fma/DFMA counted)."""
    import numba_cuda
    from numba import cuda

    from pyautonomousagent.engines.gpu import no_fma, nvvm_units

    def multiply_add(a, b, c, out):  # type: ignore[no-untyped-def]
        out[0] = a[0] * b[0] + c[0]

    units = nvvm_units()
    print(f"numba-cuda {getattr(numba_cuda, '__version__', '?')}; NVVM units patched: "
          f"{[f'{u.__module__}.{u.__qualname__}' for u in units]}")  # fmt: skip
    seen: list[str] = []
    spied = [(unit, unit.__init__) for unit in units]
    for unit, original in spied:

        def spy(self, options, *args, _original=original, _unit=unit, **kwargs):  # type: ignore[no-untyped-def]
            seen.append(f"{_unit.__module__}: {options}")
            _original(self, options, *args, **kwargs)

        unit.__init__ = spy
    values = [np.array([v]) for v in (1 + 2**-30, 1 - 2**-30, -1.0)]
    expected = values[0][0] * values[1][0] + values[2][0]
    wrong = 0
    try:
        for link in (True, False):
            seen.clear()
            out = cuda.device_array(1)
            kernel = cuda.jit(fastmath=False, lto=link)(multiply_add)
            with no_fma():
                kernel[1, 1](*(cuda.to_device(v) for v in values), out)
            got = out.copy_to_host()[0]
            wrong += got != expected and not link
            print(f"lto={link}: a * b + c on the device = {got!r}, NumPy {expected!r}: "
                  f"{'same' if got == expected else 'differs (contracted)'}; NVVM compiles "
                  f"at the launch: {seen}")  # fmt: skip
            for what, inspect in (("PTX", "inspect_asm"), ("SASS", "inspect_sass")):
                try:
                    text = "".join(getattr(kernel, inspect)().values())
                except Exception as error:  # e.g. no nvdisasm for the SASS
                    print(f"  {what}: {type(error).__name__}: {error}")
                    continue
                lines = [x.strip() for x in text.splitlines() if "mul" in x or "add" in x
                         or "fma" in x.lower()]  # fmt: skip
                print(f"  {what}: {lines[:8]}")
    finally:
        for unit, original in spied:
            unit.__init__ = original
    return int(wrong > 0)


def identity(seed: str = "1") -> int:
    """The device cases of tests/test_gpu_engine.py (seed ``seed``), each run on the batched
    engine and the GPU: per recorded column, how many entries differ and the largest
    difference (in units in the last place for floats); then whether the decisions match
    exactly (the traced statuses, the active behaviour, the events). Exit 1 where a
    decision differs."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.testing import _behaviour
    from tests.test_gpu_engine import DEVICE_CASES

    decisions_differ = 0
    for name, overrides, _ in DEVICE_CASES:
        scenario = load(name).with_overrides(**overrides)
        a, b = (Simulation.create(scenario, seed=int(seed), engine=e, record_every=10)
                .run(progress=False) for e in ("batched", "gpu"))  # fmt: skip
        ra, rb = a.recorder, b.recorder
        columns = []
        for key in ra.columns:
            x, y = np.asarray(ra.column(key)), np.asarray(rb.column(key))
            if x.tobytes() == y.tobytes():
                continue
            if x.dtype.kind == "f":
                bits = np.dtype(f"i{x.dtype.itemsize}")
                gap = np.abs(x.view(bits).astype(np.float64) - y.view(bits).astype(np.float64))
                columns.append(f"{key}: {int((gap > 0).sum())} differ, at most {gap.max():.0f} ulp")
            else:
                columns.append(f"{key}: {int((x != y).sum())} differ")
        same = {
            "traces": np.array_equal(ra.traces[: ra.count], rb.traces[: rb.count]),
            "behaviour": np.array_equal(_behaviour(ra), _behaviour(rb)),
            "events": a.events == b.events,
        }
        decisions_differ += not all(same.values())
        print(f"{name} {overrides}: {columns or 'every column the same'}; decisions: {same}",
              flush=True)  # fmt: skip
    return int(decisions_differ > 0)


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


def crossover(iterations: str, every: str, *sizes: str) -> int:
    """Where the GPU starts to pay for patrol: the whole run (set-up, the CUDA compile
    included, and loop) of ``iterations`` x each of ``sizes`` drones, on the GPU and on
    the compiled engine (all this machine's cores; its cache warm), each in a fresh process
    (``pyaa bench``'s), the two interleaved, sizes in increasing order. The largest size the
    GPU loses and the next one, where it wins, are then run once more each (best of two).
    Prints the crossover, interpolated between them (the difference of the two engines'
    times is linear in the swarm between two sizes), and the value for
    ``engines.gpu.AUTO_DRONE_ITERATIONS`` (agents x iterations, rounded up)."""
    from pyautonomousagent.bench import Case, measure

    its, k = int(iterations), int(every)
    best: dict[int, dict[str, float]] = {}

    def run(agents: int) -> float:
        """GPU seconds minus compiled seconds (best so far) at ``agents``."""
        times = best.setdefault(agents, {"compiled": float("inf"), "gpu": float("inf")})
        for engine in times:
            result = measure(Case("patrol", engine, agents, its, k))
            if result.seconds is None:
                raise SystemExit(f"crossover: {engine} at {agents} drones: {result.error}")
            times[engine] = min(times[engine], result.seconds)
        print(f"  {agents} drones x {its}: compiled {times['compiled']:.3f} s, "
              f"gpu {times['gpu']:.3f} s (best so far)", flush=True)  # fmt: skip
        return times["gpu"] - times["compiled"]

    ordered = sorted(int(n) for n in sizes)
    differences = {n: run(n) for n in ordered}
    losing = [n for n in ordered if differences[n] >= 0]
    if not losing:
        print(f"crossover: the GPU wins from the smallest size tried ({ordered[0]} drones) on")
        return 0
    last = max(losing)
    if last == ordered[-1]:
        print(f"crossover: the GPU did not win up to {last} drones x {its}")
        return 1
    high_n = ordered[ordered.index(last) + 1]
    low, high = run(last), run(high_n)
    if high >= 0:
        print(f"crossover: not settled: the GPU won at {high_n} once, lost in the re-run")
        return 1
    if low < 0:
        print(f"crossover: not settled: the GPU lost at {last} once, won in the re-run")
        return 1
    at = last + (high_n - last) * low / (low - high)
    print(f"crossover: {at:.0f} drones x {its} iterations (record every {k}): the GPU loses "
          f"at {last} and wins at {high_n}; AUTO_DRONE_ITERATIONS = "
          f"{math.ceil(at) * its}")  # fmt: skip
    return 0


def auto(threshold: str) -> int:
    """What "auto" picks on this machine with ``AUTO_DRONE_ITERATIONS = threshold``: the
    engine of gathering's 4-drone teaching run (created and run), and of patrol runs just
    below and above the threshold (created: the GPU's kernel compiled, not run)."""
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.engines import gpu

    gpu.AUTO_DRONE_ITERATIONS = least = int(threshold)
    sim = Simulation.create(load("gathering"), engine="auto").run(progress=False)
    print(f"auto, AUTO_DRONE_ITERATIONS = {least}: gathering 4 x 8000 runs on {sim.engine.name}")
    for agents in (least // 1000 // 2, 2 * least // 1000):
        patrol = load("patrol").with_overrides(agents=agents, iterations=1000)
        name = Simulation.create(patrol, engine="auto", record_every=100).engine.name
        print(f"auto, AUTO_DRONE_ITERATIONS = {least}: patrol {agents} x 1000 takes {name}")
    return 0


def spread(
    engine: str = "gpu", agents: str = "1000000", iterations: str = "200",
    neighbours: str = "20",
) -> int:  # fmt: skip
    """Gathering with messages in range, its swarm spread at constant density: ``agents``
    drones, each starting on its own refuelling slot and flying to its own surveillance
    position, both drawn uniformly in a square world sized so that a drone has
    ``neighbours`` others within the 25 m datalink range on average (side =
    sqrt(agents * pi * 25**2 / neighbours)); every drone shares its state every iteration
    (spatial messaging), drone1 orders the gathering at iteration 100. Prints the set-up
    and loop times and drone-iterations per second. (The gathering scenario's own 4 slots
    and 4 points would pack the swarm: every drone would hear a quarter of it. The points
    are drawn in the mission's placement, wrapped here for this process only: a scenario
    file of a million points takes minutes to read and check.)"""
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.missions.gathering import GatheringMission

    n, its = int(agents), int(iterations)
    side = math.ceil(math.sqrt(n * math.pi * 25.0**2 / float(neighbours)))
    place = GatheringMission.place

    def spread_out(mission: Any, swarm: Any, world: Any, rng: Any) -> None:
        place(mission, swarm, world, rng)
        draw = np.random.default_rng(0)
        size = swarm.size  # the run's swarm, or the fit check's probe of a few drones
        slots, points = (draw.uniform(1.0, side - 1.0, (size, 2)) for _ in "ab")
        s, bb = swarm.columns, swarm.blackboard
        s["x"][:], s["y"][:] = slots.T
        bb["x_refueling_position"][:], bb["y_refueling_position"][:] = slots.T
        mission.set_surveillance(swarm, points)

    scenario = load("gathering").with_overrides(
        agents=n, iterations=its, size=[side, side], datalink_range=25, gathering_iteration=100
    )
    began = time.perf_counter()
    setattr(GatheringMission, "place", spread_out)  # noqa: B010  (for this process only)
    try:
        sim = Simulation.create(scenario, seed=0, engine=engine, record_every=100)
    finally:
        setattr(GatheringMission, "place", place)  # noqa: B010
    made = time.perf_counter()
    sim.run(progress=False)
    loop = time.perf_counter() - made
    x, y = sim.swarm.columns["x"], sim.swarm.columns["y"]
    print(f"gathering spread, {engine}: {n} drones x {its} iterations in a {side} m square "
          f"({neighbours} neighbours in range on average): set-up {made - began:.1f} s, loop "
          f"{loop:.3f} s = {n * its / loop:.3g} drone-iterations/s (goal 4.7e8); parts "
          f"{getattr(sim.engine, 'timings', None)}; at the end x {x.min():.0f}..{x.max():.0f}, "
          f"y {y.min():.0f}..{y.max():.0f}")  # fmt: skip
    return 0


def memory(*sizes: str) -> int:
    """Device memory of patrol runs of ``sizes`` drones x 100 iterations (record every 100),
    one after the other in this process; with two sizes or more, the bytes per drone (the
    slope between the two largest: both should be past 6,300,000 drones, where a record
    slot holds one row) and the largest swarm that the free memory holds."""
    import gc

    from numba import cuda

    from pyautonomousagent import Simulation, load

    context = cuda.current_context()
    free0, total = context.get_memory_info()
    print(f"device memory: {free0 / 2**30:.1f} GiB free of {total / 2**30:.1f} GiB")
    used: dict[int, int] = {}
    for text in sizes:
        n = int(text)
        scenario = load("patrol").with_overrides(agents=n, iterations=100)
        sim = Simulation.create(scenario, engine="gpu", record_every=100).run(progress=False)
        free1, _ = context.get_memory_info()
        used[n] = free0 - free1
        print(f"patrol {n} drones x 100 on the GPU: device memory in use "
              f"{used[n] / 2**30:.2f} GiB = {used[n] / n:.0f} bytes per drone; "
              f"{sim.world.iteration} iterations done", flush=True)  # fmt: skip
        del sim
        gc.collect()
        pending = getattr(context, "deallocations", None)  # None under the simulator
        if pending is not None:
            pending.clear()
    if len(used) >= 2:
        (n1, u1), (n2, u2) = sorted(used.items())[-2:]
        slope = (u2 - u1) / (n2 - n1)
        if not slope > 0:
            print(f"memory per drone: not measurable here (device memory in use {u1}, {u2})")
            return 1
        fixed = u1 - slope * n1
        largest = int((free0 - fixed) / slope)
        print(f"memory per drone: {slope:.0f} bytes (fixed {fixed / 2**20:.0f} MiB); the "
              f"largest patrol swarm the free {free0 / 2**30:.1f} GiB hold: {largest} drones "
              f"(computed from the slope, not run)")  # fmt: skip
    return 0


def main(argv: list[str]) -> int:
    commands = {"check": check, "fma": fma, "lto": lto, "identity": identity, "device": device,
                "bandwidth": bandwidth, "bytes": state_bytes, "rate": rate, "memory": memory,
                "crossover": crossover, "spread": spread, "auto": auto}  # fmt: skip
    if not argv or argv[0] not in commands:
        print(__doc__, file=sys.stderr)
        return 2
    return commands[argv[0]](*argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
