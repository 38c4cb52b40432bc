"""Our two engines against the real BehaviorTree.CPP (behaviortreepy), on random trees.

Every tree is drawn over every BehaviorTree.CPP tag we support, with scripted leaves (a
random status per tick per agent). Tick by tick, the root status and each agent's ordered
leaf executions and halts must equal those of one BT.CPP tree per agent ticked with
``tick_exactly_once()`` (docs/tree-files.md, "One iteration is one tick"). The seed changes
every run unless ``PYAA_CONFORMANCE_SEED`` is set; a failure prints it.
"""

from __future__ import annotations

import os
import re
import secrets
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pyautonomousagent.bt.document import document_from_node
from pyautonomousagent.bt.files import read_document, to_text_format
from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError, check_structure
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.bt.vocabulary import tags
from pyautonomousagent.bt.xml_format import write_xml

from .btcpp_reference import btcpp_factory_with_our_leaves, btcpp_text, ours, reference

pytest.importorskip("behaviortreepy")

TREES, AGENTS, TICKS = 300, 4, 6
SEED = int(os.environ.get("PYAA_CONFORMANCE_SEED", secrets.randbits(32)))

#: The BT.CPP tags drawn: not our py_trees-only tags (BT.CPP lacks them), nor Delay and
#: Timeout (wall-clock time in BT.CPP, simulated time here: see test_btcpp_nodes.py).
BTCPP_TAGS = [tag for tag in tags() if tag.builtin and tag.tag not in ("Delay", "Timeout")]


def random_tree(rng: np.random.Generator, leaves: list[str], depth: int = 0) -> Node:
    """A random tree whose leaves are Scripted nodes named l0, l1, ... (appended to leaves);
    conditions (never RUNNING; the first child of IfThenElse and WhileDoElse) are c3, ..."""
    if depth >= 3 or (depth > 0 and rng.random() < 0.35):
        if rng.random() < 0.15:  # BT.CPP's own leaves: they run there, unlogged
            kind = str(rng.choice(["AlwaysSuccess", "AlwaysFailure", "ScriptCondition"]))
            code = {"code": "gate > 0"} if kind == "ScriptCondition" else {}
            return Node(kind, f"k{rng.integers(1 << 30)}", (), code)
        name = f"l{len(leaves)}"
        leaves.append(name)
        return Node("Scripted", name, (), {"statuses": [[SUCCESS]]})
    tag = BTCPP_TAGS[rng.integers(len(BTCPP_TAGS))]
    record = NODE_TYPES.get(tag.spec)
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
        elif key == "then_skip":
            params[key] = bool(rng.random() < 0.5)
        elif key == "if":
            params[key] = str(rng.choice(["gate > 0", "gate == 0", "!(gate > 0) || false"]))
        elif key == "variable":
            params[key] = BlackboardRef("mode")  # a string entry in BT.CPP (the port's type)
        elif key.startswith("case_"):
            params[key] = str(rng.choice(["0", "1", "2"]))
        elif key == "else":
            params[key] = str(rng.choice(["FAILURE", "SUCCESS", "RUNNING"]))
    return Node(tag.spec, f"n{depth}_{rng.integers(1 << 30)}", kids, params)


#: Scripting attributes drawn for some nodes: they read and write the entry ``gate``.
ATTRIBUTES = {
    "_failureIf": ["gate > 0", "gate == 0"],
    "_successIf": ["gate > 0", "gate == 0"],
    "_onSuccess": ["gate := 1", "gate := 0"],
    "_onFailure": ["gate := 1 - gate"],
    "_post": ["gate := gate", "gate := 0"],
    "_onHalted": ["gate := 1"],
    "_skipIf": ["gate > 0", "gate == 0"],
    "_while": ["gate > 0", "gate == 0"],
}


#: The pre-condition attributes.
PRE = ("_failureIf", "_successIf", "_skipIf", "_while")


def with_attributes(rng: np.random.Generator, root: Node) -> Node:
    """``root`` with random scripting attributes on about one node in eight."""
    kids = tuple(with_attributes(rng, child) for child in root.children)
    scripts = {}
    if rng.random() < 0.125:
        for key in rng.choice(sorted(ATTRIBUTES), size=int(rng.integers(1, 3)), replace=False):
            scripts[str(key)] = str(rng.choice(ATTRIBUTES[str(key)]))
    if root.name.startswith("c"):  # BT.CPP may leave it un-reset: see test_btcpp_nodes.py
        scripts = {k: v for k, v in scripts.items() if k not in PRE}
    return replace(root, children=kids, scripts=scripts)


def draw(rng: np.random.Generator) -> tuple[Node, dict[str, list[list[int]]]]:
    """A random tree and its leaves' scripts {name: [tick][agent] status codes}."""
    while True:
        leaves: list[str] = []
        tree = with_attributes(rng, random_tree(rng, leaves))
        try:
            check_structure(tree)  # e.g. BT.CPP's one AsyncSequence per ReactiveSequence
            break
        except TreeError:
            continue
    codes = np.array([SUCCESS, FAILURE, RUNNING])
    table = {
        name: codes[rng.integers(2 if name[0] == "c" else 3, size=(TICKS, AGENTS))].tolist()
        for name in leaves
    }
    table["gate"] = rng.integers(2, size=(TICKS, AGENTS)).tolist()  # read by scripts
    table["mode"] = rng.integers(3, size=(TICKS, AGENTS)).tolist()  # read by Switch nodes
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


ROOT = Path(__file__).parent.parent
SHIPPED = sorted(ROOT.glob("examples/*.xml")) + sorted(
    ROOT.glob("src/pyautonomousagent/missions/*/*.xml")
)


#: YAML tree files (not sweep files) among the examples.
YAML_TREES = [
    path
    for path in sorted(ROOT.glob("examples/*.yaml"))
    if re.search(r"(?m)^(trees?|main_tree_to_execute):", path.read_text())
]


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_tree_files_load_in_behaviortree_cpp(path: Path) -> None:
    factory = btcpp_factory_with_our_leaves()
    tree = factory.create_tree_from_text(btcpp_text(path.read_text()))
    assert tree.root_node() is not None


@pytest.mark.parametrize("path", SHIPPED + YAML_TREES, ids=lambda p: p.name)
def test_files_we_write_load_in_behaviortree_cpp(path: Path) -> None:
    text = to_text_format(read_document(path), "xml")
    factory = btcpp_factory_with_our_leaves()
    assert factory.create_tree_from_text(btcpp_text(text)).root_node() is not None


def test_random_trees_we_write_load_in_behaviortree_cpp() -> None:
    rng = np.random.default_rng(SEED)
    for _ in range(20):
        tree, _ = draw(rng)
        text = write_xml(document_from_node(tree))
        assert btcpp_factory_with_our_leaves().create_tree_from_text(btcpp_text(text))
