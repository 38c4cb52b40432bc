"""The GPU engine's datalink grid: one message type's messages grouped by cell on the device.

A delivery that reached only some agents hands each receiver the messages within the
datalink's range of it (``hypot(receiver - sender) <= range``, the batched engine's test),
in message order. Testing every message for every receiver is O(N * M) work; instead the
messages are grouped on a uniform grid whose cells are at least the range wide (the
device's analogue of :class:`~pyautonomousagent.proximity.CellList`), so a receiver tests
only the messages of its own and the 8 neighbouring cells:

1. :func:`geometry` (on the host, from the agents' and senders' bounding box): the grid's
   lowest corner, cell side (the range plus :data:`MARGIN`, doubled while the grid would
   have more than ``limit`` cells or :data:`AXIS` cells along an axis: memory O(N + M))
   and cells per axis.
2. ``_count``: one thread per message, its cell (:func:`cell_of`, row-major) and
   ``cuda.atomic.add`` of the cell's count; an exclusive prefix sum of the counts gives
   each cell's first place (``starts``, shape (cells + 1,)).
3. ``_place``: each message to its cell's segment of ``order``, at a place taken by
   counting the cell's count down atomically (the counts are all zero again afterwards:
   allocated once, never cleared); ``_sort``: one thread per cell sorts its segment by
   message index (heapsort), so the grouping does not depend on the atomics' order.
4. The generated ``handle_near_<k>`` (:mod:`~pyautonomousagent.engines.gpu_source`): each
   receiver's up to 9 cells (:func:`cell_spans`) merged by message index
   (:func:`next_message`, a merge over the segments' heads), the ones in range handled.

Why neighbouring cells suffice: ``hypot`` <= range bounds each axis' computed difference
by the range times (1 + 2**-51), and a cell's number ``floor((v - low) / side)`` is off
its exact value by less than ``AXIS * 2**-50`` (~1e-9) cells, far below the 1e-6 margin
of the side: two points in range lie in the same or neighbouring cells.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import cuda as numba_cuda

from pyautonomousagent.engines.cuda_jit import kernel
from pyautonomousagent.engines.gpu_reduce import Workspace, exclusive_scan, shape
from pyautonomousagent.jit import njit

cuda: Any = numba_cuda  # numba's stubs type cuda.grid poorly

#: A cell's side is the range times (1 + MARGIN) at least (see the module's docstring).
MARGIN = 1e-6

#: The most cells along one axis (the cell numbers' rounding stays below the margin).
AXIS = 1 << 20

#: The geometry of a grid of one cell (every message a candidate of every receiver): for
#: positions that are not finite, or a range that is not positive.
ONE_CELL = (0.0, 0.0, 1.0, 1, 1)


def geometry(
    box: tuple[float, ...], reach: float, limit: int
) -> tuple[float, float, float, int, int]:
    """The grid over ``box`` (low x, high x, low y, high y: world units) for ``reach``:
    (low x, low y, cell side, cells along x, cells along y), at most ``limit`` cells."""
    low_x, high_x, low_y, high_y = box
    side = reach * (1.0 + MARGIN)
    if not (side > 0.0 and all(math.isfinite(v) for v in box)):
        return ONE_CELL
    while True:
        along_x = int((high_x - low_x) / side) + 1
        along_y = int((high_y - low_y) / side) + 1
        if max(along_x, along_y) <= AXIS and along_x * along_y <= max(1, limit):
            return low_x, low_y, side, along_x, along_y
        side *= 2.0


@njit(inline="always")
def cell_of(v: float, low: float, side: float, cells: int) -> int:
    """The cell (0 .. ``cells`` - 1) of coordinate ``v`` along one axis: ``floor((v -
    low) / side)``, clamped (a NaN: cell 0)."""
    u = (v - low) / side
    if not u >= 1.0:
        return 0
    if u >= cells - 1:
        return cells - 1
    return int(u)


@njit
def cell_spans(x: float, y: float, grid: Any, starts: Any, heads: Any, ends: Any) -> int:
    """The segments of ``order`` holding the messages of the cells around (``x``, ``y``)
    (its own and the neighbouring ones inside the grid, at most 9): their starts into
    ``heads``, their ends into ``ends``; returns their number. ``grid``: the geometry
    (low x, low y, side, cells along x, cells along y), shape (5,)."""
    along_x, along_y = int(grid[3]), int(grid[4])
    cx = cell_of(x, grid[0], grid[2], along_x)
    cy = cell_of(y, grid[1], grid[2], along_y)
    spans = 0
    for row in range(max(cy - 1, 0), min(cy + 2, along_y)):
        for column in range(max(cx - 1, 0), min(cx + 2, along_x)):
            c = row * along_x + column
            if starts[c + 1] > starts[c]:
                heads[spans], ends[spans] = starts[c], starts[c + 1]
                spans += 1
    return spans


@njit
def next_message(heads: Any, ends: Any, spans: int, order: Any) -> int:
    """The lowest message index at the ``spans`` segments' heads (each sorted ascending),
    that head moved on; -1 once all are done."""
    best, m = -1, -1
    for s in range(spans):
        if heads[s] < ends[s] and (best < 0 or order[heads[s]] < m):
            best, m = s, order[heads[s]]
    if best >= 0:
        heads[best] += 1
    return m


@kernel
def _count(sx: Any, sy: Any, count: int, grid: Any, cell: Any, filled: Any) -> None:
    """Message ``m``'s cell into ``cell[m]``, counted in ``filled[cell]``."""
    m = cuda.grid(1)
    if m >= count:
        return
    along_x, along_y = int(grid[3]), int(grid[4])
    cx = cell_of(sx[m], grid[0], grid[2], along_x)
    cy = cell_of(sy[m], grid[1], grid[2], along_y)
    cell[m] = cy * along_x + cx
    cuda.atomic.add(filled, cy * along_x + cx, 1)


@kernel
def _place(cell: Any, starts: Any, filled: Any, count: int, order: Any) -> None:
    """Message ``m`` into its cell's segment of ``order``, counting ``filled`` down."""
    m = cuda.grid(1)
    if m >= count:
        return
    c = cell[m]
    order[starts[c] + cuda.atomic.add(filled, c, -1) - 1] = m


@kernel(device=True)
def _sift(values: Any, first: int, root: int, size: int) -> None:
    """Restore the max-heap ``values[first:first + size]`` below ``root``."""
    while 2 * root + 1 < size:
        child = 2 * root + 1
        if child + 1 < size and values[first + child + 1] > values[first + child]:
            child += 1
        if values[first + root] >= values[first + child]:
            return
        values[first + root], values[first + child] = values[first + child], values[first + root]
        root = child


@kernel
def _sort(starts: Any, order: Any, cells: int) -> None:
    """Cell ``c``'s segment of ``order`` sorted ascending (heapsort: O(s log s), in place)."""
    c = cuda.grid(1)
    if c >= cells:
        return
    first, size = starts[c], starts[c + 1] - starts[c]
    for root in range(size // 2 - 1, -1, -1):
        _sift(order, first, root, size)
    for end in range(size - 1, 0, -1):
        order[first], order[first + end] = order[first + end], order[first]
        _sift(order, first, 0, end)


class DeviceGrid:
    """One message type's grid on the device, its arrays allocated once.

    Args:
        slots: the most messages of the type (its inbox's size); the grid has at most
            twice as many cells.

    Attributes:
        grid: the geometry (low x, low y, side, cells along x, cells along y), device (5,).
        starts: each cell's first place in ``order``, device int64 (cells + 1,).
        order: the message indices, grouped by cell, ascending in each; device int64
            (slots,).
        cells: the number of cells of the last grouping.
    """

    def __init__(self, slots: int) -> None:
        self.limit = 2 * max(1, slots)
        self.grid = cuda.to_device(np.array(ONE_CELL, dtype=np.float64))
        self.filled = cuda.to_device(np.zeros(self.limit + 1, dtype=np.int64))
        self.starts = cuda.to_device(np.zeros(self.limit + 1, dtype=np.int64))
        self.cell = cuda.device_array(max(1, slots), np.int64)
        self.order = cuda.device_array(max(1, slots), np.int64)
        self.work = Workspace()  # the prefix sum's temporaries
        self.cells = 1

    def group(self, sx: Any, sy: Any, count: int, box: tuple[float, ...], reach: float) -> None:
        """Group the first ``count`` messages at ``sx``, ``sy`` (device arrays, world units)
        on the grid over ``box`` (low x, high x, low y, high y of the agents and senders)."""
        layout = geometry(box, reach, self.limit)
        self.grid.copy_to_device(np.array(layout, dtype=np.float64))
        self.cells = layout[3] * layout[4]
        _count[shape(count)](sx, sy, count, self.grid, self.cell, self.filled)
        exclusive_scan(self.filled[: self.cells + 1], self.starts[: self.cells + 1], self.work)
        _place[shape(count)](self.cell, self.starts, self.filled, count, self.order)
        _sort[shape(self.cells)](self.starts, self.order, self.cells)

    def arguments(self) -> tuple[Any, Any, Any]:
        """The generated kernels' grid arguments: ``grid``, ``starts``, ``order``."""
        return self.grid, self.starts, self.order
