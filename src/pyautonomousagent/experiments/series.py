"""Time series of a sweep: each measure every K iterations of every run (``every: K``).

Each worker computes, after its run, every measure of the run *as it stood* at iterations
0, K, 2K, ... and at its last iteration (:func:`prefix`). The rows travel with the run's
result row, are journaled with it (``journal/series-N.parquet`` beside the results' part N)
and are compacted into ``timeseries.parquet``: run_id, iteration, measure, value, one row
per ok run, measure and checkpoint (docs/experiments.md, "Time series").
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from pyautonomousagent.experiments.store import described

if TYPE_CHECKING:
    from pyautonomousagent.experiments.measures import Measure, RunData

#: The time-series table of a sweep folder.
TIMESERIES = "timeseries.parquet"
#: Key of a result row that carries the run's time series from the worker (never journaled
#: with the row).
SERIES = "__series__"
#: Units and descriptions of the time series' own columns.
SERIES_DOCS: dict[str, tuple[str, str]] = {
    "run_id": ("", "the run's key (results.parquet's run_id)"),
    "iteration": ("iterations", "the checkpoint: the measure of the run up to this iteration"),
    "measure": ("", "the measure's name (a column of results.parquet)"),
    "value": ("", "the measure's value at the checkpoint; its unit is in experiment.json"),
}


def series_schema() -> pa.Schema:
    """The time series' columns, each with its unit and description as field metadata."""
    types = (pa.string(), pa.int64(), pa.string(), pa.float64())  # SERIES_DOCS' columns
    return described(
        [pa.field(name, kind) for name, kind in zip(SERIES_DOCS, types, strict=True)], SERIES_DOCS
    )


def checkpoints(iterations: np.ndarray, every: int) -> np.ndarray:
    """The recorded iterations that are multiples of ``every``, and the last one.

    Args:
        iterations: the recorded iterations, ascending, shape (records,).
        every: K, iterations between checkpoints (>= 1).

    Returns:
        The checkpoint iterations, ascending, without repeats, shape (checkpoints,).
    """
    if iterations.size == 0:
        return iterations.astype(np.int64)
    chosen = iterations[iterations % every == 0]
    return np.unique(np.append(chosen, iterations[-1])).astype(np.int64)


def prefix(run: RunData, iteration: int) -> RunData:
    """``run`` as it stood at ``iteration``: its records up to and including it (views) and
    the events raised by then."""
    keep = int(np.searchsorted(run.iterations, iteration, side="right"))
    return dataclasses.replace(
        run,
        iterations=run.iterations[:keep],
        columns={name: values[:keep] for name, values in run.columns.items()},
        events=[e for e in run.events if int(e.get("iteration", 0)) <= iteration],
        behaviour=None if run.behaviour is None else run.behaviour[:keep],
    )


def measure_at(measure: Measure, run: RunData) -> float:
    """The measure of ``run`` (a prefix); NaN where it raises (e.g. too few records yet)."""
    try:
        return measure(run)
    except Exception:  # a measure undefined this early is NaN at this checkpoint
        return math.nan


def run_series(run_id: str, data: RunData, measures: Sequence[Measure], every: int) -> pa.Table:
    """The time series of one run: every measure at every checkpoint (:func:`checkpoints`),
    rows ordered by measure, then iteration; ``measures x checkpoints`` rows."""
    points = checkpoints(np.asarray(data.iterations), every)
    cuts = [prefix(data, int(t)) for t in points]
    values = [measure_at(m, cut) for m in measures for cut in cuts]
    count = len(points)
    columns = {
        "run_id": pa.array([run_id] * (count * len(measures)), pa.string()),
        "iteration": pa.array(np.tile(points, len(measures)), pa.int64()),
        "measure": pa.array([m.name for m in measures for _ in range(count)], pa.string()),
        "value": pa.array(values, pa.float64()),
    }
    return pa.table(columns, schema=series_schema())


def read_parts(folder: Path) -> pa.Table:
    """Every time-series part of a journal folder, each row tagged with its part number
    (column ``part``), oldest first; parts that cannot be read are left out (their runs'
    results parts decide whether the runs ran)."""
    tables = []
    for path in sorted(folder.glob("series-*.parquet")):
        number = int(path.name.split("-")[1].split(".")[0])
        try:
            table = pq.read_table(path).select(series_schema().names).cast(series_schema())
        except (pa.ArrowException, OSError, ValueError, KeyError):
            continue
        tables.append(table.append_column("part", pa.array([number] * table.num_rows, pa.int64())))
    if not tables:
        return series_schema().empty_table().append_column("part", pa.array([], pa.int64()))
    return pa.concat_tables(tables)


def compact(folder: Path, results: pa.Table) -> pa.Table:
    """The time series of the runs ``results`` says are "ok": each run's rows from its
    latest part (a run done again replaces its earlier rows), ordered as the results'
    runs, then by measure as the run gave them, then iteration."""
    parts = read_parts(folder)
    ok = results.filter(pc.equal(results["status"], "ok"))
    order = {run_id: i for i, run_id in enumerate(ok["run_id"].to_pylist())}
    rows = list(zip(parts["run_id"].to_pylist(), parts["part"].to_pylist(), strict=True))
    latest = dict(rows)  # the parts oldest first: a run's last row is in its latest part
    keep = [i for i, (run, part) in enumerate(rows) if run in order and latest[run] == part]
    keep.sort(key=lambda i: order[rows[i][0]])  # stable: a run's rows keep their order
    return parts.take(pa.array(keep, pa.int64())).select(series_schema().names)


def documented(table: pa.Table, units: Mapping[str, Any]) -> pa.Table:
    """``table`` with the measures' units (``units``: name -> {"unit", "doc"}, the
    manifest's ``measures``) in the schema's metadata under ``b"measures"``."""
    metadata = dict(table.schema.metadata or {})
    metadata[b"measures"] = json.dumps(dict(units)).encode()
    return table.replace_schema_metadata(metadata)
