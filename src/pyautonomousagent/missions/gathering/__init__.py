"""The paper's first scenario (Results, Fig. 5-10): drones orbit their surveillance positions,
refuel, share their state, and gather on one drone's position when it orders it."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.datalink import Delivery
from pyautonomousagent.kernels import HandlerKernel, Receive
from pyautonomousagent.missions.drones.kernels import adopt_point, adopt_point_everyone
from pyautonomousagent.missions.drones.leaves import GATHERING
from pyautonomousagent.missions.drones.mission import DroneMission, cycled
from pyautonomousagent.missions.gathering import measures  # noqa: F401  (registers them)
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation import (
    MessageType,
    Param,
    SimulationView,
    WorldObject,
    register_mission,
)
from pyautonomousagent.simulation.params import Reader
from pyautonomousagent.simulation.scenario_view import ScenarioView
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World


@register_mission
class GatheringMission(DroneMission):
    """Fig. 6's mission: surveillance positions per drone and the "gathering" order."""

    name = "gathering"
    description = "drones orbit their surveillance positions, refuel, share data and gather"
    parameters: ClassVar[tuple[Param, ...]] = (
        *DroneMission.parameters,
        Param("gathering_iteration", 5000, "iteration",
              "when the sender orders the gathering", minimum=0),
        Param("gathering_sender", "drone1", "", "the drone that orders the gathering"),
    )  # fmt: skip
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        *DroneMission.world_objects,
        WorldObject("surveillance_positions", Reader.points,
                    doc="surveillance positions [x, y], used in turn by drones 1, 2, ..."),
    )  # fmt: skip
    #: The "gathering" handler's kernels, for everyone and for one receiver (3-D: their
    #: forms with the altitude), in a tuple: a function held by a class would be bound.
    adopt_kernels: ClassVar[tuple[Any, Any]] = (adopt_point_everyone, adopt_point)
    points = "surveillance_positions"

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """The sender is one of the drones; positions lie in the world."""
        sender = scenario.parameters.gathering_sender
        number = sender.removeprefix(cls.agent_prefix)  # no list of names: agents may be 10**12
        if not (number.isdigit() and number[0] != "0" and int(number) <= scenario.agents):
            raise reader.fail(
                "parameters.gathering_sender",
                f"one of the drones (drone1..drone{scenario.agents})",
                sender,
            )
        super().check(scenario, reader)

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """On the refuelling slots; the first destination is the own surveillance position."""
        super().place(swarm, world, rng)
        self.set_surveillance(
            swarm, cycled(self.scenario.objects.surveillance_positions, swarm.size)
        )

    def message_types(self) -> list[MessageType]:
        """Sharing data, and "gathering" (recorded): the receiver adopts the position (the
        fields x, y and, in 3-D, z)."""
        fields = tuple(key[0] for key in self.surveillance)
        point = {f"p{field}": key for field, key in zip(fields, self.surveillance, strict=True)}
        everyone, one = self.adopt_kernels
        return [
            *super().message_types(),
            MessageType(GATHERING, self.adopt_gathering_position, recorded=True,
                        doc=f"{', '.join(fields)}: the position to gather on",
                        kernel=HandlerKernel(everyone, fields, point, receive=Receive(one))),
        ]  # fmt: skip

    def adopt_gathering_position(self, sim: SimulationView, delivery: Delivery) -> None:
        """The receiver's surveillance position becomes the message's position (the last
        one, in canonical order, if several arrived)."""
        bb = sim.swarm.blackboard
        receivers, rows = delivery.pairs(sim.swarm.size)
        last = receivers.size - 1 - np.unique(receivers[::-1], return_index=True)[1]
        data = delivery.messages.data
        for key in self.surveillance:
            bb[key][receivers[last]] = data[key[0]][rows[last]]

    def marks(self) -> list[Mark]:
        """Slots R1.., surveillance positions S1.."""
        points = self.scenario.objects.surveillance_positions
        return [*super().marks(), *self.surveillance_marks(points)]
