"""A tree description as text: the paper's symbols (→, R→, ?, R?, ≠) or py_trees' own drawing.

Control nodes show their symbol (from :data:`pyautonomousagent.bt.vocabulary.TAGS`; the
file tag where a node has none) and name, then any parameters; leaves show their name,
type and the ports set in the tree.
"""

from __future__ import annotations

from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.vocabulary import file_params, tag_of


def symbol(node: Node) -> str:
    """The paper's symbol for a control node (its file tag if it has none); "" for a leaf."""
    if not node.is_control:
        return ""
    tag = tag_of(node)
    return tag.symbol or tag.tag


def _ports(params: dict) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in params.items())


def label(node: Node) -> str:
    """One line for a node: symbol and name for control nodes; name, type and ports for leaves."""
    if node.is_control:
        params = file_params(node)
        return f"{symbol(node)} {node.name}" + (f" [{_ports(params)}]" if params else "")
    ports = _ports(dict(node.params))
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
