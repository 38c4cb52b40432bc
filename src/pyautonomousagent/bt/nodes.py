"""Control node types as records: one :class:`NodeType` per type, kept in :data:`NODE_TYPES`.

A record says everything the engine-independent code needs: how many children the node
takes, its parameters with their defaults and checks, the tags files write it with (and the
parameters a tag fixes: ``ReactiveSequence`` is ``Sequence`` with ``memory=False``), its
symbol for pictures, and whether BehaviorTree.CPP has it built in. The spec
(:mod:`~pyautonomousagent.bt.spec`), the file readers and writers, the pictures and both
engines read the records; an engine implements a type under the record's name
(``engines/pytrees.py``'s ``PYTREES_NODES``, ``engines/batched.py``'s ``BATCHED_NODES``).

Type names are BehaviorTree.CPP's tags where BT.CPP has the node; py_trees' own decorators
keep their py_trees names, and py_trees' Repeat/Retry/Parallel are ``PyTrees...``.
Adding a node type: register a record here, then implement it in both engines (a test
checks that each record has both).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.bt.script import ScriptError, parse
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


def whole_at_least_one(value: Any, children: int) -> str:
    """A whole number >= 1."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        return f"must be a whole number >= 1, got {value!r}"
    return ""


def loop_count(value: Any, children: int) -> str:
    """A whole number >= 1, or -1 for no limit."""
    if isinstance(value, bool) or not isinstance(value, int) or (value < 1 and value != -1):
        return f"must be a whole number >= 1 or -1, got {value!r}"
    return ""


def child_count(value: Any, children: int) -> str:
    """A count of children as BT.CPP reads it: k >= 1, or -1 (all), -2 (all but one), ..."""
    if isinstance(value, bool) or not isinstance(value, int) or value == 0:
        return f"must be a whole number other than 0, got {value!r}"
    resolved = value if value > 0 else children + value + 1
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
    """

    name: str
    kind: str
    least: int
    most: int | None
    params: tuple[Param, ...] = ()
    tags: tuple[FileTag, ...] = ()
    builtin: bool = True
    status_map: Mapping[str, str] | None = None

    def defaults(self) -> dict[str, Any]:
        """Parameter -> default (None for required ones)."""
        return {p.name: p.default for p in self.params}


NODE_TYPES: Registry[NodeType] = Registry("control node type")


def add(record: NodeType) -> NodeType:
    """Register ``record`` under its name."""
    return NODE_TYPES.register(record.name, record)


def _tag(tag: str, symbol: str, doc: str, **fixed: Any) -> tuple[FileTag, ...]:
    return (FileTag(tag, fixed, symbol, doc),)


def _decorator(name: str, tag: str, symbol: str, doc: str, **kwargs: Any) -> NodeType:
    return add(NodeType(name, DECORATOR, 1, 1, tags=_tag(tag, symbol, doc), **kwargs))


def _control(name: str, least: int, most: int | None, symbol: str, doc: str, **kw: Any) -> None:
    add(NodeType(name, CONTROL, least, most, tags=_tag(name, symbol, doc), **kw))


MEMORY = Param("memory", bool, None, boolean, in_files=False)

# -- py_trees composites, written with BT.CPP's tags -------------------------------------------
add(NodeType("Sequence", CONTROL, 0, None, (MEMORY,), (
    FileTag("Sequence", {"memory": True}, "→",
            "ticks children in order; resumes at a RUNNING child; restarts after a failure"),
    FileTag("ReactiveSequence", {"memory": False}, "R→",
            "ticks children from the first on every tick"),
)))  # fmt: skip
add(NodeType("Fallback", CONTROL, 0, None, (MEMORY,), (
    FileTag("Fallback", {"memory": True}, "?",
            "tries children in order until one does not fail; resumes at a RUNNING child"),
    FileTag("ReactiveFallback", {"memory": False}, "R?",
            "tries children from the first on every tick"),
)))  # fmt: skip

# -- status-mapping decorators ----------------------------------------------------------------
_decorator(
    "Inverter",
    "Inverter",
    "≠",
    "swaps SUCCESS and FAILURE",
    status_map={"SUCCESS": "FAILURE", "FAILURE": "SUCCESS"},
)
_decorator(
    "ForceSuccess",
    "ForceSuccess",
    "✓",
    "SUCCESS when the child finishes; RUNNING while it runs",
    status_map={"FAILURE": "SUCCESS"},
)
_decorator(
    "ForceFailure",
    "ForceFailure",
    "✗",
    "FAILURE when the child finishes; RUNNING while it runs",
    status_map={"SUCCESS": "FAILURE"},
)
_decorator(
    "KeepRunningUntilFailure",
    "KeepRunningUntilFailure",
    "∞",
    "RUNNING when the child succeeds; FAILURE when it fails",
    status_map={"SUCCESS": "RUNNING"},
)
for _name, _map in {
    "FailureIsRunning": {"FAILURE": "RUNNING"},
    "RunningIsFailure": {"RUNNING": "FAILURE"},
    "RunningIsSuccess": {"RUNNING": "SUCCESS"},
    "PassThrough": {},
}.items():
    _change = ", ".join(f"{a} becomes {b}" for a, b in _map.items()) or "returns the child's"
    _decorator(_name, _name, "", f"py_trees: child {_change}", builtin=False, status_map=_map)

# -- BehaviorTree.CPP's own semantics (one tick = one tickExactlyOnce(), docs/tree-files.md) --
_control(
    "SequenceWithMemory",
    1,
    None,
    "→*",
    "like Sequence, but after a failure resumes at the failed child",
)
_control(
    "AsyncSequence",
    1,
    None,
    "→a",
    "like Sequence, but yields (RUNNING) after a child that succeeded at once",
)
_control(
    "AsyncFallback",
    1,
    None,
    "?a",
    "like Fallback, but yields (RUNNING) after a child that failed at once",
)
_control(
    "IfThenElse", 2, 3, "if", "child 1 decides: SUCCESS ticks child 2, FAILURE child 3 (or fails)"
)
_control("WhileDoElse", 2, 3, "while", "like IfThenElse, but asks child 1 again on every tick")
_control(
    "Parallel",
    1,
    None,
    "⇉",
    "ticks unfinished children; decides by success_count / failure_count",
    params=(
        Param("success_count", int, -1, child_count),
        Param("failure_count", int, 1, child_count),
    ),
)
_control(
    "ParallelAll",
    1,
    None,
    "⇉all",
    "ticks unfinished children until all finished; fails at max_failures failures",
    params=(Param("max_failures", int, 1, child_count),),
)
_decorator(
    "Repeat",
    "Repeat",
    "↻",
    "after a success ticks the child again, num_cycles times (-1: for ever)",
    params=(Param("num_cycles", int, None, loop_count),),
)
_decorator(
    "RetryUntilSuccessful",
    "RetryUntilSuccessful",
    "↺",
    "after a failure ticks the child again, num_attempts tries (-1: for ever)",
    params=(Param("num_attempts", int, None, loop_count),),
)


def script_text(value: Any, children: int) -> str:
    """A script (BehaviorTree.CPP's scripting language)."""
    try:
        parse(value)
    except ScriptError as error:
        return f": {error}"
    return ""


def msec(value: Any, children: int) -> str:
    """Milliseconds of simulated time: a whole number >= 0."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        return f"must be a whole number of milliseconds >= 0, got {value!r}"
    return ""


def _then_skip(value: Any, children: int) -> str:
    if value is False:
        return ""
    return (
        f"must be false, got {value!r}: a skipped node (BehaviorTree.CPP's SKIPPED) has no "
        "equal on the py_trees engine"
    )


_decorator(
    "Precondition",
    "Precondition",
    "pre",
    "ticks the child if the script `if` holds (asked until the child runs), else `else`",
    params=(
        Param("if", str, None, script_text),
        Param("else", str, "FAILURE", one_of("FAILURE", "SUCCESS", "RUNNING")),
    ),
)
_decorator(
    "Delay",
    "Delay",
    "delay",
    "RUNNING for delay_msec of simulated time, then ticks the child",
    params=(Param("delay_msec", int, None, msec),),
)
_decorator(
    "Timeout",
    "Timeout",
    "timeout",
    "halts the child and fails when it runs longer than msec of simulated time",
    params=(Param("msec", int, None, msec),),
)
_decorator(
    "RunOnce",
    "RunOnce",
    "once",
    "ticks the child until it finishes once, then returns that status for ever",
    params=(Param("then_skip", bool, True, _then_skip),),
)


def entry(value: Any, children: int) -> str:
    """A blackboard entry, written ``{key}``."""
    if isinstance(value, BlackboardRef):
        return ""
    return f"must name a blackboard entry, written {{key}}, got {value!r}"


def case(value: Any, children: int) -> str:
    """A Switch case: a number, true/false, or a word (an enum value)."""
    return "" if isinstance(value, str | int | float) else f"must be text, got {value!r}"


for _cases in range(2, 7):
    _decorator_or_control = NodeType(
        f"Switch{_cases}", CONTROL, _cases + 1, _cases + 1,
        (Param("variable", str, None, entry, entry=True),
         *(Param(f"case_{k}", str, None, case) for k in range(1, _cases + 1))),
        _tag(f"Switch{_cases}", f"switch{_cases}",
             "ticks the child of the first case equal to the entry `variable`, else the "
             "last; a running child of another case is halted"),
    )  # fmt: skip
    add(_decorator_or_control)

# -- py_trees nodes BehaviorTree.CPP lacks ----------------------------------------------------
_decorator(
    "PyTreesRepeat",
    "PyTreesRepeat",
    "",
    "py_trees Repeat: RUNNING until the child succeeded num_success times, one per tick",
    builtin=False,
    params=(Param("num_success", int, None, whole_at_least_one),),
)
_decorator(
    "PyTreesRetry",
    "PyTreesRetry",
    "",
    "py_trees Retry: a failure is RUNNING until the num_failures-th, one per tick",
    builtin=False,
    params=(Param("num_failures", int, None, whole_at_least_one),),
)
add(NodeType("PyTreesParallel", CONTROL, 0, None, (
    Param("policy", str, "SuccessOnAll", one_of("SuccessOnAll", "SuccessOnOne")),
    Param("synchronise", bool, True, boolean),
), _tag("PyTreesParallel", "", "py_trees Parallel: ticks all children; policy SuccessOnAll "
        "or SuccessOnOne"), builtin=False))  # fmt: skip
