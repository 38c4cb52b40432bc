"""Test tools for a user's leaves and missions — the ones the project's own tests use: a
tree :class:`Harness` ticked one iteration at a time, checks that two engines or two runs
agree (:func:`check_engines_agree`, :func:`check_same_runs`, :func:`check_leaf`), and
:func:`scoped_registrations`. The lessons' checks (:mod:`pyautonomousagent.lessons`) use them.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.bt.behaviours import BEHAVIOUR_TYPES
from pyautonomousagent.bt.blackboard import tree_blackboard_keys
from pyautonomousagent.bt.leaf import ENGINE_LEAF_TYPES, LEAF_TYPES, Leaf
from pyautonomousagent.bt.spec import Node, leaf, reactive_sequence
from pyautonomousagent.bt.status import FAILURE, SUCCESS
from pyautonomousagent.bt.trees import TREES
from pyautonomousagent.scenarios import SCENARIOS, load
from pyautonomousagent.simulation import phases
from pyautonomousagent.simulation.mission import MISSIONS
from pyautonomousagent.simulation.motion import MOTION_MODELS
from pyautonomousagent.simulation.run import ENGINES, Engine, Simulation, scenario_tree
from pyautonomousagent.simulation.scenario import Scenario
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

__all__ = [
    "Harness",
    "check_engines_agree",
    "check_leaf",
    "check_same_runs",
    "make_harness",
    "scoped_registrations",
]


@dataclass
class Harness:
    """A tree on one engine for N agents, ticked one iteration at a time."""

    tree: Node
    swarm: Swarm
    world: World
    engine: Engine

    def tick(self) -> np.ndarray:
        """Advance the clock one iteration, tick every agent once; the node statuses,
        shape (nodes in tick order, N), int8."""
        self.world.iteration += 1
        self.engine.tick()
        return self.engine.node_statuses()

    def names(self) -> list[str]:
        """The node names in the order of :meth:`tick`'s rows."""
        return [node.name for node in self.tree.walk()]

    def statuses(self, agent: int = 0) -> dict[str, int]:
        """Node name -> status code of one agent, after the last tick."""
        column = self.engine.node_statuses()[:, agent]
        return dict(zip(self.names(), (int(c) for c in column), strict=True))


def make_harness(
    tree: Node, agents: int = 1, scenario: str | Scenario = "gathering", engine: str = "pytrees"
) -> Harness:
    """A :class:`Harness` for ``tree`` with ``agents`` agents placed by the scenario's mission
    (its blackboard, columns and parameters), no motion: only the tree runs."""
    scenario = _scenario(scenario).with_overrides(agents=agents)
    mission = scenario.create_mission()
    world = phases.create_world(scenario, 0)
    declared = tree_blackboard_keys(tree, mission.blackboard())
    swarm = phases.create_agents(mission, world, np.random.default_rng(0), declared)
    decision = ENGINES.get(engine)(tree, swarm, world, vars(scenario.parameters))
    return Harness(tree, swarm, world, decision)


def check_engines_agree(
    tree: Node | None = None,
    scenario: str | Scenario = "gathering",
    seed: int = 0,
    engines: tuple[str, str] = ("pytrees", "batched"),
    **overrides: Any,
) -> int:
    """Run ``tree`` (None: the scenario's) on two ``engines`` (the reference first) side by
    side, stepping both, with ``overrides`` of the scenario (a name, file or object), e.g.
    ``agents=6, iterations=200``; return the number of iterations compared.

    Raises:
        AssertionError: naming the first iteration, node or column, and agent that differ.
    """
    scenario = _scenario(scenario).with_overrides(**overrides)
    a, b = (Simulation.create(scenario, seed=seed, engine=e, tree=tree) for e in engines)
    nodes = [node.name for node in (tree or scenario_tree(scenario)).walk()]
    for _ in range(scenario.iterations):
        a.step()
        b.step()
        _same(a.engine.node_statuses(), b.engine.node_statuses(), a, nodes, "node", engines)
    for key in a.recorder.columns:
        _same(a.recorder.column(key), b.recorder.column(key), a, None, key, engines)
    if a.events != b.events:
        raise AssertionError(
            f"events differ: {a.events[:3]} ({engines[0]}) vs {b.events[:3]} ({engines[1]})"
        )
    return scenario.iterations


def check_same_runs(a: Simulation, b: Simulation, names: tuple[str, str] = ("a", "b")) -> None:
    """Check that two finished runs (``names`` in the message) recorded the same bits: every
    recorded column, the traced node statuses, the active behaviour, the record iterations
    (compared as raw bytes, so NaN payloads and the sign of zero count) and the events.

    Raises:
        AssertionError: naming the first record array that differs and its first differing
            (record, agent) entry, or the first differing event.
    """
    ra, rb = a.recorder, b.recorder
    arrays = [(key, ra.column(key), rb.column(key)) for key in ra.columns]
    arrays += [("traces", ra.traces[: ra.count], rb.traces[: rb.count]),
               ("behaviour", _behaviour(ra), _behaviour(rb)),
               ("iterations", ra.iterations[: ra.count], rb.iterations[: rb.count])]  # fmt: skip
    for what, x, y in arrays:
        x, y = np.asarray(x), np.asarray(y)
        if x.shape != y.shape or x.dtype != y.dtype:
            raise AssertionError(f"{what}: shape {x.shape} {x.dtype} ({names[0]}) vs "
                                 f"{y.shape} {y.dtype} ({names[1]})")  # fmt: skip
        if x.tobytes() != y.tobytes():
            bits = np.dtype(f"u{x.dtype.itemsize}")  # compare raw bits: NaNs, -0.0
            first = tuple(int(i) for i in np.argwhere(x.view(bits) != y.view(bits))[0])
            raise AssertionError(f"{what} differs first at {first}: {x[first]!r} ({names[0]}) "
                                 f"vs {y[first]!r} ({names[1]})")  # fmt: skip
    if a.events != b.events:
        pairs = zip(a.events, b.events, strict=False)
        shorter = min(len(a.events), len(b.events))
        event = next((i for i, (p, q) in enumerate(pairs) if p != q), shorter)
        raise AssertionError(f"events differ first at {event} of {len(a.events)} ({names[0]}) "
                             f"and {len(b.events)} ({names[1]})")  # fmt: skip


def _behaviour(recorder: Any) -> np.ndarray:
    """The active behaviour of the records so far, shape (records, N) (empty without a tree)."""
    if recorder.behaviour is None:
        return np.zeros((0, 0), np.int16)
    return recorder.behaviour_block(0, recorder.count)


def check_leaf(
    leaf_type: type[Leaf],
    scenario: str | Scenario = "gathering",
    agents: int = 8,
    iterations: int = 60,
    seed: int = 0,
    **ports: Any,
) -> int:
    """Check that a leaf type runs alike on both engines (:func:`check_engines_agree`) behind
    a gate that lets all, most or a few agents through on each tick at random (the batched
    engine's three ways of calling a leaf).

    Raises:
        TypeError: ``leaf_type`` is not a registered :class:`Leaf` subclass.
        AssertionError: the engines disagree (naming where).
    """
    if not (isinstance(leaf_type, type) and issubclass(leaf_type, Leaf)):
        raise TypeError(f"check_leaf takes a Leaf subclass, got {leaf_type!r}")
    if LEAF_TYPES.get(leaf_type.type_name) is not leaf_type:
        raise TypeError(f"{leaf_type.__name__} is not registered; decorate it with @register_leaf")
    rng = np.random.default_rng(seed)
    shares = rng.choice([1.0, 0.8, 0.15], size=iterations)
    gate = np.where(rng.random((iterations, agents)) < shares[:, None], SUCCESS, FAILURE)
    tree = reactive_sequence(
        "check_leaf",
        leaf("Scripted", "gate", statuses=gate.tolist()),
        leaf(leaf_type.type_name, "leaf_under_test", **ports),
    )
    return check_engines_agree(tree, scenario, seed, agents=agents, iterations=iterations)


@contextmanager
def scoped_registrations() -> Iterator[None]:
    """Within the block, register freely; afterwards every registry (leaf types, hand-written
    behaviours, missions, scenarios, motion models, engines, named trees) is as before and
    mission files imported in the block are forgotten."""
    modules = set(sys.modules)
    engine_leaves = set(ENGINE_LEAF_TYPES)
    with ExitStack() as stack:
        for registry in (
            LEAF_TYPES, BEHAVIOUR_TYPES, MISSIONS, SCENARIOS, MOTION_MODELS, ENGINES, TREES,
        ):  # fmt: skip
            stack.enter_context(registry.scoped())
        try:
            yield
        finally:
            ENGINE_LEAF_TYPES.intersection_update(engine_leaves)
            for name in set(sys.modules) - modules:
                if name.startswith("pyautonomousagent_user_"):
                    del sys.modules[name]


def _scenario(scenario: str | Scenario) -> Scenario:
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, str):
        return load(scenario)
    raise TypeError(f"scenario must be a name, a .yaml file or a Scenario, got {scenario!r}")


def _same(
    a: np.ndarray,
    b: np.ndarray,
    sim: Simulation,
    rows: list[str] | None,
    what: str,
    engines: tuple[str, str],
) -> None:
    """Raise at the first entry where ``a`` (``engines[0]``) and ``b`` (``engines[1]``) differ."""
    if np.array_equal(a, b, equal_nan=a.dtype.kind == "f"):
        return
    row, agent = (int(i) for i in np.argwhere(~((a == b) | ((a != a) & (b != b))))[0])
    if rows is not None:
        where = f"iteration {sim.world.iteration}, node {rows[row]!r}"
    else:
        where = f"column {what!r}, record {row} (iteration {int(sim.recorder.iterations[row])})"
    raise AssertionError(
        f"engines differ at {where}, agent {sim.swarm.names[agent]}: "
        f"{a[row, agent]!r} ({engines[0]}) vs {b[row, agent]!r} ({engines[1]})"
    )
