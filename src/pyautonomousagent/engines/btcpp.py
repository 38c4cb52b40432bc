"""The py_trees engine's BehaviorTree.CPP additions: SKIPPED as a status, the scripting
attributes, and :class:`Precondition` (it asks a script of the agent's blackboard), the
one BT.CPP node type without a rule (:mod:`pyautonomousagent.bt.rules`: the others are
written once in :mod:`pyautonomousagent.bt.nodes`).

It reproduces BehaviorTree.CPP 4's documented behaviour in py_trees' terms: a halted node is
``INVALID`` (BT.CPP's ``IDLE``) and a finished node keeps its last status for display. The
batched engine does the same on arrays; docs/tree-files.md has the table.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from enum import Enum
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from pyautonomousagent.bt import status as codes
from pyautonomousagent.bt.nodes import PRE_CONDITIONS as PRE_CONDITION_CODES
from pyautonomousagent.bt.script import parse

#: The statuses of :mod:`pyautonomousagent.bt.status` that py_trees lacks (BehaviorTree.CPP's
#: SKIPPED), as one Enum whose members are named and valued as in ``NAMES``: a py_trees
#: node's ``status`` where it has one of them (neither RUNNING nor INVALID to py_trees).
BeyondPyTrees = Enum(  # type: ignore[misc]  # its members come from NAMES
    "BeyondPyTrees",
    {name: name for name in codes.NAMES.values() if name not in Status.__members__},
)

#: Status codes (:mod:`pyautonomousagent.bt.status`) as py_trees' statuses, and back: a code
#: whose name py_trees has maps to that member of ``Status``, any other to ``BeyondPyTrees``.
TO_PYTREES: dict[int, Any] = {
    code: Status[name] if name in Status.__members__ else BeyondPyTrees[name]
    for code, name in codes.NAMES.items()
}
FROM_PYTREES = {v: k for k, v in TO_PYTREES.items()}


def halt_all(children: Sequence[Behaviour]) -> None:
    """BT.CPP's ``resetChildren()``: every child not INVALID is halted (set INVALID)."""
    for child in children:
        if child.status != Status.INVALID:
            child.stop(Status.INVALID)


class Precondition(py_trees.decorators.Decorator):
    """BT.CPP ``Precondition``: ticks the child while the script ``if`` holds, asked only
    until the child runs; otherwise returns ``else``. As in BT.CPP 4.8, only the child's
    finishing makes it ask again: after a halt of the running child it is not asked once.
    The engine calls :meth:`bind` after building it."""

    def __init__(self, name: str, child: Behaviour, condition: str, otherwise: str) -> None:
        super().__init__(name=name, child=child)
        self.script = parse(condition)
        self.otherwise = Status[otherwise]
        self.running = False

    def bind(self, agent: Any, world: Any, defaults: Mapping[str, Any]) -> None:
        self.agent = agent

    def update(self) -> Status:  # pragma: no cover - tick() does the work
        return self.decorated.status

    def tick(self) -> Iterator[Behaviour]:
        """Ask the condition unless the child runs; tick the child or return ``else``."""
        if not self.running and not self.script.truth(self.agent.blackboard):
            self.status = self.otherwise
            yield self
            return
        yield from self.decorated.tick()
        self.running = self.decorated.status == Status.RUNNING
        self.status = self.decorated.status
        yield self


#: :data:`~pyautonomousagent.bt.nodes.PRE_CONDITIONS` with py_trees' statuses.
PRE_CONDITIONS: tuple[tuple[str, Any, bool, bool], ...] = tuple(
    (key, TO_PYTREES[code], *rest) for key, code, *rest in PRE_CONDITION_CODES
)


def with_scripts(behaviour: Behaviour, scripts: Mapping[str, str], agent: Any) -> Behaviour:
    """Give ``behaviour`` BehaviorTree.CPP's scripting attributes, run on ``agent``'s
    blackboard: the pre-conditions (``_failureIf``, ``_successIf``, ``_skipIf``, ``_while``)
    decide without a tick (``_while`` also halts a RUNNING node); after a tick that
    finishes the node, ``_onSuccess`` or ``_onFailure``, then ``_post`` (as BT.CPP 4.8: not
    after RUNNING); ``_onHalted`` when a RUNNING node is halted, after its children's."""
    parsed = {key: parse(code) for key, code in scripts.items()}
    board = agent.blackboard
    tick, stop = behaviour.tick, behaviour.stop

    def post() -> None:
        if behaviour.status == Status.SUCCESS and "_onSuccess" in parsed:
            parsed["_onSuccess"].run(board)
        elif behaviour.status == Status.FAILURE and "_onFailure" in parsed:
            parsed["_onFailure"].run(board)
        if "_post" in parsed and behaviour.status in (Status.SUCCESS, Status.FAILURE):
            parsed["_post"].run(board)

    def scripted_tick() -> Iterator[Behaviour]:
        for key, status, holds, running in PRE_CONDITIONS:
            asked = running or behaviour.status != Status.RUNNING
            if key in parsed and asked and bool(parsed[key].truth(board)) == holds:
                if behaviour.status == Status.RUNNING:
                    behaviour.stop(Status.INVALID)
                behaviour.status = status
                post()
                yield behaviour
                return
        for node in tick():
            if node is behaviour:  # its last step: parents decide on seeing it
                post()
            yield node

    def scripted_stop(new_status: Status = Status.INVALID) -> None:
        halted = new_status == Status.INVALID and behaviour.status == Status.RUNNING
        stop(new_status)
        if halted and "_onHalted" in parsed:
            parsed["_onHalted"].run(board)

    behaviour.tick = scripted_tick  # type: ignore[method-assign]
    behaviour.stop = scripted_stop  # type: ignore[method-assign]
    return behaviour


#: Node type -> py_trees behaviour, called with (name, children, parameters).
BTCPP_BEHAVIOURS: dict[str, Callable[[str, list[Behaviour], dict[str, Any]], Behaviour]] = {
    "Precondition": lambda name, kids, p: Precondition(name, kids[0], p["if"], p["else"]),
}
