"""What a mission's code sees of a running simulation: :class:`SimulationView`.

A mission's sensors, message handlers and sensor kernels are called with the run's
:class:`~pyautonomousagent.simulation.run.Simulation`; they are typed with this protocol, which
names only what lies below the missions (the swarm, the world, the records, the messages), so
that the missions' API does not depend on the loop that calls it (no import cycle).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from pyautonomousagent.datalink import Delivery
from pyautonomousagent.recording import Recorder
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World


class SimulationView(Protocol):
    """A running simulation as a mission sees it (``Simulation`` is one).

    Attributes:
        seed: the seed of ``rng``.
        rng: the run's source of sequential randomness.
        swarm: the agents' state and blackboards (N agents).
        world: the shared world: clock (``world.iteration``), datalink, world objects.
        recorder: Phase 6's records.
        inbox: messages delivered in Phase 5, acted on in the next Phase 2.
        events: alerts and recorded messages, as plain dicts.
    """

    seed: int
    rng: np.random.Generator
    swarm: Swarm
    world: World
    recorder: Recorder
    inbox: list[Delivery]
    events: list[dict[str, Any]]

    def alert(self, rows: np.ndarray, kind: str, message: str) -> None:
        """Record an alert of ``kind`` for the agents at ``rows`` (once per agent and kind)."""
        ...
