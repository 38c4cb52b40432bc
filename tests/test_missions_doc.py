"""docs/missions.md's example, run as a user would: a mission in a folder outside the package
(a Python file, a scenario YAML, a tree XML) run with ``pyaa run <folder>/scenario.yaml`` on
both engines; and the core knows no mission."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.leaf import LEAF_TYPES, leaf_type
from pyautonomousagent.cli import main
from pyautonomousagent.simulation.mission import MISSIONS
from pyautonomousagent.testing import check_engines_agree, check_leaf, scoped_registrations

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "pyautonomousagent"
FILE_BLOCK = re.compile(r"<!-- file: (\S+) -->\n```\w*\n(.*?)```", re.DOTALL)


def write_example(folder: Path) -> Path:
    """The files of docs/missions.md's example, written into ``folder``; the scenario path."""
    text = (ROOT / "docs" / "missions.md").read_text(encoding="utf-8")
    files = {Path(name).name: content for name, content in FILE_BLOCK.findall(text)}
    assert set(files) == {"mission.py", "courier.xml", "scenario.yaml"}
    for name, content in files.items():
        (folder / name).write_text(content, encoding="utf-8")
    return folder / "scenario.yaml"


@pytest.fixture
def example(tmp_path: Path):
    folder = tmp_path / "couriers"
    folder.mkdir()
    with scoped_registrations():
        yield write_example(folder)
    assert "courier" not in MISSIONS and "Action_Deliver_S" not in LEAF_TYPES


def test_the_docs_example_runs_from_its_folder_on_both_engines(example, tmp_path, capsys):
    out = {}
    for engine in ("pytrees", "batched"):
        out[engine] = tmp_path / f"run-{engine}"
        code = main(["run", str(example), "--engine", engine, "--out", str(out[engine]),
                     "--quiet", "--frame-every", "50"])  # fmt: skip
        assert code == 0, capsys.readouterr().err
        gif = (out[engine] / "animation.gif").read_bytes()
        assert gif[:6] == b"GIF89a"
    a = pq.read_table(out["pytrees"] / "states.parquet")
    b = pq.read_table(out["batched"] / "states.parquet")
    assert a.equals(b)
    # its own sensor column and blackboard keys are recorded, with their units and meanings
    for column in ("depot_distance", "goal", "deliveries", "heard"):
        assert a.schema.field(column).metadata[b"description"]
    assert a.schema.field("depot_distance").metadata[b"unit"] == b"world unit"
    # its message type is delivered, handled and recorded
    events = json.loads((out["batched"] / "run.json").read_text())["events"]
    assert events == json.loads((out["pytrees"] / "run.json").read_text())["events"]
    delivered = [e for e in events if e.get("type") == "delivered"]
    assert len(delivered) >= 3
    last = a.slice(a.num_rows - 3).to_pydict()
    total = sum(last["deliveries"])
    assert total == len(delivered)
    # every courier heard every delivery but its own (range 1000 covers the 40 x 40 world)
    assert [h + d for h, d in zip(last["heard"], last["deliveries"], strict=True)] == [total] * 3
    # its parameter and world object come from the scenario; the sensor reads the depots
    distance = np.asarray(a.column("depot_distance"))
    assert distance.min() == 0.0 and distance.max() < 40.0


def test_the_docs_example_with_the_testing_tools(example):
    scenario = load(str(example))
    assert (scenario.mission_type.name, scenario.parameters.cruise_speed) == ("courier", 0.3)
    assert scenario.objects.depots == ((5, 5), (35, 8), (20, 35))
    assert [m.label for m in scenario.create_mission().marks()] == ["D1", "D2", "D3"]
    assert check_engines_agree(scenario=scenario, iterations=150, agents=5) == 150
    for name in ("Condition_At_Depot", "Action_Deliver_S", "Action_Fly_To_Depot_A"):
        check_leaf(leaf_type(name), scenario)
    sim = Simulation.create(scenario.with_overrides(cruise_speed=0.2, iterations=5))
    assert sim.scenario.parameters.cruise_speed == 0.2


def test_cli_shows_and_draws_the_users_mission(example, capsys):
    assert main(["scenarios", str(example)]) == 0
    shown = capsys.readouterr().out
    assert "mission.py" in shown and "pickup_radius = 1.0 world units" in shown
    assert "depots: [[5.0, 5.0], [35.0, 8.0], [20.0, 35.0]]" in shown
    assert main(["tree", str(example)]) == 0
    assert "fly [Action_Fly_To_Depot_A]" in capsys.readouterr().out


def test_a_mission_file_with_errors_is_one_line(tmp_path, capsys):
    folder = tmp_path / "broken"
    folder.mkdir()
    with scoped_registrations():
        scenario = write_example(folder)
        (folder / "mission.py").write_text("x = 1\n")
        assert main(["run", str(scenario), "--no-gif", "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "exactly one Mission subclass" in err
        text = scenario.read_text().replace("mission: mission.py", "mission: nowhere.py")
        scenario.write_text(text)
        assert main(["run", str(scenario), "--no-gif", "--out", str(tmp_path / "out")]) == 2
        assert "nowhere.py does not exist" in capsys.readouterr().err


# --------------------------------------------------------------------------- the core


CORE = ["simulation", "state.py", "datalink.py", "world.py", "recording.py", "render"]
MISSION_NAMES = ("gathering", "patrol", "vacuum", "radiation", "surveillance", "refuel")


def core_files() -> list[Path]:
    files: list[Path] = []
    for part in CORE:
        path = PACKAGE / part
        files.extend(sorted(path.rglob("*.py")) if path.is_dir() else [path])
    return files


def docstrings(tree: ast.AST) -> set[int]:
    """The ids of the docstring nodes of a module, its classes and its functions."""
    found = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            found.add(id(body[0].value))
    return found


@pytest.mark.parametrize("path", core_files(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_the_core_imports_no_mission_and_branches_on_no_name(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = docstrings(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            assert not (node.module or "").startswith("pyautonomousagent.missions"), path
        if isinstance(node, ast.Import):
            assert not any(a.name.startswith("pyautonomousagent.missions") for a in node.names)
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            words = node.value.lower()
            assert not any(name in words for name in MISSION_NAMES), (path, node.value[:60])
