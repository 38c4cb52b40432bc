"""Phase 6: recording the swarm into preallocated arrays, and exporting them.

A :class:`Recorder` keeps one array of shape ``(records, N)`` per recorded column, where
``records = iterations // every + 1`` (the initial state, then every ``every``-th
iteration). Nothing grows during a run. :func:`to_table` turns the arrays into a long
table (one row per recorded iteration and agent) for Parquet, CSV or pandas.
"""

from __future__ import annotations

import mmap
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pyarrow as pa

from pyautonomousagent.inputs import InputError
from pyautonomousagent.state import Swarm


class Recorder:
    """Preallocated columnar storage of the swarm's state and blackboard.

    Args:
        swarm: the agents (its columns and blackboard keys are recorded).
        iterations: the run's length in iterations.
        every: record iteration t when ``t % every == 0`` (decimation); 1 records all.
        extra: more columns to record (e.g. a motion model's state), name -> shape (N,).
    """

    def __init__(
        self,
        swarm: Swarm,
        iterations: int,
        every: int = 1,
        extra: Mapping[str, np.ndarray] | None = None,
    ) -> None:
        if every < 1:
            raise ValueError(f"record_every must be >= 1, got {every}")
        self.every = every
        self.names = list(swarm.names)
        records = iterations // every + 1
        self.iterations = np.zeros(records, dtype=np.int64)
        sources = {**swarm.columns, **swarm.blackboard, **(extra or {})}
        self.columns = {k: preallocated((records, swarm.size), v.dtype) for k, v in sources.items()}
        self.count = 0

    def due(self, iteration: int) -> bool:
        """Whether ``iteration`` is recorded."""
        return iteration % self.every == 0

    def record(
        self, iteration: int, swarm: Swarm, extra: Mapping[str, np.ndarray] | None = None
    ) -> None:
        """Copy the swarm's current state (and the ``extra`` columns) into the next record."""
        row = self.count
        self.iterations[row] = iteration
        sources = {**swarm.columns, **swarm.blackboard, **(extra or {})}
        for key, values in self.columns.items():
            values[row] = sources[key]
        self.count += 1

    def column(self, key: str) -> np.ndarray:
        """The recorded values of ``key``, shape (records so far, N)."""
        return self.columns[key][: self.count]


def preallocated(shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """A zero-filled array whose memory is committed at once (Linux: ``MAP_POPULATE``).

    ``numpy.zeros`` maps pages lazily, and each first write then faults one 4 KiB page; on a
    virtual machine that made full-rate recording three times slower than committing the
    whole block in one system call. Small arrays, and systems without ``MAP_POPULATE``, get
    ``numpy.zeros``.
    """
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dtype.itemsize
    populate = getattr(mmap, "MAP_POPULATE", None)
    if populate is None or nbytes < 1 << 20:
        return np.zeros(shape, dtype)
    flags = mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | populate
    return np.frombuffer(mmap.mmap(-1, nbytes, flags=flags), dtype=dtype).reshape(shape)


def to_table(recorder: Recorder) -> pa.Table:
    """The records as a long table: columns ``iteration, agent``, the state, the blackboard."""
    records, n = recorder.count, len(recorder.names)
    agent = pa.DictionaryArray.from_arrays(
        pa.array(np.tile(np.arange(n, dtype=np.int32), records)), pa.array(recorder.names)
    )
    data: dict[str, pa.Array] = {
        "iteration": pa.array(np.repeat(recorder.iterations[:records], n)),
        "agent": agent,
    }
    for key in recorder.columns:
        data[key] = pa.array(recorder.column(key).reshape(-1))
    return pa.table(data)


def write_table(table: pa.Table, path: Path, fmt: str = "parquet") -> Path:
    """Write ``table`` as ``path`` in ``fmt`` ("parquet" or "csv"); return the path."""
    if fmt == "parquet":
        import pyarrow.parquet as pq

        pq.write_table(table, path)
    elif fmt == "csv":
        import pyarrow.csv as pcsv

        pcsv.write_csv(table.cast(_plain_agent(table.schema)), path)
    else:
        raise ValueError(f"unknown format {fmt!r}; use 'parquet' or 'csv'")
    return path


def _plain_agent(schema: pa.Schema) -> pa.Schema:
    """The schema with the dictionary-encoded agent column as plain strings (for CSV)."""
    return schema.set(schema.get_field_index("agent"), pa.field("agent", pa.string()))


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``; elsewhere the
    physical memory), or None if unknown."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def check_memory(agents: int, iterations: int, every: int, columns: int, per_agent: int = 0) -> int:
    """Refuse a run whose records cannot fit in the available memory; return its estimate.

    The estimate is a lower bound: ``agents x (iterations // every + 1) x columns x 8``
    bytes of records, plus ``per_agent`` bytes of working state (tree, names) per agent.

    Raises:
        InputError: the estimate is above the available memory, with the figure and the fix.
    """
    records = iterations // every + 1
    needed = agents * (records * columns * 8 + per_agent)
    available = available_memory()
    if available is not None and needed > available:
        raise InputError(
            f"the run needs at least {needed / 1e9:.3g} GB ({agents} agents x {records} "
            f"records x {columns} columns x 8 bytes, plus the trees), more than the "
            f"{available / 1e9:.3g} GB available; record less often (--record-every K, "
            "record_every=K), or simulate fewer agents or iterations"
        )
    return needed
