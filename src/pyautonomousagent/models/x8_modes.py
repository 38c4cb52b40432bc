"""The X8's take-off and landing: the autopilot's phases and the ground.

The behaviour tree asks for a mode in the swarm column :data:`MODE_COLUMN` (``CRUISE``,
``LAND`` or ``TAKE_OFF``; a mission that declares the column lets its leaves write it) and,
while landing, for the glide path's altitude in :data:`ALTITUDE_COLUMN` (m). The model runs a
phase machine per aircraft and reports the phase in :data:`PHASE_COLUMN` (where declared)::

    FLIGHT --LAND--> APPROACH --h <= flare_height--> FLARE --contact--> ROLLOUT
      ^                                                                   | ground speed 0
      |                                                                   v
    CLIMB_OUT <--airspeed >= rotation_speed-- GROUND_ROLL <--TAKE_OFF-- PARKED

Each phase sets the references of the autopilot (:func:`overrides`): the altitude the
altitude PID holds (the glide path in APPROACH), and fixed roll, pitch and throttle where the
phase overrides the PIDs (NaN: no override). A PARKED aircraft is held where it stopped.

The ground (:func:`ground_contact`) is a constraint applied after each integration step, on
velocity level (an impulse, as in time-stepping contact methods): an aircraft at or below the
ground is put on it, its downward velocity removed (that removed speed is the normal impulse
per unit mass), Coulomb friction takes ``friction`` times that impulse off its speed along its
heading, sideways motion is stopped (a skid or wheels), its wings are levelled and its pitch
kept within ``[0, max_ground_pitch]``. Everything is made of ``+ - * /``, ``sqrt``, minimum and
maximum: the same bits on every engine and SIMD level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pyautonomousagent.models import x8_dynamics as dyn

#: Swarm column the leaves write: the requested autopilot mode.
MODE_COLUMN = "autopilot_mode"
#: Swarm column the model writes: the autopilot's phase.
PHASE_COLUMN = "flight_phase"
#: Swarm column the landing leaf writes: the glide path's altitude (m) in APPROACH.
ALTITUDE_COLUMN = "requested_altitude"

#: Requested modes.
CRUISE, LAND, TAKE_OFF = 0, 1, 2
#: Phases.
FLIGHT, APPROACH, FLARE, ROLLOUT, PARKED, GROUND_ROLL, CLIMB_OUT = range(7)
PHASES = ("flight", "approach", "flare", "rollout", "parked", "ground roll", "climb-out")


@dataclass(frozen=True)
class ModeSettings:
    """The phases' parameters (read from the ``x8:`` settings; angles here in radians).

    Attributes:
        altitude: the cruise altitude (m); CLIMB_OUT ends ``climb_out_margin`` below it.
        flare_height: altitude at which the flare starts (m).
        flare_time: time constant of the exponential flare (s).
        touchdown_sink: sink rate the flare aims at on the ground (m/s).
        flare_pitch: pitch of the flare law at zero sink error (rad).
        flare_gain: pitch per unit sink error (rad per m/s).
        max_flare_pitch: upper limit of the flare's pitch (rad).
        rotation_speed: airspeed at which the take-off roll rotates (m/s).
        rotation_pitch: pitch held from rotation to the end of the climb-out (rad).
        climb_out_margin: m below ``altitude`` where the altitude PID takes over.
        friction_rolling, friction_braking: Coulomb friction coefficients on the take-off
            roll and on the roll-out and parked.
        max_ground_pitch: the largest pitch on the ground (rad; tail strike).
    """

    altitude: float
    flare_height: float
    flare_time: float
    touchdown_sink: float
    flare_pitch: float
    flare_gain: float
    max_flare_pitch: float
    rotation_speed: float
    rotation_pitch: float
    climb_out_margin: float
    friction_rolling: float
    friction_braking: float
    max_ground_pitch: float


@dataclass
class Overrides:
    """What the phases impose on the autopilot, each (N,): the altitude reference (m) and the
    roll, pitch (rad) and throttle references (NaN where the PIDs decide)."""

    altitude: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    throttle: np.ndarray


def transitions(
    phase: np.ndarray,
    mode: np.ndarray | None,
    altitude: np.ndarray,
    airspeed: np.ndarray,
    m: ModeSettings,
) -> None:
    """Phase 4's changes of phase (in place), in the order of the cycle; the ground's own
    (touchdown, stop) are :func:`after_contact`'s.

    Args:
        phase: phases, (N,) int64, updated.
        mode: requested modes, (N,), or None (no such column: CRUISE).
        altitude, airspeed: m and m/s, (N,).
        m: the phases' settings.
    """
    if mode is None:
        return
    phase[(phase == FLIGHT) & (mode == LAND)] = APPROACH
    phase[(phase == APPROACH) & (mode != LAND)] = FLIGHT
    phase[(phase == APPROACH) & (altitude <= m.flare_height)] = FLARE
    phase[(phase == PARKED) & (mode == TAKE_OFF)] = GROUND_ROLL
    phase[(phase == GROUND_ROLL) & (airspeed >= m.rotation_speed)] = CLIMB_OUT
    phase[(phase == CLIMB_OUT) & (altitude >= m.altitude - m.climb_out_margin)] = FLIGHT


def overrides(
    phase: np.ndarray,
    glide: np.ndarray | None,
    altitude: np.ndarray,
    climb: np.ndarray,
    m: ModeSettings,
) -> Overrides:
    """The references each phase imposes.

    - FLIGHT: hold ``m.altitude``; APPROACH: the glide path ``glide`` (m).
    - FLARE: wings level, throttle 0, pitch ``flare_pitch + flare_gain (climb_ref - climb)``
      within ``[0, max_flare_pitch]``, with ``climb_ref = -(h / flare_time + touchdown_sink)``
      (an exponential flare that reaches the ground sinking at ``touchdown_sink``).
    - ROLLOUT, PARKED: wings level, pitch 0, throttle 0.
    - GROUND_ROLL: wings level, pitch 0, full throttle; CLIMB_OUT: wings level, pitch
      ``rotation_pitch``, full throttle.

    Args:
        phase: (N,) int64; glide: the requested altitude (m), (N,), or None;
        altitude, climb: m and m/s (up), (N,); m: the settings.
    """
    target = np.full(phase.shape, m.altitude)
    if glide is not None:
        target = np.where(phase == APPROACH, glide, target)
    level = phase >= FLARE
    roll = np.where(level, 0.0, np.nan)
    climb_ref = -(altitude / m.flare_time + m.touchdown_sink)
    flare = m.flare_pitch + m.flare_gain * (climb_ref - climb)
    flare = np.minimum(np.maximum(flare, 0.0), m.max_flare_pitch)
    pitch = np.where(phase == FLARE, flare, np.where(level, 0.0, np.nan))
    pitch = np.where(phase == CLIMB_OUT, m.rotation_pitch, pitch)
    powered = (phase == GROUND_ROLL) | (phase == CLIMB_OUT)
    throttle = np.where(powered, 1.0, np.where(level, 0.0, np.nan))
    return Overrides(target, roll, pitch, throttle)


def friction(phase: np.ndarray, m: ModeSettings) -> np.ndarray:
    """The friction coefficient of each aircraft's ground contact, (N,): rolling on the
    take-off roll and climb-out, braking otherwise."""
    rolling = (phase == GROUND_ROLL) | (phase == CLIMB_OUT)
    return np.where(rolling, m.friction_rolling, m.friction_braking)


@dataclass
class Contact:
    """What :func:`ground_contact` found, each (K,): the downward speed the ground took
    (m/s, the sink rate at a touchdown), the speed before (m/s; in still air the airspeed),
    and whether the aircraft came to rest."""

    sink: np.ndarray
    speed: np.ndarray
    stopped: np.ndarray


def ground_contact(b: np.ndarray, mu: np.ndarray, max_pitch: float) -> Contact:
    """Put K aircraft that are at or below the ground on it (in place).

    Args:
        b: their states, (>= 13, K) with the rows of :mod:`x8_dynamics`; position, attitude,
            rates and velocity are changed.
        mu: Coulomb friction coefficient, (K,).
        max_pitch: the largest pitch on the ground (rad).

    Returns:
        The :class:`Contact`.
    """
    rot = dyn.rotation(b[dyn.QUATERNION])
    u, v, w = b[dyn.U], b[dyn.V], b[dyn.W]
    north, east, down = dyn.body_to_ned(b[dyn.QUATERNION], u, v, w)
    # attitude: the body x axis's heading kept, wings levelled, pitch within [0, max_pitch]
    span = np.sqrt(rot[0, 0] * rot[0, 0] + rot[1, 0] * rot[1, 0])  # cos(pitch) > 0
    cos_yaw, sin_yaw = rot[0, 0] / span, rot[1, 0] / span
    sin_pitch = -rot[2, 0]
    s = np.minimum(np.maximum(sin_pitch, 0.0), math.sin(max_pitch))
    c = np.sqrt((1.0 - s) * (1.0 + s))
    half_c, half_s = np.sqrt((1.0 + c) * 0.5), np.sqrt((1.0 - c) * 0.5)
    yaw_c = np.sqrt(np.maximum(1.0 + cos_yaw, 0.0) * 0.5)
    yaw_s = np.sqrt(np.maximum(1.0 - cos_yaw, 0.0) * 0.5)
    yaw_s = np.where(sin_yaw < 0.0, -yaw_s, yaw_s)
    e = np.array([yaw_c * half_c, -(yaw_s * half_s), yaw_c * half_s, yaw_s * half_c])
    # velocity: no sinking, no sliding sideways, Coulomb friction along the heading
    sink = np.maximum(down, 0.0)
    along = north * cos_yaw + east * sin_yaw
    slowed = np.maximum(np.abs(along) - mu * sink, 0.0)
    along = np.where(along < 0.0, -slowed, slowed)
    down = np.minimum(down, 0.0)
    north, east = along * cos_yaw, along * sin_yaw
    speed = np.sqrt(b[dyn.U] * b[dyn.U] + b[dyn.V] * b[dyn.V] + b[dyn.W] * b[dyn.W])
    stopped = (along == 0.0) & (down == 0.0)
    new = dyn.rotation(e)
    b[dyn.QUATERNION] = e
    b[dyn.U] = new[0, 0] * north + new[1, 0] * east + new[2, 0] * down
    b[dyn.V] = new[0, 1] * north + new[1, 1] * east + new[2, 1] * down
    b[dyn.W] = new[0, 2] * north + new[1, 2] * east + new[2, 2] * down
    b[dyn.P] = 0.0
    b[dyn.R] = 0.0
    b[dyn.Q] = np.where((s != sin_pitch) | stopped, 0.0, b[dyn.Q])
    b[dyn.PD] = 0.0
    return Contact(sink=sink, speed=speed, stopped=stopped)


def after_contact(phase: np.ndarray, rows: np.ndarray, contact: Contact) -> np.ndarray:
    """The phases of the aircraft ``rows`` that touched the ground this step (in place):
    airborne ones (FLIGHT, APPROACH, FLARE) go to ROLLOUT, a ROLLOUT at rest to PARKED.

    Returns:
        Which of ``rows`` touched down from the air, (K,) bool.
    """
    was = phase[rows]
    landed = (was == FLIGHT) | (was == APPROACH) | (was == FLARE)
    now = np.where(landed, ROLLOUT, was)
    now = np.where((now == ROLLOUT) & contact.stopped, PARKED, now)
    phase[rows] = now
    return landed
