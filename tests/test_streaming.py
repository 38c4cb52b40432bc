"""States written while the run goes on: the same table, in row groups, and nothing left
behind by a run that is not saved."""

from __future__ import annotations

import os
import sys
import threading

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.recording import parquet_options, to_table
from pyautonomousagent.runs import save_run, streaming, verify
from pyautonomousagent.streaming import NICER, StatesStream


def patrol(agents: int = 5, iterations: int = 40) -> Simulation:
    return Simulation.create(load("patrol").with_overrides(agents=agents, iterations=iterations))


def test_the_stream_writes_the_table_in_row_groups(tmp_path):
    sim = patrol()
    stream = StatesStream(sim.recorder, tmp_path / "states.parquet", rows=5 * 7)
    assert stream.block == 7
    sim.run(progress=False)
    path = stream.finish()
    assert stream.busy > 0
    written = pq.read_table(path)
    assert written.equals(to_table(sim.recorder), check_metadata=True)
    assert pq.ParquetFile(path).metadata.num_row_groups == 6  # 41 records: 5 x 7 + 6


def test_records_can_be_taken_by_range():
    sim = patrol().run(progress=False)
    whole = to_table(sim.recorder)
    parts = [to_table(sim.recorder, 0, 10), to_table(sim.recorder, 10, 41)]
    assert pa.concat_tables(parts).equals(whole, check_metadata=True)
    assert to_table(sim.recorder, 3, 3).num_rows == 0


def test_only_dictionary_columns_are_dictionary_encoded(tmp_path):
    table = to_table(patrol().run(progress=False).recorder)
    options = parquet_options(table.schema)
    assert options["use_dictionary"] == ["agent", "behaviour"]
    assert options["write_statistics"] == ["iteration"]
    pq.write_table(table, tmp_path / "t.parquet", **options)
    meta = pq.ParquetFile(tmp_path / "t.parquet").metadata.row_group(0)
    columns = [meta.column(i) for i in range(meta.num_columns)]
    encodings = {column.path_in_schema: column.encodings for column in columns}
    assert "RLE_DICTIONARY" in encodings["agent"]
    assert "RLE_DICTIONARY" not in encodings["x"]


def test_a_streamed_run_saves_the_same_data(tmp_path):
    plain, streamed = patrol().run(progress=False), patrol()
    with streaming(streamed, tmp_path / "run") as stream:
        assert stream is not None
        streamed.run(progress=False)
        saved = save_run(streamed, tmp_path / "run", animation=False, stream=stream)
    assert verify(saved.folder)["status"] == "complete"
    written = pq.read_table(saved.folder / "states.parquet")
    assert written.equals(to_table(plain.recorder), check_metadata=True)
    assert streamed.timings["write_data_thread"] > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_an_abandoned_stream_leaves_nothing(tmp_path):
    sim = patrol()
    with pytest.raises(RuntimeError), streaming(sim, tmp_path / "run") as stream:
        assert stream is not None and len(list(tmp_path.iterdir())) == 1
        sim.run(progress=False)
        raise RuntimeError("the run failed")
    assert list(tmp_path.iterdir()) == []
    assert sim.recorder.listeners == []


def test_csv_is_written_at_the_end(tmp_path):
    sim = patrol()
    with streaming(sim, tmp_path / "run", "csv") as stream:
        assert stream is None
        sim.run(progress=False)
        save_run(sim, tmp_path / "run", fmt="csv", animation=False, stream=stream)
    assert verify(tmp_path / "run")["files"][0]["name"] == "states.csv"


@pytest.mark.skipif(sys.platform != "linux", reason="threads have their own priority on Linux")
def test_the_writing_thread_gives_way_to_the_loop():
    from pyautonomousagent.streaming import _lower_priority

    seen: list[int] = []

    def probe() -> None:
        thread = threading.get_native_id()
        before = os.getpriority(os.PRIO_PROCESS, thread)
        _lower_priority()
        seen.append(os.getpriority(os.PRIO_PROCESS, thread) - before)

    main = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    worker = threading.Thread(target=probe)
    worker.start()
    worker.join()
    assert seen == [min(NICER, 19 - main)]
    assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == main  # the loop's
