"""The py_trees engine: one real py_trees tree per agent, ticked agent by agent.

This is the didactic path of the paper. Library leaves become :class:`LeafBehaviour`
adapters around the engine-independent :class:`~pyautonomousagent.bt.leaf.Leaf`; a
hand-written :class:`AgentBehaviour` subclass (override ``update()`` as in py_trees) can be
registered under a type name with :func:`register_behaviour` and used in any tree.
"""

from __future__ import annotations

import operator
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from functools import cache
from typing import Any

import numpy as np
import py_trees
from py_trees.common import Status

from pyautonomousagent.bt.behaviours import BEHAVIOUR_TYPES
from pyautonomousagent.bt.leaf import ENGINE_LEAF_TYPES, Leaf, check_leaves, make_leaf
from pyautonomousagent.bt.nodes import CONTROL, NODE_TYPES, may_skip
from pyautonomousagent.bt.script_leaves import time_step
from pyautonomousagent.bt.spec import Node, TreeError, check_entries, control_params
from pyautonomousagent.bt.status import invalid_status
from pyautonomousagent.engines.btcpp import BTCPP_BEHAVIOURS, TO_PYTREES, halt_all, with_scripts
from pyautonomousagent.engines.pytrees_rules import tick_method
from pyautonomousagent.state import AgentView, Swarm
from pyautonomousagent.world import World

#: id(py_trees status) -> status code: an int key hashes in C, an Enum member in Python.
_CODE_BY_ID = {id(v): k for k, v in TO_PYTREES.items()}
_STATUS = operator.attrgetter("status")


class AgentBehaviour(py_trees.behaviour.Behaviour):
    """A py_trees behaviour that belongs to one agent.

    Subclass it and override ``update()`` (and ``initialise()``/``terminate()`` if
    needed), reading and writing ``self.agent`` (e.g. ``self.agent.energy``,
    ``self.agent.blackboard.x_current_destination_position``). Every tick adds one to the
    agent's ``number_ticks``.
    """

    def __init__(self, name: str, agent: AgentView, world: World, **params: Any) -> None:
        super().__init__(name)
        self.agent = agent
        self.world = world
        self.params = params
        self._ticks = agent.swarm.blackboard["number_ticks"]
        self._row = agent.index

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """Count the tick on the blackboard, then tick as py_trees does."""
        self._ticks[self._row] += 1
        yield from super().tick()


class LeafBehaviour(AgentBehaviour):
    """A library leaf (engine-independent :class:`Leaf`) run for one agent by py_trees.

    It counts its ticks in ``update()``, which py_trees calls once per tick, sparing the
    extra generator of :meth:`AgentBehaviour.tick` on this hot path. ``tick`` and ``stop``
    do what py_trees' own do, without their debug-log lines (whose text py_trees builds on
    every call, logging on or not) and without checking the status ``update`` returns
    (always one of :data:`TO_PYTREES`).
    """

    def __init__(self, name: str, leaf: Leaf, agent: AgentView, world: World) -> None:
        super().__init__(name, agent, world)
        self.leaf = leaf

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """py_trees' ``Behaviour.tick`` for a leaf: update, take the status, yield itself.

        py_trees would also call ``initialise()`` (a no-op here) unless RUNNING, and
        ``stop(new_status)`` unless RUNNING, which only takes the status: ``terminate`` acts
        on INVALID alone, and ``update`` never returns it.
        """
        self.status = self.update()
        yield self

    def stop(self, new_status: Status) -> None:
        """py_trees' ``Behaviour.stop``: terminate, then take the status (its ``iterator``,
        which py_trees never reads, is left as it is)."""
        self.terminate(new_status)
        self.status = new_status

    def update(self) -> Status:
        """Count the tick, then evaluate the leaf for this agent."""
        self._ticks[self._row] += 1
        code = self.leaf.evaluate(self.agent, self.world)
        if not code:
            raise TreeError(invalid_status(self.name, self.leaf.type_name))
        return TO_PYTREES[code]

    def terminate(self, new_status: Status) -> None:
        """A RUNNING leaf stopped from outside (halted) tells its leaf."""
        if new_status == Status.INVALID and self.status == Status.RUNNING:
            self.leaf.halt(self.agent, self.world)


def register_behaviour(type_name: str) -> Callable[[type[AgentBehaviour]], type[AgentBehaviour]]:
    """Class decorator: use an :class:`AgentBehaviour` subclass as leaf type ``type_name``.

    Such a leaf runs on the py_trees engine only.
    """

    def register(cls: type[AgentBehaviour]) -> type[AgentBehaviour]:
        BEHAVIOUR_TYPES.register(type_name, cls)
        ENGINE_LEAF_TYPES.add(type_name)  # tree files may use it
        return cls

    return register


def build_behaviour(
    node: Node, agent: AgentView, world: World, defaults: Mapping[str, Any]
) -> py_trees.behaviour.Behaviour:
    """The py_trees tree of one agent for a (checked) tree description."""
    children = [build_behaviour(c, agent, world, defaults) for c in node.children]
    if node.is_control:  # a type with a rule and no entry of PYTREES_NODES: its rule's class
        if node.type in PYTREES_NODES or NODE_TYPES[node.type].rule is None:
            behaviour = PYTREES_NODES[node.type](node.name, children, control_params(node))
        else:
            behaviour = _rule_behaviour(node, children, time_step(defaults))
        if hasattr(behaviour, "bind"):  # nodes that read the blackboard or the clock
            behaviour.bind(agent, world, defaults)
    elif node.type in BEHAVIOUR_TYPES:
        behaviour = BEHAVIOUR_TYPES[node.type](node.name, agent, world, **dict(node.params))
    else:
        behaviour = LeafBehaviour(node.name, make_leaf(node, defaults), agent, world)
    return with_scripts(behaviour, node.scripts, agent) if node.scripts else behaviour


def _parallel(
    name: str, children: list[py_trees.behaviour.Behaviour], params: dict[str, Any]
) -> py_trees.behaviour.Behaviour:
    policies = py_trees.common.ParallelPolicy
    policy = (
        policies.SuccessOnOne()
        if params["policy"] == "SuccessOnOne"
        else policies.SuccessOnAll(synchronise=params["synchronise"])
    )
    return py_trees.composites.Parallel(name, policy, children)


class _Ruled(py_trees.behaviour.Behaviour):
    """A node type with a rule, for one agent: its class's ``tick`` is the rule written for
    its shape (:func:`~pyautonomousagent.engines.pytrees_rules.tick_method`), its memory
    ``m0``, ``m1``, ... (0 before it is first set), its clock ``world.iteration``, its
    agent's blackboard ``board``."""

    def bind(self, agent: AgentView, world: World, defaults: Mapping[str, Any]) -> None:
        self.world, self.board = world, agent.blackboard

    def update(self) -> Status:  # pragma: no cover - tick() does the work
        return self.status

    def stop(self, new_status: Status = Status.INVALID) -> None:
        """Halted (INVALID): the children are halted too; take the status (py_trees' ``stop``
        without its debug lines, whose text it builds on every call)."""
        if new_status == Status.INVALID:
            setattr(self, "current_child", None)  # noqa: B010 - a composite's, py_trees' type
            halt_all(self.children)
        self.terminate(new_status)
        self.status = new_status


class RuleComposite(_Ruled, py_trees.composites.Composite):
    """A control node type with a rule, as a py_trees composite."""

    def __init__(self, name: str, children: list[Any], slots: int) -> None:
        super().__init__(name, children)
        self.__dict__.update((f"m{slot}", 0) for slot in range(slots))


class RuleDecorator(_Ruled, py_trees.decorators.Decorator):
    """A decorator type with a rule, as a py_trees decorator."""

    def __init__(self, name: str, children: list[Any], slots: int) -> None:
        super().__init__(name=name, child=children[0])
        self.__dict__.update((f"m{slot}", 0) for slot in range(slots))


@cache
def _rule_class(type_name: str, *shape: Any) -> type:
    """The py_trees class of a node type with a rule, for one shape (``tick_method``'s)."""
    record = NODE_TYPES.get(type_name)
    base = RuleComposite if record.kind == CONTROL else RuleDecorator
    tick = tick_method(type_name, *shape)
    return type(type_name, (base,), {"tick": tick, "__doc__": record.tags[0].doc})


def _rule_behaviour(node: Node, children: list[Any], step: float) -> py_trees.behaviour.Behaviour:
    """The py_trees behaviour of a node whose type has a rule (``step``: the time step, s)."""
    params = tuple(sorted(control_params(node).items()))
    skippable = tuple(may_skip(child) for child in node.children)
    cls = _rule_class(node.type, len(children), params, skippable, step)
    return cls(node.name, children, NODE_TYPES[node.type].memory)


_decorators = py_trees.decorators
#: Node type -> py_trees behaviour, called with (name, children, parameters): one entry per
#: record of :data:`~pyautonomousagent.bt.nodes.NODE_TYPES` without a rule; py_trees' own
#: node types are py_trees' classes, the others BT.CPP's (``engines/btcpp.py``). A type with
#: a rule is a class derived from it (:func:`_rule_class`) unless given an entry here.
PYTREES_NODES: dict[str, Callable[[str, list[Any], dict[str, Any]], Any]] = {
    "PyTreesParallel": _parallel,
    "PyTreesRepeat": lambda name, kids, p: _decorators.Repeat(name, kids[0], p["num_success"]),
    "PyTreesRetry": lambda name, kids, p: _decorators.Retry(name, kids[0], p["num_failures"]),
    **BTCPP_BEHAVIOURS,
}


class PyTreesEngine:
    """Phase 3 with one py_trees tree per agent.

    Args:
        tree: the tree description.
        swarm: the agents (each gets its own tree and its own blackboard row).
        world: the shared world.
        defaults: scenario parameters that supply leaf ports not set in the tree.
    """

    name = "pytrees"

    def __init__(self, tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]) -> None:
        check_leaves(tree, swarm, defaults, skip=BEHAVIOUR_TYPES)
        check_entries(tree, swarm.blackboard)
        self.tree = tree
        self.roots = [
            build_behaviour(tree, swarm.agent(i), world, defaults) for i in range(swarm.size)
        ]
        self._run: Callable[[Iterable[Any]], None] = deque(maxlen=0).extend

    def tick(self) -> None:
        """Tick every agent's tree once, in agent order (py_trees' ``tick_once``, with the
        root's generator run to its end by a zero-length deque, in C)."""
        run = self._run
        for root in self.roots:
            run(root.tick())

    def node_statuses(self) -> np.ndarray:
        """Status codes after the last tick, shape (nodes in tick order, N), int8."""
        if getattr(self, "_flat", None) is None:  # the trees never change: flatten them once
            self._flat = [b for root in self.roots for b in _preorder(root)]
        flat = self._flat
        statuses = map(id, map(_STATUS, flat))  # C-level maps: no Python frame per node
        table = np.fromiter(map(_CODE_BY_ID.__getitem__, statuses), np.int8, len(flat))
        return table.reshape(len(self.roots), -1).T


def _preorder(behaviour: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    """The behaviours of a tree in tick order (the order of :meth:`Node.walk`)."""
    nodes = [behaviour]
    for child in behaviour.children:
        nodes.extend(_preorder(child))
    return nodes
