"""The paper's drone leaves: Table 1, the patrol nodes and the radiation/damage nodes.

Every leaf reads and writes an :class:`~pyautonomousagent.state.AgentView` with array
expressions, so the same code runs for one agent (py_trees engine) or many at once.
Suffix ``_S``: synchronous (SUCCESS/FAILURE); suffix ``_A``: asynchronous (may be RUNNING).
"""

from __future__ import annotations

from typing import Any, ClassVar

from pyautonomousagent.arrays import bearing, choose, maximum, minimum
from pyautonomousagent.bt.leaf import Leaf, Port, register_leaf
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS, status_if, success_if
from pyautonomousagent.kernels import ITERATION, Later, LeafKernel, Sends
from pyautonomousagent.kernels import bearing as bearing_of_one
from pyautonomousagent.missions.drones import kernels as k
from pyautonomousagent.state import AgentView
from pyautonomousagent.world import World

#: The message types the drones send.
SHARING_DATA = "sharing data"
GATHERING = "gathering"

DESTINATION = ("x_current_destination_position", "y_current_destination_position")
SURVEILLANCE = ("x_surveillance_position", "y_surveillance_position")
REFUELING = ("x_refueling_position", "y_refueling_position")
PATROL = (
    "index_current_surveillance_position",
    "x_surveillance_position_1",
    "y_surveillance_position_1",
    "x_surveillance_position_2",
    "y_surveillance_position_2",
)
#: The control references a navigating leaf writes.
REQUESTED = ("requested_heading", "requested_speed")
#: The arrays of ``kernels.patrol_position``, parameter -> column.
PATROL_ARRAYS = dict(
    zip(("index", "to_x", "to_y", "sx", "sy", "x1", "y1", "x2", "y2"),
        (PATROL[0], *DESTINATION, *SURVEILLANCE, *PATROL[1:]), strict=True)
)  # fmt: skip
#: What "sharing data" carries: the sender's state, in payload order.
STATE = ("x", "y", "speed", "heading", "damage", "energy")
SPEED = Port("speed", float, "reference_speed", 0.0, "cruise speed requested, units per iteration")


def toward(target: tuple[str, ...]) -> dict[str, str]:
    """The position and the point ``target`` (its x, y[, z] keys) as the kernels' ``x, y[, z],
    to_x, to_y[, to_z]`` (parameter -> column: ``kernels.destination_reached``, its 3-D form,
    ``kernels.bearing``)."""
    axes = "xyz"[: len(target)]
    return {**{a: a for a in axes}, **{f"to_{a}": key for a, key in zip(axes, target, strict=True)}}


@register_leaf
class ConditionDestinationReached(Leaf):
    """SUCCESS if the agent is within ``distance`` of its current destination."""

    type_name = "Condition_Destination_Reached"
    ports = (Port("distance", float, "destination_tolerance", 0.0, "world units"),)
    keys: ClassVar[tuple[str, ...]] = DESTINATION
    distance: float
    #: The blackboard keys (x, y) of the point, and the kernel in a tuple (a function held
    #: by a class would be bound as a method); subclasses set others.
    target: ClassVar[tuple[str, ...]] = DESTINATION
    reached: ClassVar[tuple[Any]] = (k.destination_reached,)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        dx = agents.x - getattr(bb, self.target[0])
        dy = agents.y - getattr(bb, self.target[1])
        dx *= dx  # in place on arrays: two temporaries of N, not five
        dy *= dy
        dx += dy
        return success_if(dx <= self.distance * self.distance)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(self.reached[0], toward(self.target), (self.distance,))


@register_leaf
class ConditionLowEnergyLevel(Leaf):
    """SUCCESS if the energy level is at or below ``threshold`` percent."""

    type_name = "Condition_Low_Energy_Level"
    ports = (Port("threshold", float, "low_energy_threshold", 0.0, "percent"),)
    threshold: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(agents.energy <= self.threshold)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.at_most, ("energy",), (self.threshold,))


@register_leaf
class ConditionGatheringMoment(Leaf):
    """SUCCESS at iteration ``iteration`` for the agent called ``sender``."""

    type_name = "Condition_Gathering_Moment"
    ports = (
        Port("iteration", int, "gathering_iteration", 0, "the iteration of the gathering"),
        Port("sender", str, "gathering_sender", None, "the agent that orders the gathering"),
    )
    iteration: int
    sender: str

    def evaluate(self, agents: AgentView, world: World) -> Any:
        if world.iteration != self.iteration:
            return FAILURE
        return success_if(agents.rows == world.agent_index.get(self.sender, -1))

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(
            k.gathering_moment,
            {"iteration": ITERATION},
            (self.iteration, world.agent_index.get(self.sender, -1)),
        )


@register_leaf
class ConditionRadiationDetected(Leaf):
    """SUCCESS if the radiation sensor reads more than ``threshold`` percent."""

    type_name = "Condition_Radiation_Detected"
    ports = (Port("threshold", float, "radiation_threshold", 0.0, "percent"),)
    threshold: float
    #: The kernel, in a tuple (a function held by a class would be bound as a method).
    above: ClassVar[tuple[Any]] = (k.above,)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(agents.radiation > self.threshold)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(self.above[0], ("radiation",), (self.threshold,))


@register_leaf
class ConditionHighDamageLevel(Leaf):
    """SUCCESS if the damage level is at or above ``threshold`` percent."""

    type_name = "Condition_High_Damage_Level"
    ports = (Port("threshold", float, "damage_limit", 0.0, "percent"),)
    threshold: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(agents.damage >= self.threshold)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.at_least, ("damage",), (self.threshold,))


@register_leaf
class ActionNavigateToDestinationA(Leaf):
    """Request the heading toward the current destination at cruise speed; always RUNNING."""

    type_name = "Action_Navigate_To_Destination_A"
    ports = (SPEED,)
    keys: ClassVar[tuple[str, ...]] = DESTINATION
    speed: float
    #: The blackboard keys (x, y) of the point flown to, and the kernel in a tuple (a
    #: function held by a class would be bound as a method); subclasses set others.
    target: ClassVar[tuple[str, ...]] = DESTINATION
    fly: ClassVar[tuple[Any]] = (k.navigate,)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        to_x, to_y = (getattr(bb, key) for key in self.target)
        agents.requested_heading = bearing(agents.x, agents.y, to_x, to_y)
        agents.requested_speed = self.speed
        return RUNNING

    def kernel(self, world: World) -> LeafKernel:
        heading = Later(bearing_of_one, toward(self.target), "requested_heading")
        return LeafKernel(self.fly[0], ("requested_speed",), (self.speed,), later=heading)


class CopyDestination(Leaf):
    """Base of the leaves "destination := a blackboard position" (2-D and 3-D); SUCCESS."""

    #: The keys (x, y[, z]) of the destination and of the position copied to it.
    destination: ClassVar[tuple[str, ...]] = DESTINATION
    source: ClassVar[tuple[str, ...]]
    #: The kernel (``copy_destination`` or its 3-D form), in a tuple: a function held by
    #: a class would be bound as a method.
    copy: ClassVar[tuple[Any]] = (k.copy_destination,)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        return _set_destination(agents, self.destination, *(getattr(bb, s) for s in self.source))

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(self.copy[0], _destination_from(self.destination, self.source))


def _set_destination(agents: AgentView, keys: tuple[str, ...], *position: Any) -> int:
    """Destination (blackboard ``keys``: x, y[, z]) := ``position``; SUCCESS."""
    for key, value in zip(keys, position, strict=True):
        setattr(agents.blackboard, key, value)
    return SUCCESS


def _destination_from(destination: tuple[str, ...], source: tuple[str, ...]) -> dict[str, str]:
    """``kernels.copy_destination``'s (or its 3-D form's) arrays, parameter -> key:
    ``to_x, to_y[, to_z]`` the ``destination``, then ``from_x, ...`` the ``source``."""
    axes = "xyz"[: len(source)]
    return {**{f"to_{axis}": key for axis, key in zip(axes, destination, strict=True)},
            **{f"from_{axis}": key for axis, key in zip(axes, source, strict=True)}}  # fmt: skip


@register_leaf
class ActionSetDestinationEqualToSurveillanceS(CopyDestination):
    """Destination := the surveillance position; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Surveillance_S"
    keys = DESTINATION + SURVEILLANCE
    source = SURVEILLANCE


@register_leaf
class ActionSetDestinationEqualToRefuelingS(CopyDestination):
    """Destination := the refuelling slot; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Refueling_S"
    keys = DESTINATION + REFUELING
    source = REFUELING


class PatrolPosition(Leaf):
    """Base of the leaves that make patrol position 1 or 2 current and the destination (2-D
    and 3-D: :attr:`axes`); SUCCESS. :attr:`other`: 1 switches to the other position, 0
    keeps the current one."""

    axes: ClassVar[str] = "xy"
    other: ClassVar[int]
    #: The kernel (``patrol_position`` or its 3-D form) and its arrays, parameter -> key.
    patrol: ClassVar[tuple[Any, dict[str, str]]] = (k.patrol_position, PATROL_ARRAYS)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        index = bb.index_current_surveillance_position
        index = 3 - index if self.other else index
        first = index == 1
        position = [
            choose(first, getattr(bb, f"{axis}_surveillance_position_1"),
                   getattr(bb, f"{axis}_surveillance_position_2"))
            for axis in self.axes
        ]  # fmt: skip
        bb.index_current_surveillance_position = index
        for axis, value in zip(self.axes, position, strict=True):
            setattr(bb, f"{axis}_surveillance_position", value)
        keys = tuple(f"{axis}_current_destination_position" for axis in self.axes)
        return _set_destination(agents, keys, *position)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(self.patrol[0], self.patrol[1], (self.other,))


@register_leaf
class ActionSetDestinationEqualToOtherSurveillanceS(PatrolPosition):
    """Switch to the other patrol surveillance position and make it the destination; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Other_Surveillance_S"
    keys = DESTINATION + SURVEILLANCE + PATROL
    other = 1


@register_leaf
class ActionSetDestinationEqualToCurrentSurveillanceS(PatrolPosition):
    """Destination := the current patrol surveillance position; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Current_Surveillance_S"
    keys = DESTINATION + SURVEILLANCE + PATROL
    other = 0


@register_leaf
class ActionTransmitGatheringMessageS(Leaf):
    """Send everyone a "gathering" message carrying this agent's surveillance position; SUCCESS.

    The 3-D leaf subclasses it: :attr:`keys` are the point's (x, y[, z]: the payload's
    fields), :attr:`transmit` holds the kernel."""

    type_name = "Action_Transmit_Gathering_Message_S"
    keys: ClassVar[tuple[str, ...]] = SURVEILLANCE
    transmit: ClassVar[tuple[Any]] = (k.transmit_point,)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        data = {key[0]: getattr(bb, key) for key in self.keys}
        self.broadcast(agents, world, GATHERING, data)
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        point = {f"p{key[0]}": key for key in self.keys}
        fields = tuple(key[0] for key in self.keys)
        return LeafKernel(self.transmit[0], {"x": "x", "y": "y", **point},
                          sends=Sends(GATHERING, fields))  # fmt: skip


@register_leaf
class ActionTransmitSharedDataS(Leaf):
    """Send everyone a "sharing data" message with this agent's state; SUCCESS."""

    type_name = "Action_Transmit_Shared_Data_S"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        a = agents
        data = {"x": a.x, "y": a.y, "speed": a.speed, "heading": a.heading,
                "damage": a.damage, "energy": a.energy}  # fmt: skip
        self.broadcast(agents, world, SHARING_DATA, data)
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.transmit_state, STATE, sends=Sends(SHARING_DATA, STATE))


def _hold_still_until(agents: AgentView, done: Any, speed: float) -> Any:
    """Request speed 0 (keeping the heading) until ``done``, then cruise speed; RUNNING/SUCCESS."""
    agents.requested_speed = choose(done, speed, 0.0)
    agents.requested_heading = agents.heading
    return status_if(done, SUCCESS, RUNNING)


@register_leaf
class ActionRefuelA(Leaf):
    """Refuel ``rate`` percent per iteration, standing still; RUNNING until 100 %, then SUCCESS."""

    type_name = "Action_Refuel_A"
    ports = (Port("rate", float, "refuel_rate", 0.0, "percent per iteration"), SPEED)
    rate: float
    speed: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        energy = minimum(agents.energy + self.rate, 100.0)
        agents.energy = energy
        return _hold_still_until(agents, energy >= 100.0, self.speed)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(
            k.refuel, ("energy", "heading", *REQUESTED[::-1]), (self.rate, self.speed)
        )


@register_leaf
class ActionRepairDamageA(Leaf):
    """Repair ``rate`` percent of damage per iteration, standing still; RUNNING until 0 %."""

    type_name = "Action_Repair_Damage_A"
    ports = (Port("rate", float, "repair_rate", 0.0, "percent per iteration"), SPEED)
    rate: float
    speed: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        damage = maximum(agents.damage - self.rate, 0.0)
        agents.damage = damage
        return _hold_still_until(agents, damage <= 0.0, self.speed)

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(
            k.repair, ("damage", "heading", *REQUESTED[::-1]), (self.rate, self.speed)
        )
