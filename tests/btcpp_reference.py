"""Run a tree description in the real BehaviorTree.CPP (behaviortreepy) and in our engines,
with scripted leaves that log their executions and halts, one log per agent.

Our side: a test leaf type ``Logged`` (registered while :func:`logged_leaf_type` is active)
returns ``statuses[tick][agent]`` and appends ``name`` (executed) or ``~name`` (halted) to its
agent's log. BT.CPP side: one tree per agent, every leaf a stateful action dispatching on its
node name to the same script; leaves named ``c...`` never run and are conditions there
(executed on every tick, as BT.CPP means conditions to be). One iteration of ours is one
``tick_exactly_once()`` there.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

import numpy as np

from pyautonomousagent.bt.document import document_from_node
from pyautonomousagent.bt.leaf import LEAF_TYPES, Leaf
from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.status import FAILURE, RUNNING, SKIPPED, SUCCESS
from pyautonomousagent.bt.vocabulary import BTCPP_LEAVES
from pyautonomousagent.bt.xml_format import write_xml
from pyautonomousagent.engines.batched import BatchedEngine
from pyautonomousagent.engines.pytrees import PyTreesEngine
from pyautonomousagent.missions.drones import DroneMission
from pyautonomousagent.state import AgentView, Swarm
from pyautonomousagent.world import World

from .conftest import BLACKBOARD_KEYS, Harness, default_parameters, make_world

Logs = list[list[list[str]]]  # [agent][tick] -> leaf events in order


class Logged(Leaf):
    """Returns ``statuses[iteration - 1][agent]`` and logs each execution and halt."""

    type_name = "Logged"

    @classmethod
    def create(cls, params: Mapping[str, Any], defaults: Mapping[str, Any], where: str) -> Leaf:
        return cls(**params)

    @classmethod
    def port_names(cls) -> list[str]:
        return ["statuses", "log", "name"]

    def evaluate(self, agents: AgentView, world: World) -> Any:
        rows = np.atleast_1d(agents.indices)
        for row in rows:
            self.log[row].append(self.name)
        return agents.pick(np.asarray(self.statuses[world.iteration - 1], dtype=np.int8))

    def halt(self, agents: AgentView, world: World) -> None:
        for row in np.atleast_1d(agents.indices):
            self.log[row].append("~" + self.name)


@contextmanager
def logged_leaf_type() -> Iterator[None]:
    """Register the ``Logged`` leaf type for the duration of the block."""
    with LEAF_TYPES.override("Logged", Logged):
        yield


def with_logged_leaves(root: Node, table: dict[str, list[list[int]]], log: list) -> Node:
    """``root`` with each leaf replaced by a Logged leaf of its name."""
    if root.type == "Scripted":
        params = {"statuses": table[root.name], "log": log, "name": root.name}
        return replace(root, type="Logged", params=params)  # scripting attributes kept
    return replace(root, children=tuple(with_logged_leaves(c, table, log) for c in root.children))


def ours(
    tree: Node, table: dict[str, list[list[int]]], agents: int, ticks: int, engine: str
) -> tuple[list[list[int]], list[list[list[str]]]]:
    """Root statuses [tick][agent] and events [agent][tick] on one of our engines."""
    log: list[list[str]] = [[] for _ in range(agents)]
    with logged_leaf_type():
        logged = with_logged_leaves(tree, table, log)
        swarm = Swarm.create(
            [f"drone{i + 1}" for i in range(agents)],
            {**BLACKBOARD_KEYS, "gate": np.int64, "mode": np.int64},
            DroneMission.columns,
        )
        world = make_world(swarm)
        kind = PyTreesEngine if engine == "pytrees" else BatchedEngine
        h = Harness(logged, swarm, world, kind(logged, swarm, world, default_parameters()))
        roots, events = [], [[] for _ in range(agents)]
        for t in range(ticks):
            swarm.blackboard["gate"][:] = table["gate"][t]
            if "mode" in table:
                swarm.blackboard["mode"][:] = table["mode"][t]
            roots.append([int(s) for s in h.tick()[0]])
            for a in range(agents):
                events[a].append(log[a][:])
                log[a].clear()
    return roots, events


BT_STATUS = {"SUCCESS": SUCCESS, "FAILURE": FAILURE, "RUNNING": RUNNING, "SKIPPED": SKIPPED}


def btcpp_xml(tree: Node) -> str:
    """The tree as we write it, with the leaves' ports left out (BT.CPP knows none)."""
    document = document_from_node(tree)
    for raw in document.trees[document.main].walk():
        if not raw.children and raw.tag == "Scripted":
            raw.ports = {}
            if (raw.name or "").startswith("c"):
                raw.tag = "ScriptedCondition"
    return write_xml(document)


def reference(
    tree: Node, table: dict[str, list[list[int]]], agents: int, ticks: int
) -> tuple[list[list[int]], list[list[list[str]]]]:
    """Root statuses [tick][agent] and events [agent][tick] in BehaviorTree.CPP."""
    import behaviortreepy as btpy

    xml = btcpp_xml(tree)
    roots: list[list[int]] = [[0] * agents for _ in range(ticks)]
    events: list[list[list[str]]] = [[] for _ in range(agents)]
    for agent in range(agents):
        tick = [0]
        log: list[str] = []

        def run(node: Any, log: list[str] = log, tick: list[int] = tick, agent: int = agent) -> Any:
            name = node.name()
            log.append(name)
            code = table[name][tick[0]][agent]
            return {SUCCESS: btpy.NodeStatus.SUCCESS, FAILURE: btpy.NodeStatus.FAILURE}.get(
                code, btpy.NodeStatus.RUNNING
            )

        def halted(node: Any, log: list[str] = log) -> None:
            log.append("~" + node.name())

        factory = btpy.BehaviorTreeFactory()
        factory.register_simple_stateful_action("Scripted", run, run, halted)
        factory.register_simple_condition("ScriptedCondition", run)
        bt_tree = factory.create_tree_from_text(xml)
        board = bt_tree.root_blackboard()
        for t in range(ticks):
            tick[0] = t
            board.set_int("gate", int(table["gate"][t][agent]))
            if "mode" in table:
                board.set_string("mode", str(table["mode"][t][agent]))
            status = bt_tree.tick_exactly_once()
            roots[t][agent] = BT_STATUS[str(status).split(".")[-1]]
            events[agent].append(log[:])
            log.clear()
    return roots, events


def btcpp_text(xml: str) -> str:
    """A tree file as BT.CPP loads it with our leaf types registered there: our leaves' ports
    left out (nodes registered from Python cannot declare ports), ``name`` and the ``_``
    attributes kept; BT.CPP's own nodes unchanged."""
    root = ET.fromstring(xml)
    for tree in root.iter("BehaviorTree"):
        for element in tree.iter():
            if element.tag in LEAF_TYPES and element.tag not in BTCPP_LEAVES:
                for key in list(element.attrib):
                    if key != "name" and not key.startswith("_"):
                        del element.attrib[key]
    return ET.tostring(root, encoding="unicode")


def btcpp_factory_with_our_leaves() -> Any:
    """A BT.CPP factory with every registered leaf type of ours (that BT.CPP lacks) as a
    stateful action returning SUCCESS."""
    import behaviortreepy as btpy

    factory = btpy.BehaviorTreeFactory()
    for name in LEAF_TYPES.names():
        if name not in BTCPP_LEAVES:
            factory.register_simple_stateful_action(
                name, lambda node: btpy.NodeStatus.SUCCESS, lambda node: btpy.NodeStatus.SUCCESS
            )
    return factory
