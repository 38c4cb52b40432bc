"""BehaviorTree.CPP 4.9's TryCatch, from its documented behaviour, on every engine.

BT.CPP 4.9 documents: children 1..N-1 run as a Sequence (the try block); SUCCESS when they all
succeed; when one fails, the last child (the catch) is ticked, RUNNING while it runs, and the
node returns FAILURE whatever the catch returned; finished, it resets its children. 4.8.2
(the version of the conformance suite) lacks the node, so these tests hold the engines to
those documented rules. Leaves read their status from the blackboard (``s_<name>``), so the
compiled engine, which needs leaf kernels, runs the same trees.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pytest

from pyautonomousagent import jit
from pyautonomousagent.bt import reactive_sequence
from pyautonomousagent.bt.leaf import LEAF_TYPES, Leaf, Port
from pyautonomousagent.bt.spec import Node, TreeError, check_structure
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import LeafKernel
from pyautonomousagent.missions.drones import DroneMission
from pyautonomousagent.simulation.run import ENGINES as ENGINES_BY_NAME
from pyautonomousagent.state import AgentView, Swarm
from pyautonomousagent.world import World

from .conftest import BLACKBOARD_KEYS, default_parameters, make_world
from .test_composites import letters

CODE = {"S": SUCCESS, "F": FAILURE, "R": RUNNING}


@njit
def read_status(a: int, statuses: np.ndarray) -> int:
    """Agent ``a``'s status from its entry."""
    return statuses[a]


class FromEntry(Leaf):
    """Returns the status in blackboard entry ``key`` (set by the test before each tick)."""

    type_name = "FromEntry"
    ports = (Port("key", str, None, None, "the blackboard entry"),)
    key: str

    def evaluate(self, agents: AgentView, world: World) -> Any:
        value = getattr(agents.blackboard, self.key)
        return np.asarray(value, dtype=np.int8) if isinstance(value, np.ndarray) else int(value)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(read_status, {"statuses": self.key})


def from_entry(name: str) -> Node:
    return Node("FromEntry", name, (), {"key": f"s_{name}"})


def try_catch(*kids: Node, **params: Any) -> Node:
    return Node("TryCatch", "t", kids, params)


ENGINES = [
    "pytrees",
    "batched",
    pytest.param(
        "compiled",
        marks=pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT"),
    ),
]


def run(tree: Node, engine: str, scripts: Mapping[str, str], expected: list[str],
        ticks: list[int], board: Mapping[str, str] | None = None) -> None:  # fmt: skip
    """Tick once per row, leaf ``x`` returning ``scripts[x][tick]`` (S, F, R) and each entry
    ``k`` of ``board`` holding digit ``board[k][tick]``; assert every node's status (letters,
    tick order) and the leaf ticks of that tick."""
    names = [node.name for node in tree.walk() if not node.is_control]
    board = board or {}
    keys = {f"s_{name}": np.int64 for name in names} | dict.fromkeys(board, np.int64)
    with LEAF_TYPES.override("FromEntry", FromEntry):
        swarm = Swarm.create(["drone1"], {**BLACKBOARD_KEYS, **keys}, DroneMission.columns)
        world = make_world(swarm)
        decision = ENGINES_BY_NAME.get(engine)(tree, swarm, world, default_parameters())
        counts = swarm.blackboard["number_ticks"]
        for t, (row, leaf_ticks) in enumerate(zip(expected, ticks, strict=True)):
            for name in names:
                swarm.blackboard[f"s_{name}"][:] = CODE[scripts[name][t]]
            for key, digits in board.items():
                swarm.blackboard[key][:] = int(digits[t])
            before = int(counts[0])
            world.iteration += 1
            decision.tick()
            got = letters(decision.node_statuses()[:, 0])
            assert got == row.replace(" ", ""), f"tick {t + 1}: got {got}, want {row}"
            assert int(counts[0]) - before == leaf_ticks, f"leaf ticks at tick {t + 1}"


KIDS = (from_entry("a"), from_entry("b"), from_entry("c"))


@pytest.mark.parametrize("engine", ENGINES)
def test_try_block_that_succeeds_succeeds_and_resets(engine: str) -> None:
    run(try_catch(*KIDS), engine, {"a": "S", "b": "S", "c": "S"}, ["S III"], [2])


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("catch", ["S", "F"])
def test_a_failure_runs_the_catch_and_fails_whatever_it_returns(engine: str, catch: str) -> None:
    run(try_catch(*KIDS), engine, {"a": "S", "b": "F", "c": catch}, ["F III"], [3])


@pytest.mark.parametrize("engine", ENGINES)
def test_running_try_and_catch_children_are_resumed(engine: str) -> None:
    scripts = {"a": "RSSS", "b": "SRFS", "c": "SSRS"}
    # tick 1: a runs; 2: a done, b runs; 3: b fails: try reset, catch runs; 4: catch done
    run(try_catch(*KIDS), engine, scripts, ["R RII", "R SRI", "R IIR", "F III"], [1, 2, 2, 1])


@pytest.mark.parametrize("engine", ENGINES)
def test_a_halted_try_catch_starts_again_at_the_try_block(engine: str) -> None:
    tree = reactive_sequence("root", from_entry("g"), try_catch(*KIDS))
    scripts = {"g": "SFS", "a": "FSS", "b": "SSS", "c": "RRR"}
    # tick 1: a fails, the catch runs; 2: g fails, the catch is halted; 3: the try block again
    run(tree, engine, scripts, ["R S R IIR", "F F I III", "S S S III"], [3, 1, 3])


@pytest.mark.parametrize("engine", ENGINES)
def test_with_two_children_the_try_block_is_one_child(engine: str) -> None:
    run(try_catch(*KIDS[:2]), engine, {"a": "FS", "b": "SS"}, ["F II", "S II"], [2, 1])


def test_catch_on_halt_is_refused_in_one_line() -> None:
    with pytest.raises(TreeError, match="catch_on_halt must be false"):
        check_structure(try_catch(*KIDS, catch_on_halt=True))
    with pytest.raises(TreeError, match="needs at least 2"):
        check_structure(try_catch(KIDS[0]))
