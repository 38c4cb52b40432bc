"""The Skywalker X8's 6-DOF equations of motion for all agents at once (NumPy).

The equations are Beard & McLain's (*Small Unmanned Aircraft*, 2012, ch. 3-4) with the X8
coefficients of Gryte et al. (2018) and the nonlinear angle-of-attack and sideslip extensions
that PyFly (Bohn et al. 2019) documents; the parameters come from the files the installed
``pyfly-fixed-wing`` package ships (:mod:`~pyautonomousagent.models.x8_params`). This is an
independent implementation written from those publications, vectorised over agents:

- attitude as a quaternion ``(e0, e1, e2, e3)`` (body to NED), body rates ``p, q, r``
  (rad/s), NED position ``(n, e, d)`` (m), body velocity ``(u, v, w)`` (m/s);
- lift, drag and pitching moment blended with flat-plate values through the stall function
  ``sigma(alpha)`` (Beard & McLain eq. 4.10); drag adds a sideslip polynomial
  ``C_D_beta1 beta + C_D_beta2 beta^2`` and ``C_D_delta_e delta_e^2``; the aerodynamic forces
  ``(-D, Y, -L)`` are rotated into the body frame with the angles ``(alpha, beta)``;
- Beard & McLain's propeller (thrust and torque) and gravity;
- two second-order elevons (deflection and rate limits) mixed into elevator and aileron, and a
  first-order throttle.

The state of N agents is one array of shape ``(STATES, N)``; rows are named by the index
constants below. :func:`step` advances it by one time step: the actuators (linear apart from
their limits) are propagated exactly over two half steps with their rate limit applied, and
the airframe with one third-order Runge-Kutta step that reads the actuators at the start,
middle and end of the step. Afterwards the quaternion is renormalised and the actuators clipped, as
PyFly does after each of its steps. :func:`derivatives` is the whole right-hand side (used to
check the equations against PyFly's).

Every operation has a fixed order, the same for any number of agents and on every CPU: sums
are written out term by term (``numpy.sum`` and BLAS reassociate depending on the array's
shape and the machine), the small matrix products accumulate column by column
(:func:`_product`), and the arctangent, arcsine and exponential are computed from
``+ - * /`` and ``sqrt`` alone (:func:`~pyautonomousagent.arrays.arctan2`, :func:`exp`),
which are correctly rounded everywhere, where NumPy's own kernels differ by an ulp between
SIMD levels. The compiled kernel (:mod:`~pyautonomousagent.models.x8_kernel`) repeats these
operations agent by agent and gives the same bits.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from decimal import Context, Decimal

import numpy as np

from pyautonomousagent.arrays import arctan2
from pyautonomousagent.models.x8_params import X8Parameters

# Rows of the state array, shape (STATES, N).
E0, E1, E2, E3 = 0, 1, 2, 3  # attitude quaternion, body -> NED
P, Q, R = 4, 5, 6  # body rates, rad/s
PN, PE, PD = 7, 8, 9  # NED position, m
U, V, W = 10, 11, 12  # body velocity, m/s
ELEVON_R, ELEVON_L = 13, 14  # elevon deflections, rad
ELEVON_R_RATE, ELEVON_L_RATE = 15, 16  # their rates, rad/s
THROTTLE = 17  # throttle setting in [0, 1]
STATES = 18
QUATERNION = slice(E0, E3 + 1)
RATES = slice(P, R + 1)
VELOCITY = slice(U, W + 1)
BODY = slice(E0, W + 1)  # the airframe's 13 rows
ELEVONS = slice(ELEVON_R, ELEVON_L + 1)
ELEVON_RATES = slice(ELEVON_R_RATE, ELEVON_L_RATE + 1)

# Rows of the command array, shape (COMMANDS, N).
CMD_ELEVON_R, CMD_ELEVON_L, CMD_THROTTLE = 0, 1, 2
COMMANDS = 3

# Quaternion kinematics: de/dt = 0.5 * sum_k omega_k * SIGN[k] * e[PERM[k]], k = p, q, r.
_PERM = np.array([[1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]], dtype=np.intp)
_HALF_SIGN = (
    0.5 * np.array([[-1, 1, 1, -1], [-1, -1, 1, 1], [-1, 1, -1, 1]], dtype=float)[:, :, None]
)
# Row orders of the cross product v x omega = v[_A] omega[_B] - v[_B] omega[_A].
_A, _B = np.array([1, 2, 0], dtype=np.intp), np.array([2, 0, 1], dtype=np.intp)

#: The exponential's constants: log2(e); ln 2 split in a head with 32 significant bits (so
#: ``k * LN2_HI`` is exact for ``|k| < 2**21``) and the rest; 1/n!, n = 0..13.
LOG2E = 1.0 / math.log(2.0)
LN2_HI = math.floor(math.log(2.0) * 2.0**32) / 2.0**32
LN2_LO = float(Decimal(2).ln(Context(prec=40)) - Decimal(LN2_HI))
EXP_SERIES = tuple(1.0 / math.factorial(n) for n in range(14))
#: Arguments of :func:`exp` are clipped to this range (its result stays finite).
EXP_LIMIT = 700.0


def exp(x: np.ndarray) -> np.ndarray:
    """``e**x`` from ``+ - * /``, ``floor`` and ``ldexp`` (all exact or correctly rounded).

    ``x = k ln 2 + r`` with ``|r| <= ln(2)/2`` (Cody and Waite's two-part ln 2), ``e**r`` by
    14 terms of its series (within 2e-18 there), times ``2**k``. Within a few ulp of
    ``math.exp``; arguments are clipped to +-:data:`EXP_LIMIT`. Shape of ``x``.
    """
    x = np.minimum(np.maximum(x, -EXP_LIMIT), EXP_LIMIT)
    k = np.floor(x * LOG2E + 0.5)
    r = (x - k * LN2_HI) - k * LN2_LO
    total = r * EXP_SERIES[-1]
    for coefficient in EXP_SERIES[-2:0:-1]:
        total += coefficient
        total *= r
    total += EXP_SERIES[0]
    return np.ldexp(total, k.astype(np.int64))


def arcsin(s: np.ndarray) -> np.ndarray:
    """``asin(s)`` for s in [-1, 1] as ``arctan2(s, sqrt((1 - s)(1 + s)))``, same bits
    everywhere; the factored square root keeps it accurate next to +-1."""
    return arctan2(s, np.sqrt((1.0 - s) * (1.0 + s)))


def _product(m: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``m @ x`` for a small matrix ``m`` (k, j) and ``x`` (j, N), shape (k, N).

    Summed column by column, ``((m[:, 0] x[0] + m[:, 1] x[1]) + ...)``, zero terms included:
    the order BLAS and ``einsum`` leave to the machine is fixed here.
    """
    return np.add.accumulate(m[:, :, None] * x[None], axis=1)[:, -1]


def _sum3(a: np.ndarray) -> np.ndarray:
    """``(a[0] + a[1]) + a[2]`` over the first axis of ``a`` (3, ...)."""
    return a[0] + a[1] + a[2]


def quaternion_from_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """The unit quaternion of Euler angles (ZYX: yaw, pitch, roll; rad), shape (4, N)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ]
    )


def roll_pitch(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roll and pitch (rad) of unit quaternions ``e`` of shape (4, N); each (N,)."""
    e0, e1, e2, e3 = e
    roll = arctan2(2 * (e0 * e1 + e2 * e3), e0 * e0 + e3 * e3 - e1 * e1 - e2 * e2)
    pitch = arcsin(np.minimum(np.maximum(2 * (e0 * e2 - e1 * e3), -1.0), 1.0))
    return roll, pitch


def euler_from_quaternion(e: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch and yaw (rad) of unit quaternions ``e`` of shape (4, N); each (N,)."""
    e0, e1, e2, e3 = e
    yaw = np.arctan2(2 * (e0 * e3 + e1 * e2), e0**2 + e1**2 - e2**2 - e3**2)
    return (*roll_pitch(e), yaw)


def rotation(e: np.ndarray) -> np.ndarray:
    """Body-to-NED rotation matrices of quaternions ``e`` (4, N), shape (3, 3, N).

    Beard & McLain eq. 3.14 in quaternion form, ``R = (e0^2 - |v|^2) I + 2 v v^T + 2 e0 [v]x``
    with ``v = (e1, e2, e3)``; for a quaternion of norm 1 + eps the matrix is off by O(eps), as
    in PyFly, which also evaluates it with unnormalised quaternions between its steps.
    """
    v = e[1:]
    m = 2 * (v[:, None] * v[None, :])
    flat = m.reshape((9,) + e.shape[1:])
    flat[::4] += e[0] * e[0] - _sum3(v * v)
    s = 2 * e[0] * v
    m[0, 1] -= s[2]
    m[0, 2] += s[1]
    m[1, 0] += s[2]
    m[1, 2] -= s[0]
    m[2, 0] -= s[1]
    m[2, 1] += s[0]
    return m


def body_to_ned(e: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Rotate body-frame vectors ``(x, y, z)`` (each (N,)) into NED; shape (3, N)."""
    return _sum3(np.moveaxis(rotation(e) * np.array([x, y, z])[None], 1, 0))


#: Names of the features the aerodynamic coefficients are linear in (rows of the feature
#: array built in :func:`_forces_moments`), with s = sigma(alpha), lin = C_L_0 + C_L_alpha alpha,
#: flat = s sign(alpha) sin^2(alpha) and V the airspeed:
#: one = 1, lin = (1-s) lin, lin2 = (1-s) lin^2, lin_alpha = (1-s) alpha, lin_one = 1-s,
#: flat, flat_cos = flat cos(alpha), flat_sin = flat sin(alpha), q = q/2V, de = elevator,
#: de2 = elevator^2, beta, beta2 = beta^2, p = p/2V, r = r/2V, da = aileron.
FEATURES = (
    "one",
    "lin",
    "lin2",
    "lin_alpha",
    "lin_one",
    "flat",
    "flat_cos",
    "flat_sin",
    "q",
    "de",
    "de2",
    "beta",
    "beta2",
    "p",
    "r",
    "da",
)


@dataclass(frozen=True)
class Constants:
    """Products of the parameters that every evaluation uses, computed once.

    Attributes:
        params: the parameters.
        dt: the time step (s) that :func:`step` takes.
        aero: (6, 16) matrix taking the :data:`FEATURES` to the coefficients of lift, drag,
            pitching moment times the chord c, side force, and rolling and yawing moments times
            the span b; times ``0.5 rho V^2 S`` they are forces (N) and moments (N m).
        inertia: (3, 7) matrix taking ``[pq, qr, pr, p^2 - r^2, l, m, n]`` to the angular
            accelerations (Beard & McLain eq. 3.13).
        actuator_step: (2, 2) transition matrix of an elevon over half a time step.
        throttle_decay: the throttle's first-order decay over half a time step.
    """

    params: X8Parameters
    dt: float
    aero: np.ndarray
    inertia: np.ndarray
    actuator_step: np.ndarray
    throttle_decay: float

    @classmethod
    def of(cls, p: X8Parameters, dt: float | None = None) -> Constants:
        """The constants of the parameters ``p`` for time steps of ``dt`` (default ``p.dt``)."""
        a, act = p.airframe, p.actuators
        dt = p.dt if dt is None else dt
        g1, g2, g3, g4, g5, g6, g7, g8 = a.gammas()
        inertia = np.array(
            [
                [g1, -g2, 0, 0, g3, 0, g4],
                [0, 0, g5, -g6, 0, 1 / a.Jy, 0],
                [g7, -g1, 0, 0, g4, 0, g8],
            ]
        )
        return cls(
            params=p,
            dt=dt,
            aero=_aero_matrix(p),
            inertia=inertia,
            actuator_step=_transition(act.omega_0, act.zeta, dt / 2),
            throttle_decay=math.exp(-dt / 2 / act.throttle_tau),
        )


def _aero_matrix(p: X8Parameters) -> np.ndarray:
    """The (6, 16) matrix of :attr:`Constants.aero` (columns in :data:`FEATURES` order),
    with s = sigma(alpha), a = alpha, b = beta, de = elevator.

    Lift: ``(1-s) C_L_lin + 2 s flat cos(a) + C_L_q c q/2V + C_L_delta_e de``.
    Drag: ``C_D_p + (1-s) C_L_lin^2 / (pi e AR) + 2 s flat sin(a) + C_D_beta1 b + C_D_beta2 b^2
    + C_D_q c q/2V + C_D_delta_e de^2``.
    Pitch (times c): ``(1-s)(C_m_0 + C_m_alpha a) + s C_m_fp flat + C_m_q b q/2V
    + C_m_delta_e de``; PyFly non-dimensionalises the pitch damping with the span b where
    Beard & McLain use the chord c, and so does this model.
    Side force, roll and yaw (the moments times b): the usual linear terms in ``1, beta,
    b p/2V, b r/2V, aileron`` (the X8 has no rudder).
    """
    c, a = p.aero, p.airframe
    col = {name: i for i, name in enumerate(FEATURES)}
    m = np.zeros((6, len(FEATURES)))

    def put(row: int, scale: float, **terms: float) -> None:
        for name, value in terms.items():
            m[row, col[name]] = scale * value

    put(0, 1.0, lin=1.0, flat_cos=2.0, q=c.C_L_q * a.c, de=c.C_L_delta_e)
    induced = 1 / (np.pi * c.e * a.aspect_ratio)
    put(1, 1.0, one=c.C_D_p, lin2=induced, flat_sin=2.0, q=c.C_D_q * a.c, de2=c.C_D_delta_e)
    put(1, 1.0, beta=c.C_D_beta1, beta2=c.C_D_beta2)
    put(2, a.c, lin_one=c.C_m_0, lin_alpha=c.C_m_alpha, flat=c.C_m_fp, q=c.C_m_q * a.b)
    put(2, a.c, de=c.C_m_delta_e)
    put(3, 1.0, one=c.C_Y_0, beta=c.C_Y_beta, p=c.C_Y_p * a.b, r=c.C_Y_r * a.b)
    put(3, 1.0, da=c.C_Y_delta_a)
    put(4, a.b, one=c.C_l_0, beta=c.C_l_beta, p=c.C_l_p * a.b, r=c.C_l_r * a.b)
    put(4, a.b, da=c.C_l_delta_a)
    put(5, a.b, one=c.C_n_0, beta=c.C_n_beta, p=c.C_n_p * a.b, r=c.C_n_r * a.b)
    put(5, a.b, da=c.C_n_delta_a)
    return m


def _transition(omega: float, zeta: float, h: float) -> np.ndarray:
    """exp(A h) of the second-order actuator ``A = [[0, 1], [-omega^2, -2 zeta omega]]``.

    In closed form from the eigenvalues l1, l2 of A (Sylvester's formula,
    ``exp(A h) = c0 I + c1 A``), with the scalar library's ``exp``, so the constants are the
    same on every machine and SIMD level (NumPy's ``exp`` and LAPACK's ``eig`` are not).
    """
    a = np.array([[0.0, 1.0], [-(omega**2), -2.0 * zeta * omega]])
    root = cmath.sqrt(zeta * zeta - 1.0) * omega
    l1, l2 = -zeta * omega + root, -zeta * omega - root
    if l1 == l2:  # critically damped: the limit of the formula below
        e = math.exp(l1.real * h)
        return e * ((1.0 - l1.real * h) * np.eye(2) + h * a)
    e1, e2 = cmath.exp(l1 * h), cmath.exp(l2 * h)
    c0, c1 = (l1 * e2 - l2 * e1) / (l1 - l2), (e1 - e2) / (l1 - l2)
    return c0.real * np.eye(2) + c1.real * a


def _stall_blend(alpha: np.ndarray, m: float, a0: float) -> np.ndarray:
    """Beard & McLain's blending function sigma(alpha) in [0, 1] (eq. 4.10).

    ``(1 + exp(-M(a - a0)) + exp(M(a + a0))) / ((1 + exp(-M(a - a0))) (1 + exp(M(a + a0))))``
    rewritten with ``k = exp(M a0)`` as ``(1 + 2k cosh(M a)) / (1 + k^2 + 2k cosh(M a))``.
    """
    k = math.exp(m * a0)
    z = exp(m * alpha)
    t = k * (z + 1 / z)  # 2k cosh(M a)
    return (1 + t) / ((1 + k * k) + t)


def _forces_moments(
    b: np.ndarray, surfaces: tuple[np.ndarray, ...], down: np.ndarray, k: Constants
) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame forces (N) and moments (N m), each of shape (3, N).

    Args:
        b: the airframe's state (rows E0..W), shape (13, N).
        surfaces: elevator and aileron (rad) and throttle in [0, 1], each (N,).
        down: the NED down axis in body axes, shape (3, N) (the rotation's last row).
        k: the model's constants.
    """
    a = k.params.airframe
    elevator, aileron, throttle = surfaces
    u, v, w = b[U], b[V], b[W]
    uw2 = u * u + w * w
    airspeed2 = uw2 + v * v
    airspeed = np.maximum(np.sqrt(airspeed2), k.params.airspeed_min)
    inv_2v = 0.5 / airspeed
    uw = np.maximum(np.sqrt(uw2), k.params.airspeed_min)  # at rest: alpha 0, no force
    sa, ca = w / uw, u / uw  # sin, cos of alpha
    sb = v / airspeed  # sin(beta)
    cb = np.sqrt(1 - sb * sb)
    alpha, beta = arctan2(np.array([w, sb]), np.array([u, cb]))  # one call: atan2(w, u), asin(sb)
    sigma = _stall_blend(alpha, k.params.aero.M, k.params.aero.a_0)
    linear = 1 - sigma
    lift_linear = k.params.aero.C_L_0 + k.params.aero.C_L_alpha * alpha
    lin_lift = linear * lift_linear
    flat = sigma * sa * np.abs(sa)  # sigma sign(alpha) sin^2(alpha), flat-plate shape
    rates = inv_2v * b[P : R + 1]
    features = np.array(
        [np.ones_like(u), lin_lift, lin_lift * lift_linear, linear * alpha, linear, flat]
        + [flat * ca, flat * sa, rates[1], elevator, elevator * elevator, beta, beta * beta]
        + [rates[0], rates[2], aileron]
    )
    qbar_s = (0.5 * k.params.rho * a.S_wing) * airspeed2
    lift, drag, pitch_m, side, roll_m, yaw_m = _product(k.aero, features) * qbar_s
    induced_speed = airspeed + throttle * (a.k_motor - airspeed)
    thrust = (0.5 * k.params.rho * a.S_prop * a.C_prop) * induced_speed * (induced_speed - airspeed)
    along = drag * cb - side * sb
    forces = (a.mass * k.params.g) * down
    forces[0] += thrust - ca * along + lift * sa
    forces[1] += drag * sb + side * cb
    forces[2] -= sa * along + lift * ca
    torque = a.k_T_P * (a.k_Omega * throttle) ** 2
    return forces, np.array([roll_m - torque, pitch_m, yaw_m])


def body_derivatives(b: np.ndarray, surfaces: tuple[np.ndarray, ...], k: Constants) -> np.ndarray:
    """The airframe's time derivative for given surfaces and throttle.

    Args:
        b: the airframe's state, rows E0..W, shape (13, N).
        surfaces: elevator and aileron deflections (rad) and throttle in [0, 1], each (N,).
        k: the model's constants.

    Returns:
        d b / dt, shape (13, N).
    """
    e, omega, vel = b[QUATERNION], b[RATES], b[VELOCITY]
    rot = rotation(e)
    forces, moments = _forces_moments(b, surfaces, rot[2], k)
    p, q, r = omega
    d = np.empty_like(b)
    d[QUATERNION] = _sum3(_HALF_SIGN * e.take(_PERM, axis=0) * omega[:, None])
    products = np.array([p * q, q * r, p * r, p * p - r * r, *moments])
    d[RATES] = _product(k.inertia, products)
    d[PN : PD + 1] = _sum3(np.moveaxis(rot * vel[None], 1, 0))
    d[VELOCITY] = vel.take(_A, axis=0) * omega.take(_B, axis=0)
    d[VELOCITY] -= vel.take(_B, axis=0) * omega.take(_A, axis=0)
    d[VELOCITY] += forces / k.params.airframe.mass
    return d


def _surfaces(actuators: np.ndarray, k: Constants) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Elevator, aileron (rad) and throttle from actuator rows (right, left, ..., throttle)."""
    act = k.params.actuators
    right = np.minimum(np.maximum(actuators[0], act.elevon_min), act.elevon_max)
    left = np.minimum(np.maximum(actuators[1], act.elevon_min), act.elevon_max)
    throttle = np.minimum(np.maximum(actuators[4], act.throttle_min), act.throttle_max)
    return 0.5 * (right + left), 0.5 * (left - right), throttle


def derivatives(y: np.ndarray, commands: np.ndarray, k: Constants) -> np.ndarray:
    """The time derivative of the whole state ``y`` (STATES, N) under ``commands`` (3, N).

    Actuator values and rates are read clipped to their limits. This is the full system that
    :func:`step` integrates (there by splitting actuators from airframe).
    """
    act = k.params.actuators
    elevator, aileron, throttle = _surfaces(y[ELEVON_R:], k)
    dy = np.empty_like(y)
    dy[BODY] = body_derivatives(y[BODY], (elevator, aileron, throttle), k)
    values = np.clip(y[ELEVONS], act.elevon_min, act.elevon_max)
    rates = np.clip(y[ELEVON_RATES], -act.elevon_rate_max, act.elevon_rate_max)
    w0 = act.omega_0
    dy[ELEVONS] = rates
    dy[ELEVON_RATES] = w0 * w0 * (commands[:2] - values) - 2 * act.zeta * w0 * rates
    throttle_now = np.clip(y[THROTTLE], act.throttle_min, act.throttle_max)
    dy[THROTTLE] = (commands[CMD_THROTTLE] - throttle_now) / act.throttle_tau
    return dy


def _actuator_half_step(a: np.ndarray, commands: np.ndarray, k: Constants) -> np.ndarray:
    """Actuator rows (right, left, right rate, left rate, throttle) after half a time step.

    Exact for the linear actuator dynamics; where an elevon would move faster than its rate
    limit allows, its movement is cut to the limit and its rate clipped.
    """
    act = k.params.actuators
    (f11, f12), (f21, f22) = k.actuator_step
    limit = act.elevon_rate_max * 0.5 * k.dt
    offset = a[0:2] - commands[0:2]
    moved = f11 * offset + f12 * a[2:4] - offset
    out = np.empty_like(a)
    out[0:2] = a[0:2] + np.minimum(np.maximum(moved, -limit), limit)
    rates = f21 * offset + f22 * a[2:4]
    out[2:4] = np.minimum(np.maximum(rates, -act.elevon_rate_max), act.elevon_rate_max)
    out[4] = commands[2] + (a[4] - commands[2]) * k.throttle_decay
    return out


def step(y: np.ndarray, commands: np.ndarray, k: Constants) -> np.ndarray:
    """Advance the state by one time step (``k.dt``) with the commands held.

    The actuators are propagated over two half steps (:func:`_actuator_half_step`); the
    airframe takes one step of Kutta's third-order Runge-Kutta method, reading the actuators at
    the start, middle and end of the step; then the quaternion is renormalised and the
    actuators clipped. Against a reference integrated with 20 RK4 substeps per step, the
    airframe's method is not what limits the accuracy: over 40 s of patrol RK4 and RK3 both
    differ from it by 1.7 cm, RK2 by 2.2 cm; the difference comes from the actuators' rate limit
    applied per half step (docs/x8.md).

    Args:
        y: the state, shape (STATES, N); not modified.
        commands: actuator set points, shape (COMMANDS, N) (rad, rad, [0, 1]).
        k: the model's constants (their time step is the step's).

    Returns:
        The new state, shape (STATES, N).
    """
    h = k.dt
    middle = _actuator_half_step(y[ELEVON_R:], commands, k)
    end = _actuator_half_step(middle, commands, k)
    b = y[BODY]
    k1 = body_derivatives(b, _surfaces(y[ELEVON_R:], k), k)
    k2 = body_derivatives(b + (h / 2) * k1, _surfaces(middle, k), k)
    k3 = body_derivatives(b + h * (2 * k2 - k1), _surfaces(end, k), k)
    new = np.empty_like(y)
    new[BODY] = b + (h / 6) * (k1 + 4 * k2 + k3)
    new[ELEVON_R:] = end
    e, act = new[QUATERNION], k.params.actuators
    e /= np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3])
    for rows, low, high in (
        (new[ELEVONS], act.elevon_min, act.elevon_max),
        (new[ELEVON_RATES], -act.elevon_rate_max, act.elevon_rate_max),
        (new[THROTTLE], act.throttle_min, act.throttle_max),
    ):
        np.maximum(rows, low, out=rows)
        np.minimum(rows, high, out=rows)
    return new


def elevon_commands(elevator: np.ndarray, aileron: np.ndarray, k: Constants) -> np.ndarray:
    """Right and left elevon set points (rad) for elevator and aileron commands, clipped.

    Returns:
        Shape (2, N): right = elevator - aileron, left = elevator + aileron.
    """
    act = k.params.actuators
    both = np.array([elevator - aileron, elevator + aileron])
    return np.minimum(np.maximum(both, act.elevon_min), act.elevon_max)
