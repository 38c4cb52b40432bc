"""The patrol mission: drones patrol between two surveillance positions and refuel at low
energy (the paper's Fig. 11-12)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.missions.drones.leaves import PATROL
from pyautonomousagent.missions.drones.mission import DroneMission
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation import WorldObject, register_mission
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World


@register_mission
class PatrolMission(DroneMission):
    """Fig. 12's mission: every drone alternates between the two patrol positions."""

    name = "patrol"
    description = "drones patrol between two surveillance positions and refuel"
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        *DroneMission.world_objects,
        WorldObject("patrol_positions", lambda r, d, p: r.points(d, p, 2, 2),
                    doc="the two positions patrolled by every drone; the first is the first"),
    )  # fmt: skip
    #: The patrol's blackboard keys: the index, then positions 1 and 2 (x, y[, z] each).
    patrol: ClassVar[tuple[str, ...]] = PATROL
    points = "patrol_positions"

    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        **DroneMission.meanings,
        "index_current_surveillance_position": (
            "",
            "blackboard: patrol position flown to (1 or 2)",
        ),
        "x_surveillance_position_1": ("world unit", "blackboard: patrol position 1, east"),
        "y_surveillance_position_1": ("world unit", "blackboard: patrol position 1, north"),
        "x_surveillance_position_2": ("world unit", "blackboard: patrol position 2, east"),
        "y_surveillance_position_2": ("world unit", "blackboard: patrol position 2, north"),
    }

    def blackboard(self) -> dict[str, Any]:
        """Table 3 plus the two patrol positions and the index of the current one."""
        keys = {**super().blackboard(), **dict.fromkeys(PATROL, np.float64)}
        return {**keys, "index_current_surveillance_position": np.int64}

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """On the refuelling slots; the first patrol position is the first destination."""
        super().place(swarm, world, rng)
        first, second = self.scenario.objects.patrol_positions
        bb = swarm.blackboard
        for key, value in zip(self.patrol[1:], (*first, *second), strict=True):
            bb[key][:] = value
        bb["index_current_surveillance_position"][:] = 1
        self.set_surveillance(swarm, np.tile(np.asarray(first, dtype=np.float64), (swarm.size, 1)))

    def marks(self) -> list[Mark]:
        """Slots R1.., the two patrol positions S1, S2."""
        return [*super().marks(), *self.surveillance_marks(self.scenario.objects.patrol_positions)]
