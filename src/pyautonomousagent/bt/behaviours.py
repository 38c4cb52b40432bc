"""The registry of hand-written py_trees behaviours used as leaves.

Such a leaf runs on the py_trees engine only; the other engines look here to refuse it (and
"auto" to pick the py_trees engine). The py_trees engine registers into it
(``engines.pytrees.register_behaviour``) and builds from it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pyautonomousagent.registry import Registry

#: Hand-written py_trees behaviours: type name -> class taking ``(name, agent, world,
#: **params)`` (an ``engines.pytrees.AgentBehaviour`` subclass).
BEHAVIOUR_TYPES: Registry[Callable[..., Any]] = Registry("hand-written behaviour")
