"""The GPU engine's records: groups of record rows copied back while the next iterations run.

Each call of :meth:`~pyautonomousagent.engines.gpu.GpuEngine.loop` has its kernel write the
records of its iterations into one :class:`Slot` (a group of rows on the device: the
recorded columns, shape (rows, N) each; the traces, (rows, nodes, K) int8; the active
behaviour, (rows, N) int16; the iteration each agent first stopped at, (N,) int64), whose
copy into pinned host buffers :meth:`RecordGroups.launched` queues on a second stream, so
that it runs while the next call's kernel writes the other slot (:data:`SLOTS`, in turn).
The host waits only when a slot is needed again while its group is in flight
(:meth:`RecordGroups.slot`) and at :meth:`RecordGroups.settle`; handing a group over stores
its rows in the recorder and has the simulation do the fused loop's bookkeeping
(``account_fused``). ``sim.world.iteration`` counts the iterations launched; the recorder's
count lags it by the groups in flight. A group holds at most :data:`GROUP_BYTES`
(:meth:`RecordGroups.fit` shortens a call to fit). docs/architecture.md, "The GPU engine".
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent.kernels import SensorKernel
from pyautonomousagent.record_blocks import RECORD_BLOCK_BYTES, fitting
from pyautonomousagent.recording import Recorder

if TYPE_CHECKING:
    from pyautonomousagent.simulation.engine_api import LoopView

#: Slots of record rows, used in turn: one being written by a kernel while another is copied.
SLOTS = 2

#: Bytes of record rows a slot holds at most on the device (and as many pinned on the host):
#: the slots share the fused loops' budget
#: (:data:`~pyautonomousagent.record_blocks.RECORD_BLOCK_BYTES`), so that the host holds no
#: more beyond the recorder's records than on the compiled engine.
#: A call whose records would need more runs fewer iterations (at least one).
GROUP_BYTES = RECORD_BLOCK_BYTES // SLOTS


@dataclass
class Slot:
    """One group of record rows on the device and its pinned host buffers (``capacity``
    rows each), and the CUDA events that time and order its kernel and its copy.

    Attributes:
        device: the columns, then the traces, the active behaviour and ``stopped`` (the
            iteration each agent first stopped at in the call, -1 if none), device arrays.
        host: pinned host arrays of the same shapes and types.
        events: "began", "ran" (the kernel's), "copying", "copied" (the copy's).
    """

    device: list[Any]
    host: list[np.ndarray]
    events: dict[str, Any]


@dataclass
class Group:
    """A call's records in flight: its slot, iterations ``start + 1 .. start + count``,
    records ``row0 .. row0 + rows - 1``, the sensors it ran (for their alerts), and the host
    seconds its launch and its copy's enqueuing took (the simulator's timings)."""

    slot: Slot
    start: int
    count: int
    row0: int
    rows: int
    sensors: SensorKernel
    launch_s: float
    enqueue_s: float


class RecordGroups:
    """The record rows of a run on the GPU engine, copied back group by group (see the
    module's docstring).

    Args:
        recorder: the run's recorder.
        names: the recorded columns in the kernel's order (``Layout.names``).
        iterations: the run's length, sizing the slots (at most the records of the run).
        timings: where "kernel" and "copy_back" seconds are added (the engine's).
        on_device: time the kernel and the copies with CUDA events (device seconds); False
            under numba's CUDA simulator, whose events time nothing (host seconds instead).
    """

    def __init__(
        self,
        recorder: Recorder,
        names: Sequence[str],
        iterations: int,
        timings: dict[str, float],
        on_device: bool = True,
    ) -> None:
        from numba import cuda

        self.recorder, self.names, self.timings = recorder, list(names), timings
        self.on_device = on_device
        self.stream = cuda.stream()  # the kernels'
        self.copies = cuda.stream()  # the copies back
        agents = len(recorder.names)
        traced_at = np.full(agents, -1, dtype=np.int64)
        traced_at[recorder.traced] = np.arange(recorder.traced.size)
        self.traced_at = cuda.to_device(traced_at)
        self.leaf_rows = cuda.to_device(recorder.leaf_rows.astype(np.int64))
        self._no_stop = cuda.to_device(np.full(agents, -1, dtype=np.int64))
        # the shape of one record row and the type of each record array, in kernel order
        self._shapes: list[tuple[tuple[int, ...], np.dtype]]
        self._shapes = [((agents,), recorder.columns.dtypes[k]) for k in self.names]
        self._shapes.append(((len(recorder.nodes), recorder.traced.size), np.dtype(np.int8)))
        self._shapes.append(((agents,), np.dtype(np.int16)))
        fitting = GROUP_BYTES // max(1, self.row_bytes)
        self.capacity = max(1, min(iterations // recorder.every + 1, fitting))
        self._slots: list[Slot] = []
        self._next = 0
        self._flight: deque[Group] = deque()

    @property
    def row_bytes(self) -> int:
        """Bytes of one record row on the device: columns, traces and active behaviour."""
        return sum(int(np.prod(shape)) * dtype.itemsize for shape, dtype in self._shapes)

    def fit(self, start: int, count: int) -> int:
        """The most iterations, up to ``count``, from iteration ``start`` whose records fit
        in a slot (:attr:`capacity` rows); at least one."""
        return fitting(start, count, self.recorder.every, self.capacity)

    @property
    def in_flight(self) -> int:
        """Groups launched whose records the recorder does not hold yet."""
        return len(self._flight)

    def slot(self, sim: LoopView) -> Slot:
        """The next slot, free: its group handed over first if it is still in flight (the
        host waits for its copy); its ``stopped`` reset and its "began" event recorded on
        :attr:`stream`, for the kernel launched next."""
        if not self._slots:
            self._slots = [self._new_slot() for _ in range(SLOTS)]
        slot = self._slots[self._next]
        self._next = (self._next + 1) % SLOTS
        while any(group.slot is slot for group in self._flight):
            self._hand_over(sim, self._flight.popleft())
        slot.device[-1].copy_to_device(self._no_stop, stream=self.stream)
        slot.events["began"].record(self.stream)
        return slot

    def _new_slot(self) -> Slot:
        from numba import cuda

        shapes = [((self.capacity, *shape), dtype) for shape, dtype in self._shapes]
        shapes.append(((len(self.recorder.names),), np.dtype(np.int64)))  # stopped
        device = [cuda.device_array(shape, dtype) for shape, dtype in shapes]
        host = [cuda.pinned_array(shape, dtype) for shape, dtype in shapes]
        events = {name: cuda.event() for name in ("began", "ran", "copying", "copied")}
        return Slot(device, host, events)

    def arguments(self, slot: Slot) -> tuple[Any, ...]:
        """The kernel's record arguments for ``slot``: ``records..., traces, traced_at,
        behaviour, leaf_rows, stopped_at`` (device arrays)."""
        *columns, traces, behaviour, stopped = slot.device
        return (*columns, traces, self.traced_at, behaviour, self.leaf_rows, stopped)

    def launched(
        self, slot: Slot, start: int, count: int, sensors: SensorKernel, launch_s: float
    ) -> None:
        """The kernel writing ``slot`` for iterations ``start + 1 .. start + count`` was
        launched (in ``launch_s`` host seconds): queue the copy of its rows on
        :attr:`copies`, after the kernel, and keep the group in flight. A call of no
        iteration (compiling only) waits for the kernel and keeps nothing."""
        if count == 0:
            self.stream.synchronize()
            return
        every = self.recorder.every
        row0, rows = start // every + 1, (start + count) // every - start // every
        began = time.perf_counter()
        events = slot.events
        events["ran"].record(self.stream)
        events["ran"].wait(self.copies)
        events["copying"].record(self.copies)
        for device, host in zip(slot.device[:-1], slot.host[:-1], strict=True):
            if rows:
                device[:rows].copy_to_host(host[:rows], stream=self.copies)
        slot.device[-1].copy_to_host(slot.host[-1], stream=self.copies)
        events["copied"].record(self.copies)
        enqueue_s = time.perf_counter() - began
        self._flight.append(Group(slot, start, count, row0, rows, sensors, launch_s, enqueue_s))

    def settle(self, sim: LoopView) -> None:
        """Hand every group in flight over to the recorder, in order (the host waits for
        their copies)."""
        while self._flight:
            self._hand_over(sim, self._flight.popleft())

    def _hand_over(self, sim: LoopView, group: Group) -> None:
        """Wait for ``group``'s copy, store its rows in the recorder and do its bookkeeping
        (``sim.account_fused``: alerts, the recorder's count, its listeners; the clock is
        left at the iterations launched)."""
        slot = group.slot
        slot.events["copied"].synchronize()
        began = time.perf_counter()
        *columns, traces, behaviour, stopped = slot.host
        rows = group.rows
        recorded = {k: v[:rows] for k, v in zip(self.names, columns, strict=True)}
        self.recorder.store_group(group.row0, recorded, traces[:rows], behaviour[:rows])
        sim.account_fused(group.sensors, group.start, group.count, stopped)
        host = time.perf_counter() - began
        if self.on_device:
            events = slot.events
            kernel = events["began"].elapsed_time(events["ran"]) / 1000.0
            copy = events["copying"].elapsed_time(events["copied"]) / 1000.0
        else:
            kernel, copy = group.launch_s, group.enqueue_s
        self.timings["kernel"] += kernel
        self.timings["copy_back"] += copy + host
