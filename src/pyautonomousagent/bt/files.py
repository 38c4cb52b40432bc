"""Load and save behaviour trees as files: BehaviorTree.CPP v4 XML or YAML.

    tree = load_tree("my_tree.xml")            # a checked Node, ready for either engine
    save_tree(tree, "my_tree.yaml")            # the same tree in YAML
    document = read_document("groot2.xml")     # the file as written (SubTrees kept)
    text = to_text_format(document, "xml")     # ... written back

Errors in a file raise :class:`~pyautonomousagent.bt.document.TreeFileError`, whose
message names the file, the line and the fix. docs/tree-files.md describes both formats.
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

from pyautonomousagent.bt.build import build
from pyautonomousagent.bt.document import (
    DEFAULT_TREE_ID,
    Document,
    TreeFileError,
    document_from_node,
)
from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.trees import tree_by_name
from pyautonomousagent.bt.xml_format import read_xml, write_xml
from pyautonomousagent.bt.yaml_format import read_yaml, write_yaml
from pyautonomousagent.inputs import InputError, decode_text, read_text

FORMATS = {".xml": "xml", ".yaml": "yaml", ".yml": "yaml"}


def is_tree_file(name: str | Path) -> bool:
    """Whether ``name`` ends like a tree file (.xml, .yaml, .yml)."""
    return Path(name).suffix.lower() in FORMATS


def file_format(path: str | Path) -> str:
    """``"xml"`` or ``"yaml"`` from the file name; TreeFileError for other endings."""
    fmt = FORMATS.get(Path(path).suffix.lower())
    if fmt is None:
        raise TreeFileError(
            str(path),
            0,
            "a tree file must end in .xml, .yaml or .yml",
            "rename the file, e.g. my_tree.xml",
        )
    return fmt


def parse_document(text: str, fmt: str, file: str = "<text>") -> Document:
    """The document in ``text`` (``fmt`` ``"xml"`` or ``"yaml"``)."""
    return read_xml(text, file) if fmt == "xml" else read_yaml(text, file)


def read_document(path: str | Path) -> Document:
    """The tree file at ``path`` as written; TreeFileError if unreadable or malformed."""
    fmt = file_format(path)
    try:
        text = read_text(path, "tree file")  # bounded size, UTF-8
    except InputError as error:
        raise _unreadable(str(path), error) from None
    return parse_document(text, fmt, str(path))


def document_from_bytes(data: bytes, name: str) -> Document:
    """The tree file ``name`` whose content is ``data`` (an upload), with
    :func:`read_document`'s checks (size, UTF-8, format by ending, XML attacks refused)."""
    fmt = file_format(name)
    try:
        text = decode_text(data, name, "tree file")
    except InputError as error:
        raise _unreadable(name, error) from None
    return parse_document(text, fmt, name)


def _unreadable(name: str, error: InputError) -> TreeFileError:
    problem, _, fix = str(error).rpartition("; ")
    return TreeFileError(name, 0, f"cannot read the file ({problem})", fix or "check the path")


def scenario_document(tree: str) -> Document:
    """The document a scenario's ``tree`` names: a tree file's, or a built-in tree's."""
    if is_tree_file(tree):
        return read_document(tree)
    return document_from_node(tree_by_name(tree), tree)


def load_tree(path: str | Path) -> Node:
    """The checked tree description of the main tree of the file at ``path``."""
    return build(read_document(path))


def to_text_format(
    tree: Node | Document,
    fmt: str,
    tree_id: str = DEFAULT_TREE_ID,
    leaves: Collection[str] | None = None,
) -> str:
    """``tree`` as the text of a ``"xml"`` or ``"yaml"`` file; an XML file's TreeNodesModel
    lists ``leaves`` (and those in use) where given, else the whole library."""
    document = tree if isinstance(tree, Document) else document_from_node(tree, tree_id)
    return write_xml(document, leaves) if fmt == "xml" else write_yaml(document)


def from_text_format(text: str, fmt: str, file: str = "<text>") -> Node:
    """The checked tree description in ``text``."""
    return build(parse_document(text, fmt, file))


def save_tree(tree: Node | Document, path: str | Path, tree_id: str = DEFAULT_TREE_ID) -> Path:
    """Write ``tree`` to ``path`` in the format its ending names; returns the path."""
    path = Path(path)
    path.write_text(to_text_format(tree, file_format(path), tree_id), encoding="utf-8")
    return path
