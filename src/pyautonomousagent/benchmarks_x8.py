"""The X8 benchmark (the paper's Table 5) and its stress test: time and peak memory per case.

Each case (engine, UAVs, iterations) runs in a fresh process, so its peak resident memory
(``ru_maxrss``) is its own: the interpreter, NumPy, the swarm, the engine, the model and the
preallocated recording. The time is the wall time of the simulation loop (Phases 2-6, as in the
paper's table; set-up and export not included).

Engines: "pyfly" is the py_trees engine flying one PyFly simulator per UAV (the paper's set-up);
"batched" is the batched engine flying the vectorised X8; "pytrees" is the py_trees engine with
the engine's default model.

The stress test (``--stress``) doubles the number of UAVs until a case's peak memory exceeds
the budget (the paper: 5.12 GB), then bisects. Each trial preallocates the recording of the
full run and commits its memory, then runs ``stress_iterations`` iterations: the loop allocates
nothing that grows, so the peak is reached within the first iterations.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import resource
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass

#: Engine name -> (decision engine, X8 implementation or None for the engine's default).
BENCH_ENGINES: dict[str, tuple[str, str | None]] = {
    "pyfly": ("pytrees", "pyfly"),
    "batched": ("batched", None),
    "pytrees": ("pytrees", None),
}

#: The paper's Table 5 (seconds for 4000 iterations), UAVs -> time.
PAPER_TABLE_5 = {1: 20.89, 10: 210.97, 100: 1955.72}
#: The paper's memory budget of its stress tests (5.12 GB).
PAPER_BUDGET_GB = 5.12


@dataclass(frozen=True)
class Case:
    """One benchmark case.

    Attributes:
        scenario: registered scenario name or YAML path.
        engine: a key of :data:`BENCH_ENGINES`.
        agents: number of UAVs.
        iterations: iterations simulated.
        record_every: recording decimation.
        full_iterations: the run the recording is sized for (>= iterations); for stress trials.
        seed: the run's seed.
    """

    scenario: str
    engine: str
    agents: int
    iterations: int
    record_every: int = 1
    full_iterations: int | None = None
    seed: int = 0


@dataclass(frozen=True)
class Result:
    """What one case measured.

    Attributes:
        case: the case.
        seconds: wall time of the simulation loop (s).
        peak_mb: peak resident memory of the process (MB, 10^6 bytes).
        setup_seconds: wall time of the set-up (Phase 1, engine, model, recorder).
    """

    case: Case
    seconds: float
    peak_mb: float
    setup_seconds: float

    @property
    def per_agent_iteration(self) -> float:
        """Seconds per UAV and iteration."""
        return self.seconds / (self.case.agents * self.case.iterations)


def _run_case(case: Case) -> Result:
    """Run ``case`` in this process (the child) and measure it."""
    from pyautonomousagent import Simulation, load

    engine, implementation = BENCH_ENGINES[case.engine]
    full = max(case.full_iterations or case.iterations, case.iterations)
    scenario = load(case.scenario).with_overrides(agents=case.agents, iterations=full)
    start = time.perf_counter()
    sim = Simulation.create(
        scenario,
        seed=case.seed,
        engine=engine,
        record_every=case.record_every,
        implementation=implementation,
    )
    for values in sim.recorder.columns.values():
        values.fill(0)  # commit the recording's pages, as a full run would
    setup = time.perf_counter() - start
    start = time.perf_counter()
    for _ in range(case.iterations):
        sim.step()
    seconds = time.perf_counter() - start
    peak_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return Result(case, seconds, peak_kib * 1024 / 1e6, setup)


def measure(case: Case) -> Result:
    """Run ``case`` in a fresh process; its time and peak memory.

    Args:
        case: what to run.

    Returns:
        The measurement.
    """
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        return pool.submit(_run_case, case).result()


def table_rows(results: Sequence[Result], engines: Sequence[str]) -> list[dict[str, object]]:
    """One row per number of UAVs: each engine's time, memory and per-UAV-iteration cost, and
    the speed-up of the last engine over the first (per UAV-iteration, same run)."""
    by_key = {(r.case.engine, r.case.agents): r for r in results}
    rows = []
    for agents in sorted({r.case.agents for r in results}):
        row: dict[str, object] = {"uavs": agents}
        for engine in engines:
            r = by_key.get((engine, agents))
            if r is not None:
                row[engine] = r
        first, last = by_key.get((engines[0], agents)), by_key.get((engines[-1], agents))
        if first and last and len(engines) > 1:
            row["speedup"] = first.per_agent_iteration / last.per_agent_iteration
        rows.append(row)
    return rows


def format_table(results: Sequence[Result], engines: Sequence[str], iterations: int) -> str:
    """The benchmark as a text table like the paper's Table 5."""
    head = f"{'UAVs':>6}"
    for engine in engines:
        head += f" | {engine + ' (s)':>13} {'s/UAV-it':>9} {'peak MB':>8}"
    head += f" | {'speed-up':>8} | {'paper (s)':>9}"
    lines = [head, "-" * len(head)]
    for row in table_rows(results, engines):
        agents = int(str(row["uavs"]))
        line = f"{agents:>6}"
        for engine in engines:
            r = row.get(engine)
            if isinstance(r, Result):
                full = r.per_agent_iteration * agents * iterations
                mark = "~" if r.case.iterations != iterations else " "
                line += f" | {mark}{full:>12.2f} {r.per_agent_iteration:>9.2e} {r.peak_mb:>8.1f}"
            else:
                line += f" | {'-':>13} {'-':>9} {'-':>8}"
        speedup = row.get("speedup")
        line += f" | {speedup:>7.0f}x" if isinstance(speedup, float) else f" | {'-':>8}"
        paper = PAPER_TABLE_5.get(agents) if iterations == 4000 else None
        line += f" | {paper:>9.2f}" if paper else f" | {'-':>9}"
        lines.append(line)
    return "\n".join(lines)


@dataclass(frozen=True)
class StressResult:
    """The stress test's outcome: the largest fleet whose case stayed within the budget.

    Attributes:
        engine: the engine.
        budget_mb: the memory budget (MB).
        largest_fit: the most UAVs measured within the budget (0 if none).
        trials: every trial run, in order.
    """

    engine: str
    budget_mb: float
    largest_fit: int
    trials: tuple[Result, ...]


def stress(
    scenario: str,
    engine: str,
    budget_mb: float,
    iterations: int,
    full_iterations: int,
    record_every: int,
    start: int = 1000,
    limit: int = 10_000_000,
    precision: float = 0.05,
) -> StressResult:
    """Double the fleet from ``start`` until a trial's peak exceeds ``budget_mb``, then bisect
    to ``precision`` (relative); each trial is a :class:`Case` run by :func:`measure`."""
    trials: list[Result] = []

    def fits(agents: int) -> bool:
        case = Case(scenario, engine, agents, iterations, record_every, full_iterations)
        trials.append(measure(case))
        return trials[-1].peak_mb <= budget_mb

    low, high = 0, start
    while high <= limit and fits(high):
        low, high = high, high * 2
    while low and high - low > precision * low:
        middle = (low + high) // 2
        low, high = (middle, high) if fits(middle) else (low, middle)
    return StressResult(engine, budget_mb, low, tuple(trials))


def format_stress(result: StressResult) -> str:
    """The stress test as text: each trial, then the largest fleet within the budget."""
    lines = [f"stress test, {result.engine}: budget {result.budget_mb:.0f} MB"]
    for t in result.trials:
        ok = "fits" if t.peak_mb <= result.budget_mb else "over"
        lines.append(
            f"  {t.case.agents:>9} UAVs: peak {t.peak_mb:>8.1f} MB ({ok}), "
            f"{t.case.iterations} iterations in {t.seconds:.2f} s"
        )
    lines.append(f"  largest fleet within the budget: {result.largest_fit} UAVs")
    return "\n".join(lines)


def to_json(results: Sequence[Result], stresses: Sequence[StressResult]) -> str:
    """All measurements as JSON (cases, seconds, peak MB, per UAV-iteration)."""

    def one(r: Result) -> dict[str, object]:
        return {**asdict(r), "per_agent_iteration": r.per_agent_iteration}

    data = {
        "results": [one(r) for r in results],
        "stress": [
            {
                **{k: v for k, v in asdict(s).items() if k != "trials"},
                "trials": [one(t) for t in s.trials],
            }
            for s in stresses
        ],
    }
    return json.dumps(data, indent=2)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``pyaa bench`` (X8 benchmark)."""
    parser.add_argument("scenario", help="a registered scenario name or a scenario .yaml file")
    parser.add_argument("--agents", type=_counts, default=[1, 10, 100], help="e.g. 1,10,100")
    parser.add_argument(
        "--engines", type=_engines, default=["pyfly", "batched"], help="e.g. pyfly,batched"
    )
    parser.add_argument("--iterations", type=int, help="iterations (default: the scenario's)")
    parser.add_argument(
        "--reference-iterations",
        type=int,
        metavar="K",
        help="run the pyfly engine for K iterations only and scale its time to --iterations "
        "(marked ~ in the table)",
    )
    parser.add_argument("--record-every", type=int, default=1, metavar="K")
    parser.add_argument("--stress", action="store_true", help="find the largest fleet in budget")
    parser.add_argument(
        "--memory-budget", type=float, default=PAPER_BUDGET_GB, metavar="GB", help="stress budget"
    )
    parser.add_argument("--stress-start", type=int, default=1000, metavar="N")
    parser.add_argument("--stress-iterations", type=int, default=20, metavar="K")
    parser.add_argument(
        "--stress-record-every",
        type=int,
        default=100,
        metavar="K",
        help="recording decimation of the stress trials (default 100)",
    )
    parser.add_argument("--json", action="store_true", help="print the measurements as JSON")


def _counts(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers like 1,10,100, got {text!r}") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"expected positive numbers, got {text!r}")
    return values


def _engines(text: str) -> list[str]:
    values = [v.strip() for v in text.split(",") if v.strip()]
    unknown = [v for v in values if v not in BENCH_ENGINES]
    if not values or unknown:
        raise argparse.ArgumentTypeError(
            f"unknown engine {', '.join(unknown) or text!r}; choose from {', '.join(BENCH_ENGINES)}"
        )
    return values


def run_bench(args: argparse.Namespace) -> int:
    """``pyaa bench``: the table (and the stress test), printed."""
    from pyautonomousagent.scenarios import load

    scenario = load(args.scenario)
    iterations = args.iterations or scenario.iterations
    results = []
    for agents in args.agents:
        for engine in args.engines:
            its = iterations
            if engine == "pyfly" and args.reference_iterations:
                its = min(args.reference_iterations, iterations)
            case = Case(args.scenario, engine, agents, its, args.record_every, iterations)
            results.append(measure(case))
            if not args.json:
                r = results[-1]
                print(f"  {engine:>8} {agents:>6} UAVs x {its} iterations: {r.seconds:.2f} s")
    stresses = []
    if args.stress:
        for engine in args.engines:
            if engine == "pyfly":
                continue  # hours per trial; the paper's 290 UAVs is the reference
            stresses.append(
                stress(
                    args.scenario,
                    engine,
                    args.memory_budget * 1000,
                    args.stress_iterations,
                    iterations,
                    args.stress_record_every,
                    start=args.stress_start,
                )
            )
    if args.json:
        print(to_json(results, stresses))
        return 0
    print(
        f"\n{scenario.name}: {iterations} iterations (dt = one iteration), "
        f"record every {args.record_every}; time of the simulation loop, peak resident memory"
    )
    print(format_table(results, args.engines, iterations))
    for s in stresses:
        print()
        print(format_stress(s))
    return 0
