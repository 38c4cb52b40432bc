"""BehaviorTree.CPP's node semantics, on both engines, with scripted leaves.

Same notation as test_composites.py: a script is one letter per tick (S, F, R); expected
statuses are one letter per node in tick order (I for INVALID, BT.CPP's IDLE), and the
number of leaf ticks per tick is checked too, since BT.CPP's loops tick a child several
times within one tick.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pyautonomousagent.bt import fallback, leaf, reactive_fallback, reactive_sequence, sequence
from pyautonomousagent.bt.spec import (
    BlackboardRef,
    Node,
    TreeError,
    check_structure,
    sequence_with_memory,
)
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS

from .conftest import default_parameters
from .test_composites import letters, scripted

ENGINES = ["pytrees", "batched"]


def run(h, expected: list[str], leaf_ticks: list[int]) -> None:
    """Tick once per row; assert every node's status and the leaf ticks of that tick."""
    counts = h.swarm.blackboard["number_ticks"]
    for t, (row, ticks) in enumerate(zip(expected, leaf_ticks, strict=True), start=1):
        before = int(counts[0])
        got = letters(h.tick()[:, 0])
        assert got == row.replace(" ", ""), f"tick {t}: nodes {h.names()}: got {got}, want {row}"
        assert int(counts[0]) - before == ticks, f"leaf ticks at tick {t}"


def decorated(kind: str, child: Node, **params: int) -> Node:
    return Node(kind, "d", (child,), params)


@pytest.mark.parametrize("engine", ENGINES)
def test_sequence_with_memory_resumes_at_the_failed_child(harness, engine):
    kids = (scripted("a", "SFFF"), scripted("b", "SFSS"), scripted("c", "SSSS"))
    h = harness(sequence_with_memory("m", *kids), engine=engine)
    # a first-tick success yields (a wake-up): one child per tick; tick 3 resumes at b
    run(h, ["R SII", "F SFI", "R SSI", "S SSS"], [1, 1, 1, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_bt_sequence_restarts_after_a_failure(harness, engine):
    kids = (scripted("a", "SFF"), scripted("b", "FSS"), scripted("c", "SSS"))
    h = harness(sequence("s", *kids), engine=engine)  # BT.CPP <Sequence>
    run(h, ["F SFI", "F FII", "F FII"], [2, 1, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_sequence_with_memory_keeps_its_place_when_halted(harness, engine):
    guarded = sequence_with_memory("m", scripted("a", "SFF"), scripted("b", "RRS"))
    h = harness(reactive_fallback("rf", scripted("x", "FSF"), guarded), engine=engine)
    # tick 2: x succeeds and the reactive fallback halts m; tick 3: m resumes at b, not a
    run(h, ["R F R SI", "S S I II", "S F S IS"], [2, 1, 2])


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(
    ("script", "expected", "ticks"),
    [
        ("S", ["S S"], [1]),
        ("FFF", ["R F", "R F", "F F"], [1, 1, 1]),  # one attempt per tick (wake-ups)
        ("RF", ["R R", "R F"], [1, 2]),  # a child that was running is retried at once
        ("RS", ["R R", "S S"], [1, 1]),
    ],
)
def test_retry_until_successful_tries_again_at_the_next_tick(
    harness, engine, script, expected, ticks
):
    h = harness(
        decorated("RetryUntilSuccessful", scripted("a", script), num_attempts=3), engine=engine
    )
    run(h, expected, ticks)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(
    ("script", "expected", "ticks"),
    [
        ("SSS", ["R S", "R S", "S S"], [1, 1, 1]),
        ("F", ["F F"], [1]),
        ("RSS", ["R R", "R S", "S S"], [1, 2, 1]),
    ],
)
def test_repeat_repeats_at_the_next_tick(harness, engine, script, expected, ticks):
    h = harness(decorated("Repeat", scripted("a", script), num_cycles=3), engine=engine)
    run(h, expected, ticks)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("cycles", [-1, 99999999999999999999])
def test_endless_repeat_ticks_its_child_once_per_tick(harness, engine, cycles):
    h = harness(decorated("Repeat", scripted("a", "SSSS"), num_cycles=cycles), engine=engine)
    run(h, ["R S"] * 4, [1] * 4)


@pytest.mark.parametrize("engine", ENGINES)
def test_repeat_counts_cycles_across_ticks(harness, engine):
    child = sequence_with_memory("m", scripted("p", "SSSS"), scripted("q", "RSSS"))
    h = harness(decorated("Repeat", child, num_cycles=2), engine=engine)
    # tick 2: q (running) finishes cycle 1 and p starts cycle 2 in the same tick
    run(h, ["R R SI", "R R SS", "S S SS"], [1, 2, 1])


def parallel(*kids: Node, success: int, failure: int) -> Node:
    return Node("Parallel", "p", kids, {"success_count": success, "failure_count": failure})


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(
    ("scripts", "success", "failure", "expected", "ticks"),
    [
        (("S", "S", "S"), 1, 1, ["S S II"], [1]),  # decided after the first child
        (("RS", "SS", "RS"), -1, 1, ["R RSR", "S SSS"], [3, 2]),  # b is not ticked again
        (("F", "R", "F"), 2, 2, ["F F I F"], [3]),  # b was running: halted
        (("F", "S", "S"), -1, 3, ["F F II"], [1]),  # success became impossible
        (("R", "F", "R"), -2, 2, ["R RFR"], [3]),
    ],
)
def test_parallel_thresholds(harness, engine, scripts, success, failure, expected, ticks):
    kids = [scripted(name, script) for name, script in zip("abc", scripts, strict=True)]
    h = harness(parallel(*kids, success=success, failure=failure), engine=engine)
    run(h, expected, ticks)


@pytest.mark.parametrize("engine", ENGINES)
def test_fallback_and_reactive_fallback_are_py_trees_selectors(harness, engine):
    tree = fallback(
        "f",
        scripted("a", "FSS"),
        reactive_fallback("r", scripted("b", "RF"), leaf("Scripted", "c", statuses=[[3], [1]])),
    )
    h = harness(tree, engine=engine)
    run(h, ["R F R R I", "S I S F S"], [2, 2])


@pytest.mark.parametrize(
    ("node", "message"),
    [
        (Node("Parallel", "p", (scripted("a", "S"),), {"success_count": 2}), "asks for 2 of 1"),
        (Node("Parallel", "p", (scripted("a", "S"),), {"failure_count": 0}), "other than 0"),
        (Node("Repeat", "r", (scripted("a", "S"),), {"num_cycles": 0}), ">= 1 or -1"),
        (Node("RetryUntilSuccessful", "r", (scripted("a", "S"),)), "needs parameter"),
        (Node("SequenceWithMemory", "m", ()), "at least 1"),
    ],
)
def test_bad_btcpp_nodes_are_refused(node, message):
    with pytest.raises(TreeError, match=message):
        check_structure(node)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("reactive", [reactive_fallback, reactive_sequence])
def test_reactive_nodes_halt_a_running_child_when_an_earlier_one_runs(harness, engine, reactive):
    first = "FR" if reactive is reactive_fallback else "SR"
    h = harness(reactive("r", scripted("a", first), scripted("b", "RR")), engine=engine)
    # BT.CPP: a child returning RUNNING halts its siblings, so b (running) is halted
    run(h, [f"R {first[0]}R", "R RI"], [2, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_a_leaf_scripted_to_return_invalid_is_refused_when_the_tree_is_built(harness, engine):
    tree = fallback("f", leaf("Scripted", "a", statuses=[[0]]), scripted("b", "S"))
    with pytest.raises(TreeError, match="never returns 0"):
        harness(tree, engine=engine)


def test_more_children_than_an_int16_holds_under_one_node(harness):
    kids = [leaf("Scripted", f"k{i}", statuses=[[2], [2]]) for i in range(33_000)]
    kids.append(scripted("last", "RS"))
    h = harness(fallback("f", *kids), engine="batched")
    counts = h.swarm.blackboard["number_ticks"]
    assert letters(h.tick()[[0, -1], 0]) == "RR" and counts[0] == 33_001
    assert letters(h.tick()[[0, -1], 0]) == "SS" and counts[0] == 33_002  # resumed at the last


def test_every_node_type_record_has_both_engines_and_a_file_tag():
    from pyautonomousagent.bt.nodes import NODE_TYPES
    from pyautonomousagent.engines.batched import BATCHED_NODES
    from pyautonomousagent.engines.pytrees import PYTREES_NODES

    for name, record in NODE_TYPES.items():  # a rule is every engine's; else both by hand
        assert record.rule is not None or name in PYTREES_NODES.keys() & BATCHED_NODES, name
        assert record.tags, name


# -- time in simulated iterations: msec / (1000 x time_step), rounded up ------------------------


def timed(kind: str, msec: int, child: Node) -> Node:
    return Node(kind, "d", (child,), {"delay_msec" if kind == "Delay" else "msec": msec})


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(("time_step", "waits"), [(1.0, 2), (0.5, 4), (0.3, 7)])
def test_delay_waits_in_simulated_time(harness, engine, time_step, waits):
    defaults = {**default_parameters(), "time_step": time_step}
    h = harness(timed("Delay", 2000, scripted("a", "S" * (waits + 2))), defaults=defaults,
                engine=engine)  # fmt: skip
    run(h, ["R I"] * waits + ["S S", "R S"], [0] * waits + [1, 0])  # then a new delay


@pytest.mark.parametrize("engine", ENGINES)
def test_timeout_halts_a_child_that_runs_too_long(harness, engine):
    h = harness(timed("Timeout", 3000, scripted("a", "RRRRRS")), engine=engine)
    run(h, ["R R", "R R", "R R", "F I", "R R", "S S"], [1, 1, 1, 0, 1, 1])  # then anew


@pytest.mark.parametrize("engine", ENGINES)
def test_timeout_zero_never_fires(harness, engine):
    h = harness(timed("Timeout", 0, scripted("a", "RRRS")), engine=engine)
    run(h, ["R R", "R R", "R R", "S S"], [1, 1, 1, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_sleep_runs_then_succeeds(harness, engine):
    tree = sequence("s", leaf("Sleep", "nap", msec="1500"), scripted("a", "SSSSS"))
    run(harness(tree, engine=engine), ["R RI", "R RI", "S SS", "R RI"], [1, 1, 2, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_run_once_remembers_the_first_finish(harness, engine):
    h = harness(Node("RunOnce", "o", (scripted("a", "RFSS"),), {"then_skip": False}),
                engine=engine)  # fmt: skip
    run(h, ["R R", "F F", "F F", "F F"], [1, 1, 0, 0])


def test_script_precondition_and_ports_read_each_agents_blackboard():
    from pyautonomousagent.testing import make_harness

    tree = sequence(
        "s",
        leaf("Script", "count", code="n := n + 1; limit := n * 30"),
        Node("Precondition", "p", (
            leaf("Condition_Low_Energy_Level", "low", threshold=BlackboardRef("limit")),
        ), {"if": "n != 2", "else": "RUNNING"}),
        memory=False,
    )  # fmt: skip
    for engine in ENGINES:
        h = make_harness(tree, agents=3, scenario="patrol", engine=engine)
        h.swarm.columns["energy"][:] = [20.0, 50.0, 95.0]
        assert h.swarm.blackboard["n"].dtype == np.int64
        assert h.swarm.blackboard["limit"].dtype == np.int64
        rows = [letters(h.tick()[0]) for _ in range(4)]  # limit 30, 60, 90, 120
        assert rows == ["SFF", "RRR", "SSF", "SSS"], engine
        assert list(h.swarm.blackboard["n"]) == [4, 4, 4]


def test_tree_blackboard_keys_types_and_skips_known_keys():
    from pyautonomousagent.bt.blackboard import tree_blackboard_keys

    tree = sequence(
        "s",
        leaf("Script", "a", code="flag := x > 1; x := 2; y := x / 2; name := 'home'"),
        leaf("SetBlackboard", "b", output_key="z", value="3.5"),
        leaf("SetBlackboard", "c", output_key="energy_copy", value="{x}"),
        leaf("Script", "d", code="known := 1"),
    )
    keys = tree_blackboard_keys(tree, {"known": np.float64})
    assert keys == {
        "flag": np.dtype(bool), "x": np.dtype(np.int64), "y": np.dtype(np.float64),
        "name": np.dtype(np.int64), "z": np.dtype(np.float64), "energy_copy": np.dtype(np.int64),
    }  # fmt: skip


def test_every_node_type_is_drawn_and_written(tmp_path):
    from pyautonomousagent.bt.build import build
    from pyautonomousagent.bt.document import document_from_node
    from pyautonomousagent.bt.draw import draw_tree, to_dot
    from pyautonomousagent.bt.nodes import NODE_TYPES
    from pyautonomousagent.bt.text import to_text
    from pyautonomousagent.bt.xml_format import read_xml, write_xml

    kids = []
    for n, (name, record) in enumerate(NODE_TYPES.items()):
        params = {p.name: p.default for p in record.params if p.default is not None}
        params.update({"num_cycles": 2, "num_attempts": 2, "num_success": 2, "num_failures": 2,
                       "if": "x > 1", "delay_msec": 10, "msec": 10, "memory": True,
                       "then_skip": False})  # fmt: skip
        params = {k: v for k, v in params.items() if k in record.defaults()}
        for param in record.params:
            if param.entry:
                params[param.name] = BlackboardRef("mode")
            elif param.name.startswith("case_"):
                params[param.name] = param.name[5:]
        count = max(record.least, 1) if record.most is None else record.most
        children = tuple(leaf("AlwaysSuccess", f"k{n}_{i}") for i in range(count))
        kids.append(Node(name, f"node{n}", children, params))
    tree = Node("Sequence", "root", tuple(kids), {"memory": False})
    text, dot = to_text(tree), to_dot(tree)
    for record in NODE_TYPES.values():
        symbol = record.tags[0].symbol or record.tags[0].tag
        assert symbol in text and symbol in dot
    assert draw_tree(tree, tmp_path / "all.png").stat().st_size > 0
    assert build(read_xml(write_xml(document_from_node(tree)), "all.xml")) == tree


def test_scripting_attributes_on_both_engines():
    from pyautonomousagent.testing import make_harness

    a = replace(scripted("a", "RRRSS", "RRRSS"), scripts={
        "_failureIf": "tick == 4", "_onSuccess": "ok += 1", "_onFailure": "bad += 1",
        "_post": "done += 1", "_onHalted": "halts += 1",
    })  # fmt: skip
    tree = reactive_sequence(
        "r",
        leaf("Script", "count", code="tick := tick + 1; ok := ok; bad := bad"),
        reactive_fallback("f", leaf("ScriptCondition", "third", code="tick == 3"), a),
    )
    for engine in ENGINES:
        h = make_harness(tree, agents=2, scenario="patrol", engine=engine)
        statuses = [letters(h.tick()[4, :1]) for _ in range(5)]
        assert statuses == ["R", "R", "I", "F", "S"], engine  # halted at 3, decided at 4
        board = {k: int(h.swarm.blackboard[k][1]) for k in ("ok", "bad", "done", "halts")}
        assert board == {"ok": 1, "bad": 1, "done": 2, "halts": 1}, engine


def test_scripting_attributes_round_trip_through_files():
    from pyautonomousagent.bt.files import from_text_format, to_text_format

    xml = """<root BTCPP_format="4"><BehaviorTree ID="M">
      <Sequence _onSuccess="laps += 1">
        <AlwaysSuccess _failureIf="laps &gt; 2" _post="seen := true"/>
      </Sequence></BehaviorTree></root>"""
    tree = from_text_format(xml, "xml")
    assert tree.scripts == {"_onSuccess": "laps += 1"}
    assert tree.children[0].scripts == {"_failureIf": "laps > 2", "_post": "seen := true"}
    for fmt in ("xml", "yaml"):
        assert from_text_format(to_text_format(tree, fmt), fmt) == tree


def test_a_stale_condition_is_not_asked_its_preconditions_in_btcpp_but_is_here():
    """Documented difference: a two-child IfThenElse whose condition failed leaves it un-reset
    in BT.CPP 4.8, so at the next tick BT.CPP runs it without asking its _successIf; we ask
    _successIf whenever the node is not RUNNING (docs/tree-files.md)."""
    from .btcpp_reference import ours, reference

    condition = replace(leaf("Scripted", "c0", statuses=[[2]]), scripts={"_successIf": "gate > 0"})
    tree = Node("IfThenElse", "ite", (condition, leaf("AlwaysSuccess", "yes")))
    table = {"c0": [[FAILURE], [FAILURE]], "gate": [[0], [1]]}
    bt_roots, bt_events = reference(tree, table, 1, 2)
    for engine in ENGINES:
        roots, events = ours(tree, table, 1, 2, engine)
        assert bt_events == [[["c0"], ["c0"]]] and bt_roots == [[FAILURE], [FAILURE]]
        assert events == [[["c0"], []]] and roots == [[FAILURE], [SUCCESS]]


def test_one_iteration_is_tick_exactly_once_not_tick_once():
    """The documented decision: where BT.CPP asks for a wake-up, its tickOnce() ticks the
    tree again at once (the condition above runs twice); tickExactlyOnce() and we do not."""
    btpy = pytest.importorskip("behaviortreepy")
    from .btcpp_reference import btcpp_xml, ours

    tree = reactive_sequence(
        "r", leaf("Scripted", "l0", statuses=[[1]]),
        Node("Repeat", "again", (leaf("Scripted", "l1", statuses=[[1]]),), {"num_cycles": 2}),
    )  # fmt: skip
    table = {"l0": [[SUCCESS]], "l1": [[SUCCESS]], "gate": [[0]]}
    runs = {}
    for how in ("tick_once", "tick_exactly_once"):
        log: list[str] = []

        def run(node, log=log):
            log.append(node.name())
            return btpy.NodeStatus.SUCCESS

        factory = btpy.BehaviorTreeFactory()
        factory.register_simple_stateful_action("Scripted", run, run)
        status = getattr(factory.create_tree_from_text(btcpp_xml(tree)), how)()
        runs[how] = (str(status).split(".")[-1], log)
    assert runs["tick_once"] == ("SUCCESS", ["l0", "l1", "l0", "l1"])
    assert runs["tick_exactly_once"] == ("RUNNING", ["l0", "l1"])
    for engine in ENGINES:
        assert ours(tree, table, 1, 1, engine) == ([[RUNNING]], [[["l0", "l1"]]])


@pytest.mark.parametrize("engine", ENGINES)
def test_a_leaf_returning_invalid_is_refused_on_both_engines(harness, engine):
    from pyautonomousagent.bt.leaf import LEAF_TYPES, Leaf

    class Confused(Leaf):
        type_name = "Confused"

        def evaluate(self, agents, world):
            return 0

    with LEAF_TYPES.override("Confused", Confused):
        h = harness(fallback("f", leaf("Confused", "c"), scripted("b", "S")), engine=engine)
        with pytest.raises(TreeError, match=r"'c' \(Confused\) returned INVALID \(0\)"):
            h.tick()
