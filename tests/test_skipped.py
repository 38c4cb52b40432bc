"""BehaviorTree.CPP's SKIPPED status (4.8, as behaviortreepy runs it): RunOnce's default
``then_skip="true"``, the ``_skipIf`` and ``_while`` pre-conditions, and what Sequence,
Fallback, the status-mapping decorators and TryCatch do with a skipped child.

Same notation as test_composites.py, K for SKIPPED. The conformance suite holds random trees
with these against the real library; these tiny trees say the rules one by one.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from pyautonomousagent.bt import fallback, inverter, reactive_sequence, sequence
from pyautonomousagent.bt.files import read_document
from pyautonomousagent.bt.spec import Node, TreeError, check_structure, decorator
from pyautonomousagent.bt.status import SKIPPED

from . import test_composites
from .test_composites import scripted
from .test_try_catch import ENGINES, from_entry, run, try_catch

test_composites.LETTER[SKIPPED] = "K"


def gated(node: Node, **scripts: str) -> Node:
    return replace(node, scripts=scripts)


@pytest.mark.parametrize("engine", ENGINES)
def test_run_once_skips_after_its_child_finished(engine: str) -> None:
    tree = sequence("s", decorator("RunOnce", "o", from_entry("a")), from_entry("b"))
    scripts = {"a": "RSFF", "b": "SSSS"}
    # a runs, then succeeds once; afterwards RunOnce is SKIPPED and the sequence goes on
    # (a fresh sequence resets its children: the skipped RunOnce's child stays INVALID)
    run(tree, engine, scripts, ["R RR I", "S SS S", "S KI S", "S KI S"], [1, 2, 1, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_run_once_then_skip_false_returns_the_status_again(engine: str) -> None:
    tree = decorator("RunOnce", "o", from_entry("a"), then_skip=False)
    run(tree, engine, {"a": "FSS"}, ["F F", "F F", "F F"], [1, 0, 0])


@pytest.mark.parametrize("engine", ENGINES)
def test_a_sequence_of_skipped_children_is_skipped(engine: str) -> None:
    once = [decorator("RunOnce", f"o{k}", from_entry(k)) for k in "ab"]
    # tick 2 skips both: the sequence is SKIPPED, and the inverter passes that on
    run(inverter("i", sequence("s", *once)), engine, {"a": "SS", "b": "SS"},
        ["F S SS SS", "K K KI KI"], [2, 0])  # fmt: skip


@pytest.mark.parametrize("engine", ENGINES)
def test_a_fallback_goes_past_a_skipped_child(engine: str) -> None:
    tree = fallback("f", decorator("RunOnce", "o", from_entry("a")), from_entry("b"))
    run(tree, engine, {"a": "FF", "b": "FS"}, ["F FF F", "S KF S"], [2, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_keep_running_until_failure_runs_on_a_skipped_child(engine: str) -> None:
    tree = decorator("KeepRunningUntilFailure", "k", decorator("RunOnce", "o", from_entry("a")))
    run(tree, engine, {"a": "SS"}, ["R SS", "R KS"], [1, 0])


@pytest.mark.parametrize("engine", ENGINES)
def test_try_catch_of_skipped_try_children_is_skipped(engine: str) -> None:
    once = decorator("RunOnce", "o", from_entry("a"))
    tree = try_catch(once, from_entry("c"))
    run(tree, engine, {"a": "SS", "c": "SS"}, ["S III", "K III"], [1, 0])


SCRIPTED = ["pytrees", "batched"]  # scripting attributes: no compiled form


@pytest.mark.parametrize("engine", SCRIPTED)
def test_skip_if_skips_a_node_that_is_not_running(engine: str) -> None:
    tree = sequence("s", gated(from_entry("a"), _skipIf="gate > 0"), from_entry("b"))
    # tick 2 resumes at the running b: a is not asked again; tick 3 skips a afresh
    run(tree, engine, {"a": "SSS", "b": "RSS"}, ["R KR", "S KS", "S KS"], [1, 1, 1],
        board={"gate": "101"})  # fmt: skip


@pytest.mark.parametrize("engine", SCRIPTED)
def test_while_halts_a_running_node_and_skips_it(engine: str) -> None:
    guarded = gated(from_entry("a"), _while="gate > 0")
    tree = reactive_sequence("r", guarded, from_entry("b"))
    # tick 2: a is RUNNING and the condition no longer holds: halted, SKIPPED; b runs
    run(tree, engine, {"a": "RRR", "b": "SSS"}, ["R RI", "S KS", "R RI"], [1, 1, 1],
        board={"gate": "101"})  # fmt: skip


def test_a_skipped_child_under_a_node_without_a_rule_is_refused() -> None:
    once = decorator("RunOnce", "o", scripted("a", "S"))
    with pytest.raises(TreeError, match="Repeat 'r' cannot take child 'o', which may be SKIP"):
        check_structure(decorator("Repeat", "r", once, num_cycles=2))
    kept = replace(once, params={"then_skip": False})
    check_structure(decorator("Repeat", "r", kept, num_cycles=2))


def test_a_record_says_what_may_be_skipped_and_where_and_the_message_follows() -> None:
    from pyautonomousagent.bt.nodes import DECORATOR, NODE_TYPES, NodeType

    with NODE_TYPES.scoped():  # a new node type is its record: nothing else names it
        NODE_TYPES.register("Once2", NodeType(
            "Once2", DECORATOR, 1, 1, skipped_when=lambda params: True))  # fmt: skip
        NODE_TYPES.register("Taker", NodeType("Taker", DECORATOR, 1, 1, skips=True))
        once = decorator("Once2", "o", scripted("a", "S"))
        with pytest.raises(TreeError) as error:
            check_structure(decorator("Repeat", "r", once, num_cycles=2))
        message = str(error.value)
        assert "(_skipIf, _while, RunOnce, Once2)" in message
        assert "Sequence, Fallback, RunOnce, TryCatch, Taker or status-mapping" in message
        check_structure(decorator("Taker", "t", once))
    with pytest.raises(TreeError, match="Sequence, Fallback, RunOnce, TryCatch or status"):
        check_structure(decorator("Repeat", "r", decorator("RunOnce", "o", scripted("a", "S")),
                                  num_cycles=2))  # fmt: skip


def test_files_with_skip_attributes_and_run_once_load(tmp_path) -> None:
    path = tmp_path / "skip.xml"
    path.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="M"><Sequence>'
        "<RunOnce><Action_Refuel_A/></RunOnce>"
        '<Action_Repair_Damage_A _skipIf="energy &gt; 90" _while="true"/>'
        "</Sequence></BehaviorTree></root>"
    )
    document = read_document(path)
    assert document.main == "M"
