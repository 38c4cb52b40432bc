"""Tree files in YAML: the same vocabulary as the XML, for writing trees by hand.

A file is a mapping with ``tree`` (one tree) or ``trees`` (ID -> tree, with
``main_tree_to_execute``). A node is a mapping: ``type`` (a control tag, a leaf type or
``SubTree``), optional ``name``, ``children`` (a list of nodes) and its ports as further
keys; a SubTree also has ``ID`` and optionally ``_autoremap``. docs/tree-files.md has the
schema. Files are read with ``yaml.SafeLoader`` into its node graph, so every error can name
its line, and a key given twice is an error rather than silently dropped.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import yaml

from pyautonomousagent.bt.document import (
    DEFAULT_TREE_ID,
    SUBTREE,
    Document,
    RawNode,
    TreeFileError,
    main_tree,
)
from pyautonomousagent.bt.vocabulary import SCRIPT_ATTRIBUTES, closest
from pyautonomousagent.inputs import Loader, YamlLimitError, clip, yaml_error_line

TOP_KEYS = ["main_tree_to_execute", "tree", "trees", "subtree_ports"]
DOCS = "docs/tree-files.md"


def _line(node: yaml.Node) -> int:
    return node.start_mark.line + 1


class _Reader:
    def __init__(self, text: str, file: str) -> None:
        self.file = file
        self.loader = Loader(text)  # safe, with limits on depth, aliases and repeated keys

    def fail(self, node: yaml.Node | int, message: str, fix: str) -> TreeFileError:
        line = node if isinstance(node, int) else _line(node)
        return TreeFileError(self.file, line, message, fix)

    def value(self, node: yaml.Node) -> Any:
        try:
            return self.loader.construct_object(node, deep=True)
        except (yaml.YAMLError, ValueError, OverflowError, TypeError) as error:
            problem = error.problem if isinstance(error, yaml.MarkedYAMLError) else str(error)
            raise self.fail(
                node,
                f"this value cannot be read ({clip(str(problem), 120)})",
                "write a plain number, true/false or text (quote text that looks like a date)",
            ) from None

    def mapping(self, node: yaml.Node, what: str, fix: str) -> dict[str, tuple[int, yaml.Node]]:
        """A YAML mapping's keys -> (line, value node); refuses repeated keys."""
        if not isinstance(node, yaml.MappingNode):
            raise self.fail(node, f"{what} must be a mapping of keys to values", fix)
        found: dict[str, tuple[int, yaml.Node]] = {}
        for key_node, value_node in node.value:
            key = str(self.value(key_node))
            if key in found:
                raise self.fail(
                    key_node,
                    f"key {key!r} is given twice (lines {found[key][0]} and {_line(key_node)})",
                    "keep one of them",
                )
            found[key] = (_line(key_node), value_node)
        return found

    def text(self, node: yaml.Node, what: str, fix: str) -> str:
        value = self.value(node)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(node, f"{what} must be a non-empty string, got {value!r}", fix)
        return value.strip()

    def document(self) -> Document:
        try:
            top = self.loader.get_single_node()
        except YamlLimitError as error:
            line, problem = yaml_error_line(error)
            raise self.fail(line, problem, error.fix) from None
        except yaml.YAMLError as error:
            line, problem = yaml_error_line(error)
            raise self.fail(
                line or 1,
                f"not valid YAML ({problem})",
                "check the indentation and the ': ' after each key near this line",
            ) from None
        if top is None:
            raise self.fail(1, "the file is empty", f"write a tree as shown in {DOCS}")
        keys = self.mapping(top, "the file", "start with 'tree:' followed by the root node")
        for key, (line, _) in keys.items():
            if key not in TOP_KEYS:
                hint = closest(key, TOP_KEYS)
                raise self.fail(line, f"unknown key {key!r}", hint or f"use {', '.join(TOP_KEYS)}")
        trees, lines = self.trees(top, keys)
        main = self.main(top, keys, trees)
        ports = self.subtree_ports(keys)
        return Document(self.file, main, trees, lines, ports)

    def trees(
        self, top: yaml.Node, keys: dict[str, tuple[int, yaml.Node]]
    ) -> tuple[dict[str, RawNode], dict[str, int]]:
        if ("tree" in keys) == ("trees" in keys):
            raise self.fail(
                top,
                "the file needs exactly one of 'tree' and 'trees'",
                "use 'tree:' for one tree, 'trees:' (ID: tree, ...) for several",
            )
        if "tree" in keys:
            line, node = keys["tree"]
            return {DEFAULT_TREE_ID: self.node(node)}, {DEFAULT_TREE_ID: line}
        fix = "list the trees as ID: root node, e.g. 'MainTree: {type: Sequence, ...}'"
        entries = self.mapping(keys["trees"][1], "'trees'", fix)
        if not entries:
            raise self.fail(keys["trees"][1], "'trees' is empty", fix)
        trees = {key: self.node(node) for key, (_, node) in entries.items()}
        return trees, {key: line for key, (line, _) in entries.items()}

    def main(self, top: yaml.Node, keys: dict[str, tuple[int, yaml.Node]], trees: dict) -> str:
        line, node = keys.get("main_tree_to_execute", (0, None))
        fix = "name the tree to run"
        main = None if node is None else self.text(node, "main_tree_to_execute", fix)
        add = "add 'main_tree_to_execute: {}'"
        return main_tree(trees, main, partial(self.fail, line or top), "tree", add)

    def subtree_ports(self, keys: dict[str, tuple[int, yaml.Node]]) -> dict[str, dict[str, Any]]:
        if "subtree_ports" not in keys:
            return {}
        fix = "write 'subtree_ports: {TreeID: {port: default}}'"
        entries = self.mapping(keys["subtree_ports"][1], "'subtree_ports'", fix)
        return {
            key: {k: self.value(v) for k, (_, v) in self.mapping(node, key, fix).items()}
            for key, (_, node) in entries.items()
        }

    def node(self, node: yaml.Node) -> RawNode:
        fix = "write a node as a mapping, e.g. {type: Condition_Low_Energy_Level, threshold: 40}"
        keys = self.mapping(node, "a tree node", fix)
        if "type" not in keys:
            raise self.fail(
                node,
                "a node has no 'type'",
                f"add 'type:' with a control node or leaf type (see {DOCS})",
            )
        raw = RawNode(self.text(keys["type"][1], "type", "name the node type"), _line(node))
        for key, (line, value) in keys.items():
            self.field(raw, key, line, value)
        if raw.tag == SUBTREE and raw.subtree is None:
            raise self.fail(node, "a SubTree has no 'ID'", "add 'ID:' with the tree it includes")
        return raw

    def field(self, raw: RawNode, key: str, line: int, value: yaml.Node) -> None:
        if key == "name":
            raw.name = self.text(value, "name", "give the node a name, or leave name out")
        elif key == "children":
            if not isinstance(value, yaml.SequenceNode):
                raise self.fail(
                    value,
                    "children must be a list of nodes",
                    "write each child on its own line starting with '- type: ...'",
                )
            raw.children = [self.node(child) for child in value.value]
        elif key == "ID":
            if raw.tag != SUBTREE:
                raise self.fail(
                    line, f"{raw.tag} has an 'ID'", "only a SubTree takes an ID; remove it"
                )
            raw.subtree = self.text(value, "ID", "name the tree to include")
        elif key == "_autoremap":
            flag = self.value(value)
            if not isinstance(flag, bool):
                raise self.fail(
                    line,
                    f"_autoremap must be true or false, got {flag!r}",
                    "write '_autoremap: true' or leave it out",
                )
            raw.autoremap = flag
        elif key in SCRIPT_ATTRIBUTES:
            raw.scripts[key] = self.text(value, key, "write the script as text")
            raw.port_lines[key] = line
        elif key != "type" and not key.startswith("_"):
            raw.ports[key] = self.port(key, line, value)
            raw.port_lines[key] = line

    def port(self, key: str, line: int, node: yaml.Node) -> Any:
        if isinstance(node, yaml.MappingNode):
            raise self.fail(
                line,
                f"port {key!r} is a mapping",
                "write the value itself; to refer "
                f'to a SubTree port write it in quotes: {key}: "{{name}}"',
            )
        return self.value(node)


def read_yaml(text: str, file: str) -> Document:
    """Read a YAML tree file into a :class:`Document`."""
    try:
        reader = _Reader(text, file)
    except yaml.YAMLError as error:  # the reader refuses some characters at once
        line, problem = yaml_error_line(error)
        raise TreeFileError(file, line, f"not valid YAML ({problem})", "remove it") from None
    try:
        return reader.document()
    finally:
        reader.loader.dispose()


class _Flow(list[Any]):
    """A list written on one line (port values such as status tables)."""


class _Dumper(yaml.SafeDumper):
    """Indents list items under their key, which reads better in trees."""

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        super().increase_indent(flow, False)


_Dumper.add_representer(
    _Flow, lambda d, v: d.represent_sequence("tag:yaml.org,2002:seq", v, flow_style=True)
)


def write_yaml(document: Document) -> str:
    """The document as YAML (see docs/tree-files.md)."""
    data: dict[str, Any] = {"main_tree_to_execute": document.main}
    data["trees"] = {tree_id: _plain(root) for tree_id, root in document.trees.items()}
    if document.subtree_ports:
        data["subtree_ports"] = document.subtree_ports
    body = yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
    return f"# pyAutonomousAgent behaviour tree ({DOCS})\n{body}"


def _plain(node: RawNode) -> dict[str, Any]:
    data: dict[str, Any] = {"type": node.tag}
    if node.subtree is not None:
        data["ID"] = node.subtree
    if node.name is not None:
        data["name"] = node.name
    if node.autoremap:
        data["_autoremap"] = True
    for key, value in node.ports.items():
        data[key] = _Flow(value) if isinstance(value, list | tuple) else value
    data.update(node.scripts)
    if node.children:
        data["children"] = [_plain(child) for child in node.children]
    return data
