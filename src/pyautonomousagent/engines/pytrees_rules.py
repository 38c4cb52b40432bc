"""A node type's rule as the ``tick`` of a py_trees behaviour, generated once per node shape.

The rule (:mod:`pyautonomousagent.bt.rules`) is run once with :class:`ScalarSourceOps`, which
writes what it does for one agent as Python source: a generator method over ``self`` (a
py_trees composite or decorator) whose statuses are py_trees' own, compared by identity, and
whose memory is ``self.m0``, ``self.m1``, ... The source is compiled once per node type,
parameters, number of children and which children may be SKIPPED (:func:`tick_method`), so
a tick runs straight-line code with no rule interpreted.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator, Mapping
from functools import cache
from typing import Any

from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.status import INVALID
from pyautonomousagent.bt.tree_source import UNROLLED, CodeOps, Source, source_text
from pyautonomousagent.engines.btcpp import FROM_PYTREES, TO_PYTREES


class StatusSource(Source):
    """A py_trees status in the generated code: ``==``/``!=`` a status code (or another
    status) are identity tests against py_trees' status objects."""

    def _op(self, op: str, other: Any, flip: bool = False) -> Source:
        if op not in ("==", "!="):
            raise TypeError(f"a status is compared with == or != only, not {op}")
        test = "is" if op == "==" else "is not"
        return Source(f"({self.text} {test} {_status_text(other)})")


def _status_text(value: Any) -> str:
    """Source of a status: a status code (its py_trees status's name in the namespace), a
    :class:`StatusSource`, or another :class:`Source` holding a code (looked up)."""
    if isinstance(value, StatusSource):
        return value.text
    if isinstance(value, Source):
        return f"STATUS[{value.text}]"
    return f"S{int(value)}"


class ScalarSourceOps(CodeOps):
    """:class:`~pyautonomousagent.bt.rules.Ops` that writes a rule as the body of a py_trees
    ``tick`` for one agent: the children are ``c0``, ``c1``, ...; a ``finish`` sets
    ``self.status``, yields ``self`` and returns; the iteration is ``self.world.iteration``,
    blackboard entry ``key`` an attribute of ``self.board``."""

    def __init__(
        self, kids: int, params: Mapping[str, Any], skippable: tuple[bool, ...], time_step: float
    ) -> None:
        super().__init__(kids, params, skippable, time_step)
        self._depth = 1
        self.tables: dict[str, dict[int, Any]] = {}

    def status(self) -> StatusSource:
        return StatusSource("self.status")

    def now(self) -> Source:
        return Source("self.world.iteration")

    def entry(self, key: str) -> Source:
        return Source(f"getattr(self.board, {key!r})")

    def memory(self, slot: int = 0) -> Source:
        return Source(f"self.m{slot}")

    def set_memory(self, value: Any, slot: int = 0) -> None:
        code = f"CODE[id({value.text})]" if isinstance(value, StatusSource) else None
        self._emit(f"self.m{slot} = {code or source_text(value)}")

    def child(self, k: int) -> StatusSource:
        return StatusSource(f"c{k}.status")

    def tick(self, k: int) -> StatusSource:
        self._emit(f"self.current_child = c{k}")
        self._emit(f"run(c{k}.tick())")
        self._emit(f"result = c{k}.status")
        return StatusSource("result")

    def halt(self, first: int, last: int | None = None) -> None:
        chosen = range(self.kids)[first:last]  # a range: no list of all the children
        if len(chosen) > UNROLLED:  # a loop: the code stays linear in the children
            self._emit(f"for child in self.children[{first}:{last}]:")
            names = ["child"]
            self._depth += 1
        else:
            names = [f"c{k}" for k in chosen]
        for child in names:
            self._emit(f"if {child}.status is not S{INVALID}:")
            self._emit(f"    {child}.stop(S{INVALID})")
        self._depth -= names == ["child"]

    def pick(self, cond: Any, if_true: Any, if_false: Any) -> Any:
        if isinstance(cond, Source) and StatusSource in (type(if_true), type(if_false)):
            true, false = _status_text(if_true), _status_text(if_false)
            return StatusSource(f"({true} if {cond.text} else {false})")
        return super().pick(cond, if_true, if_false)

    def lookup(self, table: tuple[int, ...], value: Any) -> StatusSource:
        name = f"TABLE{len(self.tables)}"
        self.tables[name] = {id(TO_PYTREES[a]): TO_PYTREES[b] for a, b in enumerate(table)}
        return StatusSource(f"{name}[id({source_text(value)})]")

    def finish(self, status: Any, where: Any = True) -> None:
        with self.when(where):
            self._emit(f"self.status = {_status_text(status)}")
            self._emit("yield self")
            self._emit("return")


@cache
def tick_method(
    type_name: str,
    kids: int,
    params: tuple[tuple[str, Any], ...],
    skippable: tuple[bool, ...],
    time_step: float,
) -> Callable[[Any], Iterator[Any]]:
    """The ``tick`` of a node of ``type_name`` with ``kids`` children, parameters ``params``
    (name, value), children that may be SKIPPED where ``skippable`` says so and the
    scenario's ``time_step`` (seconds): its rule written by :class:`ScalarSourceOps` and
    compiled (cached: the arguments are the shape)."""
    rule = NODE_TYPES.get(type_name).rule
    assert rule is not None, type_name
    ops = ScalarSourceOps(kids, dict(params), skippable, time_step)
    rule(ops)
    children = "".join(f"c{k}, " for k in range(kids))
    head = [f"    {children}= self.children"] if kids else []
    source = "\n".join(["def tick(self):", *head, *ops.lines])
    namespace: dict[str, Any] = {f"S{code}": status for code, status in TO_PYTREES.items()}
    namespace |= ops.tables
    namespace |= {
        "STATUS": tuple(TO_PYTREES[code] for code in range(len(TO_PYTREES))),
        "CODE": {id(status): code for status, code in FROM_PYTREES.items()},
        "run": deque(maxlen=0).extend,
    }
    exec(compile(source, f"<{type_name} rule>", "exec"), namespace)
    tick: Callable[[Any], Iterator[Any]] = namespace["tick"]
    return tick
