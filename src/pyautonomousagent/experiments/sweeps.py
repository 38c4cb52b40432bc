"""Run an experiment: every point x seed on a backend, into a sweep folder.

:func:`sweep` is the library function behind ``pyaa sweep``. Before anything runs, every
varied value is checked against the scenario, expression measures against the recorded
columns, and the estimated memory of the largest run against what a worker may use. Runs
are journaled as they finish (:mod:`~pyautonomousagent.experiments.store`); a run that raises
is recorded as failed and the sweep goes on; ``resume=True`` skips the runs already done.
"""

from __future__ import annotations

import contextlib
import json
import math
import pickle
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pyarrow as pa

from pyautonomousagent.bt.files import is_tree_file
from pyautonomousagent.engines.compiled import CompiledEngine
from pyautonomousagent.experiments.backends import Backend, make_backend, quiet
from pyautonomousagent.experiments.design import DESIGN_FILE, design_table
from pyautonomousagent.experiments.errors import close_hint
from pyautonomousagent.experiments.measures import MEASURES, RunData, _Evaluate
from pyautonomousagent.experiments.runner import (
    RunTask,
    blank_row,
    execute,
    one_line,
    parameter_columns,
    scenario_parameters,
)
from pyautonomousagent.experiments.series import SERIES, TIMESERIES, compact, documented
from pyautonomousagent.experiments.spec import Experiment, ExperimentError, Run, for_scenario
from pyautonomousagent.experiments.store import (
    MANIFEST,
    RESULTS,
    RUNS,
    Journal,
    atomic_write_table,
    last_row_per_run,
    read_manifest,
    results_schema,
    write_manifest,
)
from pyautonomousagent.folders import BusyError, claimed
from pyautonomousagent.progress import Progress
from pyautonomousagent.runs import versions
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import ScenarioError, Simulation
from pyautonomousagent.simulation.costs import AUTO_COMPILE_SECONDS, run_costs
from pyautonomousagent.simulation.run import choose_engine, recorded_columns, scenario_tree
from pyautonomousagent.simulation.scenario import to_mapping

#: Freed memory a worker process may keep: the trim threshold set by ``allocator.py``
#: (4 x 32 MiB), which the batched engine applies to every process it runs in.
ALLOCATOR_RETAINED_BYTES = 4 * 32 * 1024 * 1024
#: Share of a worker's memory a run may use (Dask pauses a worker at 80 % of its limit).
MEMORY_SHARE = 0.8
_NOT_VARIED = ("name", "description", "parameters")


@dataclass
class SweepResult:
    """What a sweep did.

    Attributes:
        out: the sweep folder.
        table: the results, one row per run (also ``out/results.parquet``).
        counts: runs "ok", "failed" and "skipped" (done before, with ``resume``).
        seconds: wall-clock time of the sweep.
        backend: the backend's name and workers, e.g. ``"pool x 2"``.
    """

    out: Path
    table: pa.Table
    counts: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0
    backend: str = ""


def base_scenario(experiment: Experiment) -> Any:
    """The experiment's scenario with its fixed overrides and iterations applied."""
    try:
        scenario = load(experiment.scenario)
        return scenario.with_overrides(**{"iterations": experiment.iterations, **experiment.fixed})
    except ScenarioError as error:
        raise ExperimentError(f"experiment {experiment.name!r}: {error}") from None


def check(experiment: Experiment, scenario: Any) -> RunData:
    """Check every varied value against ``scenario`` and the expression measures against
    what a run records; return the data of a one-agent, one-iteration probe run.

    Raises:
        ExperimentError: an unknown parameter, a bad value, or an unknown column.
    """
    data = to_mapping(scenario)
    known = [k for k in data if k not in _NOT_VARIED] + list(data["parameters"])
    values: dict[str, set[str]] = {}
    for point in experiment.points():
        for name, value in point.items():
            values.setdefault(name, set()).add(json.dumps(value))
    for name, texts in values.items():
        if name not in known:
            hint = close_hint(name, known)
            raise ExperimentError(
                f"experiment {experiment.name!r}: unknown parameter {name!r}{hint}"
            )
        for text in sorted(texts):
            value = json.loads(text)
            tree_file = name == "tree" and isinstance(value, str) and is_tree_file(value)
            if tree_file and not Path(value).is_file():  # it is read on the worker
                raise ExperimentError(
                    f"experiment {experiment.name!r}: tree: no file {value!r} (a varied tree is "
                    "a path relative to the working directory, or an absolute one)"
                )
            try:
                scenario.with_overrides(**{name: value})
            except ScenarioError as error:
                raise ExperimentError(f"experiment {experiment.name!r}: {error}") from None
    probe = Simulation.create(
        scenario.with_overrides(agents=1, iterations=1), seed=0, engine=experiment.engine
    )
    recorded = RunData.from_simulation(probe)
    names = list(recorded.expression_values())
    for measure in experiment.measures:
        columns = measure.fn.expression.names if isinstance(measure.fn, _Evaluate) else []
        for column in (c for c in columns if c not in names):
            hint = close_hint(column, names)
            raise ExperimentError(f"measure {measure.name!r}: unknown column {column!r}{hint}")
    return recorded


def compile_once(
    experiment: Experiment, scenario: Any, runs: int, report: Callable[[str], None]
) -> float | None:
    """Compile the tree's fused loop here, once, for workers that take the compiled engine
    (``engine: compiled``, or ``auto`` where the largest run saves enough over all ``runs``
    to pay for compiling: :data:`~pyautonomousagent.simulation.costs.AUTO_COMPILE_SECONDS`);
    they load it from numba's cache. Not for a varied tree. ``report`` is told before and
    how long it took; the seconds, or None where nothing was compiled."""
    if experiment.engine not in ("auto", "compiled") or "tree" in experiment.parameters:
        return None
    tree = scenario_tree(scenario)
    if experiment.engine == "auto":
        agents, iterations = largest_run(experiment, scenario)
        every = experiment.record_every
        columns = recorded_columns(scenario.create_mission(), tree)
        if choose_engine(tree, agents, iterations, every, columns, True) != "compiled":
            return None
        costs = run_costs(agents, iterations, every, columns, compiled_ready=True)
        if runs * (costs["batched"].seconds - costs["compiled"].seconds) < AUTO_COMPILE_SECONDS:
            return None
    report("compiling (or loading) the tree's loop for the compiled engine once, before the "
           "runs go to the workers ...")  # fmt: skip
    began = time.perf_counter()
    probe = scenario.with_overrides(agents=1, iterations=1)
    sim = Simulation.create(probe, seed=0, engine="compiled", tree=tree)
    seconds = time.perf_counter() - began
    why = sim.engine.why_not_fused(sim) if isinstance(sim.engine, CompiledEngine) else ""
    if why:
        report(f"the compiled engine ticks the tree only, not whole iterations: {why}")
    report(f"compiled engine: compiling (or loading) the tree's code took {seconds:.1f} s")
    return seconds


def largest_run(experiment: Experiment, scenario: Any) -> tuple[int, int]:
    """The most agents and the most iterations of any of the experiment's points."""
    points = experiment.points()
    agents = max(int(p.get("agents", scenario.agents)) for p in points)
    return agents, max(int(p.get("iterations", scenario.iterations)) for p in points)


def run_bytes(experiment: Experiment, scenario: Any, columns: int, save_runs: bool) -> int:
    """Estimated peak memory of the experiment's largest run: its records (8 bytes per
    column, agent and record; twice when the run's table is written) and the freed memory
    the allocator keeps."""
    agents, iterations = largest_run(experiment, scenario)
    records = iterations // experiment.record_every + 1
    recorded = records * agents * columns * 8 * (2 if save_runs else 1)
    return recorded + ALLOCATOR_RETAINED_BYTES


def check_memory(needed: int, backend: Backend) -> None:
    """Refuse a sweep whose largest run would not fit in a worker."""
    available = backend.memory_per_worker()
    if available is None or needed <= MEMORY_SHARE * available:
        return
    raise ExperimentError(
        f"the largest run needs about {needed / 2**20:.0f} MiB but a {backend.name} worker may "
        f"use {MEMORY_SHARE * available / 2**20:.0f} MiB; record less (--record-every), run "
        "fewer agents, or give the workers more memory"
    )


def sweep(
    experiment: Experiment,
    out: str | Path,
    backend: Backend | str = "pool",
    *,
    workers: int | None = None,
    address: str | None = None,
    resume: bool = False,
    save_runs: bool = False,
    progress: bool | None = None,
    on_result: Callable[[dict[str, Any]], None] | None = None,
    flush_every: int = 50,
    flush_seconds: float = 5.0,
    report: Callable[[str], None] | None = None,
) -> SweepResult:
    """Run every point x seed of ``experiment`` into the folder ``out``.

    Args:
        experiment: what to run.
        out: the sweep folder (created; must not hold another sweep unless ``resume``).
        backend: "pool" (local processes, default), "serial", "dask" (``address`` of a
            scheduler, or a local Dask cluster), or a :class:`Backend` (then not closed here).
        workers: processes of the local pool or local Dask cluster (default: all cores).
        address: the Dask scheduler's address, e.g. ``"tcp://10.0.0.5:8786"``.
        resume: continue the sweep in ``out``: runs already done are skipped.
        save_runs: also write each run's recorded data under ``out/runs`` (hive-partitioned).
        progress: show progress on standard error (default): a bar with ETA on a terminal,
            else a line every 10 s or 5 % of the runs, and a line per lost worker; False for
            none.
        on_result: called with each result row as it arrives.
        flush_every: journal finished runs at least every this many runs...
        flush_seconds: ...and every this many seconds.
        report: called with each line saying what opening the folder repaired (a torn
            journal part set aside, whose runs run again; temporary files deleted).

    Raises:
        ExperimentError: bad experiment, ``out`` holds another sweep, or a run too large.
    """
    out, report = Path(out), report or quiet
    scenario = base_scenario(experiment)
    experiment = for_scenario(experiment, scenario)  # a design's int parameters stay int
    runs = experiment.runs()
    compile_once(experiment, scenario, len(runs), report)
    probe = check(experiment, scenario)
    _previous_manifest(out, experiment, resume)  # refused before a backend starts
    owned = isinstance(backend, str)
    chosen = make_backend(backend, workers, address) if isinstance(backend, str) else backend
    with contextlib.ExitStack() as held:
        if owned:  # closed on an error before the runs (after them, closing again does nothing)
            held.callback(chosen.close)
        check_memory(run_bytes(experiment, scenario, len(probe.columns), save_runs), chosen)
        if chosen.name == "pool":
            _check_picklable(_tasks(experiment, scenario, runs[:1], None)[0])
        held.enter_context(_claim(out, report))
        previous = _previous_manifest(out, experiment, resume)  # again, now that it is ours
        start = time.perf_counter()
        journal = Journal(out, _schema(experiment, scenario))  # makes the folder
        for note in journal.notes:
            report(note)
        done = journal.finished() if resume else set()
        todo = [run for run in runs if run.run_id not in done]
        counts = {"ok": 0, "failed": 0, "skipped": len(runs) - len(todo)}
        manifest = _manifest(experiment, scenario, runs, chosen, previous)
        try:
            write_manifest(out, manifest)
            if experiment.design is not None:
                atomic_write_table(design_table(experiment.design), out / DESIGN_FILE)
            tasks = _tasks(experiment, scenario, todo, out / RUNS if save_runs else None)
            bar = Progress(
                len(tasks), f"sweep {experiment.name}", enabled=progress, lines=True, unit="runs"
            )
            _execute(tasks, chosen, journal, counts, bar, on_result, (flush_every, flush_seconds))
            manifest["status"] = "finished"
        except BaseException:
            manifest["status"] = "interrupted"
            raise
        finally:
            journal.flush()
            if owned:
                chosen.close()
            manifest["backend"].update(worker_stats(chosen))
            table = _finish(journal, out, manifest, counts, start)
    workers_text = f"{chosen.name} x {manifest['backend']['workers']}"
    return SweepResult(out, table, counts, time.perf_counter() - start, workers_text)


def _schema(experiment: Experiment, scenario: Any) -> pa.Schema:
    """The results' schema (:func:`~pyautonomousagent.experiments.store.results_schema`)."""
    points = experiment.points()
    types, docs = parameter_columns(scenario)
    docs.update({m.name: (m.unit, m.doc) for m in experiment.measures})
    parameters = {name: [p[name] for p in points] for name in experiment.parameters}
    measures = [m.name for m in experiment.measures]
    constants = scenario_parameters(scenario)
    return results_schema(parameters, measures, constants, types=types, docs=docs)


def _finish(
    journal: Journal, out: Path, manifest: dict[str, Any], counts: dict[str, int], start: float
) -> pa.Table:
    """Write the results (the journal's last row of each run), the time series (if the
    experiment keeps one) and the final manifest; the results."""
    table = last_row_per_run(journal.read())
    atomic_write_table(table, out / RESULTS)
    if manifest["experiment"].get("every") is not None:
        series = documented(compact(journal.folder, table), manifest["measures"])
        atomic_write_table(series, out / TIMESERIES)
    statuses = table["status"].to_pylist()
    manifest.update(
        counts=counts,  # this session's
        results={state: statuses.count(state) for state in ("ok", "failed")},
        finished_at=_now(),
        seconds=time.perf_counter() - start,
    )
    write_manifest(out, manifest)
    return table


def worker_stats(backend: Backend) -> dict[str, Any]:
    """What the backend says of its workers (seen, lost, runs retried), for the manifest;
    empty for a backend that does not say."""
    stats = getattr(backend, "stats", None)
    return dict(stats()) if callable(stats) else {}


def _tasks(
    experiment: Experiment, scenario: Any, runs: list[Run], runs_dir: Path | None
) -> list[RunTask]:
    """One task per run; the tree is read once here unless the tree itself is varied."""
    tree = None if "tree" in experiment.parameters else scenario_tree(scenario)
    folder = str(runs_dir.resolve()) if runs_dir is not None else None
    shared = (experiment.engine, experiment.record_every, experiment.measures, folder, tree)
    return [RunTask(run, scenario, *shared, experiment.every) for run in runs]


def _check_picklable(task: RunTask) -> None:
    """Pool workers receive runs pickled: a measure defined in a notebook or a function
    cannot be sent; say so before every run fails."""
    try:
        pickle.dumps(task)
    except Exception as error:
        raise ExperimentError(
            f"a run cannot be sent to the pool's processes ({one_line(error)}); define custom "
            "measures in an importable module, or use backend='serial' or 'dask'"
        ) from None


def _execute(
    tasks: list[RunTask],
    backend: Backend,
    journal: Journal,
    counts: dict[str, int],
    bar: Progress,
    on_result: Callable[[dict[str, Any]], None] | None,
    flush: tuple[int, float],
) -> None:
    """Run the tasks, journaling each result once (in batches); ``bar`` shows them (and is
    closed here)."""
    told = getattr(backend, "report", None)
    if told is not None:
        backend.report = bar.note  # type: ignore[attr-defined]  # a lost worker: one line
    seen: set[str] = set()
    last_flush = time.monotonic()
    try:
        for task, outcome in backend.map_unordered(execute, tasks):
            row = outcome if isinstance(outcome, dict) else failed_row(task, outcome)
            series = row.pop(SERIES, None)
            if row["run_id"] in seen:  # never journal a run twice
                continue
            seen.add(row["run_id"])
            journal.append(row, series)
            counts[row["status"]] += 1
            bar.update(len(seen))
            if len(journal.buffer) >= flush[0] or time.monotonic() - last_flush >= flush[1]:
                journal.flush()
                last_flush = time.monotonic()
            if on_result is not None:
                on_result(row)
    finally:
        worker_stats(backend)  # a worker lost near the end is named while the bar can say so
        bar.close()
        if told is not None:
            backend.report = told  # type: ignore[attr-defined]


def failed_row(task: RunTask, error: BaseException) -> dict[str, Any]:
    """The row of a run whose worker failed (e.g. was killed more than Dask allows)."""
    return {**blank_row(task), "status": "failed", "error": one_line(error), "seconds": math.nan}


@contextlib.contextmanager
def _claim(out: Path, report: Callable[[str], None]) -> Iterator[None]:
    """Hold the sweep folder ``out`` for this process (the lock :func:`sweep` and ``pyaa run``
    share: see :mod:`pyautonomousagent.folders`)."""
    try:
        with claimed(out) as held:
            for note in held.notes:
                report(note)
            yield
    except BusyError as error:
        raise ExperimentError(
            f"{out} is being written by another sweep or run ({error.strerror}); wait for it "
            "to finish, or choose another --out"
        ) from None


def _previous_manifest(out: Path, experiment: Experiment, resume: bool) -> dict[str, Any] | None:
    try:
        previous = read_manifest(out)
    except (OSError, ValueError) as error:
        raise ExperimentError(
            f"{out / MANIFEST} cannot be read ({one_line(error)}); the sweep in {out} cannot "
            "be resumed: choose another --out"
        ) from None
    if previous is None:
        if out.is_dir() and any(out.iterdir()):
            raise ExperimentError(
                f"{out} is not empty and holds no sweep; choose another --out (an empty or new "
                "folder)"
            )
        return None
    if not resume:
        raise ExperimentError(
            f"{out} already holds a sweep; pass --resume to continue it, or choose another --out"
        )
    wanted = json.loads(json.dumps(experiment.to_mapping(), default=str))
    if previous.get("experiment") != wanted:
        changed = [k for k in wanted if previous.get("experiment", {}).get(k) != wanted[k]]
        raise ExperimentError(
            f"{out} holds a different experiment ({', '.join(changed) or 'its description'} "
            "changed); resume it with the same experiment, or choose another --out"
        )
    return previous


def _manifest(
    experiment: Experiment,
    scenario: Any,
    runs: list[Run],
    backend: Backend,
    previous: Mapping[str, Any] | None,
) -> dict[str, Any]:
    measures = {
        m.name: {"doc": m.doc, "unit": m.unit, "registered": m.name in MEASURES}
        for m in experiment.measures
    }
    return {
        "experiment": json.loads(json.dumps(experiment.to_mapping(), default=str)),
        "scenario": to_mapping(scenario),
        "parameters": experiment.parameters,
        "measures": measures,
        "runs": len(runs),
        "results": RESULTS,
        "backend": {"name": backend.name, "workers": backend.workers()},
        "versions": versions(
            ("pyautonomousagent", "numpy", "pyarrow", "py_trees", "dask", "distributed")
        ),
        "started_at": (previous or {}).get("started_at", _now()),
        "resumed_at": _now() if previous else None,
        "status": "running",
    }


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")
