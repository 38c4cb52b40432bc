"""A tree of more than ``compiled_source.INLINE_NODES`` nodes is written once, in a group
function that the serial and the parallel fused function both call (``block_group``, or
``tick_group`` where the loop runs Phase by Phase): the same bits as the batched engine on
both variants. The bound is lowered here so that the scenarios' own small trees take that
path (a tree above it takes a minute to compile)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyautonomousagent import jit
from pyautonomousagent.engines import compiled, compiled_source
from pyautonomousagent.testing import check_same_runs

from .test_compiled_engine import counted_run

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


@pytest.mark.parametrize(
    ("scenario", "group", "overrides"),
    [
        ("patrol", "block_group", {"agents": 6, "iterations": 300}),
        ("vacuum", "tick_group", {"agents": 4, "iterations": 300}),  # a swarm sensor
    ],
)
def test_a_large_trees_group_function_gives_the_batched_bits_serial_and_parallel(
    monkeypatch: pytest.MonkeyPatch, scenario: str, group: str, overrides: dict
) -> None:
    monkeypatch.setattr(compiled_source, "INLINE_NODES", 0)
    batched, _ = counted_run("batched", scenario, 3, **overrides)
    for parallel in (False, True):
        threshold = 0 if parallel else 10**12
        monkeypatch.setattr(compiled, "PARALLEL", threshold)
        monkeypatch.setattr(compiled, "PARALLEL_AGENTS", threshold)
        run, fused = counted_run("compiled", scenario, 3, **overrides)
        engine = run.engine
        function = engine._function(engine._fusable(run), 300)
        assert function.endswith("_parallel" if parallel else "_serial")
        source = Path(engine._code(engine._fusable(run)).__file__).read_text()
        assert source.count(f"{group}(first, last, ") == 3  # its definition, two calls
        assert fused == overrides["iterations"]
        check_same_runs(batched, run, ("batched", f"compiled, {function}"))
