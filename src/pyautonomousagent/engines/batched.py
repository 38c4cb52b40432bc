"""The batched engine: one tree compiled once, ticked for all agents in one pass over arrays.

The tree description is compiled into a flat program (:class:`Program`): nodes in tick
order (pre-order), each with its parent, its children and the end of its subtree, so a
subtree is the contiguous range ``[i, end[i])``. Per-node state is held per agent:

- ``status``: shape (nodes, N), int8 codes of :mod:`pyautonomousagent.bt.status`;
- ``current``: shape (nodes, N), the child index a composite remembers (py_trees'
  ``current_child``), -1 for none;
- ``counter``: shape (nodes, N), the successes of ``Repeat`` / failures of ``Retry``.

A node is ticked for the agents whose tick reaches it (a sorted index array), and every
rule of py_trees 2.x is reproduced: which children are ticked, which statuses are kept,
and which RUNNING subtrees are halted (set INVALID) and when. Leaves run their
engine-independent ``evaluate`` once for all those agents.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.bt.leaf import Leaf, check_leaves, make_leaf
from pyautonomousagent.bt.spec import STATUS_MAPS, Node, TreeError, control_params
from pyautonomousagent.bt.status import FAILURE, INVALID, NAMES, RUNNING, SUCCESS
from pyautonomousagent.engines.pytrees import BEHAVIOUR_TYPES
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

_CODES = {name: code for code, name in NAMES.items()}


@dataclass(frozen=True)
class Program:
    """A tree description flattened into tick order.

    Attributes:
        nodes: the nodes, pre-order (the order of :meth:`Node.walk`).
        parent: index of each node's parent, -1 for the root; shape (n,).
        children: the child indices of each node.
        end: one past the last node of each node's subtree; shape (n,).
        params: control parameters with defaults filled in ({} for leaves).
    """

    nodes: tuple[Node, ...]
    parent: np.ndarray
    children: tuple[tuple[int, ...], ...]
    end: np.ndarray
    params: tuple[dict[str, Any], ...]


def compile_tree(root: Node) -> Program:
    """Flatten a (checked) tree description into a :class:`Program`."""
    nodes: list[Node] = []
    parent: list[int] = []
    children: list[list[int]] = []
    end: list[int] = []

    def visit(node: Node, up: int) -> int:
        i = len(nodes)
        nodes.append(node)
        parent.append(up)
        children.append([])
        end.append(0)
        for child in node.children:
            children[i].append(visit(child, i))
        end[i] = len(nodes)
        return i

    visit(root, -1)
    params = tuple(control_params(n) if n.is_control else {} for n in nodes)
    return Program(tuple(nodes), np.asarray(parent), tuple(tuple(c) for c in children),
                   np.asarray(end), params)


def _status_table(type_name: str) -> np.ndarray:
    """Lookup table child status -> own status of a status-mapping decorator."""
    table = np.arange(len(NAMES), dtype=np.int8)
    for child, own in STATUS_MAPS[type_name].items():
        table[_CODES[child]] = _CODES[own]
    return table


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
        self.program = program = compile_tree(tree)
        self.swarm, self.world = swarm, world
        n = len(program.nodes)
        self.status = np.zeros((n, swarm.size), dtype=np.int8)
        self.current = np.full((n, swarm.size), -1, dtype=np.int16)
        self.counter = np.zeros((n, swarm.size), dtype=np.int32)
        self.leaves: dict[int, Leaf] = {
            i: make_leaf(node, defaults) for i, node in enumerate(program.nodes) if not node.is_control
        }
        self._ticks = swarm.blackboard["number_ticks"]
        self._everyone = np.arange(swarm.size)
        self._tables = {i: _status_table(node.type) for i, node in enumerate(program.nodes)
                        if node.type in STATUS_MAPS}
        self._tickers = [self._ticker(i) for i in range(n)]

    def _ticker(self, i: int) -> Callable[[np.ndarray], None]:
        node_type = self.program.nodes[i].type
        if node_type == "Sequence":
            return lambda idx: self._sequence(i, idx)
        if node_type == "Selector":
            return lambda idx: self._selector(i, idx)
        if node_type == "Parallel":
            return lambda idx: self._parallel(i, idx)
        if node_type in STATUS_MAPS or node_type in ("Repeat", "Retry"):
            return lambda idx: self._decorator(i, idx)
        return lambda idx: self._leaf(i, idx)

    def tick(self) -> None:
        """Tick the tree once for every agent."""
        self._tickers[0](self._everyone)

    def node_statuses(self) -> np.ndarray:
        """Status codes after the last tick, shape (nodes in tick order, N), int8."""
        return self.status.copy()

    # -- halting -------------------------------------------------------------------------

    def _halt(self, child: int, agents: np.ndarray) -> None:
        """py_trees' ``stop(INVALID)`` of ``child``'s subtree for ``agents``."""
        if agents.size:
            stop = self.program.end[child]
            self.status[child:stop, agents] = INVALID
            self.current[child:stop, agents] = -1

    def _halt_children(self, i: int, first: int, agents: np.ndarray) -> None:
        """Halt the children of node ``i`` from position ``first`` on."""
        kids = self.program.children[i]
        if agents.size and first < len(kids):
            stop = self.program.end[i]
            self.status[kids[first]:stop, agents] = INVALID
            self.current[kids[first]:stop, agents] = -1

    # -- nodes ---------------------------------------------------------------------------

    def _leaf(self, i: int, idx: np.ndarray) -> None:
        result = self.leaves[i].evaluate(self.swarm.agents(idx), self.world)
        self.status[i, idx] = result
        self._ticks[idx] += 1

    def _sequence(self, i: int, idx: np.ndarray) -> None:
        kids, memory = self.program.children[i], self.program.params[i]["memory"]
        status, current = self.status[i], self.current[i]
        fresh = status[idx] != RUNNING
        self._halt_children(i, 0, idx[fresh])
        if not kids:
            status[idx], current[idx] = SUCCESS, -1
            return
        start = np.where(fresh, 0, current[idx]) if memory else np.zeros(idx.size, np.int16)
        going = start == 0
        for k, child in enumerate(kids):
            if going.any():
                at = np.flatnonzero(going)
                agents = idx[at]
                current[agents] = k
                self._tickers[child](agents)
                result = self.status[child, agents]
                stopped = result != SUCCESS
                if stopped.any():
                    halted = agents[stopped]
                    if not memory:
                        self._halt_children(i, k + 1, halted)
                    status[halted] = result[stopped]
                going = np.zeros(idx.size, bool)
                going[at[~stopped]] = True
            if memory and k + 1 < len(kids):
                going |= start == k + 1
        status[idx[going]] = SUCCESS

    def _selector(self, i: int, idx: np.ndarray) -> None:
        kids, memory = self.program.children[i], self.program.params[i]["memory"]
        status, current = self.status[i], self.current[i]
        current[idx[status[idx] != RUNNING]] = 0
        if not kids:
            status[idx], current[idx] = FAILURE, -1
            return
        previous = current[idx]
        start = previous if memory else np.zeros(idx.size, np.int16)
        for k in range(int(start.max())):
            self._halt(kids[k], idx[start > k])
        going = start == 0
        for k, child in enumerate(kids):
            if going.any():
                at = np.flatnonzero(going)
                agents = idx[at]
                self._tickers[child](agents)
                result = self.status[child, agents]
                chosen = result != FAILURE
                if chosen.any():
                    winners = agents[chosen]
                    current[winners] = k
                    self._halt_children(i, k + 1, winners[previous[at[chosen]] != k])
                    status[winners] = result[chosen]
                going = np.zeros(idx.size, bool)
                going[at[~chosen]] = True
            if memory and k + 1 < len(kids):
                going |= start == k + 1
        failed = idx[going]
        status[failed], current[failed] = FAILURE, len(kids) - 1

    def _parallel(self, i: int, idx: np.ndarray) -> None:
        kids, params = self.program.children[i], self.program.params[i]
        status = self.status[i]
        self._halt_children(i, 0, idx[status[idx] != RUNNING])
        if not kids:
            status[idx] = SUCCESS
            return
        for child in kids:
            agents = idx[self.status[child, idx] != SUCCESS] if params["synchronise"] else idx
            if agents.size:
                self._tickers[child](agents)
        results = self.status[np.ix_(kids, idx)]
        success = results == SUCCESS
        won = success.all(axis=0) if params["policy"] == "SuccessOnAll" else success.any(axis=0)
        new = np.where((results == FAILURE).any(axis=0), FAILURE, np.where(won, SUCCESS, RUNNING))
        finished = new != RUNNING
        for k, child in enumerate(kids):
            self._halt(child, idx[finished & (results[k] == RUNNING)])
        status[idx] = new

    def _decorator(self, i: int, idx: np.ndarray) -> None:
        node, child = self.program.nodes[i], self.program.children[i][0]
        counter = self.counter[i]
        counter[idx[self.status[i, idx] != RUNNING]] = 0
        self._tickers[child](idx)
        result = self.status[child, idx]
        if node.type == "Repeat":
            success = result == SUCCESS
            counter[idx[success]] += 1
            done = counter[idx] == self.program.params[i]["num_success"]
            new = np.where(result == FAILURE, FAILURE, np.where(success & done, SUCCESS, RUNNING))
        elif node.type == "Retry":
            failure = result == FAILURE
            counter[idx[failure]] += 1
            again = counter[idx] < self.program.params[i]["num_failures"]
            new = np.where(failure, np.where(again, RUNNING, FAILURE), result)
        else:
            new = self._tables[i][result]
        self._halt(child, idx[(new != RUNNING) & (result == RUNNING)])
        self.status[i, idx] = new
