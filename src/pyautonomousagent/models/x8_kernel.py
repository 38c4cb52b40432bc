"""The vectorised X8's step and autopilot compiled agent by agent (numba, the ``[fast]`` extra).

The NumPy code in :mod:`~pyautonomousagent.models.x8_dynamics`, :mod:`.x8` and
:mod:`.autopilot` is the reference; the functions here repeat its operations on one agent's
numbers at a time, in the same order, so that they give the same bits (no ``fastmath``, no
library arctangent or exponential: :func:`atan2` and :func:`exp` follow
:func:`pyautonomousagent.arrays.arctan2` and :func:`.x8_dynamics.exp` step by step).
Without numba (or with ``PYAA_NO_JIT=1``) they run as plain Python, correct but slow; the model
then uses the NumPy code (:attr:`pyautonomousagent.models.x8.X8Vectorised.compiled`).

Two calls per iteration, whatever the number of agents: :func:`advance` (Phase 2: one step
of every moving agent, then what the loop reads of it) and :func:`control` (Phase 4: guidance,
attitude and airspeed PIDs, elevon mixing). Their scalar constants travel in float arrays
laid out by :func:`pack_constants` and :func:`pack_gains`.
"""

from __future__ import annotations

import math

import numpy as np

from pyautonomousagent.arrays import _SERIES, _SQRT3, _TAN_PI_12
from pyautonomousagent.jit import njit
from pyautonomousagent.models import x8_dynamics as dyn
from pyautonomousagent.models.autopilot import AttitudeController, Guidance

#: Rows of the flight array that :func:`advance` fills (the fields of ``x8.Flight``).
FLIGHT_ROWS = 9
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
def _min(a: float, b: float) -> float:
    """``numpy.minimum`` of two finite numbers (the first where equal)."""
    return a if a <= b else b


@njit
def _max(a: float, b: float) -> float:
    """``numpy.maximum`` of two finite numbers (the first where equal)."""
    return a if a >= b else b


@njit
def _clip(x: float, low: float, high: float) -> float:
    """``minimum(maximum(x, low), high)``."""
    return _min(_max(x, low), high)


@njit
def _atan_unit(t: float) -> float:
    """``arrays._atan_unit`` for one number t in [0, 1] (rad)."""
    big = 1.0 if t > _TAN_PI_12 else 0.0
    u = big * ((t * _SQRT3 - 1.0) / (t + _SQRT3)) + (1.0 - big) * t
    z = u * u
    total = z * _SERIES[15]
    for j in range(14, 0, -1):
        total += _SERIES[j]
        total *= z
    total += _SERIES[0]
    return (math.pi / 6.0) * big + u * total


@njit
def atan2(y: float, x: float) -> float:
    """``arrays.arctan2`` for one pair (rad, [-pi, pi])."""
    ay, ax = abs(y), abs(x)
    steep = 1.0 if ay > ax else 0.0
    high = _max(ay, ax)
    angle = _atan_unit(_min(ay, ax) / (high + (1.0 if high == 0.0 else 0.0)))
    angle = (math.pi / 2.0) * steep + (1.0 - 2.0 * steep) * angle
    west = 1.0 - math.copysign(1.0, x)
    angle = (math.pi / 2.0) * west + (1.0 - west) * angle
    return math.copysign(angle, y)


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


@njit
def _rotation(b: np.ndarray, rot: np.ndarray) -> None:
    """``x8_dynamics.rotation`` of the quaternion ``b[0:4]`` into ``rot`` (3, 3)."""
    e0, e1, e2, e3 = b[0], b[1], b[2], b[3]
    d = e0 * e0 - (e1 * e1 + e2 * e2 + e3 * e3)
    s1, s2, s3 = 2 * e0 * e1, 2 * e0 * e2, 2 * e0 * e3
    rot[0, 0] = 2 * (e1 * e1) + d
    rot[1, 1] = 2 * (e2 * e2) + d
    rot[2, 2] = 2 * (e3 * e3) + d
    rot[0, 1] = 2 * (e1 * e2) - s3
    rot[0, 2] = 2 * (e1 * e3) + s2
    rot[1, 0] = 2 * (e2 * e1) + s3
    rot[1, 2] = 2 * (e2 * e3) - s1
    rot[2, 0] = 2 * (e3 * e1) - s2
    rot[2, 1] = 2 * (e3 * e2) + s1


@njit
def _features(b: np.ndarray, surf: np.ndarray, c: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Air data and the (16,) aerodynamic features into ``f`` (``x8_dynamics.FEATURES``).

    Returns ``[airspeed, airspeed^2, sin(alpha), cos(alpha), sin(beta), cos(beta)]``.
    """
    u, v, w = b[10], b[11], b[12]
    uw2 = u * u + w * w
    airspeed2 = uw2 + v * v
    airspeed = _max(math.sqrt(airspeed2), c[VMIN])
    inv_2v = 0.5 / airspeed
    uw = math.sqrt(uw2)
    alpha = atan2(w, u)
    sa, ca = w / uw, u / uw
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
    f[0], f[1], f[2], f[3] = 1.0, lin_lift, lin_lift * lift_linear, linear * alpha
    f[4], f[5], f[6], f[7] = linear, flat, flat * ca, flat * sa
    f[8], f[9], f[10], f[11] = inv_2v * b[5], surf[0], surf[0] * surf[0], beta
    f[12], f[13], f[14], f[15] = beta * beta, inv_2v * b[4], inv_2v * b[6], surf[1]
    return np.array([airspeed, airspeed2, sa, ca, sb, cb])


@njit
def _product_row(m: np.ndarray, i: int, x: np.ndarray) -> float:
    """``x8_dynamics._product`` for row i: ``((m[i,0] x[0] + m[i,1] x[1]) + ...)``."""
    total = m[i, 0] * x[0]
    for j in range(1, x.shape[0]):
        total = total + m[i, j] * x[j]
    return total


@njit
def _forces_moments(
    b: np.ndarray,
    surf: np.ndarray,
    c: np.ndarray,
    aero: np.ndarray,
    rot: np.ndarray,
    fm: np.ndarray,
) -> None:
    """``x8_dynamics._forces_moments`` for one agent: forces (N) and moments (N m) into ``fm``
    (6,); ``surf`` = (elevator, aileron, throttle), ``rot`` its rotation matrix (3, 3)."""
    f = np.empty(16)
    airspeed, airspeed2, sa, ca, sb, cb = _features(b, surf, c, f)
    qbar_s = c[QBAR] * airspeed2
    coef = np.empty(6)
    for i in range(6):
        coef[i] = _product_row(aero, i, f) * qbar_s
    lift, drag, pitch_m, side, roll_m, yaw_m = coef[0], coef[1], coef[2], coef[3], coef[4], coef[5]
    induced = airspeed + surf[2] * (c[KMOTOR] - airspeed)
    thrust = c[THRUST] * induced * (induced - airspeed)
    along = drag * cb - side * sb
    fm[0] = c[WEIGHT] * rot[2, 0] + (thrust - ca * along + lift * sa)
    fm[1] = c[WEIGHT] * rot[2, 1] + (drag * sb + side * cb)
    fm[2] = c[WEIGHT] * rot[2, 2] - (sa * along + lift * ca)
    spin = c[KOMEGA] * surf[2]
    fm[3], fm[4], fm[5] = roll_m - c[KTP] * (spin * spin), pitch_m, yaw_m


@njit
def _derivatives(
    b: np.ndarray, surf: np.ndarray, c: np.ndarray, aero: np.ndarray, inertia: np.ndarray
) -> np.ndarray:
    """``x8_dynamics.body_derivatives`` for one agent's airframe ``b`` (13,); returns (13,)."""
    rot = np.empty((3, 3))
    _rotation(b, rot)
    fm = np.empty(6)
    _forces_moments(b, surf, c, aero, rot, fm)
    p, q, r, u, v, w = b[4], b[5], b[6], b[10], b[11], b[12]
    d = np.empty(13)
    for i in range(4):
        d[i] = (_HS[0, i] * b[_PERM[0, i]]) * p + (_HS[1, i] * b[_PERM[1, i]]) * q
        d[i] = d[i] + (_HS[2, i] * b[_PERM[2, i]]) * r
    products = np.array([p * q, q * r, p * r, p * p - r * r, fm[3], fm[4], fm[5]])
    for i in range(3):
        d[4 + i] = _product_row(inertia, i, products)
        d[7 + i] = rot[i, 0] * u + rot[i, 1] * v + rot[i, 2] * w
    d[10] = v * r - w * q + fm[0] / c[MASS]
    d[11] = w * p - u * r + fm[1] / c[MASS]
    d[12] = u * q - v * p + fm[2] / c[MASS]
    return d


@njit
def _half_step(a: np.ndarray, cmd: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``x8_dynamics._actuator_half_step`` for one agent's actuator rows ``a`` (5,)."""
    out = np.empty(5)
    for j in range(2):
        offset = a[j] - cmd[j]
        moved = c[F11] * offset + c[F12] * a[2 + j] - offset
        out[j] = a[j] + _clip(moved, -c[LIMIT], c[LIMIT])
        out[2 + j] = _clip(c[F21] * offset + c[F22] * a[2 + j], -c[RMAX], c[RMAX])
    out[4] = cmd[2] + (a[4] - cmd[2]) * c[DECAY]
    return out


@njit
def _surfaces(a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``x8_dynamics._surfaces``: (elevator, aileron, throttle) of actuator rows ``a`` (5,)."""
    right = _clip(a[0], c[EMIN], c[EMAX])
    left = _clip(a[1], c[EMIN], c[EMAX])
    throttle = _clip(a[4], c[TMIN], c[TMAX])
    return np.array([0.5 * (right + left), 0.5 * (left - right), throttle])


@njit
def _step_one(
    y: np.ndarray, cmd: np.ndarray, c: np.ndarray, aero: np.ndarray, inertia: np.ndarray
) -> np.ndarray:
    """``x8_dynamics.step`` (settling included) for one agent's state ``y`` (18,)."""
    h = c[H]
    act = y[13:18]
    middle = _half_step(act, cmd, c)
    end = _half_step(middle, cmd, c)
    b = y[0:13]
    k1 = _derivatives(b, _surfaces(act, c), c, aero, inertia)
    k2 = _derivatives(b + (h / 2) * k1, _surfaces(middle, c), c, aero, inertia)
    k3 = _derivatives(b + h * (2 * k2 - k1), _surfaces(end, c), c, aero, inertia)
    new = np.empty(18)
    new[0:13] = b + (h / 6) * (k1 + 4 * k2 + k3)
    new[13:18] = end
    norm = math.sqrt(new[0] * new[0] + new[1] * new[1] + new[2] * new[2] + new[3] * new[3])
    for i in range(4):
        new[i] /= norm
    for i in range(13, 15):
        new[i] = _clip(new[i], c[EMIN], c[EMAX])
        new[i + 2] = _clip(new[i + 2], -c[RMAX], c[RMAX])
    new[17] = _clip(new[17], c[TMIN], c[TMAX])
    return new


@njit
def _observe_one(y: np.ndarray, flight: np.ndarray, i: int) -> None:
    """``x8.observe`` for one agent's state ``y`` (18,) into column i of ``flight`` (9, N)."""
    e0, e1, e2, e3, u, v, w = y[0], y[1], y[2], y[3], y[10], y[11], y[12]
    rot = np.empty((3, 3))
    _rotation(y, rot)
    north = rot[0, 0] * u + rot[0, 1] * v + rot[0, 2] * w
    east = rot[1, 0] * u + rot[1, 1] * v + rot[1, 2] * w
    s = _clip(2 * (e0 * e2 - e1 * e3), -1.0, 1.0)
    flight[0, i], flight[1, i], flight[2, i] = y[7], y[8], -y[9]
    flight[3, i] = math.sqrt(u * u + v * v + w * w)
    flight[4, i] = atan2(east, north)
    flight[5, i] = atan2(2 * (e0 * e1 + e2 * e3), e0 * e0 + e3 * e3 - e1 * e1 - e2 * e2)
    flight[6, i] = atan2(s, math.sqrt((1.0 - s) * (1.0 + s)))
    flight[7, i], flight[8, i] = y[4], y[5]


@njit
def advance(
    state: np.ndarray,
    commands: np.ndarray,
    moving: np.ndarray,
    c: np.ndarray,
    aero: np.ndarray,
    inertia: np.ndarray,
    new: np.ndarray,
    flight: np.ndarray,
) -> None:
    """One time step of every agent where ``moving``; the others are held.

    Args:
        state: the state, (STATES, N); not modified.
        commands: actuator set points, (COMMANDS, N).
        moving: (N,) bool.
        c: :func:`pack_constants`; aero, inertia: ``Constants.aero`` (6, 16), ``.inertia`` (3, 7).
        new: receives the new state, (STATES, N).
        flight: receives ``x8.observe`` of the new state, (FLIGHT_ROWS, N): north, east,
            altitude (m), airspeed (m/s), course, roll, pitch (rad), p, q (rad/s).
    """
    for i in range(state.shape[1]):
        y = state[:, i].copy()
        if moving[i]:
            y = _step_one(y, commands[:, i].copy(), c, aero, inertia)
        new[:, i] = y
        _observe_one(y, flight, i)


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
def control(
    flight: np.ndarray,
    heading: np.ndarray,
    speed: np.ndarray,
    pids: np.ndarray,
    g: np.ndarray,
    commands: np.ndarray,
) -> None:
    """Phase 4 for every agent: ``X8Vectorised.control`` (guidance, attitude, elevon mixing).

    Args:
        flight: (FLIGHT_ROWS, N), as :func:`advance` fills it.
        heading, speed: the requested heading (degrees clockwise from north) and speed
            (m/s), (N,).
        pids: controller state, (7, N), updated: course integral and previous error,
            altitude integral and previous error, integrals of the airspeed, roll and pitch
            errors.
        g: :func:`pack_gains`.
        commands: receives the actuator set points, (COMMANDS, N).
    """
    for i in range(flight.shape[1]):
        error = _mod(heading[i] * (math.pi / 180.0) - flight[4, i] + math.pi, 2 * math.pi)
        roll_ref = _pid(error - math.pi, pids, 0, i, g, C_KP)
        pitch_ref = _pid(g[ALT_REF] - flight[2, i], pids, 2, i, g, A_KP)
        errors = (
            flight[3, i] - _max(speed[i], g[V_MIN]),
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
