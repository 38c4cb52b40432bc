"""A corpus of bad inputs: every one gives exit code 2 (or a clear exception in Python) with
one line naming the file, line or field, no traceback, and an answer within seconds.

Scenario files, tree files and command lines run in-process through ``cli.main``; the
tiny-file bombs (aliases, SubTrees, deep nesting, huge files) are made here, not stored.
The deadline is generous (a hang guard, not a timing assertion).
"""

from __future__ import annotations

import contextlib
import dataclasses
import signal
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import yaml

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.document import TreeFileError
from pyautonomousagent.bt.files import from_text_format, load_tree
from pyautonomousagent.cli import main
from pyautonomousagent.inputs import InputError
from pyautonomousagent.scenarios import SCENARIOS
from pyautonomousagent.simulation import ScenarioError

DEADLINE_S = 30
GATHERING = SCENARIOS.get("gathering")
BASE = yaml.safe_load(GATHERING.read_text())
BASE["tree"] = str(GATHERING.parent / "gathering.xml")


class HungError(Exception):
    pass


@contextlib.contextmanager
def deadline(seconds: int = DEADLINE_S) -> Iterator[None]:
    """Fail (rather than hang) if the block takes more than ``seconds``."""

    def stop(*_: Any) -> None:
        raise HungError(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``pyaa argv``; assert exit code 2 and one line on stderr; return that line."""
    with deadline():
        code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, f"exit {code}: {out[-300:]} {err[-300:]}"
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err[:2000]
    assert lines[0].startswith("pyaa"), lines[0]
    assert len(lines[0]) <= 700, lines[0][:300]
    return lines[0]


# ----------------------------------------------------------------------- scenario files


def mutated(path: str, value: Any) -> dict[str, Any]:
    """The gathering scenario with the field at dotted ``path`` set to ``value`` (or removed
    when ``value`` is ``...``)."""
    data = yaml.safe_load(yaml.safe_dump(BASE))
    *parents, last = path.split(".")
    target = data
    for key in parents:
        target = target.setdefault(key, {})
    if value is ...:
        del target[last]
    else:
        target[last] = value
    return data


NAN, INF = float("nan"), float("inf")
FLOAT_PARAMETERS = [
    "reference_speed", "max_speed", "speed_step", "turn_step", "energy_use", "refuel_rate",
    "low_energy_threshold", "destination_tolerance", "radiation_damage_factor",
    "radiation_threshold", "damage_limit", "repair_rate", "datalink_range",
]  # fmt: skip

FIELD_CASES: list[tuple[str, Any, str]] = [
    *[(f"parameters.{p}", v, p) for p in FLOAT_PARAMETERS for v in (NAN, INF, -1.0)],
    ("parameters.gathering_iteration", INF, "gathering_iteration"),
    ("parameters.gathering_iteration", -5, "gathering_iteration"),
    ("parameters.gathering_iteration", 2.5, "gathering_iteration"),
    ("parameters.gathering_sender", 5, "gathering_sender"),
    ("parameters.gathering_sender", "", "gathering_sender"),
    ("parameters.energy_usage", 1, "did you mean 'energy_use'"),
    ("agents", -3, "agents"),
    ("agents", 0, "agents"),
    ("agents", 1.5, "agents"),
    ("agents", "four", "agents"),
    ("agents", INF, "agents"),
    ("agents", NAN, "agents"),
    ("agents", True, "agents"),
    ("agents", [4], "agents"),
    ("agents", None, "agents"),
    ("agents", ..., "missing key"),
    ("iterations", 0, "iterations"),
    ("iterations", INF, "iterations"),
    ("iterations", NAN, "iterations"),
    ("iterations", "long", "iterations"),
    ("iterations", 2.5, "iterations"),
    ("iterations", 10**15, "needs at least"),
    ("world.size", [NAN, 100], "world"),
    ("world.size", [100, INF], "world"),
    ("world.size", [-1, 100], "world"),
    ("world.size", [0, 0], "world"),
    ("world.size", [100], "world"),
    ("world.size", "big", "world"),
    ("world.size", [100, 100, 100], "world"),
    ("world", [100, 100], "world"),
    ("world.moon", 1, "moon"),
    ("world.refueling_positions", [], "refueling_positions"),
    ("world.refueling_positions", [[NAN, 1]], "refueling_positions"),
    ("world.refueling_positions", [[1]], "refueling_positions"),
    ("world.refueling_positions", [[1, INF]], "refueling_positions"),
    ("world.refueling_positions", "x", "refueling_positions"),
    ("world.surveillance_positions", [[NAN, 2]], "surveillance_positions"),
    ("world.surveillance_positions", [1, 2], "surveillance_positions"),
    ("initial_heading", NAN, "initial_heading"),
    ("initial_heading", INF, "initial_heading"),
    ("initial_heading", "north", "initial_heading"),
    ("frame_every", 0, "frame_every"),
    ("frame_every", INF, "frame_every"),
    ("world.radiation_sources", [{"x": NAN, "y": 1, "range": 1}], "radiation_sources[0].x"),
    ("world.radiation_sources", [{"x": 1, "y": 1, "range": 0}], "range"),
    ("world.radiation_sources", [{"x": 1, "y": 1, "range": INF}], "range"),
    ("world.radiation_sources", [{"x": 1, "y": 1}], "missing key"),
    ("world.radiation_sources", "x", "radiation_sources"),
    ("world.radiation_sources", [{"x": 1, "y": 1, "range": 1, "active": "yes"}], "active"),
    ("world.radiation_sources", [{"x": 1, "y": 1, "range": 1, "colour": 1}], "colour"),
    ("model", "car", "model"),
    ("x8", {"dt": 0.01}, "x8"),
    ("mission", "nowhere", "nowhere"),
    ("mission", "", "mission"),
    ("parameters.low_energy_threshold", 150, "low_energy_threshold"),
    ("parameters.gathering_sender", "drone9", "gathering_sender"),
    ("world.surveillance_positions", [[500, 500]], "surveillance_positions"),
    ("name", "", "name"),
    ("tree", "", "tree"),
    ("tree", "missing_tree.xml", "cannot read"),
    ("colour", "red", "unknown key"),
]


@pytest.mark.parametrize(("field", "value", "named"), FIELD_CASES)
def test_bad_scenario_field(field, value, named, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(mutated(field, value)), encoding="utf-8")
    line = refused(["run", str(path), "--no-gif", "--quiet", "--out", str(tmp_path / "o")], capsys)
    assert named in line


def alias_bomb(levels: int = 30) -> str:
    lines = ["a0: &a0 [x, x]"]
    lines += [f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}]" for i in range(1, levels)]
    return "\n".join(lines)


RAW_SCENARIOS: list[tuple[str, bytes, str]] = [
    ("duplicate_key", b"name: a\nagents: 4\nagents: 5\n", "given twice (lines 2 and 3)"),
    ("duplicate_parameter", yaml.safe_dump(BASE).encode() + b"name: again\n", "given twice"),
    ("syntax", b"name: a\n  agents: [4\n", "bad.yaml:"),
    ("unclosed", b"name: 'a\n", "not valid YAML"),
    ("tab", b"name: a\n\tagents: 4\n", "not valid YAML"),
    ("not_utf8", b"name: \xff\xfe\n", "not UTF-8"),
    ("nul_byte", b"name: a\x00\n", "bad.yaml"),
    ("alias_bomb_in_a_field", (alias_bomb() + "\ndescription: *a29\n").encode(), "aliases"),
    ("deep_nesting", b"world: " + b"[" * 5000 + b"]" * 5000 + b"\n", "nested more than"),
    ("python_tag", b"name: !!python/object/apply:os.system [echo]\n", "not valid YAML"),
    ("impossible_date", b"name: 2024-02-30\n", "cannot be read"),
    ("empty", b"", "mapping"),
    ("a_list", b"- 1\n- 2\n", "mapping"),
    ("huge", b"# " + b"x" * 3_000_000 + b"\n", "larger than"),
]


@pytest.mark.parametrize(
    ("content", "named"), [c[1:] for c in RAW_SCENARIOS], ids=[c[0] for c in RAW_SCENARIOS]
)
def test_bad_scenario_file(content, named, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_bytes(content)
    line = refused(["run", str(path), "--no-gif", "--quiet", "--out", str(tmp_path / "o")], capsys)
    assert named in line


def test_unreadable_scenario_paths(tmp_path, capsys):
    assert "cannot read" in refused(["run", str(tmp_path / "missing.yaml")], capsys)
    (tmp_path / "folder.yaml").mkdir()
    assert "cannot read" in refused(["run", str(tmp_path / "folder.yaml")], capsys)


# --------------------------------------------------------------------------- tree files

LEAF = '<Action_Refuel_A name="{name}"/>'


def subtree_bomb(trees: int = 40) -> str:
    body = ['<root BTCPP_format="4" main_tree_to_execute="T0">']
    for i in range(trees - 1):
        body.append(
            f'<BehaviorTree ID="T{i}"><Sequence><SubTree ID="T{i + 1}"/>'
            f'<SubTree ID="T{i + 1}"/></Sequence></BehaviorTree>'
        )
    body.append(f'<BehaviorTree ID="T{trees - 1}"><Action_Refuel_A/></BehaviorTree></root>')
    return "\n".join(body)


def yaml_tree_bomb(levels: int = 27) -> str:
    lines = ["x0: &n0 {type: Action_Refuel_A}"]
    for i in range(1, levels):
        lines.append(f"x{i}: &n{i} {{type: Sequence, children: [*n{i - 1}, *n{i - 1}]}}")
    return "subtree_ports:\n  " + "\n  ".join(lines) + f"\ntree: *n{levels - 1}\n"


def deep_xml(depth: int = 2000) -> str:
    return (
        '<root BTCPP_format="4"><BehaviorTree ID="T">'
        + "<Sequence>" * depth
        + "<Action_Refuel_A/>"
        + "</Sequence>" * depth
        + "</BehaviorTree></root>"
    )


def deep_yaml(depth: int = 2000) -> str:
    node = "{type: Action_Refuel_A}"
    for _ in range(depth):
        node = "{type: Sequence, children: [" + node + "]}"
    return "tree: " + node + "\n"


def yaml_leaf(port: str) -> str:
    head = "tree:\n  type: Sequence\n  children:\n    - type: Condition_Low_Energy_Level\n"
    return f"{head}      {port}\n"


def xml_leaf(attribute: str) -> str:
    return (
        '<root BTCPP_format="4"><BehaviorTree ID="T"><Sequence>'
        f"<Condition_Low_Energy_Level {attribute}/></Sequence></BehaviorTree></root>"
    )


TREE_CASES: list[tuple[str, str, str, str]] = [
    ("subtree_bomb", "xml", subtree_bomb(), "nodes once its SubTrees are inlined"),
    ("subtree_bomb_yaml", "yaml", "", "nodes once its SubTrees are inlined"),
    ("yaml_alias_bomb", "yaml", yaml_tree_bomb(), "aliases"),
    ("deep_xml", "xml", deep_xml(), "levels"),
    ("deep_yaml", "yaml", deep_yaml(), "nested more than"),
    ("deep_xml_70", "xml", deep_xml(70), "levels"),
    ("deep_yaml_70", "yaml", deep_yaml(70), "levels deep"),
    ("yaml_nan_port", "yaml", yaml_leaf("threshold: .nan"), "finite"),
    ("yaml_inf_port", "yaml", yaml_leaf("threshold: .inf"), "finite"),
    ("yaml_minus_inf_port", "yaml", yaml_leaf("threshold: -.inf"), "finite"),
    ("xml_nan_port", "xml", xml_leaf('threshold="nan"'), "finite"),
    ("xml_inf_port", "xml", xml_leaf('threshold="inf"'), "finite"),
    ("yaml_python_tag", "yaml", yaml_leaf("threshold: !!python/name:os.system"), "cannot be read"),
    ("yaml_bad_date", "yaml", yaml_leaf("threshold: 2024-02-30"), "cannot be read"),
    ("yaml_duplicate_port", "yaml", yaml_leaf("threshold: 1\n      threshold: 2"), "twice"),
    ("huge_port_value", "xml", xml_leaf('threshold="' + "9" * 1_500_000 + 'x"'), "characters"),
    ("huge_yaml_port", "yaml", yaml_leaf("threshold: " + "x" * 1_500_000), "characters"),
    ("huge_file", "xml", "<!--" + "x" * 2_100_000 + "-->", "larger than"),
    ("not_utf8", "xml", "", "not UTF-8"),
]


@pytest.mark.parametrize(
    ("fmt", "text", "named"), [c[1:] for c in TREE_CASES], ids=[c[0] for c in TREE_CASES]
)
def test_bad_tree_file(fmt, text, named, tmp_path, capsys):
    path = tmp_path / f"bad.{fmt}"
    if named == "not UTF-8":
        path.write_bytes(b'<root BTCPP_format="4">\xff</root>')
    elif not text:  # the SubTree bomb, written as YAML
        path.write_text(yaml.safe_dump(_subtree_bomb_yaml()), encoding="utf-8")
    else:
        path.write_text(text, encoding="utf-8")
    line = refused(["tree", str(path)], capsys)
    assert named in line
    assert str(path) in line
    with deadline(), pytest.raises(TreeFileError):
        load_tree(path)


def _subtree_bomb_yaml(trees: int = 40) -> dict[str, Any]:
    found: dict[str, Any] = {}
    for i in range(trees - 1):
        child = {"type": "SubTree", "ID": f"T{i + 1}"}
        found[f"T{i}"] = {"type": "Sequence", "children": [child, dict(child)]}
    found[f"T{trees - 1}"] = {"type": "Action_Refuel_A"}
    return {"main_tree_to_execute": "T0", "trees": found}


def test_many_unnamed_leaves_are_named_in_linear_time():
    leaves = "".join("<Action_Refuel_A/>" for _ in range(30_000))
    text = (
        f'<root BTCPP_format="4"><BehaviorTree><Sequence>{leaves}</Sequence></BehaviorTree></root>'
    )
    with deadline():
        tree = from_text_format(text, "xml")
    assert tree.children[-1].name == "action_refuel_a_30000"


def test_the_largest_tree_allowed_is_built():
    text = subtree_bomb(14)  # 2**14 - 1 nodes once inlined: within the limit of 32,767
    with deadline():
        tree = from_text_format(text, "xml")
    assert len(tree.leaves()) == 2**13


# ------------------------------------------------------------------------ command lines

RUN = ["run", "gathering", "--no-gif", "--quiet"]
CLI_CASES: list[tuple[list[str], str]] = [
    ([*RUN, "--agents", "-3"], "agents"),
    ([*RUN, "--agents", "0"], "agents"),
    ([*RUN, "--agents", "abc"], "--agents"),
    ([*RUN, "--agents", "1e3"], "--agents"),
    ([*RUN, "--agents", "1000000000000"], "needs at least"),
    ([*RUN, "--iterations", "0"], "iterations"),
    ([*RUN, "--iterations", "-5"], "iterations"),
    ([*RUN, "--iterations", "x"], "--iterations"),
    ([*RUN, "--iterations", "1000000000000000"], "needs at least"),
    ([*RUN, "--seed", "-1"], "--seed"),
    ([*RUN, "--seed", "x"], "--seed"),
    ([*RUN, "--record-every", "0"], "--record-every"),
    ([*RUN, "--record-every", "-1"], "--record-every"),
    ([*RUN, "--trace", ",,"], "--trace needs agent names"),
    ([*RUN, "--record-every", "x"], "--record-every"),
    ([*RUN, "--frame-every", "0"], "frame_every"),
    ([*RUN, "--frame-every", "-2"], "frame_every"),
    ([*RUN, "--set", "low_energy_threshold="], "KEY=VALUE"),
    ([*RUN, "--set", "=5"], "KEY=VALUE"),
    ([*RUN, "--set", "novalue"], "KEY=VALUE"),
    ([*RUN, "--set", "agents=5"], "use the option --agents 5"),
    ([*RUN, "--set", "iterations=3"], "--iterations"),
    ([*RUN, "--set", "size=[3, 4]"], "use the option --world"),
    ([*RUN, "--world", "10"], "--world: WIDTH,HEIGHT"),
    ([*RUN, "--world", "a,b"], "--world: WIDTH,HEIGHT"),
    ([*RUN, "--world", "1,2,3"], "--world: WIDTH,HEIGHT"),
    ([*RUN, "--world=-5,10"], "world.size must be a positive"),
    ([*RUN, "--world", "nan,10"], "finite"),
    ([*RUN, "--set", "foo=1"], "unknown parameter 'foo'; parameters: "),
    ([*RUN, "--set", "low_energy_treshold=30"], "did you mean 'low_energy_threshold'"),
    ([*RUN, "--set", "energy_use=lots"], "energy_use must be a number"),
    ([*RUN, "--set", "energy_use=.nan"], "finite"),
    ([*RUN, "--set", "energy_use=.inf"], "finite"),
    ([*RUN, "--set", "energy_use=[1"], "not valid YAML"),
    ([*RUN, "--set", "energy_use={a: 1}"], "energy_use"),
    ([*RUN, "--set", "energy_use=-1"], "energy_use"),
    ([*RUN, "--set", "gathering_iteration=1.5"], "gathering_iteration"),
    ([*RUN, "--set", "energy_use=!!python/name:os.system"], "not valid YAML"),
    ([*RUN, "--set", "energy_use=1\n2"], "energy_use"),
    ([*RUN, "--engine", "fast"], "--engine"),
    ([*RUN, "--format", "xls"], "--format"),
    ([*RUN, "--tree", "x.txt"], "must end in .xml"),
    ([*RUN, "--tree", "missing.xml"], "cannot read"),
    (["run", "no_such_scenario"], "unknown scenario"),
    (["run", "gatherin"], "did you mean 'gathering'"),
    (["run"], "scenario"),
    (["tree", "x.txt"], "neither a registered scenario"),
    (["tree", "missing.xml"], "cannot read"),
    (["tree", "gathering", "--format", "jpg"], "--format"),
    (["tree", "nothing"], "unknown scenario 'nothing'"),
    (["tree", "gatherin"], "did you mean 'gathering'"),
    (["tree", "gathering", "--out", "missing/dir/x.xml", "--format", "xml"], "cannot write"),
    (["tree", "gathering", "--out", "missing/dir/x.png", "--format", "png"], "cannot write"),
    (["bench", "patrol", "--stress", "--memory-budget", "lots"], "--memory-budget"),
    (["bench", "patrol", "--stress", "--memory-budget", "-5GB"], "--memory-budget"),
    (["bench", "patrol", "--stress", "--memory-budget", "0"], "--memory-budget"),
    (["bench", "patrol", "--memory-budget", "lots"], "--memory-budget"),
    (["bench", "patrol", "--timeout", "-1"], "--timeout"),
    (["bench", "patrol", "--timeout", "nan"], "--timeout"),
    (["bench", "patrol", "--agents", "0"], "--agents"),
    (["bench", "patrol", "--agents", "x"], "--agents"),
    (["bench", "patrol", "--iterations", "0"], "--iterations"),
    (["bench", "patrol", "--engines", "fast"], "--engines"),
    (["bench", "patrol", "--stress-start", "0"], "--stress-start"),
    (["bench", "nowhere"], "unknown scenario"),
    ([], "command"),
    (["fly"], "invalid choice"),
]


@pytest.mark.parametrize(("argv", "named"), CLI_CASES, ids=[" ".join(c[0]) for c in CLI_CASES])
def test_bad_command_line(argv, named, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert named in refused(argv, capsys)
    assert not (tmp_path / "runs").exists()  # nothing written


def test_replay_into_a_missing_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert main([*RUN, "--iterations", "20", "--no-replay", "--out", str(out)]) == 0
    capsys.readouterr()
    line = refused(["replay", str(out), "--out", str(tmp_path / "missing" / "x.html")], capsys)
    assert "No such file or directory" in line


def test_output_folder_problems(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    assert "is a file" in refused([*RUN, "--out", str(tmp_path / "file")], capsys)
    assert "cannot use" in refused([*RUN, "--out", str(tmp_path / "file" / "below")], capsys)


def test_a_bad_output_folder_is_refused_before_the_run_is_set_up(tmp_path, capsys, monkeypatch):
    """Set-up can compile for minutes: a folder that cannot take the run is refused first."""
    import pyautonomousagent.cli as cli

    class NotSetUp:
        @staticmethod
        def create(*args: Any, **kwargs: Any) -> None:
            raise AssertionError("the run was set up before its folder was checked")

    monkeypatch.setattr(cli, "Simulation", NotSetUp)
    (tmp_path / "file").write_text("x")
    assert "is a file" in refused([*RUN, "--out", str(tmp_path / "file")], capsys)
    assert "cannot use" in refused([*RUN, "--out", str(tmp_path / "file" / "below")], capsys)


# ---------------------------------------------------------------------------- Python API

SHORT = load("patrol").with_overrides(agents=2, iterations=5)
HUGE_REPEAT = (
    '<root BTCPP_format="4"><BehaviorTree><Repeat num_cycles="'
    + "x" * 1_000_000
    + '"><Action_Refuel_A/></Repeat></BehaviorTree></root>'
)
RAW = dataclasses.replace(SHORT, agents=-1)  # built directly, not validated yet
RAW_WORLD = dataclasses.replace(SHORT, world=(NAN, 100.0))

API_CASES: list[tuple[str, Callable[[], Any], type[Exception], str]] = [
    ("name_not_scenario", lambda: Simulation.create("gathering"), TypeError, "load('gathering')"),
    ("tree_missing_file", lambda: Simulation.create(SHORT, tree="x.xml"), TreeFileError, "x.xml"),
    ("tree_wrong_type", lambda: Simulation.create(SHORT, tree=5), TypeError, "tree"),
    ("seed_text", lambda: Simulation.create(SHORT, seed="1"), TypeError, "seed"),
    ("seed_float", lambda: Simulation.create(SHORT, seed=1.5), TypeError, "seed"),
    ("seed_none", lambda: Simulation.create(SHORT, seed=None), TypeError, "seed"),
    ("seed_negative", lambda: Simulation.create(SHORT, seed=-1), ValueError, "seed"),
    ("record_every_zero", lambda: Simulation.create(SHORT, record_every=0), ValueError, "record"),
    ("record_every_text", lambda: Simulation.create(SHORT, record_every="2"), TypeError, "record"),
    ("record_every_float", lambda: Simulation.create(SHORT, record_every=2.5), TypeError, "rec"),
    ("record_every_bool", lambda: Simulation.create(SHORT, record_every=True), TypeError, "rec"),
    ("engine_number", lambda: Simulation.create(SHORT, engine=3), TypeError, "engine"),
    ("engine_unknown", lambda: Simulation.create(SHORT, engine="fast"), ValueError, "engine"),
    ("scenario_built_directly", lambda: Simulation.create(RAW), ScenarioError, "agents"),
    ("scenario_nan_world", lambda: Simulation.create(RAW_WORLD), ScenarioError, "world"),
    ("override_nan", lambda: SHORT.with_overrides(energy_use=NAN), ScenarioError, "finite"),
    ("override_negative", lambda: SHORT.with_overrides(agents=-1), ScenarioError, "agents"),
    ("load_unknown", lambda: load("nothing"), ScenarioError, "unknown scenario"),
    ("load_missing", lambda: load("missing.yaml"), ScenarioError, "cannot read"),
    ("tree_text_empty", lambda: from_text_format("", "xml"), TreeFileError, "XML"),
    ("tree_text_bomb", lambda: from_text_format(subtree_bomb(), "xml"), TreeFileError, "nodes"),
    ("tree_huge_parameter", lambda: from_text_format(HUGE_REPEAT, "xml"), TreeFileError, "..."),
    ("huge_run", lambda: Simulation.create(SHORT.with_overrides(agents=10**12)), InputError, "GB"),
]


@pytest.mark.parametrize(
    ("call", "kind", "named"), [c[1:] for c in API_CASES], ids=[c[0] for c in API_CASES]
)
def test_bad_api_call(call, kind, named):
    with deadline(), pytest.raises(kind) as info:
        call()
    message = str(info.value)
    assert named in message and "\n" not in message and len(message) < 700


def test_step_past_the_end_changes_nothing():
    sim = Simulation.create(SHORT).run(progress=False)
    before = {k: v.copy() for k, v in sim.swarm.columns.items()}
    with pytest.raises(RuntimeError, match="all its 5 iterations"):
        sim.step()
    assert sim.world.iteration == 5
    assert all((sim.swarm.columns[k] == v).all() for k, v in before.items())


def test_the_corpus_has_at_least_150_bad_inputs():
    count = len(FIELD_CASES) + len(RAW_SCENARIOS) + 2 + len(TREE_CASES) + len(CLI_CASES) + 2
    assert count + len(API_CASES) >= 150
