"""Every notebook and the README's Python examples run from start to end."""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from pyautonomousagent.testing import scoped_registrations

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path: Path, tmp_path: Path) -> None:
    notebook = nbformat.read(path, as_version=4)
    client = NotebookClient(
        notebook,
        timeout=300,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()
    errors = [o for c in notebook.cells for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors


def test_there_is_a_notebook() -> None:
    assert NOTEBOOKS, "notebooks/ should hold at least the gathering notebook"


def readme_python_blocks() -> list[str]:
    text = (ROOT / "README.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_readme_examples_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = readme_python_blocks()
    assert len(blocks) >= 2
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    with scoped_registrations():  # the README registers a hand-written leaf
        for block in blocks:
            exec(compile(block, "README.md", "exec"), namespace)  # noqa: S102
    assert namespace["table"].num_rows == 4 * 8001  # type: ignore[attr-defined]


def test_the_pytrees_floor_script_ticks_its_tree() -> None:
    import runpy

    module = runpy.run_path(str(ROOT / "scripts" / "pytrees_floor.py"))
    tree = module["patrol_shaped_tree"]()
    tree.tick_once()
    assert tree.status.name == "RUNNING"
    assert [c.status.name for c in tree.children] == ["FAILURE", "FAILURE", "RUNNING"]
