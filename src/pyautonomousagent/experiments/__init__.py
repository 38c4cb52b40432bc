"""Experiments: parameter sweeps with seeds, measures per run, backends and plots; sampled
designs (:mod:`~pyautonomousagent.experiments.design`) and their sensitivity indices
(:mod:`~pyautonomousagent.experiments.sensitivity`).

``pyaa sweep``, ``pyaa plot`` and ``pyaa analyse`` are thin wrappers of :func:`sweep`,
:func:`plot_measure` and :func:`~pyautonomousagent.experiments.sensitivity.indices`; see
docs/experiments.md.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pyautonomousagent.experiments.expression import Expression, ExpressionError
    from pyautonomousagent.experiments.measures import (
        MEASURES,
        Measure,
        RunData,
        expression_measure,
        register_measure,
    )
    from pyautonomousagent.experiments.plot import plot_measure
    from pyautonomousagent.experiments.spec import Experiment, ExperimentError, Run
    from pyautonomousagent.experiments.sweeps import SweepResult, sweep

#: Where each name of the package lives: imported when first asked for, so that a mission
#: registering a measure (``experiments.measures``) does not load the sweeps, their backends
#: and plotting (about a second).
_HOMES = {
    "Expression": "expression", "ExpressionError": "expression",
    "MEASURES": "measures", "Measure": "measures", "RunData": "measures",
    "expression_measure": "measures", "register_measure": "measures",
    "plot_measure": "plot", "Experiment": "spec", "ExperimentError": "spec", "Run": "spec",
    "SweepResult": "sweeps", "sweep": "sweeps",
}  # fmt: skip


def __getattr__(name: str) -> Any:
    """The package's names, from their modules on first use (PEP 562)."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    globals()[name] = value  # asked once
    return value


__all__ = [
    "MEASURES",
    "Experiment",
    "ExperimentError",
    "Expression",
    "ExpressionError",
    "Measure",
    "Run",
    "RunData",
    "SweepResult",
    "expression_measure",
    "plot_measure",
    "register_measure",
    "sweep",
]
