"""What the compiled and GPU engines share: the tree's arrays, the fused loop's arguments
by stage, and the bookkeeping of a fused run (:class:`LoopEngine`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent.bt.leaf import check_leaves, make_leaf
from pyautonomousagent.bt.program import Program, compile_tree
from pyautonomousagent.bt.script_leaves import time_step
from pyautonomousagent.bt.spec import Node, TreeError, check_entries
from pyautonomousagent.bt.tree_source import memory_rows, memory_size
from pyautonomousagent.kernels import LeafKernel, Sends, SensorKernel
from pyautonomousagent.loop.layout import Fused, Layout, Messaging, deferrable
from pyautonomousagent.loop.source import Stages, swarm_state_names
from pyautonomousagent.models.drone2d import Drone2D
from pyautonomousagent.models.drone3d import Drone3D
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.datalink import Datalink, Delivery
    from pyautonomousagent.simulation.engine_api import LoopView


class LoopEngine:
    """The base of the engines that run the fused loop (compiled, GPU): the tree flattened
    (:attr:`program`), its leaves' kernels, where the generated code finds things
    (:attr:`layout`), the arrays it reads and writes (node statuses ``status``, (nodes, N)
    int8; remembered children ``current``, (M, N) int32; deferred ``Later`` steps
    ``pending``, (N,) int32; the swarm's columns and blackboard then the outboxes,
    ``arrays``), the fused functions' arguments by stage (name -> value, matched to the
    generated parameters by :func:`~pyautonomousagent.loop.arguments.ordered`), and the
    bookkeeping of a fused run.

    Raises:
        TreeError: a leaf has no kernel, or any error the batched engine would raise.
    """

    name = "loop"
    #: The per-agent source of the fused loop's stages (set by the engine that writes it).
    stages: Stages

    def __init__(self, tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]) -> None:
        check_leaves(tree, swarm, defaults)
        check_entries(tree, swarm.blackboard)
        self.program: Program = compile_tree(tree)
        self.swarm, self.world = swarm, world
        self.kernels: dict[int, LeafKernel] = {}
        for i, node in enumerate(self.program.nodes):
            if not node.is_control:
                kernel = make_leaf(node, defaults).kernel(world)
                if kernel is None:
                    raise TreeError(f"leaf {node.name!r} ({node.type}) has no kernel")
                self.kernels[i] = kernel
        senders = tuple(i for i, kernel in sorted(self.kernels.items()) if kernel.sends)
        self.layout = Layout(
            tuple(swarm.columns) + tuple(swarm.blackboard),
            memory_rows(self.program),
            senders,
            deferrable(self.program, self.kernels),
            time_step=time_step(defaults),
        )
        self.pending = np.full(swarm.size, -1, dtype=np.int32)  # deferred Later steps
        self.status = np.zeros((len(self.program.nodes), swarm.size), dtype=np.int8)
        self.current = np.zeros((memory_size(self.program), swarm.size), dtype=np.int32)
        self.outboxes = {i: np.zeros((3 + len(self._sends(i).fields), swarm.size)) for i in senders}
        self.arrays = [{**swarm.columns, **swarm.blackboard}[k] for k in self.layout.names]
        self.arrays += list(self.outboxes.values())
        self._inboxes: list[tuple[np.ndarray, np.ndarray]] | None = None

    def _share(self, host: LoopEngine) -> None:
        """Take ``host``'s tree, kernels, layout and arrays (the same objects: what one
        engine writes, the other reads), in place of :meth:`__init__`."""
        self.program, self.kernels, self.layout = host.program, host.kernels, host.layout
        self.swarm, self.world = host.swarm, host.world
        self.status, self.current, self.pending = host.status, host.current, host.pending
        self.outboxes, self.arrays = host.outboxes, host.arrays
        self._inboxes = None

    def tick(self) -> None:
        """Phase 3 for every agent (the engine's own)."""
        raise NotImplementedError

    def node_statuses(self) -> np.ndarray:
        """Status codes after the last tick, shape (nodes in tick order, N), int8."""
        return self.status.copy()

    def _sends(self, node: int) -> Sends:
        sends = self.kernels[node].sends
        assert sends is not None
        return sends

    def _send(self, datalink: Datalink) -> None:
        """Hand the outboxes' messages to ``datalink``, leaf by leaf in node order, senders in
        ascending rows: the batched engine's calls of ``Leaf.broadcast``."""
        for i, box in self.outboxes.items():
            rows = np.flatnonzero(box[0] == 1.0)
            if rows.size:
                sends = self._sends(i)
                data = {f: box[3 + j, rows] for j, f in enumerate(sends.fields)}
                datalink.send(rows, sends.type, data, (box[1, rows], box[2, rows]))

    def _tree_arguments(self, constants: tuple[Any, Any]) -> dict[str, Any]:
        """The tree's arguments: ``st``, ``cur``, ``pend``, the constants ``kf``, ``ki``, the
        arrays ``c<j>`` and the outboxes ``o<node>``."""
        tree = {"st": self.status, "cur": self.current, "pend": self.pending}
        tree |= dict(zip(("kf", "ki"), constants, strict=True))
        return tree | dict(zip(self.layout.array_names, self.arrays, strict=True))

    @staticmethod
    def _control_arguments(model: Drone2D | Drone3D, no_climb: np.ndarray) -> dict[str, Any]:
        """The control signals ``us``, ``uh``, ``uc`` (u_v, u_a, u_w; shape (N,) each):
        ``no_climb`` as u_w for the 2-D drone."""
        u_climb = model.u_climb if isinstance(model, Drone3D) else no_climb
        return {"us": model.u_speed, "uh": model.u_heading, "uc": u_climb}

    @staticmethod
    def _model_arguments(model: Drone2D | Drone3D, sensors: SensorKernel) -> dict[str, Any]:
        """The motion's parameters (``max_speed``, ``speed_step``, ``turn_step``) and the
        sensors' state ``ss<j>``."""
        p = model.params
        values = {"max_speed": p.max_speed, "speed_step": p.speed_step, "turn_step": p.turn_step}
        return values | {f"ss{j}": array for j, array in enumerate(sensors.state)}

    @staticmethod
    def _swarm_arguments(sensors: SensorKernel) -> dict[str, Any]:
        """The swarm sensor's state ``ws<j>`` (none without a swarm sensor)."""
        swarm = sensors.swarm
        state = swarm.state if swarm is not None else ()
        return dict(zip(swarm_state_names(swarm), state, strict=True))

    def _message_arguments(self, sim: LoopView, messaging: Messaging) -> dict[str, Any]:
        """The message arguments of ``block_messages_*``: the datalink's range ``reach``,
        ``order``, ``counts``, ``lowest``, each type's inbox (senders, data) filled with
        ``sim.inbox`` (deliveries that reached everyone, checked by :meth:`_fusable`), and
        the handlers' state."""
        types = messaging.types
        if self._inboxes is None or len(self._inboxes) != len(types):
            self._inboxes = []
            for k, handler in enumerate(messaging.handlers):
                leaves = sum(1 for kind, _ in messaging.senders.values() if kind == k)
                capacity = leaves * self.swarm.size  # one message per sending leaf and agent
                self._inboxes.append((np.zeros(capacity, dtype=np.int64),
                                      np.zeros((len(handler.fields), capacity))))  # fmt: skip
        order = np.full(len(types), -1, dtype=np.int64)
        counts = np.zeros(len(types), dtype=np.int64)
        for j, delivery in enumerate(sim.inbox):
            messages = delivery.messages
            k = types.index(messages.type)
            senders, data = self._inboxes[k]
            m = len(messages)
            senders[:m] = messages.senders
            for f, name in enumerate(messaging.handlers[k].fields):
                data[f, :m] = messages.data[name]
            order[j], counts[k] = k, m
        inboxes = [array for pair in self._inboxes for array in pair]
        state = [array for handler in messaging.handlers for array in handler.state]
        lowest = np.zeros(len(types), dtype=np.int64)
        values = {"reach": sim.world.datalink.range, "order": order, "counts": counts}
        values |= {"lowest": lowest} | dict(zip(messaging.inbox_names, inboxes, strict=True))
        return values | dict(zip(messaging.state_names, state, strict=True))

    def fuses(self, sim: LoopView) -> bool:
        """Whether the fused loop can run ``sim``'s iterations (from its start)."""
        return self._fusable(sim) is not None

    def why_not_fused(self, sim: LoopView) -> str:
        """Why the fused loop cannot run ``sim``'s iterations from its start (then each
        iteration runs Phases 2 and 4-6 in NumPy and ticks the compiled tree), or ""."""
        if self._fusable(sim) is not None:
            return ""
        if sim.mission.compiled_sensors(sim) is None:
            return f"mission {sim.mission.name!r}'s sensors (Phase 2) have no compiled form"
        if not isinstance(sim.model, Drone2D):
            return f"the motion model {sim.model.name!r} has no compiled form"
        if self.layout.outboxes and self._messaging(sim) is None:
            return "a message type the tree sends has no compiled handler"
        return "the C library's sin/cos do not give NumPy's bits on this CPU"

    def _messaging(self, sim: LoopView) -> Messaging | None:
        """The compiled handling of the messages the tree sends, or None where a type sent
        has no compiled handler in ``sim`` (or one that reads a field not sent)."""
        types = tuple(dict.fromkeys(self._sends(i).type for i in self.layout.outboxes))
        handlers = []
        for kind in types:
            declared = sim.handlers.get(kind)
            if declared is None or declared.kernel is None:
                return None
            handlers.append(declared.kernel)
        senders = {}
        for i in self.layout.outboxes:
            sends = self._sends(i)
            k = types.index(sends.type)
            if not set(handlers[k].fields) <= set(sends.fields):
                return None
            senders[i] = (k, tuple(3 + sends.fields.index(f) for f in handlers[k].fields))
        recorded = tuple(sim.handlers[kind].recorded for kind in types)
        return Messaging(types, tuple(handlers), recorded, senders)

    def _fusable(self, sim: LoopView) -> Fused | None:
        """What the fused loop calls where it can run ``sim`` now, else None: the mission's
        compiled sensors and the 2-D or 3-D drone; a tree that sends nothing with no message in
        flight, or one whose messages have compiled handlers, the messages in flight being
        ones the loop takes (:meth:`_takes`); records of the layout's columns."""
        if not isinstance(sim.model, Drone2D | Drone3D):  # first: it is asked every iteration
            return None
        sensors = sim.mission.compiled_sensors(sim)
        recorder = sim.recorder
        if (
            sensors is None
            or sim.world.datalink.channel
            or list(recorder.columns) != list(self.layout.names)
            or not recorder.wants_statuses  # (not .behaviour: it stores it in full)
        ):
            return None
        messaging = self._messaging(sim) if self.layout.outboxes else None
        if self.layout.outboxes and messaging is None:
            return None
        if any(not self._takes(d, messaging) for d in sim.inbox):
            return None
        model = sim.model
        if isinstance(model, Drone3D):
            p = model.params
            return Fused(sensors, messaging, (p.max_climb_rate, p.climb_step, p.max_altitude))
        return Fused(sensors, messaging)

    @staticmethod
    def _takes(delivery: Delivery, messaging: Messaging | None) -> bool:
        """Whether the fused loop handles ``delivery`` (of ``sim.inbox``): one that reached
        everyone, of a type the tree sends."""
        return (
            delivery.to_all and messaging is not None and delivery.messages.type in messaging.types
        )
