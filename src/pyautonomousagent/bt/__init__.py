"""Behaviour trees: the engine-independent tree description and the leaf-node library."""

from pyautonomousagent.bt import library, scripted  # noqa: F401  (register the leaf types)
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
    "reactive_fallback",
    "reactive_sequence",
    "sequence",
]
