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

import logging
import time
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent import jit
from pyautonomousagent.bt.leaf import Leaf, leaf_type
from pyautonomousagent.bt.program import compile_tree
from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError
from pyautonomousagent.bt.tree_source import has_source
from pyautonomousagent.engines.compiled_source import (
    CHUNK,
    _control,
    _motion,
    module_source,
    tree_body,
)
from pyautonomousagent.loop.arguments import ordered, parameters
from pyautonomousagent.loop.engine import LoopEngine
from pyautonomousagent.loop.layout import Constants, Fused
from pyautonomousagent.loop.modules import cache_folder, load_source, module_name
from pyautonomousagent.loop.source import Stages
from pyautonomousagent.models.drone2d import Drone2D
from pyautonomousagent.models.drone3d import Drone3D
from pyautonomousagent.record_blocks import RecordBlock
from pyautonomousagent.registry import UnknownNameError
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.recording import Recorder
    from pyautonomousagent.simulation.engine_api import LoopView


#: Most nodes of a tree the compiled engine takes (the missions' trees have 7-19). Its
#: generated source grows linearly with the nodes, numba's compile of it faster: the serial
#: variant of a grouped tree (``compiled_source.INLINE_NODES``) took 29 s at 26 nodes, 40 s
#: at 42 and 113 s at 106 (a busy machine); the serial function of a tree of 210 nodes (eight
#: 25-child nodes) took 611 s on a machine running tests beside it.
MAX_COMPILED_NODES = 128


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
    if not has_source(compile_tree(tree)):
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


class CompiledEngine(LoopEngine):
    """Phase 3 (and, where possible, Phases 2-6) compiled with numba; the batched engine's
    semantics and bits.

    Raises:
        TreeError: the tree cannot be compiled (see :func:`compilable`), or any error the
            batched engine would raise for it.
    """

    name = "compiled"
    #: The per-agent source of the fused loop's stages, also the GPU engine's kernels'.
    stages = Stages(motion=_motion, tree=tree_body, control=_control)

    def __init__(self, tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]) -> None:
        why = compilable(tree)
        if why:
            raise TreeError(f"the compiled engine cannot run this tree: {why}")
        super().__init__(tree, swarm, world, defaults)
        self._module: ModuleType | None = None
        self._fused: Fused | None = None
        self._constants: tuple[np.ndarray, np.ndarray] = Constants().arrays()
        self._no_climb = np.zeros(0)  # the fused loop's u_w argument for the 2-D drone
        self._blocks: RecordBlock | None = None  # where the fused loop writes its records
        self._tick: tuple[ModuleType, list[Any]] | None = None  # tick's code and arguments

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
        code.tick(self.world.iteration, *self._tick_values(code))
        self._send(self.world.datalink)

    def _tick_values(self, code: ModuleType) -> list[Any]:
        """The generated ``tick``'s arguments after the iteration ``t``, matched to its
        parameters by name (:meth:`_tree_arguments`); the same objects every iteration."""
        if self._tick is None or self._tick[0] is not code:
            values = ordered(parameters(code.tick, 1), self._tree_arguments(self._constants),
                             "tick")  # fmt: skip
            self._tick = (code, values)
        return self._tick[1]

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

        arguments = (self.world.iteration, *self._tick_values(code))
        code.tick.compile(tuple(numba.typeof(a) for a in arguments))

    def ready(self, sim: LoopView) -> bool:
        """Whether ``sim`` runs fused and :meth:`prepare` compiled that loop before on this
        machine (numba's cache holds it: set-up takes well under a second)."""
        fused = self._fusable(sim)
        return fused is not None and self._marker(sim, fused).exists()

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
        values = ordered(parameters(block, 5), arguments, function)
        import numba

        groups = -(-self.swarm.size // CHUNK)
        share = max(1, groups // (SHARE * numba.get_num_threads()))
        with numba.parallel_chunksize(share):  # a core that others slow down takes less
            done = block(start, count, every, row0, CHUNK, *values)
        if done:
            blocks.hand_over(row0, (start + done) // every - start // every)
            sim.account_fused(fused.sensors, start, done, stopped)
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
    ) -> dict[str, Any]:  # fmt: skip
        """The fused function's arguments after ``t0, count, every, row0, chunk``, by
        parameter name: the tree's state, the control signals, the record arrays from record
        ``row0`` (empty ones for ``count`` 0: compiling only), the parameters and the
        sensors' state, then the messages' and the swarm sensor's; ``stopped`` (shape (N,),
        int64, -1) gets the iteration at which each agent is found unable to move."""
        recorder = sim.recorder
        traced_at = np.full(self.swarm.size, -1, dtype=np.int64)
        traced_at[recorder.traced] = np.arange(recorder.traced.size)
        columns, traces, behaviour = blocks.arrays(row0) if count else self._empty(recorder)
        assert behaviour is not None  # checked by _fusable
        records = dict(zip(self.layout.record_names, columns, strict=True))
        leaf_rows = recorder.leaf_rows.astype(np.int64)
        records |= {"traces": traces, "traced_at": traced_at, "behaviour": behaviour}
        records |= {"leaf_rows": leaf_rows, "stopped_at": stopped}
        arguments = self._tree_arguments(self._constants)
        arguments |= self._control_arguments(model, self._no_climb) | records
        arguments |= self._model_arguments(model, fused.sensors)
        if fused.messaging is not None:
            arguments |= self._message_arguments(sim, fused.messaging)
        return arguments | self._swarm_arguments(fused.sensors)

    def _empty(self, recorder: Recorder) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """Empty record arrays of the types the fused loop writes (the columns in layout
        order, the traces, the active behaviour), for compiling only: the recorder stores
        nothing (columns it keeps compact stay so: ``RecordedColumns``)."""
        n = self.swarm.size
        columns = [np.empty((0, n), recorder.columns.dtypes[k]) for k in self.layout.names]
        return columns, recorder.traces[:0], np.empty((0, n), np.int16)
