"""Tree files: round trips (Python -> XML/YAML -> Python), Groot2-style files, SubTrees,
pictures and the ``pyaa tree`` / ``pyaa run --tree`` commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.build import build
from pyautonomousagent.bt.document import TreeFileError
from pyautonomousagent.bt.draw import _levels, layout, to_dot
from pyautonomousagent.bt.files import (
    from_text_format,
    load_tree,
    parse_document,
    read_document,
    save_tree,
    to_text_format,
)
from pyautonomousagent.bt.leaf import LEAF_TYPES
from pyautonomousagent.bt.spec import Node, leaf, sequence
from pyautonomousagent.bt.vocabulary import BTCPP_LEAVES
from pyautonomousagent.cli import main
from pyautonomousagent.missions.drones.trees import gathering_tree, patrol_tree

from .strategies import trees

ROOT = Path(__file__).parent.parent
GROOT2 = ROOT / "examples" / "gathering_groot2.xml"
REFUEL_EARLY = ROOT / "examples" / "refuel_early.yaml"
MISSIONS = ROOT / "src" / "pyautonomousagent" / "missions"


def packaged(file: str) -> Path:
    """A packaged scenario or tree file: ``gathering.xml`` is in ``missions/gathering/``."""
    return MISSIONS / file.split(".")[0].removeprefix("x8-") / file


BUILDERS = {"gathering": gathering_tree, "patrol": patrol_tree}
FORMATS = ["xml", "yaml"]


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("name", list(BUILDERS))
def test_scenario_trees_round_trip(name: str, fmt: str):
    tree = BUILDERS[name]()
    assert from_text_format(to_text_format(tree, fmt), fmt) == tree


@pytest.mark.parametrize("name", list(BUILDERS))
def test_packaged_tree_files_are_the_paper_trees(name: str):
    assert load_tree(packaged(f"{name}.xml")) == BUILDERS[name]()
    assert load(name).tree == str(packaged(f"{name}.xml"))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(3, 2))
def test_random_trees_round_trip(tree: Node):
    for fmt in FORMATS:
        assert from_text_format(to_text_format(tree, fmt), fmt) == tree, fmt


def test_ports_round_trip_with_their_values():
    tree = sequence("s", leaf("Condition_Low_Energy_Level", threshold=60), leaf("Action_Refuel_A"))
    for fmt in FORMATS:
        back = from_text_format(to_text_format(tree, fmt), fmt)
        assert back.children[0].params == {"threshold": 60.0}


def test_groot2_style_file_gives_the_gathering_data(gathering_run):
    tree = load_tree(GROOT2)
    assert [n.type for n in tree.walk()] == [n.type for n in gathering_tree().walk()]
    sim = Simulation.create(load("gathering"), seed=0, engine="batched", tree=tree)
    sim.run(progress=False)
    assert sim.events == gathering_run.events
    for key, expected in gathering_run.recorder.columns.items():
        assert np.array_equal(sim.recorder.columns[key], expected), key


def test_groot2_file_round_trips_with_its_subtrees():
    document = read_document(GROOT2)
    assert list(document.trees) == ["Gathering", "GoRefuel"]
    assert document.subtree_ports == {"GoRefuel": {"threshold": "40"}}
    for fmt in FORMATS:
        again = parse_document(to_text_format(document, fmt), fmt)
        assert list(again.trees) == list(document.trees)
        assert again.trees["Gathering"].children[1].children[1].subtree == "GoRefuel"
        assert build(again) == build(document)
        text = to_text_format(again, "xml")  # a fixed point after one conversion
        assert to_text_format(parse_document(text, "xml"), "xml") == text


def subtree_file(ref: str, inner: str, model: str = "") -> str:
    return f"""<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><Sequence name="s">{ref}</Sequence></BehaviorTree>
  <BehaviorTree ID="Low"><Condition_Low_Energy_Level {inner}/></BehaviorTree>
  <TreeNodesModel>{model}</TreeNodesModel>
</root>"""


@pytest.mark.parametrize(
    ("ref", "inner", "model", "threshold"),
    [
        ('<SubTree ID="Low" threshold="60"/>', 'threshold="{threshold}"', "", 60.0),
        ('<SubTree ID="Low" level="55"/>', 'threshold="{level}"', "", 55.0),
        (
            '<SubTree ID="Low"/>',
            'threshold="{t}"',
            '<SubTree ID="Low"><input_port name="t" default="30"/></SubTree>',
            30.0,
        ),  # fmt: skip
        ('<SubTree ID="Low" threshold="70"/>', "", "", None),  # an unused port
    ],
)
def test_subtree_ports_are_filled_in_at_load(ref, inner, model, threshold):
    tree = from_text_format(subtree_file(ref, inner, model), "xml")
    low = tree.children[0]
    assert (low.type, low.name) == ("Condition_Low_Energy_Level", "low/condition_low_energy_level")
    assert low.params.get("threshold") == threshold


def test_autoremap_reaches_through_nested_subtrees():
    text = """<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><SubTree ID="Mid" name="m" t="45"/></BehaviorTree>
  <BehaviorTree ID="Mid"><SubTree ID="Low" name="l" _autoremap="true"/></BehaviorTree>
  <BehaviorTree ID="Low"><Condition_Low_Energy_Level threshold="{t}"/></BehaviorTree>
</root>"""
    tree = from_text_format(text, "xml")
    assert (tree.name, tree.params) == ("m/l/condition_low_energy_level", {"threshold": 45.0})


def test_unnamed_nodes_get_numbered_names():
    text = """tree:
  type: Sequence
  children:
    - {type: Action_Refuel_A}
    - {type: Action_Refuel_A, name: action_refuel_a_2}
    - {type: Action_Refuel_A}
"""
    tree = from_text_format(text, "yaml")
    assert [c.name for c in tree.children] == [
        "action_refuel_a",
        "action_refuel_a_2",
        "action_refuel_a_3",
    ]
    assert tree.name == "sequence"


def test_the_same_subtree_twice_gets_two_prefixes():
    text = """<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><Sequence><SubTree ID="R"/><SubTree ID="R"/></Sequence></BehaviorTree>
  <BehaviorTree ID="R"><Action_Refuel_A name="go"/></BehaviorTree>
</root>"""
    tree = from_text_format(text, "xml")
    assert [c.name for c in tree.children] == ["r/go", "r_2/go"]


def test_hand_written_yaml_example_runs_on_both_engines():
    tree = load_tree(REFUEL_EARLY)
    assert tree.children[0].children[0].params == {"threshold": 60.0}
    scenario = load("patrol").with_overrides(agents=3, iterations=400)
    runs = [Simulation.create(scenario, engine=e, tree=tree).run(progress=False) for e in
            ("pytrees", "batched")]  # fmt: skip
    for key, column in runs[0].recorder.columns.items():
        assert np.array_equal(runs[1].recorder.columns[key], column), key


def test_xml_file_declares_the_leaf_library_for_groot2():
    text = to_text_format(gathering_tree(), "xml")
    for type_name, cls in LEAF_TYPES.items():
        if type_name == "Scripted" or type_name in BTCPP_LEAVES:  # BT.CPP knows its own
            assert f'ID="{type_name}"' not in text
            continue
        assert f'ID="{type_name}"' in text
        for port in cls.ports:
            assert f'<input_port name="{port.name}"' in text
    assert '<Condition ID="Condition_Low_Energy_Level">' in text


def test_a_scenarios_xml_declares_only_the_leaves_that_fit_it(tmp_path, capsys):
    """Written for patrol, Groot2's palette holds patrol's leaves, not vacuum's or the X8's;
    the file still runs (every leaf it uses is declared)."""
    from pyautonomousagent.simulation.fit import fitting_leaves

    xml = tmp_path / "patrol.xml"
    assert cli(["tree", "patrol", "--format", "xml", "--out", str(xml)], capsys)[0] == 0
    text = xml.read_text()
    fitting = fitting_leaves(load("patrol"))
    for type_name, cls in LEAF_TYPES.items():
        if type_name == "Scripted" or type_name in BTCPP_LEAVES:
            continue
        assert (f'ID="{type_name}"' in text) == (cls in fitting), type_name
    assert 'ID="Action_Vacuum_S"' not in text and 'ID="Action_Refuel_A"' in text
    assert "leaves for this scenario" in text
    assert load_tree(xml) == patrol_tree()
    out = tmp_path / "run"
    assert main(["run", "patrol", "--tree", str(xml), "--agents", "2", "--iterations", "5",
                 "--no-gif", "--quiet", "--out", str(out)]) == 0  # fmt: skip


def test_py_trees_only_nodes_are_declared_and_read_back():
    tree = Node("PyTreesRepeat", "r", (leaf("Action_Refuel_A"),), {"num_success": 2})
    text = to_text_format(tree, "xml")
    assert '<PyTreesRepeat name="r" num_success="2">' in text
    assert '<Decorator ID="PyTreesRepeat">' in text
    assert from_text_format(text, "xml") == tree


def test_save_tree_picks_the_format_from_the_ending(tmp_path):
    for name in ("t.xml", "t.yaml", "t.yml"):
        assert load_tree(save_tree(gathering_tree(), tmp_path / name)) == gathering_tree()
    with pytest.raises(TreeFileError, match=r"t\.txt: a tree file must end in \.xml"):
        save_tree(gathering_tree(), tmp_path / "t.txt")


def test_layout_keeps_boxes_apart_and_parents_above_children():
    root, width, height = layout(gathering_tree())
    boxes = [b for b, _ in _levels(root, 0)]
    assert len(boxes) == len(list(gathering_tree().walk())) == 18
    for b in boxes:
        assert b.x - b.width / 2 > 0 and b.x + b.width / 2 < width and b.y + b.height < height
        for child in b.children:
            assert child.y > b.y + b.height
    by_row: dict[float, list] = {}
    for b in boxes:
        by_row.setdefault(b.y, []).append(b)
    for row in by_row.values():
        row.sort(key=lambda b: b.x)
        for left, right in zip(row, row[1:], strict=False):
            assert left.x + left.width / 2 < right.x - right.width / 2


def test_dot_has_a_node_per_tree_node_and_an_edge_per_child():
    dot = to_dot(gathering_tree(), "gathering")
    assert dot.startswith('digraph "gathering" {') and dot.rstrip().endswith("}")
    assert dot.count("[label=") == 18 and dot.count(" -> ") == 17
    assert 'label="R→\\nreactive_sequence_root"' in dot


def cli(args: list[str], capsys) -> tuple[int, str, str]:
    code = main(args)
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_converts_between_formats(tmp_path, capsys):
    xml, yaml_file = tmp_path / "g.xml", tmp_path / "g.yaml"
    assert cli(["tree", "gathering", "--format", "xml", "--out", str(xml)], capsys)[0] == 0
    assert cli(["tree", str(xml), "--format", "yaml", "--out", str(yaml_file)], capsys)[0] == 0
    assert load_tree(yaml_file) == gathering_tree()
    _, text_from_file, _ = cli(["tree", str(yaml_file)], capsys)
    _, text_from_scenario, _ = cli(["tree", "gathering"], capsys)
    assert text_from_file == text_from_scenario and text_from_file.startswith("R→ ")


@pytest.mark.parametrize("fmt", ["png", "svg"])
def test_cli_draws_pictures(fmt: str, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, _ = cli(["tree", "gathering", "--format", fmt], capsys)
    path = tmp_path / f"gathering.{fmt}"
    assert (code, out) == (0, f"wrote gathering.{fmt}\n")
    data = path.read_bytes()
    assert data.startswith(b"\x89PNG") if fmt == "png" else b"<svg" in data[:2000]
    assert len(data) > 20_000


def test_cli_prints_dot_and_reads_groot2_files(capsys):
    code, out, _ = cli(["tree", str(GROOT2), "--format", "dot"], capsys)
    assert code == 0 and out.startswith('digraph "gathering_groot2"')
    code, out, _ = cli(["tree", str(GROOT2), "--style", "py_trees"], capsys)
    assert code == 0 and "refuel/low_energy" in out


def test_cli_reads_a_scenario_yaml_that_names_a_tree_file(tmp_path, capsys):
    save_tree(patrol_tree(), tmp_path / "my_tree.yaml")
    scenario = (packaged("patrol.yaml")).read_text().replace("patrol.xml", "my_tree.yaml")
    (tmp_path / "mine.yaml").write_text(scenario)
    code, out, _ = cli(["tree", str(tmp_path / "mine.yaml")], capsys)
    assert code == 0 and out.startswith("R? reactive_fallback_root")
    assert load(str(tmp_path / "mine.yaml")).tree == str(tmp_path / "my_tree.yaml")


def test_cli_run_with_a_tree_file(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["run", "patrol", "--tree", str(REFUEL_EARLY), "--iterations", "50", "--agents", "2"]
    assert main([*args, "--no-gif", "--quiet", "--out", str(out)]) == 0
    summary = json.loads((out / "run.json").read_text())
    assert summary["scenario"]["tree"] == str(REFUEL_EARLY)
    code, _, err = cli(["run", "patrol", "--tree", "tree.txt", "--quiet"], capsys)
    assert code == 2 and "a tree file must end in .xml, .yaml or .yml" in err


def test_cli_run_with_a_built_in_tree_name(tmp_path, capsys):
    """``--tree patrol`` names a built-in tree, as a scenario's ``tree: patrol`` does (the
    README flies the X8 through it)."""
    out = tmp_path / "run"
    args = ["run", "patrol", "--tree", "patrol", "--iterations", "20", "--agents", "2"]
    assert main([*args, "--no-gif", "--quiet", "--out", str(out)]) == 0
    summary = json.loads((out / "run.json").read_text())
    assert summary["scenario"]["tree"] == "patrol"
    code, _, err = cli(["run", "patrol", "--tree", "patrl", "--quiet"], capsys)
    assert code == 2 and "patrl" in err and "patrol" in err and ".xml" in err


def test_a_copied_scenario_finds_the_packaged_tree_file(tmp_path):
    (tmp_path / "copy.yaml").write_text((packaged("gathering.yaml")).read_text())
    assert load(str(tmp_path / "copy.yaml")).tree == str(packaged("gathering.xml"))
    (tmp_path / "gathering.xml").write_text((packaged("patrol.xml")).read_text())
    assert load(str(tmp_path / "copy.yaml")).tree == str(tmp_path / "gathering.xml")
