"""Every node type with a rule (bt/rules.py) on every engine: the same statuses, tick by tick.

Two trees hold each such type at least once (the node types that count or read an entry,
which take no child that may be SKIPPED, in the second); 48 agents' leaves return random
statuses read from the blackboard (``FromEntry``, which has a compiled kernel), so the
py_trees engine's per-agent form, the batched engine's masked form and the compiled
engine's generated code of each rule are compared node by node, agent by agent, after every
tick.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from pyautonomousagent import jit
from pyautonomousagent.bt.leaf import LEAF_TYPES
from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.spec import BlackboardRef, Node, check_structure
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.missions.drones import DroneMission
from pyautonomousagent.simulation.run import ENGINES
from pyautonomousagent.state import Swarm

from .conftest import BLACKBOARD_KEYS, default_parameters, make_world
from .test_try_catch import FromEntry, from_entry

AGENTS, TICKS = 48, 40


def _builders(prefix: str) -> tuple[Callable[[], Node], Callable[..., Node]]:
    """``leaf()`` (a leaf returning its entry) and ``node(kind, *kids, **params)``, their
    names numbered ``<prefix><k>`` in the order made."""
    names = iter(f"{prefix}{k}" for k in range(100))

    def leaf() -> Node:
        return from_entry(next(names))

    def node(kind: str, *kids: Node, **params: object) -> Node:
        return Node(kind, f"{kind.lower()}_{next(names)}", kids, params)

    return leaf, node


def _tree() -> Node:
    leaf, node = _builders("l")
    return node(
        "Fallback",
        node("Sequence", node("RunOnce", leaf()), node("TryCatch", leaf(), leaf(), leaf()),
             node("SequenceWithMemory", leaf(), leaf()), memory=True),
        node("IfThenElse", leaf(), node("AsyncSequence", leaf(), leaf()),
             node("AsyncFallback", leaf(), leaf())),
        node("WhileDoElse", leaf(), node("Inverter", leaf()),
             node("KeepRunningUntilFailure", node("ForceSuccess", leaf()))),
        node("Sequence", node("RunOnce", leaf(), then_skip=False),
             node("Fallback", node("ForceFailure", leaf()), leaf(), memory=True),
             node("IfThenElse", leaf(), leaf()), memory=False),
        memory=False,
    )  # fmt: skip


def _counting_tree() -> Node:
    """BT.CPP's node types that count: Repeat, RetryUntilSuccessful, Parallel, ParallelAll,
    Delay and Timeout, and those that read an entry, Switch2..6 (none may take a child that
    may be SKIPPED: not in :func:`_tree`); a Switch reads a leaf's entry (1, 2 or 3)."""
    leaf, node = _builders("c")
    return node(
        "ParallelAll",
        node("Repeat", leaf(), num_cycles=3),
        node("RetryUntilSuccessful", leaf(), num_attempts=-1),
        node("Parallel", leaf(), node("Delay", leaf(), delay_msec=2000),
             node("Timeout", leaf(), msec=3000), success_count=2, failure_count=-2),
        node("Timeout", node("RetryUntilSuccessful", leaf(), num_attempts=2), msec=4000),
        node("Delay", node("Repeat", leaf(), num_cycles=-1), delay_msec=1000),
        node("Parallel", leaf(), leaf(), leaf()),
        *(node(f"Switch{n}", *(leaf() for _ in range(n + 1)), variable=BlackboardRef(entry),
               **{f"case_{k}": case for k, case in enumerate(["3", "1.0", "2", "1", "x", "2.5"], 1)
                  if k <= n})
          for n, entry in zip(range(2, 7), ["s_c0", "s_c2", "s_c4", "s_c5", "s_c7"], strict=True)),
        max_failures=3,
    )  # fmt: skip


def test_the_tree_has_every_node_type_with_a_rule() -> None:
    used = {node.type for tree in (_tree(), _counting_tree()) for node in tree.walk()}
    with_rule = {name for name, record in NODE_TYPES.items() if record.rule is not None}
    missing = with_rule - used - {"FailureIsRunning", "RunningIsFailure", "RunningIsSuccess"}
    assert missing <= {"PassThrough"}, missing


def _statuses(engine: str, tree: Node) -> list[np.ndarray]:
    names = [node.name for node in tree.walk() if not node.is_control]
    rng = np.random.default_rng(7)
    codes = np.array([SUCCESS, FAILURE, RUNNING])
    with LEAF_TYPES.override("FromEntry", FromEntry):
        keys = {f"s_{name}": np.int64 for name in names}
        swarm = Swarm.create(
            [f"d{i}" for i in range(AGENTS)], {**BLACKBOARD_KEYS, **keys}, DroneMission.columns
        )
        world = make_world(swarm)
        decision = ENGINES.get(engine)(tree, swarm, world, default_parameters())
        out = []
        for _ in range(TICKS):
            for name in names:
                swarm.blackboard[f"s_{name}"][:] = codes[rng.integers(3, size=AGENTS)]
            world.iteration += 1
            decision.tick()
            out.append(decision.node_statuses().copy())
    return out


def _assert_same_statuses(tree: Node, want: list[np.ndarray], got: list[np.ndarray]) -> None:
    """Every node's status equal after every tick; else the first tick, node and agent."""
    names = [node.name for node in tree.walk()]
    for t, (a, b) in enumerate(zip(want, got, strict=True), start=1):
        differ = np.argwhere(a != b)
        assert not differ.size, f"tick {t}: node {names[differ[0][0]]}, agent {differ[0][1]}"


def _same_as_batched(engine: str, tree: Node) -> list[np.ndarray]:
    """Assert that ``engine`` gives the batched engine's statuses on ``tree``; those."""
    check_structure(tree)
    want = _statuses("batched", tree)
    _assert_same_statuses(tree, want, _statuses(engine, tree))
    return want


ENGINE_NAMES = [
    "pytrees",
    pytest.param(
        "compiled",
        marks=pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT"),
    ),
]


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_every_rule_gives_the_batched_engines_statuses(engine: str) -> None:
    want = _same_as_batched(engine, _tree())
    assert len({int(c) for tick in want for c in tick.ravel()}) == 5  # every status seen


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_the_counting_rules_give_the_batched_engines_statuses(engine: str) -> None:
    tree = _counting_tree()
    want = _same_as_batched(engine, tree)
    for row, node in enumerate(tree.walk()):  # every control node ran, and finished
        seen = {int(c) for tick in want for c in tick[row]}
        assert not node.is_control or RUNNING in seen and seen & {SUCCESS, FAILURE}, node.name


def _wide_tree(width: int) -> Node:
    """Every rule node type that takes any number of children, each with ``width`` of them
    (leaves, some under a RunOnce, so that children may be SKIPPED)."""
    leaves = iter(f"w{k}" for k in range(20 * width))

    def kids(skipping: bool = False) -> tuple[Node, ...]:
        made = [from_entry(next(leaves)) for _ in range(width)]
        if skipping:
            made[3] = Node("RunOnce", f"once_{next(leaves)}", (made[3],), {})
        return tuple(made)

    def node(kind: str, *children: Node, **params: object) -> Node:
        return Node(kind, f"{kind.lower()}_{next(leaves)}", children, params)

    return node("Sequence",
        node("Fallback", *kids(), memory=True), node("Fallback", *kids(True), memory=False),
        node("Sequence", *kids(True), memory=True), node("Sequence", *kids(), memory=False),
        node("SequenceWithMemory", *kids()), node("AsyncSequence", *kids()),
        node("AsyncFallback", *kids()), node("TryCatch", *kids(True)),
        memory=False,
    )  # fmt: skip


def test_nodes_with_many_children_give_the_py_trees_engines_statuses_on_batched() -> None:
    from pyautonomousagent.engines.batched_rules import ROLLED

    tree = _wide_tree(ROLLED + 9)  # the batched engine writes their children's blocks as loops
    check_structure(tree)
    want, got = _statuses("batched", tree), _statuses("pytrees", tree)
    _assert_same_statuses(tree, want, got)
    assert len({int(c) for tick in want for c in tick.ravel()}) == 5  # every status seen


def test_a_node_with_many_children_is_written_as_loops_for_the_batched_engine() -> None:
    from pyautonomousagent.bt.program import compile_tree
    from pyautonomousagent.engines.batched_rules import ROLLED, ArraySourceOps, roll

    sizes = []
    for width in (ROLLED + 9, 10 * ROLLED):
        program = compile_tree(_wide_tree(width))
        for i in range(1, len(program.nodes)):  # every node with many children
            if len(program.children[i]) < width:
                continue
            ops = ArraySourceOps(program, i, time_step=1.0)
            NODE_TYPES.get(program.nodes[i].type).rule(ops)
            rolled = roll(ops.lines)
            assert any(line.startswith("for q in range(") for line in rolled)
            assert len(rolled) < len(ops.lines) / 2
            sizes.append(len(rolled))
    assert sizes[: len(sizes) // 2] == sizes[len(sizes) // 2 :]  # the same, whatever the width


@pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
def test_nodes_with_many_children_give_the_batched_engines_statuses_on_compiled() -> None:
    """Children halted by more than ``UNROLLED`` a time are one loop over (child, end) pairs
    in the compiled engine's code (so that its code grows linearly with the children: a tree
    of eight 25-child nodes once grew numba's compile past 8 GB), with the same statuses."""
    from pyautonomousagent.bt.program import compile_tree
    from pyautonomousagent.bt.tree_source import UNROLLED, tree_body

    leaves = iter(f"m{k}" for k in range(100))

    def kids(skipping: bool = False) -> tuple[Node, ...]:
        made = [from_entry(next(leaves)) for _ in range(UNROLLED + 2)]
        if skipping:
            made[1] = Node("RunOnce", f"once_{next(leaves)}", (made[1],), {})
        return tuple(made)

    tree = Node("Sequence", "root", (
        Node("Fallback", "f", kids(), {"memory": False}),
        Node("Sequence", "s", kids(True), {"memory": False}),
        Node("Fallback", "fm", kids(True), {"memory": True}),
    ), {"memory": False})  # fmt: skip
    check_structure(tree)
    program = compile_tree(tree)
    body = tree_body(program, lambda i: [f"st[{i}, a] = 1"], {}, "", 1.0, "c_{}[a]".format)
    assert body.count("for span_") >= 3  # each wide node halts its later children in a loop
    want, got = _statuses("batched", tree), _statuses("compiled", tree)
    _assert_same_statuses(tree, want, got)
    assert len({int(c) for tick in want for c in tick.ravel()}) == 5  # every status seen
