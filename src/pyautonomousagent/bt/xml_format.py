"""BehaviorTree.CPP v4 XML (the format Groot2 edits): read safely, with line numbers, and write.

Reading uses the standard library's expat parser directly: every element keeps the line
it starts on, and a file with a ``<!DOCTYPE>`` (the only place entities can be declared)
is refused before anything is expanded, so neither "billion laughs" nor external entities
can do harm. Both node forms are read: compact ``<Condition_Low_Energy_Level threshold="40"/>``
and explicit ``<Condition ID="Condition_Low_Energy_Level" threshold="40"/>``; comments,
``_description``, ``_uid`` and other ``_`` attributes Groot2 writes are ignored.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from functools import partial
from typing import Any
from xml.parsers import expat
from xml.sax.saxutils import escape, quoteattr

from pyautonomousagent.bt.document import (
    DEFAULT_TREE_ID,
    SUBTREE,
    Document,
    RawNode,
    TreeFileError,
    main_tree,
)
from pyautonomousagent.bt.leaf import LEAF_TYPES
from pyautonomousagent.bt.limits import MAX_TREE_DEPTH
from pyautonomousagent.bt.vocabulary import (
    BTCPP_LEAVES,
    SCRIPT_ATTRIBUTES,
    by_tag,
    leaf_category,
)

EXPLICIT = ("Action", "Condition", "Control", "Decorator")
#: Deepest element nesting read: <root>, <BehaviorTree>, then the tree's levels.
MAX_XML_DEPTH = MAX_TREE_DEPTH + 2
#: ``TreeFileError`` with the file given: (line, message, fix) -> the error.
Fail = Callable[[int, str, str], TreeFileError]
XML_TYPES = {float: "double", int: "int", str: "std::string", bool: "bool"}


@dataclass
class _Element:
    tag: str
    attrs: dict[str, str]
    line: int
    children: list[_Element] = field(default_factory=list)


class _RefusedError(Exception):
    """What the parser refuses: its args are the line, the message and the fix."""


def parse_elements(text: str, file: str) -> _Element:
    """The element tree of ``text``, each element with its line; TreeFileError if not XML."""
    fail = partial(TreeFileError, file)
    parser = expat.ParserCreate()
    parser.ordered_attributes = True
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack: list[_Element] = []
    found: list[_Element] = []

    def start(tag: str, attrs: list[str]) -> None:
        if len(stack) >= MAX_XML_DEPTH:
            raise _RefusedError(
                parser.CurrentLineNumber,
                f"the file has more than {MAX_TREE_DEPTH} levels, which tree files may not have",
                "nest nodes less deeply: put parts in their own <BehaviorTree> and use SubTree",
            )
        element = _Element(
            tag, dict(zip(attrs[::2], attrs[1::2], strict=True)), parser.CurrentLineNumber
        )
        (stack[-1].children if stack else found).append(element)
        stack.append(element)

    def refuse(*_: Any) -> int:
        raise _RefusedError(
            parser.CurrentLineNumber,
            "the file has a <!DOCTYPE> or entity declaration, which tree files may not have "
            "(it could expand entities)",
            "delete the <!DOCTYPE ...> and <!ENTITY ...> lines",
        )

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.ExternalEntityRefHandler = refuse
    try:
        parser.Parse(text, True)
    except _RefusedError as refused:
        raise fail(*refused.args) from None
    except expat.ExpatError as error:
        message = expat.ErrorString(error.code)
        raise fail(
            error.lineno,
            f"not well-formed XML ({message}, column {error.offset + 1})",
            "check that every tag is closed and every "
            'attribute value is in quotes, e.g. threshold="40"',
        ) from None
    return found[0]


def read_xml(text: str, file: str) -> Document:
    """Read a BehaviorTree.CPP v4 XML file into a :class:`Document`."""
    fail = partial(TreeFileError, file)
    root = parse_elements(text, file)
    if root.tag != "root":
        raise fail(
            root.line,
            f"the outermost element is <{root.tag}>, not <root>",
            'wrap the trees in <root BTCPP_format="4"> ... </root>',
        )
    version = root.attrs.get("BTCPP_format", "4").strip()
    if version != "4":
        raise fail(
            root.line,
            f"BTCPP_format is {version!r}; only version 4 files are read",
            'convert the file to BehaviorTree.CPP 4 (Groot2 does it) and set BTCPP_format="4"',
        )
    trees: dict[str, RawNode] = {}
    lines: dict[str, int] = {}
    ports: dict[str, dict[str, Any]] = {}
    count = sum(element.tag == "BehaviorTree" for element in root.children)
    for element in root.children:
        if element.tag == "BehaviorTree":
            _read_tree(element, fail, count, trees, lines)
        elif element.tag == "TreeNodesModel":
            ports.update(_subtree_ports(element))
        elif element.tag == "include":
            raise fail(
                element.line,
                "<include> is not supported",
                "copy the BehaviorTrees of that file into this one",
            )
        else:
            raise fail(
                element.line,
                f"unexpected <{element.tag}> in <root>",
                "only <BehaviorTree> and <TreeNodesModel> belong in <root>",
            )
    main = _main_tree(root, trees, fail)
    return Document(file, main, trees, lines, ports)


def _read_tree(
    element: _Element, fail: Fail, count: int, trees: dict[str, RawNode], lines: dict[str, int]
) -> None:
    tree_id = element.attrs.get("ID", "").strip()
    if not tree_id:
        if count > 1:
            raise fail(
                element.line,
                "a <BehaviorTree> has no ID",
                'give every tree an ID: <BehaviorTree ID="MainTree">',
            )
        tree_id = DEFAULT_TREE_ID
    if tree_id in trees:
        raise fail(
            element.line,
            f"two BehaviorTrees have the ID {tree_id!r} "
            f"(lines {lines[tree_id]} and {element.line})",
            "give each <BehaviorTree> its own ID",
        )
    if len(element.children) != 1:
        raise fail(
            element.line,
            f"BehaviorTree {tree_id!r} has {len(element.children)} root nodes, not 1",
            "put exactly one node (e.g. a <Sequence>) directly inside it",
        )
    trees[tree_id] = _node(element.children[0], fail)
    lines[tree_id] = element.line


def _main_tree(root: _Element, trees: dict[str, RawNode], fail: Fail) -> str:
    if not trees:
        raise fail(
            root.line,
            "the file has no <BehaviorTree>",
            'add <BehaviorTree ID="MainTree"> with the tree inside <root>',
        )
    add = 'add main_tree_to_execute="{}" (the ID of the tree to run) to <root>'
    main = root.attrs.get("main_tree_to_execute")
    return main_tree(trees, main, partial(fail, root.line), "BehaviorTree", add)


def _node(element: _Element, fail: Fail) -> RawNode:
    attrs = dict(element.attrs)
    node = RawNode(element.tag, element.line, attrs.pop("name", None))
    if element.tag in (*EXPLICIT, SUBTREE):
        node_id = attrs.pop("ID", "").strip()
        if not node_id:
            raise fail(
                element.line,
                f"<{element.tag}> has no ID",
                f'say which node it is: <{element.tag} ID="...">',
            )
        if element.tag == SUBTREE:
            node.subtree = node_id
            node.autoremap = _flag(attrs.pop("_autoremap", "false"), element, fail)
        else:
            node.tag, node.category = node_id, element.tag
    elif "ID" in attrs:
        tag = by_tag().get(element.tag)
        category = tag.kind if tag else leaf_category(element.tag)
        raise fail(
            element.line,
            f"<{element.tag}> has an ID attribute",
            f"remove it (the compact form <{element.tag}> names the node already), "
            f'or write <{category} ID="{element.tag}">',
        )
    for key, value in attrs.items():
        if key in SCRIPT_ATTRIBUTES:
            node.scripts[key] = value
        elif not key.startswith("_"):
            node.ports[key] = value
    node.children = [_node(child, fail) for child in element.children]
    return node


def _flag(text: str, element: _Element, fail: Fail) -> bool:
    if text.strip().lower() in ("true", "1"):
        return True
    if text.strip().lower() in ("false", "0"):
        return False
    raise fail(
        element.line,
        f"_autoremap must be true or false, got {text!r}",
        'write _autoremap="true" or leave it out',
    )


def _subtree_ports(models: _Element) -> dict[str, dict[str, Any]]:
    """SubTree ID -> {port: default} from a TreeNodesModel (other models are ours)."""
    return {
        model.attrs["ID"]: {
            port.attrs["name"]: port.attrs["default"]
            for port in model.children
            if port.tag in ("input_port", "inout_port") and {"name", "default"} <= set(port.attrs)
        }
        for model in models.children
        if model.tag == SUBTREE and model.attrs.get("ID")
    }


# -- writing ---------------------------------------------------------------------------


def format_value(value: Any) -> str:
    """A port value as attribute text: true/false, 40, 0.5, JSON for tables."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        text = repr(value)
        return text[:-2] if text.endswith(".0") else text
    if isinstance(value, list | tuple | dict):
        return json.dumps(value, separators=(", ", ": "))
    return str(value)


def write_xml(document: Document, leaves: Collection[str] | None = None) -> str:
    """The document as BehaviorTree.CPP v4 XML, with a TreeNodesModel for Groot2: the models
    of the library's leaves, or of ``leaves`` only (e.g. those that fit a scenario) and the
    leaves the document uses."""
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<root BTCPP_format="4" main_tree_to_execute={quoteattr(document.main)}>',
    ]
    for tree_id, root in document.trees.items():
        out.append(f"  <BehaviorTree ID={quoteattr(tree_id)}>")
        _write_node(root, 2, out)
        out.append("  </BehaviorTree>")
    which = "leaf library" if leaves is None else "leaves for this scenario"
    out.append(f"  <!-- Node models for Groot2: pyAutonomousAgent's {which} -->")
    out.append("  <TreeNodesModel>")
    out.extend(_models(document, leaves))
    out.append("  </TreeNodesModel>")
    out.append("</root>")
    return "\n".join(out) + "\n"


def _write_node(node: RawNode, depth: int, out: list[str]) -> None:
    attrs = []
    if node.tag == SUBTREE:
        attrs.append(("ID", node.subtree or ""))
    if node.name is not None:
        attrs.append(("name", node.name))
    if node.autoremap:
        attrs.append(("_autoremap", "true"))
    attrs.extend((k, format_value(v)) for k, v in node.ports.items())
    attrs.extend(node.scripts.items())
    text = "".join(f" {k}={quoteattr(v)}" for k, v in attrs)
    pad = "  " * depth
    if not node.children:
        out.append(f"{pad}<{node.tag}{text}/>")
        return
    out.append(f"{pad}<{node.tag}{text}>")
    for child in node.children:
        _write_node(child, depth + 1, out)
    out.append(f"{pad}</{node.tag}>")


def _models(document: Document, leaves: Collection[str] | None) -> list[str]:
    """TreeNodesModel entries: every library leaf (or those of ``leaves`` and those in use),
    and our non-BT.CPP nodes in use."""
    used = {n.tag for root in document.trees.values() for n in root.walk()}
    out = []
    for type_name, cls in LEAF_TYPES.items():
        if type_name in BTCPP_LEAVES or (type_name == "Scripted" and type_name not in used):
            continue
        if leaves is not None and type_name not in leaves and type_name not in used:
            continue
        ports = []
        for port in cls.ports:
            doc = f"{port.doc}; default: the scenario's {port.default}"
            ports.append(
                f'<input_port name="{port.name}" type="{XML_TYPES[port.type]}">'
                f"{escape(doc)}</input_port>"
            )
        out.extend(_model(leaf_category(type_name), type_name, ports))
    for tag in by_tag().values():
        if not tag.builtin and tag.tag in used:
            ports = [
                f'<input_port name="{k}" type="{XML_TYPES[t]}"/>'
                for k, (t, _) in tag.params.items()
            ]
            out.extend(_model(tag.kind, tag.tag, ports))
    for tree_id, defaults in document.subtree_ports.items():
        ports = [
            f"<input_port name={quoteattr(k)} default={quoteattr(format_value(v))}/>"
            for k, v in defaults.items()
        ]
        out.extend(_model(SUBTREE, tree_id, ports))
    return out


def _model(kind: str, node_id: str, ports: list[str]) -> list[str]:
    if not ports:
        return [f"    <{kind} ID={quoteattr(node_id)}/>"]
    return [
        f"    <{kind} ID={quoteattr(node_id)}>",
        *(f"      {p}" for p in ports),
        f"    </{kind}>",
    ]
