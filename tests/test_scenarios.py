"""Scenario validation (one clear ScenarioError naming the field) and the ``pyaa`` CLI."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyautonomousagent import Scenario, ScenarioError, load
from pyautonomousagent.bt.trees import tree_by_name
from pyautonomousagent.cli import main
from pyautonomousagent.scenarios import names
from pyautonomousagent.simulation.scenario import to_mapping


def base() -> dict:
    return to_mapping(load("gathering"))


def bad(**changes) -> str:
    """The one-line error for the gathering scenario with ``changes`` (world objects go into
    ``world:``; ``parameters={...}`` updates the parameters; KeyError removes a key)."""
    data = base()
    for key, value in changes.items():
        where = data["world"] if key in data["world"] else data
        if key == "parameters":
            data["parameters"].update(value)
        elif value is KeyError:
            del where[key]
        else:
            where[key] = value
    with pytest.raises(ScenarioError) as info:
        Scenario.from_mapping(data, source="my.yaml")
    message = str(info.value)
    assert message.startswith("my.yaml: ")
    assert "\n" not in message
    return message


def test_packaged_scenarios_load():
    gathering, patrol = load("gathering"), load("patrol")
    assert (gathering.agents, gathering.iterations) == (4, 8000)
    assert Path(gathering.tree).name == "gathering.xml" and Path(gathering.tree).is_file()
    assert gathering.objects.refueling_positions == ((20, 65), (20, 55), (20, 45), (20, 35))
    assert gathering.objects.surveillance_positions == ((50, 50), (70, 80), (40, 70), (60, 25))
    assert (gathering.mission, patrol.mission) == ("gathering", "patrol")
    assert (gathering.parameters.low_energy_threshold, gathering.parameters.energy_use) == (
        40,
        0.05,
    )
    assert (patrol.agents, patrol.iterations, Path(patrol.tree).name) == (10, 4000, "patrol.xml")
    assert patrol.objects.patrol_positions == ((70, 80), (70, 20))
    assert patrol.initial_heading == "random"
    assert names()[:2] == ["gathering", "patrol"]


def test_round_trip_through_mapping():
    for name in ("gathering", "patrol"):
        scenario = load(name)
        assert Scenario.from_mapping(to_mapping(scenario), source=name) == scenario


@pytest.mark.parametrize("value", [-3, 0])
def test_agents_must_be_positive(value):
    message = bad(agents=value)
    assert "agents must be a whole number >= 1" in message
    assert repr(value) in message


@pytest.mark.parametrize(
    ("field", "value", "must"),
    [
        ("agents", "four", "agents must be a whole number"),
        ("agents", 2.5, "agents must be a whole number"),
        ("agents", True, "agents must be a whole number"),
        ("iterations", "8000", "iterations must be a whole number"),
        ("iterations", 0, "iterations must be a whole number >= 1"),
        ("frame_every", 0, "frame_every must be a whole number >= 1"),
        ("initial_heading", "north", "initial_heading must be a number"),
        ("name", "", "name must be a non-empty string"),
        ("tree", 3, "tree must be a non-empty string"),
    ],
)
def test_bad_field_value(field, value, must):
    message = bad(**{field: value})
    assert must in message
    assert repr(value) in message


@pytest.mark.parametrize(
    ("key", "value", "must"),
    [
        ("energy_use", "lots", "parameters.energy_use must be a number"),
        ("energy_use", -0.1, "parameters.energy_use must be a number >= 0"),
        ("gathering_iteration", 1.5, "parameters.gathering_iteration must be a whole number"),
        ("gathering_sender", 1, "parameters.gathering_sender must be a non-empty string"),
        ("reference_speed", None, "parameters.reference_speed must be a number"),
    ],
)
def test_bad_parameter_value(key, value, must):
    data = base()
    data["parameters"][key] = value
    with pytest.raises(ScenarioError, match=must):
        Scenario.from_mapping(data, source="my.yaml")


def test_unknown_key_with_did_you_mean():
    data = base()
    data["agent"] = 3
    with pytest.raises(ScenarioError, match=r"unknown key 'agent' \(did you mean 'agents'\?\)"):
        Scenario.from_mapping(data, source="my.yaml")


def test_unknown_parameter_with_did_you_mean():
    data = base()
    data["parameters"]["energy_usage"] = 1
    with pytest.raises(
        ScenarioError,
        match=r"unknown key 'parameters.energy_usage' \(did you mean 'energy_use'\?\)",
    ):
        Scenario.from_mapping(data, source="my.yaml")


def test_unknown_key_without_a_close_match():
    data = base()
    data["zzzzzz"] = 1
    with pytest.raises(ScenarioError, match="unknown key 'zzzzzz'") as info:
        Scenario.from_mapping(data, source="my.yaml")
    assert "did you mean" not in str(info.value)


@pytest.mark.parametrize("key", ["name", "mission", "tree", "agents", "iterations", "world"])
def test_missing_key(key):
    assert f"missing key '{key}'" in bad(**{key: KeyError})


@pytest.mark.parametrize("key", ["refueling_positions", "surveillance_positions"])
def test_missing_world_object(key):
    assert f"missing key 'world.{key}'" in bad(**{key: KeyError})


@pytest.mark.parametrize(
    ("field", "value", "path"),
    [
        ("size", [100], "world.size must be a pair [x, y]"),
        ("size", [100, "wide"], "world.size[1] must be a number"),
        ("size", [100, 0], "world.size must be a positive [width, height]"),
        ("refueling_positions", [[20, 65], [20]], "world.refueling_positions[1] must be a pair"),
        ("refueling_positions", [[20, 65], ["a", 1]], "refueling_positions[1][0] must be a number"),
        ("refueling_positions", [], "world.refueling_positions must be a list of at least 1"),
        ("surveillance_positions", "here", "world.surveillance_positions must be a list"),
        ("refueling_positions", [[20, 65], [120, 5]], "must be inside the world [0, 100]"),
    ],
)
def test_bad_point(field, value, path):
    assert path in bad(**{field: value})


@pytest.mark.parametrize("value", [[[1, 2]], [[1, 2], [3, 4], [5, 6]]])
def test_patrol_needs_exactly_two_positions(value):
    data = to_mapping(load("patrol"))
    data["world"]["patrol_positions"] = value
    with pytest.raises(ScenarioError, match="patrol_positions must be a list of exactly 2"):
        Scenario.from_mapping(data, source="my.yaml")


def test_checks_across_fields():
    assert "gathering_sender must be one of the drones (drone1..drone4)" in bad(
        parameters={"gathering_sender": "drone9"}
    )
    assert "low_energy_threshold must be a number <= 100" in bad(
        parameters={"low_energy_threshold": 150}
    )
    assert "must be a finite number" in bad(parameters={"energy_use": float("nan")})


def test_bad_radiation_source():
    assert "world.radiation_sources[0].range must be a number > 0" in bad(
        radiation_sources=[{"x": 1, "y": 2, "range": 0}]
    )
    assert "radiation_sources[0].active must be true or false" in bad(
        radiation_sources=[{"x": 1, "y": 2, "range": 3, "active": "yes"}]
    )
    assert "missing key 'world.radiation_sources[0].range'" in bad(
        radiation_sources=[{"x": 1, "y": 2}]
    )


def test_not_a_mapping():
    with pytest.raises(ScenarioError, match="the file must be a mapping"):
        Scenario.from_mapping(["a", "b"], source="my.yaml")


def test_bad_yaml_file(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("name: x\nagents: [1, 2\n")
    with pytest.raises(ScenarioError, match="not valid YAML") as info:
        load(str(path))
    assert "broken.yaml" in str(info.value)


def test_yaml_file_with_a_bad_field_names_the_file(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(
        "name: mine\nmission: gathering\ntree: gathering\nagents: -1\niterations: 10\n"
        "world: {size: [10, 10], refueling_positions: [[1, 1]], surveillance_positions: [[5, 5]]}\n"
    )
    with pytest.raises(ScenarioError, match=r"mine\.yaml: agents must be a whole number >= 1"):
        load(str(path))


def test_own_yaml_file_loads(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(
        "name: mine\nmission: patrol\ntree: patrol\nagents: 2\niterations: 10\n"
        "world: {size: [10, 10], refueling_positions: [[1, 1]],\n"
        "        patrol_positions: [[5, 5], [5, 1]]}\n"
        "parameters: {energy_use: 0.5}\n"
    )
    scenario = load(str(path))
    assert (scenario.name, scenario.agents, scenario.parameters.energy_use) == ("mine", 2, 0.5)
    assert scenario.objects.radiation_sources == ()


def test_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load(str(tmp_path / "nope.yaml"))


def test_unknown_scenario_name():
    with pytest.raises(
        ScenarioError,
        match=r"unknown scenario 'gatherin'; did you mean 'gathering'( or 'gathering-3d')?\?",
    ):
        load("gatherin")
    with pytest.raises(ScenarioError, match="known: gathering, patrol"):
        load("nothing-like-it")


def test_with_overrides():
    scenario = load("gathering")
    changed = scenario.with_overrides(agents=2, iterations=50, energy_use=1.5, frame_every=None)
    assert (changed.agents, changed.iterations, changed.parameters.energy_use) == (2, 50, 1.5)
    assert changed.frame_every == scenario.frame_every  # None changes nothing
    assert changed.parameters.refuel_rate == scenario.parameters.refuel_rate
    assert (scenario.agents, scenario.parameters.energy_use) == (4, 0.05)  # the original is kept
    assert scenario.with_overrides() == scenario


def test_with_overrides_validates():
    scenario = load("gathering")
    with pytest.raises(ScenarioError, match="agents must be a whole number >= 1"):
        scenario.with_overrides(agents=-1)
    with pytest.raises(ScenarioError, match="parameters.energy_use must be a number"):
        scenario.with_overrides(energy_use="x")
    with pytest.raises(ScenarioError, match="unknown key 'foo'"):
        scenario.with_overrides(foo=1)


# --------------------------------------------------------------------------- the CLI


def cli(argv, capsys) -> tuple[int, str, str]:
    """Run ``pyaa argv``; (exit code, stdout, stderr). argparse usage errors exit via SystemExit."""
    try:
        code = main(argv)
    except SystemExit as stop:
        code = stop.code
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "gathering", "--agents", "-3"], "agents must be a whole number >= 1"),
        (["run", "gathering", "--agents", "abc"], "--agents"),
        (["run", "gathering", "--iterations", "0"], "iterations must be a whole number >= 1"),
        (["run", "gathering", "--set", "foo=1"], "unknown parameter 'foo'"),
        (["run", "gathering", "--set", "energy_use=lots"], "energy_use must be a number"),
        (["run", "gathering", "--set", "novalue"], "KEY=VALUE"),
        (["run", "gathering", "--record-every", "0"], "--record-every"),
        (["run", "gatherin"], "did you mean 'gathering'"),
        (["run", "no_such_scenario"], "unknown scenario 'no_such_scenario'"),
        (["tree", "gatherin"], "unknown scenario"),
    ],
)
def test_cli_bad_input_one_line_exit_2(argv, needle, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = cli([*argv, "--no-gif"] if argv[0] == "run" else argv, capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert err.startswith("pyaa")
    assert "Traceback" not in err
    assert needle in err
    assert out == ""
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_cli_scenarios(capsys):
    code, out, err = cli(["scenarios"], capsys)
    assert (code, err) == (0, "")
    lines = out.splitlines()
    assert len(lines) == len(names())
    assert lines[0].startswith("gathering") and "4 agents" in lines[0] and "8000" in lines[0]
    assert lines[1].startswith("patrol") and "10 agents" in lines[1] and "4000" in lines[1]


def test_cli_tree_gathering_uses_the_paper_symbols(capsys):
    code, out, err = cli(["tree", "gathering"], capsys)
    assert (code, err) == (0, "")
    lines = out.splitlines()
    assert lines[0] == "R→ reactive_sequence_root"
    for symbol in ("R→ ", "R? ", "→ ", "? ", "≠ "):
        assert symbol in out, symbol
    assert "R? reactive_fallback_behaviours" in out
    assert "→ sequence_gathering" in out
    assert "? fallback_refueling" in out
    assert "≠ inverter_destination_reached" in out
    assert "condition_gathering_moment [Condition_Gathering_Moment]" in out
    assert out.count("Action_Navigate_To_Destination_A]") == 2
    assert len(lines) == len(list(tree_by_name("gathering").walk()))  # a line per node


def test_cli_tree_patrol_py_trees_style(capsys):
    code, out, err = cli(["tree", "patrol", "--style", "py_trees"], capsys)
    assert (code, err) == (0, "")
    assert "reactive_fallback_root" in out
    assert "action_set_destination_equal_to_other_surveillance_s" in out
