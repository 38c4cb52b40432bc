"""radiation-search on the compiled engine: its leaf kernels, sensor and ``found`` handler,
and the fused loop against the batched engine, bit for bit."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from pyautonomousagent import Simulation, jit, load
from pyautonomousagent.bt import (
    Node,
    inverter,
    leaf,
    reactive_fallback,
    reactive_sequence,
    sequence,
)
from pyautonomousagent.missions.radiation_search import FOUND
from pyautonomousagent.missions.radiation_search.kernels import store_found_everyone
from pyautonomousagent.testing import check_engines_agree, check_same_runs

from .test_compiled_engine import counted_run as counted

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")

#: Seeds whose 4 drones find the source (at iterations 229, 222 and 148) within 400.
SEEDS = (0, 1, 2)


def counted_run(engine: str, seed: int, record_every: int = 1, **overrides: object):
    """A radiation-search run, and how many of its iterations the compiled engine fused."""
    return counted(engine, "radiation-search", seed, record_every, **overrides)


def found(sim: Simulation) -> list[dict]:
    return [e for e in sim.events if e["event"] == "message" and e["type"] == FOUND]


def assert_same_runs(a: Simulation, b: Simulation) -> None:
    check_same_runs(a, b, ("batched", "compiled"))


@pytest.mark.parametrize(("seed", "every"), [(0, 1), (1, 1), (2, 7)])
def test_the_fused_loop_gives_the_batched_bits_through_the_detection(seed: int, every: int):
    batched, _ = counted_run("batched", seed, every, iterations=400)
    compiled, fused = counted_run("compiled", seed, every, iterations=400)
    assert compiled.engine.name == "compiled" and compiled.engine.fuses(compiled)
    assert fused == 400  # every iteration fused; the loop stops at found for Python to deliver
    assert len(found(batched)) >= 1  # the run covers the detection and the flight to it
    assert_same_runs(batched, compiled)
    assert "radiation" in compiled.recorder.columns


def test_a_short_run_without_detection_is_fused_whole():
    batched, _ = counted_run("batched", 2, iterations=120)
    compiled, fused = counted_run("compiled", 2, iterations=120)
    assert fused == 120 and not found(batched)
    assert_same_runs(batched, compiled)


def test_found_out_of_range_is_delivered_by_the_python_datalink():
    overrides = {"iterations": 320, "datalink_range": 12.0}
    batched, _ = counted_run("batched", 0, **overrides)
    compiled, fused = counted_run("compiled", 0, **overrides)
    (message,) = found(batched)
    reported = batched.recorder.column("source_reported")[message["iteration"] + 1]
    assert 1 <= reported.sum() < 4  # the sender knows it; some drones were out of range
    assert 0 < fused < 320  # the delivery that reached only some was stepped in NumPy
    assert_same_runs(batched, compiled)


def test_several_reports_in_one_iteration_the_others_take_the_first():
    """Drones 1, 3, 5, ... start within the detection radius and report at once; the others
    take drone 1's position (the first in canonical order), the reporters keep their own."""
    starts = [[42.0, 41.0], [5.0, 5.0], [43.0, 40.0], [7.0, 7.0]]
    overrides = {"agents": 12, "iterations": 200, "start_positions": starts}
    batched, _ = counted_run("batched", 4, **overrides)
    compiled, fused = counted_run("compiled", 4, **overrides)
    assert fused == 200
    reports = found(batched)
    assert [e["iteration"] for e in reports] == [1] * 6
    x = batched.recorder.column("x_reported_position")[2]
    assert x[1::2].tolist() == [reports[0]["data"]["x"]] * 6
    assert x[::2].tolist() == [e["data"]["x"] for e in reports]  # 42, 43, 42, ...
    assert_same_runs(batched, compiled)


@pytest.mark.parametrize("seed", range(20))
def test_the_handler_kernel_does_what_the_python_handler_does(seed: int):
    """Several ``found`` from random senders, drones that already know a position or not."""
    rng = np.random.default_rng(seed)
    sims = [Simulation.create(load("radiation-search").with_overrides(agents=9), seed=seed)
            for _ in range(2)]  # fmt: skip
    senders = np.sort(rng.choice(9, size=rng.integers(1, 5), replace=False))
    knows = rng.random(9) < 0.3
    known = np.where(knows, rng.random(9), 0.0)
    points = rng.random(senders.size) * 60.0
    deliveries = []
    for sim in sims:
        bb = sim.swarm.blackboard
        bb["source_reported"][:] = knows
        bb["x_reported_position"][:] = known
        bb["y_reported_position"][:] = known + 1.0
        sim.world.datalink.send(senders, FOUND, {"x": points, "y": points + 0.5}, (points, points))
        (delivery,) = sim.world.datalink.deliver(sim.swarm.columns["x"], sim.swarm.columns["y"])
        assert delivery.to_all
        deliveries.append(delivery)
    sims[0].mission.store_reported_position(sims[0], deliveries[0])
    messages = deliveries[1].messages
    data = np.stack([messages.data["x"], messages.data["y"]])
    bb = sims[1].swarm.blackboard
    store_found_everyone(1, messages.senders.astype(np.int64), data, len(messages),
                         bb["source_reported"], bb["x_reported_position"],
                         bb["y_reported_position"])  # fmt: skip
    for key, expected in sims[0].swarm.blackboard.items():
        assert np.array_equal(sims[1].swarm.blackboard[key], expected), key
    lone = senders[0] if senders.size == 1 and not knows[senders[0]] else -1  # hears none
    assert (sims[1].swarm.blackboard["source_reported"] == (np.arange(9) != lone)).all()


def wander(**ports: object) -> Node:
    return leaf("Action_Wander_A", "wander", **ports)


#: Small trees in which each leaf changes status as the drones move.
TREES = {
    "above, hover, wander near the edge": reactive_fallback(
        "root",
        sequence(
            "s",
            leaf("Condition_Radiation_Above_Threshold", "above", threshold=5.0),
            leaf("Action_Hover_S", "hover"),
        ),
        wander(period=7, margin=15.0),
    ),
    "at the reported position, fly there": reactive_fallback(
        "root",
        sequence(
            "s",
            leaf("Condition_At_Reported_Position", "at", distance=8.0),
            leaf("Action_Hover_S", "hover"),
        ),
        leaf("Action_Fly_To_Reported_Position_A", "fly", speed=0.3),
    ),
    "report once, then fly": reactive_fallback(
        "root",
        sequence(
            "s",
            inverter("not", leaf("Condition_Source_Reported", "known")),
            leaf("Condition_Radiation_Above_Threshold", "above", threshold=10.0),
            leaf("Action_Report_Source_S", "report"),
        ),
        reactive_sequence(
            "go",
            leaf("Condition_Source_Reported", "known_2"),
            leaf("Action_Fly_To_Reported_Position_A", "fly"),
        ),
        wander(period=3),
    ),
}


@pytest.mark.parametrize("name", list(TREES))
def test_each_leaf_kernel_ticks_as_the_batched_leaf(name: str):
    """Node statuses compared after every tick (stepping), then every column and event."""
    tree = TREES[name]
    assert check_engines_agree(tree, "radiation-search", 3, ("batched", "compiled"),
                               agents=6, iterations=260) == 260  # fmt: skip


def test_the_scenario_tree_ticks_alike_step_by_step():
    assert check_engines_agree(None, "radiation-search", 2, ("batched", "compiled"),
                               iterations=200) == 200  # fmt: skip


#: Run under NUMBA_ENABLE_CUDASIM=1: the GPU engine's kernel in numba's CUDA simulator on a
#: radiation-search tree that sends nothing (the GPU engine refuses trees that send messages
#: so far), against the batched engine; prints "same" or the first difference.
SIMULATED = textwrap.dedent(
    """
    import numpy as np
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.bt import leaf, reactive_fallback, sequence

    tree = reactive_fallback(
        "root",
        sequence("s", leaf("Condition_Radiation_Above_Threshold", "above", threshold=5.0),
                 leaf("Action_Hover_S", "hover")),
        sequence("f", leaf("Condition_At_Reported_Position", "at", distance=8.0),
                 leaf("Action_Fly_To_Reported_Position_A", "fly")),
        leaf("Action_Wander_A", "wander", period=7, margin=15.0))
    scenario = load("radiation-search").with_overrides(agents=4, iterations=60)
    for seed in (1, 2, 3):
        a, b = (Simulation.create(scenario, seed=seed, engine=e, tree=tree).run(progress=False)
                for e in ("batched", "gpu"))
        assert b.engine.name == "gpu" and b.engine.timings["kernel"] > 0.0
        assert set(np.unique(a.recorder.behaviour)) >= {6, 7}  # flies and wanders
        ra, rb = a.recorder, b.recorder
        checks = [(k, ra.columns[k], rb.columns[k]) for k in ra.columns]
        checks += [("traces", ra.traces, rb.traces), ("behaviour", ra.behaviour, rb.behaviour)]
        for name, x, y in checks:
            if not np.array_equal(np.asarray(x), np.asarray(y)):
                print("differ", seed, name)
                raise SystemExit(1)
        if a.events != b.events:
            print("differ", seed, "events")
            raise SystemExit(1)
    print("same")
    """
)


def test_the_simulated_gpu_kernel_runs_the_leaf_kernels_with_the_batched_bits():
    """The wander's random headings (``uniform_of_one``), the sensor and the leaves that
    send nothing, in numba's CUDA simulator."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run([sys.executable, "-c", SIMULATED], env=env, capture_output=True,
                          text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip().splitlines()[-1] == "same"
