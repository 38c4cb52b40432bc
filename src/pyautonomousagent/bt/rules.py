"""A control node's semantics, written once as a rule that every engine runs in its own form.

A rule is a function of one argument, ``n``, an :class:`Ops`: the node as one engine sees it.
It says, for the agents whose tick reaches the node, which children are ticked, which are
halted, what the node remembers and what it returns, through ``n``'s few operations only:
values are opaque (a whole number or a piece of generated source) and combine with ``==``,
``!=``, ``<``, ``<=``, ``>``, ``>=``, ``&``, ``|`` and ``+`` (a whole number plus a number or
a condition, which counts 1 where it holds); a condition on them is taken with
``with n.when(cond):``, never with ``if``, and a block that repeats is ``with n.loop():``.
Python's own ``if`` and ``for`` see only what is fixed when the tree is built: the number of
children, the parameters, the scenario's time step and which children may be SKIPPED.
Each engine gives its form by implementing :class:`Ops` that writes code, run once when the
tree is built (values are source text, conditions ``if`` blocks):

- the py_trees engine: a py_trees node's ``tick`` for one agent (``engines/pytrees_rules.py``);
- the batched engine: NumPy code for all agents, values arrays over agents, conditions masks
  (``engines/batched_rules.py``); a value ``let`` inside a ``when`` block is read only there;
- the compiled and GPU engines: the code for agent ``a``
  (:mod:`pyautonomousagent.bt.tree_source`).

The rules of the node types live with their records (:mod:`pyautonomousagent.bt.nodes`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from contextlib import AbstractContextManager
from typing import Any, Protocol


class Ops(Protocol):
    """One control node as an engine ticks it (see the module's docstring).

    Attributes:
        kids: how many children the node has.
        params: its parameters, defaults filled in (``Program.params``).
    """

    @property
    def kids(self) -> int: ...

    @property
    def params(self) -> Mapping[str, Any]: ...

    def skippable(self, k: int) -> bool:
        """Whether child ``k`` may be SKIPPED (fixed when the tree is built: ``nodes.may_skip``);
        a rule keeps BT.CPP's bookkeeping of skipped children only where one may be."""

    def status(self) -> Any:
        """The node's own status before this tick (a code of :mod:`.status`)."""

    def memory(self, slot: int = 0) -> Any:
        """Whole number ``slot`` the node remembers between ticks (``slot`` below the record's
        ``memory``); 0 before it is first set."""

    def set_memory(self, value: Any, slot: int = 0) -> None:
        """Remember ``value`` in ``slot`` (for the agents the current conditions select)."""

    def child(self, k: int) -> Any:
        """Child ``k``'s status now."""

    def tick(self, k: int) -> Any:
        """Tick child ``k``; its status after that tick (on some engines a view of the
        child's status: ``let`` it to keep it past a halt of that child)."""

    def halt(self, first: int, last: int | None = None) -> None:
        """Halt children ``first`` to ``last - 1`` (all from ``first`` when ``last`` is None):
        a child not INVALID becomes INVALID with its subtree, a RUNNING leaf is told."""

    def let(self, name: str, value: Any) -> Any:
        """``value`` kept under ``name`` (a local of the rule; read later as it is now)."""

    def pick(self, cond: Any, if_true: Any, if_false: Any) -> Any:
        """``if_true`` where ``cond`` holds, else ``if_false``."""

    def lookup(self, table: tuple[int, ...], value: Any) -> Any:
        """``table[value]``: a status mapped through a table indexed by status code."""

    def when(self, cond: Any) -> AbstractContextManager[None]:
        """A block that applies to the agents where ``cond`` holds (nested: all of them)."""

    def loop(self) -> AbstractContextManager[None]:
        """A block run again for the agents that reach its end, left only by ``finish``
        (nothing after it is run): a child ticked again within one tick."""

    def now(self) -> Any:
        """The iteration number (simulated time, in time steps)."""

    def entry(self, key: str) -> Any:
        """The agent's blackboard entry ``key`` now (a number; ``let`` it to keep it)."""

    def iterations(self, msec: int) -> int:
        """``msec`` simulated milliseconds as whole iterations of the scenario's time step,
        rounded up (``script_leaves.iterations``; fixed when the tree is built)."""

    def finish(self, status: Any, where: Any = True) -> None:
        """End this node's tick with ``status`` where ``where`` holds (under the current
        conditions): nothing after it applies to those agents."""


#: A node type's semantics: called with the node as an engine sees it.
Rule = Callable[[Ops], None]
