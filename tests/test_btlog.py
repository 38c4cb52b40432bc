"""Groot2 logs: our .btlog decodes to the recorded trace and is laid out as the real
BehaviorTree.CPP's FileLogger2 writes it (behaviortreepy, the Python binding of BT.CPP 4)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from pyautonomousagent.bt.spec import leaf, reactive_fallback, sequence
from pyautonomousagent.bt.status import (
    BTCPP_CODES,
    FAILURE,
    INVALID,
    NAMES,
    RUNNING,
    SKIPPED,
    SUCCESS,
)
from pyautonomousagent.render.btlog import (
    MAGIC,
    RECORD,
    USEC_PER_ITERATION,
    read_btlog,
    transitions,
    write_btlog,
)
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation

#: One agent's scripted leaf statuses, one row per tick: c, a, b.
SCRIPT = {
    "c": [FAILURE, SUCCESS, SUCCESS, SUCCESS, FAILURE],
    "a": [SUCCESS, RUNNING, RUNNING, SUCCESS, SUCCESS],
    "b": [RUNNING, RUNNING, SUCCESS, SUCCESS, SUCCESS],
}


def tiny_tree():
    def scripted(name: str):
        return leaf("Scripted", name, statuses=[[s] for s in SCRIPT[name]])

    return reactive_fallback("root", sequence("seq", scripted("c"), scripted("a")), scripted("b"))


@pytest.fixture(scope="module")
def ours(tmp_path_factory: pytest.TempPathFactory):
    tree = tiny_tree()
    scenario = load("gathering").with_overrides(agents=1, iterations=len(SCRIPT["c"]))
    sim = Simulation.create(scenario, tree=tree, engine="batched").run(progress=False)
    recorder = sim.recorder
    path = tmp_path_factory.mktemp("btlog") / "drone1.btlog"
    write_btlog(path, tree, recorder.iterations[: recorder.count], recorder.trace(0))
    return path, recorder


#: Run in a fresh interpreter: BehaviorTree.CPP's own FileLogger2 (behaviortreepy) logs the
#: tree of file ``argv[1]`` ticked with the scripted statuses ``argv[2]`` (JSON: leaf name ->
#: status names, one per tick) into ``argv[3]``; the process's end destroys the logger, whose
#: writer thread then has written every transition. (Written in the test process, the log
#: held no transition after 60 s in one of two runs of the suite on 2 workers here.)
BTCPP_LOG = textwrap.dedent(
    """
    import json, sys
    import behaviortreepy as bt

    xml, script, path = open(sys.argv[1]).read(), json.loads(sys.argv[2]), sys.argv[3]
    tick = {"n": 0}

    def status(node):
        return getattr(bt.NodeStatus, script[node.name()][tick["n"]])

    factory = bt.BehaviorTreeFactory()
    factory.register_simple_stateful_action("Scripted", status, status)
    tree = factory.create_tree_from_text(xml)
    logger = bt.FileLogger(tree, path)
    for tick["n"] in range(len(script["c"])):
        tree.tick_once()
    logger.flush()
    """
)


@pytest.fixture(scope="module")
def theirs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A log written by BehaviorTree.CPP's own FileLogger2 for the same tree and script."""
    pytest.importorskip("behaviortreepy")
    from pyautonomousagent.render.btlog import tree_xml

    folder = tmp_path_factory.mktemp("btcpp")
    # BT.CPP refuses ports its node type does not declare: the same tree without them.
    (folder / "tree.xml").write_text(re.sub(r' statuses="[^"]*"', "", tree_xml(tiny_tree())))
    script = json.dumps({name: [NAMES[s] for s in column] for name, column in SCRIPT.items()})
    path = folder / "btcpp.btlog"
    done = subprocess.run(
        [sys.executable, "-c", BTCPP_LOG, str(folder / "tree.xml"), script, str(path)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return path


def test_our_log_decodes_to_the_recorded_transitions(ours):
    path, recorder = ours
    log = read_btlog(path)
    iterations, trace = recorder.iterations[: recorder.count], recorder.trace(0)
    assert np.array_equal(log.transitions, transitions(iterations, trace))
    # Replaying the transitions gives back every recorded status.
    from_btcpp = {theirs: ours for ours, theirs in BTCPP_CODES.items()}
    state = np.full(trace.shape[1], INVALID)
    for row, iteration in enumerate(iterations):
        due = log.transitions[log.transitions["usec"] == iteration * USEC_PER_ITERATION]
        for record in due:
            state[record["uid"] - 1] = from_btcpp[int(record["status"])]
        assert np.array_equal(state, trace[row]), f"iteration {iteration}"
    # The script shows up: b RUNNING at tick 1, a RUNNING at tick 2, c FAILURE at tick 5.
    assert trace[1].tolist()[4] == RUNNING and trace[2].tolist()[3] == RUNNING
    assert trace[5].tolist()[2] == FAILURE


def nodes_of(xml: str) -> list[tuple[str, str, str]]:
    root = ET.fromstring(xml)
    tree = root.find("BehaviorTree")
    assert tree is not None and tree.get("_fullpath") == ""
    return [(e.tag, e.get("name", ""), e.get("_uid", "")) for e in tree.iter() if e is not tree]


def test_header_and_layout_match_behaviortree_cpp(ours, theirs):
    ours_bytes, theirs_bytes = ours[0].read_bytes(), theirs.read_bytes()
    for data in (ours_bytes, theirs_bytes):
        assert data[:18] == MAGIC and data[18] == 1
        size = int.from_bytes(data[19:23], "little")
        xml = data[23 : 23 + size].decode("utf-8")
        assert xml.lstrip().startswith('<root BTCPP_format="4"')
        assert xml.rstrip().endswith("</root>") and "<TreeNodesModel>" in xml
        start = int.from_bytes(data[23 + size : 31 + size], "little")
        assert start > 0
        assert (len(data) - 31 - size) % RECORD == 0  # whole 9-byte records
    log_ours, log_theirs = read_btlog(ours[0]), read_btlog(theirs)
    # The same nodes with the same uids, in the same order.
    assert nodes_of(log_ours.xml) == nodes_of(log_theirs.xml)
    assert nodes_of(log_ours.xml)[:2] == [
        ("ReactiveFallback", "root", "1"),
        ("Sequence", "seq", "2"),
    ]
    for log in (log_ours, log_theirs):
        assert len(log.transitions) > 0
        assert set(log.transitions["uid"]) <= {1, 2, 3, 4, 5}
        assert set(log.transitions["status"]) <= {0, 1, 2, 3}
        assert np.all(np.diff(log.transitions["usec"].astype(np.int64)) >= 0)
    # Both logs see the leaves RUNNING and SUCCESS, and the root finishing.
    for log in (log_ours, log_theirs):
        seen = {(int(r["uid"]), int(r["status"])) for r in log.transitions}
        assert {(5, 1), (4, 1), (1, 2), (3, 3)} <= seen


def test_write_btlog_refuses_another_ending(tmp_path, ours):
    _, recorder = ours
    with pytest.raises(ValueError, match=r"\.btlog"):
        write_btlog(tmp_path / "x.log", tiny_tree(), recorder.iterations, recorder.trace(0))


def test_every_status_has_its_behaviortree_cpp_code():
    # A skipped node (a _skipIf, a RunOnce that ran) is logged as BT.CPP's SKIPPED, 4.
    assert set(BTCPP_CODES) == set(NAMES)
    assert sorted(BTCPP_CODES.values()) == list(range(len(NAMES)))
    trace = np.array([[SUCCESS, INVALID], [SKIPPED, RUNNING], [SKIPPED, FAILURE]], np.int8)
    log = transitions(np.array([0, 1, 2]), trace, usec_per_iteration=10)
    assert log["usec"].tolist() == [0, 10, 10, 20]
    assert log["uid"].tolist() == [1, 1, 2, 2]
    assert log["status"].tolist() == [2, 4, 1, 3]
