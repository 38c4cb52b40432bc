"""Behaviour trees: the engine-independent tree description, the leaf-node library, and
tree files (BehaviorTree.CPP XML, YAML: :func:`load_tree`, :func:`save_tree`)."""

from pyautonomousagent.bt import library, scripted  # noqa: F401  (register the leaf types)
from pyautonomousagent.bt.files import load_tree, save_tree
from pyautonomousagent.bt.spec import (
    Node,
    fallback,
    inverter,
    leaf,
    reactive_fallback,
    reactive_sequence,
    sequence,
)
from pyautonomousagent.bt.status import FAILURE, INVALID, RUNNING, SUCCESS

__all__ = [
    "FAILURE",
    "INVALID",
    "RUNNING",
    "SUCCESS",
    "Node",
    "fallback",
    "inverter",
    "leaf",
    "load_tree",
    "reactive_fallback",
    "reactive_sequence",
    "save_tree",
    "sequence",
]
