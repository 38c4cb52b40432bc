"""The GPU engine (issue 20): its error without a device, its kernel source, and its kernel
run through numba's CUDA simulator against the batched engine, bit for bit."""

from __future__ import annotations

import ast
import inspect
import json
import os
import subprocess
import sys
import textwrap
import types
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent import Simulation, cli, jit, load, runs
from pyautonomousagent.engines import gpu
from pyautonomousagent.engines.gpu_source import Thread, kernel_module_source
from pyautonomousagent.loop.layout import Constants
from pyautonomousagent.loop.source import alias
from pyautonomousagent.models import drone2d
from pyautonomousagent.simulation.run import ENGINES, choose_engine, gpu_engine, scenario_tree
from pyautonomousagent.testing import check_same_runs

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
needs_device = pytest.mark.skipif(
    gpu.simulating() or gpu.gpu_problem() is not None,
    reason=f"no CUDA device here: {gpu.gpu_problem()}",
)


def test_the_device_name_is_text_whether_numba_cuda_gives_bytes_or_str() -> None:
    """numba-cuda 0.30.4 gives the name as str (seen on the lent H100), older ones bytes."""
    assert gpu._text(b"NVIDIA H100 80GB HBM3") == "NVIDIA H100 80GB HBM3"
    assert gpu._text("NVIDIA H100 80GB HBM3") == "NVIDIA H100 80GB HBM3"


def test_gpu_is_a_registered_engine() -> None:
    """Registered as the GPU engine on a compiled engine (its host: the two engines import
    none of each other)."""
    assert "gpu" in ENGINES
    assert ENGINES.get("gpu") is gpu_engine


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


@pytest.mark.parametrize("where", ["no device", "simulator"])
def test_auto_never_picks_the_gpu_without_a_device_or_under_the_simulator(
    where: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(gpu, "simulating", lambda: where == "simulator")
    problem = "no CUDA device (stubbed)" if where == "no device" else None
    monkeypatch.setattr(gpu, "gpu_problem", lambda: problem)
    tree = scenario_tree(load("patrol"))
    for agents, iterations in ((4, 100), (10**6, 1000), (10**8, 1000)):
        assert choose_engine(tree, agents, iterations) != "gpu"


def _device_present(monkeypatch: pytest.MonkeyPatch) -> None:
    """Have :func:`gpu.auto_takes_gpu` see a device (no simulator, no problem)."""
    monkeypatch.setattr(gpu, "simulating", lambda: False)
    monkeypatch.setattr(gpu, "gpu_problem", lambda: None)


@needs_numba
def test_with_a_device_auto_picks_the_gpu_from_the_threshold_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _device_present(monkeypatch)
    tree = scenario_tree(load("patrol"))
    assert gpu.AUTO_DRONE_ITERATIONS is None  # not measured on a GPU yet: auto never takes it
    assert choose_engine(tree, 10**8, 1000) != "gpu"
    least = 10**9  # as if gpu_figures.sh had measured it
    monkeypatch.setattr(gpu, "AUTO_DRONE_ITERATIONS", least)
    assert choose_engine(tree, least // 1000, 1000) == "gpu"
    assert choose_engine(tree, least, 1) == "gpu"
    assert choose_engine(tree, least // 1000 - 1, 1000) != "gpu"
    assert choose_engine(tree, 10**6, 100) != "gpu"  # 1e8 drone-iterations: the CPU's
    gathering = load("gathering")  # the 4-drone teaching run
    assert gathering.agents * gathering.iterations < least
    assert choose_engine(scenario_tree(gathering), gathering.agents, gathering.iterations) != "gpu"


@needs_numba
def test_auto_takes_the_compiled_engine_where_the_kernel_cannot_run_the_run(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Crowded's proximity sensor senses the whole swarm (no device form): above the
    threshold, with a device, auto builds the GPU engine, sees it cannot run the run, and
    takes the compiled one."""
    _device_present(monkeypatch)
    monkeypatch.setattr(gpu, "AUTO_DRONE_ITERATIONS", 40)
    scenario = load("crowded").with_overrides(agents=4, iterations=10)
    assert choose_engine(scenario_tree(scenario), 4, 10) == "gpu"
    sim = Simulation.create(scenario, seed=1, engine="auto")
    assert sim.engine.name == "compiled"


def _kernel_source(agents: int = 4) -> str:
    sim = Simulation.create(
        load("patrol").with_overrides(agents=agents, iterations=10), seed=1, engine="compiled"
    )
    engine = sim.engine
    fused = engine._fusable(sim)
    assert fused is not None and fused.messaging is None
    layout = engine.layout.__class__(**{**vars(engine.layout), "constants": Constants()})
    return kernel_module_source(
        Thread(engine.program, engine.kernels, layout, fused.sensors, engine.stages)
    )


@needs_numba
def test_the_kernel_is_the_compiled_generators_code_for_one_thread() -> None:
    source = _kernel_source()
    tree = ast.parse(source)  # valid Python
    kernel = next(n for n in tree.body if isinstance(n, ast.FunctionDef))
    assert kernel.name == "block_gpu"
    assert "a = cuda.grid(1)" in source
    assert f"{alias(drone2d.step_agent)}(" in source  # the model's own per-agent step
    assert "math.sin" not in source and "math.cos" not in source
    step = inspect.getsource(drone2d.step_agent.py_func)
    assert "sincos_one(h)" in step and "math." not in step  # no library sin/cos on the device
    assert "prange" not in source.split("import", 3)[-1]  # one agent a thread, no CPU threads


#: Run under NUMBA_ENABLE_CUDASIM=1 (numba reads it on import): the GPU engine's kernel in the
#: simulator against the batched engine; raises at the first difference, else prints "same".
SIMULATED = textwrap.dedent(
    """
    import sys
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.testing import check_same_runs

    agents, iterations, every = (int(v) for v in sys.argv[1:4])
    scenario_name, energy_use = sys.argv[4], float(sys.argv[5])
    for seed in (1, 2, 3):
        scenario = load(scenario_name).with_overrides(
            agents=agents, iterations=iterations, energy_use=energy_use)
        a, b = (Simulation.create(scenario, seed=seed, engine=e, record_every=every).run(
            progress=False) for e in ("batched", "gpu"))
        assert b.engine.name == "gpu" and b.engine.timings["kernel"] > 0.0
        check_same_runs(a, b, ("batched", "gpu"))
        # a third of the run, three single steps (a launch each), the rest with three
        # iterations on the CPU (the compiled engine's tick): the same bits
        c = Simulation.create(scenario, seed=seed, engine="gpu", record_every=every)
        fusable = c.engine._fusable  # from iteration 23 (after the steps), 3 cannot be fused
        c.engine._fusable = lambda sim: None if 23 <= sim.world.iteration < 26 else fusable(sim)
        c.run(progress=False, iterations=iterations // 3)
        for _ in range(3):
            c.step()
        c.run(progress=False)
        check_same_runs(a, c, ("batched", "gpu with CPU steps"))
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


#: Run under NUMBA_ENABLE_CUDASIM=1: many calls of the GPU engine's loop (``run.FUSED``
#: iterations each, fewer where a group holds ``GROUP_BYTES``), compact records, traces,
#: drones running dry; prints "same" and how many groups were in flight at most.
IN_FLIGHT = textwrap.dedent(
    """
    import sys
    import numpy as np
    from pyautonomousagent import Simulation, load, recording
    from pyautonomousagent.engines import gpu_records
    from pyautonomousagent.simulation import run
    from pyautonomousagent.testing import check_same_runs

    every, fused, group_bytes = (int(v) for v in sys.argv[1:4])
    recording.COMPACT_AGENTS = 1  # records kept compact, as for a large swarm
    run.FUSED = fused
    if group_bytes:
        gpu_records.GROUP_BYTES = group_bytes
    handed = []  # (groups still in flight, the engine's iteration, the group's last)
    hand_over = gpu_records.RecordGroups._hand_over
    def counted(self, sim, group):
        handed.append((self.in_flight, sim.world.iteration, group.start + group.count))
        hand_over(self, sim, group)
    gpu_records.RecordGroups._hand_over = counted
    scenario = load("patrol").with_overrides(agents=5, iterations=60, energy_use=2.0)
    a = Simulation.create(scenario, seed=4, engine="batched", record_every=every)
    b = Simulation.create(scenario, seed=4, engine="gpu", record_every=every)
    a.run(progress=False, iterations=23)
    b.run(progress=False, iterations=23)  # settles: records and state of 23 iterations
    for sim in (a, b):
        sim.mid = (sim.recorder.count, {k: v.copy() for k, v in sim.swarm.columns.items()})
        sim.run(progress=False)
    ra, rb = a.recorder, b.recorder
    assert a.mid[0] == b.mid[0] == 23 // every + 1, (a.mid[0], b.mid[0])
    assert ra.columns.stored == rb.columns.stored, (ra.columns.stored, rb.columns.stored)
    assert len(ra.columns.stored) < len(ra.columns), "no column kept compact"
    def bits(x):
        x = np.asarray(x)
        return x.view(np.uint64) if x.dtype == np.float64 else x
    check_same_runs(a, b, ("batched", "gpu"))  # records, traces, behaviour, events
    checks = [("mid " + k, a.mid[1][k], b.mid[1][k]) for k in a.mid[1]]
    checks += [("end " + k, a.swarm.columns[k], b.swarm.columns[k]) for k in a.swarm.columns]
    for name, x, y in checks:
        assert np.shape(x) == np.shape(y) and np.array_equal(bits(x), bits(y)), name
    assert a.events == b.events and any(e["event"] == "alert" for e in a.events)
    late = max(now - last for _, now, last in handed)  # iterations run before a hand-over
    print("same", max(flight for flight, _, _ in handed), late, len(handed))
    """
)


@needs_numba
@pytest.mark.parametrize(("every", "fused", "group_bytes"), [(1, 4, 0), (7, 20, 1), (1, 20, 1)])
def test_record_groups_in_flight_give_the_batched_engines_records(
    every: int, fused: int, group_bytes: int
) -> None:
    """5 drones x 60 iterations in calls of 4 or 20 iterations (one record a group where
    ``group_bytes`` is 1): a group is handed to the recorder only after the next call's
    kernel was launched; compact columns, traces, alerts, a run stopped at 23 and resumed."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", IN_FLIGHT, str(every), str(fused), str(group_bytes)],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    word, flight, late, groups = done.stdout.split()
    assert word == "same"
    assert int(flight) >= 1 and int(late) >= 1  # another group was launched meanwhile
    assert int(groups) >= (60 // 7 if group_bytes else 60 // fused)


#: Run under NUMBA_ENABLE_CUDASIM=1: a run folder written while the run goes (two records a
#: Parquet row group), by the batched and the GPU engine, into ``argv[1]/ENGINE``.
STREAMED = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    from pyautonomousagent import Simulation, load, runs
    from pyautonomousagent.simulation import run

    run.FUSED = 6
    scenario = load("patrol").with_overrides(agents=4, iterations=40, energy_use=3.0)
    for engine in ("batched", "gpu"):
        sim = Simulation.create(scenario, seed=5, engine=engine, record_every=2)
        out = Path(sys.argv[1]) / engine
        written = []  # (records written to Parquet, the engine's iteration) at each record
        with runs.streaming(sim, out) as stream:
            stream.block = 2
            sim.recorder.listeners.append(
                lambda count: written.append((stream.written, sim.world.iteration)))
            status = runs.simulate(sim)
            runs.save_run(sim, out, status=status, stream=stream, animation=False)
        during = max(records for records, iteration in written if iteration < 40)
        print(engine, during)
    """
)


@needs_numba
def test_the_gpu_engines_run_folder_is_streamed_as_the_batched_engines(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", STREAMED, str(tmp_path)],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    during = dict(line.split() for line in done.stdout.strip().splitlines())
    assert int(during["gpu"]) >= 10  # records in Parquet before the run's last iteration
    for name in ("states.parquet", "traces.parquet"):
        a, b = (pq.read_table(tmp_path / e / name) for e in ("batched", "gpu"))
        assert a.equals(b, check_metadata=True), name
    states = pq.ParquetFile(tmp_path / "gpu" / "states.parquet")
    assert states.metadata.num_row_groups == 11  # 21 records, two a row group
    assert runs.verify(tmp_path / "gpu")["engine"] == "gpu"


#: Device runs against the batched engine: (scenario, overrides, whether messages are sent).
#: Gathering and radiation-search once with the default range (messages reach everyone)
#: and once with a short one (only neighbours hear them: delivered on the device).
DEVICE_CASES = [
    ("patrol", {"agents": 2000, "iterations": 300}, False),
    ("patrol-3d", {"agents": 2000, "iterations": 300}, False),
    ("gathering", {"agents": 64, "iterations": 300, "gathering_iteration": 100}, True),
    ("gathering", {"agents": 64, "iterations": 300, "gathering_iteration": 100,
                   "datalink_range": 25}, True),
    ("radiation-search", {"agents": 64, "iterations": 400}, True),
    ("radiation-search", {"agents": 64, "iterations": 400, "datalink_range": 15}, True),
    ("vacuum", {"agents": 64, "iterations": 300}, False),
    ("vacuum", {"agents": 64, "iterations": 300, "start_positions": [[1.5, 1.5]]}, False),
]  # fmt: skip


@needs_device
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize(("scenario", "overrides", "messages"), DEVICE_CASES)
def test_on_the_device_the_gpu_engine_gives_the_batched_engines_bits(
    scenario: str, overrides: dict[str, Any], messages: bool, seed: int
) -> None:
    """Every recorded column, bit for bit, the traces, the active behaviour and the events."""
    loaded = load(scenario).with_overrides(**overrides)
    a, b = (
        Simulation.create(loaded, seed=seed, engine=e, record_every=10).run(progress=False)
        for e in ("batched", "gpu")
    )
    assert b.engine.name == "gpu" and b.engine.device()["name"] != "numba CUDA simulator"
    check_same_runs(a, b, ("batched", "gpu"))
    sent = [e for e in a.events if e["event"] == "message"]
    assert bool(sent) == messages  # a message case that sent nothing would test nothing


@needs_numba
def test_bench_reports_the_gpu_engines_parts() -> None:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    command = [sys.executable, "-m", "pyautonomousagent.cli", "bench", "patrol", "--agents", "3",
               "--iterations", "10", "--record-every", "5", "--engines", "gpu", "--save",
               "--bandwidth", "2000", "--json"]  # fmt: skip
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(done.stdout)
    assert row["error"] == "" and row["engine"] == "gpu"
    parts = row["gpu_s"]
    assert set(parts) == {"compile", "kernel", "copy_back", "state", "write"}
    assert 0.0 < parts["compile"] <= row["setup_s"]
    assert 0.0 < parts["kernel"] + parts["copy_back"] + parts["state"] <= row["loop_s"]
    assert parts["write"] == row["write_s"] > 0.0
    # patrol: 228 bytes of state a drone (docs/performance.md), read and written; a record
    # row (21 columns, the active behaviour, the traces of the 3 drones) every 5 iterations
    sim = Simulation.create(load("patrol").with_overrides(agents=3, iterations=10),
                            engine="compiled", record_every=5)  # fmt: skip
    engine = sim.engine
    state = [engine.status, engine.current, engine.pending, *engine.arrays,
             sim.model.u_speed, sim.model.u_heading]  # fmt: skip
    row_bytes = sum(d.itemsize for d in sim.recorder.columns.dtypes.values()) * 3
    row_bytes += 2 * 3 + sim.recorder.traces[0].nbytes
    expected = 2 * sum(a.nbytes for a in state) / 3 + row_bytes / 3 / 5
    assert row["bytes_per_drone_iteration"] == pytest.approx(expected)
    rate = 3 * 10 / row["loop_s"]
    assert row["bandwidth_fraction"] == pytest.approx(expected * rate / 2e12)


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
        ("crowded", "engine gpu: mission 'crowded' senses the whole swarm at once"),
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
