"""The words of tree files: BehaviorTree.CPP 4 node tags and how they map onto :class:`Node`.

XML files and YAML files use the same vocabulary: a control node is written with its
BehaviorTree.CPP tag (``Sequence``, ``ReactiveFallback``, ``Repeat``, ...), a leaf with its
leaf type (``Condition_Low_Energy_Level``). The tags come from the node type records of
:mod:`pyautonomousagent.bt.nodes`; a tag may fix parameters (``ReactiveSequence`` is
``Sequence`` with ``memory=False``). py_trees node types that BehaviorTree.CPP lacks have
tags of their own (``PyTreesRepeat``, ``FailureIsRunning``, ...), declared in the file's
``TreeNodesModel`` so Groot2 shows them.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.bt.nodes import NODE_TYPES, PRE_CONDITIONS
from pyautonomousagent.bt.spec import Node


@dataclass(frozen=True)
class Tag:
    """A control node as files write it (a view of a :class:`NodeType` and one of its tags).

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


def tags() -> list[Tag]:
    """Every file tag of every registered control node type."""
    return [
        Tag(t.tag, node.name, node.kind, t.fixed, params, node.builtin, t.symbol, t.doc)
        for node in NODE_TYPES.values()
        for params in [{p.name: (p.type, p.default is None) for p in node.params if p.in_files}]
        for t in node.tags
    ]


def by_tag() -> dict[str, Tag]:
    """File tag -> :class:`Tag`."""
    return {t.tag: t for t in tags()}


#: Leaf types that are BehaviorTree.CPP 4 built-ins (not declared in a TreeNodesModel).
BTCPP_LEAVES = frozenset(
    {"AlwaysSuccess", "AlwaysFailure", "Script", "ScriptCondition", "SetBlackboard", "Sleep"}
)

#: BehaviorTree.CPP 4 built-ins that pyAutonomousAgent does not run, with the reason (the
#: file reader looks here only for a tag that is no node type or leaf type).
UNSUPPORTED: dict[str, str] = {
    **dict.fromkeys(
        ["ManualSelector", "AlwaysRunning"],
        "it is not a built-in of BehaviorTree.CPP 4.8 (the version held against)",
    ),
    **dict.fromkeys(
        ["LoopInt", "LoopDouble", "LoopString", "LoopBool", "SkipUnlessUpdated",
         "WaitValueUpdate", "WasEntryUpdated"],
        "it needs wall-clock time, scripting or blackboard entries of its own",
    ),
    "UnsetBlackboard": "scripting and free blackboard entries are not supported",
}  # fmt: skip

#: BehaviorTree.CPP's scripting attributes, any node may have them (see Node.scripts): the
#: pre-conditions (:data:`~pyautonomousagent.bt.nodes.PRE_CONDITIONS`), then the others.
SCRIPT_ATTRIBUTES = (
    *(pre[0] for pre in PRE_CONDITIONS),
    "_onSuccess",
    "_onFailure",
    "_post",
    "_onHalted",
)


def tag_of(node: Node) -> Tag:
    """The file tag that writes a (checked) control node."""
    for tag in tags():
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
    """``"Condition"`` for condition leaves (``Condition_*``, ``ScriptCondition``), else
    ``"Action"``."""
    condition = type_name.startswith("Condition") or type_name == "ScriptCondition"
    return "Condition" if condition else "Action"


def closest(word: str, known: list[str]) -> str:
    """' (did you mean X?)'-style hint text, or "" when nothing is close."""
    close = difflib.get_close_matches(word, known, n=1, cutoff=0.6)
    return f"did you mean {close[0]}?" if close else ""
