"""The studio's server through its HTTP API, no browser: the palette, the tree checks (the
file loader's messages), bad input refused with nothing written, the live run's statuses
against the recorded trace, and a saved run equal to ``pyaa run --tree SAVED.xml``."""

from __future__ import annotations

import json
import math
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.document import TreeFileError
from pyautonomousagent.bt.files import load_tree
from pyautonomousagent.bt.vocabulary import tags
from pyautonomousagent.cli import main
from pyautonomousagent.inputs import MAX_FILE_BYTES
from pyautonomousagent.recording import read_table
from pyautonomousagent.scenarios import names
from pyautonomousagent.simulation.fit import fitting_leaves
from pyautonomousagent.studio import Studio
from pyautonomousagent.studio.server import scenario_blocks
from pyautonomousagent.studio.session import Session
from pyautonomousagent.studio.trees import plain, to_document

ITERATIONS = 300
"""Iterations of the runs saved here (the browser test runs the whole 8000)."""


class Client:
    """JSON calls to a running studio."""

    def __init__(self, studio: Studio) -> None:
        self.base = studio.url.rstrip("/")

    def call(self, path: str, data: Any = None, raw: bytes | None = None) -> tuple[int, Any]:
        body = raw if raw is not None else None if data is None else json.dumps(data).encode()
        request = urllib.request.Request(self.base + path, data=body)
        try:
            with urllib.request.urlopen(request, timeout=120) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as error:
            return error.code, json.loads(error.read())

    def ok(self, path: str, data: Any = None, raw: bytes | None = None) -> Any:
        status, answer = self.call(path, data, raw)
        assert status == 200, answer
        return answer


@pytest.fixture
def client(studio: Studio) -> Client:
    return Client(studio)


def files_in(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def decorator_with_two_children(info: dict[str, Any]) -> dict[str, Any]:
    tree = json.loads(json.dumps(info["tree"]))
    fallback = tree["children"][1]["children"][1]["children"][2]
    fallback["type"] = "Inverter"  # Fallback_refueling has two children
    return tree


def test_palette_is_built_from_the_registries(client: Client) -> None:
    info = client.ok("/api/info")
    assert [c["type"] for c in info["palette"]["controls"]] == [t.tag for t in tags()]
    fits = [cls.type_name for cls in fitting_leaves(load("gathering"))]
    leaves = {leaf["type"]: leaf for leaf in info["palette"]["leaves"]}
    assert list(leaves) == fits
    low = leaves["Condition_Low_Energy_Level"]
    assert low["doc"].startswith("SUCCESS if the energy level")
    assert low["ports"][0]["name"] == "threshold" and low["ports"][0]["value"] == 40.0
    assert low["name"] == "condition_low_energy_level"  # a new block's name: the loader's
    controls = {c["type"]: c for c in info["palette"]["controls"]}
    assert controls["ReactiveSequence"]["name"] == "reactive_sequence"
    names = [p["name"] for p in info["schema"]["parameters"]]
    assert "low_energy_threshold" in names
    energy = next(p for p in info["schema"]["parameters"] if p["name"] == "energy_use")
    assert energy["unit"] == "percent per iteration"
    assert (energy["minimum"], energy["maximum"]) == (0, 100)


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        (None, None),
        (True, True),
        (3, 3),
        (2.5, 2.5),
        ("text", "text"),
        (np.bool_(True), True),
        (np.int64(7), 7),
        (np.float32(0.5), 0.5),
        (math.nan, "nan"),
        (np.float64(-math.inf), "-inf"),
        ((1, 2), "(1, 2)"),
    ],
)
def test_a_value_is_sent_as_json_has_it(value: Any, shown: Any) -> None:
    """The palette's port values and the followed agent's blackboard: NumPy scalars as
    Python's (same type), NaN and infinities as text (JSON has none), other things as text."""
    got = plain(value)
    assert got == shown and type(got) is type(shown)
    json.dumps(got, allow_nan=False)


def test_the_scenarios_tree_can_run(client: Client) -> None:
    info = client.ok("/api/info")
    assert client.ok("/api/tree", {"tree": info["tree"]}) == {"ok": True, "error": "", "block": -1}


def test_an_invalid_tree_gets_the_loaders_message_and_cannot_run(
    client: Client, tmp_path: Path
) -> None:
    info = client.ok("/api/info")
    tree = decorator_with_two_children(info)
    answer = client.ok("/api/tree", {"tree": tree})
    assert not answer["ok"] and answer["block"] == 9  # depth first: the Inverter
    path = tmp_path / "bad.xml"
    path.write_text(_xml(tree), encoding="utf-8")
    with pytest.raises(TreeFileError) as raised:
        load_tree(path)
    assert raised.value.message in answer["error"] and raised.value.fix in answer["error"]
    status, refused = client.call("/api/control", {"action": "play"})
    assert status == 400 and "cannot run" in refused["error"]
    assert client.call("/api/control", {"action": "step"})[0] == 400


def _xml(tree: dict[str, Any]) -> str:
    """The tree of blocks as an XML file's text, for the file loader."""
    from pyautonomousagent.bt.xml_format import write_xml

    document = to_document({"type": "Sequence", "children": [{"type": "AlwaysSuccess"}]})
    document.trees[document.main] = to_raw(tree)
    return write_xml(document, ())


def to_raw(block: dict[str, Any]) -> Any:
    from pyautonomousagent.bt.document import RawNode

    children = [to_raw(child) for child in block["children"]]
    return RawNode(block["type"], 0, block["name"], dict(block["ports"]), children)


def test_an_unknown_port_is_flagged_on_its_block(client: Client) -> None:
    info = client.ok("/api/info")
    tree = info["tree"]
    tree["children"][0]["ports"]["bogus"] = "1"
    answer = client.ok("/api/tree", {"tree": tree})
    assert answer["block"] == 1 and "has no port 'bogus'" in answer["error"]


def test_node_names_are_kept_checked_and_saved(client: Client, tmp_path: Path) -> None:
    info = client.ok("/api/info")
    tree = info["tree"]
    packaged = [node.name for node in load_tree(load("gathering").tree).walk()]
    assert _names(tree) == packaged  # the scenario's tree keeps its file's names
    tree["children"][0]["name"] = "share"
    assert client.ok("/api/tree", {"tree": tree})["ok"]
    client.ok("/api/save-tree", {"name": "named", "format": "yaml"})
    assert [n.name for n in load_tree(tmp_path / "named.yaml").walk()][1] == "share"
    tree["children"][0]["name"] = "two\nlines"
    answer = client.ok("/api/tree", {"tree": tree})
    assert not answer["ok"] and answer["block"] == 1 and "one line" in answer["error"]
    tree["children"][0]["name"] = "reactive_fallback_behaviours"
    answer = client.ok("/api/tree", {"tree": tree})
    assert not answer["ok"] and answer["block"] == 2  # the second of the two, by its line
    assert "two nodes are named 'reactive_fallback_behaviours'" in answer["error"]


def _names(block: dict[str, Any]) -> list[str]:
    return [block["name"], *(n for child in block["children"] for n in _names(child))]


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;">]>
<root BTCPP_format="4"><BehaviorTree ID="T"><Sequence name="&lol2;"/></BehaviorTree></root>
"""


@pytest.mark.parametrize(
    ("path", "payload", "words"),
    [
        ("/api/upload?name=big.xml", b"<!--" + b"x" * MAX_FILE_BYTES + b"-->", "larger than"),
        ("/api/upload?name=lol.xml", BILLION_LAUGHS.encode(), "<!DOCTYPE"),
        ("/api/upload?name=tree.txt", b"<root/>", "must end in .xml, .yaml or .yml"),
        ("/api/settings", b'{"parameters": {"energy_use": NaN}}', "NaN is not a number"),
        ("/api/settings", b'{"parameters": {"energy_use": "NaN"}}', "finite number"),
        ("/api/settings", b'{"agents": 0}', "agents must be a whole number >= 1"),
        ("/api/settings", b'{"seed": -1}', "seed must be a whole number >= 0"),
        ("/api/save-tree", b'{"name": "../outside", "format": "xml"}', "a name is"),
        ("/api/save-run", b'{"name": "/etc"}', "a name is"),
    ],
)
def test_bad_input_gets_a_clear_message_and_writes_nothing(
    client: Client, tmp_path: Path, path: str, payload: bytes, words: str
) -> None:
    before = files_in(tmp_path)
    status, answer = client.call(path, raw=payload)
    assert status in (400, 413), answer
    assert words in answer["error"]
    assert "Traceback" not in answer["error"]
    assert files_in(tmp_path) == before
    assert client.ok("/api/info")  # still serving


def test_an_uploaded_tree_comes_back_as_blocks(client: Client) -> None:
    text = Path(load("gathering").tree).read_bytes()
    tree = client.ok("/api/upload?name=gathering.xml", raw=text)["tree"]
    assert tree["type"] == "ReactiveSequence" and len(tree["children"]) == 2
    assert client.ok("/api/tree", {"tree": tree})["ok"]


def test_paused_statuses_equal_the_recorded_trace(client: Client) -> None:
    info = client.ok("/api/info")
    client.ok("/api/tree", {"tree": info["tree"]})
    client.ok("/api/control", {"action": "step", "steps": 4321})
    frame = client.ok("/api/frame?follow=1")
    assert frame["iteration"] == 4321
    sim = Simulation.create(load("gathering"), seed=0, tree=load_tree(load("gathering").tree))
    sim.run(progress=False, iterations=4321)
    names = {0: "invalid", 1: "success", 2: "failure", 3: "running"}
    assert frame["follow"]["statuses"] == [names[int(c)] for c in sim.recorder.trace(1)[-1]]
    assert frame["follow"]["agent"] == "drone2"
    board = frame["follow"]["blackboard"]
    assert board["number_ticks"] == int(sim.swarm.blackboard["number_ticks"][1]) > 0
    assert frame["active"][0] == 4  # every drone has the root active
    assert frame["x"] == [round(float(v), 3) for v in sim.swarm.columns["x"]]
    energy = sim.swarm.columns["energy"]
    assert frame["energy"] == {"mean": round(float(energy.mean()), 3),
                               "low": round(float(energy.min()), 3)}  # fmt: skip


def test_play_and_pause(client: Client) -> None:
    import time

    info = client.ok("/api/info")
    client.ok("/api/tree", {"tree": info["tree"]})
    assert client.ok("/api/control", {"action": "play", "speed": 2000})["playing"]
    time.sleep(1.0)
    client.ok("/api/control", {"action": "pause"})
    reached = client.ok("/api/frame")["iteration"]
    time.sleep(0.3)
    assert 0 < reached == client.ok("/api/frame")["iteration"]
    client.ok("/api/control", {"action": "reset"})
    assert client.ok("/api/frame")["iteration"] == 0


def test_a_change_of_tree_or_parameter_during_a_run_offers_reset(client: Client) -> None:
    info = client.ok("/api/info")
    client.ok("/api/tree", {"tree": info["tree"]})
    client.ok("/api/control", {"action": "step", "steps": 50})
    renamed = json.loads(json.dumps(info["tree"]))
    renamed["children"][0]["name"] = "share"
    assert client.ok("/api/tree", {"tree": renamed})["ok"]
    frame = client.ok("/api/frame")
    assert frame["iteration"] == 50 and frame["stale"] == "the tree changed during this run"
    for action in ("play", "step"):
        status, refused = client.call("/api/control", {"action": action})
        assert status == 400 and "Reset runs the new one" in refused["error"]
    client.ok("/api/tree", {"tree": info["tree"]})  # undone: the run is current again
    client.ok("/api/control", {"action": "step"})
    frame = client.ok("/api/frame")
    assert (frame["iteration"], frame["stale"]) == (51, "")
    answer = client.ok("/api/settings", {"parameters": {"energy_use": 0.3}})
    assert answer["stale"] == "the parameters changed during this run"
    assert client.call("/api/control", {"action": "step"})[0] == 400
    client.ok("/api/control", {"action": "reset"})
    frame = client.ok("/api/frame")
    assert (frame["iteration"], frame["stale"]) == (0, "")
    client.ok("/api/tree", {"tree": renamed})  # at iteration 0 the new tree simply runs
    assert client.ok("/api/frame")["stale"] == ""
    client.ok("/api/control", {"action": "step"})
    assert client.ok("/api/frame?follow=0")["nodes"][1]["name"] == "share"


def test_a_saved_run_equals_pyaa_run_of_the_saved_tree(client: Client, tmp_path: Path) -> None:
    info = client.ok("/api/info")
    client.ok("/api/settings", {"iterations": ITERATIONS, "seed": 3})
    client.ok("/api/tree", {"tree": info["tree"]})
    saved = client.ok("/api/save-run", {"name": "mine"})
    assert saved["status"] == "complete" and saved["folder"] == "runs/mine"
    tree = tmp_path / "mine.xml"
    assert tree.is_file() and saved["tree"] == "mine.xml"
    summary = json.loads((tmp_path / "runs/mine/run.json").read_text())
    assert summary["command"][:3] == ["pyaa", "studio", "gathering"]
    assert summary["tree"]["content"] == tree.read_text()
    out = tmp_path / "cli"
    args = ["run", "gathering", "--tree", str(tree), "--seed", "3"]
    assert main([*args, "--iterations", str(ITERATIONS), "--out", str(out), "--quiet"]) == 0
    studio_states = read_table(tmp_path / "runs/mine/states.parquet")
    assert studio_states.equals(read_table(out / "states.parquet"))
    assert main(["verify", str(tmp_path / "runs/mine")]) == 0


def test_a_saved_tree_loads_in_pyaa(client: Client, tmp_path: Path) -> None:
    info = client.ok("/api/info")
    client.ok("/api/tree", {"tree": info["tree"]})
    assert client.ok("/api/save-tree", {"name": "t", "format": "yaml"}) == {"file": "t.yaml"}
    assert client.ok("/api/save-tree", {"name": "t", "format": "xml"}) == {"file": "t.xml"}
    assert load_tree(tmp_path / "t.yaml") == load_tree(tmp_path / "t.xml")
    assert load_tree(tmp_path / "t.xml") == load_tree(load("gathering").tree)


def test_pyaa_studio_without_a_bundle_says_how_to_build_it(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import pyautonomousagent.studio as studio

    monkeypatch.setattr(studio, "has_bundle", lambda: False)
    assert main(["studio", "gathering", "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "npm run build" in err


def test_a_notebook_cell_shows_the_studio(tmp_path: Path) -> None:
    studio = Studio("gathering", tmp_path)
    try:
        html = studio._repr_html_()
        assert f'<iframe src="{studio.url}"' in html
        assert f'<a href="{studio.url}" target="_blank"' in html  # a tab of its own
        assert repr(studio) == f"Studio('gathering') at {studio.url}"
        with urllib.request.urlopen(studio.url, timeout=30) as page:
            assert b"/static/studio.js" in page.read()
    finally:
        studio.shutdown()


def test_without_the_front_end_a_notebook_cell_says_how_to_build_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pyautonomousagent.studio import server

    monkeypatch.setattr(server, "has_bundle", lambda: False)
    studio = Studio("gathering", tmp_path)
    html = studio._repr_html_()
    assert "front-end is not built" in html and "npm run build" in html
    assert "<iframe" not in html and studio._thread is None  # not served


def test_another_sites_page_cannot_change_anything(studio: Studio, tmp_path: Path) -> None:
    body = json.dumps({"name": "x", "format": "xml"}).encode()
    for header, value in (("Origin", "http://example.com"), ("Host", "evil.example:80")):
        request = urllib.request.Request(studio.url + "api/save-tree", data=body)
        request.add_header(header, value)
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(request, timeout=30)
        assert refused.value.code == 403
    assert list(tmp_path.iterdir()) == []


def _events_of(scenario: Any, iterations: int) -> list[dict[str, Any]]:
    """The events of an independent run of ``scenario`` (seed 0) to ``iterations``."""
    sim = Simulation.create(scenario, seed=0)
    sim.run(progress=False, iterations=iterations)
    return sim.events


@pytest.mark.parametrize(
    ("name", "overrides", "steps", "measures"),
    [
        ("gathering", {"energy_use": 1.0}, 150, {"alerts": 4, "messages": 0}),
        ("crowded", {}, 600, None),
        ("patrol", {}, 50, {"alerts": 0}),
    ],
)
def test_the_measures_plot_counts_the_runs_events(
    tmp_path: Path, name: str, overrides: dict[str, Any], steps: int, measures: Any
) -> None:
    session = Session(name, tmp_path)
    session.configure({"parameters": overrides})
    session.set_tree(scenario_blocks(session))
    session.advance(steps // 2)
    session.frame()  # the events so far are read once; the rest on the next frame
    session.advance(steps - steps // 2)
    frame = session.frame()
    events = _events_of(session.scenario, steps)
    kinds = {"alerts": "alert", "collisions": "collision", "messages": "message"}
    counted = {k: sum(e["event"] == kind for e in events) for k, kind in kinds.items()}
    assert frame["measures"] == {k: counted[k] for k in frame["measures"]}
    if measures is not None:
        assert frame["measures"] == measures
    else:  # crowded: collisions are reported, and happen
        assert list(frame["measures"]) == ["alerts", "collisions"]
        assert frame["measures"]["collisions"] > 0
    window = session.feed.window  # type: ignore[union-attr]
    recent = [e for e in events if e["iteration"] > steps - window][-50:]
    assert [e["iteration"] for e in frame["events"]] == [e["iteration"] for e in recent]
    json.dumps(frame, allow_nan=False)


@pytest.mark.parametrize("reach", [1000.0, 25.0])
def test_a_message_is_drawn_to_the_receivers_in_its_range(tmp_path: Path, reach: float) -> None:
    session = Session("gathering", tmp_path)
    session.configure({"parameters": {"datalink_range": reach}})
    session.set_tree(scenario_blocks(session))
    session.advance(5003)
    message = [e for e in session.frame()["events"] if e["kind"] == "message"]
    assert len(message) == 1 and message[0]["iteration"] == 5000
    assert message[0]["text"] == "gathering message from drone1 to all"
    sim = Simulation.create(session.scenario, seed=0)
    sim.run(progress=False, iterations=5000)
    x, y = sim.swarm.columns["x"], sim.swarm.columns["y"]
    near = [k for k in range(1, 4) if math.hypot(x[k] - x[0], y[k] - y[0]) <= reach]
    assert message[0]["from"] == [round(float(x[0]), 3), round(float(y[0]), 3)]
    assert message[0]["to"] == [[round(float(x[k]), 3), round(float(y[k]), 3)] for k in near]
    assert len(near) == (3 if reach == 1000.0 else 1)  # at 25 units: drone3 only


@pytest.mark.parametrize("name", names())
def test_every_scenario_opens_steps_and_draws(name: str, tmp_path: Path) -> None:
    session = Session(name, tmp_path)
    checked = session.set_tree(scenario_blocks(session))
    assert checked.tree is not None, checked.error
    assert session.advance(3) == 3
    frame = session.frame(0)
    json.dumps(frame, allow_nan=False)
    assert len(frame["x"]) == session.scenario.agents and frame["follow"]["statuses"]
    assert ("z" in session.sim.swarm.columns) == bool(frame["altitude"])  # type: ignore[union-attr]
    assert frame["measures"]["alerts"] == 0 and frame["stale"] == ""
    assert list(tmp_path.iterdir()) == []
