"""Bad 3-D inputs (issue 18): an altitude below the ground, a climb rate of NaN and the like
each give exit code 2 and one line naming the file and the key, no traceback."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from pyautonomousagent.scenarios import SCENARIOS
from tests.test_bad_inputs import refused

NAN = float("nan")


def _scenario(name: str) -> dict[str, Any]:
    path = SCENARIOS.get(name)
    data = yaml.safe_load(path.read_text())
    data["tree"] = str(path.parent / data["tree"])
    return data


def _write(tmp_path: Path, data: dict[str, Any]) -> str:
    path = tmp_path / "bad-3d.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def _set(data: dict[str, Any], dotted: str, value: Any) -> dict[str, Any]:
    *parents, last = dotted.split(".")
    target = data
    for key in parents:
        target = target[key]
    target[last] = value
    return data


CASES = [
    ("gathering-3d", "world.surveillance_positions", [[50, 50, -5]],
     "world.surveillance_positions[0][2] must be an altitude >= 0"),
    ("patrol-3d", "world.patrol_positions", [[70, 80, 30], [70, 20, -0.5]],
     "world.patrol_positions[1][2] must be an altitude >= 0"),
    ("patrol-3d", "world.patrol_positions", [[70, 80, 30], [70, 20, 60]],
     "world.patrol_positions[1][2] must be an altitude <= max_altitude (50)"),
    ("patrol-3d", "world.patrol_positions", [[70, 80], [70, 20]],
     "world.patrol_positions[0] must be a point [x, y, z]"),
    ("gathering-3d", "world.surveillance_positions", [[50, 50, NAN]],
     "world.surveillance_positions[0][2] must be a finite number"),
    ("patrol-3d", "parameters.max_climb_rate", NAN, "parameters.max_climb_rate must be a finite"),
    ("patrol-3d", "parameters.climb_step", NAN, "parameters.climb_step must be a finite"),
    ("patrol-3d", "parameters.max_climb_rate", -0.1, "max_climb_rate must be a number >= 0"),
    ("patrol-3d", "parameters.max_altitude", -1, "parameters.max_altitude must be a number >= 0"),
    ("gathering-3d", "parameters.climb_energy_use", NAN, "parameters.climb_energy_use must be"),
]  # fmt: skip


@pytest.mark.parametrize(("name", "key", "value", "message"), CASES)
def test_bad_3d_field_is_one_line_naming_file_and_key(tmp_path, capsys, name, key, value, message):
    path = _write(tmp_path, _set(_scenario(name), key, value))
    line = refused(["run", path, "--iterations", "2", "--out", str(tmp_path / "out")], capsys)
    assert "bad-3d.yaml" in line and message in line, line


def test_a_3d_mission_refuses_the_2d_drone(tmp_path, capsys):
    data = _scenario("patrol-3d")
    data["model"] = "drone2d"
    for key in ("max_climb_rate", "climb_step", "max_altitude"):
        del data["parameters"][key]
    line = refused(["run", _write(tmp_path, data), "--out", str(tmp_path / "out")], capsys)
    assert "bad-3d.yaml" in line and "model must be drone3d" in line, line


def test_the_3d_drone_refuses_a_mission_without_altitude(tmp_path, capsys):
    data = _scenario("patrol")
    data["model"] = "drone3d"
    line = refused(["run", _write(tmp_path, data), "--out", str(tmp_path / "out")], capsys)
    assert "model drone3d moves the state columns z, climb_rate, requested_altitude" in line


def test_a_requested_altitude_below_ground_in_a_tree_file(tmp_path, capsys):
    tree = tmp_path / "low.xml"
    tree.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="Low"><BehaviorTree ID="Low">'
        '<Action_Request_Altitude_S name="down" altitude="-3"/></BehaviorTree></root>'
    )
    argv = ["run", "patrol-3d", "--tree", str(tree), "--out", str(tmp_path / "out")]
    line = refused(argv, capsys)
    assert "low.xml" in line and "altitude" in line and "-3" in line, line
