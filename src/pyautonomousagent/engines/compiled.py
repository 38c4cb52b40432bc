"""The compiled engine: the tree as generated code compiled with numba, agent by agent.

The tree is flattened as for the batched engine, turned into Python source (one function
per node, :mod:`~pyautonomousagent.engines.compiled_source`) that calls each leaf's
:class:`~pyautonomousagent.kernels.LeafKernel`, and compiled with numba once (the module is
kept in a cache folder, so numba's own cache serves later runs). The node statuses and
remembered children are the batched engine's arrays, updated by the same rules, so both
engines give the same bits.

Where the run allows it (the mission's sensors have a compiled form, the motion model is the
2-D or the 3-D drone), :meth:`CompiledEngine.loop` runs whole iterations, Phases 2 to 6, in
one compiled call. A tree that sends no message runs ``CHUNK`` agents at a time over many
iterations, on every core, unless the sensors sense the whole swarm at once
(``SwarmSensorKernel``, e.g. collisions): then it runs iteration by iteration, the swarm
sensor once an iteration before the agents' phases. A tree that sends messages runs
iteration by iteration, its messages handled by the mission's compiled handlers
(``MessageType.kernel``) while they reach every agent; a delivery that reaches only some, or
a recorded message type, is handed to the datalink in Python. Elsewhere the simulation calls
:meth:`CompiledEngine.tick` once per iteration, and what the leaves sent goes to the datalink
after it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import logging
import os
import re
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent import jit
from pyautonomousagent.bt.leaf import Leaf, check_leaves, leaf_type, make_leaf
from pyautonomousagent.bt.program import Program, compile_tree
from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError, check_entries
from pyautonomousagent.bt.tree_source import memory_rows, memory_size
from pyautonomousagent.engines.compiled_source import (
    CHUNK,
    Constants,
    Layout,
    Messaging,
    deferrable,
    module_source,
    supported,
)
from pyautonomousagent.kernels import LeafKernel, Sends, SensorKernel
from pyautonomousagent.models.drone2d import Drone2D
from pyautonomousagent.models.drone3d import Drone3D
from pyautonomousagent.record_blocks import RecordBlock
from pyautonomousagent.registry import UnknownNameError
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.datalink import Datalink, Delivery
    from pyautonomousagent.recording import Recorder
    from pyautonomousagent.simulation.engine_api import LoopView


#: Most nodes of a tree the compiled engine takes. Its generated source grows with the square
#: of a control node's children (each child's case halts the others): a Fallback of 1000
#: leaves took 12 s to generate, before any compiling; the paper's trees have under 30 nodes.
MAX_COMPILED_NODES = 256


def compilable(tree: Node) -> str:
    """Why ``tree`` cannot run on the compiled engine, or "" when it can: numba is missing
    (or ``PYAA_NO_JIT`` is set), the tree has more than :data:`MAX_COMPILED_NODES` nodes, a
    control node has no compiled form, or a leaf has no kernel, reads a port from the
    blackboard, or must be told when halted."""
    if not jit.available():
        return "numba is not installed (the [fast] extra) or PYAA_NO_JIT is set"
    nodes = sum(1 for _ in tree.walk())
    if nodes > MAX_COMPILED_NODES:
        return f"the tree has {nodes} nodes, more than the {MAX_COMPILED_NODES} it compiles"
    if not supported(compile_tree(tree)):
        return "a control node has no compiled form (or has scripts)"
    for node in tree.leaves():
        try:
            cls = leaf_type(node.type)
        except (UnknownNameError, ValueError):
            return f"leaf {node.name!r} ({node.type}) is no leaf of the library"
        if cls.kernel is Leaf.kernel or cls.halt is not Leaf.halt:
            return f"leaf {node.name!r} ({node.type}) has no kernel"
        if any(isinstance(v, BlackboardRef) for v in node.params.values()):
            return f"leaf {node.name!r} ({node.type}) reads a port from the blackboard"
    return ""


def cache_folder() -> Path:
    """Where generated modules are kept: ``$PYAA_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/pyautonomousagent/compiled`` (``~/.cache`` by default)."""
    if os.environ.get("PYAA_CACHE_DIR"):
        return Path(os.environ["PYAA_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pyautonomousagent" / "compiled"


def module_name(source: str) -> str:
    """The name of generated ``source``'s module: a hash of it and of the files of the
    modules it imports from (numba's cache checks only the generated file, so a changed
    kernel must give a new name)."""
    digest = hashlib.sha256(source.encode())
    for module in sorted(set(re.findall(r"^from (\S+) import", source, re.MULTILINE))):
        spec = importlib.util.find_spec(module)
        if spec is not None and spec.origin and os.path.isfile(spec.origin):
            digest.update(Path(spec.origin).read_bytes())
    return "pyaa_tree_" + digest.hexdigest()[:24]


def load_source(source: str) -> ModuleType:
    """Import generated ``source`` as a module from a file named by :func:`module_name`
    (written once; numba caches the compiled functions beside it)."""
    name = module_name(source)
    if name in sys.modules:
        return sys.modules[name]
    folder = cache_folder()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.py"
    if not path.exists():
        temporary = folder / f"{name}.{os.getpid()}.tmp"
        temporary.write_text(source)
        temporary.replace(path)
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


#: Where :meth:`CompiledEngine.prepare` says that it compiles, and how long it took.
compile_log = logging.getLogger("pyautonomousagent.compile")
#: Set-up seconds from which :meth:`CompiledEngine.prepare` says how long compiling took
#: (loading a compiled tree from numba's cache takes well under a second).
SAY_COMPILE_SECONDS = 1.0


#: Agent-iterations from which :meth:`CompiledEngine.loop` runs numba's parallel function
#: (on every core, and about twice as fast per agent on one: numba passes its arrays
#: without reference counting); its threads can take milliseconds to start on a busy
#: machine, more than a few agents' iteration.
PARALLEL = 100_000


#: Agents from which a tree that sends messages runs numba's parallel function: it starts the
#: threads three times an iteration (tens of microseconds), which this many agents' iteration
#: (about a millisecond on one core) pays for.
PARALLEL_AGENTS = 20_000


#: The parallel loop hands each thread about 1 / SHARE of its share of the chunks at a time
#: (dynamic sharing: on a shared machine one core can run at a fraction of the other's speed).
SHARE = 8


@dataclass(frozen=True)
class Fused:
    """What the fused loop of a run calls: the mission's compiled sensors and, where the
    tree sends messages, their compiled handling; for the 3-D drone, its vertical
    parameters (``Layout.vertical``)."""

    sensors: SensorKernel
    messaging: Messaging | None
    vertical: tuple[float, float, float] | None = None


class CompiledEngine:
    """Phase 3 (and, where possible, Phases 2-6) compiled with numba; the batched engine's
    semantics and bits.

    Raises:
        TreeError: the tree cannot be compiled (see :func:`compilable`), or any error the
            batched engine would raise for it.
    """

    name = "compiled"

    def __init__(self, tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]) -> None:
        why = compilable(tree)
        if why:
            raise TreeError(f"the compiled engine cannot run this tree: {why}")
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
        rows = memory_rows(self.program)
        senders = tuple(i for i, kernel in sorted(self.kernels.items()) if kernel.sends)
        self.layout = Layout(
            tuple(swarm.columns) + tuple(swarm.blackboard),
            rows,
            senders,
            deferrable(self.program, self.kernels),
        )
        self.pending = np.full(swarm.size, -1, dtype=np.int32)  # deferred Later steps
        self.status = np.zeros((len(self.program.nodes), swarm.size), dtype=np.int8)
        self.current = np.zeros((memory_size(self.program), swarm.size), dtype=np.int32)
        self.outboxes = {i: np.zeros((3 + len(self._sends(i).fields), swarm.size)) for i in senders}
        self.arrays = [{**swarm.columns, **swarm.blackboard}[k] for k in self.layout.names]
        self.arrays += list(self.outboxes.values())
        self._module: ModuleType | None = None
        self._fused: Fused | None = None
        self._constants: tuple[np.ndarray, np.ndarray] = Constants().arrays()
        self._inboxes: list[tuple[np.ndarray, np.ndarray]] | None = None
        self._no_climb = np.zeros(0)  # the fused loop's u_w argument for the 2-D drone
        self._blocks: RecordBlock | None = None  # where the fused loop writes its records

    def _sends(self, node: int) -> Sends:
        sends = self.kernels[node].sends
        assert sends is not None
        return sends

    def _code(self, fused: Fused | None) -> ModuleType:
        if self._module is None or (fused is not None and self._fused is None):
            source, self._constants = self._source(fused)
            self._module, self._fused = load_source(source), fused
        return self._module

    def _source(self, fused: Fused | None) -> tuple[str, tuple[np.ndarray, np.ndarray]]:
        """The generated module for ``fused`` (or the tick only), and the arrays ``kf``,
        ``ki`` of the numbers it reads."""
        sensors, messaging = (fused.sensors, fused.messaging) if fused else (None, None)
        vertical = fused.vertical if fused else None
        layout = replace(self.layout, constants=Constants(), vertical=vertical)
        source = module_source(self.program, self.kernels, layout, sensors, messaging)
        return source, layout.constants.arrays()

    def tick(self) -> None:
        """Tick the tree once for every agent (at the world's iteration); what the leaves
        sent goes to the datalink."""
        code = self._code(self._fused)
        code.tick(self.world.iteration, self.status, self.current, self.pending, *self._constants,
                  *self.arrays)  # fmt: skip
        self._send(self.world.datalink)

    def _send(self, datalink: Datalink) -> None:
        """Hand the outboxes' messages to ``datalink``, leaf by leaf in node order, senders in
        ascending rows: the batched engine's calls of ``Leaf.broadcast``."""
        for i, box in self.outboxes.items():
            rows = np.flatnonzero(box[0] == 1.0)
            if rows.size:
                sends = self._sends(i)
                data = {f: box[3 + j, rows] for j, f in enumerate(sends.fields)}
                datalink.send(rows, sends.type, data, (box[1, rows], box[2, rows]))

    def prepare(self, sim: LoopView) -> None:
        """Compile (or load from numba's cache) what this run will call, before its loop:
        the fused loop's serial and parallel functions both (:meth:`variants`), so that a
        later run of any swarm size or length finds them compiled; mark them compiled (see
        :meth:`ready`). Its seconds go to ``sim.timings["compile"]``; on the
        ``pyautonomousagent.compile`` logger (INFO, which ``pyaa run`` and ``pyaa sweep``
        show) a line before a fused loop is compiled for the first time on this machine,
        and one saying how long it took where that was :data:`SAY_COMPILE_SECONDS` or
        more."""
        began = time.perf_counter()
        fused = self._fusable(sim)
        if fused is None:
            self._compile_tick(self._code(None))
        else:
            marker = self._marker(sim, fused)
            if not marker.exists():
                compile_log.info("compiling this tree's fused loop for the compiled engine, "
                                 "serial and parallel (once on this machine: numba's cache "
                                 "keeps it) ...")  # fmt: skip
            for name in self.variants(fused):
                self._call(sim, fused, 0, name)
            marker.parent.mkdir(parents=True, exist_ok=True)  # (a module loaded before it)
            marker.touch()
        seconds = sim.timings["compile"] = time.perf_counter() - began
        if seconds >= SAY_COMPILE_SECONDS:
            compile_log.info("compiled engine: compiling (or loading) the tree's code took "
                             "%.1f s", seconds)  # fmt: skip

    def sync(self, sim: LoopView) -> None:
        """Nothing to finish: :meth:`loop` returns with its records and state written."""

    def _compile_tick(self, code: ModuleType) -> None:
        """Compile (or load from numba's cache) ``code.tick`` for this run's arguments, so
        that the run's first iteration does not (numba compiles on a function's first call:
        a cold compile of x8-patrol's tree took 8 s of its first iteration)."""
        import numba

        arguments = (self.world.iteration, self.status, self.current, self.pending,
                     *self._constants, *self.arrays)  # fmt: skip
        code.tick.compile(tuple(numba.typeof(a) for a in arguments))

    def ready(self, sim: LoopView) -> bool:
        """Whether ``sim`` runs fused and :meth:`prepare` compiled that loop before on this
        machine (numba's cache holds it: set-up takes well under a second)."""
        fused = self._fusable(sim)
        return fused is not None and self._marker(sim, fused).exists()

    def fuses(self, sim: LoopView) -> bool:
        """Whether :meth:`loop` can run ``sim``'s iterations (from its start)."""
        return self._fusable(sim) is not None

    def why_not_fused(self, sim: LoopView) -> str:
        """Why :meth:`loop` cannot run ``sim``'s iterations from its start (then each
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

    def _marker(self, sim: LoopView, fused: Fused) -> Path:
        """The file saying that the fused functions ``sim``'s loop calls (serial and
        parallel: :meth:`variants`) are in numba's cache."""
        kind = self.variants(fused)[0].removesuffix("_serial")
        return cache_folder() / f"{module_name(self._source(fused)[0])}.{kind}.compiled"

    def variants(self, fused: Fused) -> tuple[str, str]:
        """The fused functions of ``fused``'s kind, serial then parallel: which one a call
        runs depends on the swarm's size and the iterations (:meth:`_function`)."""
        if fused.messaging is not None or fused.sensors.swarm is not None:
            kind = "messages" if fused.messaging is not None else "swarm"
            return f"block_{kind}_serial", f"block_{kind}_parallel"
        return "block_serial", "block_parallel"

    def _function(self, fused: Fused, iterations: int) -> str:
        """The fused function a call of ``iterations`` iterations runs: the parallel one
        where it pays for starting the threads (once a call without messages, three times
        an iteration with them)."""
        serial, parallel = self.variants(fused)
        if fused.messaging is not None or fused.sensors.swarm is not None:
            return parallel if self.swarm.size >= PARALLEL_AGENTS else serial
        return parallel if iterations * self.swarm.size >= PARALLEL else serial

    def node_statuses(self) -> np.ndarray:
        """Status codes after the last tick, shape (nodes in tick order, N), int8."""
        return self.status.copy()

    def loop(self, sim: LoopView, count: int, typical: int | None = None) -> int:
        """Run up to ``count`` whole iterations in compiled code; return how many were run:
        0 where this run cannot be fused now (then call ``sim.step()``). Phases 2-6 of
        each, except the last one's Phase 5: its messages wait on the datalink's channel,
        for the caller to deliver. Fewer iterations where their records would not fit in
        the record block's budget (:class:`~pyautonomousagent.record_blocks.RecordBlock`:
        the columns the recorder keeps compact are written into its buffers and handed to
        the recorder after the call). ``typical``: pick the compiled function as for that
        many iterations (``count`` 0 compiles it and runs nothing)."""
        fused = self._fusable(sim)
        if fused is None:
            return 0
        return self._call(sim, fused, count, self._function(fused, typical or count))

    def _call(self, sim: LoopView, fused: Fused, count: int, function: str) -> int:
        """:meth:`loop` by the fused function named ``function`` (chosen before the count
        is cut to the records that fit: a short call runs the function of a long one)."""
        model = sim.model
        assert isinstance(model, Drone2D | Drone3D)
        block = getattr(self._code(fused), function)
        start, every = sim.world.iteration, sim.recorder.every
        row0 = start // every + 1  # the first record these iterations can write
        blocks = self._block(sim.recorder)
        count = blocks.fit(start, count) if count else 0
        stopped = np.full(self.swarm.size, -1, dtype=np.int64)  # the iteration each stopped at
        arguments = self._arguments(sim, fused, model, blocks, row0, count, stopped)
        import numba

        groups = -(-self.swarm.size // CHUNK)
        share = max(1, groups // (SHARE * numba.get_num_threads()))
        with numba.parallel_chunksize(share):  # a core that others slow down takes less
            done = block(start, count, every, row0, CHUNK, *arguments)
        if fused.messaging is not None and done:
            sim.inbox = []  # handled in the first iteration
        if done:
            blocks.hand_over(row0, (start + done) // every - start // every)
            self._after(sim, fused.sensors, start, done, stopped)
            self._send(sim.world.datalink)
        return int(done)

    def _block(self, recorder: Recorder) -> RecordBlock:
        """The run's record block (made for ``recorder`` once)."""
        if self._blocks is None or self._blocks.recorder is not recorder:
            self._blocks = RecordBlock(recorder, self.layout.names)
        return self._blocks

    def _arguments(
        self, sim: LoopView, fused: Fused, model: Drone2D | Drone3D, blocks: RecordBlock,
        row0: int, count: int, stopped: np.ndarray,
    ) -> tuple[Any, ...]:  # fmt: skip
        """The fused function's arguments after ``t0, count, every, row0, chunk``: the
        state, the control signals, the record arrays from record ``row0`` (empty ones for
        ``count`` 0: compiling only), the parameters, the sensors' state, then the messages'
        and the swarm sensor's; ``stopped`` (shape (N,), int64, -1) gets the iteration at
        which each agent is found unable to move."""
        recorder = sim.recorder
        u_climb = model.u_climb if isinstance(model, Drone3D) else self._no_climb
        traced_at = np.full(self.swarm.size, -1, dtype=np.int64)
        traced_at[recorder.traced] = np.arange(recorder.traced.size)
        columns, traces, behaviour = blocks.arrays(row0) if count else self._empty(recorder)
        assert behaviour is not None  # checked by _fusable
        p = model.params
        arguments = (
            self.status, self.current, self.pending, *self._constants, *self.arrays,
            model.u_speed, model.u_heading, u_climb, *columns, traces,
            traced_at, behaviour, recorder._leaf_rows.astype(np.int64), stopped,
            p.max_speed, p.speed_step, p.turn_step, *fused.sensors.state,
        )  # fmt: skip
        if fused.messaging is not None:
            arguments += tuple(self._inbox(sim, fused.messaging))
        if fused.sensors.swarm is not None:
            arguments += fused.sensors.swarm.state
        return arguments

    def _inbox(self, sim: LoopView, messaging: Messaging) -> list[Any]:
        """The arguments of ``block_messages_*`` after the common ones: the datalink's range,
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
        return [sim.world.datalink.range, order, counts, lowest, *inboxes, *state]

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

    def _empty(self, recorder: Recorder) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """Empty record arrays of the types the fused loop writes (the columns in layout
        order, the traces, the active behaviour), for compiling only: the recorder stores
        nothing (columns it keeps compact stay so: ``RecordedColumns``)."""
        n = self.swarm.size
        columns = [np.empty((0, n), recorder.columns.dtypes[k]) for k in self.layout.names]
        return columns, recorder.traces[:0], np.empty((0, n), np.int16)

    def _fusable(self, sim: LoopView) -> Fused | None:
        """What :meth:`loop` calls where it can run ``sim`` now, else None: the mission's
        compiled sensors and the 2-D or 3-D drone; a tree that sends nothing with no message in
        flight, or one whose messages have compiled handlers, the messages in flight having
        reached everyone; records of the layout's columns."""
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

    @staticmethod
    def _after(
        sim: LoopView, sensors: SensorKernel, start: int, count: int, stopped: np.ndarray
    ) -> None:
        """The bookkeeping of a fused run: the sensors' alerts and what the swarm sensor
        kept, in order of iteration (an iteration's alerts first, as Phase 2 raises them),
        the world's clock, the recorder's iterations and count."""
        collect = sensors.swarm.collect if sensors.swarm is not None else None
        for t in np.unique(stopped[stopped >= 0]).tolist():
            if collect is not None:
                collect(sim, t - 1)
            sim.world.iteration = t
            if sensors.stopped is not None:
                sensors.stopped(sim, np.flatnonzero(stopped == t))
        if collect is not None:
            collect(sim, start + count)
        sim.world.iteration = start + count
        recorder = sim.recorder
        for t in range(start + 1, start + count + 1):
            if recorder.due(t):
                recorder.iterations[recorder.count] = t
                recorder.count += 1
        for listener in recorder.listeners:  # e.g. the states written while the run goes
            listener(recorder.count)
