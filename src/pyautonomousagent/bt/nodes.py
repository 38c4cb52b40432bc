"""Control node types as records: one :class:`NodeType` per type, kept in :data:`NODE_TYPES`.

A record says everything the engine-independent code needs: how many children the node
takes, its parameters with their defaults and checks, the tags files write it with (and the
parameters a tag fixes: ``ReactiveSequence`` is ``Sequence`` with ``memory=False``), its
symbol for pictures, and whether BehaviorTree.CPP has it built in. The spec
(:mod:`~pyautonomousagent.bt.spec`), the file readers and writers, the pictures and the
engines read the records. A record with a ``rule`` (:mod:`~pyautonomousagent.bt.rules`)
says its semantics once, and every engine derives its form from that; a record without one
is implemented by hand under its name in the py_trees and batched engines
(``engines/btcpp.py``'s ``BTCPP_BEHAVIOURS``, ``engines/batched.py``'s ``BATCHED_NODES``).

Type names are BehaviorTree.CPP's tags where BT.CPP has the node; py_trees' own decorators
keep their py_trees names, and py_trees' Repeat/Retry/Parallel are ``PyTrees...``.
Adding a node type: register a record here with its rule, and its tests.

BehaviorTree.CPP's SKIPPED lives here too, beside its code in
:mod:`~pyautonomousagent.bt.status`: the pre-conditions that give it (:data:`PRE_CONDITIONS`),
the records that return it of themselves (``skipped_when``) or pass it on (``skips``), and
the checks built on them (:func:`may_skip`, :func:`skip_problem`). No other module names it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from pyautonomousagent.bt.rules import Ops, Rule
from pyautonomousagent.bt.script import ScriptError, literal, parse
from pyautonomousagent.bt.status import FAILURE, NAMES, RUNNING, SKIPPED, SUCCESS
from pyautonomousagent.registry import Registry

CONTROL = "Control"
DECORATOR = "Decorator"


@dataclass(frozen=True, repr=False)
class BlackboardRef:
    """A port written ``{key}``: the agent's blackboard entry ``key``, read each tick."""

    key: str

    def __str__(self) -> str:
        return "{" + self.key + "}"

    __repr__ = __str__


#: A parameter check: (value, number of children) -> what is wrong, or "" when nothing is.
Check = Callable[[Any, int], str]


def whole(least: int, unit: str = "", no_limit: bool = False) -> Check:
    """A whole number (of ``unit``) >= ``least``; with ``no_limit`` also -1 (no limit)."""
    must = f"must be a whole number{unit} >= {least}" + (" or -1" if no_limit else "")

    def check(value: Any, children: int) -> str:
        number = isinstance(value, int) and not isinstance(value, bool)
        if number and (value >= least or (no_limit and value == -1)):
            return ""
        return f"{must}, got {value!r}"

    return check


def parallel_threshold(value: int, children: int) -> int:
    """A count of children as BehaviorTree.CPP resolves it: ``k >= 1`` is k children, ``-1``
    all of them, ``-2`` all but one, ... (checked by :func:`child_count`)."""
    return value if value > 0 else children + value + 1


def child_count(value: Any, children: int) -> str:
    """A count of children as BT.CPP reads it: k >= 1, or -1 (all), -2 (all but one), ..."""
    if isinstance(value, bool) or not isinstance(value, int) or value == 0:
        return f"must be a whole number other than 0, got {value!r}"
    resolved = parallel_threshold(value, children)
    if not 1 <= resolved <= children:
        return f"={value} asks for {resolved} of {children} child(ren)"
    return ""


def boolean(value: Any, children: int) -> str:
    """True or false."""
    return "" if isinstance(value, bool) else f"must be true or false, got {value!r}"


def one_of(*choices: str) -> Check:
    """One of ``choices``."""

    def check(value: Any, children: int) -> str:
        return "" if value in choices else f"must be one of {choices}, got {value!r}"

    return check


@dataclass(frozen=True)
class Param:
    """A control node parameter.

    Attributes:
        name: its name in trees and files.
        type: int, bool or str: what file text is read as.
        default: the value when not given; None marks a required parameter.
        check: what a good value is (see :data:`Check`).
        in_files: False for parameters only a tag sets (``memory``).
        entry: True for a parameter that names a blackboard entry (``variable="{mode}"``).
    """

    name: str
    type: type
    default: Any = None
    check: Check | None = None
    in_files: bool = True
    entry: bool = False


@dataclass(frozen=True)
class FileTag:
    """How files write a node type: the tag, the parameters it fixes, its picture symbol."""

    tag: str
    fixed: Mapping[str, Any] = field(default_factory=dict)
    symbol: str = ""
    doc: str = ""


@dataclass(frozen=True)
class NodeType:
    """One control node type.

    Attributes:
        name: the type name of :class:`~pyautonomousagent.bt.spec.Node`.
        kind: :data:`CONTROL` (children) or :data:`DECORATOR` (exactly one child).
        least, most: how many children it takes (most None: no limit).
        params: its parameters.
        tags: the file tags that write it (the first is the one without fixed parameters
            if there is one).
        builtin: True if BehaviorTree.CPP 4 has it (Groot2 knows it already).
        status_map: for a decorator that maps its child's status: {child: own} by name.
        rule: its semantics, for every engine (:mod:`~pyautonomousagent.bt.rules`); None
            for a type each engine implements by hand.
        memory: how many whole numbers per agent the rule remembers (``Ops.memory``).
        yields: True if the node returns at once, RUNNING, when a child is RUNNING (so no
            node ticked after that child sees the tick: compiled leaves may defer a step).
        skips: True if the rule says what a SKIPPED child does (BT.CPP's); a child that
            may be SKIPPED is refused under the others.
        skipped_when: for a type whose rule may return SKIPPED of itself (not through a
            child): whether a node with these parameters (defaults filled in) may.
    """

    name: str
    kind: str
    least: int
    most: int | None
    params: tuple[Param, ...] = ()
    tags: tuple[FileTag, ...] = ()
    builtin: bool = True
    status_map: Mapping[str, str] | None = None
    rule: Rule | None = None
    memory: int = 0
    yields: bool = False
    skips: bool = False
    skipped_when: Callable[[Mapping[str, Any]], bool] | None = None

    def defaults(self) -> dict[str, Any]:
        """Parameter -> default (None for required ones)."""
        return {p.name: p.default for p in self.params}


NODE_TYPES: Registry[NodeType] = Registry("control node type")


def add(record: NodeType) -> NodeType:
    """Register ``record`` under its name."""
    return NODE_TYPES.register(record.name, record)


def _tag(tag: str, symbol: str, doc: str, **fixed: Any) -> tuple[FileTag, ...]:
    return (FileTag(tag, fixed, symbol, doc),)


def _decorator(name: str, symbol: str, doc: str, **kwargs: Any) -> NodeType:
    status_map = kwargs.get("status_map")
    if status_map is not None:
        rule = mapped_rule(status_map)
        kwargs.update(rule=rule, yields=status_map.get("RUNNING") is None, skips=True)
    return add(NodeType(name, DECORATOR, 1, 1, tags=_tag(name, symbol, doc), **kwargs))


def _control(
    name: str, symbol: str, doc: str, least: int = 1, most: int | None = None, **kw: Any
) -> None:
    add(NodeType(name, CONTROL, least, most, tags=_tag(name, symbol, doc), **kw))


MEMORY = Param("memory", bool, None, boolean, in_files=False)


def sequence_rule(n: Ops) -> None:
    """py_trees' Sequence: ticks the children in order from the first (with ``memory``, from
    the RUNNING one) until one neither succeeds nor is skipped, which it returns; without
    memory the children after that one are halted. SKIPPED when every child was skipped
    (BT.CPP's: in this run, or this tick without memory). Remembers the child it ticks
    (-1: none), and whether no child succeeded yet."""
    memory = n.params["memory"]
    skips = any(n.skippable(k) for k in range(n.kids))
    fresh = n.let("fresh", n.status() != RUNNING)
    with n.when(fresh):
        n.halt(0)
    if not n.kids:
        n.set_memory(-1)
        n.finish(SUCCESS)
        return
    start = n.let("start", n.pick(fresh, 0, n.memory())) if memory else 0
    if skips:
        with n.when(fresh if memory else True):
            n.set_memory(1, slot=1)  # no child succeeded yet in this run
    for k in range(n.kids):
        with n.when(start <= k):
            if memory:
                n.set_memory(k)
            result = n.tick(k)
            with n.when(_neither(n, k, result, SUCCESS)):
                if not memory:
                    n.halt(k + 1)
                n.finish(result)
            _note_not_skipped(n, skips, k, result, SUCCESS)
    _finish_unless_all_skipped(n, skips, SUCCESS)


def _note_not_skipped(n: Ops, skips: bool, k: int, result: Any, proceed: int) -> None:
    """With ``skips``, memory slot 1 := 0 once child ``k`` was not skipped (``proceed``)."""
    if skips:
        with n.when(result == proceed if n.skippable(k) else True):
            n.set_memory(0, slot=1)


def _finish_unless_all_skipped(n: Ops, skips: bool, status: int) -> None:
    """Finish with ``status``, or SKIPPED where every child was (:func:`_note_not_skipped`)."""
    n.finish(n.pick(n.memory(1) == 1, SKIPPED, status) if skips else status)


def _neither(n: Ops, k: int, result: Any, proceed: int) -> Any:
    """Whether child ``k``'s ``result`` is neither ``proceed`` nor SKIPPED (the latter asked
    only of a child that may be skipped)."""
    if n.skippable(k):
        return (result != proceed) & (result != SKIPPED)
    return result != proceed


def fallback_rule(n: Ops) -> None:
    """py_trees' Selector: tries the children in order from the first (with ``memory``, from
    the remembered one, halting those before it) until one neither fails nor is skipped,
    which it returns and remembers; a newly chosen child halts the ones after it. SKIPPED
    when every child was skipped (as Sequence); remembers whether no child failed yet."""
    memory = n.params["memory"]
    fresh = n.let("fresh", n.status() != RUNNING)
    with n.when(fresh):
        n.set_memory(0)
    if not n.kids:
        n.set_memory(-1)
        n.finish(FAILURE)
        return
    previous = n.let("previous", n.memory())
    for k in range(n.kids - 1) if memory else ():
        with n.when(previous > k):
            n.halt(k, k + 1)
    start = previous if memory else 0
    skips = any(n.skippable(k) for k in range(n.kids))
    if skips:
        with n.when(fresh if memory else True):
            n.set_memory(1, slot=1)  # no child failed yet in this run
    for k in range(n.kids):
        with n.when(start <= k):
            result = n.tick(k)
            with n.when(_neither(n, k, result, FAILURE)):
                n.set_memory(k)
                with n.when(previous != k):
                    n.halt(k + 1)
                n.finish(result)
            _note_not_skipped(n, skips, k, result, FAILURE)
    n.set_memory(n.kids - 1)
    _finish_unless_all_skipped(n, skips, FAILURE)


# -- py_trees composites, written with BT.CPP's tags -------------------------------------------
add(NodeType("Sequence", CONTROL, 0, None, (MEMORY,), (
    FileTag("Sequence", {"memory": True}, "→",
            "ticks children in order; resumes at a RUNNING child; restarts after a failure"),
    FileTag("ReactiveSequence", {"memory": False}, "R→",
            "ticks children from the first on every tick"),
), rule=sequence_rule, memory=2, yields=True, skips=True))  # fmt: skip
add(NodeType("Fallback", CONTROL, 0, None, (MEMORY,), (
    FileTag("Fallback", {"memory": True}, "?",
            "tries children in order until one does not fail; resumes at a RUNNING child"),
    FileTag("ReactiveFallback", {"memory": False}, "R?",
            "tries children from the first on every tick"),
), rule=fallback_rule, memory=2, yields=True, skips=True))  # fmt: skip


def mapped_rule(status_map: Mapping[str, str]) -> Rule:
    """A status-mapping decorator: ticks the child and returns its status mapped through
    ``status_map`` ({child: own} by name); a child left RUNNING under a finished decorator is
    halted."""
    codes = {name: code for code, name in NAMES.items()}
    table = [*range(len(NAMES))]
    for child, own in status_map.items():
        table[codes[child]] = codes[own]

    def rule(n: Ops) -> None:
        result = n.tick(0)
        new = n.let("new", n.lookup(tuple(table), result))
        with n.when((new != RUNNING) & (result == RUNNING)):
            n.halt(0)
        n.finish(new)

    return rule


# -- status-mapping decorators ----------------------------------------------------------------
_decorator(
    "Inverter",
    "≠",
    "swaps SUCCESS and FAILURE",
    status_map={"SUCCESS": "FAILURE", "FAILURE": "SUCCESS"},
)
_decorator(
    "ForceSuccess",
    "✓",
    "SUCCESS when the child finishes; RUNNING while it runs",
    status_map={"FAILURE": "SUCCESS"},
)
_decorator(
    "ForceFailure",
    "✗",
    "FAILURE when the child finishes; RUNNING while it runs",
    status_map={"SUCCESS": "FAILURE"},
)
_decorator(
    "KeepRunningUntilFailure",
    "∞",
    "RUNNING when the child succeeds (or is skipped); FAILURE when it fails",
    status_map={"SUCCESS": "RUNNING", "SKIPPED": "RUNNING"},
)
for _name, _map in {
    "FailureIsRunning": {"FAILURE": "RUNNING"},
    "RunningIsFailure": {"RUNNING": "FAILURE"},
    "RunningIsSuccess": {"RUNNING": "SUCCESS"},
    "PassThrough": {},
}.items():
    _change = ", ".join(f"{a} becomes {b}" for a, b in _map.items()) or "returns the child's"
    _decorator(_name, "", f"py_trees: child {_change}", builtin=False, status_map=_map)


# -- BehaviorTree.CPP's own semantics (one tick = one tickExactlyOnce(), docs/tree-files.md) --
def sequence_with_memory_rule(n: Ops) -> None:
    """BT.CPP's SequenceWithMemory: resumes at the remembered child (kept on halt); after a
    child that succeeded at its first tick it yields (RUNNING, a wake-up); a child that does
    not succeed is returned and remembered; starts over only after success."""
    start = n.let("start", n.memory())
    for k in range(n.kids):
        with n.when(start <= k):
            woke = n.let("woke", n.child(k) != RUNNING)
            result = n.tick(k)
            if k + 1 < n.kids:
                with n.when(woke & (result == SUCCESS)):
                    n.set_memory(k + 1)
                    n.finish(RUNNING)
            with n.when(result != SUCCESS):
                n.set_memory(k)
                n.finish(result)
    n.set_memory(0)
    n.finish(SUCCESS)


def async_rule(proceed: int) -> Rule:
    """BT.CPP's AsyncSequence (``proceed`` SUCCESS) and AsyncFallback (FAILURE): a memory
    Sequence / Fallback that yields (RUNNING) after a child that ended with ``proceed`` at
    its first tick, and goes on at the next tick. Remembers the child to tick."""

    def rule(n: Ops) -> None:
        with n.when(n.status() != RUNNING):
            n.set_memory(0)
        start = n.let("start", n.memory())
        for k in range(n.kids):
            with n.when(start <= k):
                woke = n.let("woke", n.child(k) != RUNNING)
                result = n.tick(k)
                with n.when(result != proceed):
                    n.set_memory(n.pick(result == RUNNING, k, 0))
                    n.finish(result)
                if k + 1 < n.kids:
                    with n.when(woke):
                        n.set_memory(k + 1)
                        n.finish(RUNNING)
        n.set_memory(0)
        n.finish(proceed)

    return rule


def if_then_else_rule(n: Ops) -> None:
    """BT.CPP's IfThenElse: the first child decides (unless a branch runs): SUCCESS ticks the
    second, FAILURE the third (with two children: FAILURE); a finished branch resets all.
    Remembers the running branch (0: none, ask the condition)."""
    with n.when(n.status() != RUNNING):
        n.set_memory(0)
    with n.when(n.memory() == 0):
        result = n.tick(0)
        with n.when(result == SUCCESS):
            n.set_memory(1)
        if n.kids == 3:
            with n.when(result == FAILURE):
                n.set_memory(2)
        n.finish(result, where=n.memory() == 0)
    for branch in range(1, n.kids):
        with n.when(n.memory() == branch):
            result = n.let("result", n.tick(branch))  # kept: the halt below resets it
            with n.when(result != RUNNING):
                n.halt(0)
                n.set_memory(0)
            n.finish(result)


def while_do_else_rule(n: Ops) -> None:
    """BT.CPP's WhileDoElse: the first child is asked on every tick; SUCCESS ticks the second
    (halting the third), FAILURE the third (halting the second) or fails; all are reset when
    both the condition and the branch finished."""
    asked = n.let("asked", n.tick(0))
    yes, no = asked == SUCCESS, asked == FAILURE
    with n.when(yes):
        n.halt(2)
        n.tick(1)
    if n.kids == 3:
        with n.when(no):
            n.halt(1, 2)
            n.tick(2)
    otherwise = n.child(2) if n.kids == 3 else asked
    result = n.let("result", n.pick(yes, n.child(1), n.pick(no, otherwise, asked)))
    with n.when((asked != RUNNING) & (result != RUNNING)):
        n.halt(0)
    n.finish(result)


_control(
    "SequenceWithMemory",
    "→*",
    "like Sequence, but after a failure resumes at the failed child",
    rule=sequence_with_memory_rule,
    memory=1,
)
_control(
    "AsyncSequence",
    "→a",
    "like Sequence, but yields (RUNNING) after a child that succeeded at once",
    rule=async_rule(SUCCESS),
    memory=1,
)
_control(
    "AsyncFallback",
    "?a",
    "like Fallback, but yields (RUNNING) after a child that failed at once",
    rule=async_rule(FAILURE),
    memory=1,
)
_control(
    "IfThenElse",
    "if",
    "child 1 decides: SUCCESS ticks child 2, FAILURE child 3 (or fails)",
    least=2,
    most=3,
    rule=if_then_else_rule,
    memory=1,
)
_control(
    "WhileDoElse",
    "while",
    "like IfThenElse, but asks child 1 again on every tick",
    least=2,
    most=3,
    rule=while_do_else_rule,
)


def _tick_unfinished(n: Ops, k: int, going: Any = True) -> None:
    """Tick child ``k`` where it has not finished in this run (neither succeeded nor failed)
    and ``going`` holds; count its finish: memory slot 0 the successes of the run, slot 1
    the failures."""
    unfinished = (n.child(k) != SUCCESS) & (n.child(k) != FAILURE)
    with n.when(unfinished if going is True else going & unfinished):
        result = n.tick(k)
        n.set_memory(n.memory(0) + (result == SUCCESS), slot=0)
        n.set_memory(n.memory(1) + (result == FAILURE), slot=1)


def parallel_rule(n: Ops) -> None:
    """BT.CPP's Parallel: a fresh run halts the children; the children that have not finished
    in this run are ticked left to right until the counts decide: SUCCESS at
    ``success_count`` successes, FAILURE at ``failure_count`` failures or when too few
    children are left to succeed; then the RUNNING children are halted (the finished keep
    their status). Remembers the successes and failures of the run."""
    need_success = parallel_threshold(n.params["success_count"], n.kids)
    need_failure = parallel_threshold(n.params["failure_count"], n.kids)
    with n.when(n.status() != RUNNING):
        n.halt(0)
        n.set_memory(0, slot=0)
        n.set_memory(0, slot=1)
    successes, failures = n.memory(0), n.memory(1)
    won = successes >= need_success
    lost = (failures >= need_failure) | (failures > n.kids - need_success)
    undecided = (successes < need_success) & (failures < need_failure)
    undecided = undecided & (failures <= n.kids - need_success)
    for k in range(n.kids):  # undecided before the first child: else it had finished
        _tick_unfinished(n, k, undecided if k else True)
    with n.when(won | lost):
        for k in range(n.kids):
            with n.when(n.child(k) == RUNNING):
                n.halt(k, k + 1)
        n.finish(n.pick(won, SUCCESS, FAILURE))
    n.finish(RUNNING)


def parallel_all_rule(n: Ops) -> None:
    """BT.CPP's ParallelAll: ticks the children that have not finished in this run; once all
    have, halts them all and fails if ``max_failures`` of them failed, else succeeds.
    Remembers the successes and failures of the run."""
    need_failure = parallel_threshold(n.params["max_failures"], n.kids)
    with n.when(n.status() != RUNNING):
        n.set_memory(0, slot=0)
        n.set_memory(0, slot=1)
    for k in range(n.kids):
        _tick_unfinished(n, k)
    with n.when(n.memory(0) + n.memory(1) == n.kids):
        failed = n.let("failed", n.memory(1) >= need_failure)
        n.halt(0)
        n.finish(n.pick(failed, FAILURE, SUCCESS))
    n.finish(RUNNING)


def loop_rule(again: int, limit: str) -> Rule:
    """BT.CPP's Repeat (``again`` SUCCESS) and RetryUntilSuccessful (FAILURE): the child is
    ticked again within the tick while it returns ``again`` (at most parameter ``limit``
    times in all, -1: for ever) if it was RUNNING before; one that returns ``again`` at its
    first tick ends the tick (RUNNING, a wake-up). Remembers how often it returned
    ``again`` in this run."""

    def rule(n: Ops) -> None:
        times = n.params[limit]  # at most two a tick: 2**31 (int32 memory) is for ever too
        with n.when(n.status() != RUNNING):
            n.set_memory(0)
        with n.loop():
            woke = n.let("woke", n.child(0) != RUNNING)
            result = n.tick(0)
            with n.when(result == again):
                if 0 < times < 2**31:
                    n.set_memory(n.memory() + 1)
                    with n.when(n.memory() >= times):
                        n.set_memory(0)
                        n.finish(again)
                n.finish(RUNNING, where=woke)
            with n.when(result != again):  # else: again, within the tick
                with n.when(result != RUNNING):
                    n.set_memory(0)
                n.finish(result)

    return rule


_control(
    "Parallel",
    "⇉",
    "ticks unfinished children; decides by success_count / failure_count",
    params=(
        Param("success_count", int, -1, child_count),
        Param("failure_count", int, 1, child_count),
    ),
    rule=parallel_rule,
    memory=2,
)
_control(
    "ParallelAll",
    "⇉all",
    "ticks unfinished children until all finished; fails at max_failures failures",
    params=(Param("max_failures", int, 1, child_count),),
    rule=parallel_all_rule,
    memory=2,
)
_decorator(
    "Repeat",
    "↻",
    "after a success ticks the child again, num_cycles times (-1: for ever)",
    params=(Param("num_cycles", int, None, whole(1, no_limit=True)),),
    rule=loop_rule(SUCCESS, "num_cycles"),
    memory=1,
    yields=True,
)
_decorator(
    "RetryUntilSuccessful",
    "↺",
    "after a failure ticks the child again, num_attempts tries (-1: for ever)",
    params=(Param("num_attempts", int, None, whole(1, no_limit=True)),),
    rule=loop_rule(FAILURE, "num_attempts"),
    memory=1,
    yields=True,
)


def script_text(value: Any, children: int) -> str:
    """A script (BehaviorTree.CPP's scripting language)."""
    try:
        parse(value)
    except ScriptError as error:
        return f": {error}"
    return ""


msec = whole(0, " of milliseconds")  # simulated time


_decorator(
    "Precondition",
    "pre",
    "ticks the child if the script `if` holds (asked until the child runs), else `else`",
    params=(
        Param("if", str, None, script_text),
        Param("else", str, "FAILURE", one_of("FAILURE", "SUCCESS", "RUNNING")),
    ),
)


def delay_rule(n: Ops) -> None:
    """BT.CPP's Delay: a fresh run waits ``delay_msec`` of simulated time (RUNNING), then
    ticks the child and returns its status. Remembers the iteration it waits for."""
    with n.when(n.status() != RUNNING):
        n.set_memory(n.now() + n.iterations(n.params["delay_msec"]))
    n.finish(RUNNING, where=n.now() < n.memory())
    n.finish(n.tick(0))


def timeout_rule(n: Ops) -> None:
    """BT.CPP's Timeout: ticks the child and returns its status; once the run has lasted
    ``msec`` of simulated time (0: no limit), halts the child and fails instead. Remembers
    the iteration at which it stops the child."""
    with n.when(n.status() != RUNNING):
        n.set_memory(n.now() + n.iterations(n.params["msec"]))
    if n.params["msec"] > 0:
        with n.when((n.status() == RUNNING) & (n.now() >= n.memory())):
            n.halt(0)
            n.finish(FAILURE)
    n.finish(n.tick(0))


_decorator(
    "Delay",
    "delay",
    "RUNNING for delay_msec of simulated time, then ticks the child",
    params=(Param("delay_msec", int, None, msec),),
    rule=delay_rule,
    memory=1,
    yields=True,
)
_decorator(
    "Timeout",
    "timeout",
    "halts the child and fails when it runs longer than msec of simulated time",
    params=(Param("msec", int, None, msec),),
    rule=timeout_rule,
    memory=1,
    yields=True,
)


def run_once_rule(n: Ops) -> None:
    """BT.CPP's RunOnce: ticks the child until it succeeds or fails once, then returns that
    status for ever without ticking it (``then_skip``: SKIPPED instead). Remembers the
    status (0: none yet)."""
    done = n.let("done", n.memory())
    with n.when(done != 0):
        n.finish(SKIPPED if n.params["then_skip"] else done)
    result = n.tick(0)
    with n.when((result == SUCCESS) | (result == FAILURE)):
        n.set_memory(result)
    n.finish(result)


_decorator(
    "RunOnce",
    "once",
    "ticks the child until it finishes once; then SKIPPED (then_skip=false: that status)",
    params=(Param("then_skip", bool, True, boolean),),
    rule=run_once_rule,
    memory=1,
    skips=True,
    yields=True,
    skipped_when=lambda params: bool(params["then_skip"]),
)


def entry(value: Any, children: int) -> str:
    """A blackboard entry, written ``{key}``."""
    if isinstance(value, BlackboardRef):
        return ""
    return f"must name a blackboard entry, written {{key}}, got {value!r}"


def case(value: Any, children: int) -> str:
    """A Switch case: a number, true/false, or a word (an enum value)."""
    return "" if isinstance(value, str | int | float) else f"must be text, got {value!r}"


def case_values(params: Mapping[str, Any]) -> list[Any]:
    """A Switch's cases as the numbers they compare with (words: enum values)."""
    cases = sorted((int(k[5:]), v) for k, v in params.items() if k.startswith("case_"))
    texts = (str(value).lower() if isinstance(value, bool) else str(value) for _, value in cases)
    return [literal(text)[0] for text in texts]


def switch_rule(n: Ops) -> None:
    """BT.CPP's Switch2..6: ticks the child of the first case equal to the agent's entry
    ``variable`` now (else the last child) and returns its status; a running child of another
    case is halted first; when the child finishes, all are reset. A case that is no number
    (NaN, a ``{key}``) matches nothing. Remembers the running child + 1 (0: none)."""

    value = n.let("value", n.entry(n.params["variable"].key))
    match: Any = n.kids - 1
    for k, number in reversed(list(enumerate(case_values(n.params)))):
        if not isinstance(number, str) and number == number:  # else: never equal
            match = n.pick(value == number, k, match)
    match = n.let("match", match)
    with n.when(n.status() != RUNNING):
        n.set_memory(0)
    for k in range(n.kids):
        with n.when((n.memory() == k + 1) & (match != k)):
            n.halt(k, k + 1)
    for k in range(n.kids):
        if (match == k) is False:  # no case is a number: the last child only
            continue
        with n.when(match == k), n.when(n.tick(k) == RUNNING):
            n.set_memory(k + 1)
            n.finish(RUNNING)
    result = n.child(n.kids - 1)
    for k in reversed(range(n.kids - 1)):
        result = n.pick(match == k, n.child(k), result)
    result = n.let("result", result)  # kept: the halt below resets it
    n.set_memory(0)
    n.halt(0)
    n.finish(result)


for _cases in range(2, 7):
    _decorator_or_control = NodeType(
        f"Switch{_cases}", CONTROL, _cases + 1, _cases + 1,
        (Param("variable", str, None, entry, entry=True),
         *(Param(f"case_{k}", str, None, case) for k in range(1, _cases + 1))),
        _tag(f"Switch{_cases}", f"switch{_cases}",
             "ticks the child of the first case equal to the entry `variable`, else the "
             "last; a running child of another case is halted"),
        rule=switch_rule, memory=1,
    )  # fmt: skip
    add(_decorator_or_control)


def try_catch_rule(n: Ops) -> None:
    """BT.CPP 4.9's TryCatch: children 1..N-1 are a Sequence with memory (the try block); if
    one fails, all are reset and the last child (the catch) is ticked until it finishes, when
    all are reset and the node fails; SUCCESS (all reset) when the try block succeeded,
    SKIPPED when it was all skipped. Remembers the child to tick (0..N-2 in the try block,
    N-1 in the catch) and whether no try child succeeded yet."""
    catch = n.kids - 1
    skips = any(n.skippable(k) for k in range(catch))
    with n.when(n.status() != RUNNING):
        n.set_memory(0)
        if skips:
            n.set_memory(1, slot=1)  # no try child succeeded yet
    for k in range(catch):
        with n.when(n.memory() <= k):
            result = n.tick(k)
            with n.when(result == RUNNING):
                n.set_memory(k)
                n.finish(RUNNING)
            with n.when(result == FAILURE):
                n.halt(0)
                n.set_memory(catch)
            if skips:
                with n.when(result == SUCCESS):
                    n.set_memory(0, slot=1)
    with n.when(n.memory() != catch):
        n.halt(0)
        n.set_memory(0)
        _finish_unless_all_skipped(n, skips, SUCCESS)
    result = n.tick(catch)
    with n.when(result != RUNNING):
        n.halt(0)
        n.set_memory(0)
    n.finish(n.pick(result == RUNNING, RUNNING, FAILURE))


def _no_catch_on_halt(value: Any, children: int) -> str:
    if value is False:
        return ""
    return f"must be false, got {value!r}: no engine ticks a child while halting its parent"


_control(
    "TryCatch",
    "try",
    "BT.CPP 4.9: children but the last in sequence; if one fails, the last (catch) runs, "
    "then FAILURE",
    least=2,
    params=(Param("catch_on_halt", bool, False, _no_catch_on_halt),),
    builtin=False,  # not in BT.CPP 4.8, the version held against: files declare it
    rule=try_catch_rule,
    memory=2,
    skips=True,
    yields=True,
)

# -- py_trees nodes BehaviorTree.CPP lacks ----------------------------------------------------
_decorator(
    "PyTreesRepeat",
    "",
    "py_trees Repeat: RUNNING until the child succeeded num_success times, one per tick",
    builtin=False,
    params=(Param("num_success", int, None, whole(1)),),
)
_decorator(
    "PyTreesRetry",
    "",
    "py_trees Retry: a failure is RUNNING until the num_failures-th, one per tick",
    builtin=False,
    params=(Param("num_failures", int, None, whole(1)),),
)
add(NodeType("PyTreesParallel", CONTROL, 0, None, (
    Param("policy", str, "SuccessOnAll", one_of("SuccessOnAll", "SuccessOnOne")),
    Param("synchronise", bool, True, boolean),
), _tag("PyTreesParallel", "", "py_trees Parallel: ticks all children; policy SuccessOnAll "
        "or SuccessOnOne"), builtin=False))  # fmt: skip


# -- SKIPPED: what may return it, and which node types may take a child that does -------------
#: BehaviorTree.CPP's pre-condition attributes in the order it checks them: (attribute, the
#: status, a code of :mod:`pyautonomousagent.bt.status`, the node gets without a tick, the
#: script's truth value that decides it, whether it is also asked of a RUNNING node, which
#: is then halted first). Asked of a node that does not resume (not RUNNING), in order.
PRE_CONDITIONS = (
    ("_failureIf", FAILURE, True, False),
    ("_successIf", SUCCESS, True, False),
    ("_skipIf", SKIPPED, True, False),
    ("_while", SKIPPED, False, True),
)

#: Scripting attributes that may make a node SKIPPED (BehaviorTree.CPP's pre-conditions).
SKIPPING = tuple(key for key, status, *_ in PRE_CONDITIONS if status == SKIPPED)


class TreeNode(Protocol):
    """What the skip checks read of a tree node (a :class:`~pyautonomousagent.bt.spec.Node`)."""

    @property
    def type(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def is_control(self) -> bool: ...
    @property
    def params(self) -> Mapping[str, Any]: ...
    @property
    def scripts(self) -> Mapping[str, str]: ...
    @property
    def children(self) -> Sequence[TreeNode]: ...


def may_skip(node: TreeNode) -> bool:
    """Whether ``node`` may return SKIPPED: it has ``_skipIf`` or ``_while``, its record says
    that it may of itself with its parameters (``skipped_when``: RunOnce's ``then_skip``), or
    it is of a node type that passes SKIPPED on (its record ``skips``) with a child that may
    (conservatively: a Sequence is SKIPPED only when all children are)."""
    if any(key in node.scripts for key in SKIPPING):
        return True
    if not node.is_control:
        return False
    record = NODE_TYPES.get(node.type)
    params = {**record.defaults(), **node.params}
    if record.skipped_when is not None and record.skipped_when(params):
        return True
    return record.skips and any(may_skip(child) for child in node.children)


def _skip_help() -> tuple[str, str]:
    """What may make a node SKIPPED (the pre-conditions, the node types that may return it of
    themselves) and the node types that say what a SKIPPED child does, for messages."""
    records = NODE_TYPES.values()
    causes = [*SKIPPING, *(r.name for r in records if r.skipped_when is not None)]
    takers = [r.name for r in records if r.skips and r.status_map is None]
    return ", ".join(causes), ", ".join(takers) + " or status-mapping decorator"


def skip_problem(node: TreeNode) -> str | None:
    """Why control node ``node`` cannot have its children, or None when it can: a child may
    be SKIPPED and ``node``'s type does not say what a skipped child does (its record's
    ``skips``), or ``node`` has a pre-condition or ``_onHalted``: BT.CPP leaves a node whose
    own tick returned SKIPPED RUNNING, which no engine here mirrors."""
    child = next((c for c in node.children if may_skip(c)), None)
    if child is None:
        return None
    if not NODE_TYPES.get(node.type).skips:
        causes, takers = _skip_help()
        return (
            f"{node.type} {node.name!r} cannot take child {child.name!r}, which may be "
            f"SKIPPED ({causes}): put it under a {takers}"
        )
    held = sorted(set(node.scripts) - {"_onSuccess", "_onFailure", "_post"})
    if held:
        return (
            f"{node.type} {node.name!r} may be SKIPPED through child {child.name!r}, so it "
            f"cannot have {', '.join(held)} (BehaviorTree.CPP then keeps it RUNNING)"
        )
    return None
