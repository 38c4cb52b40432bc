"""The paper's 2-D point-mass drone (eqs. 1-4) and its bang-bang control system (Phase 4).

Heading is in degrees, measured clockwise from north (+y), as in aviation: a drone with
heading 90 flies east (+x). The NumPy functions work on whole arrays of shape ``(N,)``;
beside each, its per-agent form (``*_agent``: the same operations in the same order on row
``a``; the compiled engine's loop and the GPU kernel call it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyautonomousagent.arrays import sincos_degrees, wrap_degrees
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import np_maximum, np_minimum, np_sign
from pyautonomousagent.kernels import sincos_degrees as sincos_one
from pyautonomousagent.kernels import wrap_degrees as wrap_one


@dataclass(frozen=True)
class DroneParameters:
    """Parameters of the 2-D drone model.

    Attributes:
        max_speed: upper speed limit, world units per iteration (paper: 0.1).
        speed_step: magnitude of the speed control signal u_v per iteration (paper: 0.1).
        turn_step: magnitude of the heading control signal u_a, degrees per iteration
            (reference-facts decision: 1.0).
    """

    max_speed: float = 0.1
    speed_step: float = 0.1
    turn_step: float = 1.0


def advance(
    x: np.ndarray,
    y: np.ndarray,
    speed: np.ndarray,
    heading: np.ndarray,
    u_speed: np.ndarray,
    u_heading: np.ndarray,
    params: DroneParameters,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One step of paper eqs. 1-4 with last iteration's state and control signals.

    Args:
        x, y: position, shape (N,).
        speed: units per iteration, shape (N,).
        heading: degrees clockwise from north, shape (N,).
        u_speed, u_heading: control signals of the previous iteration, shape (N,).
        params: model parameters (speed limits).

    Returns:
        New (x, y, speed, heading); speed clipped to [0, max_speed], heading in [0, 360).
    """
    new_x, new_y = next_position(x, y, speed, heading)
    new_speed = np.minimum(np.maximum(speed + u_speed, 0.0), params.max_speed)
    new_heading = wrap_degrees(heading + u_heading)
    return new_x, new_y, new_speed, new_heading


@njit(inline="always")
def step_agent(a: int, moving: bool, x: np.ndarray, y: np.ndarray, speed: np.ndarray,
               heading: np.ndarray, u_speed: np.ndarray, u_heading: np.ndarray,
               max_speed: float) -> None:  # fmt: skip
    """:meth:`Drone2D.advance` of agent row ``a``: :func:`advance` written into its entries
    of the arrays (shape (N,)) where ``moving``, else its speed set to 0."""
    if not moving:
        speed[a] = 0.0
        return
    h, v = heading[a], speed[a]
    sine, cosine = sincos_one(h)
    x[a] = x[a] + v * sine
    y[a] = y[a] + v * cosine
    speed[a] = np_minimum(np_maximum(v + u_speed[a], 0.0), max_speed)
    heading[a] = wrap_one(h + u_heading[a])


def next_position(
    x: np.ndarray, y: np.ndarray, speed: np.ndarray, heading: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where each drone will be after its next step (paper eqs. 1-2), shape (N,) each.

    Args:
        x, y: position, world units, shape (N,).
        speed: world units per iteration, shape (N,).
        heading: degrees clockwise from north, [0, 360), shape (N,) (sine and cosine from
            :func:`~pyautonomousagent.arrays.sincos_degrees`: the same bits on every engine,
            CPU and GPU).
    """
    sine, cosine = sincos_degrees(heading)
    return x + speed * sine, y + speed * cosine


def heading_error(requested: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Signed shortest turn from ``current`` to ``requested`` (both in [0, 360)), degrees in
    (-180, 180]."""
    error = wrap_degrees(requested - current)
    return np.where(error > 180.0, error - 360.0, error)


def control(
    speed: np.ndarray,
    heading: np.ndarray,
    requested_speed: np.ndarray,
    requested_heading: np.ndarray,
    params: DroneParameters,
) -> tuple[np.ndarray, np.ndarray]:
    """Phase 4: bang-bang control signals toward the requested speed and heading.

    The heading turns the shorter way round the circle; a signal is 0 when the value
    already equals its reference.

    Returns:
        (u_speed, u_heading), each shape (N,), in {-step, 0, +step}.
    """
    u_speed = params.speed_step * np.sign(requested_speed - speed)
    u_heading = params.turn_step * np.sign(heading_error(requested_heading, heading))
    return u_speed, u_heading


@njit(inline="always")
def control_agent(a: int, speed: np.ndarray, heading: np.ndarray, requested_speed: np.ndarray,
                  requested_heading: np.ndarray, u_speed: np.ndarray, u_heading: np.ndarray,
                  speed_step: float, turn_step: float) -> None:  # fmt: skip
    """:func:`control` of agent row ``a``, written into ``u_speed[a]`` and ``u_heading[a]``
    (arrays shape (N,); the steps as in :class:`DroneParameters`)."""
    u_speed[a] = speed_step * np_sign(requested_speed[a] - speed[a])
    error = wrap_one(requested_heading[a] - heading[a])
    if error > 180.0:
        error = error - 360.0
    u_heading[a] = turn_step * np_sign(error)


def settle(s: dict[str, np.ndarray], new: dict[str, np.ndarray], moving: np.ndarray,
           stopped: str) -> None:  # fmt: skip
    """The ``new`` columns (shape (N,) each) into the swarm's ``s`` where ``moving`` (shape
    (N,), bool); elsewhere the column ``stopped`` (a rate: speed, climb rate) set to 0."""
    everyone = bool(moving.all())
    for key, value in new.items():
        np.copyto(s[key], value, where=True if everyone else moving)
    if not everyone:
        s[stopped][~moving] = 0.0


class Drone2D:
    """The 2-D drone as the swarm's motion model: Phase 2 motion and Phase 4 control.

    Holds the control signals of the last Phase 4, used by the next Phase 2.

    Args:
        params: model parameters.
        n_agents: number of agents N.
    """

    name = "drone2d"

    def __init__(self, params: DroneParameters, n_agents: int) -> None:
        self.params = params
        self.u_speed = np.zeros(n_agents)
        self.u_heading = np.zeros(n_agents)

    def columns(self) -> dict[str, np.ndarray]:
        """Model state recorded beside the swarm's columns (none for this model)."""
        return {}

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None:
        """Move the agents where ``moving`` (shape (N,), bool); the others stop where they are.

        Args:
            s: the swarm's state columns, updated in place.
            moving: agents that move this iteration (those with energy).
        """
        new = advance(
            s["x"], s["y"], s["speed"], s["heading"], self.u_speed, self.u_heading, self.params
        )
        settle(s, dict(zip(("x", "y", "speed", "heading"), new, strict=True)), moving, "speed")

    def control(self, s: dict[str, np.ndarray]) -> None:
        """Phase 4: control signals toward the requested speed and heading."""
        self.u_speed, self.u_heading = control(
            s["speed"], s["heading"], s["requested_speed"], s["requested_heading"], self.params
        )
