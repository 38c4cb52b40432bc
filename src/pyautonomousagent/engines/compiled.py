"""The compiled engine: the tree as generated code compiled with numba, agent by agent.

The tree is flattened as for the batched engine, turned into Python source (one function
per node, :mod:`~pyautonomousagent.engines.compiled_source`) that calls each leaf's
:class:`~pyautonomousagent.kernels.LeafKernel`, and compiled with numba once (the module is
kept in a cache folder, so numba's own cache serves later runs). The node statuses and
remembered children are the batched engine's arrays, updated by the same rules, so both
engines give the same bits.

Where the run allows it (the mission's sensors have a compiled form, the motion model is the
2-D drone, no message is in flight: no leaf with a kernel sends any, and the C library's
``sin``/``cos`` give NumPy's bits on this CPU: :func:`trig_agrees_with_numpy`),
:meth:`CompiledEngine.loop` runs whole iterations, Phases 2 to 6, in one compiled call,
``CHUNK`` agents at a time and on every core; elsewhere the simulation calls
:meth:`CompiledEngine.tick` once per iteration.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent import jit
from pyautonomousagent.bt.leaf import Leaf, check_leaves, leaf_type, make_leaf
from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError, check_entries
from pyautonomousagent.engines.batched import Program, compile_tree
from pyautonomousagent.engines.compiled_runtime import trig_agrees_with_numpy
from pyautonomousagent.engines.compiled_source import CHUNK, Layout, module_source, supported
from pyautonomousagent.kernels import LeafKernel, SensorKernel
from pyautonomousagent.models.drone2d import Drone2D
from pyautonomousagent.registry import UnknownNameError
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.recording import Recorder
    from pyautonomousagent.simulation.run import Simulation


def compilable(tree: Node) -> str:
    """Why ``tree`` cannot run on the compiled engine, or "" when it can: numba is missing
    (or ``PYAA_NO_JIT`` is set), a control node has no compiled form, or a leaf has no
    kernel, reads a port from the blackboard, or must be told when halted."""
    if not jit.available():
        return "numba is not installed (the [fast] extra) or PYAA_NO_JIT is set"
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


def load_source(source: str) -> ModuleType:
    """Import generated ``source`` as a module from a file named by its hash (written once;
    numba caches the compiled functions beside it)."""
    name = "pyaa_tree_" + hashlib.sha256(source.encode()).hexdigest()[:24]
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


#: Agent-iterations from which :meth:`CompiledEngine.loop` runs numba's parallel function
#: (on every core, and about twice as fast per agent on one: numba passes its arrays
#: without reference counting); its threads can take milliseconds to start on a busy
#: machine, more than a few agents' iteration.
PARALLEL = 100_000


#: The parallel loop hands each thread about 1 / SHARE of its share of the chunks at a time
#: (dynamic sharing: on a shared machine one core can run at a fraction of the other's speed).
SHARE = 8


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
        memory = [i for i, n in enumerate(self.program.nodes) if n.type in ("Sequence", "Fallback")]
        self.layout = Layout(
            tuple(swarm.columns) + tuple(swarm.blackboard), {i: k for k, i in enumerate(memory)}
        )
        self.status = np.zeros((len(self.program.nodes), swarm.size), dtype=np.int8)
        self.current = np.full((len(memory), swarm.size), -1, dtype=np.int32)
        self.arrays = [{**swarm.columns, **swarm.blackboard}[k] for k in self.layout.names]
        self._module: ModuleType | None = None
        self._sensors: SensorKernel | None = None
        self._trig = np.full((3, swarm.size), np.nan)  # heading, its sine and cosine
        self._trig_agrees: bool | None = None  # compiled sin/cos give NumPy's bits

    def _code(self, sensors: SensorKernel | None) -> ModuleType:
        if self._module is None or (sensors is not None and self._sensors is None):
            source = module_source(self.program, self.kernels, self.layout, sensors)
            self._module, self._sensors = load_source(source), sensors
        return self._module

    def tick(self) -> None:
        """Tick the tree once for every agent (at the world's iteration)."""
        self._code(self._sensors).tick(
            self.world.iteration, self.status, self.current, *self.arrays
        )

    def prepare(self, sim: Simulation) -> None:
        """Compile (or load from numba's cache) what this run will call, before its loop."""
        if self._fusable(sim) is not None:
            self.loop(sim, 0, typical=min(sim.scenario.iterations, 500))
        else:
            self._code(None)

    def node_statuses(self) -> np.ndarray:
        """Status codes after the last tick, shape (nodes in tick order, N), int8."""
        return self.status.copy()

    def loop(self, sim: Simulation, count: int, typical: int | None = None) -> int:
        """Run up to ``count`` whole iterations (Phases 2-6) in compiled code; return how many
        were run: 0 where this run cannot be fused (then call ``sim.step()``). ``typical``:
        pick the compiled function as for that many iterations (``count`` 0 compiles it)."""
        sensors = self._fusable(sim)
        if sensors is None:
            return 0
        recorder, model = sim.recorder, sim.model
        assert isinstance(model, Drone2D)
        code = self._code(sensors)
        start, every = sim.world.iteration, recorder.every
        traced_at = np.full(self.swarm.size, -1, dtype=np.int64)
        traced_at[recorder.traced] = np.arange(recorder.traced.size)
        stopped = np.full(self.swarm.size, -1, dtype=np.int64)
        p = model.params
        parallel = (typical or count) * self.swarm.size >= PARALLEL
        block = code.block_parallel if parallel else code.block_serial
        import numba

        groups = -(-self.swarm.size // CHUNK)
        share = max(1, groups // (SHARE * numba.get_num_threads()))
        records = self._records(recorder, count)  # the columns, then the active behaviour
        with numba.parallel_chunksize(share):  # a core that others slow down takes less
            block(start, count, every, CHUNK, self.status, self.current, *self.arrays,
                  model.u_speed, model.u_heading, self._trig,
                  *records[:-1], recorder.traces,
                  traced_at, records[-1], recorder._leaf_rows.astype(np.int64),
                  stopped, p.max_speed, p.speed_step, p.turn_step)  # fmt: skip
        self._after(sim, sensors, start, count, stopped)
        return count

    def _records(self, recorder: Recorder, count: int) -> list[np.ndarray]:
        """The record arrays the fused loop writes, shape (records, N) each: the recorded
        columns in layout order, then the active behaviour. For ``count`` 0 (compiling only)
        empty ones of the same types, so that compiling does not make the recorder store
        columns it keeps as one value while agents are alike (``RecordedColumns``)."""
        if count:
            assert recorder.behaviour is not None  # checked by _fusable
            return [*(recorder.columns[k] for k in self.layout.names), recorder.behaviour]
        dtypes = [*(recorder.columns.dtypes[k] for k in self.layout.names), np.dtype(np.int16)]
        return [np.empty((0, self.swarm.size), dtype) for dtype in dtypes]

    def _fusable(self, sim: Simulation) -> SensorKernel | None:
        """The mission's compiled sensors where :meth:`loop` can run ``sim``, else None."""
        sensors = sim.mission.compiled_sensors(sim)
        recorder = sim.recorder
        if (
            sensors is None
            or not isinstance(sim.model, Drone2D)
            or sim.inbox
            or sim.world.datalink.channel
            or list(recorder.columns) != list(self.layout.names)
            or recorder.behaviour is None
        ):
            return None
        if self._trig_agrees is None:
            self._trig_agrees = trig_agrees_with_numpy()
        return sensors if self._trig_agrees else None

    @staticmethod
    def _after(
        sim: Simulation, sensors: SensorKernel, start: int, count: int, stopped: np.ndarray
    ) -> None:
        """The bookkeeping of a fused run: the sensors' alerts in order of iteration, the
        world's clock, the recorder's iterations and count."""
        for t in np.unique(stopped[stopped >= 0]).tolist():
            sim.world.iteration = t
            if sensors.stopped is not None:
                sensors.stopped(sim, np.flatnonzero(stopped == t))
        sim.world.iteration = start + count
        recorder = sim.recorder
        for t in range(start + 1, start + count + 1):
            if recorder.due(t):
                recorder.iterations[recorder.count] = t
                recorder.count += 1
        for listener in recorder.listeners:  # e.g. the states written while the run goes
            listener(recorder.count)
