"""The GPU engine's iterations of a tree that sends messages: the datalink on the device.

The generated kernels (:func:`~pyautonomousagent.engines.gpu_source.message_module_source`) run
one thread an agent; this module launches them iteration by iteration and keeps the
messages on the device between iterations: ``sense_move`` (Phase 2); last iteration's
deliveries type by type, one that reached everyone by sender (``handle_sender_<k>``), per
receiver (``handle_each_<k>``, at most :data:`EACH_MOST` messages) or in one thread
(``handle_all_<k>``), one that reached only some per receiver over the messages in range
found on the type's cell grid (``handle_near_<k>``,
:class:`~pyautonomousagent.engines.gpu_grid.DeviceGrid`); ``tick`` (Phases 3, 4 and 6);
then Phase 5: per type the sent flags (``flag_<k>``), their prefix sum and the scatter
into the inbox in canonical order (``scatter_<k>``), and the bounding box the host reads
to plan the next iteration. docs/architecture.md, "The GPU engine", has the details.

The loop stops after an iteration that sent a recorded message type (the CPU delivers it
and records its events, as the compiled engine does), or whose positions hold a NaN, or
whose messages did not reach everyone and whose type has no per-receiver form.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numba import cuda as numba_cuda

from pyautonomousagent.arrays import hypot
from pyautonomousagent.engines.gpu_grid import DeviceGrid
from pyautonomousagent.engines.gpu_reduce import Workspace, bounding_box, exclusive_scan, shape
from pyautonomousagent.loop.layout import Messaging

if TYPE_CHECKING:
    from pyautonomousagent.simulation.engine_api import LoopView

cuda: Any = numba_cuda  # numba's stubs type cuda.grid poorly

#: ``lowest`` before an iteration's collection: above every node index.
NO_NODE = np.iinfo(np.int64).max

#: The most messages of a delivery to everyone handled per receiver (``handle_each``):
#: that is N x M steps in all, M per thread, where the handler's everyone form in one
#: thread may take as few as M (a form that keeps the last message of all, say): beyond a
#: few dozen messages the N x M work costs more than the one thread's latency.
EACH_MOST = 64


class DeviceMessages:
    """The inboxes, flags, handler state and cell grids of a tree's message types on the
    device, and the launches of whole iterations (see the module's docstring).

    Args:
        kernels: name -> compiled kernel, the generated module's (``sense_move``, ``tick``,
            ``handle_all_<k>``, ``handle_sender_<k>``, ``handle_each_<k>``,
            ``handle_near_<k>``, ``flag_<k>``, ``scatter_<k>``).
        messaging: the tree's message types and their handlers.
        common: the names of the kernels' common parameters, in order
            (``loop.source.fused_parameters``, flattened).
        xy: where the agents' x and y arrays are among them, found by name.
        n: agents.
    """

    #: How a type's delivery of last iteration is handled: not delivered; to everyone in one
    #: thread; near (to some, per receiver); to everyone by sender; to everyone per receiver.
    NONE, ALL, NEAR, SENDER, EACH = 0, 1, 2, 3, 4

    #: The kernel of each way of handling (type ``k``'s: the name and ``_<k>``).
    KERNELS = {ALL: "handle_all", NEAR: "handle_near", SENDER: "handle_sender",
               EACH: "handle_each"}  # fmt: skip

    #: Entries per receiver a per-receiver state starts with (doubled while short).
    ROOM = 8

    def __init__(
        self, kernels: dict[str, Any], messaging: Messaging, common: list[str],
        xy: tuple[int, int], n: int,
    ) -> None:  # fmt: skip
        self.kernels, self.messaging, self.n = kernels, messaging, n
        self.common, self.xy = common, xy
        types = len(messaging.types)
        self.width = [sum(1 for kind, _ in messaging.senders.values() if kind == k)
                      for k in range(types)]  # fmt: skip
        self.counts = cuda.to_device(np.zeros(types, dtype=np.int64))
        self.no_node = np.full(types, NO_NODE, dtype=np.int64)
        self.lowest = cuda.to_device(self.no_node)
        self.work = Workspace()  # the prefix sums' and bounding boxes' temporaries
        self.rx, self.ry = cuda.device_array(n), cuda.device_array(n)
        self.inboxes: list[list[Any]] = []
        self.grids: dict[int, DeviceGrid] = {}  # type -> its grid, for those handled near
        for k, handler in enumerate(messaging.handlers):
            slots = max(1, n * self.width[k])  # one message per sending node and agent
            if handler.receive is not None:
                self.grids[k] = DeviceGrid(slots)
            flags = [cuda.device_array(slots, np.int64) for _ in range(2)]
            inbox = [cuda.device_array(slots, np.int64),
                     cuda.device_array((len(handler.fields), slots)),
                     cuda.device_array(slots), cuda.device_array(slots)]  # fmt: skip
            self.inboxes.append(flags + inbox)
        self.state: list[Any] = []
        self.room = [self.ROOM] * types
        self.tables: list[tuple[Any, ...]] = [()] * types
        #: (type, how, messages) of the next iteration's handling, in delivery order.
        self.plan: list[tuple[int, int, int]] = []

    def upload_state(self) -> None:
        """The handlers' state to the device (after the CPU changed it)."""
        handlers = self.messaging.handlers
        self.state = [cuda.to_device(array) for h in handlers for array in h.state]
        for k, handler in enumerate(handlers):
            receive = handler.receive
            if receive is not None and receive.state is not None:
                self.tables[k] = tuple(cuda.to_device(a) for a in receive.state(self.room[k]))

    def download_state(self) -> None:
        """The handlers' state back into the mission's arrays."""
        host = [array for h in self.messaging.handlers for array in h.state]
        for array, device in zip(host, self.state, strict=True):
            device.copy_to_host(array)
        for k, handler in enumerate(self.messaging.handlers):
            if handler.receive is not None and handler.receive.keep is not None:
                handler.receive.keep(tuple(a.copy_to_host() for a in self.tables[k]))

    def upload_inbox(self, sim: LoopView) -> None:
        """``sim.inbox`` (last iteration's deliveries, delivered by the CPU) into the inboxes,
        those that reached only some grouped by cell; the agents' positions now are their
        positions at delivery."""
        x, y = sim.swarm.columns["x"], sim.swarm.columns["y"]
        reach = sim.world.datalink.range
        self.rx.copy_to_device(np.ascontiguousarray(x))
        self.ry.copy_to_device(np.ascontiguousarray(y))
        counts = np.zeros(len(self.messaging.types), dtype=np.int64)
        self.plan = []
        for delivery in sim.inbox:
            messages = delivery.messages
            k = self.messaging.types.index(messages.type)
            m = counts[k] = len(messages)
            inbox = self.inboxes[k][2:]  # senders, data, sender x, sender y
            fields = self.messaging.handlers[k].fields
            rows = [messages.senders, messages.x, messages.y, *(messages.data[f] for f in fields)]
            places = [inbox[0], inbox[2], inbox[3], *(inbox[1][f] for f in range(len(fields)))]
            for device, row in zip(places, rows, strict=True):
                if m:  # only the first m: the kernels read no further
                    device[:m].copy_to_device(np.ascontiguousarray(row, device.dtype))
            how = self._everyone(k, m) if delivery.to_all else self.NEAR
            self.plan.append((k, how, m))
            if not delivery.to_all and k in self.grids:
                xs, ys = np.concatenate((x, messages.x)), np.concatenate((y, messages.y))
                box = (xs.min(), xs.max(), ys.min(), ys.max())  # NaN: one cell
                self.grids[k].group(inbox[2], inbox[3], m, tuple(map(float, box)), reach)
        self.counts.copy_to_device(counts)

    def arguments(self, reach: float) -> tuple[Any, ...]:
        """The kernels' arguments after the common ones (``gpu_source.message_arguments``)."""
        inboxes = [array for inbox in self.inboxes for array in inbox]
        tables = [array for table in self.tables for array in table]
        grids = [array for k in sorted(self.grids) for array in self.grids[k].arguments()]
        return (reach, self.counts, self.lowest, self.rx, self.ry, *inboxes, *self.state,
                *tables, *grids)  # fmt: skip

    def compile(self, common: tuple[Any, ...], reach: float) -> None:
        """Launch every kernel once with no thread at work (compiles them, changes nothing)."""
        for kernel in self.kernels.values():
            kernel[1, 1](0, 0, 1, 0, *common, *self.arguments(reach))
        exclusive_scan(self.inboxes[0][0][:1], self.inboxes[0][1][:1], self.work)
        sx, sy = self.inboxes[0][4:]
        bounding_box(common[self.xy[0]], common[self.xy[1]], sx, sy, self.counts, 0, self.work)
        for k, grid in self.grids.items():  # its kernels, with no message
            sx, sy = self.inboxes[k][4:]
            grid.group(sx, sy, 0, (0.0, 0.0, 0.0, 0.0), reach)

    def run(
        self, sim: LoopView, common: tuple[Any, ...], count: int, row0: int, fresh: bool
    ) -> int:
        """Up to ``count`` iterations from the world's, ``sim.inbox`` handled in the first
        (``common``: the kernels' common arguments, ``row0``: the record group's first row,
        ``fresh``: the state goes to the device anew, the handlers' too); how many were
        done. ``count`` 0 compiles the kernels."""
        start, every, reach = sim.world.iteration, sim.recorder.every, sim.world.datalink.range
        if fresh:
            self.upload_state()
        if not count:
            self.compile(common, reach)
            return 0
        self.upload_inbox(sim)
        for t in range(start + 1, start + count + 1):
            head = (t, every, row0, *common)
            self._launch("sense_move", self.n, head, reach)
            for k, how, m in self.plan:
                self._handle(k, how, m, head, reach)
            self._launch("tick", self.n, head, reach)
            if self._collect(head, reach):
                return t - start
        return count

    def _launch(self, name: str, live: int, head: tuple[Any, ...], reach: float) -> None:
        """Kernel ``name`` over ``live`` threads: ``head`` (the iteration, ``every``,
        ``row0``, then the common arguments), then :meth:`arguments`."""
        self.kernels[name][shape(live)](live, *head, *self.arguments(reach))

    def _everyone(self, k: int, m: int) -> int:
        """How type ``k``'s delivery to everyone of ``m`` messages is handled (see the
        module's docstring)."""
        handler = self.messaging.handlers[k]
        if handler.by_sender:
            return self.SENDER
        if handler.receive is not None and m <= EACH_MOST:
            return self.EACH
        return self.ALL

    def _handle(self, k: int, how: int, m: int, head: tuple[Any, ...], reach: float) -> None:
        """Type ``k``'s delivery of last iteration (``m`` messages), handled ``how``: in one
        thread (``ALL``), one thread per message (``SENDER``: those that start a sender's
        run work) or one thread per receiver (``EACH``, ``NEAR``), with more room for the
        per-receiver state while it lacks some."""
        name = f"{self.KERNELS[how]}_{k}"
        if how in (self.ALL, self.SENDER):
            self._launch(name, 1 if how == self.ALL else m, head, reach)
            return
        receive = self.messaging.handlers[k].receive
        assert receive is not None
        while True:
            self._launch(name, self.n, head, reach)
            if not self.tables[k] or self.tables[k][0].copy_to_host()[0] == 0:
                return
            assert receive.keep is not None and receive.state is not None
            receive.keep(tuple(a.copy_to_host() for a in self.tables[k]))
            self.room[k] *= 2
            self.tables[k] = tuple(cuda.to_device(a) for a in receive.state(self.room[k]))

    def _collect(self, head: tuple[Any, ...], reach: float) -> bool:
        """Phase 5 on the device: this iteration's messages into the inboxes and the next
        iteration's handling planned; True where the CPU must deliver them instead."""
        n, messaging = self.n, self.messaging
        self.lowest.copy_to_device(self.no_node)
        x, y = head[3 + self.xy[0]], head[3 + self.xy[1]]  # after t, every, row0
        for k in range(len(messaging.types)):
            flags, places = self.inboxes[k][:2]
            self._launch(f"flag_{k}", n, head, reach)
            exclusive_scan(flags[: n * self.width[k]], places, self.work)
            self._launch(f"scatter_{k}", n, head, reach)
        counts, lowest = self.counts.copy_to_host(), self.lowest.copy_to_host()
        sent = sorted((int(lowest[k]), k) for k in range(len(counts)) if counts[k] > 0)
        self.plan, stop, boxes = [], False, {}
        for _, k in sent:
            sx, sy = self.inboxes[k][4:]
            box = bounding_box(x, y, sx, sy, self.counts, k, self.work)
            low_x, high_x, low_y, high_y, bad = box
            everyone = bool(hypot(high_x - low_x, high_y - low_y) <= reach)
            near = messaging.handlers[k].receive is not None
            stop = stop or messaging.recorded[k] or bad > 0.0 or not (everyone or near)
            m = int(counts[k])
            self.plan.append((k, self._everyone(k, m) if everyone else self.NEAR, m))
            boxes[k] = (low_x, high_x, low_y, high_y)
        for k, how, _ in self.plan if not stop else []:
            if how == self.NEAR:
                sx, sy = self.inboxes[k][4:]
                self.grids[k].group(sx, sy, int(counts[k]), boxes[k], reach)
        return stop
