"""Measures: one number per run, computed from the run's recorded data.

A measure is a function of a :class:`RunData` (the recorded columns, events and scenario of
one run) that returns a float, kept in the registry :data:`MEASURES` with a one-line
description and a unit; missions add their own with :func:`register_measure`, and an
experiment can use an expression over the columns
(:mod:`~pyautonomousagent.experiments.expression`; ``mean(in_<leaf name>)`` is the share of
time in a behaviour, :func:`behaviour_fractions` gives all of them).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent.experiments.expression import Expression
from pyautonomousagent.registry import Registry

if TYPE_CHECKING:
    from pyautonomousagent.simulation import Scenario, Simulation


@dataclass(frozen=True)
class RunData:
    """What a measure reads of one finished run.

    Attributes:
        scenario: the scenario that ran (parameters included).
        seed: the run's seed.
        iterations: the recorded iterations, shape (records,).
        columns: each recorded column (state and blackboard), shape (records, N).
        events: alerts and recorded messages, as in ``Simulation.events``.
        behaviour: each agent's active behaviour (the leaf RUNNING after the tick, else the
            last leaf ticked) as an index into ``nodes``, shape (records, N), -1 before the
            first tick; None if the run did not record it.
        nodes: the tree's node names in tick order.
    """

    scenario: Scenario
    seed: int
    iterations: np.ndarray
    columns: Mapping[str, np.ndarray]
    events: list[dict[str, Any]] = field(default_factory=list)
    behaviour: np.ndarray | None = None
    nodes: list[str] = field(default_factory=list)

    @classmethod
    def from_simulation(cls, sim: Simulation) -> RunData:
        """The recorded data of ``sim`` (views of its recorder, not copies)."""
        recorder = sim.recorder
        columns = {key: recorder.column(key) for key in recorder.columns}
        behaviour = getattr(recorder, "behaviour", None)
        return cls(
            sim.scenario,
            sim.seed,
            recorder.iterations[: recorder.count],
            columns,
            list(sim.events),
            None if behaviour is None else behaviour[: recorder.count],
            [node.name for node in getattr(recorder, "nodes", [])],
        )

    @property
    def agents(self) -> int:
        """N, the number of agents."""
        return int(self.scenario.agents)

    def parameter(self, name: str, default: float) -> float:
        """A scenario parameter by name (``default`` if the scenario has none of that name)."""
        return float(getattr(self.scenario.parameters, name, default))

    def expression_values(self) -> Mapping[str, Any]:
        """Names an expression may use: every column, ``iteration`` (shape (records, 1)),
        ``agents`` and ``iterations`` (the run's length), and ``in_<leaf>`` (shape
        (records, N): 1 where that leaf is the agent's active behaviour), made when used."""
        values: dict[str, Any] = dict(self.columns)
        values["iteration"] = self.iterations.astype(np.float64)[:, None]
        values["agents"] = float(self.agents)
        values["iterations"] = float(self.scenario.iterations)
        if self.behaviour is None:
            return values
        # in_<node name> (characters other than letters, digits and _ become _) -> node index
        leaves = {"in_" + re.sub(r"\W", "_", name): i for i, name in enumerate(self.nodes)}
        return _Lazy(values, self.behaviour, leaves)


class _Lazy(Mapping[str, Any]):
    """Columns, plus ``in_<leaf>`` arrays computed only when an expression uses them."""

    def __init__(self, values: dict[str, Any], behaviour: np.ndarray, leaves: dict[str, int]):
        self.plain, self.behaviour, self.leaves = values, behaviour, leaves

    def __getitem__(self, name: str) -> Any:
        if name in self.plain:
            return self.plain[name]
        return self.behaviour == self.leaves[name]  # KeyError for an unknown name

    def __iter__(self) -> Iterator[str]:
        return iter([*self.plain, *self.leaves])

    def __len__(self) -> int:
        return len(self.plain) + len(self.leaves)


@dataclass(frozen=True)
class Measure:
    """A named measure of a run.

    Attributes:
        name: the column it gets in the results.
        fn: ``fn(run) -> float`` (NaN where it does not apply, e.g. no refuel happened).
        doc: one line saying what it is.
        unit: its unit, e.g. ``"iterations"``, ``"%"``, ``"world units"``.
    """

    name: str
    fn: Callable[[RunData], float]
    doc: str = ""
    unit: str = ""

    def __call__(self, run: RunData) -> float:
        return float(self.fn(run))


def expression_measure(name: str, text: str, unit: str = "") -> Measure:
    """A measure computed by an expression over the columns (checked now, evaluated later)."""
    expression = Expression(text)
    return Measure(name, _Evaluate(expression), f"expression: {text}", unit)


@dataclass(frozen=True)
class _Evaluate:
    """A picklable ``fn`` for an expression measure."""

    expression: Expression

    def __call__(self, run: RunData) -> float:
        return self.expression.evaluate(run.expression_values())


#: The measures experiments can name.
MEASURES: Registry[Measure] = Registry("measure")


def register_measure(
    name: str, fn: Callable[[RunData], float], doc: str = "", unit: str = ""
) -> Measure:
    """Add a measure under ``name`` (missions call this for their own measures)."""
    return MEASURES.register(name, Measure(name, fn, doc, unit))


def behaviour_fractions(run: RunData) -> dict[str, float]:
    """Per leaf of the tree, the share of agent-records in which it is the active behaviour
    (records before the first tick count as none); empty if the run recorded no behaviour."""
    if run.behaviour is None or run.behaviour.size == 0:
        return {}
    counts = np.bincount(run.behaviour.reshape(-1) + 1, minlength=len(run.nodes) + 1)[1:]
    return {
        name: float(c) / run.behaviour.size
        for name, c in zip(run.nodes, counts, strict=True)
        if c > 0
    }


def distance_flown(run: RunData) -> float:
    """The path length of all agents together, summed over the recorded positions
    (a lower bound when not every iteration is recorded)."""
    x, y = run.columns["x"], run.columns["y"]
    return float(np.hypot(np.diff(x, axis=0), np.diff(y, axis=0)).sum())


def alerts(run: RunData) -> float:
    """Agents that ran out of energy (one zero-energy alert each)."""
    return float(sum(1 for event in run.events if event.get("event") == "alert"))


def register_documented(fn: Callable[[RunData], float], unit: str) -> Measure:
    """Register ``fn`` under its own name, its docstring's first lines as the doc."""
    return register_measure(fn.__name__, fn, " ".join((fn.__doc__ or "").split()).rstrip("."), unit)


# Measures of any run; missions register their own (missions/drones/measures.py).
register_documented(distance_flown, "world units")
register_documented(alerts, "agents")
