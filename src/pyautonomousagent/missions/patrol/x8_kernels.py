"""The X8 landing leaves for one agent, for the compiled engine.

Each function repeats, operation for operation, the NumPy body of the leaf named in its
docstring (:mod:`pyautonomousagent.missions.patrol.x8`) on agent row ``a``; the
engine-identity tests hold the two equal bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from pyautonomousagent.bt.status import RUNNING, SUCCESS
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import bearing, np_minimum
from pyautonomousagent.models.x8_modes import CRUISE, FLIGHT, LAND, PARKED, TAKE_OFF


@njit(inline="always")
def land(a: int, x: np.ndarray, y: np.ndarray, phase: np.ndarray, mode: np.ndarray,
         heading: np.ndarray, speed: np.ndarray, altitude: np.ndarray, leg: np.ndarray,
         aim_x: float, aim_y: float, fix_x: float, fix_y: float, tangent: float,
         capture: float, ceiling: float, approach_speed: float, cruise: float) -> int:  # fmt: skip
    """Action_Land_A."""
    dx = fix_x - x[a]
    dy = fix_y - y[a]
    now = 1 if dx * dx + dy * dy <= capture * capture else leg[a]
    final = now == 1
    dx = aim_x - x[a]
    dy = aim_y - y[a]
    glide = tangent * math.sqrt(dx * dx + dy * dy)
    to_x, to_y = (aim_x, aim_y) if final else (fix_x, fix_y)
    heading[a] = bearing(x[a], y[a], to_x, to_y)
    speed[a] = approach_speed if final else cruise
    altitude[a] = np_minimum(ceiling, glide)
    mode[a] = float(LAND) if final else float(CRUISE)
    parked = phase[a] == PARKED
    leg[a] = 0 if parked else now
    return SUCCESS if parked else RUNNING


@njit(inline="always")
def take_off(a: int, phase: np.ndarray, mode: np.ndarray, heading: np.ndarray,
             requested_heading: np.ndarray, speed: np.ndarray, cruise: float) -> int:  # fmt: skip
    """Action_Take_Off_A."""
    flying = phase[a] == FLIGHT
    mode[a] = float(CRUISE) if flying else float(TAKE_OFF)
    speed[a] = cruise
    requested_heading[a] = heading[a]
    return SUCCESS if flying else RUNNING
