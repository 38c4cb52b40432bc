"""Every kernel the GPU engine launches, compiled to PTX for a compute capability 9.0 device
(H100/H200) by numba-cuda's NVVM, no GPU needed (issue 20).

numba's CUDA simulator runs kernels as Python: it never types or lowers them for the CUDA
target, where e.g. ``math.floor`` of a float is a float (an int on the CPU target), so device
code that only the simulator ran may not compile at all. Here each mission the GPU engine runs
is run for a few iterations under the simulator (in a subprocess) with a hook on the
simulator's kernel launch that records each kernel launched (its module and name) and the
numba types of its arguments; then, in this process (real numba-cuda, no simulator), each is
compiled with ``cuda.compile_ptx(..., cc=(9, 0))`` inside :func:`gpu.no_fma`: it must compile,
and its PTX must hold no fused multiply-add (``fma.``) and no approximate or flush-to-zero
instruction (``.approx``, ``.ftz``): each would round otherwise than NumPy does.

Runs where the numba-cuda package and its NVVM are importable (the ``[test]`` extra's
``numba-cuda[cu13]`` brings NVVM in wheels; numba's own deprecated ``numba.cuda`` does not
lower these kernels); skipped with the reason otherwise.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import pickle
import subprocess
import sys
import textwrap
import types
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent.engines import gpu
from pyautonomousagent.loop.modules import load_source

#: The device the PTX is for: compute capability 9.0 (H100, H200).
CC = (9, 0)


def _ptx_problem() -> str | None:
    """Why kernels cannot be compiled to PTX here, or None."""
    if gpu.simulating():
        return "numba's CUDA simulator is on (NUMBA_ENABLE_CUDASIM)"
    if importlib.util.find_spec("numba_cuda") is None:
        return "numba-cuda is not installed (the [test] extra: pip install -e '.[test]')"
    try:
        from numba.cuda.cudadrv import nvvm

        nvvm.NVVM()
    except Exception as error:  # NvvmSupportError: no libNVVM found
        return f"no NVVM ({type(error).__name__}: {str(error).splitlines()[0]})"
    return None


needs_nvvm = pytest.mark.skipif(_ptx_problem() is not None, reason=str(_ptx_problem()))

#: One xdist worker runs these tests: they share the launches recorded and the PTX compiled
#: (:data:`_RECORDED`, :data:`_COMPILED`: the datalink's kernels, patrol's launches).
pytestmark = pytest.mark.xdist_group("gpu-ptx")

#: Run under NUMBA_ENABLE_CUDASIM=1: scenario ``argv[1]`` with overrides ``argv[2]`` (a
#: Python literal) on the GPU engine; pickles into ``argv[3]`` the kernels launched, as
#: sorted (module, module's file, kernel name, numba types of the arguments), the simulator's
#: device arrays as the NumPy arrays they hold; prints the messages sent.
RECORD = textwrap.dedent(
    """
    import ast
    import pickle
    import sys
    import warnings
    import numba
    from numba.cuda.simulator import kernel as simulated
    from pyautonomousagent import Simulation, load

    warnings.simplefilter("ignore", RuntimeWarning)  # the generator's uint64 wraps in Python
    launched = set()
    call = simulated.FakeCUDAKernel.__call__
    def recorded(self, *args):
        if not (self._device or simulated._kernel_context):  # a launch from the host
            fn = self.fn
            where = getattr(sys.modules[fn.__module__], "__file__", None)
            types = tuple(numba.typeof(getattr(a, "_ary", a)) for a in args)
            launched.add((fn.__module__, where, fn.__qualname__, types))
        return call(self, *args)
    simulated.FakeCUDAKernel.__call__ = recorded
    scenario = load(sys.argv[1]).with_overrides(**ast.literal_eval(sys.argv[2]))
    sim = Simulation.create(scenario, seed=1, engine="gpu").run(progress=False)
    assert sim.engine.name == "gpu"
    with open(sys.argv[3], "wb") as out:
        pickle.dump(sorted(launched, key=str), out)
    print(sum(1 for e in sim.events if e["event"] == "message"))
    """
)

#: A patrol tree with nodes of six children (halted in a loop: ``tree_source.UNROLLED``).
WIDE = str(Path(__file__).parent / "data" / "trees" / "wide_patrol.yaml")

#: (scenario, overrides, whether its tree sends messages): every mission the GPU engine
#: runs. (A run launches every kernel of its generated module whatever the datalink's range,
#: which the test checks, with the same argument types: one range each is enough.)
CASES = [
    ("patrol", {"agents": 5, "iterations": 20}, False),
    ("patrol-3d", {"agents": 5, "iterations": 20}, False),
    ("patrol", {"agents": 5, "iterations": 20, "tree": WIDE}, False),  # halts in a loop
    ("gathering", {"agents": 40, "iterations": 30, "gathering_iteration": 10}, True),
    ("gathering-3d", {"agents": 20, "iterations": 30, "gathering_iteration": 10}, True),
    ("radiation-search", {"agents": 20, "iterations": 40}, True),
    ("vacuum", {"agents": 20, "iterations": 20}, False),
]  # fmt: skip

#: The datalink's kernels every tree that sends messages launches (gpu_grid, gpu_reduce).
DATALINK = {"_count", "_place", "_sort", "_scan_chunks", "_add_chunks", "_box_points",
            "_box_boxes"}  # fmt: skip

Launch = tuple[str, str | None, str, tuple[Any, ...]]


#: The launches recorded, by scenario and overrides (``repr``): once per test session.
_RECORDED: dict[tuple[str, str], tuple[list[Launch], int]] = {}


def _launches(scenario: str, overrides: dict[str, Any], out: Path) -> tuple[list[Launch], int]:
    """The kernels a short run of ``scenario`` launches under the simulator, and the
    messages it sent (see :data:`RECORD`)."""
    key = (scenario, repr(overrides))
    if key not in _RECORDED:
        _RECORDED[key] = _record(scenario, overrides, out)
    return _RECORDED[key]


def _record(scenario: str, overrides: dict[str, Any], out: Path) -> tuple[list[Launch], int]:
    """:func:`_launches`, run."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", RECORD, scenario, repr(overrides), str(out)],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    with out.open("rb") as recorded:
        return pickle.load(recorded), int(done.stdout.split()[-1])


def _function(module: str, where: str | None, name: str) -> Any:
    """The Python function of a kernel: of a package module, or of a generated one (loaded
    from its source, the file the simulator's run wrote)."""
    if module.startswith("pyautonomousagent.") or where is None:
        loaded = importlib.import_module(module)
    else:
        loaded = load_source(Path(where).read_text())
    function = getattr(loaded, name)
    return getattr(function, "py_func", function)  # a cuda.jit dispatcher's Python function


@contextmanager
def _device_of(cc: tuple[int, int]) -> Iterator[None]:
    """numba-cuda compiles a device function a kernel calls (``cuda.jit(device=True)``, or
    an njit function) for the current device's compute capability, which needs a driver:
    stand a device of ``cc`` in for it while the body runs."""
    from numba.cuda import dispatcher

    current = dispatcher.get_current_device
    dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=cc)
    try:
        yield
    finally:
        dispatcher.get_current_device = current


#: The PTX already compiled, by (module, its file, kernel name, argument types): the
#: datalink's kernels are the same in every mission that sends messages.
_COMPILED: dict[Launch, str] = {}


def _cached_ptx(launch: Launch) -> str:
    """:func:`_ptx` of a recorded launch, compiled once per test session."""
    if launch not in _COMPILED:
        module, where, name, argument_types = launch
        _COMPILED[launch] = _ptx(_function(module, where, name), argument_types)
    return _COMPILED[launch]


def _ptx(function: Any, argument_types: tuple[Any, ...], contract: bool = False) -> str:
    """The PTX of kernel ``function`` for ``argument_types``, for a device of :data:`CC`,
    with FMA contraction off (:func:`gpu.no_fma`) unless ``contract``."""
    from numba import cuda

    with _device_of(CC):
        if contract:
            return cuda.compile_ptx(function, argument_types, cc=CC)[0]
        with gpu.no_fma():
            return cuda.compile_ptx(function, argument_types, cc=CC)[0]


@needs_nvvm
@pytest.mark.parametrize(("scenario", "overrides", "messages"), CASES)
def test_every_kernel_compiles_to_ptx_without_fma_approx_or_ftz(
    scenario: str, overrides: dict[str, Any], messages: bool, tmp_path: Path
) -> None:
    launches, sent = _launches(scenario, overrides, tmp_path / "launches.pickle")
    if scenario.startswith("gathering"):
        assert sent > 0  # the message kernels ran on real messages too
    names = {name for _, _, name, _ in launches}
    generated = {(module, where) for module, where, _, _ in launches if where and
                 not module.startswith("pyautonomousagent.")}  # fmt: skip
    assert len(generated) == 1, generated
    ((module, where),) = generated
    defined = {line[4:].split("(")[0] for line in Path(str(where)).read_text().splitlines()
               if line.startswith("def ")}  # fmt: skip
    assert defined <= names  # every kernel of the generated module was launched
    assert (names >= DATALINK) == messages and ("block_gpu" in names) != messages
    failed: list[str] = []
    fused: list[str] = []
    for launch in launches:
        name = launch[2]
        try:
            ptx = _cached_ptx(launch)
        except Exception as error:  # numba's TypingError, LoweringError, NVVM's errors
            failed.append(f"{name}: {type(error).__name__}: {error}")
            continue
        fused += [f"{name}: {bad}" for bad in ("fma.", ".approx", ".ftz") if bad in ptx]
    assert not failed, "\n\n".join(failed)
    assert not fused, f"instructions that round otherwise than NumPy: {fused}"
    print(scenario, len(launches), "kernels compiled:", " ".join(sorted(names)))


@needs_nvvm
def test_without_no_fma_nvvm_contracts_the_kernels_multiply_adds(tmp_path: Path) -> None:
    """The check above can fail: the patrol kernel compiled without :func:`gpu.no_fma` has
    fused multiply-adds in its PTX (NVVM contracts ``a * b + c`` by default)."""
    scenario, overrides, _ = CASES[0]
    launches, _ = _launches(scenario, overrides, tmp_path / "p.pickle")
    ((module, where, name, argument_types),) = launches
    function = _function(module, where, name)
    assert "fma.rn.f64" in _ptx(function, argument_types, contract=True)
    assert "fma." not in _cached_ptx(launches[0])


@needs_nvvm
def test_no_fma_patches_the_nvvm_unit_of_every_module_that_defines_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """numba-cuda loaded under a second module name: its NVVM units get ``fma=False`` too,
    and only while ``no_fma`` runs."""

    class Unit:
        def __init__(self, options: dict[str, Any]) -> None:
            self.options = options

    other = types.ModuleType("elsewhere.numba.cuda.cudadrv.nvvm")
    other.CompilationUnit = Unit  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, other.__name__, other)
    assert Unit in gpu.nvvm_units() and len(gpu.nvvm_units()) == 2
    with gpu.no_fma():
        assert Unit({"opt": 3}).options == {"opt": 3, "fma": False}
    assert Unit({"opt": 3}).options == {"opt": 3}
