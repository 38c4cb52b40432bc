"""Where a fused loop writes its records: blocks of record rows within a memory budget.

A fused loop (the compiled engine's ``block_*`` functions) writes the record of iteration
``t`` into row ``t // every - row0`` of the arrays a :class:`RecordBlock` hands it: a view of
the recorder's own array for a column stored in full (written in place), else a buffer of
:attr:`RecordBlock.capacity` rows, reused call after call, whose rows
:meth:`RecordBlock.hand_over` then stores as ``Recorder.record`` does. The buffers hold at
most :data:`RECORD_BLOCK_BYTES` (:meth:`RecordBlock.fit`). See docs/architecture.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pyautonomousagent.recording import RecordedColumns, Recorder, preallocated

#: Bytes of record rows a fused loop holds outside the recorder at once (its buffers of the
#: columns the recorder keeps compact; the GPU engine's record groups, per slot). 128 MiB:
#: 9 records of 100,000 drones' 17 compact patrol columns, which is under a tenth of that
#: run's records (1.8 GB recording every iteration of 500).
RECORD_BLOCK_BYTES = 1 << 27


def fitting(start: int, count: int, every: int, capacity: int) -> int:
    """The most iterations, up to ``count``, from iteration ``start`` whose records (every
    ``every``-th iteration's) fit in ``capacity`` rows (at least 1); at least one iteration
    where ``count`` is."""
    return min(count, (start // every + max(1, capacity) + 1) * every - 1 - start)


class RecordBlock:
    """The record arrays of a fused loop's calls, and the hand-over of their rows (see the
    module's docstring).

    Args:
        recorder: the run's recorder.
        names: the recorded columns in the fused loop's order (``Layout.names``).
        budget: bytes the buffers may hold, at most (but one record row always fits);
            default :data:`RECORD_BLOCK_BYTES`.

    Attributes:
        capacity: rows each buffer holds (0 until the first call allocates them, and then
            none where every column is stored in full).
    """

    def __init__(self, recorder: Recorder, names: Sequence[str], budget: int | None = None) -> None:
        self.recorder, self.names = recorder, list(names)
        self.budget = RECORD_BLOCK_BYTES if budget is None else budget
        self.capacity = 0
        self._buffers: dict[int, np.ndarray] = {}
        self._allocated = False

    def _sources(self) -> list[tuple[str, RecordedColumns]]:
        """Each record array's (column name, the recorded columns holding it): the columns
        in the loop's order, then the active behaviour."""
        columns = self.recorder.columns
        sources = [(key, columns) for key in self.names]
        codes = self.recorder.codes
        return [*sources, ("behaviour", codes)] if codes is not None else sources

    def _allocate(self) -> None:
        """Allocate the buffers of the record arrays kept compact, once: as many rows as fit
        in the budget (at least one, at most the run's records)."""
        self._allocated = True
        compact = {i: c.dtypes[k] for i, (k, c) in enumerate(self._sources()) if c.full(k) is None}
        if not compact:
            return
        agents = len(self.recorder.names)
        row_bytes = agents * sum(dtype.itemsize for dtype in compact.values())
        records = len(self.recorder.iterations)
        self.capacity = max(1, min(records, self.budget // max(1, row_bytes)))
        self._buffers = {i: preallocated((self.capacity, agents), dt) for i, dt in compact.items()}

    @property
    def nbytes(self) -> int:
        """Bytes the buffers hold now."""
        return sum(buffer.nbytes for buffer in self._buffers.values())

    def fit(self, start: int, count: int) -> int:
        """The most iterations, up to ``count``, from iteration ``start`` whose records fit
        in the buffers: ``count`` where every record array is stored in full."""
        if not self._allocated:
            self._allocate()
        if not self._buffers:
            return count
        return fitting(start, count, self.recorder.every, self.capacity)

    def arrays(self, row0: int) -> tuple[list[np.ndarray], np.ndarray, np.ndarray | None]:
        """The record arrays of a call whose first record is ``row0`` (row ``r`` of each is
        record ``row0 + r``): the columns in the loop's order, shape (rows, N) each; the
        traces, (rows, nodes, K) int8; the active behaviour, (rows, N) int16, or None
        without a tree. Call :meth:`fit` first."""
        arrays = []
        for i, (key, columns) in enumerate(self._sources()):
            full = columns.full(key)
            if full is not None:
                self._buffers.pop(i, None)  # stored in full since: its buffer is freed
                arrays.append(full[row0:])
            else:
                arrays.append(self._buffers[i])
        behaviour = arrays.pop() if self.recorder.wants_statuses else None
        return arrays, self.recorder.traces[row0:], behaviour

    def hand_over(self, row0: int, rows: int) -> None:
        """Store the ``rows`` buffered rows written from record ``row0`` on in the recorder
        (``Recorder.store_group``; what was written in place stays); the bookkeeping
        (``iterations``, ``count``, listeners) is the caller's."""
        if not rows:
            return
        held = {i: buffer[:rows] for i, buffer in self._buffers.items()}  # by source index
        columns = {self.names[i]: block for i, block in held.items() if i < len(self.names)}
        self.recorder.store_group(row0, columns, None, held.get(len(self.names)))
