"""The world the agents share: its size, the clock, the datalink, the mission's world objects
and the reproducible random numbers of leaves."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.datalink import Datalink
from pyautonomousagent.randomness import CounterRandom


@dataclass
class World:
    """Everything outside the agents that leaves and phases read.

    Attributes:
        width, height: extent of the world (world units); x in [0, width], y in [0, height].
        datalink: the shared message channel.
        objects: the mission's world objects, read from the scenario's ``world:`` section,
            as attributes (e.g. ``objects.radiation_sources``).
        agent_index: agent name -> row in the swarm arrays.
        iteration: the current iteration (1 for the first step; 0 before the run).
        random: counter-based random numbers, the same on both engines
            (see :mod:`pyautonomousagent.randomness`).
    """

    width: float
    height: float
    datalink: Datalink
    objects: Any = field(default_factory=dict)
    agent_index: Mapping[str, int] = field(default_factory=dict)
    iteration: int = 0
    random: CounterRandom = field(default_factory=lambda: CounterRandom(0))
