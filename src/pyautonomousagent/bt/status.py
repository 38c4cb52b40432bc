"""Node statuses as small integers, shared by both engines and the recorded traces.

The codes mirror :class:`py_trees.common.Status`, plus BehaviorTree.CPP's SKIPPED (a node
that was not executed: a ``_skipIf``/``_while`` pre-condition, a ``RunOnce`` that ran); arrays
of them have dtype int8.
"""

from __future__ import annotations

from typing import Any

import numpy as np

INVALID = 0
SUCCESS = 1
FAILURE = 2
RUNNING = 3
SKIPPED = 4

NAMES = {
    INVALID: "INVALID",
    SUCCESS: "SUCCESS",
    FAILURE: "FAILURE",
    RUNNING: "RUNNING",
    SKIPPED: "SKIPPED",
}
#: Status name -> code (:data:`NAMES` inverted).
CODES = {name: code for code, name in NAMES.items()}

#: Each code's value in BehaviorTree.CPP 4's ``NodeStatus`` (its ``.btlog`` files): IDLE 0
#: (our INVALID), RUNNING 1, SUCCESS 2, FAILURE 3, SKIPPED 4.
BTCPP_CODES = {INVALID: 0, RUNNING: 1, SUCCESS: 2, FAILURE: 3, SKIPPED: 4}

#: Each status's colour in the views (the animation's inset, the replay, the studio, the
#: lessons' tick tables), in their legends' order: INVALID ("not ticked") last.
COLOURS = {
    SUCCESS: "#2ca02c",
    FAILURE: "#d62728",
    RUNNING: "#ff9f1c",
    SKIPPED: "#9e9ac8",
    INVALID: "#d9d9d9",
}


def status_if(condition: Any, if_true: int, if_false: int) -> Any:
    """``if_true`` where ``condition`` holds, else ``if_false``: an int, or an int8 array."""
    if isinstance(condition, np.ndarray):
        return np.where(condition, np.int8(if_true), np.int8(if_false))
    return if_true if condition else if_false


def success_if(condition: Any) -> Any:
    """SUCCESS where ``condition`` holds, FAILURE elsewhere (:func:`status_if`, written out:
    conditions call it once per agent-tick on the py_trees engine)."""
    if isinstance(condition, np.ndarray):
        return np.where(condition, np.int8(SUCCESS), np.int8(FAILURE))
    return SUCCESS if condition else FAILURE


def invalid_status(name: str, type_name: str) -> str:
    """The message for a leaf that returned INVALID (0), which both engines refuse: py_trees
    and BehaviorTree.CPP treat such a leaf differently, so no engine guesses."""
    return (
        f"leaf {name!r} ({type_name}) returned INVALID (0); a leaf returns SUCCESS (1), "
        "FAILURE (2) or RUNNING (3)"
    )
