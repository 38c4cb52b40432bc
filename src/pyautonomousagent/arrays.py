"""Helpers that work alike on one agent's numbers and on arrays of many agents.

Leaf nodes are written once for both engines: the py_trees engine calls them with
scalars (one agent), the batched engine with arrays. NumPy on scalars costs about a
microsecond a call, so these helpers take the plain-Python path for scalars. Both paths
use only IEEE operations that are correctly rounded on every CPU (``+ - * /``, comparisons,
``abs``), so the two engines compute the same bits on every machine and SIMD level.
Library functions such as ``atan2`` are not: NumPy's AVX-512 ``arctan2`` differs from
``math.atan2`` by one ulp on about 8 % of inputs, so :func:`bearing` computes its arctangent
from those operations alone, with one body for scalars and arrays; :func:`sincos_degrees`
does the same for the motion's sine and cosine (a GPU's ``sin``/``cos`` differ too), and
:func:`hypot` for distances.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def choose(condition: Any, if_true: Any, if_false: Any) -> Any:
    """``if_true`` where ``condition`` holds, else ``if_false`` (``numpy.where`` for arrays)."""
    if isinstance(condition, np.ndarray):
        return np.where(condition, if_true, if_false)
    return if_true if condition else if_false


def minimum(a: Any, b: Any) -> Any:
    """Element-wise minimum."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.minimum(a, b)
    return a if a <= b else b


def maximum(a: Any, b: Any) -> Any:
    """Element-wise maximum."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.maximum(a, b)
    return a if a >= b else b


def wrap_degrees(angle: Any) -> Any:
    """An angle in [-360, 720) degrees brought into [0, 360).

    Gives the same bits as ``numpy.mod(angle, 360)`` on that interval (one exact addition
    or subtraction), at a third of its cost.
    """
    if isinstance(angle, np.ndarray):
        angle = np.where(angle < 0.0, angle + 360.0, angle)
        return np.where(angle >= 360.0, angle - 360.0, angle)
    if angle < 0.0:
        angle += 360.0
    return angle - 360.0 if angle >= 360.0 else angle


#: (-1)**k / (2k + 1), k = 0..15: the arctangent's series, enough for |t| <= tan(pi / 12).
_SERIES = tuple((-1.0) ** k / (2 * k + 1) for k in range(16))
_TAN_PI_12 = 2.0 - math.sqrt(3.0)
_SQRT3 = math.sqrt(3.0)


def copysign(magnitude: Any, sign: Any) -> Any:
    """``magnitude`` with the sign bit of ``sign`` (a bit operation, exact)."""
    if isinstance(magnitude, np.ndarray) or isinstance(sign, np.ndarray):
        return np.copysign(magnitude, sign)
    return math.copysign(magnitude, sign)


def _atan_unit(t: Any) -> Any:
    """``atan(t)`` for t in [0, 1], radians, from ``+ - * /`` only.

    Above tan(pi/12) the argument is reduced with atan(t) = pi/6 + atan((sqrt(3) t - 1) /
    (t + sqrt(3))), which brings it into [-tan(pi/12), tan(pi/12)], where 16 terms of the
    series ``t - t**3/3 + t**5/5 - ...`` are within 1e-17 of the arctangent. The branch is
    taken by multiplying with 0 or 1, which is exact here (every value is finite and ``t``
    is not negative), so arrays need no ``numpy.where`` (ten times slower than a product).
    """
    big = t > _TAN_PI_12
    u = big * ((t * _SQRT3 - 1.0) / (t + _SQRT3)) + (1.0 - big) * t
    z = u * u
    total = z * _SERIES[-1]  # a new array (or float), so the in-place steps below are safe
    for coefficient in _SERIES[-2:0:-1]:
        total += coefficient
        total *= z
    total += _SERIES[0]
    return (math.pi / 6.0) * big + u * total


def _atan_float(t: float) -> float:
    """:func:`_atan_unit` for one Python float: the same operations in the same order (the
    series' loop written out), so the same bits, without the loop's cost."""
    big = t > _TAN_PI_12
    u = big * ((t * _SQRT3 - 1.0) / (t + _SQRT3)) + (1.0 - big) * t
    z = u * u
    c = _SERIES  # Horner's rule, innermost first, exactly as the loop of _atan_unit
    total = (((((((((((((((z * c[15] + c[14]) * z + c[13]) * z + c[12]) * z + c[11]) * z
        + c[10]) * z + c[9]) * z + c[8]) * z + c[7]) * z + c[6]) * z + c[5]) * z + c[4]) * z
        + c[3]) * z + c[2]) * z + c[1]) * z + c[0])  # fmt: skip
    return (math.pi / 6.0) * big + u * total


def _arctan2_float(y: float, x: float) -> float:
    """:func:`arctan2` for two Python floats: the same operations (:func:`minimum`,
    :func:`maximum` and :func:`copysign` written in place), so the same bits."""
    ay, ax = abs(y), abs(x)
    steep = ay > ax
    high = ay if ay >= ax else ax
    low = ay if ay <= ax else ax
    angle = _atan_float(low / (high + (high == 0.0)))
    angle = (math.pi / 2.0) * steep + (1.0 - 2.0 * steep) * angle
    west = 1.0 - math.copysign(1.0, x)
    angle = (math.pi / 2.0) * west + (1.0 - west) * angle
    return math.copysign(angle, y)


def arctan2(y: Any, x: Any) -> Any:
    """The angle of the vector (x, y) from the +x axis, radians in [-pi, pi].

    Within a few ulp of ``math.atan2`` (same quadrant and signed-zero rules), and the same
    bits for scalars and for arrays on every CPU (see the module's docstring): the octant
    is applied with exact steps (a sign flip, adding 0, pi/2 or pi, ``copysign``).
    """
    if type(y) is float and type(x) is float:  # one agent's numbers: the loop-free path
        return _arctan2_float(y, x)
    ay, ax = abs(y), abs(x)
    steep = ay > ax  # the angle is pi/2 - atan(ax / ay)
    high = maximum(ay, ax)
    angle = _atan_unit(minimum(ay, ax) / (high + (high == 0.0)))  # (0, 0) -> atan(0)
    angle = (math.pi / 2.0) * steep + (1.0 - 2.0 * steep) * angle
    west = 1.0 - copysign(1.0, x)  # 0 for x >= +0, 2 for x <= -0: pi - angle
    angle = (math.pi / 2.0) * west + (1.0 - west) * angle
    return copysign(angle, y)


#: (-1)**k / (2k + 1)!, k = 0..8: the sine's series, within 1e-19 of it for |x| <= pi/4.
_SINE = tuple((-1.0) ** k / math.factorial(2 * k + 1) for k in range(9))
#: (-1)**k / (2k)!, k = 0..9: the cosine's series, within 1e-20 of it for |x| <= pi/4.
_COSINE = tuple((-1.0) ** k / math.factorial(2 * k) for k in range(10))
#: Radians per degree.
DEGREE = math.pi / 180.0


def _sincos_float(angle: float) -> tuple[float, float]:
    """:func:`sincos_degrees` of one Python float: the same operations in the same order (the
    series written out), so the same bits."""
    b1 = (angle >= 45.0) * 1.0
    b2 = (angle >= 135.0) * 1.0
    b3 = (angle >= 225.0) * 1.0
    b4 = (angle >= 315.0) * 1.0
    x = (angle - 90.0 * (b1 + b2 + b3 + b4)) * DEGREE
    z = x * x
    s, c = _SINE, _COSINE
    sine = x * ((((((((z * s[8] + s[7]) * z + s[6]) * z + s[5]) * z + s[4]) * z + s[3]) * z
        + s[2]) * z + s[1]) * z + s[0])  # fmt: skip
    cosine = (((((((((z * c[9] + c[8]) * z + c[7]) * z + c[6]) * z + c[5]) * z + c[4]) * z
        + c[3]) * z + c[2]) * z + c[1]) * z + c[0])  # fmt: skip
    swap = b1 - b2 + b3 - b4
    return (
        (1.0 - 2.0 * (b2 - b4)) * (swap * cosine + (1.0 - swap) * sine),
        (1.0 - 2.0 * (b1 - b3)) * (swap * sine + (1.0 - swap) * cosine),
    )


def sincos_degrees(angle: Any) -> tuple[Any, Any]:
    """Sine and cosine of an angle in degrees, ``angle`` in [0, 360) (a number or an array).

    Within a few ulp of the sine and cosine of the exact angle, from ``+ - *`` and comparisons
    alone, so every CPU and SIMD level (and a GPU kernel compiled without FMA contraction)
    gives the same bits; a library's ``sin``/``cos`` do not (see the module's docstring). The
    angle is brought into [-45, 45) degrees by whole quadrants, ``angle - 90 k`` with ``k`` in
    0..4 found by comparisons (exact: the two terms are within a factor two of each other),
    then into radians (one rounding) and the two series evaluated by Horner's rule; the
    quadrant swaps sine and cosine and flips signs by products with 0, 1 and -1 (exact, every
    value is finite), so arrays need no ``numpy.where``. 0, 90, 180 and 270 give exactly 0
    (or -0) and +-1. Arrays of up to :data:`SMALL` agents take the scalar path element by
    element, longer ones are computed in pieces of :data:`CHUNK` (every step is element-wise:
    the same bits).

    Returns:
        (sine, cosine), each the shape of ``angle``.
    """
    if not isinstance(angle, np.ndarray):
        return _sincos_float(float(angle))
    if angle.ndim == 1 and angle.size <= SMALL:
        pairs = [_sincos_float(a) for a in angle.tolist()]
        return (
            np.array([p[0] for p in pairs], dtype=np.float64),
            np.array([p[1] for p in pairs], dtype=np.float64),
        )
    if angle.ndim == 1 and angle.size > CHUNK:
        sine, cosine = np.empty(angle.shape), np.empty(angle.shape)
        for start in range(0, angle.size, CHUNK):
            piece = slice(start, start + CHUNK)
            sine[piece], cosine[piece] = _sincos_array(angle[piece])
        return sine, cosine
    return _sincos_array(angle)


def _sincos_array(angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sincos_degrees` of an array: :func:`_sincos_float`'s operations, in its order."""
    b1 = (angle >= 45.0) * 1.0
    b2 = (angle >= 135.0) * 1.0
    b3 = (angle >= 225.0) * 1.0
    b4 = (angle >= 315.0) * 1.0
    x = (angle - 90.0 * (b1 + b2 + b3 + b4)) * DEGREE
    z = x * x
    sine = z * _SINE[-1]  # new arrays, so the in-place steps below are safe
    for coefficient in _SINE[-2:0:-1]:
        sine += coefficient
        sine *= z
    sine += _SINE[0]
    sine *= x
    cosine = z * _COSINE[-1]
    for coefficient in _COSINE[-2:0:-1]:
        cosine += coefficient
        cosine *= z
    cosine += _COSINE[0]
    swap = b1 - b2 + b3 - b4
    return (
        (1.0 - 2.0 * (b2 - b4)) * (swap * cosine + (1.0 - swap) * sine),
        (1.0 - 2.0 * (b1 - b3)) * (swap * sine + (1.0 - swap) * cosine),
    )


#: Arrays up to this size take the scalar path element by element in :func:`bearing`:
#: NumPy's cost per call (about 40 calls) exceeds the arithmetic for a few agents.
SMALL = 8


#: Arrays longer than this are computed by :func:`bearing` in pieces of this many agents:
#: its ~10 temporaries then take 5 MB, not 80 bytes per agent (1.6 GB at 20 million agents).
CHUNK = 1 << 16


def hypot(dx: Any, dy: Any) -> Any:
    """``sqrt(dx * dx + dy * dy)``: the length of (dx, dy), for one value or arrays.

    Used instead of ``numpy.hypot``/``math.hypot`` wherever a decision reads a distance (the
    datalink's range, sensors): unlike those, ``* + sqrt`` are correctly rounded everywhere.
    (It overflows for lengths above about 1e154 world units, far beyond any world.)
    """
    if isinstance(dx, np.ndarray) or isinstance(dy, np.ndarray):
        return np.sqrt(dx * dx + dy * dy)
    return math.sqrt(dx * dx + dy * dy)


def bearing(x: Any, y: Any, to_x: Any, to_y: Any) -> Any:
    """Heading (degrees clockwise from north, [0, 360)) pointing from (x, y) to (to_x, to_y).

    One body for one agent and for arrays of agents, so both engines get the same bits
    (a small array is computed element by element on the scalar path, a long one in pieces
    of :data:`CHUNK` agents: every step is element-wise, so the same bits too).
    """
    if any(
        isinstance(v, np.ndarray) and v.ndim == 1 and v.size > CHUNK for v in (x, y, to_x, to_y)
    ):
        return _bearing_in_pieces(*np.broadcast_arrays(x, y, to_x, to_y))
    dx, dy = to_x - x, to_y - y
    if isinstance(dx, np.ndarray) or isinstance(dy, np.ndarray):
        ex, ey = np.broadcast_arrays(dx, dy)
        if ex.ndim == 1 and ex.size <= SMALL:
            pairs = zip(ex.tolist(), ey.tolist(), strict=True)
            return np.array([_bearing(a, b) for a, b in pairs], dtype=np.float64)
    return _bearing(dx, dy)


def _bearing_in_pieces(x: np.ndarray, y: np.ndarray, tx: np.ndarray, ty: np.ndarray) -> np.ndarray:
    """:func:`bearing` of arrays of shape (N,), :data:`CHUNK` agents at a time."""
    out = np.empty(x.shape, dtype=np.result_type(x, y, tx, ty, 1.0))
    for start in range(0, x.size, CHUNK):
        piece = slice(start, start + CHUNK)
        out[piece] = _bearing(tx[piece] - x[piece], ty[piece] - y[piece])
    return out


def _bearing(dx: Any, dy: Any) -> Any:
    return wrap_degrees(arctan2(dx, dy) * (180.0 / math.pi))
