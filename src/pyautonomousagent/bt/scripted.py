"""A leaf whose statuses are given in advance: for tests, and for teaching composites.

``leaf("Scripted", "a", statuses=[[SUCCESS], [RUNNING], ...])`` returns
``statuses[world.iteration - 1][agent]`` on each tick: one row per tick (iteration 1
first), one column per agent. It changes nothing else.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.bt.leaf import Leaf, LeafError, register_leaf
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.inputs import InputError, load_json
from pyautonomousagent.state import AgentView
from pyautonomousagent.world import World

#: The statuses a leaf may return: INVALID is the engines' "not ticked / halted" mark, which
#: py_trees and BehaviorTree.CPP treat differently when a leaf returns it, so it is refused.
RETURNABLE = [SUCCESS, FAILURE, RUNNING]


@register_leaf
class Scripted(Leaf):
    """Returns the scripted status of the current iteration for each agent."""

    type_name = "Scripted"
    statuses: np.ndarray

    @classmethod
    def create(cls, params: Mapping[str, Any], defaults: Mapping[str, Any], where: str) -> Leaf:
        if set(params) != {"statuses"}:
            raise LeafError(f"{where}: Scripted takes exactly one port, 'statuses'")
        try:
            table = np.asarray(params["statuses"], dtype=np.int64)
        except (ValueError, TypeError, OverflowError):  # ragged, text, beyond int64
            table = np.zeros(0, dtype=np.int64)
        if table.ndim != 2 or not np.isin(table, RETURNABLE).all():
            raise LeafError(
                f"{where}: statuses must be a (ticks, agents) table of the codes 1 (SUCCESS), "
                "2 (FAILURE) and 3 (RUNNING); a leaf never returns 0 (INVALID)"
            )
        return cls(statuses=table.astype(np.int8))

    @classmethod
    def port_names(cls) -> list[str]:
        return ["statuses"]

    @classmethod
    def parse_port(cls, name: str, value: Any, where: str) -> Any:
        """``statuses`` as a list of rows; text (from XML) is read as JSON."""
        if isinstance(value, str):
            try:
                value = load_json(value, f"{where}: statuses")
            except InputError:  # not JSON, or nested too deeply
                raise LeafError(f"{where}: statuses must be JSON, e.g. [[1, 2], [3, 1]]") from None
        cls.create({"statuses": value}, {}, where)
        return value

    @classmethod
    def port_hint(cls, name: str) -> str:
        return "a (ticks, agents) table of status codes, e.g. [[1, 2], [3, 1]]"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return agents.pick(self.statuses[world.iteration - 1])


class _Constant(Leaf):
    """A leaf that always returns :attr:`status` and touches nothing (no ports)."""

    status: ClassVar[int]

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return self.status


@register_leaf
class AlwaysSuccess(_Constant):
    """BehaviorTree.CPP's ``AlwaysSuccess``: SUCCESS on every tick."""

    type_name = "AlwaysSuccess"
    status = SUCCESS


@register_leaf
class AlwaysFailure(_Constant):
    """BehaviorTree.CPP's ``AlwaysFailure``: FAILURE on every tick."""

    type_name = "AlwaysFailure"
    status = FAILURE
