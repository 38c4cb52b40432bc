"""The py_trees engine's Sequence, Fallback and decorators (from their rules) tick as py_trees'
classes do."""

from __future__ import annotations

from typing import Any

import py_trees
from hypothesis import HealthCheck, given, settings

from pyautonomousagent.bt.spec import Node
from pyautonomousagent.engines import pytrees

from .conftest import make_harness
from .strategies import trees

TICKS, AGENTS = 8, 3

_DECORATORS = py_trees.decorators
#: The node types the engine builds from its own quiet classes, built from py_trees' instead.
PLAIN_NODES: dict[str, Any] = {
    "Sequence": lambda name, kids, p: py_trees.composites.Sequence(name, p["memory"], kids),
    "Fallback": lambda name, kids, p: py_trees.composites.Selector(name, p["memory"], kids),
    "Inverter": lambda name, kids, p: _DECORATORS.Inverter(name, kids[0]),
    "ForceSuccess": lambda name, kids, p: _DECORATORS.FailureIsSuccess(name, kids[0]),
    "ForceFailure": lambda name, kids, p: _DECORATORS.SuccessIsFailure(name, kids[0]),
    "KeepRunningUntilFailure": lambda name, kids, p: _DECORATORS.SuccessIsRunning(name, kids[0]),
    "FailureIsRunning": lambda name, kids, p: _DECORATORS.FailureIsRunning(name, kids[0]),
    "RunningIsFailure": lambda name, kids, p: _DECORATORS.RunningIsFailure(name, kids[0]),
    "RunningIsSuccess": lambda name, kids, p: _DECORATORS.RunningIsSuccess(name, kids[0]),
    "PassThrough": lambda name, kids, p: _DECORATORS.PassThrough(name, kids[0]),
}


def _current_children(engine: pytrees.PyTreesEngine) -> list[Any]:
    """Each composite's current child, by its name (None if there is none), tree by tree."""
    found = []
    for root in engine.roots:
        for node in root.iterate():
            if isinstance(node, py_trees.composites.Composite):
                child = node.current_child
                found.append(None if child is None else child.name)
    return found


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(TICKS, AGENTS))
def test_quiet_nodes_tick_as_py_trees_nodes(tree: Node) -> None:
    ours = make_harness(tree, AGENTS)
    assert not PLAIN_NODES.keys() & pytrees.PYTREES_NODES.keys()  # ours: from their rules
    pytrees.PYTREES_NODES.update(PLAIN_NODES)
    try:
        plain = make_harness(tree, AGENTS)
    finally:
        for name in PLAIN_NODES:
            del pytrees.PYTREES_NODES[name]
    assert isinstance(ours.engine, pytrees.PyTreesEngine)
    assert isinstance(plain.engine, pytrees.PyTreesEngine)
    for tick in range(1, TICKS + 1):
        assert ours.tick().tolist() == plain.tick().tolist(), f"tick {tick}"
        assert _current_children(ours.engine) == _current_children(plain.engine), f"tick {tick}"
        ticks = ours.swarm.blackboard["number_ticks"].tolist()
        assert ticks == plain.swarm.blackboard["number_ticks"].tolist(), f"tick {tick}"
