"""A node type's rule as NumPy source over all agents, generated once per node of a program.

The rule (:mod:`pyautonomousagent.bt.rules`) is run once with :class:`ArraySourceOps`, which
writes what it does for the agents of a mask as straight-line NumPy code: values are arrays
over agents (N,), a ``when`` block is the agents of its mask (``e1 = e0 & cond``, skipped
when none), and a ``finish`` takes its agents out of every enclosing mask (the function
returns once none is left). :func:`rule_ticker` compiles it for node ``i`` of a batched
engine, bound to that node's rows, so a tick interprets no rule.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np

from pyautonomousagent.bt.nodes import NODE_TYPES, may_skip
from pyautonomousagent.bt.program import Program
from pyautonomousagent.bt.script_leaves import time_step
from pyautonomousagent.bt.tree_source import UNROLLED, CodeOps, Source, source_text
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World


class ArraySource(Source):
    """An array over agents in the generated code: ``&``/``|`` are NumPy's."""

    def _op(self, op: str, other: Any, flip: bool = False) -> Source:
        op = {"and": "&", "or": "|"}.get(op, op)
        left, right = (other, self) if flip else (self, other)
        return ArraySource(f"({source_text(left)} {op} {source_text(right)})")


class ArraySourceOps(CodeOps):
    """:class:`~pyautonomousagent.bt.rules.Ops` that writes node ``i``'s rule as the body of
    ``tick(mask)``: its own status row is ``st``, child ``k``'s ``S<k>`` (ticked by
    ``tickers[child](e)``, halted by ``halt(child, e)``), memory slot ``s`` the row ``M<s>``,
    the iteration ``world.iteration``, blackboard entry ``key`` ``BOARD[key]``; the mask of
    the agents of the current block is ``e<depth>`` (a loop's: ``while`` it has any)."""

    def __init__(self, program: Program, i: int, time_step: float) -> None:
        self.children = program.children[i]
        skippable = [may_skip(program.nodes[c]) for c in self.children]
        super().__init__(len(self.children), program.params[i], skippable, time_step)
        self.lines = ["e0 = mask.copy()"]
        self.tables: dict[str, np.ndarray] = {}
        self._dead: int | None = None  # a block (depth) every agent of which has finished
        self._some = [True]  # per depth: its mask is known to have an agent (no finish since)
        self._loops: list[int] = []  # the depths of the loop blocks open

    def _emit(self, line: str) -> None:
        if self._dead is None or self._depth < self._dead:
            super()._emit(line)

    def status(self) -> ArraySource:
        return ArraySource("st")

    def memory(self, slot: int = 0) -> ArraySource:
        return ArraySource(f"M{slot}")

    def now(self) -> ArraySource:
        return ArraySource("world.iteration")

    def entry(self, key: str) -> ArraySource:
        return ArraySource(f"BOARD[{key!r}]")

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
        if len(range(len(self.children))[first:last]) > UNROLLED:  # a loop: linear code
            self._call([f"for child in KIDS[{first}:{last}]:", f"    halt(child, e{self._depth})"])
        else:
            self._call([f"halt({child}, e{self._depth})" for child in self.children[first:last]])

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

    def _open_loop(self) -> list[str]:
        depth = self._depth
        self._some[depth + 1 :] = [True]
        self._loops.append(depth + 1)
        return [f"e{depth + 1} = e{depth}.copy()", f"while count(e{depth + 1}):"]

    def _after_loop(self) -> None:
        self._loops.pop()
        self._close()

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
        own = where is not True or depth in self._loops  # a loop's mask: emptied
        for outer in range(depth + own):
            self._emit(f"e{outer} ^= {done}")  # done is within every enclosing mask
        self._emit("if not count(e0):")
        self._emit("    return")
        self._some[0] = True
        if where is True:
            self._dead = depth


#: A run of at least this many statement groups alike but for numbers that grow by fixed
#: steps (a node's blocks for child after child) becomes a loop: the code of a node with
#: many children stays small (compiling 600,000 lines took minutes and gigabytes).
ROLLED = 16

_NUMBER = re.compile(r"(\d+)")


def _statements(lines: list[str]) -> list[list[str]]:
    """``lines`` cut into top-level statements (a line without indent starts one)."""
    statements: list[list[str]] = []
    for line in lines:
        if line.startswith(" ") and statements:
            statements[-1].append(line)
        else:
            statements.append([line])
    return statements


def _template(group: list[list[str]]) -> tuple[list[str], list[int]]:
    """A group of statements' text cut around its numbers, and those numbers."""
    parts = _NUMBER.split("\n".join(line for statement in group for line in statement))
    return parts[::2], list(map(int, parts[1::2]))


def _loop(
    group: list[list[str]], first: list[int], step: list[int], times: int
) -> list[str] | None:
    """``group`` for ``q`` in ``range(times)`` as one loop, each number ``first + step * q``;
    None where a number that changes is part of a name other than a child's row ``S<k>``."""
    text = "\n".join(line for statement in group for line in statement)
    out, end, j = [], 0, 0
    for m in _NUMBER.finditer(text):
        value = str(first[j]) if step[j] == 0 else f"{first[j]} + {step[j]} * q"
        before = text[end : m.start()]
        if step[j] and before[-1:].isidentifier():
            if not (before.endswith("S") and not before[-2:-1].isidentifier()):
                return None
            before, value = before[:-1], f"S[{value}]"
        else:
            value = value if step[j] == 0 else f"({value})"
        out.append(before + value)
        end, j = m.end(), j + 1
    out.append(text[end:])
    return [f"for q in range({times}):", *("    " + line for line in "".join(out).split("\n"))]


def roll(lines: list[str]) -> list[str]:
    """``lines`` (a rule's code, no indent at its top level) with every run of at least
    :data:`ROLLED` groups of 1 to 4 statements that differ only by numbers growing by fixed
    steps written as one loop over ``q`` (children's rows ``S<k>`` as ``S[...]``)."""
    statements, out, i = _statements(lines), [], 0
    while i < len(statements):
        best: tuple[int, list[str]] | None = None
        for size in range(1, 5):
            groups = [statements[i + size * g : i + size * (g + 1)] for g in range(2)]
            if len(groups[1]) < size:
                break
            (shape, first), (other, second) = (_template(g) for g in groups)
            if shape != other:
                continue
            step, times = [b - a for a, b in zip(first, second, strict=True)], 2
            while i + size * (times + 1) <= len(statements):
                follows = _template(statements[i + size * times : i + size * (times + 1)])
                expected = [a + s * times for a, s in zip(first, step, strict=True)]
                if follows != (shape, expected):
                    break
                times += 1
            loop = _loop(statements[i : i + size], first, step, times) if times >= ROLLED else None
            if loop is not None:  # the shortest period that repeats
                best = (times * size, loop)
                break
        if best is None:
            out += statements[i]
            i += 1
        else:
            out += best[1]
            i += best[0]
    return out


class BatchedTree(Protocol):
    """What a rule's ticker needs of the batched engine."""

    program: Program
    status: np.ndarray
    world: World
    swarm: Swarm
    defaults: Mapping[str, Any]
    _tickers: list[Callable[[np.ndarray], None]]

    def _halt(self, child: int, mask: np.ndarray) -> None: ...


def rule_ticker(engine: BatchedTree, i: int, size: int) -> Callable[[np.ndarray], None]:
    """Node ``i``'s tick for the agents of a mask (shape (``size``,), bool; never modified):
    its type's rule written by :class:`ArraySourceOps` and compiled, bound to the node's
    status row, its children's and its memory (``record.memory`` rows of int64, 0 at first)."""
    record = NODE_TYPES.get(engine.program.nodes[i].type)
    assert record.rule is not None, record.name
    ops = ArraySourceOps(engine.program, i, time_step(engine.defaults))
    record.rule(ops)
    lines = roll(ops.lines) if len(ops.children) >= ROLLED else ops.lines
    source = "\n".join(["def tick(mask):", *("    " + line for line in lines)])
    memory = np.zeros((record.memory, size), np.int64)
    namespace: dict[str, Any] = {
        "st": engine.status[i],
        **{f"S{k}": engine.status[c] for k, c in enumerate(ops.children)},
        "S": tuple(engine.status[c] for c in ops.children),
        **{f"M{slot}": memory[slot] for slot in range(record.memory)},
        **ops.tables,
        "tickers": engine._tickers,
        "world": engine.world,
        "BOARD": engine.swarm.blackboard,
        "halt": engine._halt,
        "KIDS": tuple(ops.children),
        "count": np.count_nonzero,
        "copyto": np.copyto,
        "where": np.where,
    }
    exec(compile(source, f"<{record.name} rule, node {i}>", "exec"), namespace)
    ticker: Callable[[np.ndarray], None] = namespace["tick"]
    return ticker
