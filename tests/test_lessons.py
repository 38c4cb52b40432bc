"""The lessons' exercise checks: right answers pass, missing and wrong ones fail with a hint."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.compute as pc
import pytest

from pyautonomousagent.lessons import (
    CHECKS,
    STATUS_COLOURS,
    ExerciseError,
    check_exercise,
    embedded_replay,
    l02_tree,
    l05_expected_tree,
    l09_expected_tree,
    scripted,
    tick_table,
    x8_climb_time,
)
from pyautonomousagent.testing import scoped_registrations


def test_tick_table_shows_a_reactive_sequence_halting_its_action() -> None:
    from pyautonomousagent.bt import leaf, reactive_sequence

    tree = reactive_sequence(
        "root",
        leaf("Scripted", "ok", statuses=scripted("SUCCESS", "FAILURE")),
        leaf("Scripted", "act", statuses=scripted("RUNNING", "RUNNING")),
    )
    table = tick_table(tree, 2)
    assert table.names == ("root", "ok", "act") and table.depths == (0, 1, 1)
    assert table.statuses == (("RUNNING", "SUCCESS", "RUNNING"), ("FAILURE", "FAILURE", "INVALID"))
    assert f"background:{STATUS_COLOURS['RUNNING']};" in table._repr_html_()
    assert STATUS_COLOURS["RUNNING"] == "#ffe7c6"  # the views' orange, pale
    assert str(table).splitlines()[2].split() == ["ok", "SUCCESS", "FAILURE"]


def test_scripted_refuses_an_unknown_status() -> None:
    with pytest.raises(ValueError, match="unknown status 'DONE'"):
        scripted("SUCCESS", "DONE")


def test_check_02_right_answer(capsys: pytest.CaptureFixture[str]) -> None:
    check_exercise(2, root_statuses=["running", "RUNNING", "RUNNING", "SUCCESS", "RUNNING"])
    assert capsys.readouterr().out.startswith("\u2714 Well done!")


@pytest.mark.parametrize(
    ("answer", "message"),
    [
        (None, "Not answered yet: set `root_statuses`"),
        ("RUNNING", "should be a list of 5 statuses"),
        (["RUNNING"] * 4, "has 4 statuses; give one per tick"),
        (["RUNNING", "DONE", "RUNNING", "SUCCESS", "RUNNING"], "'DONE' is not a status"),
        (["RUNNING", "RUNNING", "RUNNING", "RUNNING", "RUNNING"], "after tick 4 is not RUNNING"),
    ],
)
def test_check_02_wrong_answers(answer: object, message: str) -> None:
    with pytest.raises(ExerciseError, match=message):
        check_exercise("02", root_statuses=answer)


def test_check_02_answer_is_what_the_engines_give() -> None:
    for engine in ("pytrees", "batched"):
        assert tick_table(l02_tree(), 5, engine).column("enter_room") == [
            "RUNNING", "RUNNING", "RUNNING", "SUCCESS", "RUNNING",
        ]  # fmt: skip


def test_an_exercise_error_renders_without_a_traceback() -> None:
    error = ExerciseError("Not quite.\nHint: look again.")
    assert error._render_traceback_() == ["\u2718 Not quite.", "  Hint: look again."]


def test_an_embedded_replay_fills_the_width_and_opens_full_page(tmp_path: Path) -> None:
    import html
    import re

    page = '<!DOCTYPE html><title>a "replay" & more</title><p>ok</p>'
    (tmp_path / "replay.html").write_text(page, encoding="utf-8")
    shown = embedded_replay(tmp_path / "replay.html")
    markup = shown._repr_html_()
    frame = re.search(r'<iframe title="replay replay.html" srcdoc="([^"]*)" style="([^"]*)"',
                      markup)  # fmt: skip
    assert frame is not None, markup
    assert html.unescape(frame[1]) == page  # the page whole, its quotes escaped
    assert "width:100%" in frame[2] and "height:85vh" in frame[2]
    assert "createObjectURL" in html.unescape(markup) and "full page</button>" in markup
    assert repr(shown) == str(shown) == "replay.html: a replay of 0 kB (open it in a browser)"


def test_every_lesson_has_a_check() -> None:
    assert set(CHECKS) >= {"02", "06"}
    with pytest.raises(ExerciseError, match="no exercise for lesson 10"):
        check_exercise(10)


# --- the other lessons' checks: missing and wrong answers fail with a hint ------------------


@pytest.mark.parametrize(
    ("lesson", "answers", "message"),
    [
        (1, {}, "Not answered yet: set `position`"),
        (1, {"position": (50.0, "north")}, "should be 2 numbers"),
        (1, {"position": (50.0, 68.0)}, "Not quite: .* units from where the drone is"),
        (3, {}, "Not answered yet: set `heard`"),
        (3, {"heard": "drone3"}, "should be a list of drone names"),
        (3, {"heard": ["drone9"]}, "'drone9' is not a drone"),
        (3, {"heard": ["drone2", "drone3", "drone4"]}, "does not reach exactly"),
        (4, {}, "Not answered yet: set `ConditionShelterNear`"),
        (4, {"leaf_type": 3}, "should be a class derived from Leaf"),
        (5, {}, "Not answered yet: set `tree_file`"),
        (5, {"tree_file": "slow.xml"}, "is not a YAML file"),
        (5, {"tree_file": "no-such-file.yaml"}, "There is no file"),
        (6, {}, "Not answered yet: set `table`"),
        (6, {"table": [1, 2]}, "should be a sweep's results table"),
        (7, {}, "Not answered yet: set `agents`"),
        (7, {"agents": 2.5}, "should be a whole number"),
        (7, {"agents": 260_000}, "still below AUTO_COMPILE_SECONDS"),
        (7, {"agents": 270_000}, "fewer drones already reach"),
        (8, {}, "Not answered yet: set `climb_time`"),
        (8, {"climb_time": "soon"}, "should be a number of seconds"),
        (9, {}, "Not answered yet: set `tree_file`"),
        (9, {"tree_file": 9}, "should be the name of the XML file"),
        (9, {"tree_file": "early.yaml"}, "is not an XML file: press Save XML"),
        (9, {"tree_file": "no-such-file.xml"}, "There is no file"),
    ],
)
def test_checks_refuse_missing_and_wrong_answers(
    lesson: int, answers: dict[str, object], message: str, tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ExerciseError, match=message):
        check_exercise(lesson, **answers)


def test_check_01_right_answer(capsys: pytest.CaptureFixture[str]) -> None:
    from pyautonomousagent.models.drone2d import DroneParameters, advance

    x, y, v, a = (np.array([value]) for value in (50.0, 50.0, 0.0, 0.0))
    for _ in range(180):
        x, y, v, a = advance(x, y, v, a, np.array([0.01]), np.array([2.0]), DroneParameters())
    check_exercise(1, position=[float(x[0]), float(y[0])])
    assert "Well done" in capsys.readouterr().out


def test_check_05_wrong_file_and_a_file_that_does_not_load(tmp_path: Path, monkeypatch) -> None:
    from pyautonomousagent.bt import save_tree
    from pyautonomousagent.missions.drones.trees import gathering_tree

    monkeypatch.chdir(tmp_path)
    save_tree(gathering_tree(), "unchanged.yaml")  # forgot the edit
    with pytest.raises(ExerciseError, match="the drones' x is not what it should be"):
        check_exercise(5, tree_file="unchanged.yaml")
    Path("broken.yaml").write_text("trees: [\n")
    with pytest.raises(ExerciseError, match="Your file does not load: broken.yaml"):
        check_exercise(5, tree_file="broken.yaml")
    save_tree(l05_expected_tree(), "slow.yaml")
    check_exercise(5, tree_file="slow.yaml")


def test_check_06_wrong_best(tmp_path: Path) -> None:
    from pyautonomousagent.experiments import Experiment, sweep

    experiment = Experiment.from_mapping({
        "scenario": "patrol", "iterations": 300, "set": {"agents": 2},
        "vary": {"energy_use": [0.1, 0.2, 0.3]}, "seeds": 3, "measures": ["minimum_energy"],
    })  # fmt: skip
    table = sweep(experiment, tmp_path / "sweep", backend="serial", progress=False).table
    with pytest.raises(ExerciseError, match="does not have the lowest mean minimum energy"):
        check_exercise(6, table=table, best=0.1)
    check_exercise(6, table=table, best=0.3)
    few = table.filter(pc.not_equal(table["energy_use"], 0.3))
    with pytest.raises(ExerciseError, match="at least 3 values"):
        check_exercise(6, table=few, best=0.2)


def test_check_08_wrong_time() -> None:
    pytest.importorskip("pyfly")
    right = x8_climb_time(60.0)
    assert 0 < right < 30
    with pytest.raises(ExerciseError, match="it is later"):
        check_exercise(8, climb_time=right - 0.5)


def test_check_04_a_wrong_leaf_in_the_lessons_mission(executed_lessons: Path) -> None:
    from pyautonomousagent import load
    from pyautonomousagent.bt import Leaf, Port, register_leaf, success_if

    folder = executed_lessons / "work" / "04" / "shelter"

    class Backwards(Leaf):
        type_name = "Condition_Shelter_Near"
        ports = (Port("distance", float, None, 0.0, "world units"),)

        def evaluate(self, agents, world):  # type: ignore[no-untyped-def]
            return success_if(agents.shelter_distance >= self.distance)  # backwards

    class Branching(Backwards):
        def evaluate(self, agents, world):  # type: ignore[no-untyped-def]
            return 1 if agents.shelter_distance <= self.distance else 2  # `if` on arrays

    for leaf_type, message in ((Backwards, "but your leaf returned"),
                               (Branching, "Your leaf fails when ticked")):  # fmt: skip
        with scoped_registrations():
            scenario = load(str(folder / "scenario.yaml"))  # registers the lesson's mission
            register_leaf(leaf_type)
            with pytest.raises(ExerciseError, match=message):
                check_exercise(4, leaf_type=leaf_type, scenario=scenario)


def test_check_09_names_the_field_left_unset(tmp_path: Path, monkeypatch) -> None:
    from pyautonomousagent import lessons
    from pyautonomousagent.bt import save_tree
    from pyautonomousagent.missions.drones.trees import gathering_tree

    monkeypatch.chdir(tmp_path)
    # Each check flies the expected tree and the hint's trees again (3000 iterations each):
    # a tree flown once is not flown again (a deterministic run, keyed by the whole tree).
    flights: dict[str, list[np.ndarray]] = {}
    fly = lessons._flight

    def flown_once(tree):
        key = repr(tree)
        if key not in flights:
            flights[key] = fly(tree)
        return flights[key]

    monkeypatch.setattr(lessons, "_flight", flown_once)
    for name, tree, message in (
        ("threshold-only.xml", l09_expected_tree(60, 2), "the refuel rate is not 5"),
        ("rate-only.xml", l09_expected_tree(40, 5), "the threshold is not 60"),
        ("unchanged.xml", gathering_tree(), "as with the scenario's own tree"),
        ("other.xml", l09_expected_tree(50, 5), "do not fly as they should"),
    ):
        save_tree(tree, name)
        with pytest.raises(ExerciseError, match=message):
            check_exercise(9, tree_file=name)
    Path("broken.xml").write_text("<root>")
    with pytest.raises(ExerciseError, match="Your file does not load: broken.xml"):
        check_exercise(9, tree_file="broken.xml")
    save_tree(l09_expected_tree(), "early.xml")
    check_exercise(9, tree_file="early.xml")


def test_the_tests_of_the_executed_lessons_form_one_xdist_group(request: pytest.FixtureRequest):
    """Under ``--dist loadgroup`` every test that reads the executed lessons carries the group
    suffix, so that one worker executes the lessons and builds the site (pytest 9.2 silently
    dropped the grouping: two builds of about 4 minutes each)."""
    if not getattr(request.config.option, "loadgroup", False):  # set on xdist's workers
        pytest.skip("grouping applies only under pytest-xdist's --dist loadgroup (make test)")
    readers = [i.nodeid for i in request.session.items if "executed_lessons" in i.fixturenames]
    if not readers:
        pytest.skip("no test that reads the executed lessons was selected")
    assert [n for n in readers if not n.endswith("@lessons")] == []
