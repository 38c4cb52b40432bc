"""The GPU engine (in progress): the compiled engine's fused loop as a CUDA kernel.

``engine="gpu"`` runs the drone missions whose sensors and message handlers are compiled with
one CUDA thread per agent: the kernels are written by the compiled engine's generator
(:mod:`~pyautonomousagent.engines.gpu_source`) and compiled by numba-cuda with FMA
contraction off, so they do the NumPy engine's arithmetic operation for operation. A tree
that sends messages runs iteration by iteration (:mod:`~pyautonomousagent.engines.gpu_messages`).
The swarm's state stays on the device for the whole run; each :meth:`GpuEngine.loop` call's
records are copied back while the next call runs
(:mod:`~pyautonomousagent.engines.gpu_records`), the state only by :meth:`GpuEngine.sync`.
docs/architecture.md, "The GPU engine", has the whole design.

Without numba-cuda, CuPy or a CUDA device, creating the engine raises
:class:`GpuUnavailableError` (one line naming the install command). With
``NUMBA_ENABLE_CUDASIM=1`` numba's CUDA simulator stands in for the device (for tests).
"""

from __future__ import annotations

import sys
import time
import types
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from pyautonomousagent.engines import cuda_jit
from pyautonomousagent.engines.gpu_records import RecordGroups, Slot
from pyautonomousagent.engines.gpu_source import Thread, kernel_module_source, message_module_source
from pyautonomousagent.inputs import InputError
from pyautonomousagent.loop.arguments import ordered, parameters
from pyautonomousagent.loop.engine import LoopEngine
from pyautonomousagent.loop.layout import Constants, Fused, Messaging
from pyautonomousagent.loop.modules import load_source
from pyautonomousagent.loop.source import fused_parameters, record_parameters, swarm_state_names
from pyautonomousagent.models.drone2d import Drone2D
from pyautonomousagent.models.drone3d import Drone3D

if TYPE_CHECKING:
    from pyautonomousagent.datalink import Delivery
    from pyautonomousagent.engines.gpu_messages import DeviceMessages
    from pyautonomousagent.simulation.engine_api import LoopView

#: How to install what the GPU engine needs.
INSTALL = "pip install 'pyautonomousagent[gpu]' (numba-cuda and CuPy for CUDA 13)"

#: Threads per block of the kernel.
THREADS = 256

#: The parts of a run :attr:`GpuEngine.timings` gives, in seconds: "compile" (in set-up:
#: generating and compiling the kernel, allocating the record groups), "kernel" (the kernels'
#: device time), "copy_back" (the record groups' copies, device time, and handing them to the
#: recorder, host time; under the simulator host times throughout) and "state" (copying the
#: state to the device and back, host time).
TIMINGS = ("compile", "kernel", "copy_back", "state")


class GpuUnavailableError(InputError):
    """The GPU engine cannot run here (no numba-cuda, no CuPy, or no CUDA device)."""


def simulating() -> bool:
    """Whether numba's CUDA simulator stands in for a device (``NUMBA_ENABLE_CUDASIM=1``)."""
    try:
        from numba import config
    except ImportError:
        return False
    return bool(getattr(config, "ENABLE_CUDASIM", False))


def gpu_problem() -> str | None:
    """Why the GPU engine cannot run here, or None where it can (or the simulator is on)."""
    if simulating():
        return None
    try:
        import cupy
        from numba import cuda
    except ImportError as error:
        return f"{error.name or 'a package'} is not installed"
    try:
        count = int(cupy.cuda.runtime.getDeviceCount())
    except Exception as error:  # CUDARuntimeError: no driver or no device
        return f"no CUDA device ({type(error).__name__}: {str(error).splitlines()[0]})"
    if count == 0 or not cuda.is_available():
        return "no CUDA device that numba-cuda can use"
    return None


#: Drone-iterations (agents x iterations) from which "auto" takes the GPU engine where a
#: device is present (:func:`auto_takes_gpu`); None: never. It stays None until
#: ``scripts/gpu_figures.sh`` has shown the device's bits equal to the batched engine's and
#: measured (its ``crossover`` step) where the GPU starts to win (docs/performance.md, "GPU
#: engine on an H100": the crossover measured there waits for bits that match).
AUTO_DRONE_ITERATIONS: int | None = None


def auto_takes_gpu(agents: int, iterations: int) -> bool:
    """Whether "auto" takes the GPU engine for a run of ``agents`` x ``iterations``: at
    least :data:`AUTO_DRONE_ITERATIONS`, a device present (:func:`gpu_problem` is None),
    and not numba's CUDA simulator (a stand-in for tests, slower than any CPU engine)."""
    least = AUTO_DRONE_ITERATIONS
    if least is None or agents * iterations < least or simulating():
        return False
    return gpu_problem() is None


def require_gpu() -> None:
    """Raise :class:`GpuUnavailableError` (one line with the install command) where
    :func:`gpu_problem` finds one."""
    problem = gpu_problem()
    if problem is not None:
        raise GpuUnavailableError(f"engine gpu: {problem}; install with: {INSTALL}, on a machine "
                             "with an NVIDIA GPU and its driver")  # fmt: skip


def nvvm_units() -> list[Any]:
    """Every NVVM ``CompilationUnit`` class of the loaded numba-cuda modules (one, unless
    numba-cuda is importable under two module names: each is patched by :func:`no_fma`);
    [] under the simulator, whose stand-in module has none."""
    if simulating():
        return []
    import numba.cuda.codegen  # noqa: F401  (loads the nvvm module the code generator uses)

    units = {id(unit): unit for name, module in list(sys.modules.items())
             if name.endswith("cudadrv.nvvm")
             and isinstance(unit := getattr(module, "CompilationUnit", None), type)}  # fmt: skip
    return list(units.values())


@contextmanager
def no_fma() -> Iterator[None]:
    """Compile CUDA code with NVVM's ``-fma=0`` (no contraction of ``a * b + c`` into one
    rounding): numba-cuda passes ``fma`` only with ``fastmath=True``, and NVVM contracts by
    default. While the body runs, every NVVM compilation unit numba-cuda makes (of each
    class :func:`nvvm_units` finds, whichever function makes it) gets ``fma=False`` in its
    options. (Nothing to do under the simulator, which compiles nothing.)"""
    originals = [(unit, unit.__init__) for unit in nvvm_units()]

    def patched(original: Any) -> Any:
        def init(self: Any, options: Any, *args: Any, **kwargs: Any) -> None:
            original(self, {**options, "fma": False}, *args, **kwargs)

        return init

    for unit, original in originals:
        unit.__init__ = patched(original)
    try:
        yield
    finally:
        for unit, original in originals:
            unit.__init__ = original


def _text(name: str | bytes) -> str:
    """A device's name as text (numba-cuda gives bytes in some versions, str in others)."""
    return name.decode() if isinstance(name, bytes) else name


def load_kernel(source: str, name: str = "block_gpu") -> Any:
    """Function ``name`` of generated ``source`` as a CUDA kernel (:func:`.cuda_jit.kernel`:
    no fast math, no link-time optimisation). Under the simulator the njit helpers it calls
    with arrays run as Python (their ``py_func``): the simulator's arrays are not NumPy's."""
    module = load_source(source)
    if simulating():
        for key, value in list(vars(module).items()):
            if key != "cuda" and hasattr(value, "py_func"):
                setattr(module, key, _python(value))
    return cuda_jit.kernel(getattr(module, name))


def _python(function: Any, made: dict[int, Any] | None = None) -> Any:
    """An njit ``function`` as plain Python for the simulator: its ``py_func`` with the njit
    functions it calls made plain Python too (in a copy of its globals: the module's own
    are left to the compiled code); one that uses ``numba.cuda`` (e.g. its atomics) as the
    simulator's device function, which gives it the running thread's ``cuda``."""
    from numba import cuda

    made = {} if made is None else made
    if id(function) in made:
        return made[id(function)]
    py = function.py_func
    names = dict(py.__globals__)
    plain = types.FunctionType(py.__code__, names, py.__name__, py.__defaults__, py.__closure__)
    made[id(function)] = plain
    for key in py.__code__.co_names:
        value = names.get(key)
        if value is not None and hasattr(value, "py_func"):
            names[key] = _python(value, made)
    if any(names.get(key) is cuda for key in py.__code__.co_names):
        made[id(function)] = cuda.jit(device=True)(plain)
    return made[id(function)]


def fma_free(kernel: Any) -> bool:
    """Whether the compiled ``kernel``'s PTX has no fused multiply-add (True under the
    simulator, which compiles nothing)."""
    if simulating():
        return True
    return not any("fma." in ptx for ptx in kernel.inspect_asm().values())


class GpuEngine(LoopEngine):
    """The fused loop of a ``host`` engine's tree on a CUDA device (see the module's
    docstring): it shares the host's arrays (:meth:`LoopEngine._share`), writes its kernels
    with the host's per-agent stages (``host.stages``), and has the host tick the iterations
    stepped on the CPU. (The simulation gives it a compiled engine of the run's tree.)

    Raises:
        GpuUnavailableError: no numba-cuda, CuPy or device (see :func:`gpu_problem`).
    """

    name = "gpu"

    def __init__(self, host: LoopEngine) -> None:
        require_gpu()
        self._share(host)
        self.host, self.stages = host, host.stages
        self._kernel: Any = None
        self._messages: DeviceMessages | None = None
        self._kernel_constants: tuple[np.ndarray, np.ndarray] = (np.zeros(1), np.zeros(1, int))
        self._device: dict[str, Any] | None = None  # the state, by parameter name
        self._readings: dict[str, Any] = {}  # the sensors' state (ss<j>), on the device
        self._swarm_kernels: list[Any] = []  # the swarm sensor's device steps (swarm_<j>)
        self._swarm_state: tuple[np.ndarray, ...] = ()  # its state (host), written on the device
        self._swarm_device: list[Any] = []  # and on the device
        self._synced = -1  # the iteration the device's state is of (-1: none sent)
        self._host_synced = -1  # the iteration the state copied back is of
        self._groups: RecordGroups | None = None
        self.timings = dict.fromkeys(TIMINGS, 0.0)

    def tick(self) -> None:
        """Tick the tree once for every agent on the CPU (the host's tick: an iteration the
        kernels cannot run)."""
        self.host.tick()

    def prepare(self, sim: LoopView) -> None:
        """Compile the kernel before the loop.

        Raises:
            InputError: the run cannot be fused (messages, no compiled sensors, ...).
        """
        fused = self._fusable(sim)
        swarm = fused.sensors.swarm if fused is not None else None
        if swarm is not None and not self.runs(sim):
            why = "no device form yet" if not swarm.device else "and a tree that sends messages"
            raise InputError(
                f"engine gpu: mission {sim.mission.name!r} senses the whole swarm at once (a "
                f"SwarmSensorKernel, e.g. collisions) with {why}; use --engine compiled"
            )
        if fused is None:
            raise InputError(
                "engine gpu: only runs whose mission has compiled sensors and compiled "
                "handlers of the messages its tree sends run on the GPU so far (e.g. patrol, "
                "gathering); use --engine compiled"
            )
        start = time.perf_counter()
        layout = replace(self.layout, constants=Constants(), vertical=fused.vertical)
        thread = Thread(self.program, self.kernels, layout, fused.sensors, self.stages)
        if fused.messaging is None:
            source = kernel_module_source(thread)
            self._kernel = load_kernel(source)
            steps = len(swarm.device) if swarm is not None else 0
            self._swarm_kernels = [load_kernel(source, f"swarm_{j}") for j in range(steps)]
        else:
            self._message_kernels(thread, fused.messaging)
        self._kernel_constants = layout.constants.arrays()  # the CPU tick's may differ
        iterations = sim.scenario.iterations
        self._groups = RecordGroups(sim.recorder, self.layout.names, iterations, self.timings,
                                     on_device=not simulating())  # fmt: skip
        self.loop(sim, 0)
        compiled = self._messages.kernels.values() if self._messages else [self._kernel]
        compiled = [*compiled, *self._swarm_kernels]
        with no_fma():  # inspect_asm may compile the PTX anew (the launch linked LTO-IR)
            clean = all(fma_free(kernel) for kernel in compiled)
        if not clean:
            raise RuntimeError("engine gpu: the kernel's PTX has fused multiply-adds")
        self.timings.update(dict.fromkeys(TIMINGS, 0.0), compile=time.perf_counter() - start)

    def _message_kernels(self, thread: Thread, messaging: Messaging) -> None:
        """Generate and load the kernels of a tree that sends messages
        (:mod:`~pyautonomousagent.engines.gpu_messages`)."""
        from pyautonomousagent.engines.gpu_messages import DeviceMessages

        source = message_module_source(thread, messaging)
        names = [line.split("(")[0][4:] for line in source.splitlines() if line.startswith("def ")]
        kernels = {name: load_kernel(source, name) for name in names}
        layout = thread.layout
        common = [name for line in fused_parameters(layout, thread.sensors) for name in line]
        xy = (common.index(layout.array("x")), common.index(layout.array("y")))
        self._messages = DeviceMessages(kernels, messaging, common, xy, self.swarm.size)

    @staticmethod
    def _takes(delivery: Delivery, messaging: Messaging | None) -> bool:
        """Whether the device loop handles ``delivery`` (of ``sim.inbox``): one of a type the
        tree sends that reached everyone, or broadcasts from finite positions whose type's
        handler has a per-receiver form."""
        messages = delivery.messages
        if messaging is None or messages.type not in messaging.types:
            return False
        if delivery.to_all:
            return True
        handler = messaging.handlers[messaging.types.index(messages.type)]
        return bool(
            handler.receive is not None
            and (messages.lists < 0).all()
            and np.isfinite(messages.x).all()
            and np.isfinite(messages.y).all()
        )

    def device(self) -> dict[str, str]:
        """What ran the kernel, for ``run.json``: the device's name, the CUDA driver's
        version, CuPy's and numba's ("numba CUDA simulator" under the simulator)."""
        import numba

        if simulating():
            return {"name": "numba CUDA simulator", "numba": numba.__version__}
        import cupy
        from numba import cuda

        driver = int(cupy.cuda.runtime.driverGetVersion())
        return {
            "name": _text(cuda.get_current_device().name),
            "driver": f"{driver // 1000}.{driver % 1000 // 10}",
            "cupy": cupy.__version__,
            "numba": numba.__version__,
        }

    def runs(self, sim: LoopView) -> bool:
        """Whether the kernels can run ``sim``'s iterations from its start (else
        :meth:`prepare` refuses it): a mission with compiled sensors and compiled handlers
        of the messages its tree sends, the 2-D or 3-D drone; a sensor of the whole swarm
        (``SwarmSensorKernel``) only with a device form and a tree that sends nothing."""
        fused = self._fusable(sim)
        if fused is None:
            return False
        swarm = fused.sensors.swarm
        return swarm is None or (bool(swarm.device) and fused.messaging is None)

    def bytes_per_drone_iteration(self, sim: LoopView) -> float:
        """Bytes of device memory one drone-iteration moves, counted from the kernel's
        arrays: the drone's state (node statuses, remembered children, columns, blackboard,
        control signals) read and written once an iteration, and its record row (columns,
        active behaviour, its share of the traces) written once every ``every`` iterations.
        (One thread runs all a call's iterations of its drone, so caches may keep part of
        the state: the figure is what the kernel would move without them.)"""
        model = sim.model
        assert isinstance(model, Drone2D | Drone3D) and self._groups is not None
        arrays: list[np.ndarray] = [self.status, self.current, self.pending, *self.arrays]
        arrays += [model.u_speed, model.u_heading]
        if isinstance(model, Drone3D):
            arrays.append(model.u_climb)
        state = sum(array.nbytes for array in arrays) / self.swarm.size
        return 2 * state + self._groups.row_bytes / self.swarm.size / sim.recorder.every

    def _state(self, sim: LoopView) -> dict[str, Any]:
        """The state the kernel reads and writes, by parameter name (host arrays): the
        tree's and the control signals."""
        model = sim.model
        assert isinstance(model, Drone2D | Drone3D)
        tree = self._tree_arguments(self._kernel_constants)
        return tree | self._control_arguments(model, np.zeros(1))

    def _arguments(self, sim: LoopView, fused: Fused, slot: Slot) -> dict[str, Any]:
        """The kernels' arguments after the leading ones, by parameter name (device arrays
        and the parameters): the state, the records of ``slot``, the motion's parameters,
        the sensors' state and the swarm sensor's."""
        model = sim.model
        assert isinstance(model, Drone2D | Drone3D)
        assert self._device is not None and self._groups is not None
        records = record_parameters(self.layout)
        arguments = self._device | dict(zip(records, self._groups.arguments(slot), strict=True))
        arguments |= self._model_arguments(model, fused.sensors) | self._readings
        swarm = swarm_state_names(fused.sensors.swarm)
        return arguments | dict(zip(swarm, self._swarm_device, strict=True))

    @no_fma()
    def loop(self, sim: LoopView, count: int, typical: int | None = None) -> int:
        """Run up to ``count`` whole iterations on the device (0 compiles only; fewer where
        their records would not fit in a group, :meth:`RecordGroups.fit`, or where a tree's
        messages must go through the CPU's datalink, a recorded type); return how many ran,
        or 0 where the run cannot be fused now (the simulation then steps the iteration on
        the CPU, the compiled engine's ``tick``: the records in flight and the state are
        copied back first, and the state goes to the device again after it). The records
        are copied back while the next call's iterations run (:mod:`.gpu_records`); the
        state by :meth:`sync`, after every call of a tree that sends messages (whose last
        iteration's messages then go to the datalink, and the handlers' state to the
        mission). With NVVM's FMA contraction off (:func:`no_fma`): a kernel first launched
        here with new argument types (a grid or reduction step, e.g. when the first message
        falls in range) is compiled at that launch, and must do the NumPy engine's
        arithmetic as the kernels compiled by :meth:`prepare` do."""
        from numba import cuda

        if self._kernel is None and self._messages is None:
            self.prepare(sim)
        fused = self._fusable(sim)
        if fused is None:  # e.g. a radiation source came on
            self.sync(sim)
            return 0  # the CPU steps this iteration; the state goes to the device again after
        recorder, model = sim.recorder, sim.model
        assert isinstance(model, Drone2D | Drone3D) and self._groups is not None
        start, every = sim.world.iteration, recorder.every
        count = self._groups.fit(start, count)
        row0 = start // every + 1  # the first record these iterations can write
        fresh = self._device is None or self._synced != start  # new, or stepped on the CPU
        if fresh:
            sent = time.perf_counter()
            self._device = {k: cuda.to_device(array) for k, array in self._state(sim).items()}
            self._readings = {f"ss{j}": cuda.to_device(array)
                              for j, array in enumerate(fused.sensors.state)}  # fmt: skip
            swarm = fused.sensors.swarm
            self._swarm_state = swarm.state if swarm is not None else ()
            self._swarm_device = [cuda.to_device(array) for array in self._swarm_state]
            self._host_synced = start
            self.timings["state"] += time.perf_counter() - sent
        n = self.swarm.size
        slot = self._groups.slot(sim)
        arguments = self._arguments(sim, fused, slot)
        began = time.perf_counter()
        if self._swarm_kernels:
            self._swarm_loop(start, count, every, row0, arguments)
            done = count
        elif self._messages is None:
            values = ordered(parameters(self._kernel, 4), arguments, "block_gpu")
            launch = self._kernel[max(1, -(-n // THREADS)), THREADS, self._groups.stream]
            launch(start, count, every, row0, *values)
            done = count
        else:
            values = ordered(self._messages.common, arguments, "the message kernels")
            done = self._messages.run(sim, tuple(values), count, row0, fresh)
        self._groups.launched(slot, start, done, fused.sensors, time.perf_counter() - began)
        self._synced = start + done  # the clock: the simulation advances it by ``done``
        if self._messages is not None and done:
            self.sync(sim)  # the outboxes, for the datalink
            self._messages.download_state()
            self._send(sim.world.datalink)  # the last iteration's, for the CPU to deliver
        return done

    def sync(self, sim: LoopView) -> None:
        """Hand the records in flight over to the recorder and copy the state back into the
        swarm's arrays (where a kernel ran since the last sync): at the end of
        ``Simulation.run`` and ``step``, before an iteration stepped on the CPU, and after
        each call of a tree that sends messages."""
        if self._groups is not None:
            self._groups.settle(sim)
        if self._device is None or self._host_synced == self._synced:
            return
        began = time.perf_counter()
        assert self._groups is not None  # made with the device's state, by prepare
        hosts = [*self._state(sim).values(), *self._swarm_state]
        devices = [*self._device.values(), *self._swarm_device]
        for host, device in zip(hosts, devices, strict=True):
            device.copy_to_host(host, stream=self._groups.stream)
        self._groups.stream.synchronize()
        self._host_synced = self._synced
        self.timings["state"] += time.perf_counter() - began

    def _swarm_loop(
        self, start: int, count: int, every: int, row0: int, arguments: dict[str, Any]
    ) -> None:
        """Iterations ``start + 1 .. start + count`` of a run with a sensor of the whole swarm:
        per iteration its device steps (``gpu_source.swarm_kernels``) over every agent, then
        one iteration of ``block_gpu``, all on the records' stream. ``count`` 0 launches each
        once on no agent (compiling them). ``arguments``: ``block_gpu``'s, by name (the
        steps take some of them)."""
        from pyautonomousagent.engines.gpu_reduce import shape  # numba.cuda: the [gpu] extra

        assert self._groups is not None
        n, stream = self.swarm.size, self._groups.stream
        steps = []
        for j, kernel in enumerate(self._swarm_kernels):
            names = parameters(kernel, 2)  # after t, n: kf, ki, the arrays, the swarm state
            some = {name: arguments[name] for name in names if name in arguments}
            steps.append((kernel, ordered(names, some, f"swarm_{j}")))
        values = ordered(parameters(self._kernel, 4), arguments, "block_gpu")
        blocks = max(1, -(-n // THREADS))
        for t in range(start + 1, start + max(count, 1) + 1):
            for kernel, state in steps:
                kernel[(*shape(n), stream)](t, n if count else 0, *state)
            launch = self._kernel[blocks, THREADS, stream]
            launch(t - 1, 1 if count else 0, every, row0, *values)
