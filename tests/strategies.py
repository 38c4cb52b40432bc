"""Hypothesis strategies: random behaviour trees of every supported control type, with
Scripted leaves whose status per tick per agent is drawn at random."""

from __future__ import annotations

from dataclasses import replace
from itertools import count

from hypothesis import strategies as st

from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError, check_structure
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS

STATUSES = st.sampled_from([SUCCESS, FAILURE, RUNNING])


def scripted_leaf(ticks: int, agents: int) -> st.SearchStrategy[Node]:
    """A Scripted leaf with a random (ticks, agents) status table."""
    table = st.lists(
        st.lists(STATUSES, min_size=agents, max_size=agents), min_size=ticks, max_size=ticks
    )
    return table.map(lambda rows: Node("Scripted", "leaf", (), {"statuses": rows}))


def control_node(children: st.SearchStrategy[list[Node]]) -> st.SearchStrategy[Node]:
    """A composite or decorator over drawn children."""
    composites = st.builds(
        lambda kind, memory, kids: Node(kind, "c", tuple(kids), {"memory": memory}),
        st.sampled_from(["Sequence", "Fallback"]),
        st.booleans(),
        children,
    )
    parallels = st.builds(
        lambda policy, sync, kids: Node(
            "PyTreesParallel",
            "p",
            tuple(kids),
            {"policy": policy, **({"synchronise": sync} if policy == "SuccessOnAll" else {})},
        ),
        st.sampled_from(["SuccessOnAll", "SuccessOnOne"]),
        st.booleans(),
        children,
    )
    one_child = children.filter(bool).map(lambda kids: kids[:1])
    mapped = st.builds(
        lambda kind, kids: Node(kind, "d", tuple(kids)),
        st.sampled_from(sorted(n for n, r in NODE_TYPES.items() if r.status_map is not None)),
        one_child,
    )
    counted = st.builds(
        lambda kind, n, kids: Node(
            kind,
            "r",
            tuple(kids),
            {"num_success" if kind == "PyTreesRepeat" else "num_failures": n},
        ),
        st.sampled_from(["PyTreesRepeat", "PyTreesRetry"]),
        st.integers(1, 3),
        one_child,
    )
    return st.one_of(composites, parallels, mapped, counted, btcpp_node(children))


def btcpp_node(children: st.SearchStrategy[list[Node]]) -> st.SearchStrategy[Node]:
    """A node with BehaviorTree.CPP semantics: SequenceWithMemory, Parallel with random
    thresholds, Repeat or RetryUntilSuccessful."""
    with_memory = children.map(lambda kids: Node("SequenceWithMemory", "m", tuple(kids)))
    parallel = children.flatmap(
        lambda kids: st.builds(
            lambda s, f: Node(
                "Parallel", "q", tuple(kids), {"success_count": s, "failure_count": f}
            ),
            _threshold(len(kids)),
            _threshold(len(kids)),
        )
    )
    one_child = children.filter(bool).map(lambda kids: kids[:1])
    loops = st.builds(
        lambda kind, n, kids: Node(
            kind, "l", tuple(kids), {"num_cycles" if kind == "Repeat" else "num_attempts": n}
        ),
        st.sampled_from(["Repeat", "RetryUntilSuccessful"]),
        st.integers(1, 3),
        one_child,
    )
    flows = st.builds(
        lambda kind, kids: Node(kind, "a", tuple(kids)),
        st.sampled_from(["AsyncSequence", "AsyncFallback"]),
        children.filter(bool),
    )
    branches = st.builds(
        lambda kind, kids: Node(kind, "b", tuple(kids[:3])),
        st.sampled_from(["IfThenElse", "WhileDoElse"]),
        children.filter(lambda kids: len(kids) >= 2),
    )
    parallel_all = children.filter(bool).flatmap(
        lambda kids: _threshold(len(kids)).map(
            lambda m: Node("ParallelAll", "pa", tuple(kids), {"max_failures": m})
        )
    )
    timed = st.builds(
        lambda kind, msec, kids: Node(
            kind, "t", tuple(kids), {"delay_msec" if kind == "Delay" else "msec": msec}
        ),
        st.sampled_from(["Delay", "Timeout"]),
        st.sampled_from([0, 1000, 2500]),  # iterations of the default time step, 1 s
        one_child,
    )
    guarded = st.builds(
        lambda code, otherwise, kids: Node(
            "Precondition", "g", tuple(kids), {"if": code, "else": otherwise}
        ),
        st.sampled_from(["number_ticks > 2", "number_ticks < 4 && number_ticks != 1"]),
        st.sampled_from(["FAILURE", "SUCCESS", "RUNNING"]),
        one_child,
    )
    switch = children.filter(lambda kids: len(kids) >= 3).map(
        lambda kids: Node(
            "Switch2", "w", tuple(kids[:3]),
            {"variable": BlackboardRef("number_ticks"), "case_1": "1", "case_2": "3"},
        )
    )  # fmt: skip
    once = one_child.map(lambda kids: Node("RunOnce", "o", tuple(kids), {"then_skip": False}))
    return st.one_of(
        with_memory, parallel, loops, flows, branches, parallel_all, timed, guarded, once,
        switch,
    )  # fmt: skip


def _threshold(children: int) -> st.SearchStrategy[int]:
    """A valid Parallel count for ``children`` children: 1..n or -n..-1."""
    return st.one_of(st.integers(1, children), st.integers(-children, -1))


def _renamed(root: Node) -> Node:
    """The tree with unique node names n0, n1, ... in tick order."""
    names = count()

    def visit(node: Node) -> Node:
        name = f"n{next(names)}"
        return replace(node, name=name, children=tuple(visit(c) for c in node.children))

    return visit(root)


def trees(ticks: int, agents: int, max_leaves: int = 12) -> st.SearchStrategy[Node]:
    """Random trees (a control node at the root) with uniquely named nodes."""
    leaves = scripted_leaf(ticks, agents)
    tree = st.recursive(
        leaves,
        lambda inner: control_node(st.lists(inner, min_size=1, max_size=4)),
        max_leaves=max_leaves,
    )
    return tree.filter(lambda node: node.is_control).map(_renamed).filter(_allowed)


def _allowed(root: Node) -> bool:
    """False for trees BehaviorTree.CPP refuses (two AsyncSequence under a ReactiveSequence)."""
    try:
        check_structure(root)
    except TreeError:
        return False
    return True
