"""A tree description as text: the paper's symbols (→, R→, ?, R?, ≠) or py_trees' own drawing."""

from __future__ import annotations

from pyautonomousagent.bt.spec import Node

SYMBOLS = {
    ("Sequence", True): "→",
    ("Sequence", False): "R→",
    ("Selector", True): "?",
    ("Selector", False): "R?",
    ("Inverter", None): "≠",
}


def symbol(node: Node) -> str:
    """The paper's symbol for a control node; "" for a leaf."""
    memory = node.params.get("memory") if node.type in ("Sequence", "Selector") else None
    return SYMBOLS.get((node.type, memory), "")


def label(node: Node) -> str:
    """One line for a node: symbol and name for control nodes; name, type and ports for leaves."""
    if node.is_control:
        return f"{symbol(node)} {node.name}"
    ports = ", ".join(f"{k}={v!r}" for k, v in node.params.items())
    return f"{node.name} [{node.type}{': ' + ports if ports else ''}]"


def to_text(root: Node) -> str:
    """The tree drawn with box characters, root first, children indented in tick order."""
    lines = [label(root)]
    _children(root, "", lines)
    return "\n".join(lines)


def _children(node: Node, indent: str, lines: list[str]) -> None:
    for i, child in enumerate(node.children):
        last = i == len(node.children) - 1
        lines.append(f"{indent}{'└── ' if last else '├── '}{label(child)}")
        _children(child, indent + ("    " if last else "│   "), lines)
