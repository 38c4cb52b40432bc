"""Sensitivity analysis of a sweep drawn with a Sobol or Morris design (``pyaa analyse``;
docs/experiments.md says what each index means).

:func:`indices` gives a tidy table, one row per (measure, parameter, index): Sobol's ``S1``
and ``ST`` (no unit, 0 to 1) or Morris's ``mu_star``, ``sigma`` and ``mu`` (the measure's
unit per the parameter's whole range), each with ``confidence``, the half-width of its 95 %
bootstrap interval (drawn from the design's seed: the same sweep gives the same table). A
point run with several seeds counts by the mean of its successful runs; a measure with one
value everywhere, or none at some point, has no indices (NaN).
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from pyautonomousagent.experiments.design import (
    DESIGN_FILE,
    MORRIS_LEVELS,
    Design,
    library,
    unit_problem,
)
from pyautonomousagent.experiments.errors import ExperimentError, close_hint
from pyautonomousagent.experiments.plot import measure_label, pyplot, read_results, save
from pyautonomousagent.inputs import InputError, read_parquet

#: The indices of each method, in the table's order.
INDICES = {"sobol": ("S1", "ST"), "morris": ("mu_star", "sigma", "mu")}
#: Bootstrap resamples of the confidence intervals (SALib's default).
RESAMPLES = 100
#: Confidence level of the intervals.
CONFIDENCE = 0.95


@dataclass(frozen=True)
class StoredSweep:
    """What :func:`read_sweep` reads from a sweep folder.

    Attributes:
        results: one row per run.
        measures: the manifest's measures, name -> {"doc", "unit", ...}.
        design: the sweep's design.
        unit: its points in the unit cube, shape (points, parameters).
        seeds: runs per point.
    """

    results: pa.Table
    measures: dict[str, Any]
    design: Design
    unit: np.ndarray
    seeds: int


def read_sweep(folder: str | Path) -> StoredSweep:
    """The results, measures, design and seeds of the sweep in ``folder``.

    Raises:
        ExperimentError: no sweep there, no design file, or a damaged file.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ExperimentError(f"{folder}: no such sweep folder; give a folder pyaa sweep wrote")
    results, manifest = read_results(folder)
    method = manifest.get("experiment", {}).get("design", "grid")
    if method not in INDICES:
        raise ExperimentError(
            f"{folder}: the sweep's design is {method}; sensitivity indices need a sweep run "
            "with --design sobol or --design morris (plot it with pyaa plot)"
        )
    design, unit = _read_design(folder / DESIGN_FILE)
    seeds = manifest.get("experiment", {}).get("seeds")
    if not isinstance(seeds, list) or not seeds:
        raise ExperimentError(f"{folder}: the manifest names no seeds; run the sweep again")
    return StoredSweep(results, manifest.get("measures", {}), design, unit, len(seeds))


def _read_design(path: Path) -> tuple[Design, np.ndarray]:
    """The design and its unit-cube points from a sweep's ``design.parquet``."""
    if not path.is_file():
        raise ExperimentError(f"{path}: no design file; run the sweep again with this version")
    try:
        table = read_parquet(path, "design", ("point",))
        about = json.loads((table.schema.metadata or {})[b"pyaa.design"])
        method, samples, seed = about["method"], int(about["samples"]), int(about["seed"])
        bounds = {k: (float(lo), float(hi)) for k, (lo, hi) in about["bounds"].items()}
        design = Design(method, samples, seed, bounds, frozenset(about["integers"]))
        unit = np.column_stack([table[name].to_numpy() for name in design.names])
    except (InputError, KeyError, ValueError, TypeError, pa.ArrowException) as error:
        raise ExperimentError(f"{path}: not a design pyaa sweep wrote ({error})") from None
    if unit.shape != (design.size(), len(design.names)):
        raise ExperimentError(f"{path}: {unit.shape[0]} points, the design has {design.size()}")
    return design, unit


def check_measures(results: pa.Table, measures: list[str], known: list[str]) -> None:
    """Every name in ``measures`` must be one of the sweep's measures ``known``."""
    for name in measures:
        if name not in known or name not in results.column_names:
            raise ExperimentError(
                f"unknown measure {name!r}{close_hint(name, known)}; the sweep measured "
                f"{', '.join(known)}"
            )


def point_means(results: pa.Table, measure: str, points: int, seeds: int) -> np.ndarray:
    """The mean of ``measure`` over each point's successful runs (point = run // seeds),
    shape (points,); NaN at a point without a successful run with a value."""
    runs = results["run"].to_numpy()
    values = results[measure].to_numpy(zero_copy_only=False).astype(np.float64)
    ok = np.asarray([s == "ok" for s in results["status"].to_pylist()], dtype=bool)
    ok &= np.isfinite(values) & (runs < points * seeds)
    point = runs[ok] // seeds
    counts = np.bincount(point, minlength=points)
    sums = np.bincount(point, weights=values[ok], minlength=points)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def indices(
    results: pa.Table, design: Design, unit: np.ndarray, measures: list[str], seeds: int = 1
) -> pa.Table:
    """The sensitivity indices of each measure (see the module docstring): a table with
    the columns measure, parameter, index, value and confidence."""
    rows: list[dict[str, Any]] = []
    for measure in measures:
        y = point_means(results, measure, design.size(), seeds)
        found = _analyse(design, unit, y)
        for j, name in enumerate(design.names):
            for index in INDICES[design.method]:
                value, half = found[index][j]
                rows.append(
                    {"measure": measure, "parameter": name, "index": index,
                     "value": value, "confidence": half}
                )  # fmt: skip
    schema = pa.schema(
        [("measure", pa.string()), ("parameter", pa.string()), ("index", pa.string()),
         ("value", pa.float64()), ("confidence", pa.float64())]
    )  # fmt: skip
    return pa.Table.from_pylist(rows, schema=schema)


def _analyse(design: Design, unit: np.ndarray, y: np.ndarray) -> dict[str, list[tuple]]:
    """index -> [(value, 95 % half-width), one per parameter] for the point means ``y``."""
    names = INDICES[design.method]
    d = len(design.names)
    if not np.isfinite(y).all() or np.ptp(y) == 0:  # a point without a value, or no variance
        return {index: [(math.nan, math.nan)] * d for index in names}
    problem = unit_problem(design.names)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if design.method == "sobol":
            sobol = library("SALib.analyze.sobol", "sobol")
            found = sobol.analyze(
                problem, y, calc_second_order=False, num_resamples=RESAMPLES,
                conf_level=CONFIDENCE, seed=np.random.default_rng(design.seed),
            )  # fmt: skip  # a Generator: SALib leaves a seed of 0 unused
        else:
            morris = library("SALib.analyze.morris", "morris")
            found = morris.analyze(
                problem, unit, y, num_resamples=RESAMPLES, conf_level=CONFIDENCE,
                num_levels=MORRIS_LEVELS, seed=design.seed,
            )  # fmt: skip
    out: dict[str, list[tuple]] = {}
    for index in names:  # SALib gives S1_conf, ST_conf and mu_star_conf, not sigma's or mu's
        values = np.asarray(found[index], dtype=np.float64)
        halves = np.asarray(found.get(f"{index}_conf", np.full(d, math.nan)), dtype=np.float64)
        out[index] = [(float(v), float(h)) for v, h in zip(values, halves, strict=True)]
    return out


def report(table: pa.Table, stored: StoredSweep) -> list[str]:
    """The indices of ``table`` as printed lines, a block per measure."""
    design = stored.design
    lines: list[str] = []
    points = f"{design.size()} points x {stored.seeds} seed{'s' * (stored.seeds > 1)}"
    for measure in dict.fromkeys(table["measure"].to_pylist()):
        rows = [r for r in table.to_pylist() if r["measure"] == measure]
        unit = stored.measures.get(measure, {}).get("unit", "")
        shown = measure_label(measure, stored.measures)
        if all(math.isnan(r["value"]) for r in rows):
            lines.append(f"{shown}: {_why_none(stored, measure)}: no indices")
            continue
        if design.method == "sobol":
            lines.append(f"{shown}: Sobol indices, {points}, 95 % confidence intervals")
            lines.append(f"  {'parameter':24s} {'S1 (first order)':>20s} {'ST (total)':>20s}")
        else:
            per = f"{unit or measure} per whole range"
            lines.append(f"{shown}: Morris elementary effects ({per}), {points}")
            lines.append(f"  {'parameter':24s} {'mu* (95 % CI)':>22s} {'sigma':>10s} {'mu':>10s}")
        for name in design.names:
            found = {r["index"]: r for r in rows if r["parameter"] == name}
            if design.method == "sobol":
                cells = [
                    f"{found[i]['value']:.3f} ± {found[i]['confidence']:.3f}" for i in ("S1", "ST")
                ]
                lines.append(f"  {name:24s} {cells[0]:>20s} {cells[1]:>20s}")
            else:
                star, sigma, mu = (found[i]["value"] for i in ("mu_star", "sigma", "mu"))
                text = f"{star:.4g} ± {found['mu_star']['confidence']:.2g}"
                lines.append(f"  {name:24s} {text:>22s} {sigma:10.4g} {mu:10.4g}")
    return lines


def _why_none(stored: StoredSweep, measure: str) -> str:
    """Why ``measure`` has no indices: points without a value, or one value everywhere."""
    y = point_means(stored.results, measure, stored.design.size(), stored.seeds)
    missing = int(np.isnan(y).sum())
    if missing:
        return (
            f"no value at {missing} of {len(y)} points (runs failed or not done: --resume; "
            "or the measure is NaN there)"
        )
    return f"the same value at every point ({y[0]:.6g})"


def plot_indices(table: pa.Table, stored: StoredSweep, out: str | Path) -> Path:
    """Draw the indices: a panel per measure, bars with 95 % intervals (Sobol: S1 and ST
    per parameter; Morris: mu* per parameter, sigma as a second bar). PNG or SVG by
    ``out``'s suffix; returns the path."""
    measures = list(dict.fromkeys(table["measure"].to_pylist()))
    columns = 1 if len(measures) == 1 else 2
    lines = math.ceil(len(measures) / columns)
    fig, axes = pyplot().subplots(
        lines, columns, figsize=(6.4 * columns, 0.6 + 2.6 * lines), dpi=120, squeeze=False
    )
    for ax, measure in zip(axes.flat, measures, strict=False):
        _panel(ax, table, stored, measure)
    for ax in list(axes.flat)[len(measures) :]:
        ax.set_visible(False)
    method = {"sobol": "Sobol indices", "morris": "Morris screening"}[stored.design.method]
    seeds = f"{stored.seeds} seed{'s' * (stored.seeds > 1)}"
    fig.suptitle(f"{method}: {stored.design.size()} points x {seeds}, 95 % intervals", fontsize=10)
    return save(fig, Path(out))


def _panel(ax: Any, table: pa.Table, stored: StoredSweep, measure: str) -> None:
    """One measure's bars: per parameter, the method's two main indices side by side."""
    rows = [r for r in table.to_pylist() if r["measure"] == measure]
    names = stored.design.names
    unit = stored.measures.get(measure, {}).get("unit", "")
    ax.set_title(measure_label(measure, stored.measures), fontsize=9)
    if all(math.isnan(r["value"]) for r in rows):
        ax.text(0.5, 0.5, "no indices", ha="center", transform=ax.transAxes)
        ax.set(xticks=[], yticks=[])
        return
    labels = {"S1": "first order S1", "ST": "total ST", "mu_star": "mu*", "sigma": "sigma"}
    where = np.arange(len(names))
    for k, index in enumerate(INDICES[stored.design.method][:2]):
        found = {r["parameter"]: r for r in rows if r["index"] == index}
        values = [found[n]["value"] for n in names]
        halves = [found[n]["confidence"] for n in names]
        errors = None if all(math.isnan(h) for h in halves) else halves
        ax.barh(where + (k - 0.5) * 0.38, values, height=0.38, xerr=errors, capsize=3,
                label=labels[index])  # fmt: skip
    ax.set_yticks(where, names, fontsize=8)
    ax.invert_yaxis()
    ax.axvline(0, color="black", linewidth=0.6)
    per = f"{unit or measure} per whole range"
    ax.set_xlabel("share of the variance" if stored.design.method == "sobol" else per, fontsize=8)
    ax.grid(True, axis="x", alpha=0.3)
    ax.legend(fontsize=7)
