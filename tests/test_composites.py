"""Composites and decorators on the py_trees engine, with scripted leaves.

In the style of py_trees' own tests: tiny trees, and every node's status after every tick.
A script is one letter per tick (S SUCCESS, F FAILURE, R RUNNING); a leaf that is not
ticked on some tick has a letter there that would change the outcome if it were. Expected
statuses are one letter per node in tick (``Node.walk``) order, I for INVALID.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent.bt import (
    FAILURE,
    INVALID,
    RUNNING,
    SUCCESS,
    Node,
    fallback,
    inverter,
    leaf,
    reactive_fallback,
    reactive_sequence,
    sequence,
)
from pyautonomousagent.bt.leaf import LeafError
from pyautonomousagent.bt.spec import TreeError, check_structure
from pyautonomousagent.engines.pytrees import PyTreesEngine

CODE = {"S": SUCCESS, "F": FAILURE, "R": RUNNING, "I": INVALID}
LETTER = {v: k for k, v in CODE.items()}


def scripted(name: str, *scripts: str) -> Node:
    """A Scripted leaf; one script (letters per tick) per agent."""
    table = [[CODE[script[t]] for script in scripts] for t in range(len(scripts[0]))]
    return leaf("Scripted", name, statuses=table)


def letters(column) -> str:
    return "".join(LETTER[int(c)] for c in column)


def run(h, expected: list[str], agent: int = 0, ticks_per_tick: list[int] | None = None) -> None:
    """Tick once per expected row; assert every node's status (and the leaf-tick count)."""
    names = h.names()
    counts = h.swarm.blackboard["number_ticks"]
    for t, row in enumerate(expected, start=1):
        before = int(counts[agent])
        table = h.tick()
        assert table.shape == (len(names), h.swarm.size)
        got = letters(table[:, agent])
        assert got == row.replace(" ", ""), f"tick {t}: nodes {names}: got {got}, want {row}"
        if ticks_per_tick is not None:
            assert int(counts[agent]) - before == ticks_per_tick[t - 1], f"leaf ticks at tick {t}"


def test_before_any_tick_every_node_is_invalid(harness):
    h = harness(sequence("seq", scripted("a", "S"), inverter("inv", scripted("b", "S"))))
    assert letters(h.engine.node_statuses()[:, 0]) == "IIII"
    assert h.names() == ["seq", "a", "inv", "b"]


def test_sequence_with_memory(harness):
    tree = sequence(
        "seq",
        scripted("a", "SFFSSFF"),
        scripted("b", "RSFFRFS"),
        scripted("c", "RRSFFFF"),
    )
    h = harness(tree)
    run(
        h,
        [
            "R SRI",  # a succeeds, b runs, c not reached
            "R SSR",  # resumes at b (a is not re-ticked), c runs
            "S SSS",  # resumes at c
            "F SFI",  # finished last tick: restarts from a; children reset, b fails
            "R SRI",
            "F SFI",  # resumes at b, which fails
            "F FII",  # failure reset the sequence: restarts from a, which fails
        ],
        ticks_per_tick=[2, 2, 1, 2, 2, 1, 1],
    )


def test_reactive_sequence(harness):
    tree = reactive_sequence(
        "seq",
        scripted("a", "SSFSSS"),
        scripted("b", "RSSRFS"),
        scripted("c", "FRFFFS"),
    )
    h = harness(tree)
    run(
        h,
        [
            "R SRI",
            "R SSR",  # restarts from a every tick
            "F FII",  # a fails: the RUNNING c (and b) are halted to INVALID
            "R SRI",
            "F SFI",
            "S SSS",
        ],
        ticks_per_tick=[2, 3, 1, 2, 2, 3],
    )


def test_selector_with_memory(harness):
    tree = fallback(
        "sel",
        scripted("a", "FSSSFFS"),
        scripted("b", "RRFRFRS"),
        scripted("c", "FFSFFSR"),
    )
    h = harness(tree)
    run(
        h,
        [
            "R FRI",  # a fails, b runs
            "R IRI",  # resumes at b; the skipped a is reset to INVALID
            "S IFS",  # b fails, c succeeds
            "S SFS",  # fresh start at a, which succeeds; py_trees leaves b, c as they were
            "F FFF",
            "R FRI",  # a new running child: the lower priorities are reset
            "S ISI",  # resumes at b
        ],
        ticks_per_tick=[2, 1, 2, 1, 3, 2, 1],
    )


def test_reactive_selector(harness):
    tree = reactive_fallback(
        "sel",
        scripted("a", "FSFFF"),
        scripted("b", "RSFRF"),
        scripted("c", "SSRSF"),
    )
    h = harness(tree)
    run(
        h,
        [
            "R FRI",
            "S SII",  # the higher priority a succeeds: the RUNNING b is halted to INVALID
            "R FFR",
            "R FRI",  # b takes over again: the RUNNING c is halted
            "F FFF",
        ],
        ticks_per_tick=[2, 1, 3, 2, 3],
    )


def test_inverter(harness):
    h = harness(inverter("inv", scripted("a", "SFRS")))
    run(h, ["F S", "S F", "R R", "F S"], ticks_per_tick=[1, 1, 1, 1])


def test_inverter_inside_a_sequence_as_a_guard(harness):
    # the shape of the trees' "fly to the slot until reached" branch
    tree = reactive_sequence(
        "root",
        inverter("not_c", scripted("c", "FFFSF")),
        sequence("work", scripted("x", "SFRSS"), scripted("y", "RSSSS")),
    )
    h = harness(tree)
    run(
        h,
        [
            "R SF RSR",
            "S SF SSS",  # work resumes at y
            "R SF RRI",  # root finished last tick: everything restarts
            "F FS III",  # the guard fails: the RUNNING work branch is halted
            "S SF SSS",
        ],
        ticks_per_tick=[3, 2, 2, 1, 3],
    )


def test_reactive_fallback_of_memory_sequences(harness):
    # the shape of the gathering tree's behaviours: a higher priority interrupts a lower one
    tree = reactive_fallback(
        "root",
        sequence("s1", scripted("c1", "FFSFF"), scripted("a1", "FFSFF")),
        sequence("s2", scripted("c2", "SFSFS"), scripted("a2", "RRRFS")),
        scripted("n", "SSSRF"),
    )
    h = harness(tree)
    run(
        h,
        [
            "R FFI RSR I",
            "R FFI RSR I",  # s2 resumes at a2: c2 is not re-checked
            "S SSS III I",  # s1 takes over: the RUNNING s2 is halted
            "R FFI FFI R",
            "S FFI SSS I",  # s2 takes over: the RUNNING n is halted
        ],
        ticks_per_tick=[3, 2, 2, 3, 3],
    )


def test_nested_memory_selector_inside_memory_sequence(harness):
    # the low-energy branch: condition, action, then a memory fallback that keeps its place
    tree = sequence(
        "low",
        scripted("cond", "SFFFS"),
        scripted("set", "SFFFS"),
        fallback(
            "fb",
            reactive_sequence("go", inverter("not_reached", scripted("reached", "FFSFF")),
                              scripted("nav", "RRRRR")),
            sequence("refuel_then", scripted("refuel", "RRRSF"), scripted("back", "SSSSS")),
        ),
    )  # fmt: skip
    h = harness(tree)
    run(
        h,
        [
            "R SS R RSFR III",
            "R SS R RSFR III",  # resumes at fb, inside go: reached is re-checked (reactive)
            "R SS R FFSI RRI",  # reached: go fails (nav halted), refuel runs
            "S SS S IIII SSS",  # fb resumes at refuel_then; the skipped go is reset
            "R SS R RSFR III",  # fresh start from cond
        ],
        ticks_per_tick=[4, 2, 2, 2, 4],
    )


def test_agents_have_their_own_trees(harness):
    tree = sequence(
        "seq",
        scripted("a", "SSS", "FSS"),
        scripted("b", "RSF", "RRS"),
    )
    h = harness(tree, n=2)
    expected = {0: ["R SR", "S SS", "F SF"], 1: ["F FI", "R SR", "S SS"]}
    for t in range(3):
        table = h.tick()
        for agent in (0, 1):
            assert letters(table[:, agent]) == expected[agent][t].replace(" ", "")
    assert h.swarm.blackboard["number_ticks"].tolist() == [5, 4]


def test_number_ticks_counts_leaf_ticks_only(harness):
    tree = reactive_sequence(
        "root",
        inverter("inv", scripted("a", "FFF")),
        sequence("seq", scripted("b", "SSS"), scripted("c", "SSS")),
    )
    h = harness(tree)
    for t in range(1, 4):
        h.tick()
        assert int(h.swarm.blackboard["number_ticks"][0]) == 3 * t


def test_scripted_leaf_reads_the_row_of_the_current_iteration(harness):
    h = harness(scripted("a", "SFR"))
    h.world.iteration = 2  # next tick is iteration 3
    assert letters(h.tick()[:, 0]) == "R"


def test_scripted_leaf_rejects_bad_tables(swarm_world):
    from pyautonomousagent.bt.leaf import leaf_type

    cls = leaf_type("Scripted")
    with pytest.raises(LeafError, match="statuses"):
        cls.create({"statuses": [1, 2]}, {}, "leaf 'a'")
    with pytest.raises(LeafError, match="statuses"):
        cls.create({"statuses": [[7]]}, {}, "leaf 'a'")
    with pytest.raises(LeafError, match="statuses"):
        cls.create({"statuses": [[1]], "other": 1}, {}, "leaf 'a'")
    swarm, world = swarm_world(2)
    node = cls.create({"statuses": [[1, 2], [3, 1]]}, {}, "leaf 'a'")
    world.iteration = 2
    assert node.evaluate(swarm.agent(0), world) == RUNNING
    np.testing.assert_array_equal(node.evaluate(swarm.agents(np.array([1, 0])), world), [1, 3])


# --------------------------------------------------------------------------- structure errors


def a() -> Node:
    return scripted("a", "S")


def b() -> Node:
    return scripted("b", "S")


@pytest.mark.parametrize(
    ("tree", "message"),
    [
        (Node("Inverter", "inv", (a(), b())), r"Inverter 'inv' needs 1 child\(ren\), has 2"),
        (Node("Inverter", "inv", ()), r"Inverter 'inv' needs 1 child\(ren\), has 0"),
        (sequence("root", a(), scripted("a", "F")), "two nodes are named 'a'"),
        (sequence("a", a()), "two nodes are named 'a'"),
        (sequence("root", inverter("x", a()), inverter("x", b())), "two nodes are named 'x'"),
        (Node("Scripted", "a", (b(),), {}), "leaf 'a'.*cannot have children"),
        (Node("Sequence", "s", (a(),), {"memory": True, "mem": 1}), r"unknown parameter"),
    ],
)
def test_tree_structure_errors(swarm_world, tree, message):
    with pytest.raises(TreeError, match=message):
        check_structure(tree)
    swarm, world = swarm_world(1)
    with pytest.raises(TreeError, match=message):
        PyTreesEngine(tree, swarm, world, {})


def test_tree_error_is_a_value_error():
    assert issubclass(TreeError, ValueError)
