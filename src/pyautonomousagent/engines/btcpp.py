"""BehaviorTree.CPP's control nodes that py_trees lacks, as small py_trees classes.

Each class reproduces the documented BehaviorTree.CPP 4 behaviour (which children are
ticked, what is returned, what is remembered) in py_trees' terms: a halted node is
``INVALID`` (BT.CPP's ``IDLE``) and a finished node keeps its last status for display.
The batched engine implements the same rules on arrays; docs/tree-files.md has the table.

- :class:`Loop` (``RetryUntilSuccessful`` / ``Repeat``): tick the child again *within the
  same tick* after a failure (resp. success), up to ``num_attempts`` (resp. ``num_cycles``).
- :class:`Parallel`: ticks the children that have not finished yet, left to right, and
  returns as soon as ``success_count`` children succeeded or success became impossible
  (``failure_count`` failures); running children are then halted.
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
from pyautonomousagent.bt.nodes import parallel_threshold
from pyautonomousagent.bt.program import case_values
from pyautonomousagent.bt.script import parse
from pyautonomousagent.bt.script_leaves import iterations

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


class Loop(py_trees.decorators.Decorator):
    """BT.CPP ``Repeat`` (``again`` SUCCESS: until the child has succeeded ``limit`` times,
    FAILURE at its first failure) and ``RetryUntilSuccessful`` (``again`` FAILURE: up to
    ``limit`` tries, FAILURE when they all failed): the child is ticked again within one
    tick while it returns ``again`` (``limit`` -1: for ever)."""

    def __init__(self, name: str, child: Behaviour, limit: int, again: Status) -> None:
        super().__init__(name=name, child=child)
        self.limit = limit
        self.again = again
        self.count = 0

    def tick(self) -> Iterator[Behaviour]:
        """Tick the child again while it returns ``again`` and the limit is not hit; a child
        that returned ``again`` at its first tick ends the tick instead (RUNNING, a wake-up)."""
        if self.status != Status.RUNNING:
            self.count = 0
            self.initialise()
        while True:
            fresh = self.decorated.status != Status.RUNNING
            yield from self.decorated.tick()
            result = self.decorated.status
            if result == self.again:
                self.count += 1
                if self.limit == -1 or self.count < self.limit:
                    if not fresh:
                        continue
                    self.status = Status.RUNNING
                    yield self
                    return
            break
        if result != Status.RUNNING:
            self.count = 0
            self.stop(result)
        self.status = result
        yield self

    def update(self) -> Status:  # pragma: no cover - tick() does the work
        return self.decorated.status


def halt_all(children: Sequence[Behaviour]) -> None:
    """BT.CPP's ``resetChildren()``: every child not INVALID is halted (set INVALID)."""
    for child in children:
        if child.status != Status.INVALID:
            child.stop(Status.INVALID)


class Parallel(py_trees.composites.Composite):
    """BT.CPP ``Parallel`` with ``success_count`` / ``failure_count`` thresholds.

    Args:
        name: the node's name.
        children: the children, ticked left to right.
        success_count: successes needed (-1: all children, -2: all but one, ...).
        failure_count: failures that make it fail (same convention).
    """

    def __init__(
        self, name: str, children: Sequence[Behaviour], success_count: int, failure_count: int
    ) -> None:
        super().__init__(name, list(children))
        self.need_success = parallel_threshold(success_count, len(self.children))
        self.need_failure = parallel_threshold(failure_count, len(self.children))
        self.done: set[int] = set()  # children that finished during this run

    def tick(self) -> Iterator[Behaviour]:
        """Tick the unfinished children; decide after each one, as BT.CPP does."""
        if self.status != Status.RUNNING:
            halt_all(self.children)
            self.done = set()
            self.initialise()
        for k, child in enumerate(self.children):
            if k not in self.done:
                yield from child.tick()
                if child.status != Status.RUNNING:
                    self.done.add(k)
            verdict = self._verdict()
            if verdict is not None:
                self._finish(verdict)
                yield self
                return
        self.status = Status.RUNNING
        yield self

    def _verdict(self) -> Status | None:
        """SUCCESS or FAILURE if the counts decide it now, else None."""
        successes = sum(1 for k in self.done if self.children[k].status == Status.SUCCESS)
        failures = len(self.done) - successes
        if successes >= self.need_success:
            return Status.SUCCESS
        if len(self.children) - failures < self.need_success or failures >= self.need_failure:
            return Status.FAILURE
        return None

    def _finish(self, verdict: Status) -> None:
        """Halt the children still running, forget the run, and end with ``verdict``."""
        for child in self.children:
            if child.status == Status.RUNNING:
                child.stop(Status.INVALID)
        self.done = set()
        self.stop(verdict)


class ParallelAll(py_trees.composites.Composite):
    """BT.CPP ``ParallelAll``: ticks the unfinished children until all have finished; then
    FAILURE if at least ``max_failures`` of them failed (-1: all, -2: all but one, ...)."""

    def __init__(self, name: str, children: Sequence[Behaviour], max_failures: int) -> None:
        super().__init__(name, list(children))
        self.need_failure = parallel_threshold(max_failures, len(self.children))
        self.done: set[int] = set()

    def tick(self) -> Iterator[Behaviour]:
        """Tick every unfinished child once; decide when none is left."""
        if self.status != Status.RUNNING:
            self.done = set()
            self.initialise()
        for k, child in enumerate(self.children):
            if k not in self.done:
                yield from child.tick()
                if child.status != Status.RUNNING:
                    self.done.add(k)
        if len(self.done) < len(self.children):
            self.status = Status.RUNNING
        else:
            failures = sum(1 for c in self.children if c.status == Status.FAILURE)
            self.status = Status.FAILURE if failures >= self.need_failure else Status.SUCCESS
            halt_all(self.children)
            self.done = set()
        yield self


class _Timed(py_trees.decorators.Decorator):
    """A decorator that needs the agent, the clock or the scenario's time step: the engine
    calls :meth:`bind` after building it."""

    def bind(self, agent: Any, world: Any, defaults: Mapping[str, Any]) -> None:
        self.agent, self.world, self.defaults = agent, world, defaults

    def update(self) -> Status:  # pragma: no cover - tick() does the work
        return self.decorated.status


class Precondition(_Timed):
    """BT.CPP ``Precondition``: ticks the child while the script ``if`` holds, asked only
    until the child runs; otherwise returns ``else``. As in BT.CPP 4.8, only the child's
    finishing makes it ask again: after a halt of the running child it is not asked once."""

    def __init__(self, name: str, child: Behaviour, condition: str, otherwise: str) -> None:
        super().__init__(name=name, child=child)
        self.script = parse(condition)
        self.otherwise = Status[otherwise]
        self.running = False

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


class Delay(_Timed):
    """BT.CPP ``Delay``: RUNNING for ``delay_msec`` of simulated time, then ticks the child."""

    def __init__(self, name: str, child: Behaviour, delay_msec: int) -> None:
        super().__init__(name=name, child=child)
        self.msec = delay_msec
        self.deadline = 0

    def tick(self) -> Iterator[Behaviour]:
        """Start the delay on a fresh tick; tick the child once it has passed."""
        if self.status != Status.RUNNING:
            self.deadline = self.world.iteration + iterations(self.msec, self.defaults)
        if self.world.iteration < self.deadline:
            self.status = Status.RUNNING
        else:
            yield from self.decorated.tick()
            self.status = self.decorated.status
        yield self


class Timeout(_Timed):
    """BT.CPP ``Timeout``: ticks the child; halts it and fails once it has run ``msec`` of
    simulated time (0: no limit)."""

    def __init__(self, name: str, child: Behaviour, msec: int) -> None:
        super().__init__(name=name, child=child)
        self.msec = msec
        self.deadline = 0

    def tick(self) -> Iterator[Behaviour]:
        """Start the clock on a fresh tick; fail (halting the child) when it has run out."""
        if self.status != Status.RUNNING:
            self.deadline = self.world.iteration + iterations(self.msec, self.defaults)
        elif self.msec > 0 and self.world.iteration >= self.deadline:
            if self.decorated.status != Status.INVALID:
                self.decorated.stop(Status.INVALID)
            self.status = Status.FAILURE
            yield self
            return
        yield from self.decorated.tick()
        self.status = self.decorated.status
        yield self


class Switch(py_trees.composites.Composite):
    """BT.CPP ``Switch2``...``Switch6``: ticks the child of the first case equal to the
    agent's entry ``variable`` (else the last child); a running child of another case is
    halted first; when the child finishes, all are reset."""

    def __init__(self, name: str, children: Sequence[Behaviour], key: str, cases: list) -> None:
        super().__init__(name, list(children))
        self.key, self.cases = key, cases
        self.running = -1

    def bind(self, agent: Any, world: Any, defaults: Mapping[str, Any]) -> None:
        self.board = agent.blackboard

    def tick(self) -> Iterator[Behaviour]:
        """Match the entry, halt a running other case, tick the matched child."""
        if self.status != Status.RUNNING:
            self.running = -1
            self.initialise()
        value = getattr(self.board, self.key)
        match = next((k for k, c in enumerate(self.cases) if value == c), len(self.cases))
        if self.running not in (-1, match):
            halt_all(self.children[self.running : self.running + 1])
        child = self.children[match]
        yield from child.tick()
        self.status = child.status
        if child.status == Status.RUNNING:
            self.running = match
        else:
            halt_all(self.children)
            self.running = -1
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
    "Parallel": lambda name, kids, p: Parallel(name, kids, p["success_count"], p["failure_count"]),
    "Repeat": lambda name, kids, p: Loop(name, kids[0], p["num_cycles"], Status.SUCCESS),
    "RetryUntilSuccessful": lambda name, kids, p: Loop(
        name, kids[0], p["num_attempts"], Status.FAILURE
    ),
    "ParallelAll": lambda name, kids, p: ParallelAll(name, kids, p["max_failures"]),
    "Precondition": lambda name, kids, p: Precondition(name, kids[0], p["if"], p["else"]),
    "Delay": lambda name, kids, p: Delay(name, kids[0], p["delay_msec"]),
    "Timeout": lambda name, kids, p: Timeout(name, kids[0], p["msec"]),
    **{
        f"Switch{n}": lambda name, kids, p: Switch(name, kids, p["variable"].key, case_values(p))
        for n in range(2, 7)
    },
}
