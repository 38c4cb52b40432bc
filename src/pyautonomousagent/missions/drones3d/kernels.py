"""The 3-D drone leaves for one agent, for the compiled engine.

Each function repeats, operation for operation, the NumPy body of the leaf named in its
docstring (``leaves.py``) on agent row ``a`` of the arrays it is given (shape (N,)); the
engine-identity tests hold the two equal bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import np_maximum, np_minimum


@njit(inline="always")
def destination_reached_3d(a: int, x: np.ndarray, y: np.ndarray, z: np.ndarray,
                           to_x: np.ndarray, to_y: np.ndarray, to_z: np.ndarray,
                           distance: float) -> int:  # fmt: skip
    """Condition_Destination_Reached_3D."""
    dx = x[a] - to_x[a]
    dy = y[a] - to_y[a]
    dz = z[a] - to_z[a]
    near = dx * dx + dy * dy <= distance * distance
    return SUCCESS if near and abs(dz) <= distance else FAILURE


@njit(inline="always")
def navigate_3d(a: int, x: np.ndarray, y: np.ndarray, z: np.ndarray, to_x: np.ndarray,
                to_y: np.ndarray, to_z: np.ndarray, speed: np.ndarray, altitude: np.ndarray,
                cruise: float, distance: float, slope: float) -> int:  # fmt: skip
    """Action_Navigate_To_Destination_3D_A: speed (0 over the destination) and altitude
    (the glide path toward a lower destination); RUNNING. Its last step, the requested
    heading, is ``kernels.bearing`` (a ``Later``)."""
    dx = x[a] - to_x[a]
    dy = y[a] - to_y[a]
    squared = dx * dx + dy * dy
    speed[a] = 0.0 if squared <= distance * distance else cruise
    target = to_z[a]
    glide = target + slope * math.sqrt(squared)
    altitude[a] = np_maximum(target, np_minimum(z[a], glide))
    return RUNNING


@njit(inline="always")
def copy_destination_3d(a: int, to_x: np.ndarray, to_y: np.ndarray, to_z: np.ndarray,
                        from_x: np.ndarray, from_y: np.ndarray,
                        from_z: np.ndarray) -> int:  # fmt: skip
    """Action_Set_Destination_Equal_To_{Surveillance,Refueling}_3D_S; SUCCESS."""
    to_x[a] = from_x[a]
    to_y[a] = from_y[a]
    to_z[a] = from_z[a]
    return SUCCESS


@njit(inline="always")
def patrol_position_3d(a: int, index: np.ndarray, to_x: np.ndarray, to_y: np.ndarray,
                       to_z: np.ndarray, sx: np.ndarray, sy: np.ndarray, sz: np.ndarray,
                       x1: np.ndarray, y1: np.ndarray, z1: np.ndarray, x2: np.ndarray,
                       y2: np.ndarray, z2: np.ndarray, other: int) -> int:  # fmt: skip
    """Action_Set_Destination_Equal_To_{Other,Current}_Surveillance_3D_S (``other`` 1/0)."""
    k = 3 - index[a] if other else index[a]
    first = k == 1
    px = x1[a] if first else x2[a]
    py = y1[a] if first else y2[a]
    pz = z1[a] if first else z2[a]
    index[a] = k
    sx[a] = px
    sy[a] = py
    sz[a] = pz
    to_x[a] = px
    to_y[a] = py
    to_z[a] = pz
    return SUCCESS


@njit(inline="always")
def land(a: int, z: np.ndarray, heading: np.ndarray, requested_speed: np.ndarray,
         requested_heading: np.ndarray, requested_altitude: np.ndarray) -> int:  # fmt: skip
    """Action_Land_3D_A."""
    requested_speed[a] = 0.0
    requested_heading[a] = heading[a]
    requested_altitude[a] = 0.0
    return SUCCESS if z[a] <= 0.0 else RUNNING


@njit(inline="always")
def request_altitude(a: int, requested_altitude: np.ndarray, value: float) -> int:
    """Action_Request_Altitude_S; SUCCESS."""
    requested_altitude[a] = value
    return SUCCESS


@njit(inline="always")
def transmit_point_3d(a: int, x: np.ndarray, y: np.ndarray, px: np.ndarray, py: np.ndarray,
                      pz: np.ndarray, outbox: np.ndarray) -> int:  # fmt: skip
    """Action_Transmit_Gathering_Message_3D_S: the point as payload x, y, z (outbox rows
    3-5) from where the drone is; SUCCESS."""
    outbox[0, a] = 1.0
    outbox[1, a] = x[a]
    outbox[2, a] = y[a]
    outbox[3, a] = px[a]
    outbox[4, a] = py[a]
    outbox[5, a] = pz[a]
    return SUCCESS


@njit(inline="always")
def drain_energy_3d(a: int, energy: np.ndarray, climb_rate: np.ndarray, use: float,
                    climb_use: float) -> bool:  # fmt: skip
    """``sense_climb`` then ``DroneMission.sense`` without an active radiation source: the
    climb's energy, then the energy of the iteration; True where some is left."""
    level = np_maximum(energy[a] - climb_use * np_maximum(climb_rate[a], 0.0), 0.0)
    level = np_maximum(level - use, 0.0)
    energy[a] = level
    return level > 0.0


@njit(inline="always")
def adopt_point_3d(r: int, m: int, t: int, senders: np.ndarray, data: np.ndarray,
                   px: np.ndarray, py: np.ndarray, pz: np.ndarray) -> None:  # fmt: skip
    """``Gathering3DMission.adopt_gathering_position`` of message ``m`` received by ``r`` (a
    ``Receive``): the drone takes the point (data rows x, y, z)."""
    px[r] = data[0, m]
    py[r] = data[1, m]
    pz[r] = data[2, m]


@njit
def adopt_point_everyone_3d(t: int, senders: np.ndarray, data: np.ndarray, count: int,
                            px: np.ndarray, py: np.ndarray, pz: np.ndarray) -> None:  # fmt: skip
    """``Gathering3DMission.adopt_gathering_position`` of a delivery that reached everyone:
    :func:`adopt_point_3d` for every drone but the sender; the last message wins."""
    for m in range(count):
        s = senders[m]
        for r in range(px.shape[0]):
            if r != s:
                adopt_point_3d(r, m, t, senders, data, px, py, pz)
