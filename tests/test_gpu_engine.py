"""The GPU engine (issue 20): its error without a device, its kernel source, and its kernel
run through numba's CUDA simulator against the batched engine, bit for bit."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import textwrap
import types
from pathlib import Path

import numpy as np
import pytest

from pyautonomousagent import Simulation, cli, jit, load, runs
from pyautonomousagent.engines import gpu
from pyautonomousagent.engines.compiled_source import Constants
from pyautonomousagent.engines.gpu_source import kernel_module_source
from pyautonomousagent.simulation.run import ENGINES, choose_engine, scenario_tree

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
needs_device = pytest.mark.skipif(
    gpu.simulating() or gpu.gpu_problem() is not None,
    reason=f"no CUDA device here: {gpu.gpu_problem()}",
)


def test_gpu_is_a_registered_engine() -> None:
    assert "gpu" in ENGINES
    assert ENGINES.get("gpu") is gpu.GpuEngine


class _NoDeviceError(Exception):
    """Stands for CuPy's CUDARuntimeError."""


def _cupy_without_device() -> types.ModuleType:
    def count() -> int:
        raise _NoDeviceError("cudaErrorNoDevice: no CUDA-capable device is detected")

    runtime = types.SimpleNamespace(getDeviceCount=count)
    return types.SimpleNamespace(cuda=types.SimpleNamespace(runtime=runtime))  # type: ignore[return-value]


@pytest.mark.parametrize("why", ["missing", "no device"])
def test_without_cupy_or_a_device_run_says_so_in_one_line(
    why: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(gpu, "simulating", lambda: False)
    monkeypatch.setitem(sys.modules, "cupy", None if why == "missing" else _cupy_without_device())
    code = cli.main(["run", "patrol", "--engine", "gpu", "--agents", "3", "--iterations", "5"])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert "engine gpu:" in err and "pip install 'pyautonomousagent[gpu]'" in err
    assert ("cupy is not installed" in err) if why == "missing" else ("no CUDA device" in err)
    assert "Traceback" not in err


def test_auto_never_picks_the_gpu() -> None:
    tree = scenario_tree(load("patrol"))
    for agents, iterations in ((4, 100), (10**6, 1000), (10**8, 1000)):
        assert choose_engine(tree, agents, iterations) != "gpu"


def _kernel_source(agents: int = 4) -> str:
    sim = Simulation.create(
        load("patrol").with_overrides(agents=agents, iterations=10), seed=1, engine="compiled"
    )
    engine = sim.engine
    fused = engine._fusable(sim)
    assert fused is not None and fused.messaging is None
    layout = engine.layout.__class__(**{**vars(engine.layout), "constants": Constants()})
    return kernel_module_source(engine.program, engine.kernels, layout, fused.sensors)


@needs_numba
def test_the_kernel_is_the_compiled_generators_code_for_one_thread() -> None:
    source = _kernel_source()
    tree = ast.parse(source)  # valid Python
    kernel = next(n for n in tree.body if isinstance(n, ast.FunctionDef))
    assert kernel.name == "block_gpu"
    assert "a = cuda.grid(1)" in source
    assert "sincos_degrees(heading)" in source  # no library sin/cos on the device
    assert "math.sin" not in source and "math.cos" not in source
    assert "prange" not in source.split("import", 3)[-1]  # one agent a thread, no CPU threads


#: Run under NUMBA_ENABLE_CUDASIM=1 (numba reads it on import): the GPU engine's kernel in the
#: simulator against the batched engine; prints the first difference, or "same".
SIMULATED = textwrap.dedent(
    """
    import sys
    import numpy as np
    from pyautonomousagent import Simulation, load

    agents, iterations, every = (int(v) for v in sys.argv[1:4])
    scenario_name, energy_use = sys.argv[4], float(sys.argv[5])
    for seed in (1, 2, 3):
        scenario = load(scenario_name).with_overrides(
            agents=agents, iterations=iterations, energy_use=energy_use)
        a, b = (Simulation.create(scenario, seed=seed, engine=e, record_every=every).run(
            progress=False) for e in ("batched", "gpu"))
        assert b.engine.name == "gpu" and b.engine.timings["kernel"] > 0.0
        ra, rb = a.recorder, b.recorder
        checks = [(k, ra.columns[k], rb.columns[k]) for k in ra.columns]
        checks += [("traces", ra.traces, rb.traces), ("behaviour", ra.behaviour, rb.behaviour),
                   ("iterations", ra.iterations, rb.iterations)]
        for name, x, y in checks:
            x, y = np.asarray(x), np.asarray(y)
            same = x.shape == y.shape and np.array_equal(
                x.view(np.uint64) if x.dtype == np.float64 else x,
                y.view(np.uint64) if y.dtype == np.float64 else y)
            if not same:
                print("differ", seed, name)
                sys.exit(1)
        if a.events != b.events:
            print("differ", seed, "events")
            sys.exit(1)
        # a third of the run, three single steps (a launch each), the rest with three
        # iterations on the CPU (the compiled engine's tick): the same bits
        c = Simulation.create(scenario, seed=seed, engine="gpu", record_every=every)
        fusable = c.engine._fusable  # from iteration 23 (after the steps), 3 cannot be fused
        c.engine._fusable = lambda sim: None if 23 <= sim.world.iteration < 26 else fusable(sim)
        c.run(progress=False, iterations=iterations // 3)
        for _ in range(3):
            c.step()
        c.run(progress=False)
        if not all(np.array_equal(np.asarray(ra.columns[k]), np.asarray(c.recorder.columns[k]))
                   for k in ra.columns):
            print("differ", seed, "after stepping")
            sys.exit(1)
        if a.events != c.events:
            print("differ", seed, "events")
            sys.exit(1)
    print("same")
    """
)


@needs_numba
@pytest.mark.parametrize(
    ("scenario", "every", "energy_use"),
    [("patrol", 1, 0.05), ("patrol", 7, 2.0), ("patrol-3d", 1, 0.05), ("patrol-3d", 5, 2.0)],
)
def test_the_simulated_kernel_gives_the_batched_engines_bits(
    scenario: str, every: int, energy_use: float
) -> None:
    """5 drones x 60 iterations, 3 seeds, the 2-D and the 3-D drone; at 2 energy a step they
    run dry at iteration 50 (they stop, alerts are raised)."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    arguments = ["5", "60", str(every), scenario, str(energy_use)]
    done = subprocess.run(
        [sys.executable, "-c", SIMULATED, *arguments],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip().splitlines()[-1] == "same"


@needs_device
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_on_the_device_the_gpu_engine_gives_the_batched_engines_bits(seed: int) -> None:
    scenario = load("patrol").with_overrides(agents=2000, iterations=300)
    a, b = (
        Simulation.create(scenario, seed=seed, engine=e, record_every=10).run(progress=False)
        for e in ("batched", "gpu")
    )
    for key in a.recorder.columns:
        assert np.array_equal(a.recorder.columns[key], b.recorder.columns[key]), key
    assert np.array_equal(a.recorder.traces, b.recorder.traces)
    assert np.array_equal(a.recorder.behaviour, b.recorder.behaviour)
    assert a.events == b.events


@needs_numba
def test_bench_reports_the_gpu_engines_parts() -> None:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    command = [sys.executable, "-m", "pyautonomousagent.cli", "bench", "patrol", "--agents", "3",
               "--iterations", "10", "--engines", "gpu", "--json"]  # fmt: skip
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(done.stdout)
    assert row["error"] == "" and row["engine"] == "gpu"
    parts = row["gpu_s"]
    assert set(parts) == {"compile", "kernel", "copy_back"}
    assert 0.0 < parts["compile"] <= row["setup_s"]
    assert 0.0 < parts["kernel"] + parts["copy_back"] <= row["loop_s"]


@needs_numba
def test_a_gpu_runs_folder_names_the_device_and_verifies(tmp_path: Path) -> None:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    out = tmp_path / "run"
    command = [sys.executable, "-m", "pyautonomousagent.cli", "run", "patrol", "--engine", "gpu",
               "--agents", "3", "--iterations", "12", "--out", str(out), "--no-gif",
               "--quiet"]  # fmt: skip
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    summary = runs.verify(out)
    assert summary["engine"] == "gpu"
    assert summary["device"]["name"] == "numba CUDA simulator"
    batched = tmp_path / "batched"
    command[command.index("gpu")] = "batched"
    command[command.index(str(out))] = str(batched)
    assert subprocess.run(command, env=env, capture_output=True, timeout=600).returncode == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in batched.iterdir())


@needs_numba
@pytest.mark.parametrize(
    ("scenario", "why"),
    [
        (
            "crowded",
            "engine gpu: only runs whose mission has compiled sensors and compiled handlers",
        ),
        ("radiation-search", "the compiled engine cannot run this tree: leaf"),
    ],
)
def test_a_run_the_kernel_cannot_do_is_refused_in_one_line(scenario: str, why: str) -> None:
    """(Gathering, whose tree sends messages, runs: tests/test_gpu_messages.py.)"""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    command = [sys.executable, "-m", "pyautonomousagent.cli", "run", scenario, "--engine", "gpu",
               "--iterations", "5", "--no-gif", "--quiet", "--out", "/nonexistent"]  # fmt: skip
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith(f"pyaa: error: {why}")
