"""The lessons' exercise checks: right answers pass, missing and wrong ones fail with a hint."""

from __future__ import annotations

import pytest

from pyautonomousagent.lessons import (
    CHECKS,
    ExerciseError,
    l02_tree,
    scripted,
    tick_table,
)
from pyautonomousagent.testing import check_exercise


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
    assert "background:#fff3c4" in table._repr_html_()  # RUNNING, coloured
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


def test_every_lesson_has_a_check() -> None:
    assert set(CHECKS) >= {"02", "06"}
    with pytest.raises(ValueError, match="no exercise for lesson 9"):
        check_exercise(9)
