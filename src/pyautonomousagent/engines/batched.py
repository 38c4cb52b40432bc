"""The batched engine: one tree compiled once, ticked for all agents in one pass over arrays.

The tree description is compiled into a flat program (:class:`Program`): nodes in tick
order (pre-order), each with its parent, its children and the end of its subtree, so a
subtree is the contiguous range ``[i, end[i])``. Per-node state is held per agent:

- ``status``: shape (nodes, N), int8 codes of :mod:`pyautonomousagent.bt.status`;
- ``counter``: per control node without a rule, shape (N,), what it remembers: the
  successes / failures of PyTreesRepeat / PyTreesRetry, whether a Precondition's child runs,
  a Switch's running child (a rule's ``memory`` has rows of its own:
  :func:`~pyautonomousagent.engines.batched_rules.rule_ticker`).

A node is ticked for the agents whose tick reaches it (a boolean mask), and every
rule of py_trees 2.x is reproduced: which children are ticked, which statuses are kept,
and which RUNNING subtrees are halted (set INVALID) and when. A node type with a rule
(:mod:`pyautonomousagent.bt.rules`) runs its rule written as NumPy code over masks
(:mod:`pyautonomousagent.engines.batched_rules`); the others have a method here. Leaves run their
engine-independent ``evaluate`` once for all those agents.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from pyautonomousagent.allocator import reuse_freed_memory
from pyautonomousagent.bt.behaviours import BEHAVIOUR_TYPES
from pyautonomousagent.bt.leaf import Leaf, check_leaves, make_leaf
from pyautonomousagent.bt.nodes import NODE_TYPES, PRE_CONDITIONS
from pyautonomousagent.bt.program import compile_tree
from pyautonomousagent.bt.script import Script, parse
from pyautonomousagent.bt.spec import Node, TreeError, check_entries
from pyautonomousagent.bt.status import (
    FAILURE,
    INVALID,
    NAMES,
    RUNNING,
    SUCCESS,
    invalid_status,
)
from pyautonomousagent.engines.batched_rules import rule_ticker
from pyautonomousagent.state import AgentView, Swarm
from pyautonomousagent.world import World

_CODES = {name: code for code, name in NAMES.items()}


def _some(mask: np.ndarray) -> bool:
    """Whether any entry of ``mask`` holds (``count_nonzero`` costs a quarter of ``any()``
    on a thousand entries)."""
    return bool(np.count_nonzero(mask))


class BatchedEngine:
    """Phase 3 for all agents at once, with exactly the py_trees engine's semantics.

    Args:
        tree: the tree description.
        swarm: the agents.
        world: the shared world.
        defaults: scenario parameters that supply leaf ports not set in the tree.

    Raises:
        TreeError: the tree has a hand-written py_trees behaviour (no batched form), or
            any error the py_trees engine would raise for it.
    """

    name = "batched"

    def __init__(self, tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]) -> None:
        for node in tree.leaves():
            if node.type in BEHAVIOUR_TYPES:
                raise TreeError(
                    f"node {node.name!r} ({node.type}) is a hand-written py_trees behaviour with "
                    "no batched form; run this tree with the pytrees engine"
                )
        check_leaves(tree, swarm, defaults)
        check_entries(tree, swarm.blackboard)
        reuse_freed_memory()
        self.program = program = compile_tree(tree)
        self.swarm, self.world, self.defaults = swarm, world, defaults
        n = len(program.nodes)
        self.status = np.zeros((n, swarm.size), dtype=np.int8)
        self.counter = {
            i: np.zeros(swarm.size, dtype=np.int64)
            for i, node in enumerate(program.nodes)
            if node.is_control and NODE_TYPES.get(node.type).rule is None
        }
        self.leaves: dict[int, Leaf] = {
            i: make_leaf(node, defaults)
            for i, node in enumerate(program.nodes)
            if not node.is_control
        }
        self._halting = [i for i, leaf in self.leaves.items() if type(leaf).halt is not Leaf.halt]
        self._ticks = swarm.blackboard["number_ticks"]
        self._everyone = np.ones(swarm.size, dtype=bool)
        self._all = swarm.agents(slice(None))  # the view of every agent, made once
        self._scripts: dict[int, Script] = {}
        self._attributes = {
            i: {key: parse(code) for key, code in node.scripts.items()}
            for i, node in enumerate(program.nodes)
            if node.scripts
        }
        watch = set(self._halting) | {i for i, a in self._attributes.items() if "_onHalted" in a}
        self._watched = {
            i for i in range(n) if any(i <= j < program.end[i] for j in watch)
        }  # nodes whose subtree has something to tell when halted
        self._tickers: list[Callable[[np.ndarray], None]] = []  # rule tickers hold this list
        self._tickers.extend(self._ticker(i) for i in range(n))
        for i in self._attributes:
            self._tickers[i] = self._with_scripts(i, self._tickers[i])

    def _ticker(self, i: int) -> Callable[[np.ndarray], None]:
        node = self.program.nodes[i]
        if not node.is_control:
            return lambda mask: self._leaf(i, mask)
        if NODE_TYPES.get(node.type).rule is not None:
            return rule_ticker(self, i, self.swarm.size)
        method = BATCHED_NODES[node.type]
        return lambda mask: method(self, i, mask)

    def tick(self) -> None:
        """Tick the tree once for every agent."""
        self._tickers[0](self._everyone)

    def node_statuses(self) -> np.ndarray:
        """Status codes after the last tick, shape (nodes in tick order, N), int8."""
        return self.status.copy()

    # Every node method takes ``mask``, shape (N,), bool: the agents whose tick reaches the
    # node (never empty). Methods never modify ``mask``.

    def _halt(self, child: int, mask: np.ndarray) -> None:
        """py_trees' ``child.stop(INVALID)`` for the agents of ``mask`` whose ``child`` is not
        INVALID: its whole subtree becomes INVALID. (A node that is INVALID has an INVALID
        subtree, so the child's own status decides. A composite's remembered child is not
        reset: it is only read while the composite is RUNNING.)"""
        need = mask & (self.status[child] != INVALID)
        if _some(need):
            self._tell_halted(child, need)
            np.copyto(self.status[child : self.program.end[child]], INVALID, where=need)

    def _tell_halted(self, node: int, need: np.ndarray) -> None:
        """For the agents of ``need``, the RUNNING nodes of ``node``'s subtree are halted:
        call their leaves' ``Leaf.halt`` and run their ``_onHalted`` scripts, children first
        (BT.CPP's order)."""
        if node not in self._watched:
            return
        for child in self.program.children[node]:
            self._tell_halted(child, need)
        rows = np.flatnonzero(need & (self.status[node] == RUNNING))
        if rows.size:
            if node in self.leaves and node in self._halting:
                self.leaves[node].halt(self.swarm.agents(rows), self.world)
            if "_onHalted" in self._attributes.get(node, {}):
                self._attributes[node]["_onHalted"].run(self.swarm.agents(rows).blackboard)

    def _with_scripts(self, i: int, ticker: Callable[[np.ndarray], None]) -> Callable:
        """``ticker`` with node ``i``'s scripting attributes (see engines/btcpp.py's
        ``with_scripts``): pre-conditions (``PRE_CONDITIONS``), then its tick for the
        agents they did not decide, then the post scripts by status."""
        scripts, status = self._attributes[i], self.status[i]

        def tick(mask: np.ndarray) -> None:
            going = mask.copy()
            for key, result, holds, running in PRE_CONDITIONS:
                asked = going if running else going & (status != RUNNING)
                if key in scripts and _some(asked):
                    truth = self._truth(scripts[key], asked)
                    decided = asked & (truth if holds else ~truth)
                    if running:
                        self._halt(i, decided & (status == RUNNING))
                    np.copyto(status, result, where=decided)
                    going &= ~decided
            if _some(going):
                ticker(going)
            for key, code in (("_onSuccess", SUCCESS), ("_onFailure", FAILURE)):
                ran = mask & (status == code)
                if key in scripts and _some(ran):
                    scripts[key].run(self.swarm.agents(np.flatnonzero(ran)).blackboard)
            finished = mask & ((status == SUCCESS) | (status == FAILURE))
            if "_post" in scripts and _some(finished):
                scripts["_post"].run(self.swarm.agents(np.flatnonzero(finished)).blackboard)

        return tick

    def _truth(self, script: Script, mask: np.ndarray) -> np.ndarray:
        """Where ``script`` holds, for the agents of ``mask``: shape (N,), bool."""
        rows = np.flatnonzero(mask)
        out = np.zeros(mask.size, dtype=bool)
        out[rows] = np.broadcast_to(script.truth(self.swarm.agents(rows).blackboard), rows.shape)
        return out

    def _halt_children(self, i: int, mask: np.ndarray) -> None:
        """Halt the children of node ``i`` for ``mask``."""
        if _some(mask):
            for child in self.program.children[i]:
                self._halt(child, mask)

    def _leaf(self, i: int, mask: np.ndarray) -> None:
        """Evaluate the leaf for the agents of ``mask``: as a compact group when few, as a
        masked view of all N when many (no gathering of values)."""
        reached = np.count_nonzero(mask)
        if reached == mask.size:
            result = self._evaluate(i, self._all)
            self.status[i] = result
            self._ticks += 1
        elif 4 * reached >= mask.size:
            result = self._evaluate(i, self.swarm.agents(mask))
            np.copyto(self.status[i], result, where=mask)
            np.add(self._ticks, 1, out=self._ticks, where=mask)
        else:
            rows = np.flatnonzero(mask)
            self.status[i, rows] = self._evaluate(i, self.swarm.agents(rows))
            self._ticks[rows] += 1

    def _evaluate(self, i: int, agents: AgentView) -> Any:
        """Leaf ``i``'s statuses for a group of agents; a leaf written for one agent only
        (``if agents.energy < 40:`` on an array) gets a message naming the node and the fix."""
        try:
            result = self.leaves[i].evaluate(agents, self.world)
            if not np.all(result):  # a status code 0
                node = self.program.nodes[i]
                raise TreeError(invalid_status(node.name, node.type))
            return result
        except ValueError as error:
            if "truth value of an array" not in str(error):
                raise
            node = self.program.nodes[i]
            raise TreeError(
                f"leaf {node.name!r} ({node.type}) works on one agent only: the batched engine "
                "calls it with arrays of many agents. Write its conditions with the helpers of "
                "pyautonomousagent.arrays (choose, minimum, ...) and status_if/success_if instead "
                "of if/and/or, or run the tree with engine='pytrees'"
            ) from None

    def _parallel(self, i: int, mask: np.ndarray) -> None:
        kids, params = self.program.children[i], self.program.params[i]
        status = self.status[i]
        self._halt_children(i, mask & (status != RUNNING))
        if not kids:
            np.copyto(status, SUCCESS, where=mask)
            return
        for child in kids:
            going = mask & (self.status[child] != SUCCESS) if params["synchronise"] else mask
            if _some(going):
                self._tickers[child](going)
        results = self.status[list(kids)]
        success = results == SUCCESS
        won = success.all(axis=0) if params["policy"] == "SuccessOnAll" else success.any(axis=0)
        new = np.where((results == FAILURE).any(axis=0), FAILURE, np.where(won, SUCCESS, RUNNING))
        finished = mask & (new != RUNNING)
        for k, child in enumerate(kids):
            self._halt(child, finished & (results[k] == RUNNING))
        np.copyto(status, new, where=mask)

    def _counted(self, i: int, mask: np.ndarray) -> None:
        """PyTreesRepeat (counts successes) and PyTreesRetry (counts failures), as py_trees'
        decorators."""
        node, child = self.program.nodes[i], self.program.children[i][0]
        counter = self.counter[i]
        np.copyto(counter, 0, where=mask & (self.status[i] != RUNNING))
        self._tickers[child](mask)
        result = self.status[child]
        if node.type == "PyTreesRepeat":
            success = mask & (result == SUCCESS)
            np.add(counter, 1, out=counter, where=success)
            done = success & (counter == self.program.params[i]["num_success"])
            new = np.where(result == FAILURE, FAILURE, np.where(done, SUCCESS, RUNNING))
        else:
            failure = mask & (result == FAILURE)
            np.add(counter, 1, out=counter, where=failure)
            again = counter < self.program.params[i]["num_failures"]
            new = np.where(failure, np.where(again, RUNNING, FAILURE), result)
        self._halt(child, mask & (new != RUNNING) & (result == RUNNING))  # left RUNNING
        np.copyto(self.status[i], new, where=mask)

    def _precondition(self, i: int, mask: np.ndarray) -> None:
        """Precondition; ``counter`` is 1 from a RUNNING child to its finishing, halts
        included (BT.CPP 4.8): the script is not asked then."""
        child, params = self.program.children[i][0], self.program.params[i]
        running, status = self.counter[i], self.status[i]
        asking = mask & (running == 0)
        allowed = mask & (running == 1)
        if _some(asking):
            script = self._scripts.setdefault(i, parse(params["if"]))
            allowed |= self._truth(script, asking)
        np.copyto(status, _CODES[params["else"]], where=mask & ~allowed)
        if _some(allowed):
            self._tickers[child](allowed)
            result = self.status[child]
            np.copyto(running, result == RUNNING, where=allowed)
            np.copyto(status, result, where=allowed)


#: Node type -> the method that ticks it, called with (engine, node index, mask): one entry
#: per record of :data:`~pyautonomousagent.bt.nodes.NODE_TYPES` without a rule (those with
#: one run it: :func:`~pyautonomousagent.engines.batched_rules.rule_ticker`).
BATCHED_NODES: dict[str, Callable[[BatchedEngine, int, np.ndarray], None]] = {
    "PyTreesParallel": BatchedEngine._parallel,
    "PyTreesRepeat": BatchedEngine._counted,
    "PyTreesRetry": BatchedEngine._counted,
    "Precondition": BatchedEngine._precondition,
}
