"""One run of a sweep, as a worker executes it: simulate, measure, optionally save the data.

:func:`execute` is what every backend calls. It never raises for a failing run: the row it
returns then has ``status`` "failed" and the error's first line, so the sweep goes on. The
per-run data is written as ``runs/NAME=VALUE/.../seed=S/data.parquet`` (hive partitions)
through a temporary file and a rename, so a killed worker leaves no partial file.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import quote

import pyarrow as pa

from pyautonomousagent.experiments.measures import Measure, RunData
from pyautonomousagent.experiments.series import SERIES, run_series
from pyautonomousagent.experiments.store import atomic_write_table
from pyautonomousagent.simulation import Scenario, Simulation
from pyautonomousagent.simulation.scenario import parameter_list, to_mapping

if TYPE_CHECKING:
    from pyautonomousagent.bt.spec import Node
    from pyautonomousagent.experiments.spec import Run


@dataclass(frozen=True)
class RunTask:
    """Everything a worker needs for one run (picklable).

    Attributes:
        run: the point, seed and key of the run.
        scenario: the experiment's base scenario (fixed overrides applied).
        engine: the decision engine.
        record_every: recording decimation.
        measures: the measures to compute.
        runs_dir: folder of the per-run data, or None not to save it.
        tree: the scenario's tree, read once by the sweep (so workers need not read the
            tree file), or None to read it per run (when the tree itself is varied).
        every: keep each measure every this many iterations (the run's time series, see
            :mod:`pyautonomousagent.experiments.series`), or None for none.
    """

    run: Run
    scenario: Scenario
    engine: str
    record_every: int
    measures: tuple[Measure, ...]
    runs_dir: str | None = None
    tree: Node | None = None
    every: int | None = None


def execute(task: RunTask) -> dict[str, Any]:
    """Run ``task``: one result row (run, run_id, parameters, seed, measures, status, error,
    seconds, engine). Measures that raise give NaN and the run's status "failed". The run's
    log (e.g. one warning per drone that runs dry) is silenced: the measures count it. With
    ``task.every`` the row also holds the run's time series (a table) under
    :data:`~pyautonomousagent.experiments.series.SERIES`, if the run is ok."""
    run, row = task.run, blank_row(task)
    start = time.perf_counter()
    log = logging.getLogger("pyautonomousagent")
    was_disabled, log.disabled = log.disabled, True
    try:
        scenario = task.scenario.with_overrides(**run.point)
        sim = Simulation.create(
            scenario,
            seed=run.seed,
            engine=task.engine,
            record_every=task.record_every,
            tree=task.tree,
            trace=0,  # the active behaviour is kept; per-node traces are not needed
        )
        row["engine"] = sim.engine.name
        sim.run(progress=False)
        row["engine"] = sim.engine.name  # the engine that ran it
        data = RunData.from_simulation(sim)
        for measure in task.measures:
            row[measure.name] = measure(data)
        if task.every is not None:
            row[SERIES] = run_series(run.run_id, data, task.measures, task.every)
        if task.runs_dir is not None:
            write_run_data(sim, Path(task.runs_dir), run)
    except Exception as error:  # a failing run is recorded, and the sweep goes on
        row.update(status="failed", error=one_line(error))
        row.pop(SERIES, None)
    else:
        row.update(status="ok", error=None)
    finally:
        log.disabled = was_disabled
    row["seconds"] = time.perf_counter() - start
    return row


def blank_row(task: RunTask) -> dict[str, Any]:
    """``task``'s row before it runs: run, point, seed, parameters; NaN measures, no engine."""
    run = task.run
    row: dict[str, Any] = {"run": run.index, "run_id": run.run_id, **run.point, "seed": run.seed}
    row.update({m.name: math.nan for m in task.measures})
    row.update({k: v for k, v in scenario_parameters(task.scenario).items() if k not in row})
    row["engine"] = None
    return row


def scenario_parameters(scenario: Any) -> dict[str, Any]:
    """A scenario's parameters as result columns: ``agents``, ``iterations`` and every
    entry of its ``parameters`` (plain numbers, strings or booleans only)."""
    data = to_mapping(scenario)
    values = {"agents": data["agents"], "iterations": data["iterations"], **data["parameters"]}
    return {k: v for k, v in values.items() if isinstance(v, bool | int | float | str)}


def one_line(error: BaseException) -> str:
    """``Type: first line of the message`` (at most 300 characters)."""
    text = str(error).strip().splitlines()
    message = f"{type(error).__name__}: {text[0] if text else ''}".rstrip(": ")
    return message[:300]


def partition_dir(root: Path, run: Run) -> Path:
    """``root/NAME=VALUE/.../seed=S`` for the run's point (values URL-quoted)."""
    parts = (f"{name}={quote(str(value), safe='')}" for name, value in run.point.items())
    return root.joinpath(*parts, f"seed={run.seed}")


def write_run_data(sim: Any, root: Path, run: Run) -> None:
    """Write the run's recorded table as ``data.parquet`` in its partition folder."""
    folder = partition_dir(root, run)
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write_table(sim.table(), folder / "data.parquet")


#: The scenario fields a sweep may vary besides its parameters: type, unit, description.
_FIELD_COLUMNS: dict[str, tuple[type, str, str]] = {
    "agents": (int, "agents", "the number of agents in the run"),
    "iterations": (int, "iterations", "the run's length"),
    "tree": (str, "", "the behaviour tree the agents ran"),
}


def parameter_columns(scenario: Any) -> tuple[dict[str, Any], dict[str, tuple[str, str]]]:
    """Each parameter's column type by its declared type (float -> float64, int -> int64,
    bool, str -> string) and its (unit, description), for the results' schema: the
    scenario's fields that can vary and every declared parameter of its core, motion model
    and mission."""
    arrow = {bool: pa.bool_(), int: pa.int64(), float: pa.float64(), str: pa.string()}
    types = {name: arrow[kind] for name, (kind, _, _) in _FIELD_COLUMNS.items()}
    docs = {name: (unit, doc) for name, (_, unit, doc) in _FIELD_COLUMNS.items()}
    for _, param in parameter_list(scenario):
        if param.type in arrow:
            types[param.name] = arrow[param.type]
        docs[param.name] = (param.unit, param.doc)
    return types, docs
