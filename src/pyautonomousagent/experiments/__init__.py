"""Experiments: parameter sweeps with seeds, measures per run, backends and plots; sampled
designs (:mod:`~pyautonomousagent.experiments.design`) and their sensitivity indices
(:mod:`~pyautonomousagent.experiments.sensitivity`).

``pyaa sweep``, ``pyaa plot`` and ``pyaa analyse`` are thin wrappers of :func:`sweep`,
:func:`plot_measure` and :func:`~pyautonomousagent.experiments.sensitivity.indices`; see
docs/experiments.md.
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
