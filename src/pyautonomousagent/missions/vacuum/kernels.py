"""The vacuum robot's leaves, sonar, stop rule and cleaning grid for one robot (compiled engine).

Each function repeats, operation for operation, the NumPy code named in its docstring
(``leaves.py``; ``room.py``'s ``Room.sonar``, ``Room.blocked`` and ``CleaningGrid.clean``;
the mission's ``sense``) on agent row ``a`` of the arrays it is given (shape (N,)), with
:mod:`pyautonomousagent.kernels`' helpers for NumPy's element-wise rules (``np_minimum``,
``np_maximum``, ``wrap_degrees``, ``sincos_degrees``); the compiled-engine tests hold the two
equal bit for bit. Squares are written ``v * v`` (NumPy's ``v ** 2`` of an array is
``numpy.square``, the same one rounding). Statuses are the codes of :mod:`pyautonomousagent.bt`.
"""

from __future__ import annotations

import math

import numpy as np

from pyautonomousagent.bt import FAILURE, SUCCESS
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import np_maximum, np_minimum, sincos_degrees, wrap_degrees
from pyautonomousagent.randomness import uniform_of_one


@njit(inline="always")
def collision(a: int, sonar: np.ndarray, distance: float) -> int:
    """Condition_Collision: SUCCESS if ``sonar[a] < distance``."""
    return SUCCESS if sonar[a] < distance else FAILURE


@njit(inline="always")
def avoid(a: int, t: int, heading: np.ndarray, cruise_heading: np.ndarray,
          requested_speed: np.ndarray, requested_heading: np.ndarray, seed_high: int,
          seed_low: int, stream: int, min_angle: float, max_angle: float,
          step: float) -> int:  # fmt: skip
    """Action_Avoid_Obstacle_S at iteration ``t``: where the robot holds its cruise heading
    (less than ``step`` degrees off it; exactly on it for ``step`` 0), a new cruise heading
    turned right or left (draw 0 of ``Leaf.uniform`` below 0.5: right) by an angle in
    [min_angle, max_angle) (draw 1) cut to whole ``step`` multiples (at least one step);
    speed 0 toward the cruise heading; SUCCESS. (A draw is a pure function of its key, so
    drawing only where it is used gives the NumPy leaf's numbers.)"""
    h = heading[a]
    goal = cruise_heading[a]
    off = wrap_degrees(h - goal)
    off = np_minimum(off, 360.0 - off)  # degrees still to turn, [0, 180]
    settled = off < step if step > 0.0 else off <= 0.0
    if settled:
        right = uniform_of_one(seed_high, seed_low, stream, a, t, 0.0, 1.0, 0) < 0.5
        angle = uniform_of_one(seed_high, seed_low, stream, a, t, min_angle, max_angle, 1)
        if step > 0.0:
            angle = np_maximum(step * math.floor(angle / step), step)
        goal = wrap_degrees(h + (angle if right else -angle))
    cruise_heading[a] = goal
    requested_heading[a] = goal
    requested_speed[a] = 0.0
    return SUCCESS


@njit(inline="always")
def navigate(a: int, cruise_heading: np.ndarray, requested_speed: np.ndarray,
             requested_heading: np.ndarray, speed: float) -> int:  # fmt: skip
    """Action_Navigate_S: the cruise heading at ``speed``; SUCCESS."""
    requested_heading[a] = cruise_heading[a]
    requested_speed[a] = speed
    return SUCCESS


@njit(inline="always")
def brush(a: int, vacuuming: np.ndarray) -> int:
    """Action_Vacuum_S: the brush on for this iteration; SUCCESS."""
    vacuuming[a] = 1
    return SUCCESS


@njit(inline="always")
def _slab(p: float, d: float, low: float, high: float) -> tuple[float, float]:
    """``room._slab`` of one ray and one slab: where p + t d enters and leaves [low, high]."""
    if d == 0.0:
        inside = p >= low and p <= high
        return (-math.inf, math.inf) if inside else (math.inf, -math.inf)
    t1 = (low - p) / d
    t2 = (high - p) / d
    return np_minimum(t1, t2), np_maximum(t1, t2)


@njit(inline="always")
def _wall(p: float, d: float, size: float) -> float:
    """The distance along one axis of ``Room._walls``: to ``size`` ahead, to 0 behind."""
    if d > 0.0:
        return (size - p) / d
    if d < 0.0:
        return -p / d
    return math.inf


@njit(inline="always")
def sonar_reading(px: float, py: float, dx: float, dy: float, rects: np.ndarray,
                  circles: np.ndarray, width: float, height: float,
                  reach: float) -> float:  # fmt: skip
    """``Room.sonar`` of one robot at (px, py) looking along the unit vector (dx, dy): the
    walls, then the rectangles (K, 4: x0, y0, x1, y1), then the circles (M, 3: x, y, r),
    world units in [0, reach]."""
    nearest = np_minimum(np_maximum(np_minimum(_wall(px, dx, width), _wall(py, dy, height)),
                                    0.0), reach)  # fmt: skip
    if rects.shape[0]:
        best = math.inf
        for k in range(rects.shape[0]):
            enter_x, leave_x = _slab(px, dx, rects[k, 0], rects[k, 2])
            enter_y, leave_y = _slab(py, dy, rects[k, 1], rects[k, 3])
            enter = np_maximum(enter_x, enter_y)
            ahead = np_maximum(enter, 0.0)
            if np_minimum(leave_x, leave_y) >= ahead:
                best = np_minimum(best, ahead)
        nearest = np_minimum(nearest, best)
    if circles.shape[0]:
        best = math.inf
        for k in range(circles.shape[0]):
            qx = px - circles[k, 0]
            qy = py - circles[k, 1]
            r = circles[k, 2]
            b = qx * dx + qy * dy
            c = qx * qx + qy * qy - r * r
            root = math.sqrt(np_maximum(b * b - c, 0.0))
            if b * b - c >= 0.0 and -b + root >= 0.0:
                best = np_minimum(best, np_maximum(-b - root, 0.0))
        nearest = np_minimum(nearest, best)
    return nearest


@njit(inline="always")
def blocked(px: float, py: float, rects: np.ndarray, circles: np.ndarray, width: float,
            height: float, m: float) -> bool:  # fmt: skip
    """``Room.blocked`` of one point with margin ``m``: outside the room or in (or on) an
    obstacle grown by ``m``."""
    if px < m or px > width - m or py < m or py > height - m:
        return True
    for k in range(rects.shape[0]):
        if (px >= rects[k, 0] - m and px <= rects[k, 2] + m and py >= rects[k, 1] - m
                and py <= rects[k, 3] + m):  # fmt: skip
            return True
    for k in range(circles.shape[0]):
        qx = px - circles[k, 0]
        qy = py - circles[k, 1]
        grown = circles[k, 2] + m
        if qx * qx + qy * qy <= grown * grown:
            return True
    return False


@njit(inline="always")
def sonar_and_stop(a: int, x: np.ndarray, y: np.ndarray, speed: np.ndarray,
                   heading: np.ndarray, sonar: np.ndarray, rects: np.ndarray,
                   circles: np.ndarray, width: float, height: float, reach: float,
                   margin: float) -> bool:  # fmt: skip
    """``VacuumMission.sense`` for robot ``a``, less the cleaning (:func:`clean_grid`): the
    sonar reading, and whether its next step (``next_position``) stays in the room and
    ``margin`` clear of every obstacle (True: it moves)."""
    px = x[a]
    py = y[a]
    v = speed[a]
    sine, cosine = sincos_degrees(heading[a])
    sonar[a] = sonar_reading(px, py, sine, cosine, rects, circles, width, height, reach)
    return not blocked(px + v * sine, py + v * cosine, rects, circles, width, height, margin)


#: ``winner``'s entry of a cell no robot claimed (``device.claim_cell``).
NOBODY = np.iinfo(np.int64).max


@njit(inline="always")
def cell_of(px: float, py: float, cell: float, rows: int, cols: int) -> tuple[int, int]:
    """``CleaningGrid.clean``'s cell (row, column) under a robot at (px, py). ``int`` of the
    floor: numba's CUDA target types ``math.floor`` of a float as a float (its CPU target as
    an int), and a float cannot index the grid on the device."""
    row = min(max(int(math.floor(py / cell)), 0), rows - 1)
    col = min(max(int(math.floor(px / cell)), 0), cols - 1)
    return row, col


@njit
def clean_grid(t: int, x: np.ndarray, y: np.ndarray, vacuuming: np.ndarray,
               cleaned_cells: np.ndarray, free: np.ndarray, cleaned: np.ndarray,
               fresh: np.ndarray, winner: np.ndarray, cell: float) -> int:  # fmt: skip
    """``CleaningGrid.clean`` of the whole swarm at the start of iteration ``t``
    (``SwarmSensorKernel.detect``): the robots whose brush ran (``vacuuming`` 1), in row
    order, each cleaning the free (``free``: bool, (rows, columns)) cell under it if it is
    not ``cleaned`` yet; ``fresh[a]``: 1 where robot ``a`` cleaned its cell first (a cell two
    robots clean at once counts for the lower row), else 0. (``winner``, shape (rows *
    columns,), is the device form's: ``device.claim_cell``.) Returns 0."""
    rows, cols = cleaned.shape
    for a in range(x.shape[0]):
        fresh[a] = 0
        if vacuuming[a] == 1:
            row, col = cell_of(x[a], y[a], cell, rows, cols)
            if free[row, col] and not cleaned[row, col]:
                cleaned[row, col] = True
                fresh[a] = 1
    return 0


@njit(inline="always")
def count_cleaned(a: int, moving: bool, x: np.ndarray, y: np.ndarray, vacuuming: np.ndarray,
                  cleaned_cells: np.ndarray, free: np.ndarray, cleaned: np.ndarray,
                  fresh: np.ndarray, winner: np.ndarray, cell: float) -> None:  # fmt: skip
    """Robot ``a``'s share of :func:`clean_grid` (``SwarmSensorKernel.apply``): its fresh
    cell added to ``cleaned_cells``, the brush off until the tree runs it again."""
    cleaned_cells[a] += fresh[a]
    vacuuming[a] = 0
