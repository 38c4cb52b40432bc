"""Behaviour trees: the engine-independent tree description, leaves (:class:`Leaf`,
:class:`Port`, :func:`register_leaf`, the status codes and helpers), and tree files
(BehaviorTree.CPP XML, YAML: :func:`load_tree`, :func:`save_tree`). The paper's leaves belong
to its missions (:mod:`pyautonomousagent.missions.drones.leaves`)."""

from pyautonomousagent.bt import (
    script_leaves,  # noqa: F401  (Script, SetBlackboard, ...)
    scripted,  # noqa: F401  (registers the Scripted test leaf)
)
from pyautonomousagent.bt.files import load_tree, save_tree
from pyautonomousagent.bt.leaf import Leaf, LeafError, Port, leaf_type, register_leaf
from pyautonomousagent.bt.spec import (
    Node,
    fallback,
    inverter,
    leaf,
    reactive_fallback,
    reactive_sequence,
    sequence,
)
from pyautonomousagent.bt.status import (
    FAILURE,
    INVALID,
    RUNNING,
    SUCCESS,
    status_if,
    success_if,
)

__all__ = [
    "FAILURE",
    "INVALID",
    "Leaf",
    "LeafError",
    "RUNNING",
    "SUCCESS",
    "Node",
    "Port",
    "fallback",
    "inverter",
    "leaf",
    "leaf_type",
    "load_tree",
    "reactive_fallback",
    "reactive_sequence",
    "register_leaf",
    "save_tree",
    "sequence",
    "status_if",
    "success_if",
]
