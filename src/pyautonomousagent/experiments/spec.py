"""An experiment: a scenario, the parameters to vary, the seeds and the measures.

Written as YAML (docs/experiments.md, "The experiment", shows every key), or given on the
command line, which adds to the same mapping (:func:`with_options`). ``vary`` is a grid
(lists or ``{from, to, step}`` ranges, both ends included) crossed with the random points
of ``sample``, or the bounds ``{from, to}`` of a sampled ``design`` (lhs, sobol or morris:
:mod:`~pyautonomousagent.experiments.design`). :meth:`Experiment.from_mapping` validates it;
every error is an :class:`ExperimentError` naming the source, the field and what it must be.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent.experiments.design import DESIGNS, Design, schema_types, typed
from pyautonomousagent.experiments.errors import ExperimentError, close_hint
from pyautonomousagent.experiments.expression import ExpressionError
from pyautonomousagent.experiments.measures import MEASURES, Measure, expression_measure
from pyautonomousagent.inputs import InputError, load_yaml, plain_value, read_text
from pyautonomousagent.registry import UnknownNameError

if TYPE_CHECKING:
    from pyautonomousagent.simulation import Scenario

#: The most runs one experiment may hold.
MAX_RUNS = 1_000_000
#: Largest whole number a sweep takes (seeds and counts are int64 columns of the results).
INT64_MAX = 2**63 - 1
#: Columns of the results that parameters and measures may not be called.
RESERVED = ("run", "run_id", "seed", "status", "error", "seconds", "worker", "engine")
_KEYS = (
    "name",
    "scenario",
    "iterations",
    "set",
    "vary",
    "sample",
    "seeds",
    "measures",
    "engine",
    "record_every",
    "design",
    "samples",
    "design_seed",
    "every",
)
_DISTRIBUTIONS = ("uniform", "integers", "choice")


@dataclass(frozen=True)
class Run:
    """One run of an experiment: a point of the parameter space and a seed.

    Attributes:
        index: position in the experiment's run list (0-based).
        point: the varied parameters' values, name -> value.
        seed: the run's seed.
        run_id: a stable key of (point, seed), the same in every sweep of the experiment.
    """

    index: int
    point: dict[str, Any]
    seed: int
    run_id: str


@dataclass(frozen=True)
class Experiment:
    """A validated experiment (docs/experiments.md has the file format).

    Attributes:
        scenario: a registered scenario name or a scenario file path.
        vary: the grid, parameter -> values.
        sample: random points: ``{"count", "seed", "parameters": {name: (kind, args)}}``,
            or None.
        seeds: the seeds run at every point.
        measures: what is computed per run.
        fixed: overrides applied to every run (the file's ``set``).
        iterations: the runs' length, or None for the scenario's.
        engine: the decision engine.
        record_every: recording decimation of every run.
        name: the experiment's name.
        design: a sampled design over bounded parameters (then ``vary`` is empty), or None
            for the grid.
        every: iterations between the time series' checkpoints (``timeseries.parquet``),
            or None for no time series.
    """

    scenario: str
    vary: dict[str, list[Any]]
    seeds: tuple[int, ...]
    measures: tuple[Measure, ...]
    sample: dict[str, Any] | None = None
    fixed: dict[str, Any] = field(default_factory=dict)
    iterations: int | None = None
    engine: str = "auto"
    record_every: int = 1
    name: str = "experiment"
    design: Design | None = None
    every: int | None = None

    @classmethod
    def from_mapping(cls, data: Any, source: str = "experiment") -> Experiment:
        """Validate a mapping (a parsed YAML file) into an experiment.

        Raises:
            ExperimentError: naming ``source`` and the offending field.
        """
        return _Reader(source).experiment(data)

    @classmethod
    def from_file(cls, path: str | Path) -> Experiment:
        """Read and validate an experiment YAML file."""
        return cls.from_mapping(read_file(path), source=str(path))

    @property
    def parameters(self) -> list[str]:
        """The varied parameters, in column order (grid first, then sampled)."""
        if self.design is not None:
            return self.design.names
        sampled = list(self.sample["parameters"]) if self.sample else []
        return [*self.vary, *(p for p in sampled if p not in self.vary)]

    def points(self) -> list[dict[str, Any]]:
        """Every point: the grid crossed with the random samples (in that order), or the
        design's points (whole numbers where :func:`for_scenario` marked a parameter so)."""
        if self.design is not None:
            return self.design.points()
        product = itertools.product(*self.vary.values())
        grid = [dict(zip(self.vary, values, strict=True)) for values in product]
        if not self.sample:
            return grid
        samples = draw_samples(self.sample)
        return [{**g, **s} for g in grid for s in samples]

    def runs(self) -> list[Run]:
        """Every (point, seed) in order: points outer, seeds inner. A design's run keys
        hold the point's position too (two points of a design may coincide)."""
        out: list[Run] = []
        for i, point in enumerate(self.points()):
            where = i if self.design is not None else None
            for seed in self.seeds:
                out.append(Run(len(out), point, seed, run_key(point, seed, where)))
        return out

    def to_mapping(self) -> dict[str, Any]:
        """The experiment as plain data (for the manifest; read back by :meth:`from_mapping`)."""
        expression = "expression: "
        measures = [
            {m.name: m.doc.removeprefix(expression)} if m.doc.startswith(expression) else m.name
            for m in self.measures
        ]
        data: dict[str, Any] = {
            "name": self.name,
            "scenario": self.scenario,
            "iterations": self.iterations,
            "set": dict(self.fixed),
            "vary": {k: list(v) for k, v in self.vary.items()},
            "seeds": list(self.seeds),
            "measures": measures,
            "engine": self.engine,
            "record_every": self.record_every,
        }
        if self.every is not None:  # absent otherwise: earlier sweeps resume unchanged
            data["every"] = self.every
        if self.sample:
            params = {
                k: {kind: list(args)} for k, (kind, args) in self.sample["parameters"].items()
            }
            data["sample"] = {**self.sample, "parameters": params}
        design = self.design
        if design is not None:
            data["vary"] = {k: {"from": lo, "to": hi} for k, (lo, hi) in design.bounds.items()}
            data.update(design=design.method, samples=design.samples, design_seed=design.seed)
        return data


def read_file(path: str | Path) -> Any:
    """The YAML document of the experiment file at ``path``, not yet validated.

    Raises:
        ExperimentError: the file cannot be read, is too large, not UTF-8 or not valid YAML
            (a key given twice, a ``!!python`` tag, ...), naming the file and line.
    """
    try:
        return load_yaml(read_text(path, "experiment file"), str(path))
    except InputError as error:
        raise ExperimentError(str(error)) from None


def with_options(
    data: Mapping[str, Any], source: str, vary: Sequence[str], fixed: Mapping[str, Any]
) -> dict[str, Any]:
    """``data`` (an experiment mapping) with the command line's ``--vary`` options and
    ``--set`` values added; an option replaces the file's entry of the same name. With a
    sampled ``design`` in ``data``, ``--vary NAME=LOW:HIGH`` gives bounds.

    Raises:
        ExperimentError: the file's ``vary`` or ``set`` is not a mapping, or ``--vary``
            names a parameter twice.
    """
    reader = _Reader(source)
    out = dict(data)
    bounds = out.get("design", "grid") != "grid"
    for key, added in (("vary", parse_vary(vary, bounds)), ("set", dict(fixed))):
        given = reader.mapping(out.get(key) or {}, key)
        out[key] = {**given, **added}
    return out


def run_key(point: Mapping[str, Any], seed: int, index: int | None = None) -> str:
    """A stable 16-hex-digit key of a run: the same point and seed (and the point's
    ``index`` in a design, when given) give the same key."""
    key: dict[str, Any] = {"point": dict(point), "seed": seed}
    if index is not None:
        key["design_point"] = index
    text = json.dumps(key, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def draw_samples(sample: Mapping[str, Any]) -> list[dict[str, Any]]:
    """``count`` random points drawn from the sample's own seed (same seed, same points)."""
    rng = np.random.default_rng(sample["seed"])
    points: list[dict[str, Any]] = [{} for _ in range(sample["count"])]
    for name, (kind, args) in sample["parameters"].items():
        n = sample["count"]
        if kind == "uniform":
            values: list[Any] = [float(v) for v in rng.uniform(args[0], args[1], n)]
        elif kind == "integers":
            values = [int(v) for v in rng.integers(args[0], args[1], n, endpoint=True)]
        else:
            values = [args[int(i)] for i in rng.integers(0, len(args), n)]
        for point, value in zip(points, values, strict=True):
            point[name] = value
    return points


def inclusive_range(start: float, stop: float, step: float) -> list[Any]:
    """``start, start + step, ...`` up to and including ``stop`` (whole numbers stay whole)."""
    count = math.floor((stop - start) / step + 1e-9) + 1
    values = [round(start + i * step, 12) for i in range(count)]
    whole = all(isinstance(v, int) for v in (start, stop, step))
    return [int(v) for v in values] if whole else values


class _Reader:
    """Checks one field at a time, naming it in every error."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, text: str) -> ExperimentError:
        return ExperimentError(f"{self.source}: {text}")

    def fail(self, path: str, must: str, value: Any) -> ExperimentError:
        shown = repr(value)
        shown = shown if len(shown) <= 80 else shown[:77] + "..."
        return self.error(f"{path} must be {must}, got {shown}")

    def experiment(self, data: Any) -> Experiment:
        if not isinstance(data, Mapping):
            raise self.fail("the file", "a mapping of keys to values", data)
        for key in data:
            if key not in _KEYS:
                raise self.error(f"unknown key {key!r}{close_hint(str(key), _KEYS)}")
        if "scenario" not in data:
            raise self.error("missing key 'scenario' (a scenario name)")
        fixed = self.mapping(data.get("set") or {}, "set")
        if "iterations" in fixed and data.get("iterations") is not None:
            raise self.error("iterations given twice, as 'iterations' and in 'set'; keep one")
        design = self.design(data)
        vary = self.vary(data.get("vary") or {}) if design is None else {}
        sample = self.sample(data["sample"]) if data.get("sample") is not None else None
        self.overlap(fixed, list(vary) if design is None else design.names)
        if not vary and not sample and design is None:
            raise self.error("nothing varies; give 'vary' (a grid) or 'sample' (random points)")
        experiment = Experiment(
            scenario=self.text(data["scenario"], "scenario"),
            vary=vary,
            sample=sample,
            seeds=self.seeds(data.get("seeds", 1)),
            measures=self.measures(data.get("measures")),
            fixed=fixed,
            iterations=self.whole(data["iterations"], "iterations", 1)
            if data.get("iterations") is not None
            else None,
            engine=self.engine(data.get("engine", "auto")),
            record_every=self.whole(data.get("record_every", 1), "record_every", 1),
            name=self.folder_name(data.get("name", "experiment"), "name"),
            design=design,
            every=self.every(data.get("every"), data.get("record_every", 1)),
        )
        self.columns(experiment)
        grid = design.size() if design is not None else math.prod(len(v) for v in vary.values())
        total = grid * (sample["count"] if sample else 1) * len(experiment.seeds)
        if total > MAX_RUNS:
            raise self.fail("the experiment", f"at most {MAX_RUNS} runs", f"{total} runs")
        return experiment

    def design(self, data: Mapping[str, Any]) -> Design | None:
        """The sampled design of ``data`` (``design``, ``samples``, ``design_seed`` and the
        bounds in ``vary``), or None for the grid."""
        method = data.get("design", "grid")
        if method not in DESIGNS:
            raise self.fail("design", f"one of {', '.join(DESIGNS)}", method)
        if method == "grid":
            for key in ("samples", "design_seed"):
                if data.get(key) is not None:
                    raise self.error(
                        f"{key} is for a sampled design (lhs, sobol or morris); a grid runs "
                        "every combination of vary"
                    )
            return None
        if data.get("sample") is not None:
            raise self.error(
                "sample (random points crossed with a grid) is for the grid design; design "
                f"{method} draws its own points: give the bounds in vary"
            )
        if data.get("samples") is None:
            raise self.error(
                f"design {method} needs samples, the number of samples N (e.g. --samples 64)"
            )
        samples = self.count(data["samples"], "samples")
        if method == "sobol" and samples & (samples - 1):  # not a power of two
            raise self.fail("samples", "a power of two for design sobol (e.g. 32, 64)", samples)
        grid = self.mapping(data.get("vary") or {}, "vary")
        if not grid:
            raise self.error(
                f"nothing varies; design {method} needs bounds in vary (e.g. --vary "
                "low_energy_threshold=30:45)"
            )
        bounds = {name: self.bounds(value, name, method) for name, value in grid.items()}
        seed = self.whole(data.get("design_seed", 0), "design_seed", 0)
        design = Design(method, samples, seed, bounds)
        if design.size() > MAX_RUNS:
            raise self.fail("samples", f"a number giving at most {MAX_RUNS} points", samples)
        return design

    def bounds(self, value: Any, name: str, method: str) -> tuple[float, float]:
        """A parameter's bounds ``{from: LOW, to: HIGH}`` with LOW < HIGH."""
        must = (
            f"bounds {{from: LOW, to: HIGH}} with LOW < HIGH for design {method} "
            f"(on the command line --vary {name}=LOW:HIGH)"
        )
        if not isinstance(value, Mapping) or set(value) != {"from", "to"}:
            raise self.fail(f"vary.{name}", must, value)
        low, high = (self.number(value[k], f"vary.{name}.{k}") for k in ("from", "to"))
        if not low < high:
            raise self.fail(f"vary.{name}", must, value)
        if not math.isfinite(high - low) or max(-low, high) > 2**62:
            raise self.fail(f"vary.{name}", "bounds within +-2**62", value)
        return low, high

    def every(self, value: Any, record_every: Any) -> int | None:
        """The time series' interval: None, or a whole number >= 1 that is a multiple of
        ``record_every`` (every checkpoint a recorded iteration)."""
        if value is None:
            return None
        every = self.whole(value, "every", 1)
        if every % record_every:  # record_every is checked by then
            raise self.fail("every", f"a multiple of record_every ({record_every})", value)
        return every

    def overlap(self, fixed: Mapping[str, Any], varied: Sequence[str]) -> None:
        """Refuse a parameter that is both fixed (``set``) and varied on the grid (a sampled
        parameter replaces its fixed value: ``set`` then gives the base scenario)."""
        both = [name for name in varied if name in fixed]
        if both:
            raise self.error(
                f"parameter {both[0]!r} is both fixed ('set') and varied; keep one of them"
            )

    def engine(self, value: Any) -> str:
        from pyautonomousagent.simulation.run import ENGINES  # the engines import numba

        known = ("auto", *ENGINES.names())
        if value not in known:
            raise self.fail("engine", f"one of {', '.join(known)}", value)
        return str(value)

    def text(self, value: Any, path: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.fail(path, "a non-empty string", value)
        return value

    def folder_name(self, value: Any, path: str) -> str:
        """A name that is one folder's name (it names the sweep's folder in runs/sweeps)."""
        text = self.text(value, path)
        if text in (".", "..") or any(c in text for c in "/\\\0") or len(text) > 200:
            raise self.fail(
                path, "a folder name (no / or \\, not . or .., at most 200 characters)", value
            )
        return text

    def whole(self, value: Any, path: str, minimum: int) -> int:
        """A whole number from ``minimum`` to int64's largest (results are int64 columns)."""
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.fail(path, f"a whole number >= {minimum}", value)
        if value > INT64_MAX:
            raise self.fail(path, f"a whole number <= {INT64_MAX} (int64)", value)
        return value

    def count(self, value: Any, path: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_RUNS:
            raise self.fail(path, f"a whole number from 1 to {MAX_RUNS}", value)
        return value

    def number(self, value: Any, path: str) -> float:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise self.fail(path, "a number", value)
        return value

    def mapping(self, value: Any, path: str) -> dict[str, Any]:
        if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
            raise self.fail(path, "a mapping of parameter names to values", value)
        return dict(value)

    def values(self, value: Any, path: str) -> list[Any]:
        if isinstance(value, Mapping):
            if set(value) != {"from", "to", "step"}:
                raise self.fail(path, "a list of values or {from: A, to: B, step: S}", value)
            start, stop, step = (
                self.number(value[k], f"{path}.{k}") for k in ("from", "to", "step")
            )
            if step <= 0 or stop < start:
                raise self.fail(path, "a range with step > 0 and to >= from", value)
            if (stop - start) / step >= MAX_RUNS:
                raise self.fail(path, f"a range of at most {MAX_RUNS} values", value)
            return inclusive_range(start, stop, step)
        if not isinstance(value, list) or not value:
            raise self.fail(path, "a non-empty list of values or {from: A, to: B, step: S}", value)
        for i, item in enumerate(value):
            if not isinstance(item, bool | int | float | str):
                raise self.fail(f"{path}[{i}]", "a number, a string or true/false", item)
            if isinstance(item, float) and not math.isfinite(item):
                raise self.fail(f"{path}[{i}]", "a finite number", item)
        if len({(isinstance(v, bool), isinstance(v, str)) for v in value}) > 1:  # kinds mixed
            raise self.fail(path, "values of one kind (numbers, strings or true/false)", value)
        if len({json.dumps(v) for v in value}) != len(value):
            raise self.fail(path, "a list without repeated values", value)
        return list(value)

    def vary(self, data: Any) -> dict[str, list[Any]]:
        grid = self.mapping(data, "vary")
        return {name: self.values(values, f"vary.{name}") for name, values in grid.items()}

    def sample(self, data: Any) -> dict[str, Any]:
        if not isinstance(data, Mapping) or set(data) != {"count", "seed", "parameters"}:
            raise self.fail("sample", "a mapping with count, seed and parameters", data)
        params = self.mapping(data["parameters"], "sample.parameters")
        if not params:
            raise self.fail("sample.parameters", "at least one parameter", params)
        out: dict[str, tuple[str, list[Any]]] = {}
        for name, spec in params.items():
            path = f"sample.parameters.{name}"
            kinds = list(spec) if isinstance(spec, Mapping) else []
            if len(kinds) != 1 or kinds[0] not in _DISTRIBUTIONS:
                raise self.fail(
                    path, "{uniform: [lo, hi]}, {integers: [lo, hi]} or {choice: [values]}", spec
                )
            kind, args = next(iter(spec.items()))
            if kind == "choice":
                out[name] = (kind, self.values(args, f"{path}.choice"))
                continue
            if not isinstance(args, list) or len(args) != 2:
                raise self.fail(f"{path}.{kind}", "a pair [lo, hi]", args)
            lo, hi = (self.number(a, f"{path}.{kind}") for a in args)
            if kind == "integers":
                lo, hi = (self.whole(a, f"{path}.{kind}", -(2**62)) for a in args)
            if hi < lo:
                raise self.fail(f"{path}.{kind}", "a pair [lo, hi] with lo <= hi", args)
            if not math.isfinite(hi - lo) or max(abs(lo), abs(hi)) > 2**62:
                raise self.fail(f"{path}.{kind}", "a pair [lo, hi] within +-2**62", args)
            out[name] = (kind, [lo, hi])
        return {
            "count": self.count(data["count"], "sample.count"),
            "seed": self.whole(data["seed"], "sample.seed", 0),
            "parameters": out,
        }

    def seeds(self, value: Any) -> tuple[int, ...]:
        if isinstance(value, int) and not isinstance(value, bool):
            if not 1 <= value <= MAX_RUNS:
                raise self.fail("seeds", f"a count from 1 to {MAX_RUNS} or a list of seeds", value)
            return tuple(range(value))
        if not isinstance(value, list) or not value:
            raise self.fail("seeds", "a count or a non-empty list of seeds", value)
        seeds = tuple(self.whole(s, f"seeds[{i}]", 0) for i, s in enumerate(value))
        if len(set(seeds)) != len(seeds):
            raise self.fail("seeds", "a list without repeated seeds", value)
        return seeds

    def measures(self, value: Any) -> tuple[Measure, ...]:
        if value is None:
            return tuple(MEASURES.get(name) for name in MEASURES.names())
        if not isinstance(value, list) or not value:
            raise self.fail(
                "measures", "a non-empty list of measure names or {name: expression}", value
            )
        out: list[Measure] = []
        for i, item in enumerate(value):
            path = f"measures[{i}]"
            if isinstance(item, str):
                try:
                    out.append(MEASURES.get(item))
                except UnknownNameError as error:
                    raise self.error(f"{path}: {error}") from None
            elif isinstance(item, Mapping) and len(item) == 1:
                name, text = next(iter(item.items()))
                if not isinstance(name, str) or not name.isidentifier():
                    raise self.fail(path, "{name: expression} with a name like low_energy", item)
                try:
                    out.append(expression_measure(name, text))
                except ExpressionError as error:
                    raise self.error(f"{path}: {error}") from None
            else:
                raise self.fail(path, "a measure name or {name: expression}", item)
        names = [m.name for m in out]
        if len(set(names)) != len(names):
            raise self.fail("measures", "a list without repeated names", names)
        return tuple(out)

    def columns(self, experiment: Experiment) -> None:
        """Parameters, measures and the reserved result columns must not share a name."""
        seen: dict[str, str] = {name: "a result column" for name in RESERVED}
        for name in experiment.parameters:
            if name in seen:
                raise self.error(f"parameter {name!r} is {seen[name]}; it cannot be varied")
            seen[name] = "a varied parameter"
        for m in experiment.measures:
            if m.name in seen:
                raise self.error(f"measure {m.name!r} is {seen[m.name]}; rename the measure")


def parse_vary(items: Sequence[str], bounds: bool = False) -> dict[str, Any]:
    """``--vary`` options as the file's ``vary`` mapping: ``name=1,2,3`` (a list) or
    ``name=20:50:5`` (20, 25, ..., 50, inclusive); with ``bounds`` (a sampled design) also
    ``name=20:50`` (bounds: ``{from: 20, to: 50}``). Values are typed as plain YAML 1.2
    scalars (:func:`~pyautonomousagent.inputs.plain_value`: ``30`` a number, ``1:30``
    text), for the parameter's own schema to check.

    Raises:
        ExperimentError: an option without ``=``, a range of other than three parts, or a
            parameter given twice.
    """
    vary: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name or not text.strip():
            raise ExperimentError(f"--vary needs NAME=V1,V2,... or NAME=FROM:TO:STEP, got {item!r}")
        if name in vary:
            raise ExperimentError(f"--vary {name} is given twice; give its values in one --vary")
        parts = text.split(":")
        if len(parts) == 3 or (bounds and len(parts) == 2):  # a range, or bounds
            keys = ("from", "to", "step")[: len(parts)]
            vary[name] = {k: _vary_value(p, name) for k, p in zip(keys, parts, strict=True)}
        elif len(parts) > 1 and all(isinstance(_vary_value(p, name), int | float) for p in parts):
            raise ExperimentError(
                f"--vary {name}: a range is FROM:TO:STEP, three numbers (e.g. 20:50:5), "
                f"got {text!r} (bounds LOW:HIGH are for --design lhs, sobol or morris)"
            )
        else:
            vary[name] = [_vary_value(v, name) for v in text.split(",") if v.strip()]
    return vary


def _vary_value(text: str, name: str) -> Any:
    """One value of a ``--vary`` option (``20`` is a number, ``a`` a string)."""
    try:
        return plain_value(text.strip())
    except InputError as error:
        raise ExperimentError(f"--vary {name}: {error}") from None


def for_scenario(experiment: Experiment, scenario: Scenario) -> Experiment:
    """``experiment`` with its design's whole-number parameters taken from ``scenario``'s
    schema (:func:`~pyautonomousagent.experiments.design.typed`); a grid experiment
    unchanged."""
    if experiment.design is None:
        return experiment
    return replace(experiment, design=typed(experiment.design, schema_types(scenario)))
