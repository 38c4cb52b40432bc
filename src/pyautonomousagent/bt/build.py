"""From a tree file's :class:`Document` to a checked :class:`Node`, with clear errors.

Three steps, each naming the file and line of what it refuses:

1. inline: the main tree, with every ``SubTree`` replaced by a copy of the tree it names
   (its nodes' names prefixed with the SubTree's name and ``/``), and every ``{port}``
   reference replaced by the value the SubTree gives that port;
2. names: nodes without a ``name`` get their type in snake case (``_2``, ``_3`` if taken);
   two nodes with the same name are an error;
3. convert: each node's tag becomes a spec node type; children counts, parameters and
   leaf ports are checked and converted to numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from pyautonomousagent.bt.document import SUBTREE, Document, RawNode, TreeFileError
from pyautonomousagent.bt.leaf import ENGINE_LEAF_TYPES, LEAF_TYPES, Leaf, LeafError
from pyautonomousagent.bt.limits import check_document
from pyautonomousagent.bt.nodes import DECORATOR, NODE_TYPES
from pyautonomousagent.bt.script import ScriptError, parse
from pyautonomousagent.bt.spec import (
    BlackboardRef,
    Node,
    TreeError,
    check_structure,
    control_params,
    snake_case,
)
from pyautonomousagent.bt.vocabulary import (
    UNSUPPORTED,
    Tag,
    by_tag,
    closest,
    leaf_category,
)

DOCS = "docs/tree-files.md"


def build(document: Document) -> Node:
    """The checked tree description of ``document``'s main tree.

    Raises:
        TreeFileError: naming the file, the line and the fix.
    """
    check_document(document)  # size and depth, before inlining anything
    builder = _Builder(document)
    root = builder.inline(document.trees[document.main], _Scope(), (document.main,), "")
    _assign_names(root, document.file)
    node = builder.convert(root)
    try:
        check_structure(node)
    except TreeError as error:  # what only the whole tree shows (BT.CPP's async rule)
        raise TreeFileError(document.file, root.line, str(error), "fix the tree") from None
    return node


@dataclass
class _Scope:
    """The ports a SubTree's nodes may refer to as ``{port}``.

    Attributes:
        values: port -> value, already resolved in the enclosing scope.
        parent: the enclosing scope, or None for the main tree.
        autoremap: whether ports not given fall through to the enclosing scope.
        tree: the SubTree's ID; line: the line of the ``<SubTree>`` element.
    """

    values: dict[str, Any] | None = None
    parent: _Scope | None = None
    autoremap: bool = False
    tree: str = ""
    line: int = 0


def reference(value: Any) -> str | None:
    """The key of a blackboard reference ``{key}``, or None for a plain value."""
    if isinstance(value, str) and len(value) >= 2 and value[0] == "{" and value[-1] == "}":
        return value[1:-1].strip()
    return None


class _Builder:
    def __init__(self, document: Document) -> None:
        self.doc = document
        self.instances: dict[str, int] = {}  # SubTree name prefix -> line of its <SubTree>
        self.tags = by_tag()  # once per file, not once per node

    def fail(self, line: int, message: str, fix: str) -> TreeFileError:
        return TreeFileError(self.doc.file, line, message, fix)

    # -- step 1: SubTrees and {port} references -------------------------------------------

    def inline(self, node: RawNode, scope: _Scope, stack: tuple[str, ...], prefix: str) -> RawNode:
        """A copy of ``node`` with SubTrees inlined and references resolved."""
        if node.tag == SUBTREE:
            return self._subtree(node, scope, stack, prefix)
        ports = {k: self._resolve(v, k, scope, node.line_of(k)) for k, v in node.ports.items()}
        children = [self.inline(child, scope, stack, prefix) for child in node.children]
        name = prefix + node.name if node.name else None
        return replace(node, name=name, ports=ports, children=children, prefix=prefix)

    def _subtree(
        self, node: RawNode, scope: _Scope, stack: tuple[str, ...], prefix: str
    ) -> RawNode:
        tree_id = node.subtree or ""
        if node.children:
            raise self.fail(
                node.line,
                f"<SubTree ID={tree_id!r}> has child nodes",
                "a SubTree takes no children: its nodes are those of the tree it names",
            )
        if tree_id not in self.doc.trees:
            hint = closest(tree_id, list(self.doc.trees))
            known = ", ".join(self.doc.trees)
            raise self.fail(
                node.line,
                f"SubTree ID {tree_id!r} names no BehaviorTree of this file",
                hint or f"use one of the trees defined here: {known}",
            )
        if tree_id in stack:
            chain = " -> ".join((*stack, tree_id))
            raise self.fail(
                node.line,
                f"SubTree {tree_id!r} contains itself ({chain})",
                "a tree cannot include itself, directly or through other trees; "
                "remove this SubTree",
            )
        values = {
            k: self._resolve("{" + k + "}" if v == "{=}" else v, k, scope, node.line_of(k))
            for k, v in node.ports.items()
        }
        for port, default in self.doc.subtree_ports.get(tree_id, {}).items():
            if port not in values and not node.autoremap:
                values[port] = self._resolve(default, port, scope, node.line)
        inner = _Scope(values, scope, node.autoremap, tree_id, node.line)
        tree = self.doc.trees[tree_id]
        return self.inline(tree, inner, (*stack, tree_id), self._instance(node, prefix))

    def _instance(self, node: RawNode, prefix: str) -> str:
        """The name prefix of a SubTree's nodes: ``prefix`` + its name (made up if none) + /."""
        base = prefix + (node.name or snake_case(node.subtree or ""))
        name, n = base, 2
        while name in self.instances:
            if node.name:
                raise self.fail(
                    node.line,
                    f"two SubTrees are named {node.name!r} (lines {self.instances[name]} "
                    f"and {node.line})",
                    "give each SubTree its own name, or leave name out",
                )
            name, n = f"{base}_{n}", n + 1
        self.instances[name] = node.line
        return name + "/"

    def _resolve(self, value: Any, port: str, scope: _Scope, line: int) -> Any:
        """``value``, or the value its ``{key}`` reference stands for in ``scope``."""
        key = reference(value)
        if key is None:
            return value
        if not key.isidentifier():
            raise self.fail(
                line,
                f"port {port!r}: {value!r} is not a reference to a port name",
                "write {name} with a name made of letters, digits and _",
            )
        while scope.values is not None:
            if key in scope.values:
                return scope.values[key]
            if not scope.autoremap or scope.parent is None:
                raise self.fail(
                    line,
                    f"port {port!r} refers to {{{key}}}, which SubTree "
                    f"{scope.tree!r} (line {scope.line}) is not given",
                    f'add {key}="..." or _autoremap="true" to that <SubTree>',
                )
            scope = scope.parent
        return BlackboardRef(key)  # the main tree: the agent's blackboard entry

    # -- step 3: tags to spec nodes ------------------------------------------------------

    def convert(self, node: RawNode) -> Node:
        """The spec node for an inlined, named raw node (with its scripting attributes)."""
        made = self._convert(node)
        if not node.scripts:
            return made
        for key, code in node.scripts.items():
            try:
                parse(code)
            except ScriptError as error:
                raise self.fail(
                    node.line_of(key),
                    f"{key}: {error}",
                    "write it in BehaviorTree.CPP's scripting language (docs/tree-files.md)",
                ) from None
        return replace(made, scripts=dict(node.scripts))

    def _convert(self, node: RawNode) -> Node:
        children = tuple(self.convert(child) for child in node.children)
        tag = self.tags.get(node.tag)
        if tag is not None:
            return self._control(node, tag, children)
        if node.tag in LEAF_TYPES or node.tag in ENGINE_LEAF_TYPES:
            return self._leaf(node, children)
        if node.tag in UNSUPPORTED:
            raise self.fail(
                node.line,
                f"BehaviorTree.CPP node {node.tag!r} is not supported: {UNSUPPORTED[node.tag]}",
                f"build it from the supported nodes listed in {DOCS}",
            )
        known = list(self.tags) + list(LEAF_TYPES) + sorted(ENGINE_LEAF_TYPES)
        hint = closest(node.tag, known)
        raise self.fail(
            node.line,
            f"unknown node {node.tag!r}",
            hint or f"use a control node or leaf listed in {DOCS}",
        )

    def _control(self, node: RawNode, tag: Tag, children: tuple[Node, ...]) -> Node:
        if node.category and node.category != tag.kind:
            raise self.fail(
                node.line,
                f"{tag.tag} is a {tag.kind}, not {_a(node.category)}",
                f'write <{tag.kind} ID="{tag.tag}"> or <{tag.tag}>',
            )
        if tag.kind == DECORATOR and len(children) != 1:
            raise self.fail(
                node.line,
                f"decorator {tag.tag} needs exactly 1 child, has {len(children)}",
                "put exactly one node inside it"
                + ("; wrap several in a Sequence" if children else ""),
            )
        if not children:
            raise self.fail(
                node.line,
                f"{tag.tag} needs at least 1 child, has 0",
                f"put the nodes it should tick inside <{tag.tag}>...</{tag.tag}>",
            )
        record = NODE_TYPES.get(tag.spec)
        if len(children) < record.least or (
            record.most is not None and len(children) > record.most
        ):
            raise self.fail(
                node.line,
                f"{tag.tag} needs {record.least} to {record.most} children, has {len(children)}",
                "the first child is the condition, then the then- and else-branch",
            )
        params = self._params(node, tag)
        entries = {p.name for p in record.params if p.entry}
        for key, value in params.items():
            if isinstance(value, BlackboardRef) and key not in entries:
                raise self.fail(
                    node.line_of(key),
                    f"{tag.tag}: {key}={value} reads the blackboard, which control node "
                    "parameters cannot",
                    f'write the value itself, e.g. {key}="3"',
                )
        spec = Node(tag.spec, node.name or "", children, {**tag.fixed, **params})
        try:
            control_params(spec)
        except TreeError as error:
            message = str(error).replace(tag.spec, tag.tag, 1)  # the word the file uses
            at = [k for k in params if f": {k}" in message]  # the parameter's own line
            line = node.line_of(at[0]) if at else node.line
            raise self.fail(line, message, _param_fix(tag, len(children))) from None
        return spec

    def _params(self, node: RawNode, tag: Tag) -> dict[str, Any]:
        params: dict[str, Any] = {}
        for key, value in node.ports.items():
            if key not in tag.params:
                takes = ", ".join(tag.params) or "no parameters"
                hint = closest(key, list(tag.params))
                raise self.fail(
                    node.line_of(key),
                    f"{tag.tag} has no parameter {key!r}",
                    hint or f"remove it ({tag.tag} takes {takes})",
                )
            params[key] = self._value(node, key, value, tag.params[key][0])
        for key, (_, required) in tag.params.items():
            if required and key not in params:
                raise self.fail(
                    node.line,
                    f"{tag.tag} needs parameter {key!r}",
                    f'add it, e.g. <{tag.tag} {key}="3">',
                )
        return params

    def _value(self, node: RawNode, key: str, value: Any, kind: type) -> Any:
        """A control parameter as ``kind`` (XML gives text)."""
        if not isinstance(value, str) or kind is str:
            return value
        text = value.strip()
        if kind is bool and text.lower() in ("true", "false"):
            return text.lower() == "true"
        if kind is int and text.lstrip("+-").isdigit():
            return int(text)
        must = "true or false" if kind is bool else "a whole number"
        raise self.fail(
            node.line_of(key),
            f"{node.tag}: {key} must be {must}, got {text!r}",
            f'write e.g. {key}="{"true" if kind is bool else 3}"',
        )

    def _leaf(self, node: RawNode, children: tuple[Node, ...]) -> Node:
        if children:
            raise self.fail(
                node.line,
                f"leaf {node.tag} cannot have child nodes",
                f"move the nodes inside <{node.tag}> next to it, under a control node",
            )
        category = leaf_category(node.tag)
        if node.category is not None and node.category != category:
            raise self.fail(
                node.line,
                f"{node.tag} is {_a(category)}, not {_a(node.category)}",
                f'write <{category} ID="{node.tag}"/>',
            )
        if node.tag in ENGINE_LEAF_TYPES and node.tag not in LEAF_TYPES:
            return Node(node.tag, node.name or "", (), dict(node.ports))
        cls = LEAF_TYPES[node.tag]
        where = f"leaf {node.name!r} ({node.tag})"
        return Node(node.tag, node.name or "", (), self._ports(node, cls, where))

    def _ports(self, node: RawNode, cls: type[Leaf], where: str) -> dict[str, Any]:
        names = cls.port_names()
        params: dict[str, Any] = {}
        for key, value in node.ports.items():
            if isinstance(value, BlackboardRef) and key in names and not cls.text_ports:
                params[key] = value  # read from the agent's blackboard on every tick
                continue
            if key not in names:
                ports = ", ".join(names) or "none"
                hint = closest(key, names)
                raise self.fail(
                    node.line_of(key),
                    f"{node.tag} has no port {key!r}",
                    hint or f"remove it ({node.tag}'s ports: {ports})",
                )
            try:
                params[key] = cls.parse_port(key, value, where)
            except LeafError as error:
                fix = f"write {key} as {cls.port_hint(key)}"
                raise self.fail(node.line_of(key), str(error), fix) from None
        for key in cls.required_ports():
            if key not in params:
                raise self.fail(
                    node.line, f"{node.tag} needs port {key!r}", f"add {key}: {cls.port_hint(key)}"
                )
        return params


def _a(word: str) -> str:
    """``"an Action"``, ``"a Condition"``."""
    return f"{'an' if word[0] in 'AEIOU' else 'a'} {word}"


def _param_fix(tag: Tag, children: int) -> str:
    if tag.spec in ("Parallel", "ParallelAll"):
        return f"use a count from 1 to {children}, or -1 (all) to -{children}"
    if tag.spec == "PyTreesParallel":
        return "use policy SuccessOnAll or SuccessOnOne (synchronise only with SuccessOnAll)"
    if tag.spec in ("Repeat", "RetryUntilSuccessful"):
        return "use a whole number >= 1, or -1 for no limit"
    if tag.spec == "Precondition":
        return "write `if` in BehaviorTree.CPP's scripting language (docs/tree-files.md)"
    if tag.spec in ("Delay", "Timeout"):
        return "use a whole number of milliseconds >= 0 (simulated time)"
    return "use a whole number >= 1"


def _assign_names(root: RawNode, file: str) -> None:
    """Give unnamed nodes their type in snake case; refuse two nodes with one name."""
    lines: dict[str, int] = {}
    for node in root.walk():
        if node.name is None:
            continue
        if node.name in lines:
            raise TreeFileError(
                file,
                node.line,
                f"two nodes are named {node.name!r} (lines {lines[node.name]} and {node.line})",
                "give each node its own name, or leave name out",
            )
        lines[node.name] = node.line
    suffix: dict[str, int] = {}  # base -> the next number to try (linear, not quadratic)
    for node in root.walk():
        if node.name is None:
            base = node.prefix + snake_case(node.tag)
            name, n = base, suffix.get(base, 2)
            while name in lines:
                name, n = f"{base}_{n}", n + 1
            suffix[base] = n
            node.name = name
            lines[name] = node.line
