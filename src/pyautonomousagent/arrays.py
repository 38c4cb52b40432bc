"""Helpers that work alike on one agent's numbers and on arrays of many agents.

Leaf nodes are written once for both engines: the py_trees engine calls them with
scalars (one agent), the batched engine with arrays. NumPy on scalars costs about a
microsecond a call, so these helpers take the plain-Python path for scalars. Both paths
use only IEEE operations that are correctly rounded on every CPU (``+ - * /``, comparisons,
``abs``), so the two engines compute the same bits on every machine and SIMD level.
Library functions such as ``atan2`` are not: NumPy's AVX-512 ``arctan2`` differs from
``math.atan2`` by one ulp on about 8 % of inputs, so :func:`bearing` computes its arctangent
from those operations alone, with one body for scalars and arrays.
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


#: 1 / (2k + 1), k = 0..15: the arctangent's series, enough for |t| <= tan(pi / 12).
_SERIES = tuple(1.0 / (2 * k + 1) * (-1.0) ** k for k in range(16))
_TAN_PI_12 = 2.0 - math.sqrt(3.0)
_SQRT3 = math.sqrt(3.0)


def _atan_unit(t: Any) -> Any:
    """``atan(t)`` for t in [0, 1], from ``+ - * /`` only (radians; scalar or array).

    Above tan(pi/12) the argument is reduced with atan(t) = pi/6 + atan((sqrt(3) t - 1) /
    (t + sqrt(3))), which brings it into [-tan(pi/12), tan(pi/12)]; there 16 terms of the
    series ``t - t**3/3 + t**5/5 - ...`` are within 1e-17 of the true value.
    """
    big = t > _TAN_PI_12
    u = choose(big, (t * _SQRT3 - 1.0) / (t + _SQRT3), t)
    z = u * u
    total = z * _SERIES[-1]  # a new array (or float), so the in-place steps below are safe
    for coefficient in _SERIES[-2:0:-1]:
        total += coefficient
        total *= z
    total += _SERIES[0]
    return choose(big, math.pi / 6.0 + u * total, u * total)


def arctan2(y: Any, x: Any) -> Any:
    """The angle of the vector (x, y) from the +x axis, radians in [-pi, pi].

    Agrees with ``math.atan2`` to within a few ulp, and gives the same bits for scalars and
    for arrays, on every CPU (see the module's docstring). (0, 0) gives 0.
    """
    ay, ax = abs(y), abs(x)
    low, high = minimum(ay, ax), maximum(ay, ax)
    ratio = low / choose(high > 0.0, high, 1.0)
    angle = _atan_unit(ratio)
    angle = choose(ay > ax, math.pi / 2.0 - angle, angle)
    angle = choose(x < 0.0, math.pi - angle, angle)
    return choose(y < 0.0, -angle, angle)


def bearing(x: Any, y: Any, to_x: Any, to_y: Any) -> Any:
    """Heading (degrees clockwise from north, [0, 360)) pointing from (x, y) to (to_x, to_y).

    One body for one agent and for arrays of agents, so both engines get the same bits.
    """
    return wrap_degrees(arctan2(to_x - x, to_y - y) * (180.0 / math.pi))
