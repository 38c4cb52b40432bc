"""The blackboard entries a tree declares: keys its scripts (``Script`` nodes and scripting
attributes such as ``_onSuccess``) and ``SetBlackboard`` nodes write.

The swarm's blackboard is numeric, one row per agent, so every entry has a dtype: a key
assigned only booleans (``done := true``, comparisons) is ``bool``, one assigned whole numbers
or strings (enum values, :func:`~pyautonomousagent.bt.script.enum_code`) is ``int64``, any
other ``float64``. :class:`~pyautonomousagent.simulation.run.Simulation` creates them with
the mission's keys, zero (false) at the start, so they are recorded like the others.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from pyautonomousagent.bt.leaf import LEAF_TYPES
from pyautonomousagent.bt.script import DTYPES, parse, widest
from pyautonomousagent.bt.script_leaves import declared_keys
from pyautonomousagent.bt.spec import Node


def type_name(dtype: Any) -> str:
    """``"bool"``, ``"int"`` or ``"float"`` for a NumPy dtype."""
    kind = np.dtype(dtype).kind
    return "bool" if kind == "b" else "int" if kind in "iu" else "float"


def tree_blackboard_keys(root: Node, known: Mapping[str, Any] | None = None) -> dict[str, np.dtype]:
    """Key -> dtype of the entries ``root`` writes that ``known`` (key -> dtype, e.g. the
    mission's blackboard) does not have, in the order the tree first writes them."""
    types = {key: type_name(dtype) for key, dtype in (known or {}).items()}
    declared: dict[str, str] = {}
    for _ in range(3):  # a key read before the node that assigns it: widen, then settle
        for node in root.walk():
            known_now = {**types, **declared}
            found: dict[str, str] = {}
            if not node.is_control and node.type in LEAF_TYPES:
                found.update(declared_keys(LEAF_TYPES.get(node.type), node.params, known_now))
            for code in node.scripts.values():  # _onSuccess="laps += 1", ...
                for key, kind in parse(code).assigned({**known_now, **found}).items():
                    found[key] = widest(kind, found.get(key, kind))
            for key, kind in found.items():
                declared[key] = widest(kind, declared.get(key, kind))
    return {key: DTYPES[kind] for key, kind in declared.items() if key not in types}
