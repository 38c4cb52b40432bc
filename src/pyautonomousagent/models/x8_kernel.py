"""The vectorised X8's step and autopilot compiled agent by agent (numba, the ``[fast]`` extra).

The NumPy code in :mod:`~pyautonomousagent.models.x8_dynamics`,
:mod:`pyautonomousagent.models.x8`, :mod:`.x8_modes` and :mod:`.autopilot` is the reference;
the functions here repeat its operations on one agent's numbers at a time, in the same order,
so that they give the same bits (no ``fastmath``, no library arctangent or exponential:
:func:`atan2` and :func:`exp` follow :func:`pyautonomousagent.arrays.arctan2` and
:func:`.x8_dynamics.exp` step by step). Without numba (or with ``PYAA_NO_JIT=1``) they run as
plain Python, with the same bits: the model uses them so for a few agents, where that beats
NumPy's cost per call, and the NumPy code above
(:attr:`pyautonomousagent.models.x8.X8Vectorised.agent_by_agent`).

Two calls per iteration, whatever the number of agents: :func:`advance` (Phase 2: one step
of every moving agent that is not parked, the ground and the phase changes it makes, what the
loop reads of the new state, the swarm's columns) and :func:`control` (Phase 4: the phases'
changes and the references they impose, guidance, attitude and airspeed PIDs, elevon mixing,
the overridden PIDs' integrators cleared). Where NumPy's ``minimum`` and ``maximum`` meet
equal numbers they return the second (with SIMD, on x86), which decides the sign of a zero:
the ground's functions use :func:`pyautonomousagent.kernels.np_minimum` and ``np_maximum``,
which do the same. Their scalar constants travel in float arrays laid out by
:func:`pack_constants`, :func:`pack_gains` and :func:`pack_modes`.
"""

from __future__ import annotations

import math

import numpy as np

from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import arctan2 as atan2  # arrays.arctan2, one pair
from pyautonomousagent.kernels import np_maximum, np_minimum
from pyautonomousagent.models import x8_dynamics as dyn
from pyautonomousagent.models import x8_modes as modes
from pyautonomousagent.models.autopilot import AttitudeController, Guidance
from pyautonomousagent.models.x8_modes import (
    APPROACH,
    CLIMB_OUT,
    FLARE,
    FLIGHT,
    GROUND_ROLL,
    LAND,
    PARKED,
    ROLLOUT,
    TAKE_OFF,
)

#: Rows of the flight array that :func:`advance` fills (the fields of ``x8.Flight``).
FLIGHT_ROWS = 10
_HS = dyn._HALF_SIGN[:, :, 0].copy()  # (3, 4): +-0.5
_PERM = dyn._PERM
_EXP = dyn.EXP_SERIES
_LOG2E, _LN2_HI, _LN2_LO, _EXP_LIMIT = dyn.LOG2E, dyn.LN2_HI, dyn.LN2_LO, dyn.EXP_LIMIT

# Indices into the constants vector of :func:`pack_constants`.
(H, VMIN, M_STALL, K_STALL, CL0, CLA, QBAR, KMOTOR, THRUST, WEIGHT, MASS, KTP, KOMEGA) = range(13)
(EMIN, EMAX, RMAX, TMIN, TMAX, LIMIT, DECAY, F11, F12, F21, F22) = range(13, 24)


def pack_constants(k: dyn.Constants) -> np.ndarray:
    """The scalars :func:`advance` needs, computed as the NumPy code computes them, (24,)."""
    p, a, act = k.params, k.params.airframe, k.params.actuators
    (f11, f12), (f21, f22) = k.actuator_step
    return np.array(
        [k.dt, p.airspeed_min, p.aero.M, math.exp(p.aero.M * p.aero.a_0), p.aero.C_L_0]
        + [p.aero.C_L_alpha, 0.5 * p.rho * a.S_wing, a.k_motor]
        + [0.5 * p.rho * a.S_prop * a.C_prop, a.mass * p.g, a.mass, a.k_T_P, a.k_Omega]
        + [act.elevon_min, act.elevon_max, act.elevon_rate_max, act.throttle_min]
        + [act.throttle_max, act.elevon_rate_max * 0.5 * k.dt, k.throttle_decay]
        + [f11, f12, f21, f22],
        dtype=np.float64,
    )


@njit
def _max(a: float, b: float) -> float:
    """``numpy.maximum`` of two finite numbers (the first where equal)."""
    return a if a >= b else b


@njit
def _clip(x: float, low: float, high: float) -> float:
    """``minimum(maximum(x, low), high)`` of finite numbers (the first where equal)."""
    x = _max(x, low)
    return x if x <= high else high


@njit
def exp(x: float) -> float:
    """``x8_dynamics.exp`` for one number."""
    x = _clip(x, -_EXP_LIMIT, _EXP_LIMIT)
    k = math.floor(x * _LOG2E + 0.5)
    r = (x - k * _LN2_HI) - k * _LN2_LO
    total = r * _EXP[13]
    for j in range(12, 0, -1):
        total += _EXP[j]
        total *= r
    total += _EXP[0]
    return math.ldexp(total, int(k))


#: Workspace of one agent's step (:func:`advance` allocates it once per call): offsets of the
#: rotation (9), features (16), products (7), forces and moments (6), derivative stages
#: k1..k3 (13 each), a stage's airframe (13), actuator rows at the middle and end (5 each).
ROT, FEAT, PROD, FM, K1, K2, K3, STAGE, MIDDLE, END, WORK = (
    0, 9, 25, 32, 38, 51, 64, 77, 90, 95, 100
)  # fmt: skip


@njit
def _rotation(e: np.ndarray, w: np.ndarray) -> None:
    """``x8_dynamics.rotation`` of the quaternion ``e[0:4]`` into ``w[ROT:ROT + 9]`` (row major)."""
    e0, e1, e2, e3 = e[0], e[1], e[2], e[3]
    d = e0 * e0 - (e1 * e1 + e2 * e2 + e3 * e3)
    s1, s2, s3 = 2 * e0 * e1, 2 * e0 * e2, 2 * e0 * e3
    w[ROT + 0], w[ROT + 1], w[ROT + 2] = 2 * (e1 * e1) + d, 2 * (e1 * e2) - s3, 2 * (e1 * e3) + s2
    w[ROT + 3], w[ROT + 4], w[ROT + 5] = 2 * (e2 * e1) + s3, 2 * (e2 * e2) + d, 2 * (e2 * e3) - s1
    w[ROT + 6], w[ROT + 7], w[ROT + 8] = 2 * (e3 * e1) - s2, 2 * (e3 * e2) + s1, 2 * (e3 * e3) + d


@njit
def _features(
    b: np.ndarray, elevator: float, aileron: float, c: np.ndarray, w: np.ndarray
) -> tuple[float, float, float, float, float, float]:
    """Air data, and the (16,) aerodynamic features into ``w[FEAT:]`` (``dyn.FEATURES``).

    Returns (airspeed, airspeed^2, sin(alpha), cos(alpha), sin(beta), cos(beta)).
    """
    u, v, ww = b[10], b[11], b[12]
    uw2 = u * u + ww * ww
    airspeed2 = uw2 + v * v
    airspeed = _max(math.sqrt(airspeed2), c[VMIN])
    inv_2v = 0.5 / airspeed
    uw = _max(math.sqrt(uw2), c[VMIN])
    alpha = atan2(ww, u)
    sa, ca = ww / uw, u / uw
    sb = v / airspeed
    cb = math.sqrt(1 - sb * sb)
    beta = atan2(sb, cb)
    kk = c[K_STALL]
    z = exp(c[M_STALL] * alpha)
    t = kk * (z + 1 / z)
    sigma = (1 + t) / ((1 + kk * kk) + t)
    linear = 1 - sigma
    lift_linear = c[CL0] + c[CLA] * alpha
    lin_lift = linear * lift_linear
    flat = sigma * sa * abs(sa)
    w[FEAT + 0], w[FEAT + 1], w[FEAT + 2] = 1.0, lin_lift, lin_lift * lift_linear
    w[FEAT + 3], w[FEAT + 4], w[FEAT + 5] = linear * alpha, linear, flat
    w[FEAT + 6], w[FEAT + 7], w[FEAT + 8] = flat * ca, flat * sa, inv_2v * b[5]
    w[FEAT + 9], w[FEAT + 10], w[FEAT + 11] = elevator, elevator * elevator, beta
    w[FEAT + 12], w[FEAT + 13], w[FEAT + 14] = beta * beta, inv_2v * b[4], inv_2v * b[6]
    w[FEAT + 15] = aileron
    return airspeed, airspeed2, sa, ca, sb, cb


@njit
def _product(m: np.ndarray, w: np.ndarray, at: int, out: int) -> None:
    """``x8_dynamics._product``: ``m @ x`` with ``x = w[at:]`` into ``w[out:]``, each row
    summed ``((m[i,0] x[0] + m[i,1] x[1]) + ...)``."""
    rows, columns = m.shape
    for i in range(rows):
        total = m[i, 0] * w[at]
        for j in range(1, columns):
            total = total + m[i, j] * w[at + j]
        w[out + i] = total


@njit
def _aero(m: np.ndarray, w: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """:func:`_product` of the (6, 16) aerodynamic matrix and the features ``w[FEAT:]``, the six
    rows kept in registers side by side (their additions overlap in the processor)."""
    x = w[FEAT]
    c0, c1, c2, c3, c4, c5 = (
        m[0, 0] * x,
        m[1, 0] * x,
        m[2, 0] * x,
        m[3, 0] * x,
        m[4, 0] * x,
        m[5, 0] * x,
    )
    for j in range(1, 16):
        x = w[FEAT + j]
        c0, c1, c2 = c0 + m[0, j] * x, c1 + m[1, j] * x, c2 + m[2, j] * x
        c3, c4, c5 = c3 + m[3, j] * x, c4 + m[4, j] * x, c5 + m[5, j] * x
    return c0, c1, c2, c3, c4, c5


@njit
def _forces_moments(
    b: np.ndarray, surf: tuple[float, float, float], c: np.ndarray, aero: np.ndarray, w: np.ndarray
) -> None:
    """``x8_dynamics._forces_moments`` for one agent: forces (N), moments (N m) into
    ``w[FM:FM + 6]``; ``surf`` = (elevator, aileron, throttle); needs the rotation in ``w``."""
    elevator, aileron, throttle = surf
    airspeed, airspeed2, sa, ca, sb, cb = _features(b, elevator, aileron, c, w)
    qbar_s = c[QBAR] * airspeed2
    c_lift, c_drag, c_pitch, c_side, c_roll, c_yaw = _aero(aero, w)
    lift, drag, side = c_lift * qbar_s, c_drag * qbar_s, c_side * qbar_s
    induced = airspeed + throttle * (c[KMOTOR] - airspeed)
    thrust = c[THRUST] * induced * (induced - airspeed)
    along = drag * cb - side * sb
    w[FM + 0] = c[WEIGHT] * w[ROT + 6] + (thrust - ca * along + lift * sa)
    w[FM + 1] = c[WEIGHT] * w[ROT + 7] + (drag * sb + side * cb)
    w[FM + 2] = c[WEIGHT] * w[ROT + 8] - (sa * along + lift * ca)
    spin = c[KOMEGA] * throttle
    w[FM + 3] = c_roll * qbar_s - c[KTP] * (spin * spin)
    w[FM + 4] = c_pitch * qbar_s
    w[FM + 5] = c_yaw * qbar_s


@njit
def _derivatives(
    b: np.ndarray,
    surf: tuple[float, float, float],
    c: np.ndarray,
    aero: np.ndarray,
    inertia: np.ndarray,
    w: np.ndarray,
    at: int,
) -> None:
    """``x8_dynamics.body_derivatives`` of one agent's airframe ``b`` (13,) into
    ``w[at:at + 13]``."""
    _rotation(b, w)
    _forces_moments(b, surf, c, aero, w)
    p, q, r, u, v, ww = b[4], b[5], b[6], b[10], b[11], b[12]
    for i in range(4):
        d = (_HS[0, i] * b[_PERM[0, i]]) * p + (_HS[1, i] * b[_PERM[1, i]]) * q
        w[at + i] = d + (_HS[2, i] * b[_PERM[2, i]]) * r
    w[PROD + 0], w[PROD + 1], w[PROD + 2], w[PROD + 3] = p * q, q * r, p * r, p * p - r * r
    w[PROD + 4], w[PROD + 5], w[PROD + 6] = w[FM + 3], w[FM + 4], w[FM + 5]
    _product(inertia, w, PROD, at + 4)
    for i in range(3):
        row = ROT + 3 * i
        w[at + 7 + i] = w[row] * u + w[row + 1] * v + w[row + 2] * ww
    w[at + 10] = v * r - ww * q + w[FM + 0] / c[MASS]
    w[at + 11] = ww * p - u * r + w[FM + 1] / c[MASS]
    w[at + 12] = u * q - v * p + w[FM + 2] / c[MASS]


@njit
def _half_step(a: np.ndarray, cmd: np.ndarray, i: int, c: np.ndarray, out: np.ndarray) -> None:
    """``x8_dynamics._actuator_half_step`` of actuator rows ``a`` (5,) under agent i's commands
    ``cmd[:, i]`` into ``out`` (5,)."""
    for j in range(2):
        offset = a[j] - cmd[j, i]
        moved = c[F11] * offset + c[F12] * a[2 + j] - offset
        out[j] = a[j] + _clip(moved, -c[LIMIT], c[LIMIT])
        out[2 + j] = _clip(c[F21] * offset + c[F22] * a[2 + j], -c[RMAX], c[RMAX])
    out[4] = cmd[2, i] + (a[4] - cmd[2, i]) * c[DECAY]


@njit
def _surfaces(a: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
    """``x8_dynamics._surfaces``: (elevator, aileron, throttle) of actuator rows ``a`` (5,)."""
    right = _clip(a[0], c[EMIN], c[EMAX])
    left = _clip(a[1], c[EMIN], c[EMAX])
    throttle = _clip(a[4], c[TMIN], c[TMAX])
    return 0.5 * (right + left), 0.5 * (left - right), throttle


@njit
def _step_one(
    y: np.ndarray,
    cmd: np.ndarray,
    i: int,
    c: np.ndarray,
    m: tuple[np.ndarray, np.ndarray],
    w: np.ndarray,
    new: np.ndarray,
) -> None:
    """``x8_dynamics.step`` (settling included) of agent i's state ``y`` (18,) into ``new``:
    the actuators' half steps (``w[MIDDLE:]``, ``w[END:]``), the three Runge-Kutta stages
    k1..k3, their sum."""
    aero, inertia = m
    h, act, b, stage = c[H], y[13:18], y[0:13], w[STAGE : STAGE + 13]
    _half_step(act, cmd, i, c, w[MIDDLE : MIDDLE + 5])
    _half_step(w[MIDDLE : MIDDLE + 5], cmd, i, c, w[END : END + 5])
    _derivatives(b, _surfaces(act, c), c, aero, inertia, w, K1)
    for j in range(13):
        stage[j] = b[j] + (h / 2) * w[K1 + j]
    _derivatives(stage, _surfaces(w[MIDDLE : MIDDLE + 5], c), c, aero, inertia, w, K2)
    for j in range(13):
        stage[j] = b[j] + h * (2 * w[K2 + j] - w[K1 + j])
    _derivatives(stage, _surfaces(w[END : END + 5], c), c, aero, inertia, w, K3)
    for j in range(13):
        new[j] = y[j] + (h / 6) * (w[K1 + j] + 4 * w[K2 + j] + w[K3 + j])
    norm = math.sqrt(new[0] * new[0] + new[1] * new[1] + new[2] * new[2] + new[3] * new[3])
    for j in range(4):
        new[j] /= norm
    for j in range(2):
        new[13 + j] = _clip(w[END + j], c[EMIN], c[EMAX])
        new[15 + j] = _clip(w[END + 2 + j], -c[RMAX], c[RMAX])
    new[17] = _clip(w[END + 4], c[TMIN], c[TMAX])


@njit
def _observe_one(y: np.ndarray, flight: np.ndarray, i: int, w: np.ndarray) -> None:
    """``x8.observe`` of one agent's state ``y`` (18,) into column i of ``flight`` (9, N)."""
    e0, e1, e2, e3, u, v, ww = y[0], y[1], y[2], y[3], y[10], y[11], y[12]
    _rotation(y, w)
    north = w[ROT + 0] * u + w[ROT + 1] * v + w[ROT + 2] * ww
    east = w[ROT + 3] * u + w[ROT + 4] * v + w[ROT + 5] * ww
    s = _clip(2 * (e0 * e2 - e1 * e3), -1.0, 1.0)
    flight[0, i], flight[1, i], flight[2, i] = y[7], y[8], 0.0 - y[9]
    flight[3, i] = math.sqrt(u * u + v * v + ww * ww)
    flight[4, i] = atan2(east, north)
    flight[5, i] = atan2(2 * (e0 * e1 + e2 * e3), e0 * e0 + e3 * e3 - e1 * e1 - e2 * e2)
    flight[6, i] = atan2(s, math.sqrt((1.0 - s) * (1.0 + s)))
    flight[7, i], flight[8, i] = y[4], y[5]
    flight[9, i] = -(w[ROT + 6] * u + w[ROT + 7] * v + w[ROT + 8] * ww)


# Indices into the gains vector of :func:`pack_gains`.
(C_KP, C_KI, C_KD, C_LIM, C_DT, A_KP, A_KI, A_KD, A_LIM, A_DT, ALT_REF, V_MIN) = range(12)
(KP_V, KI_V, KP_ROLL, KI_ROLL, KD_ROLL, KP_PITCH, KI_PITCH, KD_PITCH) = range(12, 20)
(AIL_MIN, AIL_MAX, ELEV_MIN, ELEV_MAX, ATT_DT, ELEVON_MIN, ELEVON_MAX) = range(20, 27)


def pack_gains(guidance: Guidance, attitude: AttitudeController, k: dyn.Constants) -> np.ndarray:
    """The scalars :func:`control` needs, read from the NumPy controllers, shape (27,)."""
    g, act = attitude.gains, k.params.actuators
    values = []
    for pid in (guidance.course, guidance.height):
        values += [pid.kp, pid.ki, pid.kd, pid.limit, pid.dt]
    values += [guidance.altitude, guidance.min_airspeed, g.kp_airspeed, g.ki_airspeed]
    values += [g.kp_roll, g.ki_roll, g.kd_roll, g.kp_pitch, g.ki_pitch, g.kd_pitch]
    values += [g.aileron_min, g.aileron_max, g.elevator_min, g.elevator_max, attitude.dt]
    values += [act.elevon_min, act.elevon_max]
    return np.array(values, dtype=np.float64)


@njit
def _mod(a: float, b: float) -> float:
    """``numpy.mod`` of two finite numbers, b != 0: Python's ``%`` (``fmod``, then moved to
    the sign of b; numba follows CPython), the rule NumPy's float remainder follows too."""
    return a % b


@njit
def _pid(error: float, state: np.ndarray, row: int, i: int, g: np.ndarray, at: int) -> float:
    """``autopilot.PID.update`` for agent i: integral in ``state[row]``, previous error in
    ``state[row + 1]``; gains ``g[at:at + 5]`` = kp, ki, kd, limit, dt."""
    kp, ki, kd, limit, dt = g[at], g[at + 1], g[at + 2], g[at + 3], g[at + 4]
    state[row, i] += error * dt
    previous = state[row + 1, i]
    slope = 0.0 if math.isnan(previous) else (error - previous) / dt
    state[row + 1, i] = error
    out = kp * error + ki * state[row, i] + kd * slope
    return _clip(out, -limit, limit)


@njit
def _steer(
    i: int,
    flight: np.ndarray,
    requested: tuple[float, float],
    refs: tuple[float, float, float, float],
    pids: np.ndarray,
    g: np.ndarray,
    commands: np.ndarray,
) -> None:
    """``X8Model.control`` for agent i (guidance, attitude and airspeed PIDs, elevon mixing)
    into ``commands[:, i]``; ``requested``: heading (degrees) and speed (m/s); ``refs``: the
    phase's altitude reference (m), roll and pitch (rad) and throttle, NaN where the PIDs
    decide (:func:`_overrides`)."""
    target, roll_o, pitch_o, throttle_o = refs
    error = _mod(requested[0] * (math.pi / 180.0) - flight[4, i] + math.pi, 2 * math.pi)
    roll_ref = _pid(error - math.pi, pids, 0, i, g, C_KP)
    pitch_ref = _pid(target - flight[2, i], pids, 2, i, g, A_KP)
    if not math.isnan(roll_o):
        roll_ref = roll_o
    if not math.isnan(pitch_o):
        pitch_ref = pitch_o
    errors = (
        flight[3, i] - _max(requested[1], g[V_MIN]),
        flight[5, i] - roll_ref,
        flight[6, i] - pitch_ref,
    )
    for j in range(3):
        pids[4 + j, i] += g[ATT_DT] * errors[j]
    throttle = -g[KP_V] * errors[0] - g[KI_V] * pids[4, i]
    aileron = -g[KP_ROLL] * errors[1] - g[KI_ROLL] * pids[5, i] - g[KD_ROLL] * flight[7, i]
    elevator = -g[KP_PITCH] * errors[2] - g[KI_PITCH] * pids[6, i] - g[KD_PITCH] * flight[8, i]
    elevator = _clip(elevator, g[ELEV_MIN], g[ELEV_MAX])
    aileron = _clip(aileron, g[AIL_MIN], g[AIL_MAX])
    commands[0, i] = _clip(elevator - aileron, g[ELEVON_MIN], g[ELEVON_MAX])
    commands[1, i] = _clip(elevator + aileron, g[ELEVON_MIN], g[ELEVON_MAX])
    commands[2, i] = _clip(throttle, 0.0, 1.0)
    if not math.isnan(throttle_o):
        commands[2, i] = throttle_o


# --- take-off and landing (x8_modes), agent by agent -------------------------------------

# Indices into the vector of :func:`pack_modes`.
(MD_ALTITUDE, MD_FLARE_HEIGHT, MD_FLARE_TIME, MD_SINK, MD_FLARE_PITCH, MD_FLARE_GAIN) = range(6)
(MD_MAX_FLARE, MD_ROTATION_SPEED, MD_ROTATION_PITCH, MD_MARGIN, MD_ROLLING) = range(6, 11)
(MD_BRAKING, MD_SIN_GROUND_PITCH) = range(11, 13)


def pack_modes(m: modes.ModeSettings) -> np.ndarray:
    """The phases' settings (:class:`x8_modes.ModeSettings`; m, s, m/s, rad) as the kernel
    reads them, (13,): the last is ``sin(max_ground_pitch)``, computed as
    :func:`x8_modes.ground_contact` computes it."""
    return np.array(
        [m.altitude, m.flare_height, m.flare_time, m.touchdown_sink, m.flare_pitch]
        + [m.flare_gain, m.max_flare_pitch, m.rotation_speed, m.rotation_pitch]
        + [m.climb_out_margin, m.friction_rolling, m.friction_braking]
        + [math.sin(m.max_ground_pitch)],
        dtype=np.float64,
    )


@njit
def _transition(phase: int, mode: float, altitude: float, airspeed: float, m: np.ndarray) -> int:
    """``x8_modes.transitions`` of one aircraft: its phase after Phase 4's changes, in the
    order of the cycle; ``mode`` requested, altitude (m), airspeed (m/s)."""
    if phase == FLIGHT and mode == LAND:
        phase = APPROACH
    if phase == APPROACH and mode != LAND:
        phase = FLIGHT
    if phase == APPROACH and altitude <= m[MD_FLARE_HEIGHT]:
        phase = FLARE
    if phase == PARKED and mode == TAKE_OFF:
        phase = GROUND_ROLL
    if phase == GROUND_ROLL and airspeed >= m[MD_ROTATION_SPEED]:
        phase = CLIMB_OUT
    if phase == CLIMB_OUT and altitude >= m[MD_ALTITUDE] - m[MD_MARGIN]:
        phase = FLIGHT
    return phase


@njit
def _overrides(
    phase: int, glide: float, altitude: float, climb: float, m: np.ndarray
) -> tuple[float, float, float, float]:
    """``x8_modes.overrides`` of one aircraft: the altitude reference (m; ``glide`` in
    APPROACH), roll, pitch (rad) and throttle references, NaN where the PIDs decide;
    altitude (m) and climb (m/s, up) as flown."""
    target = glide if phase == APPROACH else m[MD_ALTITUDE]
    level = phase >= FLARE
    roll = 0.0 if level else math.nan
    pitch = 0.0 if level else math.nan
    if phase == FLARE:
        climb_ref = -(altitude / m[MD_FLARE_TIME] + m[MD_SINK])
        flare = m[MD_FLARE_PITCH] + m[MD_FLARE_GAIN] * (climb_ref - climb)
        pitch = np_minimum(np_maximum(flare, 0.0), m[MD_MAX_FLARE])
    if phase == CLIMB_OUT:
        pitch = m[MD_ROTATION_PITCH]
    throttle = 0.0 if level else math.nan
    if phase in (GROUND_ROLL, CLIMB_OUT):
        throttle = 1.0
    return target, roll, pitch, throttle


@njit
def _settle(i: int, phase: int, refs: tuple[float, float, float, float], pids: np.ndarray) -> None:
    """``X8Model.settle`` for agent i: the integrators (and previous errors) of the PIDs whose
    output the phase overrides cleared (``pids`` as in :func:`control`)."""
    _, roll, pitch, throttle = refs
    if not math.isnan(roll):
        pids[0, i], pids[1, i], pids[5, i] = 0.0, math.nan, 0.0
    if not math.isnan(pitch):
        pids[2, i], pids[3, i] = 0.0, math.nan
    if not math.isnan(throttle):
        pids[4, i] = 0.0
    if phase == PARKED:
        pids[6, i] = 0.0


@njit
def _level(y: np.ndarray, w: np.ndarray, sin_max: float) -> tuple[float, float, float]:
    """The attitude half of ``x8_modes.ground_contact`` for state ``y`` (18,), whose rotation
    is in ``w[ROT:]``: the new quaternion into ``y[0:4]`` (heading kept, wings level, pitch
    within ``[0, asin(sin_max)]``). Returns cos and sin of the heading, and whether the pitch
    was clipped (1.0) or not (0.0)."""
    span = math.sqrt(w[ROT + 0] * w[ROT + 0] + w[ROT + 3] * w[ROT + 3])  # cos(pitch) > 0
    cos_yaw, sin_yaw = w[ROT + 0] / span, w[ROT + 3] / span
    sin_pitch = -w[ROT + 6]
    s = np_minimum(np_maximum(sin_pitch, 0.0), sin_max)
    c = math.sqrt((1.0 - s) * (1.0 + s))
    half_c, half_s = math.sqrt((1.0 + c) * 0.5), math.sqrt((1.0 - c) * 0.5)
    yaw_c = math.sqrt(np_maximum(1.0 + cos_yaw, 0.0) * 0.5)
    yaw_s = math.sqrt(np_maximum(1.0 - cos_yaw, 0.0) * 0.5)
    if sin_yaw < 0.0:
        yaw_s = -yaw_s
    y[0], y[1] = yaw_c * half_c, -(yaw_s * half_s)
    y[2], y[3] = yaw_c * half_s, yaw_s * half_c
    return cos_yaw, sin_yaw, 1.0 if s != sin_pitch else 0.0


@njit
def _ground(y: np.ndarray, mu: float, sin_max: float, w: np.ndarray) -> tuple[float, float, bool]:
    """``x8_modes.ground_contact`` of one aircraft at or below the ground, state ``y`` (18,)
    in place; ``mu`` the friction coefficient, ``sin_max`` the sine of the largest pitch on
    the ground. Returns the sink rate the ground took (m/s), the speed before (m/s) and
    whether it came to rest."""
    _rotation(y, w)
    u, v, ww = y[10], y[11], y[12]
    north = w[ROT + 0] * u + w[ROT + 1] * v + w[ROT + 2] * ww
    east = w[ROT + 3] * u + w[ROT + 4] * v + w[ROT + 5] * ww
    down = w[ROT + 6] * u + w[ROT + 7] * v + w[ROT + 8] * ww
    cos_yaw, sin_yaw, clipped = _level(y, w, sin_max)
    sink = np_maximum(down, 0.0)
    along = north * cos_yaw + east * sin_yaw
    slowed = np_maximum(abs(along) - mu * sink, 0.0)
    along = -slowed if along < 0.0 else slowed
    down = np_minimum(down, 0.0)
    north, east = along * cos_yaw, along * sin_yaw
    speed = math.sqrt(u * u + v * v + ww * ww)
    stopped = along == 0.0 and down == 0.0
    _rotation(y, w)  # of the new quaternion
    y[10] = w[ROT + 0] * north + w[ROT + 3] * east + w[ROT + 6] * down
    y[11] = w[ROT + 1] * north + w[ROT + 4] * east + w[ROT + 7] * down
    y[12] = w[ROT + 2] * north + w[ROT + 5] * east + w[ROT + 8] * down
    y[4], y[6], y[9] = 0.0, 0.0, 0.0
    if clipped != 0.0 or stopped:
        y[5] = 0.0
    return sink, speed, stopped


@njit
def _touch(
    y: np.ndarray,
    i: int,
    ground: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    w: np.ndarray,
) -> None:
    """``X8Model.land`` for agent i, at or below the ground: :func:`_ground` with the
    friction of its phase, then ``x8_modes.after_contact`` and the touchdown records
    (``ground`` as in :func:`advance`)."""
    phase, counts, marks, m = ground
    was = phase[i]
    rolling = was in (GROUND_ROLL, CLIMB_OUT)
    mu = m[MD_ROLLING] if rolling else m[MD_BRAKING]
    sink, speed, stopped = _ground(y, mu, m[MD_SIN_GROUND_PITCH], w)
    landed = was in (FLIGHT, APPROACH, FLARE)
    now = ROLLOUT if landed else was
    if now == ROLLOUT and stopped:
        now = PARKED
    phase[i] = now
    if landed:
        counts[0, i] += 1
        if was != FLARE:
            counts[1, i] += 1
        marks[0, i], marks[1, i] = sink, speed


@njit
def _write(
    flight: np.ndarray,
    i: int,
    moved: bool,
    phase: np.ndarray,
    columns: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """``X8Model.write`` for agent i: x, y (m), speed (m/s; 0 where it did not move),
    heading (degrees in [0, 360), kept at rest) and, where the column exists (size N, else
    0), the phase."""
    x, y, speed, heading, phase_column = columns
    x[i], y[i] = flight[1, i], flight[0, i]
    speed[i] = flight[3, i] if moved else 0.0
    if flight[3, i] != 0.0:
        heading[i] = _mod(flight[4, i] * (180.0 / math.pi), 360.0)
    if phase_column.shape[0] != 0:
        phase_column[i] = phase[i]


# --- the two calls per iteration -----------------------------------------------------------


@njit
def advance(
    state: np.ndarray,
    commands: np.ndarray,
    moving: np.ndarray,
    constants: tuple[np.ndarray, np.ndarray, np.ndarray],
    out: tuple[np.ndarray, np.ndarray],
    ground: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    columns: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """Phase 2 for every agent: ``X8Vectorised.advance`` (one time step where ``moving`` and
    not parked, the others held; the ground; the swarm's columns).

    Args:
        state: the state, (STATES, N); not modified.
        commands: actuator set points, (COMMANDS, N).
        moving: (N,) bool.
        constants: :func:`pack_constants`, ``Constants.aero`` (6, 16), ``.inertia`` (3, 7).
        out: receive the new state, (STATES, N), and ``x8.observe`` of it,
            (FLIGHT_ROWS, N): north, east, altitude (m), airspeed (m/s), course, roll,
            pitch (rad), p, q (rad/s), climb (m/s).
        ground: the phases (N,) int64, updated; touchdowns and ground strikes (2, N) int64
            and the sink rate and speed at the latest touchdown (2, N) (m/s), updated where
            an aircraft touches down; :func:`pack_modes`.
        columns: the swarm's x, y (m), speed (m/s), heading (degrees) and phase columns,
            (N,) each (the phase column (0,) where the mission has none), written.
    """
    c, aero, inertia = constants
    new, flight = out
    phase = ground[0]
    w, y, step = np.empty(WORK), np.empty(18), np.empty(18)
    for i in range(state.shape[1]):
        for j in range(18):
            y[j] = state[j, i]
        moved = moving[i] and phase[i] != PARKED
        if moved:
            _step_one(y, commands, i, c, (aero, inertia), w, step)
            y[:] = step
            if y[9] >= 0.0:
                _touch(y, i, ground, w)
        for j in range(18):
            new[j, i] = y[j]
        _observe_one(y, flight, i, w)
        _write(flight, i, moved, phase, columns)


@njit
def control(
    flight: np.ndarray,
    requests: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    phase: np.ndarray,
    constants: tuple[np.ndarray, np.ndarray],
    pids: np.ndarray,
    commands: np.ndarray,
) -> None:
    """Phase 4 for every agent: ``X8Model.control`` (the phases' changes and references,
    guidance, attitude, elevon mixing, the overridden PIDs' integrators cleared).

    Args:
        flight: (FLIGHT_ROWS, N), as :func:`advance` fills it.
        requests: the requested heading (degrees clockwise from north) and speed (m/s),
            (N,), and the requested mode and glide-path altitude (m), (N,) each or (0,)
            where the mission has no such column.
        phase: the phases, (N,) int64, updated.
        constants: :func:`pack_gains`, :func:`pack_modes`.
        pids: controller state, (7, N), updated: course integral and previous error,
            altitude integral and previous error, integrals of the airspeed, roll and pitch
            errors.
        commands: receives the actuator set points, (COMMANDS, N).
    """
    heading, speed, mode, glide = requests
    g, m = constants
    for i in range(flight.shape[1]):
        p = phase[i]
        if mode.shape[0] != 0:
            p = _transition(p, mode[i], flight[2, i], flight[3, i], m)
            phase[i] = p
        target = glide[i] if glide.shape[0] != 0 else m[MD_ALTITUDE]
        refs = _overrides(p, target, flight[2, i], flight[9, i], m)
        _steer(i, flight, (heading[i], speed[i]), refs, pids, g, commands)
        _settle(i, p, refs, pids)
