"""Every file the tool reads is untrusted: scenario, tree, sweep spec, run.json, results.

Each case gives exit code 2 and one line on stderr naming the file (or option) and the field,
with no traceback; the parsers (scripts, sweep specs) are fuzzed: any text gives a valid
result or the project's one-line error, never another exception.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyautonomousagent.bt.limits import MAX_TREE_NODES
from pyautonomousagent.bt.script import (
    MAX_SCRIPT_CHARS,
    MAX_SCRIPT_DEPTH,
    Script,
    ScriptError,
    parse,
)
from pyautonomousagent.cli import main
from pyautonomousagent.experiments.spec import (
    Experiment,
    ExperimentError,
    parse_vary,
    read_file,
    with_options,
)
from pyautonomousagent.inputs import InputError, load_yaml, plain_value
from tests.test_bad_inputs import deadline, refused

FUZZ = settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)  # fmt: skip


def write(folder: Path, name: str, content: str | bytes) -> Path:
    path = folder / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


# --------------------------------------------------------- regressions of the first hardening


RECURSIVE_TREES = [
    "tree: &a {type: Sequence, children: [*a]}\n",
    "tree: &a\n  type: Sequence\n  children:\n    - *a\n",
    "trees:\n  T: &t {type: Fallback, children: [{type: Inverter, children: [*t]}]}\n",
]


@pytest.mark.parametrize("text", RECURSIVE_TREES)
def test_a_recursive_yaml_alias_in_a_tree_is_one_line(text, tmp_path, capsys):
    path = write(tmp_path, "loop.yaml", text)
    line = refused(["tree", str(path)], capsys)
    assert str(path) in line and "refers to the value that contains it" in line


def test_a_recursive_yaml_alias_in_a_scenario_or_sweep_is_one_line(tmp_path, capsys):
    scenario = write(tmp_path, "s.yaml", "name: x\nagents: 4\nworld: &w {size: [*w, 1]}\n")
    assert "contains it" in refused(["run", str(scenario), "--quiet", "--no-gif"], capsys)
    spec = write(tmp_path, "e.yaml", "scenario: patrol\nvary: &v {refuel_rate: *v}\n")
    assert "contains it" in refused(["sweep", str(spec), "--serial"], capsys)


def test_a_fallback_with_more_children_than_an_int16_is_refused(tmp_path, capsys):
    leaves = "<AlwaysSuccess/>" * MAX_TREE_NODES  # + the Fallback: one node too many
    path = write(
        tmp_path,
        "wide.xml",
        f'<root BTCPP_format="4"><BehaviorTree ID="T"><Fallback>{leaves}</Fallback>'
        "</BehaviorTree></root>",
    )
    line = refused(["tree", str(path)], capsys)
    assert f"{MAX_TREE_NODES + 1} nodes" in line and str(MAX_TREE_NODES) in line


def test_the_recorder_refuses_a_python_tree_it_cannot_index():
    from pyautonomousagent.bt.spec import TreeError, fallback, leaf
    from pyautonomousagent.recording import Recorder
    from pyautonomousagent.state import Swarm

    kids = [leaf("AlwaysSuccess", f"k{i}") for i in range(MAX_TREE_NODES)]
    swarm = Swarm.create(["a1"], {})
    with pytest.raises(TreeError, match="in a recorded run"):
        Recorder(swarm, 3, tree=fallback("f", *kids))


# ----------------------------------------------------------------------------- tree files

MISSING_PORTS = [
    ("script.yaml", "tree:\n  type: Script\n", "Script needs port 'code'"),
    ("condition.yaml", "tree:\n  type: ScriptCondition\n", "ScriptCondition needs port 'code'"),
    (
        "set.xml",
        '<root BTCPP_format="4"><BehaviorTree><SetBlackboard value="3"/></BehaviorTree></root>',
        "SetBlackboard needs port 'output_key'",
    ),
    (
        "set.yaml",
        "tree:\n  type: SetBlackboard\n  output_key: laps\n",
        "SetBlackboard needs port 'value'",
    ),
]


@pytest.mark.parametrize(("name", "text", "named"), MISSING_PORTS)
def test_a_script_leaf_without_its_ports_is_one_line(name, text, named, tmp_path, capsys):
    path = write(tmp_path, name, text)
    assert named in refused(["tree", str(path)], capsys)
    assert named in refused(["run", "gathering", "--tree", str(path), "--quiet"], capsys)


def test_a_script_leaf_built_in_python_without_code_is_a_clear_error():
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.bt.spec import TreeError, leaf, sequence

    scenario = load("patrol").with_overrides(agents=2, iterations=3)
    tree = sequence("s", leaf("Script"), leaf("AlwaysSuccess"))
    with pytest.raises(TreeError, match="missing \\['code'\\]"):
        Simulation.create(scenario, tree=tree)


SCRIPTS = [
    ("(" * 200 + "1" + ")" * 200, "nests more than"),
    ("!" * 5000 + "x", "nests more than"),
    ("-" * 5000 + "1", "nests more than"),
    ("x := " + " + ".join(["1"] * 2000), "nests more than"),
    ("x := " + "a ? b : " * 300 + "c", "nests more than"),
    ("x := " + "1 + " * 3000 + "1", "characters, more than"),
    ("x := " + "9" * 50, "beyond int64"),
    ("x := 0x" + "F" * 17, "beyond int64"),
    ("x := 1e400", "too large"),
    ("'a' < 'b'", "operator '<' cannot take a string"),
    ("mode >= 'idle'", "operator '>=' cannot take a string"),
    ("x := 'a' + 1", "operator '+' cannot take a string"),
    ("x := -'a'", "operator '-' cannot take a string"),
    ("x := 1 \u00a0+ 2", "unexpected character"),
]


@pytest.mark.parametrize(
    ("code", "named"), SCRIPTS, ids=[s[1] + str(i) for i, s in enumerate(SCRIPTS)]
)
def test_bad_scripts_are_script_errors(code, named):
    with deadline(10), pytest.raises(ScriptError) as info:
        parse(code)
    assert named in str(info.value)
    assert "\n" not in str(info.value) and len(str(info.value)) < 400


def test_scripts_at_the_limits_parse():
    assert parse("(" * (MAX_SCRIPT_DEPTH - 1) + "1" + ")" * (MAX_SCRIPT_DEPTH - 1))
    assert parse("x := " + " + ".join(["1"] * (MAX_SCRIPT_DEPTH - 1)))
    assert parse("x := 9223372036854775807; y := 0x7FFFFFFFFFFFFFFF; 'a' == mode")
    assert len(parse("x := 1;" * (MAX_SCRIPT_CHARS // 8)).statements) == MAX_SCRIPT_CHARS // 8


def test_a_deep_script_in_a_tree_file_is_one_line(tmp_path, capsys):
    code = "(" * 1000 + "1" + ")" * 1000
    path = write(tmp_path, "deep.xml", f'<root><BehaviorTree><Script code="x := {code}"/>'
                 "</BehaviorTree></root>")  # fmt: skip
    line = refused(["tree", str(path)], capsys)
    assert f"{path}:1" in line and "nests more than" in line


SCRIPT_WORDS = [
    "x", "y", "@z", "mode", "true", "false", "1", "2.5", "0x1F", "1e3", "'a'", "'b'", "''",
    "(", ")", "+", "-", "*", "/", "!", "~", "&&", "||", "&", "|", "^", "==", "!=", "<", "<=",
    ">", ">=", "?", ":", ":=", "=", "+=", "-=", "*=", "/=", ";", "..", " ", "'", "\\", "#",
]  # fmt: skip


def _parsed_or_refused(code: str) -> None:
    """``parse(code)`` gives a Script whose analyses run, or a one-line ScriptError."""
    try:
        script = parse(code)
    except ScriptError as error:
        assert isinstance(error, InputError) and "\n" not in str(error)
        return
    assert isinstance(script, Script)
    script.assigned({})
    script.reads()


@FUZZ
@given(st.lists(st.sampled_from(SCRIPT_WORDS), max_size=80).map(" ".join))
def test_fuzz_script_tokens(code):
    _parsed_or_refused(code)


@FUZZ
@given(st.text(max_size=300))
def test_fuzz_script_text(code):
    _parsed_or_refused(code)


@FUZZ
@given(st.integers(1, 3000), st.sampled_from(["(", "!", "-", "~", "x ? 1 : ", "1 + "]))
def test_fuzz_script_nesting(levels, prefix):
    closing = ")" * levels if prefix == "(" else ""
    _parsed_or_refused(prefix * levels + "1" + closing)


# ------------------------------------------------------------------------ YAML 1.2 numbers


@pytest.mark.parametrize(
    ("text", "value"),
    [("1:30", "1:30"), ("yes", "yes"), ("off", "off"), ("010", 10), ("1_000", "1_000"),
     ("0o17", 15), ("0x1F", 31), ("1e3", 1000.0), ("true", True), ("~", None)],
)  # fmt: skip
def test_yaml_scalars_follow_yaml_1_2_not_1_1(text, value):
    assert load_yaml(f"a: {text}", "f") == {"a": value}
    assert plain_value(text) == value


def test_explicit_yaml_1_1_tags_are_refused():
    for text in ("!!int 1:30", "!!float 1:30.5", "!!bool yes"):
        with pytest.raises(InputError, match="not valid YAML"):
            load_yaml(f"a: {text}", "f")


def test_a_base_60_value_in_a_scenario_is_refused_not_read_as_90(tmp_path, capsys):
    line = refused(["run", "gathering", "--set", "low_energy_threshold=1:30", "--quiet"], capsys)
    assert "low_energy_threshold must be a number" in line and "'1:30'" in line


# ---------------------------------------------------------------------------- sweep specs

SPEC = "scenario: patrol\niterations: 5\nvary: {refuel_rate: [1, 2]}\n"
SPECS = [
    ("vary_list", "scenario: patrol\nvary: [1, 2]\n", "vary must be a mapping"),
    ("vary_text", "scenario: patrol\nvary: refuel_rate\n", "vary must be a mapping"),
    ("set_list", SPEC + "set: [agents]\n", "set must be a mapping"),
    ("engine", SPEC + "engine: warp\n", "engine must be one of auto, pytrees"),
    ("python_tag", SPEC + "name: !!python/object/apply:os.system [echo]\n", "!!python"),
    ("duplicate", SPEC + "seeds: 2\nseeds: 3\n", "key 'seeds' is given twice (lines 4 and 5)"),
    ("set_and_vary", SPEC + "set: {refuel_rate: 2}\n", "'refuel_rate' is both fixed"),
    ("base_60", "scenario: patrol\nvary: {low_energy_threshold: [1:30]}\n", "'1:30'"),
    ("date", "scenario: patrol\nvary: {refuel_rate: [2024-01-01]}\n", "number, a string"),
    ("nan", "scenario: patrol\nvary: {refuel_rate: [.nan, 1]}\n", "a finite number"),
    ("seed", SPEC + "seeds: [100000000000000000000]\n", "seeds[0] must be a whole number <="),
    ("record_every", SPEC + "record_every: 100000000000000000000\n", "(int64)"),
    (
        "uniform",
        "scenario: patrol\nsample: {count: 2, seed: 1, parameters: "
        "{refuel_rate: {uniform: [-1e308, 1e308]}}}\n",
        "within",
    ),  # fmt: skip
]


@pytest.mark.parametrize(("name", "text", "named"), SPECS, ids=[s[0] for s in SPECS])
def test_bad_sweep_spec_is_one_line(name, text, named, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    path = write(tmp_path, "spec.yaml", text)
    line = refused(["sweep", str(path), "--serial", "--quiet"], capsys)
    assert named in line and "spec" in line  # the file, or the experiment named after it
    assert not (tmp_path / "runs").exists()


def test_a_sweep_spec_that_is_not_utf8_is_one_line(tmp_path, capsys):
    path = write(tmp_path, "spec.yaml", b"scenario: p\xffatrol\nvary: {refuel_rate: [1, 2]}\n")
    assert "not UTF-8" in refused(["sweep", str(path), "--serial"], capsys)
    with pytest.raises(ExperimentError, match="not UTF-8"):
        Experiment.from_file(path)


VARY_OPTIONS = [
    (["--vary", "low_energy_threshold=1:30"], "a range is FROM:TO:STEP"),
    (["--vary", "refuel_rate=1,2", "--vary", "refuel_rate=3"], "refuel_rate is given twice"),
    (["--vary", "refuel_rate=1,2", "--set", "refuel_rate=3"], "'refuel_rate' is both fixed"),
    (["--vary", "agents=2,3", "--agents", "4"], "'agents' is both fixed"),
    (["--vary", "refuel_rate=2024-02-30"], "--vary refuel_rate"),
    (["--vary", "refuel_rate"], "NAME=V1,V2"),
]


@pytest.mark.parametrize(("options", "named"), VARY_OPTIONS)
def test_bad_vary_options_are_one_line(options, named, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    line = refused(["sweep", "patrol", *options, "--iterations", "5", "--serial"], capsys)
    assert named in line
    assert not (tmp_path / "runs").exists()


def test_vary_options_add_to_a_file_and_replace_its_entry():
    data = {"scenario": "patrol", "vary": {"refuel_rate": [1, 2]}, "set": {"agents": 3}}
    merged = with_options(data, "f.yaml", ["refuel_rate=5,6", "energy_use=0.1"], {"seed": 1})
    assert merged["vary"] == {"refuel_rate": [5, 6], "energy_use": [0.1]}
    assert merged["set"] == {"agents": 3, "seed": 1}
    assert parse_vary(["x=20:50:10", "y=a,b"]) == {"x": {"from": 20, "to": 50, "step": 10},
                                                   "y": ["a", "b"]}  # fmt: skip


YAML_WORDS = [
    "scenario: patrol", "vary:", "set:", "seeds:", "engine:", "sample:", "measures:", "name:",
    "refuel_rate:", "{", "}", "[", "]", ",", ":", "- ", "  ", "\n", "&a", "*a", "<<:",
    "!!python/name:os.system", "!!int", "1", "2.5", "1:30", ".nan", "yes", "~", "'x'", '"y"',
    "#", "|", ">", "%YAML 1.1", "---", "...", "from:", "to:", "step:", "count:", "uniform:",
    "2024-02-30", "\t", "?", "@", "`", "\xff", "\x00",
]  # fmt: skip


def _read_or_refused(content: bytes, options: list[str]) -> None:
    """An experiment file read and merged with ``--vary`` options gives an Experiment or
    a one-line ExperimentError."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "spec.yaml"
        path.write_bytes(content)
        try:
            data = read_file(path)
            if isinstance(data, dict):
                data = with_options(data, str(path), options, {})
            experiment = Experiment.from_mapping(data, str(path))
        except ExperimentError as error:
            assert isinstance(error, InputError) and "\n" not in str(error)
            return
    assert isinstance(experiment, Experiment)
    experiment.to_mapping()


@FUZZ
@given(
    st.lists(st.sampled_from(YAML_WORDS), max_size=40).map(" ".join),
    st.lists(st.sampled_from(["refuel_rate=1,2", "refuel_rate=1:3:1", "x=1:30", "a=b=c"]),
             max_size=2),
)  # fmt: skip
def test_fuzz_sweep_spec_yaml(text, options):
    _read_or_refused(text.encode("utf-8", "surrogatepass"), options)


@FUZZ
@given(st.binary(max_size=300))
def test_fuzz_sweep_spec_bytes(content):
    _read_or_refused(content, [])


JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
        st.sampled_from(["from", "to", "step", "uniform", "integers", "choice", "count",
                         "seed", "parameters", "refuel_rate", "agents", "x"]), inner, max_size=4),
    max_leaves=20,
)  # fmt: skip


@FUZZ
@given(st.dictionaries(
    st.sampled_from(["scenario", "vary", "set", "sample", "seeds", "measures", "engine",
                     "iterations", "record_every", "name"]), JSONISH, max_size=6))  # fmt: skip
def test_fuzz_sweep_spec_mappings(data):
    try:
        experiment = Experiment.from_mapping(data)
    except ExperimentError as error:
        assert "\n" not in str(error)
        return
    experiment.to_mapping()


# ------------------------------------------------------------------------------ pyaa plot


@pytest.fixture
def sweep_folder(tmp_path) -> Path:
    """A sweep folder with a results table written by hand (no sweep is run)."""
    folder = tmp_path / "sweep"
    folder.mkdir()
    table = pa.table({
        "run": [0, 1], "run_id": ["a", "b"], "seed": [0, 0], "status": ["ok", "ok"],
        "refuel_rate": [1, 2], "refuels": [3.0, 4.0], "label": ["x", "y"],
    })  # fmt: skip
    pq.write_table(table, folder / "results.parquet")
    (folder / "experiment.json").write_text(json.dumps({"measures": {"refuels": {"unit": "n"}}}))
    return folder


def test_plot_of_a_good_sweep_works(sweep_folder, capsys):
    assert main(["plot", str(sweep_folder), "--measure", "refuels", "--x", "refuel_rate"]) == 0


def test_plot_against_a_column_of_lists_is_one_line(tmp_path, capsys):
    table = pa.table({"status": ["ok"], "refuels": [1.0], "rate": [[1, 2]]})
    pq.write_table(table, tmp_path / "results.parquet")
    line = refused(["plot", str(tmp_path), "--measure", "refuels", "--x", "rate"], capsys)
    assert "parameter 'rate' is a column of lists" in line


PLOT_DAMAGE: list[tuple[str, str, Any, str]] = [
    ("text_column", "", None, "measure 'label' is a column of string, not numbers"),
    ("truncated", "results.parquet", lambda b: b[: len(b) // 2], "cannot be read"),
    ("not_parquet", "results.parquet", lambda b: b"hello", "cannot be read"),
    ("empty", "results.parquet", lambda b: b"", "cannot be read"),
    ("manifest_garbage", "experiment.json", lambda b: b"{", "not valid JSON"),
    ("manifest_list", "experiment.json", lambda b: b"[1]", "must be a JSON object"),
    ("manifest_measures", "experiment.json", lambda b: b'{"measures": [1]}', "'measures'"),
]


@pytest.mark.parametrize(("file", "damage", "named"), [c[1:] for c in PLOT_DAMAGE],
                         ids=[c[0] for c in PLOT_DAMAGE])  # fmt: skip
def test_plot_of_a_damaged_sweep_is_one_line(file, damage, named, sweep_folder, capsys):
    measure = "label" if not file else "refuels"
    if file:
        path = sweep_folder / file
        path.write_bytes(damage(path.read_bytes()))
    line = refused(["plot", str(sweep_folder), "--measure", measure, "--x", "refuel_rate"], capsys)
    assert named in line


# ---------------------------------------------------------------------------- pyaa replay


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    """A short run of gathering, written once for the module."""
    out = tmp_path_factory.mktemp("run") / "gathering"
    assert main(["run", "gathering", "--iterations", "10", "--no-gif", "--no-replay",
                 "--quiet", "--out", str(out)]) == 0  # fmt: skip
    return out


def _summary(folder: Path, change: Any) -> bytes:
    data = json.loads((folder / "run.json").read_text())
    return json.dumps(change(data)).encode()


REPLAY_DAMAGE: list[tuple[str, str, Any, str]] = [
    ("garbage", "run.json", lambda f: b"not json {", "run.json:1: not valid JSON"),
    ("a_list", "run.json", lambda f: b"[1, 2]", "must be a JSON object (a mapping), got a list"),
    ("empty", "run.json", lambda f: b"", "not valid JSON"),
    ("not_utf8", "run.json", lambda f: b'{"a": "\xff"}', "not UTF-8"),
    ("deep", "run.json", lambda f: b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
    ("scenario", "run.json", lambda f: _summary(f, lambda d: {**d, "scenario": 3}), "'scenario'"),
    ("bad_scenario", "run.json",
     lambda f: _summary(f, lambda d: {**d, "scenario": {**d["scenario"], "agents": -1}}),
     "agents"),
    ("events", "run.json", lambda f: _summary(f, lambda d: {**d, "events": {}}), "'events'"),
    ("event", "run.json", lambda f: _summary(f, lambda d: {**d, "events": [1]}), "events[0]"),
    ("iteration", "run.json",
     lambda f: _summary(f, lambda d: {**d, "events": [{"iteration": [1]}]}), "events[0].iter"),
    ("nodes", "run.json",
     lambda f: _summary(f, lambda d: {**d, "trace": {"nodes": [{"name": "a"}]}}), "nodes[0]"),
    ("parent", "run.json",
     lambda f: _summary(f, lambda d: {**d, "trace": {"nodes": [
         {"name": "a", "type": "Sequence", "parent": -1},
         {"name": "b", "type": "AlwaysSuccess", "parent": 5}]}}), "nodes[1].parent"),
    ("truncated", "states.parquet", lambda f: (f / "states.parquet").read_bytes()[:200],
     "states.parquet: the states table cannot be read"),
    ("no_states", "states.parquet", None, "no states.parquet or states.csv"),
    ("traces", "traces.parquet", lambda f: b"PAR1", "traces table cannot be read"),
    ("columns", "states.parquet",
     lambda f: _parquet(pa.table({"iteration": [0], "agent": ["a"]})), "no column 'x'"),
    ("rows", "states.parquet", lambda f: _parquet(_states(iteration=[0, 1, 2])),
     "tables do not fit together"),
    ("float_iterations", "states.parquet", lambda f: _parquet(_states()),
     "column 'iteration' must hold whole numbers"),
    ("text_positions", "states.parquet",
     lambda f: _parquet(_states(iteration=[0, 1, 2], x=list("123"))),
     "column 'x' must hold numbers"),
]  # fmt: skip


def _states(**columns: list[Any]) -> pa.Table:
    """A states table of three rows (floats), with ``columns`` replaced."""
    data: dict[str, list[Any]] = {k: [0.0, 1.0, 2.0] for k in ("iteration", "x", "y", "heading")}
    return pa.table({**data, "agent": ["a", "b", "a"], **columns})


def _parquet(table: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


@pytest.mark.parametrize(("file", "damage", "named"), [c[1:] for c in REPLAY_DAMAGE],
                         ids=[c[0] for c in REPLAY_DAMAGE])  # fmt: skip
def test_replay_of_a_damaged_run_is_one_line(file, damage, named, run_folder, tmp_path, capsys):
    import shutil

    folder = tmp_path / "run"
    shutil.copytree(run_folder, folder)
    if damage is None:
        (folder / file).unlink()
    else:
        (folder / file).write_bytes(damage(run_folder))
    line = refused(["replay", str(folder), "--out", str(tmp_path / "r.html")], capsys)
    assert named in line
    assert not (tmp_path / "r.html").exists()


def test_replay_of_a_good_run_works(run_folder, tmp_path, capsys):
    assert main(["replay", str(run_folder), "--out", str(tmp_path / "r.html")]) == 0
    assert (tmp_path / "r.html").stat().st_size > 1000


# ------------------------------------------------------- tree files and scenarios, fuzzed

TREE_YAML_WORDS = [
    "tree:", "trees:", "main_tree_to_execute:", "subtree_ports:", "type:", "children:",
    "name:", "ID:", "Sequence", "Fallback", "Inverter", "Repeat", "num_cycles:", "SubTree",
    "Script", "code:", "SetBlackboard", "output_key:", "value:", "Scripted", "statuses:",
    "[[1]]", "[[300]]", "Condition_Low_Energy_Level", "threshold:", "Parallel",
    "success_count:", "-1", "3", "x", "{", "}", "[", "]", ",", "\n", "  ", "- ", "&a", "*a",
    "'{t}'", "_autoremap:", "true", "1:30", "Switch2", "variable:", "case_1:", "'a < 1'", "T",
]  # fmt: skip
TREE_XML_WORDS = [
    '<root BTCPP_format="4">', "</root>", '<BehaviorTree ID="T">', "</BehaviorTree>",
    "<Sequence>", "</Sequence>", '<SubTree ID="T"/>', '<SubTree ID="U" x="{y}"/>',
    '<BehaviorTree ID="U">', '<Script code="x := 1"/>', "<Script/>", "<AlwaysSuccess/>",
    '<SetBlackboard output_key="k" value="{k}"/>', '<Repeat num_cycles="-1">', "</Repeat>",
    '<Parallel success_count="-3">', "</Parallel>", '<Scripted statuses="[[1]]"/>',
    '<Scripted statuses="[[1],[1,2]]"/>', '<Condition_Low_Energy_Level threshold="{t}"/>',
    '<Switch2 variable="{m}" case_1="a" case_2="1">', "</Switch2>",
    "<Precondition if=\"a &lt; 'b'\" else=\"FAILURE\">", "</Precondition>", "<!-- c -->",
]  # fmt: skip


@FUZZ
@given(
    st.lists(st.sampled_from(TREE_YAML_WORDS), max_size=40).map(" ".join),
    st.lists(st.sampled_from(TREE_XML_WORDS), max_size=30).map("".join),
)
def test_fuzz_tree_files(yaml_text, xml_text):
    from pyautonomousagent.bt.files import from_text_format
    from pyautonomousagent.bt.leaf import LeafError
    from pyautonomousagent.bt.spec import TreeError

    for text, fmt in ((yaml_text, "yaml"), (xml_text, "xml")):
        try:
            from_text_format(text, fmt)
        except (TreeError, LeafError) as error:
            assert "\n" not in str(error)


SCENARIO_KEYS = ["agents", "iterations", "world", "parameters", "model", "mission", "tree", "x8",
                 "initial_heading", "frame_every", "name"]  # fmt: skip


@FUZZ
@given(st.dictionaries(st.sampled_from(SCENARIO_KEYS), JSONISH, max_size=3))
def test_fuzz_scenario_mappings(change):
    import yaml

    from pyautonomousagent.scenarios import SCENARIOS
    from pyautonomousagent.simulation import Scenario, ScenarioError

    base = yaml.safe_load(SCENARIOS.get("patrol").read_text())
    try:
        Scenario.from_mapping({**base, **change}, source="f.yaml")
    except ScenarioError as error:
        assert "\n" not in str(error)
