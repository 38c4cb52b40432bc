"""The compiled engine against the batched engine: the same bits, fused loop or not."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from pyautonomousagent import Simulation, arrays, jit, kernels, load
from pyautonomousagent.bt import leaf
from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.spec import Node, TreeError
from pyautonomousagent.engines.compiled import MAX_COMPILED_NODES, CompiledEngine, compilable
from pyautonomousagent.simulation.costs import batched_seconds
from pyautonomousagent.simulation.run import choose_engine, scenario_tree
from pyautonomousagent.testing import check_engines_agree

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")

#: Drone leaves with kernels, with ports that make them change status during a patrol.
LEAVES = (
    ("Condition_Destination_Reached", {"distance": 3.0}),
    ("Condition_Low_Energy_Level", {"threshold": 97.0}),
    ("Condition_High_Damage_Level", {"threshold": 0.0}),
    ("Condition_Radiation_Detected", {}),
    ("Condition_Gathering_Moment", {"iteration": 7, "sender": "drone2"}),
    ("Action_Navigate_To_Destination_A", {}),
    ("Action_Set_Destination_Equal_To_Refueling_S", {}),
    ("Action_Set_Destination_Equal_To_Surveillance_S", {}),
    ("Action_Set_Destination_Equal_To_Other_Surveillance_S", {}),
    ("Action_Set_Destination_Equal_To_Current_Surveillance_S", {}),
    ("Action_Refuel_A", {"rate": 0.5}),
    ("Action_Repair_Damage_A", {}),
)
DECORATORS = sorted(name for name, r in NODE_TYPES.items() if r.status_map is not None)


def random_tree(rng: random.Random, depth: int = 3) -> Node:
    """A random tree of Sequence/Fallback (with and without memory), status-mapping
    decorators and drone leaves."""
    if depth == 0 or rng.random() < 0.25:
        kind, ports = rng.choice(LEAVES)
        return leaf(kind, f"l{rng.randrange(10**6)}", **ports)
    if rng.random() < 0.25:
        return Node(
            rng.choice(DECORATORS), f"d{rng.randrange(10**6)}", (random_tree(rng, depth - 1),)
        )
    kids = tuple(random_tree(rng, depth - 1) for _ in range(rng.randint(1, 4)))
    kind = rng.choice(["Sequence", "Fallback"])
    return Node(kind, f"c{rng.randrange(10**6)}", kids, {"memory": rng.random() < 0.5})


def run(engine: str, scenario: str = "patrol", tree: Node | None = None, **overrides: object):
    sim = Simulation.create(load(scenario).with_overrides(**overrides), seed=5, engine=engine,
                            tree=tree)  # fmt: skip
    return sim.run(progress=False)


def assert_same_runs(a: Simulation, b: Simulation) -> None:
    assert a.events == b.events
    for key, expected in a.recorder.columns.items():
        assert np.array_equal(b.recorder.columns[key], expected), key  # the same bits
    assert np.array_equal(a.recorder.traces, b.recorder.traces)
    assert np.array_equal(a.recorder.behaviour, b.recorder.behaviour)
    assert np.array_equal(a.recorder.iterations, b.recorder.iterations)
    assert np.array_equal(a.engine.node_statuses(), b.engine.node_statuses())


def test_scalar_helpers_repeat_the_array_code_bit_for_bit() -> None:
    rng = np.random.default_rng(1)
    points = rng.normal(0.0, 50.0, (4, 20000))
    points[:, :50] = 0.0  # zero vectors, both signs of zero
    points[0, 50:100] = points[2, 50:100]
    points[1, 25:50] = -0.0
    expected = arrays.bearing(*points)
    got = [kernels.bearing(*column) for column in points.T.tolist()]
    assert np.array_equal(np.array(got), expected)
    values = rng.normal(0.0, 1.0, 1000).tolist() + [0.0, -0.0, 1.0, -1.0]
    for v in values:
        assert kernels.np_sign(v) == np.sign(v) and str(kernels.np_sign(v)) == str(np.sign(v))
        assert kernels.np_maximum(v, 0.0) == np.maximum(v, 0.0)
        assert kernels.np_minimum(v, 0.5) == np.minimum(v, 0.5)


@needs_numba
@pytest.mark.parametrize("overrides", [{"agents": 300, "iterations": 1500},
                                       {"agents": 7, "iterations": 900, "energy_use": 0.2,
                                        "refuel_rate": 0.1}])  # fmt: skip
def test_fused_patrol_gives_the_batched_data(overrides: dict) -> None:
    batched, compiled = run("batched", **overrides), run("compiled", **overrides)
    assert compiled.engine.name == "compiled"
    assert_same_runs(batched, compiled)


@needs_numba
def test_drones_out_of_energy_raise_the_same_alerts() -> None:
    overrides = {"agents": 5, "iterations": 400, "energy_use": 0.5, "low_energy_threshold": 0.0}
    batched, compiled = run("batched", **overrides), run("compiled", **overrides)
    assert any(event["event"] == "alert" for event in batched.events)
    assert_same_runs(batched, compiled)


@needs_numba
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_trees_tick_alike(seed: int) -> None:
    tree = random_tree(random.Random(seed))
    check_engines_agree(tree, "patrol", seed, ("batched", "compiled"), agents=9, iterations=300)


@needs_numba
def test_auto_picks_compiled_where_it_can_and_batched_elsewhere() -> None:
    patrol = scenario_tree(load("patrol"))
    assert choose_engine(patrol, record_every=4000) == "compiled"  # 10^6 drones, 4000 its
    gathering = scenario_tree(load("gathering"))  # its messages have kernels too
    assert choose_engine(gathering, record_every=4000) == "compiled"
    scripted = leaf("Scripted", "s", statuses=[[1]])
    assert choose_engine(scripted, record_every=4000) == "batched"
    assert "no kernel" in compilable(scripted)


@needs_numba
def test_a_tree_over_the_node_limit_goes_to_the_batched_engine() -> None:
    """Its compile would take minutes (``MAX_COMPILED_NODES``): auto takes the batched
    engine, and the compiled engine refuses it in one line."""
    for children, fits in ((MAX_COMPILED_NODES - 1, True), (MAX_COMPILED_NODES, False)):
        hovers = tuple(Node("Action_Hover_S", f"hover{i}") for i in range(children))
        tree = Node("Fallback", "root", hovers, {"memory": False})
        assert (compilable(tree) == "") is fits, children
    assert f"more than the {MAX_COMPILED_NODES} it compiles" in compilable(tree)
    assert choose_engine(tree) == "batched"
    scenario = load("patrol").with_overrides(agents=3, iterations=5)
    with pytest.raises(TreeError, match=f"{MAX_COMPILED_NODES + 1} nodes"):
        Simulation.create(scenario, tree=tree, engine="compiled")
    assert Simulation.create(scenario, tree=tree).engine.name == "batched"


@needs_numba
def test_auto_takes_compiled_once_the_runs_loop_was_compiled(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, compiled_loop
) -> None:
    """Where it is faster than the batched engine with loading the compiled code (about 1
    s): 20,000 iterations of a few drones (NumPy's cost per call), 4000 of 5000 drones.
    (The code comes from the shared cache, ``compiled_loop``: what is asserted is the empty
    cache folder's marker, missing and then written, not numba compiling.)"""
    compiled_loop("gathering")
    monkeypatch.setenv("PYAA_CACHE_DIR", str(tmp_path))
    scenario = load("gathering").with_overrides(iterations=20_000)
    assert Simulation.create(scenario).engine.name == "batched"  # nothing compiled yet
    Simulation.create(scenario.with_overrides(low_energy_threshold=30.0), engine="compiled")
    assert Simulation.create(scenario).engine.name == "compiled"  # ports are no source
    other = load("gathering").with_overrides(iterations=4000, agents=5000)
    assert Simulation.create(other, record_every=100).engine.name == "compiled"  # any size
    short = load("gathering").with_overrides(iterations=20)  # faster than loading the code
    assert Simulation.create(short).engine.name == "batched"
    patrol = load("patrol").with_overrides(agents=10, iterations=20_000)  # another tree
    assert Simulation.create(patrol).engine.name == "batched"


@needs_numba
def test_auto_compiles_only_runs_that_pay_for_the_compiling(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYAA_CACHE_DIR", str(tmp_path))  # nothing compiled yet
    patrol = scenario_tree(load("patrol"))
    assert choose_engine(patrol, 1000, 4000) == "batched"  # 0.9 s on the batched engine
    assert choose_engine(patrol, 10**6, 400, record_every=400) == "batched"  # 26 s
    assert choose_engine(patrol, 10**6, 2000, record_every=2000) == "compiled"  # 130 s
    assert choose_engine(patrol, 4, 1_000_000) == "compiled"  # 150 s: NumPy's cost per call
    assert 0.5 < batched_seconds(1000, 4000) < 2.0 and batched_seconds(4, 8000) < 1.5
    small = Simulation.create(load("patrol").with_overrides(agents=10, iterations=5))
    assert small.engine.name == "batched"


def test_without_numba_auto_falls_back_to_batched(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PYAA_NO_JIT", "1")
    assert choose_engine(scenario_tree(load("patrol")), record_every=4000) == "batched"
    with pytest.raises(TreeError, match="numba"):
        Simulation.create(load("patrol"), engine="compiled")


@needs_numba
def test_a_run_that_cannot_be_fused_ticks_compiled_every_iteration() -> None:
    overrides = {"agents": 6, "iterations": 300}
    scenario = load("patrol").with_overrides(**overrides)
    sim = Simulation.create(scenario, seed=5, engine="compiled")
    assert isinstance(sim.engine, CompiledEngine)
    sim.mission.compiled_sensors = lambda sim: None  # type: ignore[method-assign]
    assert sim.engine.loop(sim, 10) == 0
    sim.run(progress=False)
    assert_same_runs(run("batched", **overrides), sim)


def counted_run(
    engine: str, scenario: str = "gathering", seed: int = 5, record_every: int = 1,
    **overrides: object,
):  # fmt: skip
    """A run, and how many of its iterations the compiled engine fused."""
    scenario_ = load(scenario).with_overrides(**overrides)
    sim = Simulation.create(scenario_, seed=seed, engine=engine, record_every=record_every)
    fused = []
    loop = getattr(sim.engine, "loop", None)
    if loop is not None:
        sim.engine.loop = lambda s, count, **kw: fused.append(loop(s, count, **kw)) or fused[-1]
    sim.run(progress=False)
    return sim, sum(fused)


def assert_same_shared_data(a: Simulation, b: Simulation) -> None:
    for receiver in range(a.swarm.size):
        assert a.mission.shared[receiver] == b.mission.shared[receiver], receiver


@needs_numba
@pytest.mark.parametrize(
    "overrides",
    [
        {},  # the paper's run: every message reaches everyone
        {"agents": 7, "iterations": 1500, "gathering_iteration": 900,
         "gathering_sender": "drone3", "low_energy_threshold": 90.0},
    ],
)  # fmt: skip
def test_fused_gathering_gives_the_batched_data_and_events(overrides: dict) -> None:
    batched, _ = counted_run("batched", **overrides)
    compiled, fused = counted_run("compiled", **overrides)
    assert fused == compiled.scenario.iterations  # stopped at the order, to record it
    assert_same_runs(batched, compiled)
    assert [e["type"] for e in compiled.events if e["event"] == "message"] == ["gathering"]
    assert_same_shared_data(batched, compiled)


@needs_numba
def test_messages_that_reach_only_some_go_through_the_python_datalink() -> None:
    overrides = {"agents": 6, "iterations": 900, "datalink_range": 25.0,
                 "gathering_iteration": 400, "low_energy_threshold": 80.0}  # fmt: skip
    batched, _ = counted_run("batched", **overrides)
    compiled, fused = counted_run("compiled", **overrides)
    assert 0 < fused < 900  # fused while all were in range (at the start), stepped after
    assert_same_runs(batched, compiled)
    assert_same_shared_data(batched, compiled)


@needs_numba
def test_stepping_the_fused_engine_one_iteration_at_a_time() -> None:
    scenario = load("gathering").with_overrides(iterations=300, gathering_iteration=120)
    stepped = Simulation.create(scenario, seed=5, engine="compiled")
    for _ in range(300):
        stepped.step()
    ran = Simulation.create(scenario, seed=5, engine="batched").run(progress=False)
    assert_same_runs(ran, stepped)
    assert_same_shared_data(ran, stepped)


@needs_numba
def test_a_later_step_waits_only_where_nothing_ticked_after_it_sees_it() -> None:
    def navigate_then_hold(decorator: str) -> Node:  # Action_Repair_A writes the heading too
        navigate = leaf("Action_Navigate_To_Destination_A", "go")
        hold = leaf("Action_Repair_Damage_A", "hold", speed=0.05)
        return Node("Sequence", "s", (Node(decorator, "d", (navigate,)), hold), {"memory": False})

    for decorator, waits in (("RunningIsSuccess", False), ("Inverter", True)):
        tree = navigate_then_hold(decorator)
        sim = Simulation.create(load("patrol").with_overrides(agents=4, iterations=5),
                                engine="compiled", tree=tree)  # fmt: skip
        assert sim.engine.layout.deferred == ((2,) if waits else ())
        check_engines_agree(tree, "patrol", 3, ("batched", "compiled"), agents=9, iterations=200)


@needs_numba
@pytest.mark.parametrize("parallel", [True, False])
def test_fused_messages_in_groups_of_agents_give_the_batched_data(
    monkeypatch: pytest.MonkeyPatch, parallel: bool
) -> None:
    from pyautonomousagent.engines import compiled

    monkeypatch.setattr(compiled, "PARALLEL_AGENTS", 100 if parallel else 10**9)
    overrides = {"agents": 700, "iterations": 400, "gathering_iteration": 150,
                 "gathering_sender": "drone650", "low_energy_threshold": 85.0}  # fmt: skip
    batched, _ = counted_run("batched", **overrides)
    compiled_run, fused = counted_run("compiled", **overrides)
    assert fused == 400
    function = compiled_run.engine._function(compiled_run.engine._fused, 1)
    assert function.endswith("_parallel" if parallel else "_serial")  # 3 groups of 256 either way
    assert_same_runs(batched, compiled_run)
    assert_same_shared_data(batched, compiled_run)


@needs_numba
@pytest.mark.parametrize("quiet", [False, True])
def test_pyaa_run_says_when_it_compiles_and_how_long_it_took(
    quiet: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    """A fused loop not yet compiled on this machine (its marker missing): a line before,
    and one with the seconds after (from 0 s here); none with --quiet. The seconds are in
    run.json's timings."""
    import json

    from pyautonomousagent import cli
    from pyautonomousagent.engines import compiled

    monkeypatch.setattr(compiled, "SAY_COMPILE_SECONDS", 0.0)
    compiled.compile_log.info("an earlier compile: logging caches that INFO is off")
    monkeypatch.setattr(CompiledEngine, "_marker", lambda self, sim, fused: tmp_path / "marker")
    out = tmp_path / "run"
    argv = ["run", "gathering", "--engine", "compiled", "--iterations", "20", "--no-gif",
            "--out", str(out), *(["--quiet"] if quiet else [])]  # fmt: skip
    assert cli.main(argv) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "compil" in line]
    if quiet:
        assert said == []
    else:
        assert said[0].startswith("pyaa: compiling this tree's fused loop")
        assert said[1].startswith(
            "pyaa: compiled engine: compiling (or loading) the tree's code took"
        )
    timings = json.loads((out / "run.json").read_text())["timings_s"]
    assert 0.0 < timings["compile"] <= timings["setup"]
