"""What the generated code of a fused loop is written against: where it finds the arrays
(:class:`Layout`), the numbers it reads at run time (:class:`Constants`), the messages the
tree sends (:class:`Messaging`) and what a run's fused loop calls (:class:`Fused`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pyautonomousagent.bt.program import Program
from pyautonomousagent.bt.tree_source import node_record
from pyautonomousagent.kernels import ITERATION, HandlerKernel, LeafKernel, SensorKernel


class Constants:
    """The numbers the generated code reads at run time (ports, parameters, agent rows): not
    written into it, so that one compiled module serves every value. Each call site's
    numbers get slots in two arrays, ``kf`` (float64) and ``ki`` (int64: whole numbers and
    flags), arguments of every generated function."""

    def __init__(self) -> None:
        self._slots: dict[tuple[str, int], str] = {}
        self.floats: list[float] = []
        self.ints: list[int] = []

    def refs(self, site: str, values: Sequence[Any]) -> list[str]:
        """Where the code reads ``values`` of call site ``site`` (e.g. ``"leaf 3"``)."""
        refs = []
        for j, value in enumerate(values):
            key = (site, j)
            if key not in self._slots:
                if isinstance(value, bool | int | np.integer):
                    self.ints.append(int(value))
                    self._slots[key] = f"ki[{len(self.ints) - 1}]"
                else:
                    self.floats.append(float(value))
                    self._slots[key] = f"kf[{len(self.floats) - 1}]"
            refs.append(self._slots[key])
        return refs

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``kf`` and ``ki`` (never empty: numba types an empty list poorly)."""
        return (np.array(self.floats or [0.0], dtype=np.float64),
                np.array(self.ints or [0], dtype=np.int64))  # fmt: skip


@dataclass(frozen=True)
class Layout:
    """Where the generated code finds things.

    Attributes:
        names: the arrays ``c0, c1, ...``: swarm columns, then blackboard keys.
        memory_rows: node index -> its first row of ``cur`` (``bt.tree_source.memory_rows``).
        outboxes: the nodes whose leaves send messages (their kernels' ``Sends``), in node
            order; each has an outbox ``o<node>`` (see :class:`~pyautonomousagent.kernels.Sends`).
        deferred: the leaves whose ``Later`` step is done for all agents after the tree
            (:func:`deferrable`); the tree marks each agent's in ``pend`` (-1: none).
        constants: the numbers the code reads from ``kf`` and ``ki``, filled while the
            source is written.
        vertical: the 3-D drone's ``(max_climb_rate, climb_step, max_altitude)`` where the
            motion model is the 3-D drone (its altitude and climb rate are moved too, the
            control signal u_w kept in ``uc``), else None (the 2-D drone).
        time_step: the scenario's, seconds (what Delay's and Timeout's milliseconds are).
    """

    names: tuple[str, ...]
    memory_rows: Mapping[int, int]
    outboxes: tuple[int, ...] = ()
    deferred: tuple[int, ...] = ()
    constants: Constants = field(default_factory=Constants)
    vertical: tuple[float, float, float] | None = None
    time_step: float = 1.0

    @property
    def arrays(self) -> str:
        """The arrays' argument list: ``c0, c1, ...``, then the outboxes ``o<node>, ...``."""
        return ", ".join(self.array_names)

    @property
    def array_names(self) -> list[str]:
        """The arrays' parameter names: ``c0, c1, ...``, then the outboxes ``o<node>``."""
        return [f"c{j}" for j in range(len(self.names))] + [f"o{i}" for i in self.outboxes]

    @property
    def record_names(self) -> list[str]:
        """The record arrays' parameter names ``r0, r1, ...`` (one per name)."""
        return [f"r{j}" for j in range(len(self.names))]

    def array(self, name: str) -> str:
        """The variable holding array ``name`` (``t`` for the iteration)."""
        return "t" if name == ITERATION else f"c{self.names.index(name)}"


def deferrable(program: Program, kernels: Mapping[int, LeafKernel]) -> tuple[int, ...]:
    """The leaves with a ``Later`` step that no node ticked after them can see: every
    ancestor returns at once when its child is RUNNING (its record ``yields``), so the tick
    ends with the leaf."""
    deferred = []
    for i, kernel in sorted(kernels.items()):
        up = int(program.parent[i])
        while up >= 0 and node_record(program, up).yields:
            up = int(program.parent[up])
        if kernel.later is not None and up < 0:
            deferred.append(i)
    return tuple(deferred)


@dataclass(frozen=True)
class Messaging:
    """The message types the tree sends, for the fused loop that handles them compiled.

    Attributes:
        types: the types, in order of their first sending node (type ``k`` is index ``k``).
        handlers: each type's compiled handler.
        recorded: each type's ``MessageType.recorded``.
        senders: sending node -> (its type's index, outbox row of each handler field).
    """

    types: tuple[str, ...]
    handlers: tuple[HandlerKernel, ...]
    recorded: tuple[bool, ...]
    senders: Mapping[int, tuple[int, tuple[int, ...]]]

    @property
    def inbox_names(self) -> list[str]:
        """The inbox parameter names ``ib_s0, ib_d0, ib_s1, ...`` (senders, data per type)."""
        return [name for k in range(len(self.types)) for name in (f"ib_s{k}", f"ib_d{k}")]

    @property
    def state_names(self) -> list[str]:
        """The handlers' state parameter names ``hs<type>_<j>``."""
        return [f"hs{k}_{j}" for k, h in enumerate(self.handlers) for j in range(len(h.state))]


@dataclass(frozen=True)
class Fused:
    """What the fused loop of a run calls: the mission's compiled sensors and, where the
    tree sends messages, their compiled handling; for the 3-D drone, its vertical
    parameters (``Layout.vertical``)."""

    sensors: SensorKernel
    messaging: Messaging | None
    vertical: tuple[float, float, float] | None = None
