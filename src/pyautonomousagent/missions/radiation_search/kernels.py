"""The radiation-search leaves, sensor and ``found`` handler for one agent (compiled engine).

Each function repeats, operation for operation, the NumPy code named in its docstring
(``leaves.py``, the mission's ``sense`` and ``store_reported_position``) on agent row ``a``
of the arrays it is given (shape (N,)), with :mod:`pyautonomousagent.kernels`' helpers for
the distances and bearings; the compiled-engine tests hold the two equal bit for bit.
Statuses are the codes of :mod:`pyautonomousagent.bt`.
"""

from __future__ import annotations

import numpy as np

from pyautonomousagent.bt import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import bearing, hypot
from pyautonomousagent.randomness import uniform_of_one


@njit(inline="always")
def radiation_reading(a: int, x: np.ndarray, y: np.ndarray, radiation: np.ndarray,
                      source_x: float, source_y: float, reach: float) -> bool:  # fmt: skip
    """``RadiationSearchMission.sense`` (``radiation_level``): the level at the drone,
    ``100 (1 - d / reach)`` percent within ``reach`` world units of the source, else 0;
    True: every drone moves."""
    distance = hypot(x[a] - source_x, y[a] - source_y)
    radiation[a] = 100.0 * (1.0 - distance / reach) if distance < reach else 0.0
    return True


@njit(inline="always")
def above(a: int, radiation: np.ndarray, threshold: float) -> int:
    """Condition_Radiation_Above_Threshold: SUCCESS if ``radiation[a] > threshold``."""
    return SUCCESS if radiation[a] > threshold else FAILURE


@njit(inline="always")
def source_reported(a: int, reported: np.ndarray) -> int:
    """Condition_Source_Reported: SUCCESS if ``reported[a] == 1``."""
    return SUCCESS if reported[a] == 1 else FAILURE


@njit(inline="always")
def at_reported_position(a: int, x: np.ndarray, y: np.ndarray, to_x: np.ndarray,
                         to_y: np.ndarray, distance: float) -> int:  # fmt: skip
    """Condition_At_Reported_Position: within ``distance`` world units of (to_x, to_y)."""
    dx = x[a] - to_x[a]
    dy = y[a] - to_y[a]
    return SUCCESS if dx * dx + dy * dy <= distance * distance else FAILURE


@njit(inline="always")
def report_source(a: int, x: np.ndarray, y: np.ndarray, reported: np.ndarray,
                  to_x: np.ndarray, to_y: np.ndarray, outbox: np.ndarray) -> int:  # fmt: skip
    """Action_Report_Source_S: ``found`` with the drone's position as payload x, y (outbox
    rows 3-4) from where it is; the drone remembers that position; SUCCESS."""
    outbox[0, a] = 1.0
    outbox[1, a] = x[a]
    outbox[2, a] = y[a]
    outbox[3, a] = x[a]
    outbox[4, a] = y[a]
    reported[a] = 1
    to_x[a] = x[a]
    to_y[a] = y[a]
    return SUCCESS


@njit(inline="always")
def fly(a: int, requested_speed: np.ndarray, speed: float) -> int:
    """Action_Fly_To_Reported_Position_A: the requested speed; RUNNING. Its last step, the
    requested heading, is ``kernels.bearing`` toward the reported position (a ``Later``)."""
    requested_speed[a] = speed
    return RUNNING


@njit(inline="always")
def hover(a: int, heading: np.ndarray, requested_speed: np.ndarray,
          requested_heading: np.ndarray) -> int:  # fmt: skip
    """Action_Hover_S: speed 0, the heading kept; SUCCESS."""
    requested_speed[a] = 0.0
    requested_heading[a] = heading[a]
    return SUCCESS


@njit(inline="always")
def wander(a: int, t: int, x: np.ndarray, y: np.ndarray, requested_speed: np.ndarray,
           requested_heading: np.ndarray, seed_high: int, seed_low: int, stream: int,
           period: int, margin: float, east: float, north: float, centre_x: float,
           centre_y: float, speed: float) -> int:  # fmt: skip
    """Action_Wander_A at iteration ``t``: a heading drawn in [0, 360) every ``period``
    iterations (``Leaf.uniform``: draw 0 of stream ``stream``, the seed in halves, see
    :func:`~pyautonomousagent.randomness.bits_of_one`); the bearing to (centre_x, centre_y)
    where the drone is nearer the edge than ``margin`` (``east``, ``north``: the world's
    width and height less the margin); RUNNING."""
    heading = requested_heading[a]
    if t % period == 0:
        heading = uniform_of_one(seed_high, seed_low, stream, a, t, 0.0, 360.0, 0)
    px = x[a]
    py = y[a]
    if px < margin or px > east or py < margin or py > north:
        heading = bearing(px, py, centre_x, centre_y)
    requested_heading[a] = heading
    requested_speed[a] = speed
    return RUNNING


@njit(inline="always")
def take_found(r: int, m: int, t: int, senders: np.ndarray, data: np.ndarray,
               reported: np.ndarray, to_x: np.ndarray, to_y: np.ndarray) -> None:  # fmt: skip
    """``store_reported_position`` of ``found`` message ``m`` received by drone ``r`` (a
    ``Receive``; ``data`` rows x, y): a drone that knows no position takes it, one that knows
    a position keeps it (so, given its messages in canonical order, the first wins)."""
    if reported[r] == 0:
        reported[r] = 1
        to_x[r] = data[0, m]
        to_y[r] = data[1, m]


@njit
def store_found_everyone(t: int, senders: np.ndarray, data: np.ndarray, count: int,
                         reported: np.ndarray, to_x: np.ndarray,
                         to_y: np.ndarray) -> None:  # fmt: skip
    """``RadiationSearchMission.store_reported_position`` of a delivery that reached everyone:
    :func:`take_found` of every message for every drone but its sender, in canonical order
    (``to_x``, ``to_y``: the reported positions)."""
    for r in range(reported.shape[0]):
        for m in range(count):
            if senders[m] != r:
                take_found(r, m, t, senders, data, reported, to_x, to_y)
