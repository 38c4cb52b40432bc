"""The engine-independent tree description: a small tree of node specs.

A :class:`Node` names its type (a control node such as ``"Sequence"`` or a leaf type such
as ``"Condition_Low_Energy_Level"``), an instance name, its children and its parameters.
Engines turn a description into something they tick (one py_trees tree per agent, or a
flat program for all agents); loaders and writers turn it into files and pictures.

Build one with the helpers, which read like the paper's figures::

    reactive_fallback("root",
        sequence("low_energy", leaf("Condition_Low_Energy_Level"), ...),
        leaf("Action_Navigate_To_Destination_A", "action_navigate_to_destination_a_2"))
"""

from __future__ import annotations

import re
from collections.abc import Container, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.bt.nodes import NODE_TYPES, NodeType, skip_problem
from pyautonomousagent.bt.nodes import BlackboardRef as BlackboardRef


class TreeError(ValueError):
    """A tree description that cannot be built, with a message naming the node."""


@dataclass(frozen=True)
class Node:
    """One node of a tree description.

    Attributes:
        type: a control node type (:data:`~pyautonomousagent.bt.nodes.NODE_TYPES`) or a
            registered leaf type name.
        name: the instance name (e.g. ``"action_navigate_to_destination_a_1"``).
        children: child nodes, left (highest priority) first.
        params: parameters: ``memory`` for composites, ports for leaves.
        scripts: BehaviorTree.CPP's scripting attributes: ``_successIf``, ``_failureIf``
            (asked before a tick that does not resume the node), ``_onSuccess``,
            ``_onFailure``, ``_post`` (after a tick that finishes it), ``_onHalted`` -> code.
    """

    type: str
    name: str
    children: tuple[Node, ...] = ()
    params: Mapping[str, Any] = field(default_factory=dict)
    scripts: Mapping[str, str] = field(default_factory=dict)

    @property
    def is_control(self) -> bool:
        """True for composites and decorators, False for leaves."""
        return self.type in NODE_TYPES

    def walk(self) -> Iterator[Node]:
        """This node and all below it, depth first, left to right (tick order)."""
        yield self
        for child in self.children:
            yield from child.walk()

    def leaves(self) -> list[Node]:
        """The leaf nodes, in tick order."""
        return [n for n in self.walk() if not n.is_control]


def snake_case(type_name: str) -> str:
    """``"Action_Refuel_A"`` -> ``"action_refuel_a"``; ``"RefuelAction"`` -> ``"refuel_action"``."""
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", type_name).replace("__", "_").lower()


def sequence(name: str, *children: Node, memory: bool = True) -> Node:
    """A sequence ("→"; with ``memory=False`` the reactive sequence "R→")."""
    return Node("Sequence", name, tuple(children), {"memory": memory})


def reactive_sequence(name: str, *children: Node) -> Node:
    """A reactive sequence ("R→"): restarts from its first child on every tick."""
    return sequence(name, *children, memory=False)


def fallback(name: str, *children: Node, memory: bool = True) -> Node:
    """A fallback / selector ("?"; with ``memory=False`` the reactive fallback "R?")."""
    return Node("Fallback", name, tuple(children), {"memory": memory})


def reactive_fallback(name: str, *children: Node) -> Node:
    """A reactive fallback ("R?"): restarts from its first child on every tick."""
    return fallback(name, *children, memory=False)


def inverter(name: str, child: Node) -> Node:
    """An inverter ("≠"): swaps its child's SUCCESS and FAILURE."""
    return Node("Inverter", name, (child,))


def parallel(
    name: str, *children: Node, policy: str = "SuccessOnAll", synchronise: bool = True
) -> Node:
    """py_trees' parallel: ticks every child every tick; ``policy`` decides its success."""
    params: dict[str, Any] = {"policy": policy}
    if policy == "SuccessOnAll":
        params["synchronise"] = synchronise
    return Node("PyTreesParallel", name, tuple(children), params)


def sequence_with_memory(name: str, *children: Node) -> Node:
    """BehaviorTree.CPP's SequenceWithMemory ("→*"): after a failure it resumes at the
    failed child instead of restarting."""
    return Node("SequenceWithMemory", name, tuple(children))


def decorator(type_name: str, name: str, child: Node, **params: Any) -> Node:
    """A decorator of type ``type_name`` (e.g. ``"Repeat"``, ``num_cycles=3``)."""
    return Node(type_name, name, (child,), dict(params))


def leaf(type_name: str, name: str | None = None, **params: Any) -> Node:
    """A leaf node of a registered type; the name defaults to the type in snake case."""
    return Node(type_name, name or snake_case(type_name), (), dict(params))


def check_structure(root: Node) -> None:
    """Raise :class:`TreeError` if a control node has a wrong number of children or
    unknown parameters, or if two nodes share a name."""
    seen: set[str] = set()
    for node in root.walk():
        if node.name in seen:
            raise TreeError(f"two nodes are named {node.name!r}; give each node its own name")
        seen.add(node.name)
        if not node.is_control:
            if node.children:
                raise TreeError(f"leaf {node.name!r} ({node.type}) cannot have children")
            continue
        record = NODE_TYPES.get(node.type)
        count = len(node.children)
        if count < record.least or (record.most is not None and count > record.most):
            raise TreeError(f"{node.type} {node.name!r} needs {_arity(record)}, has {count}")
        control_params(node)
        problem = skip_problem(node)
        if problem:
            raise TreeError(problem)
        if node.type == "Sequence" and node.params.get("memory") is False:
            asynchronous = sum(child.type == "AsyncSequence" for child in node.children)
            if asynchronous > 1:
                raise TreeError(
                    f"reactive sequence {node.name!r} has {asynchronous} AsyncSequence children; "
                    "BehaviorTree.CPP allows one"
                )


def entries_read(root: Node) -> dict[str, str]:
    """Blackboard key -> the name of the first control node whose parameters read it
    (``Switch2 variable="{mode}"``); the swarm must have these keys."""
    found: dict[str, str] = {}
    for node in root.walk():
        if node.is_control:
            for param in NODE_TYPES.get(node.type).params:
                value = node.params.get(param.name)
                if param.entry and isinstance(value, BlackboardRef):
                    found.setdefault(value.key, node.name)
    return found


def check_entries(root: Node, keys: Container[str]) -> None:
    """TreeError naming the node if a control node reads a blackboard key not in ``keys``."""
    for key, name in entries_read(root).items():
        if key not in keys:
            raise TreeError(f"node {name!r} reads blackboard entry {key!r}, which no agent has")


def _arity(record: NodeType) -> str:
    """``"1 child(ren)"``, ``"at least 1 child(ren)"``, ``"2 to 3 child(ren)"``."""
    if record.least == record.most:
        return f"{record.least} child(ren)"
    if record.most is None:
        return f"at least {record.least} child(ren)"
    return f"{record.least} to {record.most} child(ren)"


def control_params(node: Node) -> dict[str, Any]:
    """A control node's parameters with defaults filled in; TreeError if one is bad."""
    record = NODE_TYPES.get(node.type)
    defaults = record.defaults()
    where = f"{node.type} {node.name!r}"
    unknown = sorted(set(node.params) - set(defaults))
    if unknown:
        raise TreeError(f"{where} has unknown parameter(s) {unknown}; it takes {sorted(defaults)}")
    values = {**defaults, **node.params}
    for param in record.params:
        value = values[param.name]
        if value is None:
            raise TreeError(f"{where} needs parameter {param.name!r}")
        problem = param.check(value, len(node.children)) if param.check else ""
        if problem:
            joint = "" if problem[0] in "=:" else " "
            raise TreeError(f"{where}: {param.name}{joint}{problem}")
    if values.get("policy") == "SuccessOnOne":
        if node.params.get("synchronise"):
            raise TreeError(f"{where}: policy SuccessOnOne cannot synchronise")
        values["synchronise"] = False
    return values
