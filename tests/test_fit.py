"""A tree is checked against its scenario's mission before a run (simulation.fit), and
``pyaa leaves`` lists the leaves that fit."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pyautonomousagent.bt import SUCCESS, Leaf
from pyautonomousagent.bt.leaf import LEAF_TYPES, register_leaf
from pyautonomousagent.bt.spec import TreeError, fallback, leaf, sequence
from pyautonomousagent.cli import main
from pyautonomousagent.scenarios import load, names
from pyautonomousagent.simulation import Simulation
from pyautonomousagent.simulation.fit import (
    Probe,
    check_tree,
    fitting_leaves,
    is_general,
    leaf_missions,
    misfit,
)
from pyautonomousagent.simulation.run import scenario_tree

PATROL_XML = Path(__file__).parents[1] / "src/pyautonomousagent/missions/patrol/patrol.xml"


def _patrol_with(tmp_path: Path, old: str, new: str) -> Path:
    """patrol.xml with leaf type ``old`` replaced by ``new``."""
    text = PATROL_XML.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "tree.xml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


@pytest.mark.parametrize("name", names())
def test_every_scenario_s_own_tree_fits(name: str) -> None:
    scenario = load(name)
    check_tree(scenario_tree(scenario), scenario)


def test_a_vacuum_leaf_in_a_patrol_tree_is_refused_before_the_run() -> None:
    tree = sequence(
        "root", leaf("Condition_Low_Energy_Level", "low"), leaf("Action_Vacuum_S", "brush")
    )
    scenario = load("patrol").with_overrides(agents=3, iterations=5)
    with pytest.raises(TreeError) as caught:
        Simulation.create(scenario, tree=tree, engine="batched")
    message = str(caught.value)
    assert "leaf 'brush' (Action_Vacuum_S)" in message
    assert "state column 'vacuuming'" in message
    assert "a leaf of mission vacuum" in message
    assert "leaves that fit: Action_" in message and "pyaa leaves patrol" in message
    assert "\n" not in message


def test_a_port_default_the_scenario_lacks_names_the_port_and_the_parameter() -> None:
    tree = fallback("root", leaf("Action_Avoid_Obstacle_S", "avoid"), leaf("Action_Hover_S"))
    with pytest.raises(TreeError, match=r"port 'min_angle' .* parameter 'avoid_min_angle'"):
        check_tree(tree, load("patrol"))


def test_a_blackboard_key_the_mission_lacks_is_refused() -> None:
    tree = fallback(
        "root",
        leaf("Action_Avoid_Obstacle_S", "avoid", min_angle=10.0, max_angle=20.0, step=5.0),
        leaf("Action_Hover_S"),
    )
    with pytest.raises(TreeError, match=r"blackboard key\(s\) 'cruise_heading'.*vacuum"):
        check_tree(tree, load("patrol"))


class _ReadsBeacons(Leaf):
    """Reads a world object no mission has."""

    type_name = "Test_Reads_Beacons"

    def evaluate(self, agents: Any, world: Any) -> Any:
        return SUCCESS if world.objects.beacons else SUCCESS


class _Buggy(Leaf):
    """Fails on its own, whatever the mission: not a misfit."""

    type_name = "Test_Buggy"

    def evaluate(self, agents: Any, world: Any) -> Any:
        return 1 // 0


def test_a_world_object_the_mission_lacks_is_refused_and_fits_no_mission() -> None:
    with LEAF_TYPES.scoped():
        register_leaf(_ReadsBeacons)
        with pytest.raises(TreeError, match=r"world object 'beacons'.*leaves that fit"):
            check_tree(sequence("root", leaf("Test_Reads_Beacons", "b")), load("gathering"))
        assert leaf_missions("Test_Reads_Beacons") == []


def test_a_leaf_s_own_error_is_left_to_the_run() -> None:
    with LEAF_TYPES.scoped():
        register_leaf(_Buggy)
        check_tree(sequence("root", leaf("Test_Buggy", "b")), load("gathering"))


def test_the_probe_leaves_the_run_untouched() -> None:
    scenario = load("gathering").with_overrides(iterations=20)
    a = Simulation.create(scenario, engine="batched").run(progress=False)
    b = Simulation.create(scenario, engine="batched").run(progress=False)
    assert a.table().equals(b.table())
    assert Probe.of(scenario).swarm.size == 2


def test_fitting_leaves_and_their_missions() -> None:
    vacuum = {cls.type_name for cls in fitting_leaves(load("vacuum")) if not is_general(cls)}
    assert {"Action_Vacuum_S", "Condition_Collision", "Action_Navigate_S"} <= vacuum
    assert "Action_Refuel_A" not in vacuum
    assert leaf_missions("Action_Vacuum_S") == ["vacuum"]
    assert "vacuum" not in leaf_missions("Condition_Low_Energy_Level")
    script = leaf("Script", "s", code="a := 1")
    assert "blackboard key(s) 'a'" in (misfit(script, Probe.of(load("gathering"))) or "")
    assert misfit(script, Probe.of(load("gathering"), {"a": np.int64})) is None
    check_tree(sequence("root", script, leaf("Action_Hover_S")), load("gathering"))


def test_pyaa_run_refuses_a_leaf_of_another_mission_in_one_line(tmp_path, capsys) -> None:
    tree = _patrol_with(tmp_path, "Action_Refuel_A", "Action_Vacuum_S")
    out = tmp_path / "out"
    argv = ["run", "patrol", "--tree", str(tree), "--iterations", "5", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "(Action_Vacuum_S) does not fit scenario 'patrol'" in err
    assert "a leaf of mission vacuum" in err
    assert not out.exists()


def test_pyaa_leaves_lists_the_leaves_with_docs_and_ports(capsys) -> None:
    assert main(["leaves", "vacuum"]) == 0
    text = capsys.readouterr().out
    assert "Action_Vacuum_S: Switch the brush on" in text
    assert "min_angle (a number >= 0) = avoid_min_angle (90.0); degrees" in text
    assert "Action_Refuel_A" not in text
    assert "general leaves, for any mission" in text and "Script" in text
    assert main(["leaves", "patrol"]) == 0
    text = capsys.readouterr().out
    assert "Action_Refuel_A" in text and "Action_Vacuum_S" not in text


def test_pyaa_leaves_of_an_unknown_scenario_is_one_line(capsys) -> None:
    assert main(["leaves", "no-such-scenario"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown scenario" in err


def test_pyaa_leaves_of_a_user_s_mission_lists_its_own_leaves(tmp_path, capsys) -> None:
    from pyautonomousagent.testing import scoped_registrations
    from tests.test_missions_doc import write_example

    with scoped_registrations():
        scenario = write_example(tmp_path)
        assert main(["leaves", str(scenario)]) == 0
        text = capsys.readouterr().out
        assert "Action_Fly_To_Depot_A: " in text and "Action_Deliver_S: " in text
        assert "Action_Vacuum_S" not in text
        assert leaf_missions("Action_Deliver_S") == []  # no registered scenario of it
