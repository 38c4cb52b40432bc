"""A 3-D point-mass drone: the paper's eqs. 1-4 plus altitude and climb rate (docs/drone3d.md).

The horizontal motion is the 2-D drone's (:mod:`pyautonomousagent.models.drone2d`: speed is
the horizontal ground speed, heading in degrees clockwise from north). Two states are added:
the altitude ``z`` (world units above the ground, in ``[0, max_altitude]``) and the climb
rate ``w`` (world units per iteration, in ``[-max_climb_rate, max_climb_rate]``), with one
control signal ``u_w``:

- eq. 5: ``z[t+1] = clip(z[t] + w[t], 0, max_altitude)``
- eq. 6: ``w[t+1] = clip(w[t] + u_w[t], -max_climb_rate, max_climb_rate)``
- eq. 7 (Phase 4): ``w* = clip(h* - (z + w), -max_climb_rate, max_climb_rate)`` (the climb
  rate that reaches the requested altitude ``h*`` the step after the next, the next one
  being fixed already), ``u_w = clip(w* - w, -climb_step, climb_step)``: bang-bang
  (``climb_step * sign(w* - w)``) until the error is within one step, which is then taken
  whole, so the altitude settles instead of limit-cycling.

Only ``+ - min max`` act on the altitude, so every engine and every SIMD level gives the
same bits. The NumPy functions work on whole arrays of shape ``(N,)``; beside each, its
per-agent form (``*_agent``, on row ``a``: see :mod:`~pyautonomousagent.models.drone2d`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import np_maximum, np_minimum
from pyautonomousagent.models import drone2d

#: The swarm columns the 3-D drone moves and follows, name -> dtype: altitude (world units
#: above the ground), climb rate (world units per iteration, up positive) and the requested
#: altitude (world units), the control reference the altitude leaves write. A mission flown
#: by the 3-D drone declares them among its columns.
COLUMNS_3D: dict[str, type] = {
    "z": np.float64,
    "climb_rate": np.float64,
    "requested_altitude": np.float64,
}

#: Their units and meanings, for a mission's ``meanings``.
MEANINGS_3D: dict[str, tuple[str, str]] = {
    "z": ("world unit", "altitude above the ground, 0 to max_altitude"),
    "climb_rate": ("world unit / iteration", "vertical speed, up positive"),
    "requested_altitude": ("world unit", "the altitude the control system flies toward"),
}


@dataclass(frozen=True)
class Drone3DParameters(drone2d.DroneParameters):
    """Parameters of the 3-D drone model: the 2-D drone's (``max_speed``, ``speed_step``,
    ``turn_step``: :class:`~pyautonomousagent.models.drone2d.DroneParameters`), then:

    Attributes:
        max_climb_rate: largest climb or sink rate, world units per iteration.
        climb_step: largest change of the climb rate in one iteration (the control signal
            u_w's magnitude), world units per iteration per iteration.
        max_altitude: ceiling, world units above the ground.
    """

    max_climb_rate: float = 0.05
    climb_step: float = 0.05
    max_altitude: float = 100.0


def clip(value: np.ndarray, low: float, high: float) -> np.ndarray:
    """``min(max(value, low), high)`` element-wise (correctly rounded on every CPU)."""
    return np.minimum(np.maximum(value, low), high)


def advance_vertical(
    z: np.ndarray, climb: np.ndarray, u_climb: np.ndarray, params: Drone3DParameters
) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 5-6: the new altitude and climb rate, shape (N,) each.

    Args:
        z: altitude, world units, shape (N,).
        climb: climb rate, world units per iteration, shape (N,).
        u_climb: the control signal of the previous iteration, shape (N,).
        params: model parameters (bounds).
    """
    new_z = clip(z + climb, 0.0, params.max_altitude)
    new_climb = clip(climb + u_climb, -params.max_climb_rate, params.max_climb_rate)
    return new_z, new_climb


@njit(inline="always")
def climb_agent(a: int, moving: bool, z: np.ndarray, climb_rate: np.ndarray, u_climb: np.ndarray,
                max_climb_rate: float, max_altitude: float) -> None:  # fmt: skip
    """:func:`advance_vertical` of agent row ``a`` written into its entries of the arrays
    (shape (N,)) where ``moving``, else its climb rate set to 0."""
    if not moving:
        climb_rate[a] = 0.0
        return
    w = climb_rate[a]
    z[a] = np_minimum(np_maximum(z[a] + w, 0.0), max_altitude)
    climb_rate[a] = np_minimum(np_maximum(w + u_climb[a], -max_climb_rate), max_climb_rate)


def climb_control(
    z: np.ndarray, climb: np.ndarray, requested_altitude: np.ndarray, params: Drone3DParameters
) -> np.ndarray:
    """Eq. 7: the climb-rate control signal u_w toward the requested altitude, shape (N,).

    Args:
        z: altitude, world units, shape (N,).
        climb: climb rate, world units per iteration, shape (N,).
        requested_altitude: world units, shape (N,).
        params: model parameters.
    """
    wanted = clip(requested_altitude - (z + climb), -params.max_climb_rate, params.max_climb_rate)
    return clip(wanted - climb, -params.climb_step, params.climb_step)


@njit(inline="always")
def climb_control_agent(a: int, z: np.ndarray, climb_rate: np.ndarray,
                        requested_altitude: np.ndarray, u_climb: np.ndarray,
                        max_climb_rate: float, climb_step: float) -> None:  # fmt: skip
    """:func:`climb_control` of agent row ``a``, written into ``u_climb[a]`` (shape (N,))."""
    w = climb_rate[a]
    wanted = np_minimum(
        np_maximum(requested_altitude[a] - (z[a] + w), -max_climb_rate), max_climb_rate
    )
    u_climb[a] = np_minimum(np_maximum(wanted - w, -climb_step), climb_step)


class Drone3D(drone2d.Drone2D):
    """The 3-D drone as the swarm's motion model: the 2-D drone's, with the altitude: also
    moves and follows the columns of :data:`COLUMNS_3D` and holds the control signal u_w."""

    name = "drone3d"
    params: Drone3DParameters

    def __init__(self, params: Drone3DParameters, n_agents: int) -> None:
        super().__init__(params, n_agents)
        self.u_climb = np.zeros(n_agents)

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None:
        """Eqs. 1-6 where ``moving`` (shape (N,), bool) in the columns ``s``; the others stop
        where they are (speed and climb rate 0)."""
        z, climb = advance_vertical(s["z"], s["climb_rate"], self.u_climb, self.params)
        super().advance(s, moving)
        drone2d.settle(s, {"z": z, "climb_rate": climb}, moving, "climb_rate")

    def control(self, s: dict[str, np.ndarray]) -> None:
        """Phase 4: control signals toward the requested speed, heading and altitude."""
        super().control(s)
        self.u_climb = climb_control(s["z"], s["climb_rate"], s["requested_altitude"], self.params)
