"""The vacuum robot on the compiled engine: its leaf kernels, the sonar and stop rule per
robot, the cleaning grid as a sensor of the whole swarm, and the fused loop against the
batched engine (and py_trees), bit for bit; and on the GPU engine in numba's CUDA simulator."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from pyautonomousagent import jit
from pyautonomousagent.bt import fallback, leaf, reactive_fallback, sequence
from pyautonomousagent.missions.vacuum import Circle, CleaningGrid, Rectangle, Room
from pyautonomousagent.missions.vacuum.kernels import blocked, clean_grid, sonar_reading
from pyautonomousagent.testing import check_engines_agree, check_same_runs

from .test_compiled_engine import counted_run as counted

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")

#: Four robots from one start position: they brush the same cells at once.
TOGETHER = {"agents": 4, "start_positions": [[1.5, 1.5]]}


def counted_run(engine: str, seed: int, record_every: int = 1, **overrides: object):
    """A vacuum run, and how many of its iterations the compiled engine fused."""
    return counted(engine, "vacuum", seed, record_every, **overrides)


@pytest.mark.parametrize(
    ("seed", "every", "overrides"),
    [
        (0, 1, {"agents": 3}),
        (1, 1, {"agents": 3}),
        (2, 7, {"agents": 5}),
        (3, 1, TOGETHER),
        (4, 3, TOGETHER),
    ],
)
def test_the_fused_loop_gives_the_batched_bits(seed: int, every: int, overrides: dict) -> None:
    """The scenario's room (two rectangles, a circle), 500 iterations: every column, the
    traces, the active behaviour and the events; the grid cleaned alike."""
    batched, _ = counted_run("batched", seed, every, iterations=500, **overrides)
    compiled, fused = counted_run("compiled", seed, every, iterations=500, **overrides)
    assert compiled.engine.name == "compiled" and fused == 500
    check_same_runs(batched, compiled, ("batched", "compiled"))
    assert np.array_equal(batched.mission.grid.cleaned, compiled.mission.grid.cleaned)
    sonar = batched.recorder.column("sonar")
    assert sonar.min() < 0.3 and (batched.recorder.column("vacuuming")[1:] == 0).any()


def test_robots_brushing_one_cell_at_once_credit_the_lower_row() -> None:
    """Robots starting together clean their first cell at once: robot 1 gets it, and the
    fused loop does the same."""
    batched, _ = counted_run("batched", 3, iterations=40, **TOGETHER)
    compiled, fused = counted_run("compiled", 3, iterations=40, **TOGETHER)
    assert fused == 40
    cells = batched.recorder.column("cleaned_cells")
    assert (batched.recorder.column("vacuuming")[1] == 1).all()  # all four brushed together
    assert cells[2].tolist() == [1, 0, 0, 0]
    check_same_runs(batched, compiled, ("batched", "compiled"))


def test_py_trees_batched_and_compiled_record_the_same_short_run() -> None:
    runs = [counted_run(engine, 5, iterations=120, agents=2)[0]
            for engine in ("pytrees", "batched", "compiled")]  # fmt: skip
    check_same_runs(runs[1], runs[0], ("batched", "pytrees"))
    check_same_runs(runs[1], runs[2], ("batched", "compiled"))


#: Small trees whose leaves change status as the robots move (the avoid leaf also with
#: ``step`` 0, whole degrees not enforced).
TREES = {
    "the scenario's tree, turn step 0": fallback(
        "root",
        sequence(
            "avoid",
            leaf("Condition_Collision", "near", distance=1.5),
            leaf("Action_Avoid_Obstacle_S", "turn", step=0.0, min_angle=30.0),
        ),
        sequence(
            "clean", leaf("Action_Navigate_S", "go", speed=0.15), leaf("Action_Vacuum_S", "brush")
        ),
    ),  # fmt: skip
    "reactive, brush while avoiding": reactive_fallback(
        "root",
        sequence(
            "avoid",
            leaf("Condition_Collision", "near"),
            leaf("Action_Vacuum_S", "brush"),
            leaf("Action_Avoid_Obstacle_S", "turn"),
        ),
        leaf("Action_Navigate_S", "go"),
    ),  # fmt: skip
}


@pytest.mark.parametrize("name", list(TREES))
def test_each_leaf_kernel_ticks_as_the_batched_leaf(name: str) -> None:
    """Node statuses compared after every tick (stepping), then every column and event."""
    assert check_engines_agree(TREES[name], "vacuum", 2, ("batched", "compiled"),
                               agents=4, iterations=300) == 300  # fmt: skip


def _room() -> Room:
    return Room(10.0, 8.0, (Rectangle(4.0, 3.0, 2.0, 1.5), Rectangle(0.0, 6.0, 1.0, 2.0),
                            Circle(7.5, 5.5, 1.0), Circle(2.0, 2.0, 0.5)))  # fmt: skip


def _points(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """Positions in the room, with some on obstacle edges and grid lines, and headings that
    include the axes (rays along a slab)."""
    x, y = rng.uniform(0.0, 10.0, n), rng.uniform(0.0, 8.0, n)
    x[:40], y[:40] = rng.choice([4.0, 6.0, 0.5, 1.0, 7.5], 40), rng.choice([3.0, 4.5, 2.0], 40)
    heading = rng.uniform(0.0, 360.0, n)
    heading[::5] = rng.choice([0.0, 90.0, 180.0, 270.0], heading[::5].size)
    return x, y, heading


@pytest.mark.parametrize("seed", range(3))
def test_the_sonar_and_stop_kernels_give_the_room_s_bits(seed: int) -> None:
    room = _room()
    x, y, heading = _points(np.random.default_rng(seed), 400)
    expected = room.sonar(x, y, heading, 4.0)
    dx, dy = (np.asarray(v) for v in zip(*map(_sincos, heading), strict=True))
    got = [sonar_reading(x[i], y[i], dx[i], dy[i], room.rects, room.circles, 10.0, 8.0, 4.0)
           for i in range(x.size)]  # fmt: skip
    assert np.array(got).tobytes() == expected.tobytes()
    assert (expected == 0.0).any() and (expected == 4.0).any()  # on edges, and out of reach
    stop = [blocked(x[i], y[i], room.rects, room.circles, 10.0, 8.0, 1e-6) for i in range(x.size)]
    inside = room.blocked(x, y, 1e-6)
    assert np.array_equal(stop, inside) and inside.any() and not inside.all()


def _sincos(angle: float) -> tuple[float, float]:
    from pyautonomousagent.arrays import sincos_degrees

    return sincos_degrees(float(angle))


@pytest.mark.parametrize("seed", range(5))
def test_the_grid_kernel_cleans_what_the_cleaning_grid_cleans(seed: int) -> None:
    """Brushing robots, several on one cell, over a few iterations: the same cells, and the
    same robot credited for each."""
    rng = np.random.default_rng(seed)
    room = _room()
    grids = CleaningGrid(room, 0.5), CleaningGrid(room, 0.5)
    fresh = np.zeros(30, dtype=np.int64)
    for _ in range(4):
        x, y = rng.choice(np.arange(0.0, 10.0, 0.25), 30), rng.choice(np.arange(0.0, 8.0, 0.25), 30)
        brushing = rng.random(30) < 0.7
        expected = grids[0].clean(x, y, brushing)
        clean_grid(0, x, y, brushing.astype(np.int64), np.zeros(30, np.int64), grids[1].free,
                   grids[1].cleaned, fresh, np.zeros(0, np.int64), 0.5)  # fmt: skip
        assert np.array_equal(fresh, expected)
        assert np.array_equal(grids[0].cleaned, grids[1].cleaned)
    assert grids[0].cleaned.any()


#: Run under NUMBA_ENABLE_CUDASIM=1: vacuum on the GPU engine in numba's CUDA simulator (the
#: grid's device steps, atomics included) against the batched engine; prints "same".
SIMULATED = textwrap.dedent(
    """
    import numpy as np
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.testing import check_same_runs

    cases = [(1, {"agents": 3}, 7), (2, {"agents": 4, "start_positions": [[1.5, 1.5]]}, 1),
             (3, {"agents": 2}, 5)]
    for seed, overrides, every in cases:
        scenario = load("vacuum").with_overrides(iterations=60, **overrides)
        a, b = (Simulation.create(scenario, seed=seed, engine=e, record_every=every)
                .run(progress=False) for e in ("batched", "gpu"))
        assert b.engine.name == "gpu" and b.engine.timings["kernel"] > 0.0
        check_same_runs(a, b, ("batched", "gpu"))
        assert np.array_equal(a.mission.grid.cleaned, b.mission.grid.cleaned)
        if seed == 2:  # four robots brushed one cell at once: robot 1 was credited
            assert a.recorder.column("cleaned_cells")[2].tolist() == [1, 0, 0, 0]
    print("same")
    """
)


def test_the_simulated_gpu_engine_gives_the_batched_bits() -> None:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run([sys.executable, "-c", SIMULATED], env=env, capture_output=True,
                          text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip().splitlines()[-1] == "same"
