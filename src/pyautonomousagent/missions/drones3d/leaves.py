"""The 3-D drones' leaves: destinations with an altitude, and the leaves that request one.

Each works like its 2-D namesake in :mod:`pyautonomousagent.missions.drones.leaves`, with the
altitude ``z`` (world units above the ground) beside x and y. The altitude is requested
through the swarm column ``requested_altitude``, which the 3-D drone's control system
follows (:mod:`pyautonomousagent.models.drone3d`). Written once with array expressions, so the
same code runs for one agent (py_trees engine) or many (batched); ``kernels.py`` repeats them
for the compiled engine.
"""

from __future__ import annotations

from typing import Any

from pyautonomousagent.arrays import bearing, choose, hypot, maximum, minimum
from pyautonomousagent.bt.leaf import Leaf, Port, register_leaf
from pyautonomousagent.bt.status import RUNNING, SUCCESS, status_if, success_if
from pyautonomousagent.kernels import Later, LeafKernel
from pyautonomousagent.kernels import bearing as bearing_of_one
from pyautonomousagent.missions.drones.leaves import (
    DESTINATION,
    PATROL,
    REFUELING,
    SPEED,
    SURVEILLANCE,
    ActionTransmitGatheringMessageS,
    CopyDestination,
    PatrolPosition,
    toward,
)
from pyautonomousagent.missions.drones3d import kernels as k
from pyautonomousagent.state import AgentView
from pyautonomousagent.world import World

DESTINATION_3D = (*DESTINATION, "z_current_destination_position")
SURVEILLANCE_3D = (*SURVEILLANCE, "z_surveillance_position")
REFUELING_3D = (*REFUELING, "z_refueling_position")
#: The patrol keys with altitudes: the index, then position 1 (x, y, z) and 2 (x, y, z).
PATROL_3D = (
    PATROL[0],
    PATROL[1], PATROL[2], "z_surveillance_position_1",
    PATROL[3], PATROL[4], "z_surveillance_position_2",
)  # fmt: skip
#: The arrays of ``kernels.patrol_position_3d``, parameter -> key.
PATROL_ARRAYS_3D = dict(
    zip(("index", "to_x", "to_y", "to_z", "sx", "sy", "sz", "x1", "y1", "z1", "x2", "y2", "z2"),
        (PATROL_3D[0], *DESTINATION_3D, *SURVEILLANCE_3D, *PATROL_3D[1:]), strict=True)
)  # fmt: skip
DISTANCE = Port("distance", float, "destination_tolerance", 0.0, "world units")
SLOPE = Port("slope", float, "descent_slope", 0.0,
             "steepest descent toward a lower destination, world units down per world unit "
             "flown")  # fmt: skip


@register_leaf
class ConditionDestinationReached3D(Leaf):
    """SUCCESS if the agent is within ``distance`` of its current destination horizontally
    and within ``distance`` of its altitude (a cylinder round the destination)."""

    type_name = "Condition_Destination_Reached_3D"
    ports = (DISTANCE,)
    keys = DESTINATION_3D
    distance: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        dx = agents.x - bb.x_current_destination_position
        dy = agents.y - bb.y_current_destination_position
        dz = agents.z - bb.z_current_destination_position
        near = dx * dx + dy * dy <= self.distance * self.distance
        return success_if(near & (abs(dz) <= self.distance))

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.destination_reached_3d, toward(DESTINATION_3D), (self.distance,))


@register_leaf
class ActionNavigateToDestination3DA(Leaf):
    """Fly toward the current destination and its altitude; always RUNNING.

    Requests the heading toward it, cruise speed (0 once within ``distance`` horizontally:
    the drone hovers while it climbs or descends the rest of the way), and the altitude
    ``max(z_d, min(z, z_d + slope * d))`` (``z_d``: the destination's altitude, ``d``: the
    horizontal distance to it): a higher destination is climbed to at once; toward a lower
    one the drone holds its altitude until it meets the glide path of ``slope`` down to it,
    then follows that path (so it does not reach the ground before its refuelling slot).
    """

    type_name = "Action_Navigate_To_Destination_3D_A"
    ports = (SPEED, DISTANCE, SLOPE)
    keys = DESTINATION_3D
    speed: float
    distance: float
    slope: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        bb = agents.blackboard
        to_x, to_y = bb.x_current_destination_position, bb.y_current_destination_position
        agents.requested_heading = bearing(agents.x, agents.y, to_x, to_y)
        dx = agents.x - to_x
        dy = agents.y - to_y
        squared = dx * dx + dy * dy
        agents.requested_speed = choose(squared <= self.distance * self.distance, 0.0, self.speed)
        to_z = bb.z_current_destination_position
        glide = to_z + self.slope * hypot(dx, dy)  # sqrt(squared), for one agent or arrays
        agents.requested_altitude = maximum(to_z, minimum(agents.z, glide))
        return RUNNING

    def kernel(self, world: World) -> LeafKernel:
        heading = Later(bearing_of_one, toward(DESTINATION), "requested_heading")
        names = {**toward(DESTINATION_3D), "speed": "requested_speed",
                 "altitude": "requested_altitude"}  # fmt: skip
        constants = (self.speed, self.distance, self.slope)
        return LeafKernel(k.navigate_3d, names, constants, later=heading)


@register_leaf
class ActionRequestAltitudeS(Leaf):
    """Request altitude ``altitude`` (the control system climbs or descends to it); SUCCESS."""

    type_name = "Action_Request_Altitude_S"
    ports = (Port("altitude", float, "cruise_altitude", 0.0, "world units above the ground"),)
    altitude: float

    def evaluate(self, agents: AgentView, world: World) -> Any:
        agents.requested_altitude = self.altitude
        return SUCCESS

    def kernel(self, world: World) -> LeafKernel:
        return LeafKernel(k.request_altitude, ("requested_altitude",), (self.altitude,))


@register_leaf
class ActionLand3DA(Leaf):
    """Land where the drone is: request speed 0 (keeping the heading) and altitude 0;
    RUNNING until on the ground (z = 0), then SUCCESS."""

    type_name = "Action_Land_3D_A"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        agents.requested_speed = 0.0
        agents.requested_heading = agents.heading
        agents.requested_altitude = 0.0
        return status_if(agents.z <= 0.0, SUCCESS, RUNNING)

    def kernel(self, world: World) -> LeafKernel:
        names = ("z", "heading", "requested_speed", "requested_heading", "requested_altitude")
        return LeafKernel(k.land, names)


@register_leaf
class ActionSetDestinationEqualToSurveillance3DS(CopyDestination):
    """Destination := the surveillance position, with its altitude; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Surveillance_3D_S"
    keys = DESTINATION_3D + SURVEILLANCE_3D
    destination = DESTINATION_3D
    source = SURVEILLANCE_3D
    copy = (k.copy_destination_3d,)


@register_leaf
class ActionSetDestinationEqualToRefueling3DS(CopyDestination):
    """Destination := the refuelling slot, on the ground; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Refueling_3D_S"
    keys = DESTINATION_3D + REFUELING_3D
    destination = DESTINATION_3D
    source = REFUELING_3D
    copy = (k.copy_destination_3d,)


@register_leaf
class ActionSetDestinationEqualToOtherSurveillance3DS(PatrolPosition):
    """Switch to the other patrol position and make it (with its altitude) the destination;
    SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Other_Surveillance_3D_S"
    keys = DESTINATION_3D + SURVEILLANCE_3D + PATROL_3D
    axes = "xyz"
    other = 1
    patrol = (k.patrol_position_3d, PATROL_ARRAYS_3D)


@register_leaf
class ActionSetDestinationEqualToCurrentSurveillance3DS(PatrolPosition):
    """Destination := the current patrol position, with its altitude; SUCCESS."""

    type_name = "Action_Set_Destination_Equal_To_Current_Surveillance_3D_S"
    keys = DESTINATION_3D + SURVEILLANCE_3D + PATROL_3D
    axes = "xyz"
    other = 0
    patrol = (k.patrol_position_3d, PATROL_ARRAYS_3D)


@register_leaf
class ActionTransmitGatheringMessage3DS(ActionTransmitGatheringMessageS):
    """Send everyone a "gathering" message carrying this agent's surveillance position with
    its altitude (x, y, z); SUCCESS."""

    type_name = "Action_Transmit_Gathering_Message_3D_S"
    keys = SURVEILLANCE_3D
    transmit = (k.transmit_point_3d,)
