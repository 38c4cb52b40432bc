"""A fused loop's records in blocks within a budget: the recorder holds the same bits and
stores the same columns in full as the batched engine's, however small the budget."""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent import Simulation, jit, load, record_blocks, recording
from pyautonomousagent.record_blocks import RecordBlock, fitting
from pyautonomousagent.recording import to_table
from pyautonomousagent.streaming import StatesStream

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


def test_a_call_is_cut_to_the_iterations_whose_records_fit() -> None:
    # every iteration recorded, 3 rows: iterations 11, 12, 13 from 10 (rows 11-13)
    assert fitting(10, 50, 1, 3) == 3
    # every 4th: from 10, rows 3.. hold iterations 12, 16, 20; 21-23 record nothing more
    assert fitting(10, 50, 4, 3) == 13
    assert fitting(10, 2, 4, 3) == 2 and fitting(0, 0, 1, 5) == 0
    assert fitting(7, 50, 1, 0) == 1  # one row always fits


@pytest.fixture
def compact(monkeypatch: pytest.MonkeyPatch) -> None:
    """Records compact from the first agent (as for 65,536 and more)."""
    monkeypatch.setattr(recording, "COMPACT_AGENTS", 1)


def test_the_buffers_hold_the_compact_columns_within_the_budget(compact: None) -> None:
    sim = Simulation.create(load("patrol").with_overrides(agents=50, iterations=40),
                            engine="batched")  # fmt: skip
    recorder = sim.recorder
    names = list(recorder.columns)
    row_bytes = 50 * (8 * len(names) + 2)  # every column and the behaviour compact
    block = RecordBlock(recorder, names, budget=5 * row_bytes + 7)
    assert block.fit(0, 100) == 5 and block.capacity == 5 and block.nbytes <= 5 * row_bytes
    columns, traces, behaviour = block.arrays(1)
    stored = set(recorder.columns.stored)
    assert stored  # the heading differs from the start
    for key, array in zip(names, columns, strict=True):
        if key in stored:  # written in place
            assert np.shares_memory(array, recorder.columns.full(key))
        else:
            assert array.shape == (5, 50)
    assert np.shares_memory(traces, recorder.traces)
    assert behaviour is not None and behaviour.shape == (5, 50)


@needs_numba
@pytest.mark.parametrize(("budget", "every"), [(1, 1), (3000, 1), (3000, 7), (1 << 27, 3)])
def test_compiled_records_in_blocks_are_the_batched_records(
    compact: None, monkeypatch: pytest.MonkeyPatch, budget: int, every: int
) -> None:
    """However small the budget (one record a call), the compiled engine's recorder stores
    the columns the batched engine's stores in full, with the same bits."""
    monkeypatch.setattr(record_blocks, "RECORD_BLOCK_BYTES", budget)
    scenario = load("patrol").with_overrides(agents=40, iterations=120)
    runs = {
        engine: Simulation.create(scenario, seed=3, engine=engine, record_every=every)
        for engine in ("batched", "compiled")
    }
    calls = []
    engine = runs["compiled"].engine
    original = engine.loop
    monkeypatch.setattr(engine, "loop", lambda sim, n, typical=None: calls.append(
        original(sim, n, typical)) or calls[-1])  # fmt: skip
    for sim in runs.values():
        sim.run(progress=False)
    batched, compiled = (runs[k].recorder for k in ("batched", "compiled"))
    assert sum(calls) == 120 and (budget > 3000 or len(calls) > 120 // every // 4)
    assert compiled.columns.stored == batched.columns.stored != list(batched.columns)
    assert to_table(compiled).equals(to_table(batched), check_metadata=True)
    assert np.array_equal(compiled.traces, batched.traces)


@needs_numba
def test_the_writer_hears_of_each_block(
    compact: None, monkeypatch: pytest.MonkeyPatch, tmp_path
) -> None:
    import pyarrow.parquet as pq

    monkeypatch.setattr(record_blocks, "RECORD_BLOCK_BYTES", 4000)  # a record a call
    sim = Simulation.create(load("patrol").with_overrides(agents=30, iterations=60),
                            engine="compiled")  # fmt: skip
    stream = StatesStream(sim.recorder, tmp_path / "states.parquet", rows=30 * 8)
    sim.run(progress=False)
    written = pq.read_table(stream.finish())
    assert written.equals(to_table(sim.recorder))
    assert pq.ParquetFile(tmp_path / "states.parquet").metadata.num_row_groups == 8
