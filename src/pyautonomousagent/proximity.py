"""Points near each other, in 2 or 3 dimensions, found on a uniform grid (a cell list).

Transport-level geometry, like the datalink: it knows points, not agents or missions. A
:class:`CellList` buckets N points by the cell of a uniform grid (cells ``width`` wide on
every axis) in O(N) time and memory: each cell's integer coordinates are hashed into one of
2N to 4N buckets, and the points are counting-sorted by bucket. A query then looks only at
the 3**d cells around a point (a cell's points are told from other cells' points of the same
bucket by their cell coordinates), so finding every pair within ``width`` costs time
proportional to the points plus the pairs in neighbouring cells, not N**2, however large or
sparse the world: no array grows with the world's area.

Used by the datalink (:func:`pyautonomousagent.datalink.grid_pairs`: receivers in range of
senders) and by a mission's proximity sensing (:meth:`CellList.near`: every point's nearest
neighbour within a range and the pairs closer than a radius, together).

Distances are compared squared (``dx*dx + dy*dy [+ dz*dz]``: correctly rounded operations,
the same bits compiled or not, on every CPU); a reported distance is the square root of that
sum (also correctly rounded). The loops are compiled with numba where available
(:mod:`pyautonomousagent.jit`), else run as plain Python (the reference, slow for big N).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pyautonomousagent.jit import njit

#: A cell is this much wider than the distance asked for, so that two points within that
#: distance always lie in neighbouring cells despite the rounding of ``(x - low) / width``.
MARGIN = 1e-9
_LOW31 = 0x7FFFFFFF


@njit(inline="always")
def _hash(cell: np.ndarray, extent: np.ndarray, mask: int) -> int:
    """The bucket of the cell with integer coordinates ``cell`` (shape (d,)): its row-major
    number modulo the table's size, so that cells next to each other along x share or
    neighbour buckets (and their points lie near each other in memory)."""
    h = 0
    for k in range(cell.shape[0] - 1, -1, -1):
        h = (h * extent[k] + ((cell[k] + 1) & _LOW31)) & mask
    return h


@njit(inline="always")
def _cell(value: float, low: float, width: float) -> int:
    """The cell number of coordinate ``value`` along one axis: 1 for the lowest point's
    cell, so that every point's neighbours have numbers >= 0 (clamped far outside)."""
    c = math.floor((value - low) / width) + 1.0
    return int(min(max(c, -1.0), 2.0**40))


#: An empty workspace (:func:`workspace`): the grid functions then allocate their arrays anew
#: on every call. Between NumPy's array operations (the batched engine's phases) that is the
#: faster choice: the allocator hands back memory NumPy just freed, still in the CPU's cache,
#: where a workspace kept from call to call has been pushed out by the rest of the iteration.
#: A compiled loop with nothing else allocating between calls keeps a workspace instead: there
#: each new array is fresh pages for the system to map and zero.
FRESH = (np.empty(0, np.int64), np.empty(0))


@njit(inline="always")
def _part(work: np.ndarray, start: int, size: int) -> np.ndarray:
    """``work[start : start + size]``, or a new array of ``size`` where ``work`` is empty."""
    if work.size == 0:
        return np.empty(size, work.dtype)
    return work[start : start + size]


#: A grid built by :func:`_build`: the points' coordinates (d, N) and cells (d, N) in bucket
#: order, their indices in that order (N,), each bucket's first position in it (mask + 2,),
#: the cells per axis (d,) and the bucket mask.
Grid = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]


@njit
def _build(
    axes: tuple[np.ndarray, ...], width: float, mask: int, work: np.ndarray, points: np.ndarray
) -> tuple[np.ndarray, Grid]:
    """The lowest corner (d,) and the :data:`Grid` of the points whose coordinates ``axes``
    holds (one array (N,) per axis). The big arrays are views of ``work`` (int64, at least
    (d + 2) N + 2 mask + 3) and ``points`` (float64, at least d N), or new arrays where
    those are empty (:func:`_part`)."""
    d, n = len(axes), axes[0].shape[0]
    low = np.zeros(d)
    extent = np.ones(d, dtype=np.int64)
    for k in range(d):
        lowest, highest = math.inf, -math.inf
        for i in range(n):
            v = axes[k][i]
            lowest = v if v < lowest else lowest
            highest = v if v > highest else highest
        if n:
            low[k] = lowest
            extent[k] = min(int(math.floor((highest - lowest) / width)) + 3, _LOW31)
    buckets = _part(work, 0, n)
    starts = _part(work, n, mask + 2)
    starts[:] = 0
    cell = np.empty(d, dtype=np.int64)
    for i in range(n):
        for k in range(d):
            cell[k] = _cell(axes[k][i], low[k], width)
        b = _hash(cell, extent, mask)
        buckets[i] = b
        starts[b + 1] += 1
    for b in range(mask + 1):
        starts[b + 1] += starts[b]
    rest = n + mask + 2
    order = _part(work, rest, n)
    sorted_cells = _part(work, rest + n, d * n).reshape((d, n))
    sorted_points = _part(points, 0, d * n).reshape((d, n))
    fill = _part(work, rest + n + d * n, mask + 1)
    fill[:] = starts[:-1]
    for i in range(n):  # stable: a bucket's points in ascending order
        s = fill[buckets[i]]
        fill[buckets[i]] = s + 1
        order[s] = i
        for k in range(d):
            v = axes[k][i]
            sorted_points[k, s] = v
            sorted_cells[k, s] = _cell(v, low[k], width)
    return low, (sorted_points, sorted_cells, order, starts, extent, mask)


@njit
def _row_offsets(d: int) -> np.ndarray:
    """The rows of the 3**d cells around a cell, shape (3**(d-1), d): each row's offset
    from the cell along every axis, -1 along x (the row's first cell), -1, 0 or 1 along the
    others (the last axis varying slowest)."""
    rows = 3 ** (d - 1)
    offsets = np.empty((rows, d), dtype=np.int64)
    for row in range(rows):
        offsets[row, 0] = -1
        rest = row
        for k in range(1, d):
            offsets[row, k] = rest % 3 - 1
            rest //= 3
    return offsets


@njit(inline="always")
def _rows(centre: np.ndarray, offset: np.ndarray, cell: np.ndarray, extent: np.ndarray,
          mask: int, starts: np.ndarray, spans: np.ndarray) -> int:  # fmt: skip
    """The bucket spans holding the three cells x - 1, x, x + 1 of the row ``offset`` (a
    row of :func:`_row_offsets`) around cell ``centre``: one span where their buckets follow
    each other, else three. Puts the row's cell x - 1 into ``cell`` and the spans (start,
    end) into ``spans``; returns their number."""
    for k in range(centre.shape[0]):
        cell[k] = centre[k] + offset[k]
    b = _hash(cell, extent, mask)
    if b + 2 <= mask:
        spans[0, 0] = starts[b]
        spans[0, 1] = starts[b + 3]
        return 1
    for delta in range(3):
        spans[delta, 0] = starts[(b + delta) & mask]
        spans[delta, 1] = starts[((b + delta) & mask) + 1]
    return 3


@njit(inline="always")
def _in_row(cells: np.ndarray, t: int, cell: np.ndarray) -> bool:
    """Whether point ``t``'s cell is one of the three cells from ``cell`` (x - 1) along x."""
    dx = cells[0, t] - cell[0]
    if dx < 0 or dx > 2:
        return False
    for k in range(1, cell.shape[0]):  # noqa: SIM110  (numba: no all() of a generator)
        if cells[k, t] != cell[k]:
            return False
    return True


@njit(inline="always")
def _offer(slot: int, d2: float, j: int, best2: np.ndarray, best: np.ndarray) -> None:
    """Make point ``j`` at squared distance ``d2`` the nearest of ``slot`` if it is nearer
    than the one kept, or as near with a lower index."""
    if d2 < best2[slot] or (d2 == best2[slot] and j < best[slot]):
        best2[slot] = d2
        best[slot] = j


@njit
def _forward(
    grid: Grid,
    range2: float,
    radius2: float,
    best2: np.ndarray,
    best: np.ndarray,
    close: np.ndarray,
    pairs: np.ndarray,
    pairs2: np.ndarray,
    fill: bool,
) -> None:
    """Every pair of points once, from the point of the pair that comes first: each point
    looks at the later points of its own cell and at the cells after it (x + 1 in its row,
    and the rows whose first offset other than 0, counted from the last axis, is +1), half
    the neighbourhood. Without ``fill``: each point's nearest within ``range2`` into
    ``best2``, ``best`` (squared distance, index; inf and -1 before) and, per point, the
    pairs closer than ``radius2`` it found into ``close``; with ``fill``: those pairs
    (lower index first) and squared distances into ``pairs``, ``pairs2``, for the points
    whose ``close`` is not 0. All arrays per point are in bucket order."""
    points, cells, order, starts, extent, mask = grid
    d, n = points.shape
    centre = np.empty(d, dtype=np.int64)
    cell = np.empty(d, dtype=np.int64)
    spans = np.empty((3, 2), dtype=np.int64)
    offsets = _row_offsets(d)
    rows = offsets.shape[0]
    own = (rows - 1) // 2  # the row of offsets 0: the later rows are the cells after it
    written = 0
    for s in range(n):
        if fill and close[s] == 0:
            continue
        i = order[s]
        for k in range(d):
            centre[k] = cells[k, s]
        count = 0
        for row in range(own, rows):
            for span in range(_rows(centre, offsets[row], cell, extent, mask, starts, spans)):
                for t in range(spans[span, 0], spans[span, 1]):
                    if not _in_row(cells, t, cell):
                        continue
                    if row == own:
                        dx = cells[0, t] - centre[0]
                        if dx < 0 or (dx == 0 and t <= s):
                            continue
                    d2 = 0.0
                    for k in range(d):
                        delta = points[k, t] - points[k, s]
                        d2 += delta * delta
                    j = order[t]
                    if not fill and d2 <= range2:
                        _offer(s, d2, j, best2, best)
                        _offer(t, d2, i, best2, best)
                    if d2 < radius2:
                        if fill:
                            pairs[0, written + count] = min(i, j)
                            pairs[1, written + count] = max(i, j)
                            pairs2[written + count] = d2
                        count += 1
        if fill:
            written += count
        else:
            close[s] = count


@njit
def _near_and_pairs(
    grid: Grid,
    range2: float,
    radius2: float,
    none: float,
    work: np.ndarray,
    scratch: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`CellList.near` on a built grid (squared range and radius): each point's
    nearest other point with squared distance <= ``range2`` (lowest index among equals)
    within the range (N,) and its distance (N,) (-1 and ``none`` for none), views of
    ``work`` (int64, at least 3 N) and ``scratch`` (float64, at least 2 N) or new arrays
    where those are empty, and the pairs closer than the radius, first, second (P,) sorted
    by first then second, and their distances (P,). One core: on a machine shared with
    NumPy's work, threads waiting for the next parallel loop slow the rest more than they
    save here."""
    order = grid[2]
    n = order.shape[0]
    nearest, close, best = _part(work, 0, n), _part(work, n, n), _part(work, 2 * n, n)
    distance, best2 = _part(scratch, 0, n), _part(scratch, n, n)
    best2[:n] = math.inf
    best[:n] = -1
    unused = np.empty((2, 0), dtype=np.int64)
    _forward(grid, range2, radius2, best2, best, close, unused, best2, False)
    for s in range(n):
        i = order[s]
        nearest[i] = best[s]
        distance[i] = math.sqrt(best2[s]) if best[s] >= 0 else none
    total = close.sum()
    pairs = np.empty((2, total), dtype=np.int64)
    pairs2 = np.empty(total)
    if total == 0:
        return nearest, distance, pairs[0], pairs[1], pairs2
    # the second pass: only the points that found a pair (close[s] > 0) write them
    _forward(grid, 0.0, radius2, best2, best, close, pairs, pairs2, True)
    by = _pair_order(pairs[0], pairs[1], n)
    return nearest, distance, pairs[0][by], pairs[1][by], np.sqrt(pairs2[by])


#: Above this many pairs of one first point, :func:`_pair_order` sorts them with
#: ``np.argsort`` rather than by insertion.
_FEW_PARTNERS = 16


@njit
def _pair_order(first: np.ndarray, second: np.ndarray, n: int) -> np.ndarray:
    """The order of the pairs (``first``, ``second``, shape (P,) each, points < ``n``, no
    pair twice) by first, then second: a counting sort by first (O(N + P)), then each first
    point's few partners by insertion. (A comparison sort of all the keys cost the batched
    engine's run with collisions about a tenth of its time at 100,000 drones.)"""
    starts = np.zeros(n + 1, dtype=np.int64)
    for p in range(first.size):
        starts[first[p] + 1] += 1
    for a in range(n):
        starts[a + 1] += starts[a]
    fill = starts[:-1].copy()
    by = np.empty(first.size, dtype=np.int64)
    for p in range(first.size):
        a = first[p]
        by[fill[a]] = p
        fill[a] += 1
    for a in range(n):
        low, high = starts[a], starts[a + 1]
        if high - low > _FEW_PARTNERS:
            segment = by[low:high].copy()
            by[low:high] = segment[np.argsort(second[segment])]
            continue
        for i in range(low + 1, high):
            p = by[i]
            j = i - 1
            while j >= low and second[by[j]] > second[p]:
                by[j + 1] = by[j]
                j -= 1
            by[j + 1] = p
    return by


@njit
def workspace(n: int, d: int, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """The scratch arrays :func:`near_all` takes for ``n`` points in ``d`` dimensions within
    ``reach``: int64 and float64 (keep them for the next call)."""
    _, mask = _grid_shape(n, reach)
    return np.empty((d + 5) * n + 2 * mask + 3, np.int64), np.empty((d + 2) * n)


@njit
def _grid_shape(n: int, reach: float) -> tuple[float, int]:
    """The cell width for queries within ``reach`` (1 for reach 0) and the bucket mask for
    ``n`` points: 2N to 4N buckets (at least 2)."""
    width = reach * (1.0 + MARGIN) if reach > 0.0 else 1.0
    bits = 1
    while (1 << bits) < 2 * n:
        bits += 1
    return width, (1 << bits) - 1


@njit
def near_all(
    axes: tuple[np.ndarray, ...], range_: float, radius: float, none: float,
    work: np.ndarray, scratch: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """``CellList(axes, max(range_, radius)).near(range_, radius, none)`` as one compiled
    call (for compiled code that senses the whole swarm every iteration), in the scratch
    arrays of :func:`workspace` (or new ones: :data:`FRESH`): the fields of :class:`Near`
    (nearest and distance are views of them, valid until the next call)."""
    n, d = axes[0].shape[0], len(axes)
    width, mask = _grid_shape(n, max(range_, radius))
    grid_ints = (d + 2) * n + 2 * mask + 3
    _, grid = _build(axes, width, mask, work, scratch)
    range2, radius2 = range_ * range_, radius * radius
    return _near_and_pairs(grid, range2, radius2, none, work[grid_ints:], scratch[d * n :])


@njit
def _candidates(
    query: np.ndarray, low: np.ndarray, width: float, grid: Grid, out: np.ndarray
) -> int:
    """The (query row, point) pairs whose cells neighbour each other into ``out`` (2,
    capacity), as many as fit; returns how many there are."""
    _, cells, order, starts, extent, mask = grid
    d, m = query.shape
    centre = np.empty(d, dtype=np.int64)
    cell = np.empty(d, dtype=np.int64)
    spans = np.empty((3, 2), dtype=np.int64)
    count = 0
    capacity = out.shape[1]
    offsets = _row_offsets(d)
    for q in range(m):
        for k in range(d):
            centre[k] = _cell(query[k, q], low[k], width)
        for row in range(offsets.shape[0]):
            for span in range(_rows(centre, offsets[row], cell, extent, mask, starts, spans)):
                for t in range(spans[span, 0], spans[span, 1]):
                    if _in_row(cells, t, cell):
                        if count < capacity:
                            out[0, count] = q
                            out[1, count] = order[t]
                        count += 1
    return count


@dataclass(frozen=True)
class Near:
    """What :meth:`CellList.near` found.

    Attributes:
        nearest: each point's nearest other point within the range, shape (N,) int64 (the
            lowest index among equally near ones), -1 for none.
        distance: the distance to it (world units), shape (N,); ``none`` (inf unless
            asked otherwise) where there is none.
        first, second: the pairs closer than the radius, first < second, shape (P,) int64,
            sorted by first then second.
        pair_distance: their distances (world units), shape (P,).
    """

    nearest: np.ndarray
    distance: np.ndarray
    first: np.ndarray
    second: np.ndarray
    pair_distance: np.ndarray


class CellList:
    """Points bucketed on a uniform grid, for queries within ``reach`` of them.

    Args:
        coordinates: the points' coordinates, one array of shape (N,) per axis (x, y or
            x, y, z), world units.
        reach: the largest distance queries ask for (world units, >= 0); cells are that
            wide (plus :data:`MARGIN`).
    """

    def __init__(self, coordinates: Sequence[np.ndarray], reach: float) -> None:
        axes = tuple(np.ascontiguousarray(c, dtype=np.float64) for c in coordinates)
        if not axes or any(a.shape != axes[0].shape or a.ndim != 1 for a in axes):
            raise ValueError("CellList: one array of shape (N,) per axis")
        self.reach = float(reach)
        self.width, mask = _grid_shape(axes[0].size, self.reach)
        self.low, self.grid = _build(axes, self.width, mask, *FRESH)

    def near(self, range_: float, radius: float, none: float = math.inf) -> Near:
        """Every point's nearest neighbour within ``range_`` (distance <= ``range_``; distance
        ``none`` where there is none) and every pair closer than ``radius`` (distance <
        radius), both at most ``reach``: one pass over the points (each pair looked at once),
        and a second over the few that found a pair. Time: O(N + pairs in neighbouring
        cells)."""
        if max(range_, radius) > self.reach:
            raise ValueError(f"near: range {range_} and radius {radius} must be <= {self.reach}")
        range2, radius2 = range_ * range_, radius * radius
        return Near(*_near_and_pairs(self.grid, range2, radius2, none, *FRESH))

    def candidates(self, coordinates: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """(query row, point) of every query point and grid point in neighbouring cells: a
        superset of the pairs within ``reach`` (filter them by distance). Shape (P,) each,
        unordered."""
        query = np.ascontiguousarray(np.array(coordinates, dtype=np.float64, ndmin=2))
        capacity = max(64, 4 * query.shape[1])
        while True:
            out = np.empty((2, capacity), dtype=np.int64)
            count = _candidates(query, self.low, self.width, self.grid, out)
            if count <= capacity:
                return out[0, :count], out[1, :count]
            capacity = count
