"""Designs of experiments beyond the grid: Latin hypercube (SciPy), Sobol (SALib's Saltelli
scheme, first-order and total indices only) and Morris (SALib, 4 levels); docs/experiments.md
has the table of their sizes.

A design draws points in the unit cube ``[0, 1]^D`` (one dimension per varied parameter)
from its own seed (the same design and seed give the same points bit for bit, so
``--resume`` finds its runs again), then scales each to the parameter's bounds: a float
parameter takes ``low + u * (high - low)``, a whole-number one
``low + floor(u * (high - low + 1))`` (at most ``high``), so each of ``low..high`` is equally
likely. SALib and SciPy are the optional ``[experiments]`` extra, imported only here.
"""

from __future__ import annotations

import importlib
import json
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from pyautonomousagent.experiments.errors import ExperimentError

if TYPE_CHECKING:
    from pyautonomousagent.simulation import Scenario

#: The designs: a grid (every combination of ``vary``) and the sampled ones.
DESIGNS = ("grid", "lhs", "sobol", "morris")
#: Levels of the Morris grid (SALib's default, the usual choice).
MORRIS_LEVELS = 4
#: What to install for a sampled design.
EXTRA = 'pip install "pyautonomousagent[experiments]"'


@dataclass(frozen=True)
class Design:
    """A sampled design over bounded parameters.

    Attributes:
        method: "lhs", "sobol" or "morris".
        samples: N: points (lhs), base samples (sobol) or trajectories (morris).
        seed: the design's own seed (drawing the points; also the analysis' bootstrap).
        bounds: parameter -> (low, high), in the parameter's unit, in column order.
        integers: the parameters that take whole numbers (from the scenario's schema).
    """

    method: str
    samples: int
    seed: int
    bounds: dict[str, tuple[float, float]]
    integers: frozenset[str] = field(default_factory=frozenset)

    @property
    def names(self) -> list[str]:
        """The parameters, in column order."""
        return list(self.bounds)

    def size(self) -> int:
        """The number of points the design draws: ``samples`` (lhs), ``samples * (D + 2)``
        (sobol, first-order and total indices), ``samples * (D + 1)`` (morris)."""
        d = len(self.bounds)
        return self.samples * {"lhs": 1, "sobol": d + 2, "morris": d + 1}[self.method]

    def unit(self) -> np.ndarray:
        """The points in the unit cube drawn from :attr:`seed`, shape (:meth:`size`, D).

        Raises:
            ExperimentError: the library the design needs is not installed.
        """
        d, n, seed = len(self.bounds), self.samples, self.seed
        if self.method == "lhs":
            qmc = library("scipy.stats.qmc", "lhs")
            unit = qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n=n)
        elif self.method == "sobol":
            sobol = library("SALib.sample.sobol", "sobol")
            unit = sobol.sample(unit_problem(self.names), n, calc_second_order=False, seed=seed)
        else:
            morris = library("SALib.sample.morris", "morris")
            unit = morris.sample(unit_problem(self.names), n, num_levels=MORRIS_LEVELS, seed=seed)
        return np.asarray(unit, dtype=np.float64)

    def points(self) -> list[dict[str, Any]]:
        """The points in the parameters' units (see the module docstring for the mapping)."""
        unit = self.unit()
        columns: list[list[Any]] = []
        for j, (name, (low, high)) in enumerate(self.bounds.items()):
            if name in self.integers:
                lo, hi = int(low), int(high)
                whole = np.minimum(lo + np.floor(unit[:, j] * (hi - lo + 1)), hi)
                columns.append([int(v) for v in whole])
            else:
                columns.append([float(v) for v in low + unit[:, j] * (high - low)])
        return [dict(zip(self.names, row, strict=True)) for row in zip(*columns, strict=True)]


def unit_problem(names: list[str]) -> dict[str, Any]:
    """SALib's problem over the unit cube, one dimension per name (the designs are drawn
    and analysed there)."""
    return {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}


def typed(design: Design, kinds: dict[str, type]) -> Design:
    """``design`` with its whole-number parameters marked, from ``kinds`` (parameter ->
    int or float, the scenario's schema; parameters it does not name stay float).

    Raises:
        ExperimentError: a parameter that is not a number, or a whole-number parameter with
            bounds that are not whole numbers.
    """
    integers = set()
    for name, (low, high) in design.bounds.items():
        kind = kinds.get(name, float)
        if kind is bool or kind not in (int, float):
            what = {str: "text", bool: "true or false"}.get(kind, kind.__name__)
            raise ExperimentError(
                f"design {design.method}: parameter {name!r} is {what}, not a number; "
                "vary it on a grid (--design grid)"
            )
        if kind is int:
            if not (float(low).is_integer() and float(high).is_integer()):
                raise ExperimentError(
                    f"design {design.method}: parameter {name!r} takes whole numbers; give it "
                    f"whole-number bounds, got {low}:{high}"
                )
            integers.add(name)
    return replace(design, integers=frozenset(integers))


def library(module: str, method: str) -> Any:
    """The module ``module`` (of SALib or SciPy), or an ExperimentError naming the extra to
    install; ``method`` is the design that needs it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        library = module.split(".")[0].replace("scipy", "SciPy")
        raise ExperimentError(
            f"--design {method} needs {library}, which is not installed: {EXTRA}"
        ) from None


def schema_types(scenario: Scenario) -> dict[str, type]:
    """The type (int, float, str, bool...) of every field and parameter of ``scenario``:
    a parameter's from its schema (the type of its default), a field's from its value."""
    from pyautonomousagent.simulation.scenario import parameter_list, to_mapping

    kinds = {key: type(value) for key, value in to_mapping(scenario).items()}
    kinds.update({p.name: p.type for _, p in parameter_list(scenario)})
    return kinds


#: The design's file in a sweep folder.
DESIGN_FILE = "design.parquet"


def design_table(design: Design) -> pa.Table:
    """The design as a table: ``point`` (its position, 0-based) and each parameter's
    coordinate in the unit cube (0: its ``from``, 1: its ``to``); the design's method,
    samples, seed, bounds and whole-number parameters in the schema's metadata."""
    unit = design.unit()
    columns = {"point": pa.array(np.arange(len(unit)), pa.int64())}
    columns.update({name: pa.array(unit[:, j]) for j, name in enumerate(design.names)})
    about = {
        "method": design.method,
        "samples": design.samples,
        "seed": design.seed,
        "bounds": {k: list(v) for k, v in design.bounds.items()},
        "integers": sorted(design.integers),
        "morris_levels": MORRIS_LEVELS,
    }
    return pa.table(columns).replace_schema_metadata({"pyaa.design": json.dumps(about)})
