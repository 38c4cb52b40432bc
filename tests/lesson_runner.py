"""Execute the lesson notebooks top to bottom, each in a fresh kernel (nbclient).

The cell tagged ``exercise`` in ``notebooks/NN_*.ipynb`` is replaced by the reference
solution ``tests/lesson_solutions/NN.py`` (kept out of the notebooks), so the lesson's check
cell runs against a right answer. Each lesson runs in its own working folder, so files it
writes (runs, pictures) stay out of the repository.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
SOLUTIONS = Path(__file__).resolve().parent / "lesson_solutions"
#: The series, in order (the docs site links these names).
LESSONS = (
    "01_one_drone.ipynb",
    "02_behaviour_trees.ipynb",
    "03_blackboard_and_datalink.ipynb",
    "04_your_own_mission.ipynb",
    "05_tree_files.ipynb",
    "06_experiments.ipynb",
    "07_swarms_at_scale.ipynb",
    "08_skywalker_x8.ipynb",
    "09_blocks_studio.ipynb",
)
#: Seconds one cell may take before the lesson fails.
CELL_TIMEOUT = 180


def lesson_paths() -> list[Path]:
    """The lesson notebooks, in order: ``notebooks/NN_*.ipynb``."""
    return sorted(p for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))


def tagged(notebook: nbformat.NotebookNode, tag: str) -> list[int]:
    """Indexes of the cells carrying ``tag`` in their metadata."""
    return [i for i, c in enumerate(notebook.cells) if tag in c.get("metadata", {}).get("tags", [])]


def with_solution(notebook: nbformat.NotebookNode, number: str) -> nbformat.NotebookNode:
    """The notebook with its ``exercise`` cell's source replaced by the reference solution
    (unchanged when the lesson has neither an exercise cell nor a solution)."""
    cells = tagged(notebook, "exercise")
    if not cells and not (SOLUTIONS / f"{number}.py").exists():
        return notebook
    if len(cells) != 1:
        raise ValueError(
            f"lesson {number} should have one cell tagged 'exercise', has {len(cells)}"
        )
    notebook.cells[cells[0]].source = (SOLUTIONS / f"{number}.py").read_text()
    return notebook


def execute(notebook: nbformat.NotebookNode, workdir: Path) -> nbformat.NotebookNode:
    """Run every cell of ``notebook`` in a fresh kernel started in ``workdir``; stop at the
    first cell that raises (its error is in that cell's outputs)."""
    workdir.mkdir(parents=True, exist_ok=True)
    client = NotebookClient(
        notebook,
        timeout=CELL_TIMEOUT,
        kernel_name="python3",
        resources={"metadata": {"path": str(workdir)}},
    )
    with contextlib.suppress(CellExecutionError):  # the error stays in the cell's outputs
        client.execute()
    return notebook


def execute_lessons(dest: Path, solutions: bool = True) -> list[Path]:
    """Execute every lesson (with its reference solution unless ``solutions`` is False) and
    write it, outputs included, under ``dest`` with its own name; return the written paths.
    Working files go to ``dest/work/NN``."""
    dest.mkdir(parents=True, exist_ok=True)
    written = []
    for path in lesson_paths():
        number = path.name[:2]
        notebook = nbformat.read(path, as_version=4)
        if solutions:
            notebook = with_solution(notebook, number)
        execute(notebook, dest / "work" / number)
        nbformat.write(notebook, dest / path.name)
        written.append(dest / path.name)
    return written


def errors(notebook: nbformat.NotebookNode) -> list[str]:
    """Each error output as ``ename: evalue`` with the first line of its cell."""
    found = []
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            if output.output_type == "error":
                first = cell.source.splitlines()[0] if cell.source else ""
                found.append(f"{output.ename}: {output.evalue} (cell {first!r})")
    return found
