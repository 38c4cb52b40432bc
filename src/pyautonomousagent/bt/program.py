"""A checked tree as a flat program in tick order, the form every array engine runs.

The batched engine ticks it over NumPy arrays; the compiled and GPU engines generate their
kernels from it. A subtree is the contiguous range ``[i, end[i])`` of nodes in pre-order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.bt.spec import Node, control_params


@dataclass(frozen=True)
class Program:
    """A tree description flattened into tick order.

    Attributes:
        nodes: the nodes, pre-order (the order of :meth:`Node.walk`).
        parent: index of each node's parent, -1 for the root; shape (n,).
        children: the child indices of each node.
        end: one past the last node of each node's subtree; shape (n,).
        params: control parameters with defaults filled in ({} for leaves).
    """

    nodes: tuple[Node, ...]
    parent: np.ndarray
    children: tuple[tuple[int, ...], ...]
    end: np.ndarray
    params: tuple[dict[str, Any], ...]


def compile_tree(root: Node) -> Program:
    """Flatten a (checked) tree description into a :class:`Program`."""
    nodes: list[Node] = []
    parent: list[int] = []
    children: list[list[int]] = []
    end: list[int] = []

    def visit(node: Node, up: int) -> int:
        i = len(nodes)
        nodes.append(node)
        parent.append(up)
        children.append([])
        end.append(0)
        for child in node.children:
            children[i].append(visit(child, i))
        end[i] = len(nodes)
        return i

    visit(root, -1)
    params = tuple(control_params(n) if n.is_control else {} for n in nodes)
    return Program(
        tuple(nodes), np.asarray(parent), tuple(tuple(c) for c in children), np.asarray(end), params
    )
