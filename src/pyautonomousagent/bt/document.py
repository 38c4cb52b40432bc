"""A tree file as read, before validation: its behaviour trees, nodes, values and lines.

Both readers (XML, YAML) produce a :class:`Document`; both writers write one. A document
keeps what a file says (SubTree references, ``{port}`` references, values as written), so
saving a loaded file keeps its structure. :mod:`pyautonomousagent.bt.build` turns a document
into a checked :class:`~pyautonomousagent.bt.spec.Node`, the only thing the engines run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError, check_structure
from pyautonomousagent.bt.vocabulary import closest, file_params, tag_of
from pyautonomousagent.inputs import cut

#: The tag of a reference to another behaviour tree of the same file.
SUBTREE = "SubTree"
#: The ID given to the only tree of a file that names none.
DEFAULT_TREE_ID = "MainTree"


class TreeFileError(TreeError):
    """A bad tree file: the message names the file, the line and the fix.

    Attributes:
        file: the file's name (or ``<text>``).
        line: the 1-based line of the problem (0 when it concerns the whole file, which
            the message then names without a line).
        message: what is wrong.
        fix: what to do about it.
    """

    def __init__(self, file: str, line: int, message: str, fix: str) -> None:
        message, fix = cut(message, 400), cut(fix, 200)  # a quoted value may be huge
        self.file, self.line, self.message, self.fix = file, line, message, fix
        where = f"{file}:{line}" if line > 0 else file
        super().__init__(f"{where}: {message}; {fix}")


@dataclass
class RawNode:
    """One node as a file writes it.

    Attributes:
        tag: the node's tag (a control tag, a leaf type, or ``SubTree``).
        line: its line in the file (0 for trees made in Python).
        name: the ``name`` given in the file, or None.
        ports: ports and parameters as written: text from XML, values from YAML.
        children: child nodes, in order.
        category: for XML's explicit form (``<Action ID=...>``) the element name, else None.
        subtree: for ``SubTree``: the referenced tree's ID.
        autoremap: for ``SubTree``: the ``_autoremap`` flag.
        prefix: set when a SubTree is inlined: the start of the names of its nodes.
        port_lines: port -> its own line, where the file has one (YAML keys).
        scripts: scripting attributes (``_successIf``, ``_onSuccess``, ...) -> code.
    """

    tag: str
    line: int = 0
    name: str | None = None
    ports: dict[str, Any] = field(default_factory=dict)
    children: list[RawNode] = field(default_factory=list)
    category: str | None = None
    subtree: str | None = None
    autoremap: bool = False
    prefix: str = ""
    port_lines: dict[str, int] = field(default_factory=dict)
    scripts: dict[str, str] = field(default_factory=dict)

    def line_of(self, port: str) -> int:
        """The line of ``port`` (the node's line if the port has none of its own)."""
        return self.port_lines.get(port, self.line)

    def walk(self) -> list[RawNode]:
        """This node and all below it, depth first."""
        return [self, *(node for child in self.children for node in child.walk())]


@dataclass
class Document:
    """A whole tree file.

    Attributes:
        file: the file's name, for messages.
        main: the ID of the tree to run.
        trees: tree ID -> its root node, in file order.
        lines: tree ID -> the line that defines it.
        subtree_ports: SubTree ID -> {port: default} from the file's TreeNodesModel.
    """

    file: str
    main: str
    trees: dict[str, RawNode]
    lines: dict[str, int] = field(default_factory=dict)
    subtree_ports: dict[str, dict[str, Any]] = field(default_factory=dict)


def main_tree(
    trees: Mapping[str, RawNode],
    main: str | None,
    fail: Callable[[str, str], TreeFileError],
    word: str,
    add_main: str,
) -> str:
    """The ID of the tree to run: ``main`` (the file's ``main_tree_to_execute``), or the
    only tree where the file names none. ``fail(message, fix)`` makes the error; messages
    call a tree ``word``, and ``add_main.format(ID)`` is the fix for several trees."""
    if main is None:
        if len(trees) > 1:
            several = f"several {word}s and no main_tree_to_execute"
            raise fail(several, add_main.format(next(iter(trees))))
        return next(iter(trees))
    if main not in trees:
        hint = closest(main, list(trees))
        raise fail(
            f"main_tree_to_execute is {main!r}, but no {word} has that ID",
            hint or f"use one of: {', '.join(trees)}",
        )
    return main


def document_from_node(root: Node, tree_id: str = DEFAULT_TREE_ID) -> Document:
    """A one-tree document for a tree description (which is checked first)."""
    check_structure(root)
    return Document("<tree>", tree_id, {tree_id: _raw(root)})


def _raw(node: Node) -> RawNode:
    children = [_raw(child) for child in node.children]
    if node.is_control:
        raw = RawNode(tag_of(node).tag, 0, node.name, _text(file_params(node)), children)
    else:
        raw = RawNode(node.type, 0, node.name, _text(node.params), children)
    raw.scripts = dict(node.scripts)
    return raw


def _text(params: Mapping[str, Any]) -> dict[str, Any]:
    """Parameters as files write them: a blackboard reference as ``{key}``."""
    return {k: str(v) if isinstance(v, BlackboardRef) else v for k, v in params.items()}
