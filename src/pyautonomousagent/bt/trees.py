"""Trees a scenario can name instead of a tree file (``tree: patrol``): the registry.

The missions register their trees (the paper's ``gathering``, Fig. 6, and ``patrol``, Fig. 12:
:mod:`pyautonomousagent.missions.drones.trees`); the core knows none of them.
"""

from __future__ import annotations

from collections.abc import Callable

from pyautonomousagent.bt.spec import Node, TreeError
from pyautonomousagent.registry import Registry, UnknownNameError

#: Trees a scenario can name instead of a tree file (``tree: patrol``): name -> builder.
TREES: Registry[Callable[[], Node]] = Registry("tree")


def tree_by_name(name: str) -> Node:
    """The named tree; TreeError with the closest known names if there is none."""
    try:
        return TREES.get(name)()
    except UnknownNameError as error:
        raise TreeError(f"{error}; or name a tree file (.xml, .yaml)") from None
