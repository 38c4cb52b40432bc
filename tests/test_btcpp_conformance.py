"""Our two engines against the real BehaviorTree.CPP (behaviortreepy), on random trees.

Every tree is drawn over every BehaviorTree.CPP tag we support, with scripted leaves (a
random status per tick per agent). Tick by tick, the root status and each agent's ordered
leaf executions and halts must equal those of one BT.CPP tree per agent ticked with
``tick_exactly_once()`` (docs/tree-files.md, "One iteration is one tick"). The seed changes
every run unless ``PYAA_CONFORMANCE_SEED`` is set; a failure prints it.
"""

from __future__ import annotations

import os
import secrets

import numpy as np
import pytest

from pyautonomousagent.bt.spec import Node, node_type
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.bt.vocabulary import tags

from .btcpp_reference import ours, reference

pytest.importorskip("behaviortreepy")

TREES, AGENTS, TICKS = 300, 4, 6
SEED = int(os.environ.get("PYAA_CONFORMANCE_SEED", secrets.randbits(32)))

#: The BT.CPP tags drawn (our py_trees-only tags have no BT.CPP counterpart).
BTCPP_TAGS = [tag for tag in tags() if tag.builtin]


def random_tree(rng: np.random.Generator, leaves: list[str], depth: int = 0) -> Node:
    """A random tree whose leaves are Scripted nodes named l0, l1, ... (appended to leaves);
    conditions (never RUNNING; the first child of IfThenElse and WhileDoElse) are c3, ..."""
    if depth >= 3 or (depth > 0 and rng.random() < 0.35):
        if rng.random() < 0.1:
            kind = str(rng.choice(["AlwaysSuccess", "AlwaysFailure"]))
            return Node(kind, f"k{rng.integers(1 << 30)}")
        name = f"l{len(leaves)}"
        leaves.append(name)
        return Node("Scripted", name, (), {"statuses": [[SUCCESS]]})
    tag = BTCPP_TAGS[rng.integers(len(BTCPP_TAGS))]
    record = node_type(tag.spec)
    most = record.most or 3
    count = int(rng.integers(max(record.least, 1), most + 1))
    kids = tuple(random_tree(rng, leaves, depth + 1) for _ in range(count))
    if tag.tag in ("IfThenElse", "WhileDoElse"):  # the first child is a condition leaf
        leaves.append(f"c{len(leaves)}")
        kids = (Node("Scripted", leaves[-1], (), {"statuses": [[SUCCESS]]}), *kids[1:])
    params = dict(tag.fixed)
    for key in tag.params:
        if key in ("num_cycles", "num_attempts"):
            params[key] = int(rng.choice([-1, 1, 2, 3]))
        elif key in ("success_count", "failure_count", "max_failures"):
            n = len(kids)
            params[key] = int(rng.choice([*range(1, n + 1), *range(-n, 0)]))
    return Node(tag.spec, f"n{depth}_{rng.integers(1 << 30)}", kids, params)


def draw(rng: np.random.Generator) -> tuple[Node, dict[str, list[list[int]]]]:
    """A random tree and its leaves' scripts {name: [tick][agent] status codes}."""
    leaves: list[str] = []
    tree = random_tree(rng, leaves)
    codes = np.array([SUCCESS, FAILURE, RUNNING])
    table = {
        name: codes[rng.integers(2 if name[0] == "c" else 3, size=(TICKS, AGENTS))].tolist()
        for name in leaves
    }
    return tree, table


def test_random_trees_agree_with_behaviortree_cpp() -> None:
    rng = np.random.default_rng(SEED)
    for n in range(TREES):
        tree, table = draw(rng)
        want = reference(tree, table, AGENTS, TICKS)
        for engine in ("pytrees", "batched"):
            got = ours(tree, table, AGENTS, TICKS, engine)
            assert got == want, (
                f"seed {SEED} (PYAA_CONFORMANCE_SEED={SEED}), tree {n}, engine {engine}:\n"
                f"{tree}\nscripts {table}\nBT.CPP roots/events {want}\nours {got}"
            )
