"""``pyaa bench``: time and memory of scenario runs, engine against engine (paper Tables 4, 5).

Each case runs in a fresh Python process, so its peak memory (maximum resident set size)
is its own. Timed: set-up (Phase 1) and the loop (Phases 2-6), not Phase 7, as in the paper;
a case with ``save`` also times writing the run folder as ``pyaa run`` does. The speed-up is
the first engine's time per agent-iteration over each other engine's, measured in one run.
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pyautonomousagent.simulation import Simulation
    from pyautonomousagent.simulation.scenario import Scenario

#: The paper's tables (4000 iterations, its 2 GHz machine): scenario -> {agents: seconds}.
PAPER_TABLES = {
    "patrol": {
        1: 0.19,
        10: 2.02,
        20: 3.48,
        50: 8.79,
        100: 17.32,
        200: 35.41,
        500: 89.12,
        1000: 177.41,
    },  # Table 4
    "x8-patrol": {1: 20.89, 10: 210.97, 100: 1955.72},  # Table 5
}

#: Bench engine name -> (decision engine, X8 implementation or None for the engine's own).
#: "pyfly" is the paper's X8 set-up: the py_trees engine flying one PyFly per UAV.
BENCH_ENGINES: dict[str, tuple[str, str | None]] = {
    "pytrees": ("pytrees", None),
    "batched": ("batched", None),
    "compiled": ("compiled", None),
    "gpu": ("gpu", None),
    "auto": ("auto", None),
    "pyfly": ("pytrees", "pyfly"),
}

#: ``Simulation.timings`` keys of the views (seconds per view written).
VIEW_TIMINGS = ("animation", "replay")


@dataclass(frozen=True)
class Case:
    """One measured run.

    ``full_iterations``, when set, sizes the recording for a run that long (the stress
    probes run a few iterations of a full run); ``scaled`` marks a case whose time is
    scaled to ``full_iterations`` in the table (a slow engine run for fewer iterations).
    """

    scenario: str
    engine: str
    agents: int
    iterations: int
    record_every: int
    full_iterations: int | None = None
    scaled: bool = False
    save: bool = False
    variant: str = ""
    parameters: str = ""


@dataclass(frozen=True)
class Result:
    """What a case measured: seconds (set-up and loop) and peak resident memory (MB), or why
    it failed. ``setup`` is the part of ``seconds`` spent before the loop; ``write`` and
    ``views`` are the seconds spent writing the data (after the loop) and the views, and
    ``write_thread`` the CPU seconds of the thread writing the data while the loop ran
    (``case.save`` only)."""

    case: Case
    seconds: float | None
    peak_mb: float | None
    error: str = ""
    setup: float = 0.0
    write: float | None = None
    views: float | None = None
    write_thread: float | None = None
    #: The GPU engine's parts (seconds; ``engines.gpu.TIMINGS``, and "write" as ``write``);
    #: None for the other engines, as is its bytes of device memory per drone-iteration.
    gpu: dict[str, float | None] | None = None
    bytes_per_drone_iteration: float | None = None

    @property
    def loop(self) -> float | None:
        """Seconds of the loop (Phases 2-6) as measured (not scaled)."""
        return None if self.seconds is None else self.seconds - self.setup

    @property
    def per_agent_iteration(self) -> float | None:
        """Loop seconds per agent-iteration (set-up excluded)."""
        loop = self.loop
        return None if loop is None else loop / (self.case.agents * self.case.iterations)

    def bandwidth_fraction(self, gbps: float) -> float | None:
        """The share of ``gbps`` (GB/s, e.g. the card's measured copy bandwidth) that the
        loop's rate moves at :attr:`bytes_per_drone_iteration`; None where not measured."""
        if self.bytes_per_drone_iteration is None or not self.loop:
            return None
        rate = self.case.agents * self.case.iterations / self.loop
        return self.bytes_per_drone_iteration * rate / (gbps * 1e9)

    @property
    def full_seconds(self) -> float | None:
        """Seconds for the full run: measured, or set-up plus the loop scaled from a shorter
        run (``case.scaled``)."""
        if self.seconds is None or not self.case.scaled or not self.case.full_iterations:
            return self.seconds
        loop = (self.seconds - self.setup) * self.case.full_iterations / self.case.iterations
        return self.setup + loop


def run_case_here(case: Case) -> dict[str, Any]:
    """Run ``case`` in this process; its seconds (set-up and loop), set-up seconds, and peak
    memory (MB); with ``case.save`` also the seconds of writing the data and the views."""
    from pyautonomousagent.simulation import Simulation

    scenario = case_scenario(case)
    engine, implementation = BENCH_ENGINES[case.engine]
    start = time.perf_counter()
    sim = Simulation.create(
        scenario,
        seed=0,
        engine=engine,
        record_every=case.record_every,
        implementation=implementation,
    )
    setup = time.perf_counter() - start
    if not case.save:
        sim.run(progress=False, iterations=case.iterations)
        figures = {"seconds": time.perf_counter() - start, "setup": setup, "peak_mb": peak_rss_mb()}
    else:
        figures = {"setup": setup, **saved_timings(sim, case.iterations, start)}
    return {**figures, **gpu_figures(sim, figures.get("write"))}


def case_scenario(case: Case) -> Scenario:
    """The scenario ``case`` runs: its agents, iterations (enough for ``full_iterations``)
    and parameters, in the world the mission needs for that many agents (``world_for``)."""
    from pyautonomousagent.scenarios import load

    full = max(case.full_iterations or case.iterations, case.iterations)
    scenario = load(case.scenario).with_overrides(
        iterations=full, **parse_parameters(case.parameters)
    )
    size = scenario.mission_type.world_for(scenario, case.agents)
    return scenario.with_overrides(agents=case.agents, size=list(size))


def gpu_figures(sim: Simulation, write: float | None) -> dict[str, Any]:
    """The GPU engine's parts of a run (``"gpu"``: its timings and ``write``, the seconds
    of writing the data after the loop, None where it was not saved) and its
    ``"bytes_per_drone_iteration"``; {} for the other engines."""
    parts = getattr(sim.engine, "timings", None)
    per_drone = getattr(sim.engine, "bytes_per_drone_iteration", None)
    if not isinstance(parts, dict) or per_drone is None:
        return {}
    return {"gpu": {**parts, "write": write}, "bytes_per_drone_iteration": per_drone(sim)}


def saved_timings(sim: Simulation, iterations: int, start: float) -> dict[str, float]:
    """Run ``iterations`` of ``sim`` and save it as ``pyaa run`` does into a temporary
    folder: seconds from ``start`` to the loop's end, peak memory (MB) then, and the seconds
    of writing the data after the loop, of the writing thread (CPU) and of the views."""
    from pyautonomousagent.runs import save_run, streaming

    with tempfile.TemporaryDirectory(prefix="pyaa-bench-") as folder:
        out = Path(folder) / "run"
        with streaming(sim, out) as stream:
            sim.run(progress=False, iterations=iterations)
            seconds, peak = time.perf_counter() - start, peak_rss_mb()
            save_run(sim, out, progress=False, command=["pyaa", "bench"], stream=stream)
    return {
        "seconds": seconds,
        "peak_mb": peak,
        "write": sim.timings.get("write_data", 0.0),
        "write_thread": sim.timings.get("write_data_thread", 0.0),
        "views": sum(sim.timings.get(k, 0.0) for k in VIEW_TIMINGS),
    }


def peak_rss_mb(maxrss: int | None = None, system: str = sys.platform) -> float:
    """This process's peak resident memory in MB (MiB) from ``getrusage``'s ``ru_maxrss``,
    which macOS gives in bytes and Linux (and the BSDs) in KiB."""
    if maxrss is None:
        maxrss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return maxrss / (1024 * 1024) if system == "darwin" else maxrss / 1024


def measure(case: Case, timeout: float | None = None, budget_mb: float | None = None) -> Result:
    """Run ``case`` in a fresh process (so its peak memory is its own); with ``budget_mb``,
    stop it as soon as its peak memory (read from /proc) passes the budget."""
    command = [sys.executable, "-m", "pyautonomousagent.bench", json.dumps(asdict(case))]
    started = time.perf_counter()
    with subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    ) as child:
        while child.poll() is None:
            over = budget_mb is not None and (_peak_mb(child.pid) or 0.0) > budget_mb
            if over or timeout is not None and time.perf_counter() - started > timeout:
                child.kill()
                child.wait()
                if over:
                    return Result(case, None, _peak_mb(child.pid), f"over {budget_mb:.0f} MB")
                return Result(case, None, None, f"timed out after {timeout:.0f} s")
            time.sleep(0.05)
        out, err = child.communicate()
    if child.returncode != 0:
        lines = err.strip().splitlines()
        return Result(case, None, None, lines[-1] if lines else f"exit code {child.returncode}")
    return Result(case, **json.loads(out.strip().splitlines()[-1]))  # run_case_here's figures


def _peak_mb(pid: int) -> float | None:
    """Peak resident memory of a running process in MB, from /proc (None if unknown)."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


def speedups(results: Sequence[Result], reference: str) -> dict[Case, float]:
    """Case -> seconds per agent-iteration of the ``reference`` engine / this case's, for the
    same scenario, agents and recording, measured in the same run."""
    base: dict[tuple[str, int, int], float] = {}
    for r in results:
        if r.case.engine == reference and r.per_agent_iteration:
            base[(r.case.scenario, r.case.agents, r.case.record_every)] = r.per_agent_iteration
    ratios = {}
    for r in results:
        key = (r.case.scenario, r.case.agents, r.case.record_every)
        if r.case.engine != reference and r.per_agent_iteration and key in base:
            ratios[r.case] = base[key] / r.per_agent_iteration
    return ratios


def table(results: Sequence[Result], reference: str) -> str:
    """The results as a text table like the paper's Tables 4 and 5: speed-ups per
    agent-iteration against ``reference`` (``~``: a time scaled from a shorter run), then
    set-up, loop (not scaled), writing the data and the views (``-``: not saved)."""
    ratios = speedups(results, reference)
    head = (
        f"{'agents':>8} {'engine':>8} {'record':>7} {'seconds':>10} {'s/agent-it':>11} "
        f"{'peak MB':>8} {'speed-up':>9} {'paper s':>8} {'set-up':>7} {'loop':>8} "
        f"{'write':>7} {'views':>7}"
    )
    lines = [head, "-" * len(head)]
    for r in results:
        c = r.case
        full = c.full_iterations or c.iterations
        paper = PAPER_TABLES.get(c.scenario, {}).get(c.agents) if full == 4000 else None
        if r.full_seconds is None or r.per_agent_iteration is None or r.peak_mb is None:
            lines.append(f"{c.agents:>8} {c.engine:>8} {c.record_every:>7}  failed: {r.error}")
            continue
        ratio = format_ratio(ratios[c]) if c in ratios else ""
        seconds = f"{'~' if c.scaled else ''}{r.full_seconds:.3f}"
        lines.append(
            f"{c.agents:>8} {c.engine:>8} {c.record_every:>7} {seconds:>10} "
            f"{r.per_agent_iteration:>11.2e} {r.peak_mb:>8.0f} {ratio:>9} "
            f"{'' if paper is None else f'{paper:.2f}':>8} {r.setup:>7.3f} {r.loop or 0.0:>8.3f} "
            f"{_seconds(r.write):>7} {_seconds(r.views):>7}"
        )
    return "\n".join(lines)


def gpu_table(results: Sequence[Result], gbps: float | None = None) -> str:
    """One line per GPU case: its parts (compile, kernel, copy-back, state, write seconds),
    bytes per drone-iteration, and the GB/s they make at the loop's rate, with their share
    of ``gbps`` where given; "" without GPU cases."""
    lines = []
    for r in results:
        if r.gpu is None or r.bytes_per_drone_iteration is None or not r.loop:
            continue
        parts = ", ".join(f"{k.replace('_', '-')} {_seconds(v)}" for k, v in r.gpu.items())
        rate = r.case.agents * r.case.iterations / r.loop
        moved = r.bytes_per_drone_iteration * rate / 1e9
        share = r.bandwidth_fraction(gbps) if gbps else None
        of = f" = {share:.1%} of {gbps:g} GB/s" if share is not None else ""
        lines.append(
            f"gpu {r.case.agents} x {r.case.iterations}: {parts} s; "
            f"{r.bytes_per_drone_iteration:.0f} bytes/drone-iteration x {rate:.3g}/s = "
            f"{moved:.3g} GB/s{of}"
        )
    return "\n".join(lines)


def parse_parameters(text: str) -> dict[str, Any]:
    """``"a=1,b=x"`` -> ``{"a": 1, "b": "x"}`` (values read as YAML scalars); "" -> {}.

    Raises:
        ValueError: a part is not ``KEY=VALUE``.
    """
    from pyautonomousagent.inputs import load_yaml

    values = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        key, sep, value = part.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ValueError(f"expected KEY=VALUE, got {part!r}")
        values[key.strip()] = load_yaml(value, f"--compare {key.strip()}")
    return values


def compare_table(results: Sequence[Result]) -> str:
    """Variants of the same cases side by side (``pyaa bench --compare``): per agents,
    engine and variant, the best (least) loop seconds and peak memory of its repeats, and
    their ratios to the first variant's (``with / without``); every repeat's loop seconds."""
    groups: dict[tuple[int, str, int], dict[str, list[Result]]] = {}
    for r in results:
        key = (r.case.agents, r.case.engine, r.case.record_every)
        groups.setdefault(key, {}).setdefault(r.case.variant, []).append(r)
    head = (
        f"{'agents':>8} {'engine':>8} {'variant':>10} {'best loop s':>11} {'ratio':>6} "
        f"{'peak MB':>8} {'ratio':>6}  loop s of each repeat"
    )
    lines = [head, "-" * len(head)]
    for (agents, engine, _), variants in groups.items():
        base: tuple[float, float] | None = None
        for variant, runs in variants.items():
            done = [r for r in runs if r.loop is not None and r.peak_mb is not None]
            if not done:
                lines.append(f"{agents:>8} {engine:>8} {variant:>10}  failed: {runs[0].error}")
                continue
            loop = min(r.loop or 0.0 for r in done)
            peak = min(r.peak_mb or 0.0 for r in done)
            base = base or (loop, peak)
            each = " ".join(f"{r.loop:.3f}" for r in done)
            lines.append(
                f"{agents:>8} {engine:>8} {variant:>10} {loop:>11.3f} {loop / base[0]:>6.2f} "
                f"{peak:>8.0f} {peak / base[1]:>6.2f}  {each}"
            )
    return "\n".join(lines)


def _seconds(value: float | None) -> str:
    """Seconds as the table shows them, ``-`` for a figure not measured."""
    return "-" if value is None else f"{value:.3f}"


def format_ratio(ratio: float) -> str:
    """A speed-up as the table shows it: ``0.57x``, ``3.2x``, ``48x``."""
    return f"{ratio:.0f}x" if ratio >= 10 else f"{ratio:.2g}x"


def stress(
    scenario: str,
    engine: str,
    budget_mb: float,
    iterations: int,
    record_every: int,
    start: int = 1000,
    report: Callable[[Result], None] = lambda r: None,
    full_iterations: int | None = None,
) -> tuple[int, list[Result]]:
    """The largest swarm whose run stays within ``budget_mb`` of peak memory, and every
    probe: each runs ``iterations`` of a run whose (preallocated) recording is sized for
    ``full_iterations``; the agents double from ``start`` until a probe exceeds the budget
    (or fails), then a bisection narrows them to within 2 %."""
    probes: list[Result] = []

    def fits(agents: int) -> bool:
        case = Case(scenario, engine, agents, iterations, record_every, full_iterations)
        result = measure(case, budget_mb=budget_mb)
        probes.append(result)
        report(result)
        return result.peak_mb is not None and result.peak_mb <= budget_mb

    low, high = 0, start
    while fits(high):
        low, high = high, high * 2
    while high - low > max(1, low // 50):
        middle = (low + high) // 2
        low, high = (middle, high) if fits(middle) else (low, middle)
    return low, probes


def parse_size_mb(text: str) -> float:
    """``"5.12GB"`` -> 5242.88 (MB, 1024-based); also MB, KB, or a bare number of MB.

    Raises:
        ValueError: not a positive, finite size (one line naming the text).
    """
    units = {"gb": 1024.0, "mb": 1.0, "kb": 1 / 1024}
    lowered = text.strip().lower()
    suffix = next((s for s in units if lowered.endswith(s)), "")
    try:
        size = float(lowered.removesuffix(suffix)) * units.get(suffix, 1.0)
    except ValueError:
        size = float("nan")
    if not math.isfinite(size) or size <= 0:
        raise ValueError(f"expected a positive size such as 5.12GB, 800MB or 512, got {text!r}")
    return size


if __name__ == "__main__":
    print(json.dumps(run_case_here(Case(**json.loads(sys.argv[1])))))
