"""Limits on the size of a tree file's trees, checked before anything is built.

A few KB of SubTrees, each used twice by the next, inline to billions of nodes; a tree
nested thousands of levels deep overflows Python's stack. :func:`check_document` measures
the main tree as it would be once inlined (size and depth), without inlining it, and
refuses it with one line naming the file and the fix. :func:`check_size` tells the
recorder that a tree built in Python has more nodes than a recording can index (the
engines themselves tick larger trees).
"""

from __future__ import annotations

from functools import partial

from pyautonomousagent.bt.document import SUBTREE, Document, RawNode, TreeFileError

#: Most nodes of a tree once its SubTrees are inlined: a recording stores the active leaf
#: of each agent as a node index in an int16 (-1: none), so indices end at 32,766.
MAX_TREE_NODES = 32_767
#: Deepest nesting of a tree once its SubTrees are inlined (the root is level 1).
MAX_TREE_DEPTH = 64


def _measure(root: RawNode, size: dict[str, int], depth: dict[str, int]) -> tuple[int, int]:
    """Nodes and levels of the tree under ``root``, SubTrees counted as measured so far
    (a SubTree not measured yet, i.e. in a cycle, counts as one node)."""
    nodes, levels = 0, 0
    stack = [(root, 1)]
    while stack:
        node, level = stack.pop()
        if node.tag == SUBTREE:
            nodes += size.get(node.subtree or "", 1)
            levels = max(levels, level - 1 + depth.get(node.subtree or "", 1))
            continue
        nodes += 1
        levels = max(levels, level)
        stack.extend((child, level + 1) for child in node.children)
    return nodes, levels


def _references(root: RawNode, trees: dict[str, RawNode]) -> list[str]:
    found, stack = [], [root]
    while stack:
        node = stack.pop()
        if node.tag == SUBTREE and node.subtree in trees:
            found.append(node.subtree)
        stack.extend(node.children)
    return found


def inlined_size(document: Document) -> tuple[int, int]:
    """Nodes and depth of the document's main tree once its SubTrees are inlined."""
    size: dict[str, int] = {}
    depth: dict[str, int] = {}
    visiting: set[str] = set()
    stack = [document.main]
    while stack:
        tree_id = stack[-1]
        if tree_id in size:
            stack.pop()
            continue
        pending = [
            ref
            for ref in _references(document.trees[tree_id], document.trees)
            if ref not in size and ref not in visiting
        ]
        if pending and tree_id not in visiting:
            visiting.add(tree_id)
            stack.extend(pending)
            continue
        size[tree_id], depth[tree_id] = _measure(document.trees[tree_id], size, depth)
        visiting.discard(tree_id)
        stack.pop()
    return size[document.main], depth[document.main]


def check_size(nodes: int) -> str:
    """The problem with a tree of ``nodes`` nodes, or "" if it is small enough."""
    if nodes <= MAX_TREE_NODES:
        return ""
    return f"has {nodes} nodes, more than the {MAX_TREE_NODES} allowed"


def check_document(document: Document) -> None:
    """Refuse a document whose main tree, inlined, is too big or too deep.

    Raises:
        TreeFileError: naming the file, the main tree's line and the fix.
    """
    nodes, levels = inlined_size(document)
    fail = partial(TreeFileError, document.file, document.lines.get(document.main, 0))
    if check_size(nodes):
        raise fail(
            f"tree {document.main!r} has {nodes} nodes once its SubTrees are inlined, more "
            f"than the {MAX_TREE_NODES} allowed",
            "use fewer nodes, or each SubTree fewer times (every use is a copy)",
        )
    if levels > MAX_TREE_DEPTH:
        raise fail(
            f"tree {document.main!r} is {levels} levels deep once its SubTrees are inlined, "
            f"more than the {MAX_TREE_DEPTH} allowed",
            "nest fewer control nodes inside each other",
        )
