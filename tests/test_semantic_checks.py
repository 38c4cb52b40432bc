"""Input checked for what it means before anything runs (issue 29): CLI options that name
agents or columns, the record decimation, a view that fails after a complete run, the
Python API's ``save_run`` and lesson checks, and a vacuum room's obstacles."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from pyautonomousagent import cli
from pyautonomousagent.cli import main
from pyautonomousagent.lessons import ExerciseError, check_exercise
from pyautonomousagent.runs import RunError, save_run
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import ScenarioError, Simulation

GATHERING = Path(cli.__file__).parent / "missions/gathering/gathering.yaml"


def _one_line(err: str) -> None:
    assert err.count("\n") == 1 and err.startswith("pyaa: error: "), err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--follow", "nobody"], "--follow: no agent named 'nobody'; agents are drone1..drone4"),
        (["--btlog", "drone9"], "--btlog: no agent named 'drone9'"),
        (["--trace", ",,"], "--trace needs agent names, counts or 'all' separated by commas"),
        (["--trace", "drone1,"], "--trace needs agent names"),
        (["--trace", "drone1,drone77"], "--trace: no agent named 'drone77'"),
        (["--inset", "--follow", "robot1"], "--follow: no agent named 'robot1'"),
    ],
)
def test_options_naming_agents_are_checked_before_the_run(
    options: list[str], message: str, tmp_path: Path, monkeypatch, capsys
) -> None:
    def never(*args: Any, **kwargs: Any) -> str:
        raise AssertionError("the simulation ran before the options were checked")

    monkeypatch.setattr(cli, "simulate", never)
    out = tmp_path / "out"
    argv = ["run", "gathering", "--iterations", "10000", "--out", str(out), "--quiet"]
    assert main([*argv, *options]) == 2
    err = capsys.readouterr().err
    _one_line(err)
    assert message in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("trace", [",,", "drone1,", "", ["drone2", ""]])
def test_simulation_create_refuses_an_empty_trace_item(trace: Any) -> None:
    with pytest.raises(ScenarioError, match="trace: give agent names, counts or 'all'"):
        Simulation.create(load("gathering").with_overrides(iterations=2), trace=trace)


def test_inset_traces_the_first_agent_even_with_trace_0(tmp_path: Path) -> None:
    out = tmp_path / "out"
    argv = ["run", "gathering", "--iterations", "3", "--out", str(out), "--quiet"]
    assert main([*argv, "--trace", "0", "--inset", "--frame-every", "3", "--no-replay"]) == 0
    assert pq.read_table(out / "traces.parquet").column("agent").unique().to_pylist() == ["drone1"]


def _mission_whose_drawing_fails(tmp_path: Path) -> Path:
    """A scenario file whose mission's ``marks`` (drawn by every view) raises."""
    (tmp_path / "mission.py").write_text(
        "from pyautonomousagent.missions.gathering import GatheringMission\n\n\n"
        "class Broken(GatheringMission):\n"
        "    def marks(self):\n"
        "        raise RuntimeError('the drawing broke')\n",
        encoding="utf-8",
    )
    text = GATHERING.read_text(encoding="utf-8").replace(
        "mission: gathering", "mission: mission.py"
    )
    path = tmp_path / "broken.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_failed_view_says_the_data_is_complete(tmp_path: Path, capsys) -> None:
    scenario = _mission_whose_drawing_fails(tmp_path)
    out = tmp_path / "out"
    argv = ["run", str(scenario), "--iterations", "6", "--no-gif", "--out", str(out), "--quiet"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "the data is complete (all 6 iterations)" in err
    assert "the drawing broke" in err and f"pyaa replay {out}" in err
    assert "failed at iteration" not in err
    assert pq.read_table(out / "states.parquet").column("iteration").to_pylist()[-1] == 6


def test_record_every_longer_than_the_run_keeps_the_first_and_last_state(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["run", "gathering-3d", "--iterations", "7", "--record-every", "100", "--no-gif"]
    assert main([*argv, "--no-replay", "--out", str(out), "--quiet"]) == 0
    iterations = set(pq.read_table(out / "states.parquet").column("iteration").to_pylist())
    assert iterations == {0, 7}
    sim = Simulation.create(load("gathering-3d").with_overrides(iterations=7), record_every=100)
    assert sim.recorder.every == 7
    sweep = ["sweep", "gathering-3d", "--vary", "energy_use=0.01,0.02", "--iterations", "7"]
    folder = tmp_path / "sweep"
    assert main([*sweep, "--record-every", "100", "--serial", "--out", str(folder), "--quiet"]) == 0
    assert pq.read_table(folder / "results.parquet").column("status").to_pylist() == ["ok", "ok"]


def test_plot_refuses_a_column_that_is_no_measure(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "sweep"
    sweep = ["sweep", "gathering", "--vary", "refuel_rate=1,2", "--iterations", "4", "--serial"]
    assert main([*sweep, "--out", str(folder), "--quiet"]) == 0
    picture = tmp_path / "p.png"
    argv = ["plot", str(folder), "--x", "refuel_rate", "--out", str(picture)]
    assert main([*argv, "--measure", "status"]) == 2
    err = capsys.readouterr().err
    _one_line(err)
    assert "'status' is not a measure" in err
    assert not picture.exists()


@pytest.mark.parametrize("thing", [42, "gathering", None, load("gathering")])
def test_save_run_of_something_that_is_no_simulation(thing: Any, tmp_path: Path) -> None:
    with pytest.raises(RunError, match="save_run saves a Simulation"):
        save_run(thing, tmp_path / "run")
    assert list(tmp_path.iterdir()) == []


def test_save_run_of_a_simulation_that_never_ran(tmp_path: Path) -> None:
    sim = Simulation.create(load("gathering").with_overrides(iterations=5))
    with pytest.raises(RunError, match=r"never ran \(0 of its 5 iterations\).*simulate\(sim\)"):
        save_run(sim, tmp_path / "run", animation=False)
    with pytest.raises(RunError, match="status must be one of"):
        save_run(sim.run(progress=False), tmp_path / "run", status="done")
    assert list(tmp_path.iterdir()) == []
    assert save_run(sim, tmp_path / "run", animation=False).status == "complete"


@pytest.mark.parametrize(
    "obstacle",
    [
        {"shape": "rect", "x": 20, "y": 3, "width": 1, "height": 1},
        {"shape": "rect", "x": -1, "y": 3, "width": 2, "height": 1},
        {"shape": "rect", "x": 15, "y": 9, "width": 1, "height": 2},
        {"shape": "circle", "x": 15.5, "y": 5, "radius": 1},
        {"shape": "circle", "x": 8, "y": -3, "radius": 1},
    ],
)
def test_a_vacuum_obstacle_outside_the_room_is_refused(obstacle: dict[str, Any]) -> None:
    with pytest.raises(
        ScenarioError, match=r"world.obstacles\[1\] \(a .* must lie inside the room"
    ):
        load("vacuum").with_overrides(obstacles=[{"shape": "circle", "x": 3, "y": 3, "radius": 1},
                                                 obstacle])  # fmt: skip


def test_a_vacuum_obstacle_against_the_wall_is_inside(capsys) -> None:
    walls = [{"shape": "rect", "x": 0, "y": 0, "width": 16, "height": 1},
             {"shape": "circle", "x": 15, "y": 5, "radius": 1}]  # fmt: skip
    assert len(load("vacuum").with_overrides(obstacles=walls).objects.obstacles) == 2
    assert main(["run", "vacuum", "--world", "10,5", "--iterations", "2", "--no-gif"]) == 2
    _one_line(capsys.readouterr().err)


@pytest.mark.parametrize(
    ("lesson", "answers", "message"),
    [
        ("nine", {}, "There is no exercise for lesson 'nine'"),
        (None, {}, "There is no exercise for lesson None"),
        (True, {}, "There is no exercise for lesson True"),
        (7, {"agents": "many"}, "`agents` should be a whole number of drones, got 'many'"),
        (7, {"agents": 10**400}, "`agents` should be a whole number"),
        (7, {"agents": math.inf}, "`agents` should be a whole number"),
        (7, {"agent": 5}, "has no answer `agent` \\(did you mean `agents`\\?\\); give agents="),
        (5, {"tree_file": 42}, "`tree_file` should be the name of your YAML tree file"),
        (5, {"tree_file": ""}, "`tree_file` should be the name"),
        (6, {"table": None}, "Not answered yet: set `table`"),
        (8, {"climb_time": "soon"}, "`climb_time` should be a number of seconds, got 'soon'"),
        (8, {"climb_time": 10**400}, "`climb_time` should be a number of seconds"),
        (1, {"position": [10**400, 1.0]}, "`position` should be 2 numbers"),
        (4, {"leaf_type": None}, "Not answered yet"),
    ],
)
def test_lesson_checks_give_a_hint_for_malformed_answers(
    lesson: Any, answers: dict[str, Any], message: str
) -> None:
    with pytest.raises(ExerciseError, match=message):
        check_exercise(lesson, **answers)


def test_lesson_04_refuses_a_scenario_that_is_no_scenario() -> None:
    from pyautonomousagent.bt import Leaf, register_leaf
    from pyautonomousagent.bt.leaf import LEAF_TYPES

    class ConditionShelterNear(Leaf):
        type_name = "Condition_Shelter_Near"

    with LEAF_TYPES.scoped():
        register_leaf(ConditionShelterNear)
        with pytest.raises(ExerciseError, match="`scenario` should be the lesson's Scenario"):
            check_exercise(4, leaf_type=ConditionShelterNear, scenario="shelters.yaml")


def test_replay_checks_btlog_agents_before_writing(tmp_path: Path, capsys) -> None:
    run = tmp_path / "run"
    argv = ["run", "gathering", "--iterations", "3", "--no-gif", "--no-replay", "--quiet"]
    assert main([*argv, "--trace", "drone2", "--out", str(run)]) == 0
    for agent, message in (("nobody", "no agent named 'nobody'"), ("drone1", "not traced")):
        assert main(["replay", str(run), "--btlog", agent]) == 2
        err = capsys.readouterr().err
        _one_line(err)
        assert f"--btlog: {message}" in err or message in err
    assert sorted(p.name for p in run.iterdir()) == ["run.json", "states.parquet", "traces.parquet"]
