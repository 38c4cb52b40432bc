"""Every node status has its look in every view: the animation's inset, the replay, the studio
and the lessons' tick tables. A RunOnce (BehaviorTree.CPP's default ``then_skip="true"``) is
SKIPPED after its first tick; ``pyaa run --inset`` once lost its views on it (no colour for
status 4), the studio called it "invalid"."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import pyautonomousagent
from pyautonomousagent.bt.status import COLOURS, NAMES
from pyautonomousagent.cli import main
from pyautonomousagent.lessons import STATUS_COLOURS as LESSON_COLOURS
from pyautonomousagent.render.animation import FramePainter
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation
from pyautonomousagent.studio.session import STATUS_NAMES, statuses_of

PACKAGE = Path(pyautonomousagent.__file__).parent
FIRST_LEAF = '<Action_Transmit_Shared_Data_S name="action_transmit_shared_data_s"/>'


@pytest.fixture(scope="module")
def run_once_tree(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """gathering's tree with its first leaf inside a RunOnce named "once" (a Groot2 file)."""
    folder = tmp_path_factory.mktemp("tree")
    assert main(["tree", "gathering", "--format", "xml", "--out", str(folder / "g.xml")]) == 0
    text = (folder / "g.xml").read_text()
    assert text.count(FIRST_LEAF) == 1
    path = folder / "once.xml"
    path.write_text(text.replace(FIRST_LEAF, f'<RunOnce name="once">{FIRST_LEAF}</RunOnce>'))
    return path


@pytest.fixture(scope="module")
def skipping_run(run_once_tree: Path) -> Simulation:
    from pyautonomousagent.bt.files import load_tree

    scenario = load("gathering").with_overrides(iterations=60)
    sim = Simulation.create(scenario, seed=0, tree=load_tree(str(run_once_tree)), trace="drone1")
    return sim.run(progress=False)


def test_every_status_has_a_colour_a_replay_style_a_studio_style_and_a_lesson_colour():
    replay = (PACKAGE / "render" / "replay_template.html").read_text()
    studio = (PACKAGE / "studio" / "page.html").read_text()
    assert list(COLOURS) != [] and set(COLOURS) == set(NAMES)
    for code, name in NAMES.items():
        assert re.search(rf"\.s-{name} \.badge \{{ background: var\(--\w+\)", replay), name
        assert re.search(rf"\.{name.lower()} \{{ background: #[0-9a-f]{{6}}; \}}", studio), name
        assert STATUS_NAMES[code] == name.lower()
        assert re.fullmatch(r"#[0-9a-f]{6}", LESSON_COLOURS[name]), name
    assert len(set(COLOURS.values())) == len(COLOURS)  # each status its own colour


def test_the_inset_draws_a_skipped_node_in_its_own_colour(skipping_run: Simulation):
    trace = skipping_run.recorder.trace("drone1")
    once = [n.name for n in skipping_run.recorder.nodes].index("once")
    assert [NAMES[int(c)] for c in trace[:4, once]] == ["INVALID", "SUCCESS", "SKIPPED", "SKIPPED"]
    painter = FramePainter(
        skipping_run.recorder, skipping_run.scenario, follow="drone1", inset=True
    )
    pixels = painter.render(30)
    x, y = painter.inset_boxes[once]
    skipped = next(c for c, name in NAMES.items() if name == "SKIPPED")
    colour = COLOURS[skipped]
    assert tuple(pixels[y + 2, x + 2, :3]) == tuple(
        np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)], np.uint8)
    )
    assert statuses_of(skipping_run, 0)[once] == "skipped"


def test_pyaa_run_with_the_inset_writes_its_views_for_a_run_once(run_once_tree: Path, tmp_path):
    out = tmp_path / "run"
    argv = ["run", "gathering", "--tree", str(run_once_tree), "--iterations", "40",
            "--follow", "drone1", "--inset", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert (out / "animation.gif").stat().st_size > 0 and (out / "replay.html").exists()
