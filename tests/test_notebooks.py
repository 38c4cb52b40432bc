"""The lesson notebooks run from start to end, and their exercises check right and wrong
answers. (The README's Python examples run with every other block of the pages:
``tests/test_docs_blocks.py``.)"""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest

from tests.lesson_runner import LESSONS, SOLUTIONS, errors, execute, lesson_paths, tagged

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = lesson_paths()
#: Most lines one output of a lesson may print: nothing a student must scroll past.
MAX_OUTPUT_LINES = 40


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_lesson_runs_and_its_check_passes(path: Path, executed_lessons: Path) -> None:
    notebook = nbformat.read(executed_lessons / path.name, as_version=4)
    assert not errors(notebook), errors(notebook)
    (check,) = tagged(notebook, "check")
    text = "".join(o.get("text", "") for o in notebook.cells[check].outputs)
    assert "Well done" in text, f"{path.name}: the check cell printed {text!r}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_lesson_prints_nothing_to_scroll_past(path: Path, executed_lessons: Path) -> None:
    notebook = nbformat.read(executed_lessons / path.name, as_version=4)
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            text = output.get("text", "") or output.get("data", {}).get("text/plain", "")
            if output.output_type == "stream":
                assert output.name == "stdout", f"{path.name}: stderr output {text[:300]!r}"
            assert text.count("\n") <= MAX_OUTPUT_LINES, f"{path.name}: {text[:300]!r}..."


def test_the_series_is_complete() -> None:
    names = [p.name for p in NOTEBOOKS]
    assert names == list(LESSONS)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_lesson_is_stored_clean_with_one_exercise_and_check(path: Path) -> None:
    notebook = nbformat.read(path, as_version=4)
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert all(not c.outputs and c.execution_count is None for c in code), "strip the outputs"
    exercise, check = tagged(notebook, "exercise"), tagged(notebook, "check")
    assert len(exercise) == 1 and len(check) == 1 and exercise[0] < check[0]
    assert "check_exercise(" in notebook.cells[check[0]].source
    assert (SOLUTIONS / f"{path.name[:2]}.py").exists()


def test_an_unanswered_exercise_fails_with_a_friendly_message(tmp_path: Path) -> None:
    notebook = nbformat.read(ROOT / "notebooks" / "02_behaviour_trees.ipynb", as_version=4)
    execute(notebook, tmp_path)  # the exercise cell as the student finds it
    (check,) = tagged(notebook, "check")
    (error,) = [o for o in notebook.cells[check].outputs if o.output_type == "error"]
    assert error.ename == "ExerciseError"
    assert error.traceback[0].startswith("\u2718 Not answered yet: set `root_statuses`")
    assert not any("Traceback" in line or "File " in line for line in error.traceback)


def test_the_pytrees_floor_script_ticks_its_tree() -> None:
    import runpy

    module = runpy.run_path(str(ROOT / "scripts" / "pytrees_floor.py"))
    tree = module["patrol_shaped_tree"]()
    tree.tick_once()
    assert tree.status.name == "RUNNING"
    assert [c.status.name for c in tree.children] == ["FAILURE", "FAILURE", "RUNNING"]
