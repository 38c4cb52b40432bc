"""A node type's rule as NumPy source over all agents, generated once per node of a program.

The rule (:mod:`pyautonomousagent.bt.rules`) is run once with :class:`ArraySourceOps`, which
writes what it does for the agents of a mask as straight-line NumPy code: values are arrays
over agents (N,), a ``when`` block is the agents of its mask (``e1 = e0 & cond``, skipped
when none), and a ``finish`` takes its agents out of every enclosing mask (the function
returns once none is left). :func:`rule_ticker` compiles it for node ``i`` of a batched
engine, bound to that node's rows, so a tick interprets no rule.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.program import Program
from pyautonomousagent.bt.spec import may_skip
from pyautonomousagent.bt.tree_source import UNROLLED, CodeOps, Source, source_text


class ArraySource(Source):
    """An array over agents in the generated code: ``&``/``|`` are NumPy's."""

    def _op(self, op: str, other: Any, flip: bool = False) -> Source:
        op = {"and": "&", "or": "|"}.get(op, op)
        left, right = (other, self) if flip else (self, other)
        return ArraySource(f"({source_text(left)} {op} {source_text(right)})")


class ArraySourceOps(CodeOps):
    """:class:`~pyautonomousagent.bt.rules.Ops` that writes node ``i``'s rule as the body of
    ``tick(mask)``: its own status row is ``st``, child ``k``'s ``S<k>`` (ticked by
    ``tickers[child](e)``, halted by ``halt(child, e)``), memory slot ``s`` the row ``M<s>``;
    the mask of the agents of the current block is ``e<depth>``."""

    def __init__(self, program: Program, i: int) -> None:
        self.children = program.children[i]
        skippable = [may_skip(program.nodes[c]) for c in self.children]
        super().__init__(len(self.children), program.params[i], skippable)
        self.lines = ["e0 = mask.copy()"]
        self.tables: dict[str, np.ndarray] = {}
        self._dead: int | None = None  # a block (depth) every agent of which has finished
        self._some = [True]  # per depth: its mask is known to have an agent (no finish since)

    def _emit(self, line: str) -> None:
        if self._dead is None or self._depth < self._dead:
            super()._emit(line)

    def status(self) -> ArraySource:
        return ArraySource("st")

    def memory(self, slot: int = 0) -> ArraySource:
        return ArraySource(f"M{slot}")

    def set_memory(self, value: Any, slot: int = 0) -> None:
        self._emit(f"copyto(M{slot}, {source_text(value)}, where=e{self._depth})")

    def child(self, k: int) -> ArraySource:
        return ArraySource(f"S{k}")

    def _call(self, calls: list[str]) -> None:
        """``calls`` for the agents of the current block, if it has any left."""
        known = self._some[self._depth]
        if calls and not known:
            self._emit(f"if count(e{self._depth}):")
        for call in calls:
            self._emit(("" if known else "    ") + call)

    def tick(self, k: int) -> ArraySource:
        self._call([f"tickers[{self.children[k]}](e{self._depth})"])
        return ArraySource(f"S{k}")

    def halt(self, first: int, last: int | None = None) -> None:
        chosen = self.children[first:last]
        if len(chosen) > UNROLLED:  # a loop: the code stays linear in the children
            self._call([f"for child in KIDS[{first}:{last}]:", f"    halt(child, e{self._depth})"])
        else:
            self._call([f"halt({child}, e{self._depth})" for child in chosen])

    def let(self, name: str, value: Any) -> Any:
        if isinstance(value, Source) and value.text.isidentifier():
            value = ArraySource(f"{value.text}.copy()")  # a row of the engine's: as it is now
        return super().let(name, value)

    def pick(self, cond: Any, if_true: Any, if_false: Any) -> Any:
        if not isinstance(cond, Source):
            return if_true if cond else if_false
        return ArraySource(f"where({cond.text}, {source_text(if_true)}, {source_text(if_false)})")

    def lookup(self, table: tuple[int, ...], value: Any) -> ArraySource:
        name = f"TABLE{len(self.tables)}"
        self.tables[name] = np.asarray(table, dtype=np.int8)
        return ArraySource(f"{name}[{source_text(value)}]")

    def _open(self, cond: Source) -> list[str]:
        depth = self._depth
        self._some[depth + 1 :] = [True]
        return [f"e{depth + 1} = e{depth} & {cond.text}", f"if count(e{depth + 1}):"]

    def _close(self) -> None:
        if self._dead is not None and self._dead > self._depth:
            self._dead = None

    def finish(self, status: Any, where: Any = True) -> None:
        depth, value = self._depth, source_text(status)
        if where is True and depth == 0:
            self._emit(f"copyto(st, {value}, where=e0)")
            self._emit("return")
            self._dead = 0
            return
        self._some = [False] * len(self._some)
        done = f"e{depth}"
        if where is not True:
            done = "done"
            self._emit(f"done = e{depth} & {source_text(where)}")
        self._emit(f"copyto(st, {value}, where={done})")
        for outer in range(depth + (where is not True)):
            self._emit(f"e{outer} ^= {done}")  # done is within every enclosing mask
        self._emit("if not count(e0):")
        self._emit("    return")
        self._some[0] = True
        if where is True:
            self._dead = depth


class BatchedTree(Protocol):
    """What a rule's ticker needs of the batched engine."""

    program: Program
    status: np.ndarray
    _tickers: list[Callable[[np.ndarray], None]]

    def _halt(self, child: int, mask: np.ndarray) -> None: ...


def rule_ticker(engine: BatchedTree, i: int, size: int) -> Callable[[np.ndarray], None]:
    """Node ``i``'s tick for the agents of a mask (shape (``size``,), bool; never modified):
    its type's rule written by :class:`ArraySourceOps` and compiled, bound to the node's
    status row, its children's and its memory (``record.memory`` rows of int64, 0 at first)."""
    record = NODE_TYPES.get(engine.program.nodes[i].type)
    assert record.rule is not None, record.name
    ops = ArraySourceOps(engine.program, i)
    record.rule(ops)
    source = "\n".join(["def tick(mask):", *("    " + line for line in ops.lines)])
    memory = np.zeros((record.memory, size), np.int64)
    namespace: dict[str, Any] = {
        "st": engine.status[i],
        **{f"S{k}": engine.status[c] for k, c in enumerate(ops.children)},
        **{f"M{slot}": memory[slot] for slot in range(record.memory)},
        **ops.tables,
        "tickers": engine._tickers,
        "halt": engine._halt,
        "KIDS": tuple(ops.children),
        "count": np.count_nonzero,
        "copyto": np.copyto,
        "where": np.where,
    }
    exec(compile(source, f"<{record.name} rule, node {i}>", "exec"), namespace)
    ticker: Callable[[np.ndarray], None] = namespace["tick"]
    return ticker
