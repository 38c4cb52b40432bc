"""How "auto" chooses between the batched and the compiled engine: by the estimated cost of
the run it is given (seconds with or without the compile, memory), never by timing here."""

from __future__ import annotations

import pytest

from pyautonomousagent import jit, record_blocks
from pyautonomousagent.simulation import costs, run
from pyautonomousagent.simulation.costs import RunCost, pick_engine, run_costs

GB = 10**9


def test_the_faster_engine_is_picked_where_its_memory_fits() -> None:
    given = {"batched": RunCost(10.0, 2 * GB), "compiled": RunCost(4.0, 2 * GB + 10**8)}
    assert pick_engine(given) == "compiled"
    assert pick_engine(given, available=3 * GB) == "compiled"
    assert pick_engine(given, available=2 * GB) == "batched"  # the compiled one would not fit
    slower = {**given, "compiled": RunCost(11.0, 2 * GB)}
    assert pick_engine(slower) == "batched"
    leaner = {**given, "compiled": RunCost(11.0, GB)}  # slower, but the batched engine
    assert pick_engine(leaner) == "compiled"  # would need twice its memory


def test_an_engine_needing_much_more_memory_is_never_picked() -> None:
    least = 4 * GB
    over = int(least * costs.MEMORY_MARGIN) + 1
    assert over - least > costs.MEMORY_SLACK
    assert (
        pick_engine({"batched": RunCost(9.0, least), "compiled": RunCost(1.0, over)}) == "batched"
    )
    within = {"batched": RunCost(9.0, least), "compiled": RunCost(1.0, over - 2)}
    assert pick_engine(within) == "compiled"
    small = {"batched": RunCost(9.0, 10**7), "compiled": RunCost(1.0, 10**7 + costs.MEMORY_SLACK)}
    assert pick_engine(small) == "compiled"  # 26x the memory, but only MEMORY_SLACK more


def test_where_nothing_fits_the_least_memory_and_ties_go_to_the_first() -> None:
    given = {"batched": RunCost(10.0, 5 * GB), "compiled": RunCost(1.0, 4 * GB)}
    assert pick_engine(given, available=GB) == "compiled"
    tie = {"batched": RunCost(2.0, GB), "compiled": RunCost(2.0, GB)}
    assert pick_engine(tie) == "batched"


def test_the_costs_follow_the_record_rate_and_the_cache() -> None:
    cold = run_costs(100_000, 500, record_every=1)
    decimated = run_costs(100_000, 500, record_every=100)
    for engine in ("batched", "compiled"):
        assert decimated[engine].seconds < cold[engine].seconds
        assert decimated[engine].bytes < cold[engine].bytes / 15  # 6 records, not 501
    warm = run_costs(100_000, 500, record_every=1, compiled_ready=True)
    assert warm["batched"] == cold["batched"]
    saved = cold["compiled"].seconds - warm["compiled"].seconds
    assert saved == pytest.approx(costs.AUTO_COMPILE_SECONDS - costs.COMPILED_LOAD_SECONDS)
    assert warm["compiled"].seconds < warm["batched"].seconds < cold["compiled"].seconds


def test_the_compiled_engines_extra_memory_does_not_grow_with_the_run() -> None:
    """Its record block is bounded (one record row where that is more than the budget)."""
    extra = []
    for iterations in (500, 5000, 50_000):
        c = run_costs(100_000, iterations)
        extra.append(c["compiled"].bytes - c["batched"].bytes)
    assert extra[0] == extra[1] == extra[2]
    assert extra[0] <= record_blocks.RECORD_BLOCK_BYTES + costs.COMPILED_BYTES - costs.BATCHED_BYTES
    million = run_costs(10**6, 500)
    row = 10**6 * (21 * 8 + 2)
    assert million["compiled"].bytes - million["batched"].bytes >= row  # one row at least


@pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
def test_choose_engine_asks_the_costs_of_the_run_it_is_given(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from pyautonomousagent.scenarios import load

    tree = run.scenario_tree(load("patrol"))
    monkeypatch.setattr(run, "available_memory", lambda: None)  # unknown: any fits
    assert run.choose_engine(tree, 100_000, 500) == "batched"  # a cold compile is the cost
    assert run.choose_engine(tree, 100_000, 500, compiled_ready=True) == "compiled"
    assert run.choose_engine(tree, 10**6, 4000, record_every=1000) == "compiled"
    monkeypatch.setattr(run, "available_memory", lambda: 10**9)  # less than compiled needs
    assert run.choose_engine(tree, 10**6, 4000, record_every=1000) == "batched"


TINY = {
    "scenario": "patrol",
    "iterations": 30,
    "set": {"agents": 5},
    "vary": {"low_energy_threshold": [96, 99]},
    "seeds": 1,
    "measures": ["alerts"],
}


@pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
def test_a_sweep_compiles_once_before_its_runs_and_says_so(
    tmp_path, monkeypatch: pytest.MonkeyPatch, compiled_loop
) -> None:
    """(The code comes from the shared cache, ``compiled_loop``: what is asserted is when
    ``compile_once`` compiles or loads, and what it says, not numba compiling.)"""
    from pyautonomousagent.experiments import Experiment, sweep
    from pyautonomousagent.experiments.sweeps import base_scenario, compile_once

    compiled_loop("patrol")
    monkeypatch.setenv("PYAA_CACHE_DIR", str(tmp_path / "cache"))
    said: list[str] = []
    auto = Experiment.from_mapping(TINY)  # 2 runs of 5 drones x 30: the batched engine's
    assert compile_once(auto, base_scenario(auto), 2, said.append) is None and said == []
    many = 10**6  # a million such runs pay for compiling
    scenario = base_scenario(auto).with_overrides(iterations=20_000)
    assert compile_once(auto, scenario, many, said.append) is not None
    assert said[0].startswith("compiling (or loading) the tree's loop for the compiled engine")
    assert "took" in said[-1]
    said.clear()
    compiled = Experiment.from_mapping({**TINY, "engine": "compiled"})
    result = sweep(compiled, tmp_path / "out", "serial", progress=False, report=said.append)
    assert [line.split(" ")[0] for line in said] == ["compiling", "compiled"]
    assert set(result.table["engine"].to_pylist()) == {"compiled"}


@pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
def test_set_up_compiles_the_serial_and_the_parallel_loop_for_any_later_size() -> None:
    """A small run's set-up leaves both fused variants compiled, so a large run after it
    (the parallel loop) finds its code compiled: ``ready``, no cold compile."""
    from pyautonomousagent import Simulation, load

    small = Simulation.create(load("patrol").with_overrides(agents=3, iterations=5),
                              engine="compiled")  # fmt: skip
    engine = small.engine
    fused = engine._fusable(small)
    assert fused is not None and engine._function(fused, 5) == "block_serial"
    code = engine._code(fused)
    for name in engine.variants(fused):
        assert getattr(code, name).signatures, name  # compiled for this run's types
    large = Simulation.create(load("patrol").with_overrides(agents=100_000, iterations=5),
                              engine="batched", record_every=5)  # fmt: skip
    bigger = type(engine)(
        run.scenario_tree(large.scenario), large.swarm, large.world, vars(large.scenario.parameters)
    )
    assert bigger._function(fused, 500) == "block_parallel" and bigger.ready(large)
