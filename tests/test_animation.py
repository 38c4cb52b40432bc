"""Phase 7: the Fig. 5 frames and the streamed GIF."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from pyautonomousagent.render.animation import (
    DRONE_COLOUR,
    FIGSIZE,
    HEADING_COLOUR,
    MAX_LABELLED,
    FramePainter,
    draw_frame,
    frame_rows,
    write_animation,
)
from pyautonomousagent.render.gif import Palette, colour_codes
from pyautonomousagent.render.panel import panel_rows
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation


@pytest.fixture(scope="module")
def run() -> Simulation:
    """200 iterations of the gathering scenario, every iteration recorded."""
    return Simulation.create(load("gathering").with_overrides(iterations=200), seed=0).run(
        progress=False
    )


@pytest.fixture(scope="module")
def gif(run: Simulation, tmp_path_factory: pytest.TempPathFactory):
    path = tmp_path_factory.mktemp("gif") / "run.gif"
    return write_animation(run.recorder, run.scenario, path, frame_every=10, progress=False)


def rgb(hex_colour: str) -> np.ndarray:
    return np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)])


def near(image: Image.Image, painter: FramePainter, x: float, y: float, colour: str) -> bool:
    """Whether a pixel within 2 px of world point (x, y) has ``colour`` (within 40 per channel)."""
    px, py = painter.axes.transData.transform((x, y))
    column, row = int(round(px)), int(round(image.height - py))
    patch = np.asarray(image)[row - 2 : row + 3, column - 2 : column + 3].reshape(-1, 3).astype(int)
    return bool((np.abs(patch - rgb(colour)).max(axis=1) <= 40).any())


def test_gif_is_a_looping_animation_with_one_frame_per_ten_iterations(gif, run):
    with Image.open(gif.path) as image:
        assert image.format == "GIF"
        assert image.n_frames == gif.frames == len(range(0, 201, 10)) == 21
        assert image.info["loop"] == 0
        assert image.info["duration"] == 50
        assert image.size == (int(FIGSIZE[0] * 80), int(FIGSIZE[1] * 80))
    assert gif.bytes == gif.path.stat().st_size > 0
    assert gif.path.read_bytes()[:6] == b"GIF89a" and gif.path.read_bytes()[-1:] == b";"


def test_gif_frames_change_and_match_the_drawn_frames(gif, run):
    with Image.open(gif.path) as image:
        frames = []
        for index in (0, 1, image.n_frames - 1):
            image.seek(index)
            frames.append(np.asarray(image.convert("RGB"), dtype=int))
    assert (frames[0] != frames[1]).any()
    assert (frames[0] != frames[2]).sum() > 100  # the drones moved
    last = np.asarray(draw_frame(run.recorder, run.scenario, 200), dtype=int)
    assert np.abs(frames[2] - last).mean() < 0.5  # cropped frames are placed right
    assert (frames[2][:5, :5] == 255).all()  # the one colour table keeps white white


def test_palette_keeps_flat_colours_and_maps_others_to_the_nearest():
    pixels = np.zeros((20, 30, 3), dtype=np.uint8)
    pixels[:] = (255, 255, 255)
    pixels[5:9, 5:9] = rgb(DRONE_COLOUR)
    pixels[0, :20] = np.arange(20)[:, None] * 12  # a grey ramp
    palette = Palette(pixels)
    decoded = palette.rgb[palette.indices(colour_codes(pixels))]
    assert np.array_equal(decoded[1:], pixels[1:])
    unseen = np.array([[[250, 252, 251], [10, 50, 110]]], dtype=np.uint8)
    mapped = palette.rgb[palette.indices(colour_codes(unseen))]
    assert mapped.tolist() == [[[255, 255, 255], list(rgb(DRONE_COLOUR))]]


def test_drone_one_is_drawn_where_it_is_and_heads_where_it_heads(run):
    painter = FramePainter(run.recorder, run.scenario)
    x, y, heading = (run.recorder.column(k)[150, 0] for k in ("x", "y", "heading"))
    image = painter.draw(150)
    assert near(image, painter, x, y, DRONE_COLOUR)
    r = painter.radius
    h = np.radians(heading)
    assert near(image, painter, x + r * np.sin(h), y + r * np.cos(h), HEADING_COLOUR)
    behind = x - 1.1 * r * np.sin(h), y - 1.1 * r * np.cos(h)
    assert not near(image, painter, *behind, HEADING_COLOUR)
    assert not near(image, painter, 90.0, 10.0, DRONE_COLOUR)  # an empty corner


def test_blitting_leaves_nothing_of_the_previous_frame(run):
    painter = FramePainter(run.recorder, run.scenario)
    painter.draw(0)
    again = np.asarray(painter.draw(200))
    fresh = np.asarray(draw_frame(run.recorder, run.scenario, 200))
    assert np.array_equal(again, fresh)


def test_draw_frame_rejects_rows_outside_the_records(run):
    with pytest.raises(IndexError):
        draw_frame(run.recorder, run.scenario, run.recorder.count)


def marks_of(scenario, legend: str) -> list[tuple[str, float, float]]:
    """(label, x, y) of the mission's marks with that legend."""
    marks = scenario.create_mission().marks()
    return [(m.label, m.x, m.y) for m in marks if m.legend == legend]


def test_static_marks_are_the_missions(run):
    slots = [(20, 65), (20, 55), (20, 45), (20, 35)]
    assert marks_of(run.scenario, "refuelling slot") == [
        (f"R{i}", x, y) for i, (x, y) in enumerate(slots, start=1)
    ]
    points = [(50, 50), (70, 80), (40, 70), (60, 25)]
    assert marks_of(run.scenario, "surveillance position") == [
        (f"S{i}", x, y) for i, (x, y) in enumerate(points, start=1)
    ]


def test_patrol_marks_its_two_positions_and_many_drones_go_unlabelled():
    scenario = load("patrol").with_overrides(agents=MAX_LABELLED + 1, iterations=5)
    sim = Simulation.create(scenario, seed=0).run(progress=False)
    assert marks_of(scenario, "surveillance position") == [("S1", 70, 80), ("S2", 70, 20)]
    assert marks_of(scenario, "refuelling slot") == [("R1", 10, 50)]
    assert not FramePainter(sim.recorder, scenario).labelled


def test_panel_shows_the_iteration_and_followed_drone_with_fixed_labels_and_units(run):
    first, later = panel_rows(run.recorder, 0, 1), panel_rows(run.recorder, 150, 1)
    assert [label for label, _ in first] == [label for label, _ in later]
    assert later[0] == ("Iteration", "150 of 200")
    assert later[1] == ("Following", "drone2")
    values = dict(later)
    assert values["  leaf ticks so far"] == str(run.recorder.column("number_ticks")[150, 1])
    assert values["  energy [%]"] == f"{run.recorder.column('energy')[150, 1]:.2f}"
    x, y = (run.recorder.column(k)[150, 1] for k in ("x", "y"))
    assert values["  position [u]"] == f"({x:.2f}, {y:.2f})"
    leaf = run.recorder.nodes[run.recorder.behaviour[150, 1]].name
    assert later[later.index(("Active behaviour (leaf)", "")) + 1] == ("", leaf)


def fake(iterations: list[int]) -> SimpleNamespace:
    return SimpleNamespace(iterations=np.array(iterations), count=len(iterations))


def test_frame_rows_one_per_window_even_when_recording_was_decimated():
    assert list(frame_rows(fake(list(range(31))), 10)) == [0, 10, 20, 30]
    every_third = list(range(0, 61, 3))
    chosen = [every_third[i] for i in frame_rows(fake(every_third), 10)]
    assert chosen == [0, 12, 21, 30, 42, 51, 60]
    assert list(frame_rows(fake([0, 20, 40]), 10)) == [0, 1, 2]
    with pytest.raises(ValueError):
        frame_rows(fake([0]), 0)


def test_importing_the_module_does_not_import_matplotlib():
    code = "import sys, pyautonomousagent.render.animation; print('matplotlib' in sys.modules)"
    result = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=Path(__file__).parent,
    )
    assert result.stdout.strip() == "False"


def overlap(a, b) -> bool:
    return not (a[3] <= b[1] or a[1] >= b[3] or a[4] <= b[2] or a[2] >= b[4])


def test_labels_of_bunched_agents_do_not_pile_up(run):
    scenario = load("patrol").with_overrides(agents=10, iterations=1)
    sim = Simulation.create(scenario, seed=0).run(progress=False)  # all ten on one slot
    boxes = FramePainter(sim.recorder, scenario).label_boxes(0)
    assert 1 <= len(boxes) < 10
    assert not any(overlap(a, b) for k, a in enumerate(boxes) for b in boxes[k + 1 :])
    apart = FramePainter(run.recorder, run.scenario).label_boxes(150)
    assert [b[0] for b in apart] == [0, 1, 2, 3]  # drones apart: every one labelled


def test_events_are_marked_while_recent_and_the_inset_shows_the_followed_statuses(run):
    from pyautonomousagent.bt.status import COLOURS
    from pyautonomousagent.render.animation import EVENT_SHOWN

    order = {"iteration": 100, "event": "message", "type": "gathering", "sender": "drone1",
             "receivers": "all", "data": {"x": 90.0, "y": 10.0}}  # fmt: skip
    painter = FramePainter(run.recorder, run.scenario, events=[order], follow="drone3", inset=True)
    assert painter.size == (int((FIGSIZE[0] + 3.4) * 80), int(FIGSIZE[1] * 80))
    colour = painter.events[0].colour
    assert max(1, round(EVENT_SHOWN * 200)) == painter.event_window == 8
    assert near(painter.draw(104), painter, 90.0, 10.0, colour)
    assert not near(painter.draw(99), painter, 90.0, 10.0, colour)
    assert not near(painter.draw(120), painter, 90.0, 10.0, colour)
    pixels = painter.render(150)
    statuses = run.recorder.trace("drone3")[150]
    for (x, y), code in zip(painter.inset_boxes, statuses, strict=False):
        assert tuple(pixels[y + 2, x + 2, :3]) == tuple(rgb(COLOURS[int(code)])), (x, y)


def text_right_edge(painter: FramePainter, left: int, top: int, text: str) -> float:
    """Where Matplotlib's renderer ends ``text`` in the panel's font drawn at (left, top)
    (pixels from the frame's top-left): pixels from the frame's left."""
    figure = painter.figure
    width, height = figure.bbox.width, figure.bbox.height
    artist = figure.text(left / width, 1 - top / height, text, family="monospace", fontsize=9,
                         va="top", ha="left")  # fmt: skip
    try:
        return float(artist.get_window_extent(painter.canvas.get_renderer()).x1)
    finally:
        artist.remove()


@pytest.mark.parametrize("inset", [False, True])
def test_long_panel_values_are_drawn_whole_inside_the_frame(inset):
    scenario = load("patrol-3d").with_overrides(agents=2, iterations=20)  # 3-D points
    sim = Simulation.create(scenario, seed=0, trace=inset).run(progress=False)
    columns = sim.recorder.columns
    columns["x"][:, 0] = np.linspace(0.0, -123456789.125, columns["x"].shape[0])
    columns["energy"][5, 0] = np.nan
    painter = FramePainter(sim.recorder, scenario, inset=inset)
    right = painter.inset_left if inset else painter.size[0]
    assert painter.size[0] > FIGSIZE[0] * 80 + (272 if inset else 0)  # wider for the values
    assert painter.size[0] % 2 == 0  # an MP4 frame's width too
    for row in (0, 5, sim.recorder.count - 1):
        shown = painter.panel_values(row)
        assert [text for _, _, text in shown] == [v for _, v in panel_rows(sim.recorder, row)]
        for left, top, text in shown:
            if text:
                assert painter.panel_left <= left
                assert text_right_edge(painter, left, top, text) <= right, (row, text)
    values = dict(panel_rows(sim.recorder, sim.recorder.count - 1))
    assert values["  position [u]"].startswith("(-123456789.12, ")  # whole, not cut


def test_a_frame_whose_values_fit_keeps_its_size_at_any_resolution(run):
    assert FramePainter(run.recorder, run.scenario).size == (800, 480)
    wide = load("patrol-3d").with_overrides(agents=2, iterations=5)
    sim = Simulation.create(wide, seed=0).run(progress=False)
    for dpi in (50, 72, 80, 100):
        painter = FramePainter(sim.recorder, wide, dpi=dpi)
        assert painter.size[0] % 2 == 0 and painter.size[0] >= FIGSIZE[0] * dpi
        shown = painter.panel_values(0)
        assert max(text_right_edge(painter, *value) for value in shown) <= painter.size[0]
