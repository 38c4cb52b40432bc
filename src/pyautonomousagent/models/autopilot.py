"""The X8's autopilot, per agent: guidance PIDs (course, altitude) and the attitude PID.

Two layers, as in the paper's second set of tests:

- :class:`Guidance` turns the behaviour tree's requests into attitude references: a course
  (track-angle) PID gives the roll reference and an altitude PID the pitch reference; the
  airspeed reference is the requested speed, floored at a minimum flying speed.
- The attitude and airspeed PID of PyFly turns those references into elevator, aileron and
  throttle commands. The reference model uses PyFly's own ``PIDController`` (one per agent);
  :class:`AttitudeController` is the same control law over arrays, for the vectorised model,
  with the gains read from PyFly's controller (:func:`attitude_gains`).

Every controller keeps its integrators and previous errors in arrays of shape ``(N,)``: row i
belongs to agent i alone (the notebook shared them between UAVs through module globals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped into [-pi, pi)."""
    return np.mod(angle + math.pi, 2 * math.pi) - math.pi


class PID:
    """A discrete PID controller for N agents, each with its own integrator and last error.

    ``output = kp e + ki sum(e dt) + kd (e - e_previous) / dt``, clipped to ``[-limit, limit]``.
    The derivative is 0 on an agent's first update (no derivative kick at start).

    Args:
        kp, ki, kd: gains (output units per error unit, per error unit second, per error unit
            per second).
        limit: output magnitude limit.
        dt: time between updates (s).
        n: number of agents N.
    """

    def __init__(self, kp: float, ki: float, kd: float, limit: float, dt: float, n: int) -> None:
        self.kp, self.ki, self.kd, self.limit, self.dt = kp, ki, kd, limit, dt
        self.integral = np.zeros(n)
        self.previous = np.full(n, np.nan)

    def update(self, error: np.ndarray) -> np.ndarray:
        """The outputs for this step's errors, shape (N,); updates the controller state."""
        self.integral += error * self.dt
        slope = np.where(np.isnan(self.previous), 0.0, (error - self.previous) / self.dt)
        self.previous = np.array(error, dtype=float)
        out = self.kp * error + self.ki * self.integral + self.kd * slope
        return np.minimum(np.maximum(out, -self.limit), self.limit)


@dataclass(frozen=True)
class GuidanceGains:
    """Gains and limits of the guidance PIDs (reference-facts, "Scenario x8-patrol").

    Course: error in radians (wrapped), output roll reference in radians. Altitude: error in
    metres, output pitch reference in radians; kp is 0.1, not the notebook's 1.0, with which
    the loop limit-cycles (docs/x8.md). Limits in degrees.
    """

    course_kp: float = 1.0
    course_ki: float = 1e-5
    course_kd: float = 0.01
    max_roll: float = 45.0
    altitude_kp: float = 0.1
    altitude_ki: float = 1e-4
    altitude_kd: float = 0.01
    max_pitch: float = 30.0


class Guidance:
    """Course and altitude PIDs: requested heading and speed -> roll, pitch, airspeed references.

    Args:
        gains: PID gains and limits.
        altitude: altitude to hold (m).
        min_airspeed: the lowest airspeed reference (m/s); a request below it (the refuelling
            leaf asks for 0) is raised to it, since a fixed-wing aircraft cannot hover.
        dt: time between updates (s).
        n: number of agents N.
    """

    def __init__(
        self, gains: GuidanceGains, altitude: float, min_airspeed: float, dt: float, n: int
    ) -> None:
        self.altitude = altitude
        self.min_airspeed = min_airspeed

        def pid(name: str, limit: float) -> PID:
            kp, ki, kd = (getattr(gains, f"{name}_{k}") for k in ("kp", "ki", "kd"))
            return PID(kp, ki, kd, math.radians(limit), dt, n)

        self.course, self.height = pid("course", gains.max_roll), pid("altitude", gains.max_pitch)

    def references(
        self,
        course: np.ndarray,
        altitude: np.ndarray,
        requested_heading: np.ndarray,
        requested_speed: np.ndarray,
        target: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Roll and pitch references (rad) and the airspeed reference (m/s), each (N,).

        Args:
            course: course over ground (rad, clockwise from north), shape (N,).
            altitude: altitude above the origin (m), shape (N,).
            requested_heading: the tree's requested heading (degrees clockwise from north).
            requested_speed: the tree's requested speed (m/s).
            target: the altitude to hold (m), (N,); by default ``self.altitude``.
        """
        course_error = wrap_angle(requested_heading * (math.pi / 180.0) - course)
        roll = self.course.update(course_error)
        pitch = self.height.update((self.altitude if target is None else target) - altitude)
        return roll, pitch, np.maximum(requested_speed, self.min_airspeed)


@dataclass(frozen=True)
class AttitudeGains:
    """PyFly's attitude and airspeed PID gains and output limits (rad, throttle in [0, 1]).

    ``kp_airspeed``/``ki_airspeed`` act on the airspeed error (m/s); roll and pitch gains on the
    angle errors (rad) and, for ``kd_*``, on the body rates p and q (rad/s).
    """

    kp_airspeed: float
    ki_airspeed: float
    kp_roll: float
    ki_roll: float
    kd_roll: float
    kp_pitch: float
    ki_pitch: float
    kd_pitch: float
    aileron_min: float
    aileron_max: float
    elevator_min: float
    elevator_max: float


def attitude_gains(dt: float) -> AttitudeGains:
    """The gains of the installed PyFly's ``PIDController``, read from an instance of it."""
    from pyfly.pid_controller import PIDController

    c = PIDController(dt)
    names = ["k_p_V", "k_i_V", "k_p_phi", "k_i_phi", "k_d_phi", "k_p_theta", "k_i_theta"]
    names += ["k_d_theta", "delta_a_min", "delta_a_max", "delta_e_min", "delta_e_max"]
    return AttitudeGains(*(float(getattr(c, name)) for name in names))  # in the fields' order


class AttitudeController:
    """PyFly's attitude and airspeed control law for N agents at once.

    Airspeed: PI to throttle in [0, 1]. Roll: PID to aileron (derivative on the roll rate p).
    Pitch: PID to elevator (derivative on the pitch rate q; positive elevator pitches down,
    hence PyFly's negative pitch gains). Errors are measured minus reference; the integrators
    are not limited.

    Args:
        gains: the control law's gains and limits.
        dt: time between updates (s).
        n: number of agents N.
    """

    def __init__(self, gains: AttitudeGains, dt: float, n: int) -> None:
        self.gains = gains
        self.dt = dt
        self.integral = np.zeros((3, n))  # airspeed, roll, pitch

    def commands(
        self,
        refs: tuple[np.ndarray, np.ndarray, np.ndarray],
        roll: np.ndarray,
        pitch: np.ndarray,
        airspeed: np.ndarray,
        p: np.ndarray,
        q: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Elevator, aileron (rad) and throttle for references ``(roll, pitch, airspeed)``.

        All inputs and outputs have shape (N,); angles in rad, rates in rad/s, airspeed m/s.
        """
        g = self.gains
        roll_ref, pitch_ref, airspeed_ref = refs
        errors = np.array([airspeed - airspeed_ref, roll - roll_ref, pitch - pitch_ref])
        self.integral += self.dt * errors
        i_v, i_roll, i_pitch = self.integral
        throttle = -g.kp_airspeed * errors[0] - g.ki_airspeed * i_v
        aileron = -g.kp_roll * errors[1] - g.ki_roll * i_roll - g.kd_roll * p
        elevator = -g.kp_pitch * errors[2] - g.ki_pitch * i_pitch - g.kd_pitch * q
        return (
            np.minimum(np.maximum(elevator, g.elevator_min), g.elevator_max),
            np.minimum(np.maximum(aileron, g.aileron_min), g.aileron_max),
            np.minimum(np.maximum(throttle, 0.0), 1.0),
        )
