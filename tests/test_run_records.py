"""What a run folder records: the overrides given from Python, the iterations its data
holds after an interruption, and the same permissions as every folder the tool writes."""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.experiments import Experiment, sweep
from pyautonomousagent.runs import save_run


def test_overrides_given_from_python_are_recorded(tmp_path) -> None:
    scenario = load("gathering").with_overrides(iterations=5, agents=2)
    scenario = scenario.with_overrides(energy_use=0.1, agents=3)  # the later value counts
    sim = Simulation.create(scenario, seed=0).run(progress=False)
    save_run(sim, tmp_path / "run", animation=False)
    summary = json.loads((tmp_path / "run" / "run.json").read_text())
    assert summary["overrides"] == {"iterations": 5, "agents": 3, "energy_use": 0.1}
    save_run(sim, tmp_path / "given", animation=False, overrides={"agents": 3})
    given = json.loads((tmp_path / "given" / "run.json").read_text())
    assert given["overrides"] == {"agents": 3}  # what the caller says wins (pyaa run's --set)


def test_an_interrupted_run_counts_the_iterations_its_data_holds(tmp_path) -> None:
    scenario = load("gathering").with_overrides(iterations=100, agents=2)
    sim = Simulation.create(scenario, seed=0, record_every=10).run(progress=False, iterations=57)
    save_run(sim, tmp_path / "run", status="interrupted")
    summary = json.loads((tmp_path / "run" / "run.json").read_text())
    last = max(pq.read_table(tmp_path / "run" / "states.parquet")["iteration"].to_pylist())
    assert summary["iterations_done"] == last == 50  # the last record
    assert summary["iterations_run"] == 57  # what the loop ran past it, unrecorded


@pytest.fixture
def umask_027() -> Iterator[None]:
    """This process's umask 027 for the test (folders 750, files 640)."""
    before = os.umask(0o027)
    try:
        yield
    finally:
        os.umask(before)


def modes(root: Path) -> set[tuple[str, int]]:
    """("dir" or "file", permission bits) of ``root`` and everything under it."""
    found = {("dir", stat.S_IMODE(root.stat().st_mode))}
    for path in root.rglob("*"):
        kind = "dir" if path.is_dir() else "file"
        found.add((kind, stat.S_IMODE(path.stat().st_mode)))
    return found


def test_run_and_sweep_folders_have_the_same_permissions(tmp_path, umask_027) -> None:
    sim = Simulation.create(load("gathering").with_overrides(iterations=5), seed=0)
    save_run(sim.run(progress=False), tmp_path / "run", animation=False)
    experiment = Experiment.from_mapping(
        {"scenario": "gathering", "iterations": 5, "vary": {"agents": [2, 3]}, "every": 5}
    )
    sweep(experiment, tmp_path / "sweep", "serial", save_runs=True, progress=False)
    expected = {("dir", 0o750), ("file", 0o640)}
    assert modes(tmp_path / "run") == expected
    assert modes(tmp_path / "sweep") == expected
