"""examples/patrol_laps_groot2.xml: a Groot2-style tree with scripts, a Precondition, {key}
ports, IfThenElse, Timeout, SetBlackboard and RunOnce, on both engines and in BehaviorTree.CPP.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.files import load_tree
from pyautonomousagent.bt.leaf import LEAF_TYPES, stream_key
from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.bt.vocabulary import BTCPP_LEAVES

from .btcpp_reference import btcpp_text

EXAMPLE = Path(__file__).parent.parent / "examples" / "patrol_laps_groot2.xml"
ITERATIONS = 3000  # three laps, the flight to the slot and the refuelling


def scenario(agents: int):
    return load("patrol").with_overrides(agents=agents, iterations=ITERATIONS, energy_use=0.02)


def run(engine: str, agents: int, seed: int = 1) -> Simulation:
    return Simulation.create(scenario(agents), seed=seed, engine=engine, tree=load_tree(EXAMPLE))


def test_laps_are_counted_on_the_blackboard_and_refuelling_follows_the_third():
    sim = run("batched", 1).run(progress=False)
    laps = sim.recorder.column("laps")[:, 0]
    energy = sim.recorder.column("energy")[:, 0]
    assert sim.recorder.column("laps").dtype == np.int64
    assert list(np.unique(laps)) == [0, 1, 2, 3]
    third = int(np.argmax(laps == 3))
    back = third + int(np.argmax(laps[third:] == 0))  # laps := 0 after refuelling
    assert energy[back] == 100.0 and energy[third:back].min() < energy[third]
    assert (sim.recorder.column("lap_limit")[1:] == 3).all()  # SetBlackboard, every tick
    assert np.allclose(sim.recorder.column("cruise")[1:], 0.1)  # read by {cruise} ports


def test_runs_unchanged_on_both_engines_with_identical_data():
    a, b = (run(engine, 3) for engine in ("pytrees", "batched"))
    for t in range(ITERATIONS):
        a.step()
        b.step()
        assert np.array_equal(a.engine.node_statuses(), b.engine.node_statuses()), t
    for key in a.recorder.columns:
        assert np.array_equal(a.recorder.column(key), b.recorder.column(key)), key


# -- the same leaf executions in BehaviorTree.CPP -------------------------------------------------


@contextmanager
def logged_leaves(tree: Node, log: list[tuple[int, str, int]]) -> Iterator[None]:
    """Every leaf type of ``tree`` that BT.CPP does not have logs (iteration, name, status)
    of agent 0's executions, and (iteration, "~name", 0) of its halts."""
    names = {stream_key(n.name): n.name for n in tree.leaves()}
    used = {n.type for n in tree.leaves()} - BTCPP_LEAVES
    with ExitStack() as stack:
        for type_name in sorted(used):
            base: Any = LEAF_TYPES.get(type_name)
            if not base.__module__.startswith("pyautonomousagent.missions"):
                continue

            class Logged(base):  # type: ignore[misc, valid-type]
                def evaluate(self, agents: Any, world: Any) -> Any:
                    result = super().evaluate(agents, world)
                    probe = world.iteration == 0  # simulation.fit's check before the run
                    if 0 in np.atleast_1d(agents.indices) and not probe:
                        first = int(np.asarray(result).ravel()[0])
                        log.append((world.iteration, names[self.stream], first))
                    return result

                def halt(self, agents: Any, world: Any) -> None:
                    if 0 in np.atleast_1d(agents.indices):
                        log.append((world.iteration, "~" + names[self.stream], 0))

            stack.enter_context(LEAF_TYPES.override(type_name, Logged))
        yield


def test_behaviortree_cpp_executes_the_same_leaves():
    btpy = pytest.importorskip("behaviortreepy")
    tree = load_tree(EXAMPLE)
    ours: list[tuple[int, str, int]] = []
    with logged_leaves(tree, ours):
        sim = run("batched", 1)
        roots = []
        for _ in range(ITERATIONS):
            sim.step()
            roots.append(int(sim.engine.node_statuses()[0, 0]))
    replay = {(t, name): status for t, name, status in ours if not name.startswith("~")}
    theirs: list[tuple[int, str, int]] = []
    clock = [0]
    codes = {SUCCESS: btpy.NodeStatus.SUCCESS, FAILURE: btpy.NodeStatus.FAILURE}

    def tick(node: Any) -> Any:
        status = replay.get((clock[0], node.name()), FAILURE)
        theirs.append((clock[0], node.name(), status))
        return codes.get(status, btpy.NodeStatus.RUNNING)

    def halted(node: Any) -> None:
        theirs.append((clock[0], "~" + node.name(), 0))

    factory = btpy.BehaviorTreeFactory()
    for type_name in sorted({n.type for n in tree.leaves()} - BTCPP_LEAVES):
        factory.register_simple_stateful_action(type_name, tick, tick, halted)
    bt_tree = factory.create_tree_from_text(btcpp_text(EXAMPLE.read_text()))
    bt_roots = []
    for t in range(1, ITERATIONS + 1):
        clock[0] = t
        bt_roots.append(str(bt_tree.tick_exactly_once()).split(".")[-1])
    assert len(ours) > ITERATIONS  # every tick runs a leaf, some several
    assert theirs == ours
    names = {SUCCESS: "SUCCESS", FAILURE: "FAILURE", RUNNING: "RUNNING"}
    assert bt_roots == [names[r] for r in roots]
