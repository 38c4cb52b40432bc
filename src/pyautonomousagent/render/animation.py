"""Phase 7: the paper's Fig. 5 view of a recorded run, one frame per row, streamed to a GIF.

The layout (Fig. 5): the world box ``[0, width] x [0, height]`` at equal aspect; refuelling
slots as light-blue circles labelled R1, R2, ...; surveillance positions as "x" markers
labelled S1, S2, ...; drones as dark-blue circles with a small red dot on the side they head
to and their 1-based index; beside the plot, a text panel with the first drone's state and
blackboard and the iteration number.

Speed and memory: the static background is drawn once with Matplotlib's Agg canvas (no
pyplot, no global backend) and each frame only redraws the moving artists on top of a copy of
it (blitting). :func:`write_gif` writes the GIF itself, frame by frame, with Pillow's encoder
and one fixed colour table, so it never holds more than one frame. Matplotlib and Pillow are
imported only when a frame is drawn.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from pyautonomousagent.progress import Progress
from pyautonomousagent.recording import Recorder
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation.scenario import Scenario

if TYPE_CHECKING:
    from PIL import Image

FIGSIZE = (10.0, 6.0)
"""Figure size in inches; at ``dpi`` 80 a frame is 800 x 480 pixels."""
AXES_RECT = (0.07, 0.09, 0.55, 0.84)
"""The plot's [left, bottom, width, height] in figure fractions; the panel is to its right."""
PANEL_XY = (0.66, 0.92)
"""Top-left corner of the text panel, figure fractions."""
DRONE_RADIUS = 0.015
"""A drone's radius as a fraction of the world's larger side (1.5 units in a 100 x 100 world)."""
MAX_LABELLED = 50
"""Above this many agents the drones are drawn without their index labels."""
PALETTE_COLOURS = 256
"""Colours in the GIF's single global colour table (taken from the first frame)."""
DRONE_COLOUR = "#08306b"
"""Dark blue of the drones and their index labels."""
HEADING_COLOUR = "#e31a1c"
"""Red of the heading dot."""


@dataclass(frozen=True)
class AnimationStats:
    """What :func:`write_gif` wrote.

    Attributes:
        frames: number of frames in the GIF.
        seconds: wall time of drawing and encoding, in seconds.
        path: the GIF file.
        bytes: the file's size in bytes.
    """

    frames: int
    seconds: float
    path: Path
    bytes: int


def frame_rows(recorder: Recorder, frame_every: int) -> np.ndarray:
    """The record rows drawn as frames, as an int array of row indices, ascending.

    One frame per window of ``frame_every`` iterations: the first recorded row whose
    iteration lies in ``[k * frame_every, (k + 1) * frame_every)``. With every iteration
    recorded these are exactly the rows whose iteration is a multiple of ``frame_every``; when
    the recorder was decimated so that few or no multiples were recorded, the nearest later
    rows are used instead, and when records are sparser than ``frame_every``, every row.
    """
    if frame_every < 1:
        raise ValueError(f"frame_every must be >= 1, got {frame_every}")
    window = recorder.iterations[: recorder.count] // frame_every
    first = np.ones(len(window), dtype=bool)
    first[1:] = window[1:] != window[:-1]
    return np.flatnonzero(first)


def panel_rows(recorder: Recorder, row: int) -> list[tuple[str, str]]:
    """The text panel of record ``row`` as (label, value) lines: iteration, first drone's
    state and blackboard.

    Positions in world units, speed in units per iteration (the X8: airspeed in m/s), heading
    in degrees clockwise from north, energy and damage in percent; the X8 adds its altitude (m)
    and roll (degrees). Keys that were not recorded are left out, so the labels are the same
    for every row of a run.
    """
    columns = recorder.columns

    def value(key: str, kind: type = float) -> Any:
        return kind(columns[key][row, 0]) if key in columns else None

    def point(name: str) -> str | None:
        return _format("({:6.2f}, {:6.2f})", value(f"x_{name}"), value(f"y_{name}"))

    name = recorder.names[0] if recorder.names else "agent 1"
    lines = [
        ("Iteration", f"{int(recorder.iterations[row])}"),
        ("", ""),
        (f"{name} state", ""),
        ("  position", _format("({:6.2f}, {:6.2f})", value("x"), value("y"))),
        ("  speed", _format("{:.3f}", value("speed"))),
        ("  heading", _format("{:.1f} deg", value("heading"))),
        ("  altitude", _format("{:.1f} m", value("altitude"))),
        ("  roll", _format("{:.1f} deg", value("roll"))),
        ("  energy", _format("{:.1f} %", value("energy"))),
        ("  damage", _format("{:.1f} %", value("damage"))),
        ("", ""),
        (f"{name} blackboard", ""),
        ("  ticks", _format("{}", value("number_ticks", int))),
        ("  surveillance", point("surveillance_position")),
        ("  destination", point("current_destination_position")),
        ("  patrol index", _format("{}", value("index_current_surveillance_position", int))),
    ]
    return [(label, text) for label, text in lines if text is not None]


def _format(template: str, *values: Any) -> str | None:
    """``template.format(*values)``, or None when a value is None (not recorded)."""
    return None if any(v is None for v in values) else template.format(*values)


class FramePainter:
    """Draws Fig. 5 frames of one recorded run, reusing one figure for every frame.

    The static background (world box, slots, surveillance marks, axes) is rendered once;
    :meth:`draw` restores it and redraws only the drones, their labels and the text panel.

    Args:
        recorder: the run's records (x, y and heading are required; shape (records, N)).
        scenario: the run's scenario (world size, patrol positions).
        dpi: pixels per inch; the frame is ``FIGSIZE * dpi`` pixels.
    """

    def __init__(self, recorder: Recorder, scenario: Scenario, dpi: int = 80) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        if recorder.count == 0:
            raise ValueError("the recorder holds no records to draw")
        self.recorder = recorder
        self.radius = DRONE_RADIUS * max(scenario.world)
        self.figure = Figure(figsize=FIGSIZE, dpi=dpi)
        self.canvas = FigureCanvasAgg(self.figure)
        self.axes = self.figure.add_axes(AXES_RECT, anchor="W")
        _draw_background(self.axes, scenario, self.radius)
        self._add_moving_artists(len(recorder.names))
        self._add_panel()
        self.canvas.draw()
        self._place_panel_values()
        self.background = self.canvas.copy_from_bbox(self.figure.bbox)

    @property
    def size(self) -> tuple[int, int]:
        """Frame (width, height) in pixels."""
        width, height = self.canvas.get_width_height()
        return int(width), int(height)

    def _add_moving_artists(self, agents: int) -> None:
        from matplotlib.collections import EllipseCollection

        def circles(diameter: float, colour: str) -> EllipseCollection:
            collection = EllipseCollection(
                np.full(agents, diameter),
                np.full(agents, diameter),
                np.zeros(agents),
                units="xy",
                offsets=np.zeros((agents, 2)),
                offset_transform=self.axes.transData,
                facecolors=colour,
                edgecolors="none",
                animated=True,
                zorder=3,
            )
            self.axes.add_collection(collection, autolim=False)
            return collection

        self.bodies = circles(2 * self.radius, DRONE_COLOUR)
        self.dots = circles(0.8 * self.radius, HEADING_COLOUR)
        labelled = agents <= MAX_LABELLED
        self.labels = [
            self.axes.text(
                0,
                0,
                str(i + 1),
                fontsize=8,
                color=DRONE_COLOUR,
                ha="left",
                va="bottom",
                animated=True,
                clip_on=True,
                zorder=4,
            )
            for i in range(agents if labelled else 0)
        ]

    def _add_panel(self) -> None:
        """The panel's labels (static, in the background) and values (redrawn per frame).

        Only the values are redrawn: text is the costliest thing Agg draws per frame.
        """
        labels = "\n".join(label for label, _ in panel_rows(self.recorder, 0))
        style: dict[str, Any] = {"family": "monospace", "fontsize": 10, "va": "top", "ha": "left"}
        self.panel_labels = self.figure.text(*PANEL_XY, labels, **style)
        self.panel = self.figure.text(*PANEL_XY, "", animated=True, **style)

    def _place_panel_values(self) -> None:
        """Put the values column just right of the drawn labels' longest line."""
        right = self.panel_labels.get_window_extent().x1 + self.figure.dpi / 8
        self.panel.set_x(right / self.figure.bbox.width)

    def _update(self, row: int) -> None:
        """Move the drones and rewrite the panel to record ``row``."""
        columns, r = self.recorder.columns, self.radius
        x, y = columns["x"][row], columns["y"][row]
        heading = np.radians(columns["heading"][row])
        self.bodies.set_offsets(np.column_stack([x, y]))
        self.dots.set_offsets(np.column_stack([x + r * np.sin(heading), y + r * np.cos(heading)]))
        for label, xi, yi in zip(self.labels, x, y, strict=False):
            label.set_position((xi + 0.8 * r, yi + 0.8 * r))
        self.panel.set_text("\n".join(text for _, text in panel_rows(self.recorder, row)))

    def render(self, row: int) -> np.ndarray:
        """The frame of record ``row`` (0 <= row < recorder.count) as RGBA pixels.

        Returns:
            uint8 array of shape (height, width, 4), a view of the canvas that the next
            call overwrites (copy it to keep it).
        """
        if not 0 <= row < self.recorder.count:
            raise IndexError(f"row {row} is outside the {self.recorder.count} records")
        self._update(row)
        self.canvas.restore_region(self.background)
        for artist in (self.bodies, self.dots, *self.labels):
            self.axes.draw_artist(artist)
        self.figure.draw_artist(self.panel)
        return np.asarray(self.canvas.buffer_rgba())

    def draw(self, row: int) -> Image.Image:
        """The frame of record ``row`` as an RGB image (a copy)."""
        from PIL import Image

        return Image.fromarray(np.ascontiguousarray(self.render(row)[..., :3]))


def _draw_background(axes: Any, scenario: Scenario, radius: float) -> None:
    """The static part of Fig. 5 on ``axes``: the world box and the mission's marks."""
    width, height = scenario.world
    axes.set_xlim(0, width)
    axes.set_ylim(0, height)
    axes.set_aspect("equal", adjustable="box")
    axes.set_xlabel("x")
    axes.set_ylabel("y")
    axes.set_title(f"pyAutonomousAgent: {scenario.name}", fontsize=11)
    draw_marks(axes, scenario.create_mission().marks(), radius)


def draw_marks(axes: Any, marks: Iterable[Mark], radius: float) -> None:
    """Draw a mission's marks (world units) on ``axes``; ``radius`` is a drone's radius,
    the offset of point labels."""
    from matplotlib.patches import Circle, Rectangle

    for mark in marks:
        if mark.shape == "circle":
            face = mark.colour if mark.fill else "none"
            edge = "none" if mark.fill else mark.colour
            axes.add_patch(Circle((mark.x, mark.y), mark.size, facecolor=face, edgecolor=edge,
                                  zorder=1))  # fmt: skip
            at, align = (mark.x - 1.2 * mark.size, mark.y), "right"
        elif mark.shape == "rect":
            face = mark.colour if mark.fill else "none"
            axes.add_patch(Rectangle((mark.x, mark.y), mark.width, mark.height, facecolor=face,
                                     edgecolor=mark.colour, zorder=1))  # fmt: skip
            at, align = (mark.x, mark.y + mark.height), "left"
        else:
            size = mark.size or 7
            axes.plot([mark.x], [mark.y], marker=mark.symbol, color=mark.colour, markersize=size,
                      linestyle="none", zorder=2)  # fmt: skip
            at, align = (mark.x + radius, mark.y + radius), "left"
        if mark.label:
            va = "center" if align == "right" else "bottom"
            axes.text(*at, mark.label, fontsize=8, ha=align, va=va, zorder=2)


def draw_frame(recorder: Recorder, scenario: Scenario, row: int = 0, dpi: int = 80) -> Image.Image:
    """The Fig. 5 picture of record ``row`` as an RGB image (e.g. to show in a notebook).

    ``row`` indexes records (0 is the initial state), not iterations; with decimated
    recording, record ``row`` holds iteration ``recorder.iterations[row]``.
    """
    return FramePainter(recorder, scenario, dpi).draw(row)


class Palette:
    """A fixed colour table of at most 256 colours, and an exact nearest-colour map onto it.

    Colours are 24-bit codes ``R | G << 8 | B << 16``. The table is built from a sample
    frame: Pillow's median cut groups its colours into 256 clusters, and each cluster is
    represented by its most frequent colour (not the mean), so flat colours such as white
    and the drone blue are kept exactly. Any colour maps to its nearest entry (Euclidean in
    RGB), computed once per colour and memoised in a 2**24-entry table (32 MB, allocated
    lazily by the system). Pillow's own palette mapping is not used: it merges colours up to
    4 levels apart, which turns white into grey.

    Args:
        pixels: the sample frame, RGB or RGBA, shape (height, width, 3|4), uint8.
    """

    def __init__(self, pixels: np.ndarray) -> None:
        from PIL import Image

        rgb = Image.fromarray(np.ascontiguousarray(pixels[..., :3]))
        clusters = np.asarray(rgb.quantize(PALETTE_COLOURS, dither=Image.Dither.NONE))
        keys, counts = np.unique(
            clusters.astype(np.int64) << 24 | colour_codes(pixels), return_counts=True
        )
        keys = keys[np.lexsort((-counts, keys >> 24))]  # by cluster, most frequent first
        first = np.r_[True, keys[1:] >> 24 != keys[:-1] >> 24]
        self.codes = keys[first] & 0xFFFFFF
        self.rgb = _unpack(self.codes)
        self._index = np.zeros(1 << 24, dtype=np.uint16)  # entry + 1; 0: not met yet

    def indices(self, codes: np.ndarray) -> np.ndarray:
        """The table entry of each colour code, uint8 of the same shape."""
        found = self._index[codes]
        missing = found == 0
        if missing.any():
            new = np.unique(codes[missing])
            distance = ((_unpack(new)[:, None, :] - self.rgb[None, :, :]) ** 2).sum(axis=2)
            self._index[new] = distance.argmin(axis=1) + 1
            found = self._index[codes]
        return (found - 1).astype(np.uint8)

    def tobytes(self) -> bytes:
        """The table as ``RGBRGB...`` bytes."""
        return self.rgb.astype(np.uint8).tobytes()


def colour_codes(pixels: np.ndarray) -> np.ndarray:
    """24-bit codes ``R | G << 8 | B << 16`` of RGB or RGBA pixels (H, W, 3|4) uint8 -> (H, W)."""
    if pixels.shape[-1] == 4 and pixels.flags.c_contiguous:
        return pixels.view("<u4")[..., 0] & 0xFFFFFF
    rgb = pixels[..., :3].astype(np.uint32)
    return rgb[..., 0] | rgb[..., 1] << 8 | rgb[..., 2] << 16


def _unpack(codes: np.ndarray) -> np.ndarray:
    """Colour codes (K,) -> RGB (K, 3) int64."""
    codes = codes.astype(np.int64)
    return np.stack([codes & 0xFF, codes >> 8 & 0xFF, codes >> 16 & 0xFF], axis=1)


class GifStream:
    """Writes an animated, looping GIF one frame at a time, keeping no frames in memory.

    The first frame's colours become the global colour table (:class:`Palette`); every
    frame is mapped to it. Each frame after the first is stored as the smallest rectangle
    that differs from the previous frame, drawn over it (disposal "do not dispose").
    Encoding uses Pillow's GIF helpers and C encoder.

    Args:
        file: a binary file open for writing.
        delay_ms: display time of each frame in milliseconds; GIF stores whole hundredths,
            so a multiple of 10 is exact (others are truncated).
    """

    def __init__(self, file: BinaryIO, delay_ms: float) -> None:
        self.file = file
        self.delay_ms = delay_ms
        self.palette: Palette | None = None
        self.previous: np.ndarray | None = None
        self.frames = 0

    def add(self, pixels: np.ndarray) -> None:
        """Append one frame: RGB or RGBA pixels, shape (height, width, 3|4), uint8.

        Every frame must have the first frame's size.
        """
        from PIL import GifImagePlugin

        if self.palette is None:
            self.palette = Palette(pixels)
        codes = colour_codes(pixels)
        indices = self.palette.indices(codes)
        if self.previous is None:
            header, _ = GifImagePlugin.getheader(self._image(indices), info={"loop": 0})
            self.file.write(b"".join(header))
        left, top, right, bottom = _changed_box(self.previous, indices)
        self.previous = indices
        frame = self._image(indices[top:bottom, left:right])
        chunks = GifImagePlugin.getdata(
            frame, offset=(left, top), duration=self.delay_ms, disposal=1
        )
        self.file.write(b"".join(chunks))
        self.frames += 1

    def _image(self, indices: np.ndarray) -> Image.Image:
        """A "P" image of palette ``indices`` (H, W) uint8 with the stream's colour table."""
        from PIL import Image

        assert self.palette is not None
        image = Image.fromarray(np.ascontiguousarray(indices))
        image.putpalette(self.palette.tobytes())
        return image

    def close(self) -> None:
        """Write the GIF trailer (the file itself is left open)."""
        self.file.write(b";")


def _changed_box(previous: np.ndarray | None, current: np.ndarray) -> tuple[int, int, int, int]:
    """The (left, top, right, bottom) pixel box where ``current`` differs from ``previous``.

    The whole frame when there is no previous frame; one pixel when nothing changed (a GIF
    frame cannot be empty).
    """
    height, width = current.shape
    if previous is None:
        return 0, 0, width, height
    changed = previous != current
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    if rows.size == 0:
        return 0, 0, 1, 1
    return int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1


def write_gif(
    recorder: Recorder,
    scenario: Scenario,
    path: str | Path,
    frame_every: int = 10,
    dpi: int = 80,
    fps: int = 20,
    progress: bool | None = None,
) -> AnimationStats:
    """Draw the run as an animated GIF at ``path``, streaming frame by frame.

    Args:
        recorder: the run's records; see :func:`frame_rows` for which rows become frames.
        scenario: the run's scenario (world size, patrol positions).
        path: the GIF file to write (overwritten).
        frame_every: iterations between frames (one frame per window of this many).
        dpi: pixels per inch; frames are ``FIGSIZE * dpi`` pixels (800 x 480 at 80).
        fps: frames per second when played. GIF delays are whole hundredths of a second,
            so the delay is ``100 / fps`` rounded, and at least 2 (at most 50 fps; browsers
            play shorter delays slowly).
        progress: show a progress bar; by default only on a terminal.

    Returns:
        frames written, wall seconds, the path and the file size in bytes.
    """
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    start = time.perf_counter()
    path = Path(path)
    rows = frame_rows(recorder, frame_every)
    painter = FramePainter(recorder, scenario, dpi)
    bar = Progress(len(rows), "gif", enabled=progress)
    with path.open("wb") as file:
        stream = GifStream(file, delay_ms=10 * max(2, round(100 / fps)))
        for done, row in enumerate(rows, start=1):
            stream.add(painter.render(int(row)))
            bar.update(done)
        stream.close()
    bar.close()
    return AnimationStats(stream.frames, time.perf_counter() - start, path, path.stat().st_size)
