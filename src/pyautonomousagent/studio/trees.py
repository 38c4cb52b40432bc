"""The studio's trees: the palette, and blocks <-> tree files through the file loader.

The browser sends a tree as plain data, one dict per block (a :data:`Block`)::

    {"type": "Sequence", "name": null, "ports": {}, "children": [...]}

:func:`check_blocks` writes it as BehaviorTree.CPP XML (one node per line) and reads it
back with the file loader (:func:`~pyautonomousagent.bt.files.parse_document`, then
:func:`~pyautonomousagent.bt.build.build` and the scenario's
:func:`~pyautonomousagent.simulation.fit.check_tree`), so a tree of blocks gets exactly the
messages a tree file gets; the message's line or node name says which block it concerns.
Uploaded files go through :func:`~pyautonomousagent.bt.files.document_from_bytes`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.bt.build import build
from pyautonomousagent.bt.document import DEFAULT_TREE_ID, Document, RawNode, document_from_node
from pyautonomousagent.bt.files import document_from_bytes, parse_document, to_text_format
from pyautonomousagent.bt.spec import Node, TreeError, snake_case
from pyautonomousagent.bt.vocabulary import tags
from pyautonomousagent.bt.xml_format import format_value, write_xml
from pyautonomousagent.inputs import InputError
from pyautonomousagent.simulation import Scenario
from pyautonomousagent.simulation.fit import check_tree, fitting_leaves, is_general

#: A tree as the browser sends it: type (file tag or leaf type), name, ports, children.
Block = dict[str, Any]
#: The name messages give a tree made of blocks.
BLOCKS_FILE = "blocks"
#: Most blocks in one tree (a tree file's limit, bt.limits.MAX_TREE_NODES, is larger).
MAX_BLOCKS = 2000
#: What a node type or port name may be.
WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,99}")
#: What a node's name may be: one line of printable characters, at most 100.
NODE_NAME = re.compile(r"[^\x00-\x1f\x7f]{1,100}")


@dataclass
class Checked:
    """The outcome of checking a tree.

    Attributes:
        tree: the checked tree, or None when it cannot run.
        document: the tree as a file document (None when it cannot run).
        error: the loader's message ("" when the tree can run).
        block: the index of the block the message concerns, in depth-first order (-1: the
            whole tree).
    """

    tree: Node | None
    document: Document | None
    error: str = ""
    block: int = -1

    def as_dict(self) -> dict[str, Any]:
        """What the browser receives."""
        return {"ok": self.tree is not None, "error": self.error, "block": self.block}


def palette(scenario: Scenario) -> dict[str, Any]:
    """The blocks a tree for ``scenario`` may use: control nodes and decorators (file tag,
    symbol, one-line doc, parameters), and the leaves that fit the scenario (its mission's,
    then the general ones), each with its doc and ports (name, type hint, the parameter
    that gives the default and its value). Each has the name a new block of it starts with:
    the name the file loader gives an unnamed node of that type (its type in snake case)."""
    values = vars(scenario.parameters)
    controls = [
        {
            "type": t.tag,
            "name": snake_case(t.tag),
            "kind": t.kind,
            "symbol": t.symbol,
            "doc": t.doc,
            "params": [{"name": k, "required": req} for k, (_, req) in t.params.items()],
        }
        for t in tags()
    ]
    leaves = [
        {
            "type": cls.type_name,
            "name": snake_case(cls.type_name),
            "doc": cls.summary(),
            "general": is_general(cls),
            "ports": [
                {
                    "name": port.name,
                    "hint": port.hint(),
                    "doc": port.doc,
                    "default": port.default,
                    "value": plain(values.get(port.default)),
                }
                for port in cls.ports
            ],
        }
        for cls in fitting_leaves(scenario)
    ]
    return {"controls": controls, "leaves": leaves}


def plain(value: Any) -> Any:
    """``value`` as JSON has it: None, a bool, number or text as it is (a NumPy scalar as
    Python's); a number that is not finite, and anything else, as text."""
    item = value.item() if isinstance(value, np.generic) else value
    if isinstance(item, float) and not math.isfinite(item):
        return str(item)
    return item if isinstance(item, bool | int | float | str) or item is None else str(item)


def blocks_of(document: Document) -> Block:
    """The main tree of ``document`` as blocks (SubTrees inlined), checked by the loader."""
    return _block(document_from_node(build(document)).trees[DEFAULT_TREE_ID])


def _block(raw: RawNode) -> Block:
    return {
        "type": raw.tag,
        "name": raw.name,
        "ports": {k: format_value(v) for k, v in raw.ports.items()},
        "children": [_block(child) for child in raw.children],
    }


def read_upload(data: bytes, filename: str) -> Block:
    """The tree in an uploaded file, as blocks; TreeError (a TreeFileError) if the loader
    refuses it (too large, not UTF-8, not XML/YAML, an XML attack, an unknown node)."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", filename)[-80:] or "upload.xml"
    return blocks_of(document_from_bytes(data, name))


def to_document(root: Block) -> Document:
    """``root`` written as XML and read back by the loader (one node per line: line k + 3
    is the k-th block's opening tag, depth first)."""
    raw = _raw(root, [0])
    text = write_xml(Document(BLOCKS_FILE, DEFAULT_TREE_ID, {DEFAULT_TREE_ID: raw}), ())
    return parse_document(text, "xml", BLOCKS_FILE)


class BlockError(InputError):
    """A block that is not plain data of the right shape; ``block`` is its index, depth
    first."""

    def __init__(self, message: str, block: int) -> None:
        super().__init__(message)
        self.block = block


def _raw(block: Any, count: list[int]) -> RawNode:
    """A RawNode of one block (checked to be plain data of the right shape); ``count``: the
    blocks so far, depth first (a BlockError names the block by it)."""
    count[0] += 1
    index = count[0] - 1
    if count[0] > MAX_BLOCKS:
        raise BlockError(f"a tree of blocks has at most {MAX_BLOCKS} blocks", index)
    if not isinstance(block, dict) or not WORD.fullmatch(str(block.get("type"))):
        raise BlockError("each block needs a type: a node tag or a leaf type", index)
    ports = block.get("ports") or {}
    children = block.get("children") or []
    name = block.get("name")
    if not isinstance(ports, dict) or not isinstance(children, list):
        raise BlockError("a block's ports are a mapping and its children a list", index)
    if name is not None and not isinstance(name, str):
        raise BlockError("a block's name is text", index)
    name = name.strip() if name else None
    if name and not NODE_NAME.fullmatch(name):
        raise BlockError(
            f"a node's name is one line of at most 100 characters, got {name[:40]!r}", index
        )
    if not all(WORD.fullmatch(str(k)) for k in ports):
        raise BlockError("a port's name is a word of letters, digits and _", index)
    text = {str(k): str(v) for k, v in ports.items() if str(v).strip() != ""}
    kids = [_raw(child, count) for child in children]
    return RawNode(block["type"], 0, name or None, text, kids)


def check_blocks(root: Block | None, scenario: Scenario) -> Checked:
    """Check a tree of blocks as the file loader and ``pyaa run`` check a tree file."""
    if root is None:
        return Checked(None, None, "the tree is empty: drag a node into the Tree block", -1)
    try:
        document = to_document(root)
    except (InputError, TreeError) as error:  # a BlockError names its block
        return Checked(None, None, str(error), getattr(error, "block", -1))
    raws = document.trees[document.main].walk()
    tree = None
    try:
        tree = build(document)
        check_tree(tree, scenario)
    except TreeError as error:
        return Checked(None, None, str(error), _block_of(error, raws, tree))
    return Checked(tree, document)


def _block_of(error: TreeError, raws: list[RawNode], tree: Node | None) -> int:
    """The block a loader message concerns: by its line, else by a node name it quotes
    (``tree``: the built tree, None if it did not build)."""
    line = getattr(error, "line", 0)
    for i, raw in enumerate(raws):
        if line and raw.line == line:
            return i
    for i, node in enumerate(tree.walk() if tree is not None else ()):
        if node.name and f"'{node.name}'" in str(error):
            return i
    return -1


def tree_text(document: Document, fmt: str, scenario: Scenario) -> str:
    """``document`` as the text of an XML or YAML file, as ``pyaa tree SCENARIO --format``
    writes it (the XML's TreeNodesModel lists the leaves that fit the scenario)."""
    return to_text_format(document, fmt, leaves=[cls.type_name for cls in fitting_leaves(scenario)])
