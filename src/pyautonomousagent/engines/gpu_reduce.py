"""Launch shapes and chunked reductions on the device: exclusive prefix sums and bounding
boxes, as trees of chunks that one thread each takes in turn (no shared memory and no
barrier, which numba's CUDA simulator runs slowly), their temporaries kept in a
:class:`Workspace` (allocated once, grown when a longer input comes). Used by the GPU
engine's datalink (:mod:`~pyautonomousagent.engines.gpu_messages`,
:mod:`~pyautonomousagent.engines.gpu_grid`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import cuda as numba_cuda

from pyautonomousagent.engines.cuda_jit import kernel

cuda: Any = numba_cuda  # numba's stubs type cuda.grid poorly

#: Threads per block of every launch.
THREADS = 256


def shape(live: int) -> tuple[int, int]:
    """(blocks, threads per block) of a launch over ``live`` threads (at least one)."""
    threads = min(THREADS, max(1, live))
    return max(1, -(-live // threads)), threads


#: Elements one thread of a reduction takes in turn (scans and bounding boxes are trees of
#: such chunks: no shared memory and no barrier, which numba's CUDA simulator runs slowly).
CHUNK = 16


class Workspace:
    """The reductions' device temporaries, one array per use (a name and a level of the
    tree of chunks), allocated at its first use and again only when a longer one is asked
    for (twice the length then), so a run's iterations allocate nothing."""

    def __init__(self) -> None:
        self._arrays: dict[tuple[str, int], Any] = {}

    def array(self, name: str, level: int, length: int, dtype: Any, width: int = 0) -> Any:
        """A device array of ``length`` rows (``width`` columns, 0: one dimension) of
        ``dtype``, the first rows of the one kept for (``name``, ``level``)."""
        key = (name, level)
        held = self._arrays.get(key)
        if held is None or held.shape[0] < length:
            rows = max(length, 2 * held.shape[0] if held is not None else length)
            held = cuda.device_array((rows, width) if width else rows, dtype)
            self._arrays[key] = held
        return held[:length]


@kernel
def _scan_chunks(values: Any, out: Any, sums: Any) -> None:
    """Each chunk's exclusive prefix sum of ``values`` (int64, shape (L,)) into ``out``, its
    total into ``sums[chunk]``."""
    c = cuda.grid(1)
    first = c * CHUNK
    if first >= values.shape[0]:
        return
    total = 0
    for i in range(first, min(first + CHUNK, values.shape[0])):
        value = values[i]
        out[i] = total
        total += value
    sums[c] = total


@kernel
def _add_chunks(out: Any, offsets: Any) -> None:
    """``out[i] += offsets[chunk of i]``."""
    i = cuda.grid(1)
    if i < out.shape[0]:
        out[i] += offsets[i // CHUNK]


def exclusive_scan(values: Any, out: Any, work: Workspace, level: int = 0) -> None:
    """``out`` := the exclusive prefix sum of ``values`` (device int64 arrays, shape (L,)):
    chunk by chunk, then the chunks' totals scanned the same way (``level`` + 1, its
    temporaries in ``work``) and added."""
    chunks = -(-values.shape[0] // CHUNK)
    sums = work.array("sums", level, chunks, np.int64)
    _scan_chunks[shape(chunks)](values, out, sums)
    if chunks > 1:
        offsets = work.array("offsets", level, chunks, np.int64)
        exclusive_scan(sums, offsets, work, level + 1)
        _add_chunks[shape(values.shape[0])](out, offsets)


@kernel
def _box_points(x: Any, y: Any, sx: Any, sy: Any, counts: Any, k: int, live: int,
                out: Any) -> None:  # fmt: skip
    """Per chunk of the points (the first ``live`` agents ``x``, ``y``, then type ``k``'s
    first ``counts[k]`` senders ``sx``, ``sy``), their bounding box: ``out[chunk]`` = (low
    x, high x, low y, high y, 1.0 where a coordinate is NaN, else 0.0)."""
    c = cuda.grid(1)
    if c >= out.shape[0]:
        return
    low_x, high_x, low_y, high_y, bad = math.inf, -math.inf, math.inf, -math.inf, 0.0
    for i in range(c * CHUNK, c * CHUNK + CHUNK):
        if i < live:
            px, py = x[i], y[i]
        elif i - live < counts[k]:
            px, py = sx[i - live], sy[i - live]
        else:
            break
        if px != px or py != py:
            bad = 1.0
        low_x, high_x = min(low_x, px), max(high_x, px)
        low_y, high_y = min(low_y, py), max(high_y, py)
    out[c, 0], out[c, 1], out[c, 2], out[c, 3], out[c, 4] = low_x, high_x, low_y, high_y, bad


@kernel
def _box_boxes(boxes: Any, out: Any) -> None:
    """Per chunk of ``boxes`` (shape (B, 5), as ``_box_points`` writes them), the box of
    their union into ``out[chunk]``."""
    c = cuda.grid(1)
    if c >= out.shape[0]:
        return
    first = c * CHUNK
    for j in range(5):
        out[c, j] = boxes[first, j]
    for i in range(first + 1, min(first + CHUNK, boxes.shape[0])):
        out[c, 0] = min(out[c, 0], boxes[i, 0])
        out[c, 1] = max(out[c, 1], boxes[i, 1])
        out[c, 2] = min(out[c, 2], boxes[i, 2])
        out[c, 3] = max(out[c, 3], boxes[i, 3])
        out[c, 4] = max(out[c, 4], boxes[i, 4])


def bounding_box(
    x: Any, y: Any, sx: Any, sy: Any, counts: Any, k: int, work: Workspace
) -> np.ndarray:
    """The bounding box of the agents (``x``, ``y``, device arrays shape (N,)) and type
    ``k``'s senders (``sx``, ``sy``, the first ``counts[k]``, on the device): (low x, high
    x, low y, high y, NaN flag), a host array shape (5,); the chunks' boxes in ``work``.
    Min and max are exact: the order of the reduction does not change the bits."""
    chunks = -(-(x.shape[0] + sx.shape[0]) // CHUNK)
    boxes = work.array("boxes", 0, chunks, np.float64, 5)
    _box_points[shape(chunks)](x, y, sx, sy, counts, k, x.shape[0], boxes)
    level = 0
    while boxes.shape[0] > 1:
        chunks, level = -(-boxes.shape[0] // CHUNK), level + 1
        out = work.array("boxes", level, chunks, np.float64, 5)
        _box_boxes[shape(chunks)](boxes, out)
        boxes = out
    return boxes.copy_to_host()[0]
