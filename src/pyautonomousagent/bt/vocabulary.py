"""The words of tree files: BehaviorTree.CPP 4 node tags and how they map onto :class:`Node`.

XML files and YAML files use the same vocabulary: a control node is written with its
BehaviorTree.CPP tag (``Sequence``, ``ReactiveFallback``, ``Repeat``, ...), a leaf with its
leaf type (``Condition_Low_Energy_Level``). Each tag maps to one spec node type with some
parameters fixed by the tag (``ReactiveSequence`` is ``Sequence`` with ``memory=False``).
py_trees node types that BehaviorTree.CPP lacks have tags of their own (``PyTreesRepeat``,
``FailureIsRunning``, ...), declared in the file's ``TreeNodesModel`` so Groot2 shows them.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.bt.spec import Node


@dataclass(frozen=True)
class Tag:
    """A control node as files write it.

    Attributes:
        tag: the XML tag (and YAML ``type``).
        spec: the :class:`Node` type it stands for.
        kind: ``"Control"`` (children) or ``"Decorator"`` (exactly one child).
        fixed: spec parameters implied by the tag (not written in files).
        params: the parameters a file may give: name -> (type, required).
        builtin: True for BehaviorTree.CPP's own nodes (Groot2 knows them already).
        symbol: the paper's symbol for pictures, or a short one.
        doc: one line for TreeNodesModel and the docs.
    """

    tag: str
    spec: str
    kind: str
    fixed: Mapping[str, Any] = field(default_factory=dict)
    params: Mapping[str, tuple[type, bool]] = field(default_factory=dict)
    builtin: bool = True
    symbol: str = ""
    doc: str = ""


CONTROL = "Control"
DECORATOR = "Decorator"

TAGS: tuple[Tag, ...] = (
    Tag("Sequence", "Sequence", CONTROL, {"memory": True}, symbol="→",
        doc="ticks children in order; resumes at a RUNNING child; restarts after a failure"),
    Tag("ReactiveSequence", "Sequence", CONTROL, {"memory": False}, symbol="R→",
        doc="ticks children from the first on every tick"),
    Tag("SequenceWithMemory", "SequenceWithMemory", CONTROL, symbol="→*",
        doc="like Sequence, but after a failure resumes at the failed child"),
    Tag("Fallback", "Selector", CONTROL, {"memory": True}, symbol="?",
        doc="tries children in order until one does not fail; resumes at a RUNNING child"),
    Tag("ReactiveFallback", "Selector", CONTROL, {"memory": False}, symbol="R?",
        doc="tries children from the first on every tick"),
    Tag("Parallel", "BTParallel", CONTROL, symbol="⇉",
        params={"success_count": (int, False), "failure_count": (int, False)},
        doc="ticks unfinished children; decides by success_count / failure_count"),
    Tag("Inverter", "Inverter", DECORATOR, symbol="≠", doc="swaps SUCCESS and FAILURE"),
    Tag("ForceSuccess", "FailureIsSuccess", DECORATOR, symbol="✓",
        doc="SUCCESS when the child finishes; RUNNING while it runs"),
    Tag("ForceFailure", "SuccessIsFailure", DECORATOR, symbol="✗",
        doc="FAILURE when the child finishes; RUNNING while it runs"),
    Tag("KeepRunningUntilFailure", "SuccessIsRunning", DECORATOR, symbol="∞",
        doc="RUNNING when the child succeeds; FAILURE when it fails"),
    Tag("Repeat", "BTRepeat", DECORATOR, params={"num_cycles": (int, True)}, symbol="↻",
        doc="after a success ticks the child again in the same tick, num_cycles times"),
    Tag("RetryUntilSuccessful", "RetryUntilSuccessful", DECORATOR,
        params={"num_attempts": (int, True)}, symbol="↺",
        doc="after a failure ticks the child again in the same tick, num_attempts tries"),
    Tag("AsyncSequence", "AsyncSequence", CONTROL, symbol="→a",
        doc="like Sequence, but yields (RUNNING) after a child that succeeded at once"),
    Tag("AsyncFallback", "AsyncFallback", CONTROL, symbol="?a",
        doc="like Fallback, but yields (RUNNING) after a child that failed at once"),
    Tag("IfThenElse", "IfThenElse", CONTROL, symbol="if",
        doc="child 1 decides: SUCCESS ticks child 2, FAILURE child 3 (or fails)"),
    Tag("WhileDoElse", "WhileDoElse", CONTROL, symbol="while",
        doc="like IfThenElse, but asks child 1 again on every tick"),
    Tag("ParallelAll", "ParallelAll", CONTROL, symbol="⇉all",
        params={"max_failures": (int, False)},
        doc="ticks unfinished children until all finished; fails at max_failures failures"),
    Tag("FailureIsRunning", "FailureIsRunning", DECORATOR, builtin=False,
        doc="py_trees: child FAILURE becomes RUNNING"),
    Tag("RunningIsFailure", "RunningIsFailure", DECORATOR, builtin=False,
        doc="py_trees: child RUNNING becomes FAILURE"),
    Tag("RunningIsSuccess", "RunningIsSuccess", DECORATOR, builtin=False,
        doc="py_trees: child RUNNING becomes SUCCESS"),
    Tag("PassThrough", "PassThrough", DECORATOR, builtin=False,
        doc="py_trees: returns the child's status"),
    Tag("PyTreesRepeat", "Repeat", DECORATOR, params={"num_success": (int, True)},
        builtin=False,
        doc="py_trees Repeat: RUNNING until the child succeeded num_success times, one per tick"),
    Tag("PyTreesRetry", "Retry", DECORATOR, params={"num_failures": (int, True)},
        builtin=False,
        doc="py_trees Retry: a failure is RUNNING until the num_failures-th, one per tick"),
    Tag("PyTreesParallel", "Parallel", CONTROL, builtin=False,
        params={"policy": (str, False), "synchronise": (bool, False)},
        doc="py_trees Parallel: ticks all children; policy SuccessOnAll or SuccessOnOne"),
)  # fmt: skip

BY_TAG: dict[str, Tag] = {t.tag: t for t in TAGS}

#: BehaviorTree.CPP 4 built-ins that pyAutonomousAgent does not run, with the reason.
UNSUPPORTED: dict[str, str] = {
    **dict.fromkeys(
        ["Switch2", "Switch3", "Switch4", "Switch5", "Switch6"],
        "it reads a blackboard variable; blackboard ports are not supported yet",
    ),
    **dict.fromkeys(
        ["ManualSelector", "TryCatch", "AlwaysRunning"],
        "it is not a built-in of BehaviorTree.CPP 4.8 (the version held against)",
    ),
    **dict.fromkeys(
        ["Delay", "Timeout", "Sleep", "RunOnce", "Precondition", "LoopInt", "LoopDouble",
         "LoopString", "LoopBool", "SkipUnlessUpdated", "WaitValueUpdate", "WasEntryUpdated"],
        "it needs wall-clock time, scripting or blackboard entries of its own",
    ),
    **dict.fromkeys(
        ["Script", "ScriptCondition", "SetBlackboard", "UnsetBlackboard"],
        "scripting and free blackboard entries are not supported",
    ),
}  # fmt: skip

#: Attributes BehaviorTree.CPP uses for its scripting; refused with a clear message.
SCRIPT_ATTRIBUTES = (
    "_skipIf", "_successIf", "_failureIf", "_while",
    "_onSuccess", "_onFailure", "_onHalted", "_post",
)  # fmt: skip


def tag_of(node: Node) -> Tag:
    """The file tag that writes a (checked) control node."""
    for tag in TAGS:
        if tag.spec == node.type and all(
            node.params.get(key) == value for key, value in tag.fixed.items()
        ):
            return tag
    raise KeyError(f"no file tag for control node type {node.type!r}")


def file_params(node: Node) -> dict[str, Any]:
    """A control node's parameters as a file writes them (those fixed by the tag left out)."""
    fixed = tag_of(node).fixed
    return {k: v for k, v in node.params.items() if k not in fixed}


def leaf_category(type_name: str) -> str:
    """``"Condition"`` for condition leaves (``Condition_*``), else ``"Action"``."""
    return "Condition" if type_name.startswith("Condition") else "Action"


def closest(word: str, known: list[str]) -> str:
    """' (did you mean X?)'-style hint text, or "" when nothing is close."""
    close = difflib.get_close_matches(word, known, n=1, cutoff=0.6)
    return f"did you mean {close[0]}?" if close else ""
