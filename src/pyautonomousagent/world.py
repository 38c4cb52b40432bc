"""The world the agents share: its size, the datalink, radiation sources and the clock."""

from __future__ import annotations

from dataclasses import dataclass, field

from pyautonomousagent.datalink import Datalink
from pyautonomousagent.sensors import RadiationSource


@dataclass
class World:
    """Everything outside the agents that leaves and phases read.

    Attributes:
        width, height: extent of the world (world units); x in [0, width], y in [0, height].
        datalink: the shared message channel.
        radiation_sources: sources read by the radiation sensor.
        agent_index: agent name -> row in the swarm arrays.
        iteration: the current iteration (1 for the first step; 0 before the run).
    """

    width: float
    height: float
    datalink: Datalink
    radiation_sources: tuple[RadiationSource, ...] = ()
    agent_index: dict[str, int] = field(default_factory=dict)
    iteration: int = 0
