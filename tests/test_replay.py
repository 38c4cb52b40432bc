"""replay.html's data, pyaa run's outputs (data, GIF, replay, MP4) and pyaa replay."""

from __future__ import annotations

import base64
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pyautonomousagent.cli import main
from pyautonomousagent.render.animation import frame_rows
from pyautonomousagent.render.replay import MAX_AGENT_FRAMES, replay_data, replay_rows
from pyautonomousagent.runs import RunError, verify
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation


def page_data(path: Path) -> dict:
    """The JSON inside a replay page."""
    text = path.read_text()
    script = r'<script type="application/json" id="replay-data">(.*?)</script>'
    found = re.search(script, text, re.S)
    assert found, "no replay data in the page"
    return json.loads(found.group(1))


def decode(b64: str, dtype: str, shape: tuple[int, ...]) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype=dtype).reshape(shape)


@pytest.fixture(scope="module")
def run() -> Simulation:
    scenario = load("gathering").with_overrides(iterations=400)
    return Simulation.create(scenario, seed=0, trace="drone2,drone4").run(progress=False)


def test_replay_arrays_hold_the_recorded_positions_statuses_and_values(run):
    events = [{"iteration": 123, "event": "alert", "agent": "drone3", "message": "test"}]
    data = replay_data(run.recorder, run.scenario.world, "gathering", [], events, max_frames=50)
    recorder = run.recorder
    rows = replay_rows(recorder, 50, [123])
    assert data["iterations"] == recorder.iterations[rows].tolist()
    assert {123, 124} <= set(data["iterations"])  # the event's iteration and the next
    frames, n, k = len(rows), len(recorder.names), 2
    positions = decode(data["positions"]["data"], "<u2", (frames, n, 3)).astype(float)
    offset, step = data["positions"]["offset"], data["positions"]["step"]
    for q, key in enumerate(("x", "y", "heading")):
        shown = offset[q] + positions[:, :, q] * step[q]
        assert np.abs(shown - recorder.columns[key][rows]).max() <= step[q] / 2 + 1e-9
    statuses = decode(data["statuses"], "i1", (frames, k, len(recorder.nodes)))
    np.testing.assert_array_equal(statuses[:, 0, :], recorder.trace("drone2")[rows])
    values = decode(data["values"], "<f8", (frames, k, len(data["columns"])))
    c = data["columns"].index("y_current_destination_position")
    np.testing.assert_array_equal(values[:, 1, c], recorder.columns[data["columns"][c]][rows, 3])
    b = data["columns"].index("behaviour")
    np.testing.assert_array_equal(values[:, 0, b], recorder.behaviour[rows, 1])
    assert data["events"][0]["x"] == round(float(recorder.columns["x"][123, 2]), 4)
    assert data["traced"] == [1, 3] and data["names"][1] == "drone2"


def test_replay_frames_shrink_for_large_swarms():
    from types import SimpleNamespace

    iterations = np.arange(0, 4001)
    big = SimpleNamespace(iterations=iterations, count=iterations.size, names=["a"] * 1000)
    rows = replay_rows(big, 2000)
    assert len(rows) * 1000 <= MAX_AGENT_FRAMES + 1000
    assert rows[0] == 0 and np.all(np.diff(rows) == rows[1] - rows[0])
    small = SimpleNamespace(iterations=iterations, count=iterations.size, names=["a"] * 4)
    np.testing.assert_array_equal(replay_rows(small, 2000), frame_rows(small, 3))


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli") / "gathering"
    args = ["run", "gathering", "--iterations", "200", "--out", str(out), "--quiet"]
    assert main([*args, "--follow", "drone3", "--inset", "--btlog", "drone3"]) == 0
    return out


def test_pyaa_run_gathering_writes_data_gif_and_replay(cli_run):
    from PIL import Image

    names = sorted(p.name for p in cli_run.iterdir())
    assert names == [
        "animation.gif", "drone3.btlog", "replay.html", "run.json", "states.parquet",
        "traces.parquet",
    ]  # fmt: skip
    with Image.open(cli_run / "animation.gif") as gif:
        assert gif.n_frames == 21  # iterations 0, 10, ..., 200
    data = page_data(cli_run / "replay.html")
    assert data["title"] == "gathering" and data["iterations"][-1] == 200
    assert [m["label"] for m in data["marks"]][:4] == ["R1", "R2", "R3", "R4"]
    summary = json.loads((cli_run / "run.json").read_text())
    assert summary["trace"]["agents"] == ["drone1", "drone2", "drone3", "drone4"]
    assert summary["trace"]["nodes"][0]["name"] == "reactive_sequence_root"


def test_pyaa_replay_rewrites_the_same_page_from_the_files(cli_run, tmp_path, capsys):
    before = page_data(cli_run / "replay.html")
    page = tmp_path / "again.html"
    assert main(["replay", str(cli_run), "--out", str(page)]) == 0
    assert page_data(page) == before
    assert main(["replay", str(tmp_path)]) == 2
    assert "no run.json" in capsys.readouterr().err


def test_pyaa_replay_into_the_run_folder_keeps_it_verifiable(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "patrol", "--agents", "3", "--iterations", "60", "--no-gif",
                 "--no-replay", "--out", str(out), "--quiet"]) == 0  # fmt: skip
    assert main(["replay", str(out), "--btlog", "drone2"]) == 0
    summary = verify(out)  # every file listed, with its hash: the new ones too
    assert {"replay.html", "drone2.btlog"} <= {f["name"] for f in summary["files"]}
    (out / "replay.html").write_text("changed")
    with pytest.raises(RunError, match="replay.html differs"):
        verify(out)


def test_video_mp4_has_the_expected_frame_count(tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="the [video] extra")
    out = tmp_path / "mp4"
    args = ["run", "gathering", "--iterations", "150", "--video", "mp4", "--no-replay"]
    assert main([*args, "--out", str(out), "--quiet"]) == 0
    reader = imageio_ffmpeg.read_frames(str(out / "animation.mp4"))
    meta = next(reader)
    frames = sum(1 for _ in reader)
    assert frames == 16  # iterations 0, 10, ..., 150
    assert tuple(meta["size"]) == (800, 480) and meta["fps"] == 20


def test_vacuum_replay_shows_the_cleaned_area_as_it_grows():
    """The mission's changing marks (vacuum's cleaned cells) are in the page once each, with
    the frames where they show; at every frame they are the mission's marks of that record."""
    sim = Simulation.create(load("vacuum").with_overrides(iterations=400), seed=2).run(
        progress=False
    )
    mission = sim.scenario.create_mission()
    rec = sim.recorder
    data = replay_data(
        rec, sim.scenario.world, "vacuum", frame_marks=lambda row: mission.frame_marks(rec, row)
    )
    rows = np.searchsorted(rec.iterations[: rec.count], data["iterations"])
    check = sim.scenario.create_mission()  # a second instance: no shared replay state
    counts = []
    for frame, row in enumerate(rows.tolist()):
        shown = {
            (m["x"], m["y"])
            for m in data["changing_marks"]
            if any(a <= frame <= b for a, b in m["frames"])
        }
        expected = {(m.x, m.y) for m in check.frame_marks(rec, row)}
        assert shown == expected, frame
        counts.append(len(shown))
    assert counts[0] == 0 and counts[-1] > 10
    assert counts == sorted(counts)  # the cleaned area only grows
    assert len(data["changing_marks"]) == counts[-1]  # each cell once: one interval


CHANGING_MARKS = """
import hashlib, json
from pyautonomousagent.render.replay import replay_data
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation
sim = Simulation.create(load("vacuum").with_overrides(iterations=150), seed=2).run(progress=False)
mission, rec = sim.scenario.create_mission(), sim.recorder
marks = lambda r: mission.frame_marks(rec, r)
data = replay_data(rec, sim.scenario.world, "vacuum", frame_marks=marks)
print(hashlib.sha256(json.dumps(data["changing_marks"]).encode()).hexdigest())
"""


def test_the_changing_marks_are_in_the_same_order_in_every_process():
    """Python salts its string hashes per process (``PYTHONHASHSEED``): the replay's marks must
    not come out in a set's order, or one run would give a different replay.html each time."""
    src = str(Path(__file__).resolve().parents[1] / "src")
    digests = set()
    for seed in ("1", "2", "3"):
        env = {**os.environ, "PYTHONHASHSEED": seed, "PYTHONPATH": src}
        done = subprocess.run(
            [sys.executable, "-c", CHANGING_MARKS], env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr[-2000:]
        digests.add(done.stdout.strip())
    assert len(digests) == 1, digests
