"""Experiments: parameter sweeps with seeds, measures per run, backends and plots.

``pyaa sweep`` and ``pyaa plot`` are thin wrappers of :func:`sweep` and
:func:`plot_measure`; see docs/experiments.md.
"""

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
from pyautonomousagent.experiments.sweep import SweepResult, sweep

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
