"""Plots of a sweep: a measure against a parameter, mean and interval over the seeds.

:func:`summarize` groups the results of a sweep by a parameter (and optionally a second one)
and gives, per group, the number of runs, the mean of the measure and an interval;
:func:`plot_measure` draws it: one line per value of the second parameter, the interval as a
band, written as PNG or SVG. Failed runs, and runs where the measure is NaN, are left out
(the count ``n`` says how many remained).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from pyautonomousagent.experiments.errors import ExperimentError, close_hint
from pyautonomousagent.experiments.series import TIMESERIES
from pyautonomousagent.experiments.store import MANIFEST, RESULTS, read_manifest
from pyautonomousagent.inputs import InputError, read_parquet

#: A plot's ``echo``: called with its summarised rows and the parameter of its lines.
Echo = Callable[[list[dict[str, Any]], str | None], None]
#: Intervals :func:`summarize` knows: Student-t 95 % confidence interval of the mean, one
#: standard deviation either side, the smallest to the largest value, or none.
INTERVALS = ("ci95", "sd", "range", "none")
#: Two-sided 95 % quantiles of Student's t distribution by degrees of freedom (published
#: tables); between entries the next smaller one is used (a slightly wider interval).
_T95 = dict(zip((*range(1, 21), 25, 30, 40, 60, 120), (
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
    2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
    2.060, 2.042, 2.021, 2.000, 1.980), strict=True))  # fmt: skip


def t95(df: int) -> float:
    """The 95 % two-sided Student-t quantile for ``df`` degrees of freedom (1.96 beyond 120)."""
    if df > 120:
        return 1.960
    return _T95[max(k for k in _T95 if k <= df)]


def read_results(source: str | Path | pa.Table) -> tuple[pa.Table, dict[str, Any]]:
    """The results table of a sweep folder, a results file, or a table; and the manifest
    (empty if there is none), its ``measures`` checked to map names to descriptions."""
    if isinstance(source, pa.Table):
        return source, {}
    path = Path(source)
    folder = path if path.is_dir() else path.parent
    file = path / RESULTS if path.is_dir() else path
    if not file.exists():
        raise ExperimentError(f"no sweep results at {file}; run pyaa sweep first")
    try:
        table = read_parquet(file, "sweep results", ("status",))
        manifest = read_manifest(folder) or {}
    except InputError as error:
        raise ExperimentError(str(error)) from None
    measures = manifest.get("measures", {})
    if not isinstance(measures, dict) or not all(isinstance(m, dict) for m in measures.values()):
        raise ExperimentError(f"{folder / MANIFEST}: 'measures' must map names to descriptions")
    return table, manifest


def _column(table: pa.Table, name: str, what: str) -> list[Any]:
    if name not in table.column_names:
        raise ExperimentError(
            f"unknown {what} {name!r}{close_hint(name, table.column_names)}; the results have "
            f"{', '.join(table.column_names)}"
        )
    if pa.types.is_nested(table.schema.field(name).type):
        raise ExperimentError(f"{what} {name!r} is a column of lists or records, not values")
    return table[name].to_pylist()


def _numbers(table: pa.Table, name: str) -> list[Any]:
    """The measure column ``name``; ExperimentError unless it holds numbers (or true/false)."""
    values = _column(table, name, "measure")
    kind = table.schema.field(name).type
    number = (pa.types.is_integer, pa.types.is_floating)
    if not any(is_kind(kind) for is_kind in (*number, pa.types.is_boolean, pa.types.is_null)):
        numeric = [f.name for f in table.schema if any(is_kind(f.type) for is_kind in number)]
        raise ExperimentError(
            f"measure {name!r} is a column of {kind}, not numbers: {name!r} is not a measure; "
            f"plot one of {', '.join(numeric) or 'no column'}"
        )
    return values


def summarize(
    table: pa.Table, measure: str, x: str, by: str | None = None, interval: str = "ci95"
) -> list[dict[str, Any]]:
    """Per (``by``, ``x``) group of the runs that succeeded: ``n``, ``mean``, ``low``, ``high``.

    Raises:
        ExperimentError: an unknown column or interval, a measure that is not a number
            column, or no successful run.
    """
    if interval not in INTERVALS:
        raise ExperimentError(f"unknown interval {interval!r}; choose from {', '.join(INTERVALS)}")
    values = _numbers(table, measure)
    xs = _column(table, x, "parameter")
    groups = _column(table, by, "parameter") if by else [None] * len(xs)
    status = _column(table, "status", "column")
    cells: dict[tuple[Any, Any], list[float]] = {}
    for value, xv, group, state in zip(values, xs, groups, status, strict=True):
        if state == "ok" and value is not None and not math.isnan(value):
            cells.setdefault((group, xv), []).append(float(value))
    if not cells:
        raise ExperimentError(f"no successful run has a value of {measure!r} to plot")
    rows = []
    for (group, xv), found in sorted(cells.items(), key=lambda c: (_rank(c[0][0]), _rank(c[0][1]))):
        data = np.asarray(found)
        mean, (low, high) = float(data.mean()), _interval(data, interval)
        rows.append({"by": group, "x": xv, "n": data.size, "mean": mean, "low": low, "high": high})
    return rows


def _rank(value: Any) -> tuple[str, Any]:
    """Sort numbers as numbers, strings as strings, whatever their mix."""
    return ("0", value) if isinstance(value, int | float) else ("1", str(value))


def _interval(data: np.ndarray, interval: str) -> tuple[float, float]:
    mean = float(data.mean())
    if interval == "range":
        return float(data.min()), float(data.max())
    if interval == "none" or data.size < 2:
        return mean, mean
    sd = float(data.std(ddof=1))
    half = sd if interval == "sd" else t95(data.size - 1) * sd / math.sqrt(data.size)
    return mean - half, mean + half


def plot_measure(
    source: str | Path | pa.Table,
    measure: str,
    x: str,
    by: str | None = None,
    out: str | Path | None = None,
    interval: str = "ci95",
    title: str | None = None,
    echo: Echo = lambda rows, by: None,
) -> Path:
    """Draw ``measure`` against the parameter ``x`` (mean and interval over seeds), one line
    per value of ``by``; write it as PNG or SVG (by ``out``'s suffix) and return the path.

    Args:
        source: a sweep folder, its ``results.parquet``, or a results table.
        measure: the measure (a column of the results).
        x: the parameter on the horizontal axis.
        by: a second parameter: one line per value.
        out: the picture (default: ``MEASURE-vs-X.png`` in the sweep folder, or here).
        interval: "ci95" (default), "sd", "range" or "none".
        title: the title (default: says what is drawn).
        echo: called with the summarised rows (:func:`summarize`) and ``by`` before drawing.
    """
    table, manifest = read_results(source)
    rows = summarize(table, measure, x, by, interval)
    echo(rows, by)
    folder = Path(source) if isinstance(source, str | Path) else Path(".")
    folder = folder if folder.is_dir() else folder.parent
    out = Path(out) if out is not None else folder / f"{measure}-vs-{x}.png"
    fig, ax = _figure(out)
    numeric = all(isinstance(r["x"], int | float) and not isinstance(r["x"], bool) for r in rows)
    labels = sorted({r["x"] for r in rows}, key=_rank)
    groups = sorted({r["by"] for r in rows}, key=_rank)
    for k, group in enumerate(groups):
        line = [r for r in rows if r["by"] == group]
        label = f"{by} = {group}" if by else None
        if numeric:  # a line, the interval as a band
            _line(ax, [r["x"] for r in line], line, label, interval != "none", marker="o")
            continue
        # categories: points with error bars, groups side by side
        shift = (k - (len(groups) - 1) / 2) * 0.08
        means = [r["mean"] for r in line]
        spread = [[r["mean"] - r["low"] for r in line], [r["high"] - r["mean"] for r in line]]
        px = [labels.index(r["x"]) + shift for r in line]
        ax.errorbar(px, means, yerr=spread, fmt="o", capsize=4, label=label)
    if not numeric:
        names = [str(v).rsplit("/", 1)[-1] for v in labels]  # a file: its name
        ax.set_xticks(range(len(labels)), names)
        ax.set_xlim(-0.5, len(labels) - 0.5)
    band = {"ci95": ", 95 % CI", "sd": ", ± 1 sd", "range": ", min to max", "none": ""}
    default = f"{measure} vs {x} (mean of {_runs(rows)} runs{band[interval]})"
    ylabel = measure_label(measure, manifest.get("measures", {}))
    return _saved(fig, ax, out, by, x, ylabel, title or default)


def read_series(folder: str | Path) -> tuple[pa.Table, pa.Table, dict[str, Any], list[str]]:
    """A sweep folder's time series, results, measure descriptions and varied parameters.

    Raises:
        ExperimentError: no sweep results, or no time series (the sweep ran without
            ``--every``), or a file that cannot be read.
    """
    path = Path(folder)
    path = path if path.is_dir() else path.parent
    results, manifest = read_results(path)
    file = path / TIMESERIES
    if not file.exists():
        raise ExperimentError(
            f"no time series in {path} (no {TIMESERIES}); run the sweep with --every K"
        )
    try:
        series = read_parquet(file, "sweep time series", ("run_id", "iteration", "value"))
    except InputError as error:
        raise ExperimentError(str(error)) from None
    varied = manifest.get("parameters", [])
    return series, results, manifest.get("measures", {}), [str(v) for v in varied or []]


def summarize_over_time(
    series: pa.Table, results: pa.Table, measure: str, by: str | None
) -> list[dict[str, Any]]:
    """Per (``by`` value, iteration): ``n`` runs, the ``mean`` of ``measure`` and its
    Student-t 95 % confidence interval ``low``, ``high`` over the runs that succeeded
    (NaN values left out).

    Raises:
        ExperimentError: ``measure`` is not in the time series, or ``by`` not a column of
            the results, or no run has a value.
    """
    names = sorted(set(series["measure"].to_pylist()))
    if measure not in names:
        raise ExperimentError(
            f"unknown measure {measure!r} in the time series{close_hint(measure, names)}; it "
            f"has {', '.join(names)}"
        )
    if by is not None:
        _column(results, by, "parameter")
    kept = series.filter(pc.equal(series["measure"], measure))
    kept = kept.filter(pc.invert(pc.is_nan(kept["value"])))
    ok = results.filter(pc.equal(results["status"], "ok"))
    labels = ok.select(["run_id", by]) if by else ok.select(["run_id"])
    joined = kept.join(labels, "run_id", join_type="inner")
    if joined.num_rows == 0:
        raise ExperimentError(f"no successful run has a value of {measure!r} over time")
    keys = [by, "iteration"] if by else ["iteration"]
    grouped = joined.group_by(keys).aggregate(
        [("value", "mean"), ("value", "stddev", pc.VarianceOptions(ddof=1)), ("value", "count")]
    )
    rows = []
    for row in grouped.to_pylist():
        n, mean, sd = row["value_count"], row["value_mean"], row["value_stddev"]
        half = t95(n - 1) * sd / math.sqrt(n) if n > 1 and sd is not None else 0.0
        rows.append(
            {"by": row.get(by) if by else None, "iteration": row["iteration"], "n": n,
             "mean": mean, "low": mean - half, "high": mean + half}
        )  # fmt: skip
    return sorted(rows, key=lambda r: (_rank(r["by"]), r["iteration"]))


def lines_parameter(varied: list[str], by: str | None) -> str | None:
    """The parameter whose values are the lines of a plot over time: ``by``, or else the
    only varied parameter (None where nothing varies).

    Raises:
        ExperimentError: several parameters vary and ``by`` names none of them.
    """
    if by is not None or len(varied) <= 1:
        return by or (varied[0] if varied else None)
    raise ExperimentError(
        f"the sweep varies {', '.join(varied)}: name the one whose values are the lines with --by"
    )


def plot_over_time(
    source: str | Path,
    measure: str,
    by: str | None = None,
    out: str | Path | None = None,
    title: str | None = None,
    echo: Echo = lambda rows, by: None,
) -> Path:
    """Draw ``measure`` over the iterations (mean over the runs and its 95 % confidence
    band), one line per value of the parameter ``by`` (default: the only varied one),
    from the sweep's ``timeseries.parquet``; write PNG or SVG and return the path.

    Args:
        source: a sweep folder run with ``--every K``.
        measure: a measure of the time series.
        by: the parameter whose values are the lines.
        out: the picture (default: ``MEASURE-over-time.png`` in the sweep folder).
        title: the title (default: says what is drawn).
        echo: called with the rows (:func:`summarize_over_time`) and ``by`` before drawing.
    """
    series, results, descriptions, varied = read_series(source)
    by = lines_parameter(varied, by)
    rows = summarize_over_time(series, results, measure, by)
    echo(rows, by)
    folder = Path(source) if Path(source).is_dir() else Path(source).parent
    out = Path(out) if out is not None else folder / f"{measure}-over-time.png"
    fig, ax = _figure(out)
    for group in sorted({r["by"] for r in rows}, key=_rank):
        line = [r for r in rows if r["by"] == group]
        _line(ax, [r["iteration"] for r in line], line, f"{by} = {group}" if by else None)
    default = f"{measure} over time (mean of {_runs(rows)} runs, 95 % CI)"
    ylabel = measure_label(measure, descriptions)
    return _saved(fig, ax, out, by, "iteration", ylabel, title or default)


def measure_label(measure: str, descriptions: dict[str, Any]) -> str:
    """``measure (unit)`` by the manifest's ``descriptions``, or ``measure`` (no unit, or a
    unit of the measure's own name)."""
    unit = descriptions.get(measure, {}).get("unit", "")
    return f"{measure} ({unit})" if unit and unit != measure else measure


def pyplot() -> Any:
    """matplotlib's pyplot, drawing off screen (Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _figure(out: Path) -> tuple[Any, Any]:
    """The figure and axes of a plot to be written to ``out`` (a .png or .svg name)."""
    if out.suffix.lower() not in (".png", ".svg"):
        raise ExperimentError(f"plot file {out}: use a .png or .svg name")
    return pyplot().subplots(figsize=(6.4, 4.2), dpi=120)


def _line(ax: Any, px: list[Any], rows: list[dict[str, Any]], label: Any, band: bool = True,
          marker: str | None = None) -> None:  # fmt: skip
    """The rows' means at ``px``, their interval (``low`` to ``high``) as a band."""
    (drawn,) = ax.plot(px, [r["mean"] for r in rows], label=label, marker=marker)
    if band:
        low, high = [r["low"] for r in rows], [r["high"] for r in rows]
        ax.fill_between(px, low, high, color=drawn.get_color(), alpha=0.2, linewidth=0)


def _runs(rows: list[dict[str, Any]]) -> str:
    """The runs per point of ``rows``: ``N``, or ``LOW-HIGH`` where they differ."""
    low, high = min(r["n"] for r in rows), max(r["n"] for r in rows)
    return f"{low}" if low == high else f"{low}-{high}"


def _saved(
    fig: Any, ax: Any, out: Path, by: str | None, xlabel: str, ylabel: str, title: str
) -> Path:
    """Label and finish a plot (grid; a legend where lines are ``by`` a parameter) and save
    it to ``out``; ``out``."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    if by:
        ax.legend(fontsize=8)
    return save(fig, out)


def save(fig: Any, out: Path) -> Path:
    """Lay out ``fig``, write it to ``out`` (its folder made) and close it; ``out``."""
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    pyplot().close(fig)
    return out
