"""The drone leaves and sensors for one agent, for the compiled engine.

Each function repeats, operation for operation, the NumPy body of the leaf or sensor named in
its docstring (``leaves.py``, ``sensors.py``), on agent row ``a`` of the arrays it is given
(shape (N,)); the engine-identity tests hold the two equal bit for bit. Statuses are the codes
of :mod:`pyautonomousagent.bt.status`.
"""

from __future__ import annotations

import numpy as np

from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import np_maximum, np_minimum


@njit(inline="always")
def destination_reached(a: int, x: np.ndarray, y: np.ndarray, to_x: np.ndarray,
                        to_y: np.ndarray, distance: float) -> int:  # fmt: skip
    """Condition_Destination_Reached."""
    dx = x[a] - to_x[a]
    dy = y[a] - to_y[a]
    return SUCCESS if dx * dx + dy * dy <= distance * distance else FAILURE


@njit(inline="always")
def at_most(a: int, energy: np.ndarray, threshold: float) -> int:
    """Condition_Low_Energy_Level: SUCCESS if ``energy[a] <= threshold``."""
    return SUCCESS if energy[a] <= threshold else FAILURE


@njit(inline="always")
def above(a: int, radiation: np.ndarray, threshold: float) -> int:
    """Condition_Radiation_Detected: SUCCESS if ``radiation[a] > threshold``."""
    return SUCCESS if radiation[a] > threshold else FAILURE


@njit(inline="always")
def at_least(a: int, damage: np.ndarray, threshold: float) -> int:
    """Condition_High_Damage_Level: SUCCESS if ``damage[a] >= threshold``."""
    return SUCCESS if damage[a] >= threshold else FAILURE


@njit(inline="always")
def gathering_moment(a: int, iteration: int, moment: int, sender: int) -> int:
    """Condition_Gathering_Moment (``sender``: the sender's row, -1 for none)."""
    if iteration != moment:
        return FAILURE
    return SUCCESS if a == sender else FAILURE


@njit(inline="always")
def navigate(a: int, requested_speed: np.ndarray, cruise: float) -> int:
    """Action_Navigate_To_Destination_A: the requested speed; RUNNING. Its last step, the
    requested heading, is ``kernels.bearing`` of the position and the destination (a
    ``Later``)."""
    requested_speed[a] = cruise
    return RUNNING


@njit(inline="always")
def copy_destination(a: int, to_x: np.ndarray, to_y: np.ndarray, from_x: np.ndarray,
                     from_y: np.ndarray) -> int:  # fmt: skip
    """Action_Set_Destination_Equal_To_{Surveillance,Refueling}_S: destination := from; SUCCESS."""
    to_x[a] = from_x[a]
    to_y[a] = from_y[a]
    return SUCCESS


@njit(inline="always")
def patrol_position(a: int, index: np.ndarray, to_x: np.ndarray, to_y: np.ndarray,
                    sx: np.ndarray, sy: np.ndarray, x1: np.ndarray, y1: np.ndarray,
                    x2: np.ndarray, y2: np.ndarray, other: int) -> int:  # fmt: skip
    """Action_Set_Destination_Equal_To_{Other,Current}_Surveillance_S (``other`` 1 or 0)."""
    k = 3 - index[a] if other else index[a]
    first = k == 1
    px = x1[a] if first else x2[a]
    py = y1[a] if first else y2[a]
    index[a] = k
    sx[a] = px
    sy[a] = py
    to_x[a] = px
    to_y[a] = py
    return SUCCESS


@njit(inline="always")
def hold_still_until(a: int, done: bool, heading: np.ndarray, requested_speed: np.ndarray,
                     requested_heading: np.ndarray, cruise: float) -> int:  # fmt: skip
    """``_hold_still_until``: speed 0 (same heading) until ``done``; RUNNING / SUCCESS."""
    requested_speed[a] = cruise if done else 0.0
    requested_heading[a] = heading[a]
    return SUCCESS if done else RUNNING


@njit(inline="always")
def refuel(a: int, energy: np.ndarray, heading: np.ndarray, requested_speed: np.ndarray,
           requested_heading: np.ndarray, rate: float, cruise: float) -> int:  # fmt: skip
    """Action_Refuel_A."""
    level = np_minimum(energy[a] + rate, 100.0)
    energy[a] = level
    return hold_still_until(a, level >= 100.0, heading, requested_speed, requested_heading,
                            cruise)  # fmt: skip


@njit(inline="always")
def repair(a: int, damage: np.ndarray, heading: np.ndarray, requested_speed: np.ndarray,
           requested_heading: np.ndarray, rate: float, cruise: float) -> int:  # fmt: skip
    """Action_Repair_Damage_A."""
    level = np_maximum(damage[a] - rate, 0.0)
    damage[a] = level
    return hold_still_until(a, level <= 0.0, heading, requested_speed, requested_heading,
                            cruise)  # fmt: skip


@njit(inline="always")
def drain_energy(a: int, energy: np.ndarray, use: float) -> bool:
    """``DroneMission.sense`` without an active radiation source: energy drains; True where
    some is left (the drone can move)."""
    level = np_maximum(energy[a] - use, 0.0)
    energy[a] = level
    return level > 0.0


@njit(inline="always")
def transmit_state(a: int, x: np.ndarray, y: np.ndarray, speed: np.ndarray, heading: np.ndarray,
                   damage: np.ndarray, energy: np.ndarray, outbox: np.ndarray) -> int:  # fmt: skip
    """Action_Transmit_Shared_Data_S: "sharing data" with x, y, speed, heading, damage and
    energy (outbox rows 3-8) from where the drone is; SUCCESS."""
    outbox[0, a] = 1.0
    outbox[1, a] = x[a]
    outbox[2, a] = y[a]
    outbox[3, a] = x[a]
    outbox[4, a] = y[a]
    outbox[5, a] = speed[a]
    outbox[6, a] = heading[a]
    outbox[7, a] = damage[a]
    outbox[8, a] = energy[a]
    return SUCCESS


@njit(inline="always")
def transmit_point(a: int, x: np.ndarray, y: np.ndarray, px: np.ndarray, py: np.ndarray,
                   outbox: np.ndarray) -> int:  # fmt: skip
    """Action_Transmit_Gathering_Message_S: the point (``px``, ``py``) as payload x, y
    (outbox rows 3-4) from where the drone is; SUCCESS."""
    outbox[0, a] = 1.0
    outbox[1, a] = x[a]
    outbox[2, a] = y[a]
    outbox[3, a] = px[a]
    outbox[4, a] = py[a]
    return SUCCESS


@njit
def remember_everyone(t: int, senders: np.ndarray, data: np.ndarray, count: int,
                      heard_at: np.ndarray, heard: np.ndarray) -> None:  # fmt: skip
    """``SharedData.store`` of a delivery that reached everyone: each sender's latest data
    (``heard`` shape (N, fields)) and its iteration + 1 (``heard_at`` shape (N,) int64;
    the messages were sent at ``t - 1``)."""
    for m in range(count):
        s = senders[m]
        heard_at[s] = t
        for f in range(data.shape[0]):
            heard[s, f] = data[f, m]


@njit(inline="always")
def remember_pair(r: int, m: int, t: int, senders: np.ndarray, data: np.ndarray,
                  full: np.ndarray, pair_sender: np.ndarray, pair_at: np.ndarray,
                  pair_data: np.ndarray) -> None:  # fmt: skip
    """``SharedData.store`` of message ``m`` received by ``r`` alone (a ``Receive``): the
    sender's data (``pair_data`` shape (N, room, fields)) and the iteration it was sent,
    ``t - 1`` (``pair_at`` shape (N, room) int64), in the slot of ``r``'s row of
    ``pair_sender`` (shape (N, room) int64, -1: free) holding that sender, else the first
    free one; ``full[0] = 1`` where none is left."""
    s = senders[m]
    for j in range(pair_sender.shape[1]):
        held = pair_sender[r, j]
        if held == s or held < 0:
            pair_sender[r, j] = s
            pair_at[r, j] = t - 1
            for f in range(data.shape[0]):
                pair_data[r, j, f] = data[f, m]
            return
    full[0] = 1


@njit(inline="always")
def adopt_point(r: int, m: int, t: int, senders: np.ndarray, data: np.ndarray, px: np.ndarray,
                py: np.ndarray) -> None:  # fmt: skip
    """``GatheringMission.adopt_gathering_position`` of message ``m`` received by ``r`` (a
    ``Receive``): the drone takes the point (data rows x, y)."""
    px[r] = data[0, m]
    py[r] = data[1, m]


@njit
def adopt_point_everyone(t: int, senders: np.ndarray, data: np.ndarray, count: int,
                         px: np.ndarray, py: np.ndarray) -> None:  # fmt: skip
    """``GatheringMission.adopt_gathering_position`` of a delivery that reached everyone:
    :func:`adopt_point` for every drone but the sender; the last message wins."""
    for m in range(count):
        s = senders[m]
        for r in range(px.shape[0]):
            if r != s:
                adopt_point(r, m, t, senders, data, px, py)
