"""The vacuum robot's room: obstacles, the sonar, the stop rule and the grid of cleaned cells.

Positions are world units, headings degrees clockwise from north (+y), as everywhere in
pyAutonomousAgent. The room is ``[0, width] x [0, height]``; its walls and the obstacles are
what the sonar sees and what a robot may never enter. Every function works on the whole
swarm's arrays of shape ``(N,)`` at once, against all obstacles at once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pyautonomousagent.arrays import sincos_degrees
from pyautonomousagent.mission import Reader, ScenarioError


@dataclass(frozen=True)
class Rectangle:
    """An axis-aligned rectangular obstacle: lower-left corner (x, y), width x height."""

    shape: str = field(default="rect", init=False, repr=False)
    x: float
    y: float
    width: float
    height: float


@dataclass(frozen=True)
class Circle:
    """A round obstacle: centre (x, y), radius."""

    shape: str = field(default="circle", init=False, repr=False)
    x: float
    y: float
    radius: float


Obstacle = Rectangle | Circle


def extent(o: Obstacle) -> tuple[float, float, float, float]:
    """The smallest box holding the obstacle ``o``: (x0, y0, x1, y1), world units."""
    if isinstance(o, Rectangle):
        return o.x, o.y, o.x + o.width, o.y + o.height
    return o.x - o.radius, o.y - o.radius, o.x + o.radius, o.y + o.radius


def check_inside(reader: Reader, obstacles: tuple[Obstacle, ...], size: tuple[float, float],
                 path: str) -> None:  # fmt: skip
    """Raise ScenarioError naming the first obstacle not wholly inside the room
    ``[0, width] x [0, height]`` (one touching a wall is inside)."""
    width, height = size
    for i, obstacle in enumerate(obstacles):
        x0, y0, x1, y1 = extent(obstacle)
        if not (0.0 <= x0 <= x1 <= width and 0.0 <= y0 <= y1 <= height):
            raise ScenarioError(
                f"{reader.source}: {path}[{i}] (a {obstacle.shape} spanning x {x0:g}..{x1:g}, "
                f"y {y0:g}..{y1:g}) must lie inside the room [0, {width:g}] x [0, {height:g}]; "
                "move it or enlarge the world"
            )


MAX_OBSTACLES = 1000
"""The most obstacles a room may have (the sonar looks at every one for every robot)."""
_FIELDS = {"rect": ("x", "y", "width", "height"), "circle": ("x", "y", "radius")}


def read_obstacles(reader: Reader, data: Any, path: str) -> tuple[Obstacle, ...]:
    """``world.obstacles``: a list of ``{shape: rect, x, y, width, height}`` (lower-left corner)
    and ``{shape: circle, x, y, radius}``, world units."""
    if not isinstance(data, list) or len(data) > MAX_OBSTACLES:
        must = f"a list of at most {MAX_OBSTACLES} {{shape: rect|circle, ...}} obstacles"
        raise reader.fail(path, must, data)
    obstacles: list[Obstacle] = []
    for i, item in enumerate(data):
        where = f"{path}[{i}]"
        shape = item.get("shape") if isinstance(item, dict) else None
        if shape not in _FIELDS:
            raise reader.fail(f"{where}.shape", "rect or circle", shape)
        fields = _FIELDS[shape]
        given = reader.keys(item, where, ["shape", *fields], list(fields))
        above = dict.fromkeys(fields[2:], 0.0)  # width, height, radius > 0
        values = [reader.number(given[k], f"{where}.{k}", above=above.get(k)) for k in fields]
        obstacles.append(Rectangle(*values) if shape == "rect" else Circle(*values))
    return tuple(obstacles)


class Room:
    """The walls and obstacles as arrays, for the sonar and the stop rule.

    Args:
        width, height: the room, world units.
        obstacles: the obstacles in it.
    """

    def __init__(self, width: float, height: float, obstacles: tuple[Obstacle, ...]) -> None:
        self.width = width
        self.height = height
        rects = [extent(o) for o in obstacles if isinstance(o, Rectangle)]
        circles = [(o.x, o.y, o.radius) for o in obstacles if isinstance(o, Circle)]
        self.rects = np.asarray(rects, dtype=np.float64).reshape(-1, 4)  # x0, y0, x1, y1
        self.circles = np.asarray(circles, dtype=np.float64).reshape(-1, 3)  # x, y, r

    def blocked(self, x: np.ndarray, y: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Whether (x, y) lies outside the room or in (or on the edge of) an obstacle, with
        walls and obstacles grown by ``margin``.

        Args:
            x, y: positions, shape (N,).
            margin: world units added around every obstacle and inside every wall.

        Returns:
            bool, shape (N,).
        """
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        m = margin
        outside = (x < m) | (x > self.width - m) | (y < m) | (y > self.height - m)
        px, py = x[:, None], y[:, None]
        r = self.rects
        in_rect = (
            (px >= r[:, 0] - m) & (px <= r[:, 2] + m) & (py >= r[:, 1] - m) & (py <= r[:, 3] + m)
        )
        c = self.circles
        in_circle = (px - c[:, 0]) ** 2 + (py - c[:, 1]) ** 2 <= (c[:, 2] + m) ** 2
        return outside | in_rect.any(axis=1) | in_circle.any(axis=1)

    def sonar(self, x: np.ndarray, y: np.ndarray, heading: np.ndarray, reach: float) -> np.ndarray:
        """Distance from (x, y) along ``heading`` to the nearest wall or obstacle.

        Args:
            x, y: positions, shape (N,), inside the room.
            heading: degrees clockwise from north, [0, 360), shape (N,) (sine and cosine from
                :func:`~pyautonomousagent.arrays.sincos_degrees`: the same bits on every CPU
                and in a GPU kernel).
            reach: the sonar's range: longer distances read as ``reach`` (world units).

        Returns:
            World units in [0, reach], shape (N,); 0 for a position on an obstacle's edge
            facing into it.
        """
        dx, dy = sincos_degrees(np.asarray(heading, dtype=np.float64))
        with np.errstate(divide="ignore", invalid="ignore"):
            nearest = np.minimum(self._walls(x, y, dx, dy), reach)
            if len(self.rects):
                nearest = np.minimum(nearest, _ray_rectangles(x, y, dx, dy, self.rects))
            if len(self.circles):
                nearest = np.minimum(nearest, _ray_circles(x, y, dx, dy, self.circles))
        return nearest

    def _walls(self, x: np.ndarray, y: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """Distance along (dx, dy) to the room's walls, shape (N,)."""
        to_x = np.where(dx > 0.0, (self.width - x) / dx, np.where(dx < 0.0, -x / dx, np.inf))
        to_y = np.where(dy > 0.0, (self.height - y) / dy, np.where(dy < 0.0, -y / dy, np.inf))
        return np.maximum(np.minimum(to_x, to_y), 0.0)


def _slab(p: np.ndarray, d: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[Any, Any]:
    """Ray parameters (N, K) where p + t d enters and leaves the slab [low, high] of one axis;
    (-inf, inf) inside a slab the ray runs along, (inf, -inf) outside it."""
    p, d = p[:, None], d[:, None]
    t1, t2 = (low - p) / d, (high - p) / d
    along = d == 0.0
    inside = (p >= low) & (p <= high)
    enter = np.where(along, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    leave = np.where(along, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    return enter, leave


def _ray_rectangles(
    x: np.ndarray, y: np.ndarray, dx: np.ndarray, dy: np.ndarray, rects: np.ndarray
) -> np.ndarray:
    """Distance along the unit rays (N,) to the nearest of the rectangles (K, 4); inf if none."""
    enter_x, leave_x = _slab(x, dx, rects[:, 0], rects[:, 2])
    enter_y, leave_y = _slab(y, dy, rects[:, 1], rects[:, 3])
    enter = np.maximum(enter_x, enter_y)
    leave = np.minimum(leave_x, leave_y)
    hit = leave >= np.maximum(enter, 0.0)
    return np.where(hit, np.maximum(enter, 0.0), np.inf).min(axis=1)


def _ray_circles(
    x: np.ndarray, y: np.ndarray, dx: np.ndarray, dy: np.ndarray, circles: np.ndarray
) -> np.ndarray:
    """Distance along the unit rays (N,) to the nearest of the circles (M, 3); inf if none."""
    px, py = x[:, None] - circles[:, 0], y[:, None] - circles[:, 1]
    b = px * dx[:, None] + py * dy[:, None]
    c = px * px + py * py - circles[:, 2] ** 2
    root = np.sqrt(np.maximum(b * b - c, 0.0))
    hit = (b * b - c >= 0.0) & (-b + root >= 0.0)
    return np.where(hit, np.maximum(-b - root, 0.0), np.inf).min(axis=1)


class CleaningGrid:
    """The room as square cells, each cleaned or not. Only free cells (centre clear of every
    obstacle) count: a robot brushing along an obstacle's edge cleans nothing in a cell whose
    centre lies under the obstacle.

    Args:
        room: the room (its size and obstacles).
        cell: the side of a cell, world units.

    Attributes:
        cleaned: bool, shape (rows, columns); row 0 is the bottom (y in [0, cell)).
        free: bool, shape (rows, columns): the cells a robot can clean.
    """

    def __init__(self, room: Room, cell: float) -> None:
        self.cell = cell
        self.rows = max(1, int(np.ceil(room.height / cell)))
        self.cols = max(1, int(np.ceil(room.width / cell)))
        centre_y, centre_x = np.mgrid[0 : self.rows, 0 : self.cols] * cell + cell / 2
        inside = ~room.blocked(centre_x.ravel(), centre_y.ravel())
        self.free = inside.reshape(self.rows, self.cols)
        self.cleaned = np.zeros((self.rows, self.cols), dtype=bool)

    def clean(self, x: np.ndarray, y: np.ndarray, brushing: np.ndarray) -> np.ndarray:
        """Clean the cell under each robot whose brush is on: row ``floor(y / cell)``,
        column ``floor(x / cell)`` (a correctly rounded division, the same bits on a GPU).

        Args:
            x, y: positions, shape (N,).
            brushing: bool, shape (N,).

        Returns:
            int64, shape (N,): the free cells each robot cleaned first (a cell two robots clean
            at once counts for the lower row).
        """
        fresh = np.zeros(np.shape(x), dtype=np.int64)
        who = np.flatnonzero(brushing)
        if who.size == 0:
            return fresh
        row = np.clip(np.floor(y[who] / self.cell).astype(np.int64), 0, self.rows - 1)
        col = np.clip(np.floor(x[who] / self.cell).astype(np.int64), 0, self.cols - 1)
        flat = row * self.cols + col
        new = self.free.ravel()[flat] & ~self.cleaned.ravel()[flat]
        cells, first = np.unique(flat[new], return_index=True)
        self.cleaned.flat[cells] = True
        np.add.at(fresh, who[new][first], 1)
        return fresh

    def coverage(self) -> float:
        """The fraction of the free cells cleaned so far, in [0, 1]."""
        return float(self.cleaned.sum() / max(1, self.free.sum()))
