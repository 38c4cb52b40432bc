"""A tree's tick for one agent as straight-line Python source, from the node types' rules.

The compiled engine (numba) and the GPU engine (numba-cuda) both compile this code: every
control node's rule (:mod:`pyautonomousagent.bt.rules`) is run once with :class:`SourceOps`,
which writes what it does for agent ``a`` instead of doing it. ``st`` holds the node statuses
(nodes, N) int8 and ``cur`` what each node with ``memory`` remembers (one row per such node,
(M, N) int32); ``halt(a, st, node, end)`` is ``engines/compiled_runtime.halt``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

from pyautonomousagent.bt.nodes import NODE_TYPES, may_skip
from pyautonomousagent.bt.program import Program
from pyautonomousagent.bt.script_leaves import iterations


def _operator(op: str, flip: bool = False) -> Callable[[Source, Any], Source]:
    """The method of operator ``op`` (its reflected form with ``flip``): :meth:`Source._op`."""
    return lambda self, other: self._op(op, other, flip)


class Source:
    """A value of the generated code: its source text; comparisons, ``&``/``|`` and ``+`` make
    the text of the combined value."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __str__(self) -> str:
        return self.text

    def _op(self, op: str, other: Any, flip: bool = False) -> Source:
        left, right = (other, self) if flip else (self, other)
        return Source(f"({source_text(left)} {op} {source_text(right)})")

    __eq__ = _operator("==")  # type: ignore[assignment]
    __ne__ = _operator("!=")  # type: ignore[assignment]
    __lt__, __le__, __gt__, __ge__ = (_operator(op) for op in ("<", "<=", ">", ">="))
    __and__, __rand__ = _operator("and"), _operator("and", flip=True)
    __or__, __ror__ = _operator("or"), _operator("or", flip=True)
    __add__, __radd__ = _operator("+"), _operator("+", flip=True)
    __hash__ = None  # type: ignore[assignment]


def source_text(value: Any) -> str:
    """Source text of a value: a :class:`Source`, a bool, a float (not NaN) or a whole
    number."""
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else f"({'-' * (value < 0)}1e999)"
    return value.text if isinstance(value, Source) else str(int(value))


#: At most this many children are halted in a row of code each; more, by a loop (the code of
#: a node then grows linearly, not quadratically, with its children).
UNROLLED = 4


class CodeOps:
    """What the :class:`~pyautonomousagent.bt.rules.Ops` that write a rule as code share: the
    lines (:attr:`lines`, indented by block), a ``let`` kept in a local, a ``pick``, a
    ``when`` block opened by :meth:`_open` (a block left empty is dropped: a condition has
    no side effect; a static condition must hold) and a ``loop`` (``while True:``, then
    :meth:`_after_loop`). ``skippable``: per child, may it be SKIPPED (``nodes.may_skip``);
    ``time_step``: the scenario's, seconds (for ``iterations``)."""

    def __init__(
        self,
        kids: int,
        params: Mapping[str, Any],
        skippable: Sequence[bool],
        time_step: float,
    ) -> None:
        self.kids, self.params, self._skippable = kids, params, tuple(skippable)
        self.time_step = time_step
        self.lines: list[str] = []
        self._depth = 0

    def _emit(self, line: str) -> None:
        self.lines.append("    " * self._depth + line)

    def skippable(self, k: int) -> bool:
        return self._skippable[k]

    def _local(self, name: str) -> str:
        """The name of a rule's local ``name`` in the code."""
        return name

    def let(self, name: str, value: Any) -> Any:
        if not isinstance(value, Source):
            return value
        self._emit(f"{self._local(name)} = {value.text}")
        return type(value)(self._local(name))

    def pick(self, cond: Any, if_true: Any, if_false: Any) -> Any:
        if not isinstance(cond, Source):
            return if_true if cond else if_false
        return Source(f"({source_text(if_true)} if {cond.text} else {source_text(if_false)})")

    def _open(self, cond: Source) -> list[str]:
        """The lines that open a block for ``cond``."""
        return [f"if {cond.text}:"]

    def _close(self) -> None:
        """After a block (its lines written, the depth back to the enclosing one)."""

    def iterations(self, msec: int) -> int:
        return iterations(msec, {"time_step": self.time_step})

    def _open_loop(self) -> list[str]:
        """The lines that open a ``loop`` block."""
        return ["while True:"]

    def _after_loop(self) -> None:
        """After a ``loop`` block (the depth back to the enclosing one)."""

    @contextmanager
    def loop(self) -> Iterator[None]:
        for line in self._open_loop():
            self._emit(line)
        self._depth += 1
        yield
        self._depth -= 1
        self._after_loop()

    @contextmanager
    def when(self, cond: Any) -> Iterator[None]:
        if not isinstance(cond, Source):
            if not cond:
                raise ValueError("a rule's condition is false whatever the agent")
            yield
            return
        size = len(self.lines)
        for line in self._open(cond):
            self._emit(line)
        head = len(self.lines)
        self._depth += 1
        yield
        self._depth -= 1
        self._close()
        if len(self.lines) == head:
            del self.lines[size:]


class SourceOps(CodeOps):
    """:class:`~pyautonomousagent.bt.rules.Ops` that writes node ``i``'s rule as code for agent
    ``a``: its lines in :attr:`lines`, children written in place by ``expand``; a ``finish``
    leaves the node's ``while True:`` block with ``break`` (the block of a ``loop`` in it, then
    the node's); locals end in ``_<i>``; the iteration is ``t``, blackboard entry ``key``
    ``entry(key)``."""

    def __init__(
        self,
        program: Program,
        i: int,
        row: int,
        expand: Callable[[int], list[str]],
        time_step: float,
        entry: Callable[[str], str],
    ) -> None:
        self.program, self.i, self.row, self._expand = program, i, row, expand
        self.entry = lambda key: Source(entry(key))
        self.children = program.children[i]
        skippable = [may_skip(program.nodes[child]) for child in self.children]
        super().__init__(len(self.children), program.params[i], skippable, time_step)

    def _local(self, name: str) -> str:
        return f"{name}_{self.i}"

    def status(self) -> Source:
        return Source(f"st[{self.i}, a]")

    def memory(self, slot: int = 0) -> Source:
        return Source(f"cur[{self.row + slot}, a]")

    def now(self) -> Source:
        return Source("t")

    def _after_loop(self) -> None:
        self._emit("break")  # a loop is left by a finish only: the node has finished

    def set_memory(self, value: Any, slot: int = 0) -> None:
        self._emit(f"cur[{self.row + slot}, a] = {source_text(value)}")

    def child(self, k: int) -> Source:
        return Source(f"st[{self.children[k]}, a]")

    def tick(self, k: int) -> Source:
        child = self.children[k]
        self.lines += ["    " * self._depth + line for line in self._expand(child)]
        self._emit(f"res_{self.i} = st[{child}, a]")
        return Source(f"res_{self.i}")

    def halt(self, first: int, last: int | None = None) -> None:
        spans = [(child, self.program.end[child]) for child in self.children[first:last]]
        if len(spans) > UNROLLED:  # a loop over (child, end) pairs: linear code
            pairs = ", ".join(f"({child}, {end})" for child, end in spans)
            self._emit(f"for span_{self.i} in ({pairs},):")
            self._emit(f"    halt(a, st, span_{self.i}[0], span_{self.i}[1])")
            return
        for child, end in spans:
            self._emit(f"halt(a, st, {child}, {end})")

    def lookup(self, table: tuple[int, ...], value: Any) -> Source:
        return Source(f"({', '.join(map(str, table))},)[{source_text(value)}]")

    def finish(self, status: Any, where: Any = True) -> None:
        with self.when(where):
            self._emit(f"st[{self.i}, a] = {source_text(status)}")
            if self._depth or isinstance(where, Source):
                self._emit("break")


def memory_rows(program: Program) -> dict[int, int]:
    """Node index -> its first row of ``cur`` (one row per number the node's record says it
    remembers, ``memory``); ``cur`` has :func:`memory_size` rows."""
    rows, row = {}, 0
    for i, node in enumerate(program.nodes):
        if node.is_control and node_record(program, i).memory:
            rows[i], row = row, row + node_record(program, i).memory
    return rows


def memory_size(program: Program) -> int:
    """The rows of ``cur``: what the control nodes remember, in all."""
    return sum(node_record(program, i).memory for i, n in enumerate(program.nodes) if n.is_control)


def node_record(program: Program, i: int) -> Any:
    """The :class:`~pyautonomousagent.bt.nodes.NodeType` of control node ``i``."""
    return NODE_TYPES.get(program.nodes[i].type)


def has_source(program: Program) -> bool:
    """Whether every control node of ``program`` has a rule and no scripting attribute."""
    return all(
        not node.scripts and (not node.is_control or node_record(program, i).rule is not None)
        for i, node in enumerate(program.nodes)
    )


def tree_body(
    program: Program,
    leaf_lines: Callable[[int], list[str]],
    rows: Mapping[int, int],
    indent: str,
    time_step: float,
    entry: Callable[[str], str],
) -> str:
    """The tick of agent ``a`` at iteration ``t`` as straight-line code, indented by ``indent``:
    each control node is a ``while True:`` block left with ``break``, its children written in
    place; a leaf is ``leaf_lines(i)``; ``time_step``: the scenario's, seconds; ``entry(key)``:
    the source of agent ``a``'s blackboard entry ``key``. One body with no calls between
    nodes: numba passes no arrays between functions (which costs reference counting per call
    and made a tick ten times slower)."""

    def expand(i: int) -> list[str]:
        if not program.nodes[i].is_control:
            return leaf_lines(i)
        ops = SourceOps(program, i, rows.get(i, -1), expand, time_step, entry)
        rule = node_record(program, i).rule
        assert rule is not None, program.nodes[i].type
        rule(ops)
        return ["while True:", *("    " + line for line in ops.lines), "    break"]

    return "\n".join(indent + line for line in expand(0))
