"""Writing a run's records to Parquet while the run goes on, in a background thread.

    stream = StatesStream(sim.recorder, folder / "states.parquet")
    sim.run()                 # each block of records is written as a row group meanwhile
    stream.finish()           # the records not written yet, then the file is closed

The records stay in the recorder (the views read them); the thread reads finished records
(those below ``recorder.count``, never written again) without copying them, so the table
written is the one :func:`~pyautonomousagent.recording.to_table` gives, in row groups of
about :data:`ROW_GROUP_ROWS` rows. Encoding Parquet releases Python's lock, so on a machine
with a spare core the writing overlaps the loop.
"""

from __future__ import annotations

import contextlib
import os
import queue
import sys
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq

from pyautonomousagent.recording import Recorder, parquet_options, to_table

#: Rows (records x agents) per Parquet row group, about: pyarrow's default row group size.
ROW_GROUP_ROWS = 1 << 20


class StatesStream:
    """Writes ``recorder``'s records to the Parquet file ``path`` as they are recorded.

    Args:
        recorder: the run's recorder; the stream listens to its records.
        path: the Parquet file to write (created by the thread with the first block).
        rows: rows per row group, about (whole records: at least one record a group).

    Attributes:
        block: records per row group.
        written: records handed to the writing thread so far.
        busy: CPU seconds the writing thread has spent building and writing row groups
            (its own processor time: on a busy machine its wall time is longer).
    """

    def __init__(self, recorder: Recorder, path: Path, rows: int = ROW_GROUP_ROWS) -> None:
        self.recorder, self.path = recorder, Path(path)
        self.block = max(1, rows // max(1, len(recorder.names)))
        self.written = 0
        self.busy = 0.0
        self._queue: queue.Queue[tuple[int, int] | None] = queue.Queue()
        self._error: BaseException | None = None
        self._writer: pq.ParquetWriter | None = None
        self._thread = threading.Thread(target=self._work, name="pyaa-states", daemon=True)
        self._thread.start()
        recorder.listeners.append(self._recorded)

    def _recorded(self, count: int) -> None:
        """Recorder listener: hand a full block of finished records to the thread."""
        while count - self.written >= self.block:  # an engine may record many at once
            self._queue.put((self.written, self.written + self.block))
            self.written += self.block

    def finish(self) -> Path:
        """Write the records not written yet, close the file and return its path.

        Raises:
            OSError: writing failed (the thread's error, raised here).
        """
        self._detach()
        if self.recorder.count > self.written or self.written == 0:
            self._queue.put((self.written, self.recorder.count))
            self.written = self.recorder.count
        self._queue.put(None)
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self.path

    def close(self) -> None:
        """Stop the thread without writing the rest (the file is left incomplete)."""
        self._detach()
        if self._thread.is_alive():
            self._error = self._error or OSError("the stream was closed")
            self._queue.put(None)
            self._thread.join()

    def _detach(self) -> None:
        if self._recorded in self.recorder.listeners:
            self.recorder.listeners.remove(self._recorded)

    def _work(self) -> None:
        """The thread: write each block handed over as a row group, until None comes."""
        _lower_priority()
        while (item := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._write(*item)
                except BaseException as error:  # raised again by finish()
                    self._error = error
        if self._writer is not None:
            try:
                self._writer.close()
            except OSError as error:
                self._error = self._error or error

    def _write(self, start: int, stop: int) -> None:
        """Write records ``start`` to ``stop`` as one row group."""
        began = time.thread_time()
        table = to_table(self.recorder, start, stop)
        if self._writer is None:
            options = parquet_options(table.schema)
            self._writer = pq.ParquetWriter(self.path, table.schema, **options)
        self._writer.write_table(table, row_group_size=max(1, table.num_rows))
        self.busy += time.thread_time() - began


#: How much lower the writing thread's scheduling priority is than the loop's (Linux ``nice``).
NICER = 10


def _lower_priority() -> None:
    """Lower the calling thread's priority by :data:`NICER` (Linux threads have their own),
    so that on a busy machine the loop keeps its core and the writing takes what is spare;
    elsewhere, or where it is refused, nothing changes."""
    if sys.platform == "linux":
        with contextlib.suppress(OSError):
            thread = threading.get_native_id()
            os.setpriority(os.PRIO_PROCESS, thread, os.getpriority(os.PRIO_PROCESS, thread) + NICER)
