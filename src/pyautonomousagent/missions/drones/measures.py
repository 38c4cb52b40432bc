"""Measures of the paper's drone missions for experiments: refuels, energy.

Registered in the experiments' measure registry when the missions are imported (a mission's
own measures, written with the public :func:`~pyautonomousagent.experiments.register_measure`).
"""

from __future__ import annotations

import numpy as np

from pyautonomousagent.experiments.measures import RunData, register_documented


def refuel_starts(run: RunData) -> np.ndarray:
    """Where a refuel begins: energy rises now but did not at the record before,
    shape (records - 1, N), boolean. Exact when every iteration is recorded."""
    energy = run.columns["energy"]
    rising = np.diff(energy, axis=0) > 0.0
    rising[1:] &= ~rising[:-1]  # (the right side is a new array: the rows before)
    return rising


def refuels(run: RunData) -> float:
    """Refuels started by all agents together."""
    return float(np.count_nonzero(refuel_starts(run)))


def time_to_first_refuel(run: RunData) -> float:
    """The iteration at which the first agent starts refuelling (NaN if none does)."""
    rows = np.flatnonzero(refuel_starts(run).any(axis=1))
    return float(run.iterations[rows[0] + 1]) if rows.size else float("nan")


def minimum_energy(run: RunData) -> float:
    """The lowest energy level of any agent at any recorded iteration."""
    return float(run.columns["energy"].min())


def fraction_refuelling(run: RunData) -> float:
    """The share of agent-records during which energy rises (the agent is refuelling)."""
    energy = run.columns["energy"]
    if energy.shape[0] < 2:
        return float("nan")
    return float(np.mean(np.diff(energy, axis=0) > 0.0))


register_documented(refuels, "refuels")
register_documented(time_to_first_refuel, "iterations")
register_documented(minimum_energy, "%")
register_documented(fraction_refuelling, "fraction")
