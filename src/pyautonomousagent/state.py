"""The swarm's state: arrays with the agent axis first, and per-agent views on them.

Every quantity of every agent lives once, in an array of shape ``(N,)`` held by
:class:`Swarm`. An :class:`AgentView` reads and writes rows of those arrays: with an
integer index it is one agent (``agent.energy`` is a plain number), with an integer
array it is a group of agents (``agents.energy`` is an array). Leaf nodes are written
against this view, so one piece of leaf code serves a single agent and a whole batch.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent.names import AgentNames

#: The state every motion model moves: name -> dtype.
MOTION_COLUMNS: dict[str, type] = {
    "x": np.float64,  # east position (world units)
    "y": np.float64,  # north position (world units)
    "speed": np.float64,  # world units per iteration
    "heading": np.float64,  # degrees clockwise from north (+y), in [0, 360)
}
#: The references the control system (Phase 4) follows: name -> dtype.
CONTROL_COLUMNS: dict[str, type] = {
    "requested_speed": np.float64,  # world units per iteration
    "requested_heading": np.float64,  # degrees clockwise from north
}


@dataclass
class Swarm:
    """The state of all N agents.

    Attributes:
        names: agent identifiers, e.g. ``["drone1", ...]``; length N.
        columns: state arrays, each of shape ``(N,)``: the motion columns
            (:data:`MOTION_COLUMNS`), the mission's columns, then the control references
            (:data:`CONTROL_COLUMNS`).
        blackboard: blackboard arrays, each of shape ``(N,)``: key -> values per agent.
        view_type: the :class:`AgentView` class of this swarm, with one attribute per column.
        board_type: the :class:`BlackboardView` class of this swarm, with one attribute per
            blackboard key it was made with (keys added later are found too, more slowly).
    """

    names: Sequence[str]
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    blackboard: dict[str, np.ndarray] = field(default_factory=dict)
    view_type: type[AgentView] = field(init=False, repr=False)
    board_type: type[BlackboardView] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.view_type = view_type(self.columns)
        self.board_type = board_type(self.blackboard)

    @classmethod
    def create(
        cls,
        names: Iterable[str],
        blackboard_keys: Mapping[str, Any] | None = None,
        columns: Mapping[str, Any] | None = None,
    ) -> Swarm:
        """Zero-filled state for the named agents, with the given blackboard keys.

        Args:
            names: agent identifiers (an :class:`~pyautonomousagent.names.AgentNames` is
                kept as it is, other iterables as a list).
            blackboard_keys: key -> dtype (e.g. ``{"number_ticks": np.int64}``).
            columns: the mission's own state columns, name -> dtype (e.g. ``{"energy":
                np.float64}``), placed between the motion and the control columns.
        """
        names = names if isinstance(names, AgentNames) else list(names)
        n = len(names)
        kinds = {**MOTION_COLUMNS, **(columns or {}), **CONTROL_COLUMNS}
        state = {k: np.zeros(n, dtype=t) for k, t in kinds.items()}
        board = {k: np.zeros(n, dtype=t) for k, t in (blackboard_keys or {}).items()}
        return cls(names=names, columns=state, blackboard=board)

    @property
    def size(self) -> int:
        """Number of agents N."""
        return len(self.names)

    def agent(self, index: int) -> AgentView:
        """The view of one agent (``agent.energy`` is a number)."""
        return self.view_type(self, index)

    def agents(self, indices: np.ndarray | slice | None = None) -> AgentView:
        """The view of a group of agents (``agents.energy`` is an array); all if None.

        ``indices`` is an int array, a slice or a boolean mask of shape (N,)."""
        return self.view_type(self, np.arange(self.size) if indices is None else indices)


def _read(column: np.ndarray, index: Any, masked: bool) -> Any:
    """The view's values of ``column``: all N of them when the view is a mask, a Python
    number for one agent."""
    if masked:
        return column
    values = column[index]
    return values.item() if values.ndim == 0 else values


def _write(column: np.ndarray, index: Any, masked: bool, value: Any) -> None:
    """Write the view's values of ``column`` (only where the mask holds, for a mask)."""
    if masked:
        np.copyto(column, value, where=index)
    else:
        column[index] = value


class _Column:
    """Descriptor: ``view.<name>`` reads/writes ``swarm.columns[name][view.index]``."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, view: AgentView, owner: type | None = None) -> Any:
        if view.one:  # the hot path of the py_trees engine: a Python number in one call
            return view.swarm.columns[self.name].item(view.index)
        return _read(view.swarm.columns[self.name], view.index, view.masked)

    def __set__(self, view: AgentView, value: Any) -> None:
        if view.one:  # the py_trees engine's hot path: one element, no helper call
            view.swarm.columns[self.name][view.index] = value
            return
        _write(view.swarm.columns[self.name], view.index, view.masked, value)


class _Key:
    """Descriptor: ``board.<key>`` reads ``blackboard[key][board's index]`` (a Python number
    for one agent), without the failed attribute lookup that reaches ``__getattr__``."""

    def __init__(self, key: str) -> None:
        self.key = key

    def __get__(self, view: BlackboardView | None, owner: type | None = None) -> Any:
        if view is None:
            return self
        board = view._board
        if view._one and self.key in board:  # one agent: a Python number in one call
            return board[self.key].item(view._index)
        return view.__getattr__(self.key)


class BlackboardView:
    """One agent's (or a group's) blackboard: attributes are rows of the blackboard arrays.

    Each agent has its own row, so nothing leaks between agents; an unknown key raises
    AttributeError naming the key and the keys that exist.
    """

    __slots__ = ("_board", "_index", "_masked", "_one")

    def __init__(self, board: dict[str, np.ndarray], index: Any, masked: bool = False) -> None:
        object.__setattr__(self, "_board", board)
        object.__setattr__(self, "_index", index)
        object.__setattr__(self, "_masked", masked)
        object.__setattr__(self, "_one", isinstance(index, int | np.integer))

    def _column(self, key: str) -> np.ndarray:
        try:
            return self._board[key]
        except KeyError:
            known = ", ".join(sorted(self._board))
            raise AttributeError(f"no blackboard key {key!r} (keys: {known})") from None

    def __getattr__(self, key: str) -> Any:
        """A key without its own attribute (see :func:`board_type`), or AttributeError."""
        column = self._column(key)
        if self._one:  # one agent: a Python number in one call
            return column.item(self._index)
        return _read(column, self._index, self._masked)

    def __setattr__(self, key: str, value: Any) -> None:
        if self._one:  # the py_trees engine's hot path: one element, no helper call
            board = self._board
            if key in board:
                board[key][self._index] = value
                return
        _write(self._column(key), self._index, self._masked, value)

    def keys(self) -> list[str]:
        """The blackboard's keys."""
        return list(self._board)

    def as_dict(self) -> dict[str, Any]:
        """Key -> value(s) for this view, e.g. for display."""
        return {k: _read(v, self._index, self._masked) for k, v in self._board.items()}


class AgentView:
    """Rows of a :class:`Swarm`: one agent, or a group.

    The index is an int (one agent: attributes are plain numbers), an int array or a slice
    (a group: attributes are arrays of the group's values), or a boolean mask of shape
    (N,) (a group: attributes are whole (N,) arrays, and writes change only the rows where
    the mask holds; the batched engine uses this when most agents are in the group).

    State columns are attributes (``x``, ``y``, ``speed``, ``heading``,
    ``requested_speed``, ``requested_heading`` and the mission's columns, e.g. ``energy``);
    the blackboard is ``view.blackboard``. Values in "view shape" are what attributes return.
    Each swarm makes its own subclass with the mission's columns (:func:`view_type`).
    """

    __slots__ = ("swarm", "index", "blackboard", "masked", "one")

    x = _Column()
    y = _Column()
    speed = _Column()
    heading = _Column()
    requested_speed = _Column()
    requested_heading = _Column()

    def __init__(self, swarm: Swarm, index: Any) -> None:
        self.swarm = swarm
        self.index = index
        self.masked = isinstance(index, np.ndarray) and index.dtype == np.bool_
        self.one = isinstance(index, int | np.integer)
        self.blackboard = swarm.board_type(swarm.blackboard, index, self.masked)

    @property
    def is_one(self) -> bool:
        """True for a single agent (an integer index), False for a group."""
        return self.one

    @property
    def indices(self) -> np.ndarray:
        """The agents' rows as a compact int array (one entry for a single agent)."""
        if self.masked:
            return np.flatnonzero(self.index)
        return np.arange(self.swarm.size)[self.index].reshape(-1)

    @property
    def rows(self) -> Any:
        """The agents' row numbers in view shape (an int for one agent)."""
        if self.is_one:
            return int(self.index)
        return self.pick(np.arange(self.swarm.size))

    def pick(self, values: np.ndarray) -> Any:
        """The view's entries of an array of shape (N,), in view shape."""
        return _read(values, self.index, self.masked)

    def compact(self, values: Any) -> np.ndarray:
        """Values in view shape (or a scalar) as one entry per agent of :attr:`indices`
        (read-only: maybe a view of ``values``)."""
        if self.masked and np.ndim(values):
            return np.asarray(values)[self.index]
        shape = (self.count,)
        if isinstance(values, np.ndarray) and values.shape == shape:
            return values  # a group's values in view shape: one per agent already
        return np.broadcast_to(values, shape)

    @property
    def count(self) -> int:
        """The number of agents in the view."""
        index = self.index
        if self.one:
            return 1
        if isinstance(index, slice):
            return len(range(*index.indices(self.swarm.size)))
        if self.masked:
            return int(np.count_nonzero(index))
        return int(np.size(index))

    @property
    def name(self) -> Any:
        """The agent's identifier (a string), or an array of them for a group."""
        if self.is_one:
            return self.swarm.names[int(self.index)]
        rows = np.arange(self.swarm.size)[self.index].tolist()
        return np.array([self.swarm.names[i] for i in rows], dtype=object)

    if TYPE_CHECKING:  # the mission's columns are attributes of the swarm's subclass

        def __setattr__(self, key: str, value: Any) -> None: ...

    def __getattr__(self, key: str) -> Any:
        """Only reached for a name that is no column: AttributeError naming the columns."""
        if key.startswith("__"):
            raise AttributeError(key)
        known = ", ".join(self.swarm.columns)
        raise AttributeError(f"agents have no state column {key!r} (columns: {known})")

    def __repr__(self) -> str:
        return f"AgentView({self.name!r})"


def board_type(keys: Iterable[str]) -> type[BlackboardView]:
    """The :class:`BlackboardView` subclass with an attribute per key (a descriptor: no
    failed lookup before ``__getattr__``); keys that name a method (``keys``) are left to
    ``__getattr__`` as before."""
    own = [k for k in keys if not hasattr(BlackboardView, k)]
    attributes: dict[str, Any] = {"__slots__": (), **{k: _Key(k) for k in own}}
    return type("BlackboardView", (BlackboardView,), attributes)


def view_type(columns: Iterable[str]) -> type[AgentView]:
    """The :class:`AgentView` subclass with an attribute per column (a descriptor, as fast as
    the built-in ones); :class:`AgentView` itself when there are no others."""
    extra = [k for k in columns if not hasattr(AgentView, k)]
    if not extra:
        return AgentView
    # type() names each descriptor after its key (_Column.__set_name__)
    attributes: dict[str, Any] = {"__slots__": (), **{k: _Column() for k in extra}}
    return type("AgentView", (AgentView,), attributes)
