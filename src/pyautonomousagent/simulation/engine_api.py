"""What the loop asks of a decision engine, and what an engine may use of the simulation.

:class:`Engine` is Phase 3 (tick the swarm's trees); a :class:`FusedEngine` can also run whole
iterations itself (the compiled and GPU engines). Both are called with the run's
:class:`~pyautonomousagent.simulation.run.Simulation`, typed here as :class:`LoopView`, so
that the engines and the phases import no module that imports them (no import cycle).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol, TypeGuard, runtime_checkable

import numpy as np

from pyautonomousagent.simulation.view import SimulationView

if TYPE_CHECKING:
    from pyautonomousagent.bt.spec import Node
    from pyautonomousagent.simulation.mission import MessageType, Mission
    from pyautonomousagent.simulation.motion import Model
    from pyautonomousagent.simulation.scenario import Scenario
    from pyautonomousagent.state import Swarm
    from pyautonomousagent.world import World


class Engine(Protocol):
    """What the loop needs of a decision engine (Phase 3)."""

    name: str

    def __init__(
        self, tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]
    ) -> None: ...

    def tick(self) -> None: ...

    def node_statuses(self) -> np.ndarray: ...


class LoopView(SimulationView, Protocol):
    """A running simulation as the phases and the engines see it (``Simulation`` is one):
    what a mission sees, and the scenario, mission, motion model, engine and message types.

    Attributes:
        scenario: what is simulated.
        mission: the run's mission.
        model: the motion model (Phase 2 motion, Phase 4 control).
        engine: the decision engine of Phase 3.
        handlers: the mission's message types by name.
        timings: seconds spent per stage.
        everyone: which agents every message reaches, shape (N,), bool.
        recorded_types: the message types recorded as events.
        unhandled: message types received that no handler takes (warned once).
    """

    scenario: Scenario
    mission: Mission
    model: Model
    engine: Engine
    handlers: dict[str, MessageType]
    timings: dict[str, float]
    everyone: np.ndarray
    recorded_types: tuple[str, ...]
    unhandled: set[str]

    def step(self) -> None:
        """Run one iteration, Phases 2-6, in Python."""
        ...


@runtime_checkable
class FusedEngine(Protocol):
    """An engine that can also run whole iterations itself (Phases 2-6 fused, e.g. the
    compiled and GPU engines): the simulation calls :meth:`prepare` once it is built,
    :meth:`loop` before stepping an iteration in Python, and :meth:`sync` at the end of each
    ``run`` and ``step``."""

    def prepare(self, sim: LoopView) -> None:
        """Compile (or load) what the run will call, before its first iteration."""
        ...

    def loop(self, sim: LoopView, count: int, typical: int | None = None) -> int:
        """Run up to ``count`` whole iterations (all but the last one's Phase 5); how many
        were run, 0 where the next iteration cannot be fused (``Simulation.step`` runs it)."""
        ...

    def sync(self, sim: LoopView) -> None:
        """Finish the work in flight: the recorder holds every iteration run, the swarm's
        arrays the state."""
        ...


def fuses(engine: Engine) -> TypeGuard[FusedEngine]:
    """Whether ``engine`` is a :class:`FusedEngine` (by its class, decided once per class:
    ``isinstance`` of a protocol costs 6-14 us, and the loop asks twice an iteration)."""
    return _fusing_class(type(engine))


@functools.cache
def _fusing_class(kind: type) -> bool:
    return issubclass(kind, FusedEngine)
