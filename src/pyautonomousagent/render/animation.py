"""Phase 7: the paper's Fig. 5 view of a recorded run, one frame per row, streamed to a video.

The layout (Fig. 5): the world box ``[0, width] x [0, height]`` at equal aspect with the
mission's marks (a ``list[Mark]``: refuelling slots R1.., surveillance positions S1.., ...);
agents as dark-blue circles with a small red dot on the side they head to and their 1-based
index (labels that would overlap another are moved or left out); where the run records an
altitude (column ``z``: the 3-D drone), each drone is coloured by it, with a colour bar
beside the map, and its label reads ``N z=A`` (A: altitude, rounded); events as diamonds with a
line of text above the map for a while after they happen; beside the map, a panel with the
iteration and the followed agent's active behaviour, state and blackboard (each with its
unit; :mod:`.panel`: the frame grows wider where the run's widest value needs it, so that no
value is cut), and a legend; optionally, an inset with the tree, each node coloured by the
followed agent's status.

Speed and memory: the static background (axes, marks, legend, panel labels, tree names) is
drawn once with Matplotlib's Agg canvas (no pyplot, no global backend); each frame restores
it and draws only the agents and event marks on top (blitting), then writes the changing
text with pre-rendered glyphs (:mod:`.glyphs`). :func:`write_animation` streams the frames
to a GIF (:mod:`.gif`) or an MP4 (:mod:`.video`), never holding more than one. Matplotlib
and Pillow are imported only when a frame is drawn.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from pyautonomousagent.bt.status import COLOURS, INVALID, NAMES
from pyautonomousagent.progress import Progress
from pyautonomousagent.recording import Recorder, node_list
from pyautonomousagent.render.events import PlacedEvent, placed_events
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.render.panel import PanelLine, panel_lines
from pyautonomousagent.simulation.scenario import Scenario

if TYPE_CHECKING:
    from PIL import Image

FIGSIZE = (10.0, 6.0)
"""Figure size in inches without the tree inset; at ``dpi`` 80 a frame is 800 x 480 pixels."""
INSET_WIDTH = 3.4
"""Inches added on the right for the tree inset."""
AXES_INCHES = (0.6, 0.5, 5.6, 4.8)
"""The map's [left, bottom, width, height] in inches."""
PANEL_INCHES = (6.35, 5.75)
"""Top-left corner of the text panel, inches from the figure's bottom-left."""
TITLE_Y, BANNER_Y = 5.78, 5.45
"""Baselines of the title and of the event banner, inches from the bottom."""
DRONE_RADIUS = 0.015
"""A drone's radius as a fraction of the world's larger side (1.5 units in a 100 x 100 world)."""
MAX_LABELLED = 50
"""Above this many agents the drones are drawn without their index labels."""
DRONE_COLOUR = "#08306b"
"""Dark blue of the drones and their index labels."""
HEADING_COLOUR = "#e31a1c"
"""Red of the heading dot."""
FOLLOW_COLOUR = "#ff7f0e"
"""Orange of the ring around the followed agent."""
ALTITUDE = "z"
"""The column drawn as altitude where a run records it (world units above the ground)."""
ALTITUDE_COLOURS = "viridis"
"""The colour map of the altitude (dark low, yellow high: legible in grey too)."""
EVENT_SHOWN = 0.04
"""An event stays on the map for this fraction of the run's iterations (at least 1)."""
PANEL_NOTES = (
    "u: world units  it: iterations",
    "heading: degrees clockwise from north",
)
"""The panel's footnote, explaining its units."""
PANEL_MARGIN = 8
"""Pixels kept free right of the panel's widest value."""


@dataclass(frozen=True)
class ViewStats:
    """What :func:`write_animation` (or :func:`~.replay.write_replay`) wrote: its frames, the
    wall seconds of drawing and encoding, the file and its size in bytes."""

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
    return np.flatnonzero(np.diff(window, prepend=window[:1] - 1))  # where the window changes


def _rgb(colour: str) -> tuple[int, int, int]:
    from matplotlib.colors import to_rgb

    r, g, b = to_rgb(colour)
    return round(255 * r), round(255 * g), round(255 * b)


class FramePainter:
    """Draws the frames of one recorded run, reusing one figure for every frame.

    Args:
        recorder: the run's records (x, y and heading are required; shape (records, N)).
        scenario: the run's scenario (world size and name; the default marks).
        dpi: pixels per inch; the frame is ``FIGSIZE * dpi`` pixels (wider with the inset,
            and where the panel's widest value needs more room).
        marks: the static marks; by default the scenario's mission's (``Mission.marks()``).
        events: the run's events (``sim.events``), marked while they are recent.
        follow: the agent (index or name) the panel and the inset show.
        inset: draw the tree coloured by the followed agent's statuses (it must be traced).
    """

    def __init__(
        self,
        recorder: Recorder,
        scenario: Scenario,
        dpi: int = 80,
        marks: Sequence[Mark] | None = None,
        events: Iterable[Mapping[str, Any]] = (),
        follow: int | str = 0,
        inset: bool = False,
    ) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from pyautonomousagent.render.glyphs import GlyphAtlas

        if recorder.count == 0:
            raise ValueError("the recorder holds no records to draw")
        self.recorder = recorder
        self.follow = _agent_index(recorder, follow)
        self.trace = recorder.trace(self.follow) if inset else None
        self.radius = DRONE_RADIUS * max(scenario.world)
        self.altitude = altitude_range(recorder)
        # labels go to the upper right first; with altitudes (longer labels, of drones that
        # hover on their marks) to the lower right first, clear of the marks' labels
        self._diagonals = ((1, -1), (1, 1), (-1, -1), (-1, 1))
        if self.altitude is not None:
            self._diagonals = ((1, 1), (1, -1), (-1, 1), (-1, -1))
        self.mission = scenario.create_mission()
        self.marks = list(self.mission.marks() if marks is None else marks)
        self.events = placed_events(events, recorder)
        last = int(recorder.iterations[recorder.count - 1])
        self.event_window = max(1, round(EVENT_SHOWN * last))
        self.panel_font = GlyphAtlas(9, dpi)
        self.label_font = GlyphAtlas(8, dpi)
        self.lines = panel_lines(recorder, self.follow)
        self.panel_width = self._lay_out_panel(dpi)
        width = self.panel_width + (INSET_WIDTH if inset else 0.0)
        self.figure = Figure(figsize=(width, FIGSIZE[1]), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.figure)
        left, bottom, w, h = AXES_INCHES
        self.axes = self.figure.add_axes(
            (left / width, bottom / FIGSIZE[1], w / width, h / FIGSIZE[1]), anchor="W"
        )
        _draw_world(self.axes, scenario.world, self.marks)
        self.changing = _MarkLayer(self.mission, recorder, self.axes)
        title = f"pyAutonomousAgent: {scenario.name}"  # left-aligned on its baseline
        self.figure.text(left / width, TITLE_Y / FIGSIZE[1], title, fontsize=11)
        self._add_moving_artists(len(recorder.names))
        self._add_legend(width)
        self._add_panel_labels()
        if inset:
            self._add_inset(self.panel_width + 0.1)
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(self.figure.bbox)

    @property
    def size(self) -> tuple[int, int]:
        """Frame (width, height) in pixels."""
        return self.canvas.get_width_height()

    def _add_moving_artists(self, agents: int) -> None:
        from matplotlib.collections import EllipseCollection

        def circles(count: int, diameter: float, face: str, edge: str = "none") -> Any:
            collection = EllipseCollection(
                np.full(count, diameter),
                np.full(count, diameter),
                np.zeros(count),
                units="xy",
                offsets=np.zeros((count, 2)),
                offset_transform=self.axes.transData,
                facecolors=face,
                edgecolors=edge,
                linewidths=2.0,
                animated=True,
                zorder=3,
            )
            self.axes.add_collection(collection, autolim=False)
            return collection

        self.ring = circles(1, 3.4 * self.radius, "none", FOLLOW_COLOUR)
        self.bodies = circles(agents, 2 * self.radius, DRONE_COLOUR)
        self.dots = circles(agents, 0.8 * self.radius, HEADING_COLOUR)
        self.labelled = agents <= MAX_LABELLED
        if self.altitude is not None:
            self.bodies.set_cmap(ALTITUDE_COLOURS)
            self.bodies.set_clim(*self.altitude)
            self.bodies.set_array(np.zeros(agents))
            bar = self.axes.inset_axes((1.03, 0.0, 0.03, 1.0))
            self.figure.colorbar(self.bodies, cax=bar, label="altitude z [world units]")
        self.event_marks = self.axes.scatter(
            [], [], s=110, marker="D", edgecolors="white", linewidths=1.0, animated=True, zorder=5
        )

    def _add_legend(self, width: float) -> None:
        from matplotlib.lines import Line2D

        def entry(label: str, **style: Any) -> Line2D:
            return Line2D([], [], linestyle="none", label=label, **style)

        handles, seen = [], set()
        for mark in [*self.marks, *self.changing.legend_marks]:
            if not mark.legend or mark.legend in seen:
                continue
            seen.add(mark.legend)
            if mark.shape == "point":
                style = {"marker": _marker(mark.symbol), "color": mark.colour}
            else:
                face = mark.colour if mark.fill else "none"
                style = {"marker": "o" if mark.shape == "circle" else "s", "markersize": 9}
                style.update(markerfacecolor=face, markeredgecolor=mark.colour)
            handles.append(entry(mark.legend, **style))
        handles.append(entry("agent (number = drone N)", marker="o", color=DRONE_COLOUR))
        handles.append(entry("heading", marker="o", markersize=4, color=HEADING_COLOUR))
        ring = {"markerfacecolor": "none", "markeredgecolor": FOLLOW_COLOUR, "markeredgewidth": 2}
        handles.append(entry("followed agent", marker="o", markersize=11, **ring))
        for kind, colour in {e.kind: e.colour for e in self.events}.items():  # one colour a kind
            handles.append(entry(f"event: {kind}", marker="D", color=colour))
        self.figure.legend(
            handles=handles,
            loc="lower left",
            fontsize=8,
            ncols=2,
            bbox_to_anchor=(PANEL_INCHES[0] / width, 0.01),
            frameon=False,
            handletextpad=0.3,
            columnspacing=0.8,
        )

    def _lay_out_panel(self, dpi: float) -> float:
        """Where the panel's lines go (pixels: its left, top and line height; the values'
        left); returns the figure's width without the inset, inches: ``FIGSIZE``'s, or
        wider where the run's widest value (:class:`~.panel.PanelLine`) needs it."""
        font = self.panel_font
        self.line_height = font.cell[0] + 1
        self.panel_left = round(PANEL_INCHES[0] * dpi)
        self.panel_top = round((FIGSIZE[1] - PANEL_INCHES[1]) * dpi)
        longest = max(len(line.label) for line in self.lines)
        self.value_left = self.panel_left + font.width("x" * (longest + 1))
        right = max(self._value_left(line) + font.width("x" * line.widest) for line in self.lines)
        needed = right + PANEL_MARGIN
        if needed <= FIGSIZE[0] * dpi:
            return FIGSIZE[0]
        # even (an MP4's frames must be), and a quarter pixel more: Matplotlib truncates
        return (needed + needed % 2 + 0.25) / dpi

    def _value_left(self, line: PanelLine) -> int:
        """The left edge (pixels) of ``line``'s value: beside the labels, or indented on a
        line of its own."""
        return self.value_left if line.label else self.panel_left + self.panel_font.width("  ")

    def _add_panel_labels(self) -> None:
        """The panel's labels and notes (static, in the background); values are per frame."""
        text = "\n".join(line.label for line in self.lines)
        notes = "\n".join(PANEL_NOTES)
        style: dict[str, Any] = {
            "family": "monospace",
            "fontsize": 9,
            "va": "top",
            "linespacing": self.line_height / (9 * self.figure.dpi / 72),
        }
        self._text(self.panel_left, self.panel_top - 2, text, **style)
        notes_top = self.panel_top + self.line_height * (len(self.lines) + 1)
        style.update(fontsize=8, color="#555555")
        self._text(self.panel_left, notes_top, notes, **style)

    def _text(self, left: float, top: float, text: str, **style: Any) -> None:
        """Static text, left-aligned at ``(left, top)``: pixels from the figure's top-left."""
        box = self.figure.bbox
        self.figure.text(left / box.width, 1 - top / box.height, text, ha="left", **style)

    def _add_inset(self, left_inches: float) -> None:
        """The tree's node names (static) beside the status boxes drawn per frame."""
        dpi, nodes = self.figure.dpi, self.recorder.nodes
        self.inset_left = round(left_inches * dpi)
        self.inset_top = self.panel_top + 16
        self.inset_row = max(
            9, min(14, round((FIGSIZE[1] * dpi - self.inset_top - 60) / max(1, len(nodes))))
        )
        depth = [cast(int, node["depth"]) for node in node_list(nodes)]
        title = f"Tree of {self.recorder.names[self.follow]}"
        self._text(
            self.inset_left, self.inset_top - 16, title, fontsize=9, va="bottom", weight="bold"
        )
        small = {"fontsize": 6.5, "va": "center"}
        self.inset_boxes = []
        for j, node in enumerate(nodes):
            x = self.inset_left + 10 * depth[j]
            y = self.inset_top + j * self.inset_row
            self.inset_boxes.append((x, y))
            self._text(x + 12, y + self.inset_row / 2, node.name[:40], family="monospace", **small)
        y = self.inset_top + len(nodes) * self.inset_row + 8
        self._legend_codes = list(COLOURS)
        for k, code in enumerate(self._legend_codes):
            x = self.inset_left + 52 * k
            self.inset_boxes.append((x, y))
            label = "not ticked" if code == INVALID else NAMES[code]
            self._text(x + 12, y + 4, label, **small)
        self._status_rgb = {code: np.array(_rgb(c), np.uint8) for code, c in COLOURS.items()}

    def _update(self, row: int) -> list[PlacedEvent]:
        """Move the artists to record ``row``; the events shown at it (recent ones)."""
        columns, r = self.recorder.columns, self.radius
        x, y = columns["x"][row], columns["y"][row]
        heading = np.radians(columns["heading"][row])
        self.bodies.set_offsets(np.column_stack([x, y]))
        if self.altitude is not None:
            self.bodies.set_array(columns[ALTITUDE][row])
        self.dots.set_offsets(np.column_stack([x + r * np.sin(heading), y + r * np.cos(heading)]))
        self.ring.set_offsets([[x[self.follow], y[self.follow]]])
        iteration = int(self.recorder.iterations[row])
        window = self.event_window
        active = [e for e in self.events if e.iteration <= iteration < e.iteration + window]
        shown = [e for e in active if not np.isnan(e.x)]
        self.event_marks.set_offsets(np.array([[e.x, e.y] for e in shown]).reshape(-1, 2))
        self.event_marks.set_facecolor([e.colour for e in shown] or "none")
        return active

    def render(self, row: int) -> np.ndarray:
        """The frame of record ``row`` (0 <= row < recorder.count) as RGBA pixels.

        Returns:
            uint8 array of shape (height, width, 4), a view of the canvas that the next
            call overwrites (copy it to keep it).
        """
        if not 0 <= row < self.recorder.count:
            raise IndexError(f"row {row} is outside the {self.recorder.count} records")
        active = self._update(row)
        self.canvas.restore_region(self.background)
        self.changing.draw(self.axes, row)
        for artist in (self.ring, self.bodies, self.dots, self.event_marks):
            self.axes.draw_artist(artist)
        pixels = np.asarray(self.canvas.buffer_rgba())
        if not pixels.flags.writeable:
            pixels = pixels.copy()
        self._draw_labels(pixels, row)
        self._draw_panel(pixels, row)
        self._draw_banner(pixels, active)
        if self.trace is not None:
            self._draw_inset(pixels, row)
        return pixels

    def label_boxes(self, row: int) -> list[tuple[int, float, float, float, float]]:
        """Where the agent numbers of record ``row`` go: (agent, left, top, right, bottom) in
        pixels from the top-left. Each label goes to the upper right of its agent, else to
        another diagonal, whichever first overlaps no label already placed; a label that fits
        nowhere is left out (so bunched agents do not pile their numbers up)."""
        if not self.labelled:
            return []
        columns, font = self.recorder.columns, self.label_font
        points = self.axes.transData.transform(
            np.column_stack([columns["x"][row], columns["y"][row]])
        )
        height = self.figure.bbox.height
        gap = self.radius * self.axes.transData.get_matrix()[0, 0] * 0.8
        cell_h = font.cell[0]
        placed: list[tuple[int, float, float, float, float]] = []
        for i, (px, py) in enumerate(points):
            w = font.width(self._label(i, row))
            top_y = height - py
            for dx, dy in self._diagonals:
                left = px + gap if dx > 0 else px - gap - w
                top = top_y - gap - cell_h if dy < 0 else top_y + gap
                box = (i, left, top, left + w, top + cell_h)
                if all(
                    box[3] <= b[1] or box[1] >= b[3] or box[4] <= b[2] or box[2] >= b[4]
                    for b in placed
                ):
                    placed.append(box)
                    break
        return placed

    def _draw_labels(self, pixels: np.ndarray, row: int) -> None:
        """Agent numbers beside the agents (:meth:`label_boxes`)."""
        colour = _rgb(DRONE_COLOUR)
        for i, left, top, _, _ in self.label_boxes(row):
            self.label_font.draw(pixels, self._label(i, row), left, top, colour, anchor="top")

    def _label(self, agent: int, row: int) -> str:
        """Agent ``agent``'s label at record ``row``: its number, and its altitude where one
        is recorded (``3 z=20``)."""
        if self.altitude is None:
            return str(agent + 1)
        return f"{agent + 1} z={self.recorder.columns[ALTITUDE][row, agent]:.0f}"

    def panel_values(self, row: int) -> list[tuple[int, int, str]]:
        """The panel's values at record ``row`` as (left, top, text): pixels from the frame's
        top-left corner to the top-left of the text; the frame is wide enough for all."""
        return [
            (self._value_left(line), self.panel_top + k * self.line_height, line.value(row))
            for k, line in enumerate(self.lines)
        ]

    def _draw_panel(self, pixels: np.ndarray, row: int) -> None:
        for left, top, text in self.panel_values(row):
            self.panel_font.draw(pixels, text, left, top, (0, 0, 0), "top")

    def _draw_banner(self, pixels: np.ndarray, active: list[PlacedEvent]) -> None:
        if not active:
            return
        event = active[-1]
        text = f"iteration {event.iteration}: {event.text}"
        left = round(AXES_INCHES[0] * self.figure.dpi)
        baseline = pixels.shape[0] - BANNER_Y * self.figure.dpi
        self.panel_font.draw(pixels, text[:70], left, baseline, _rgb(event.colour))

    def _draw_inset(self, pixels: np.ndarray, row: int) -> None:
        assert self.trace is not None
        codes = [*self.trace[row].tolist(), *self._legend_codes]
        for (x, y), code in zip(self.inset_boxes, codes, strict=True):
            h = max(6, self.inset_row - 3)
            pixels[y + 1 : y + 1 + h, x : x + 10, :3] = self._status_rgb[int(code)]

    def draw(self, row: int) -> Image.Image:
        """The frame of record ``row`` as an RGB image (a copy)."""
        from PIL import Image

        return Image.fromarray(np.ascontiguousarray(self.render(row)[..., :3]))


def altitude_range(recorder: Recorder) -> tuple[float, float] | None:
    """(0, highest recorded altitude, at least 1) where the run records column ``z``, for
    the colour scale of the altitude; else None."""
    if ALTITUDE not in recorder.columns:
        return None
    top = float(np.max(recorder.columns[ALTITUDE][: recorder.count]))
    return 0.0, max(top, 1.0)


def _agent_index(recorder: Recorder, agent: int | str) -> int:
    """An agent given by index or name, checked; ValueError naming the agents otherwise."""
    names = recorder.names
    if isinstance(agent, str):
        if agent not in names:
            raise ValueError(
                f"follow: no agent named {agent!r}; agents are {names[0]}..{names[-1]}"
            )
        return names.index(agent)
    if not 0 <= agent < len(names):
        raise ValueError(f"follow: agent index {agent} is outside 0..{len(names) - 1}")
    return agent


def _marker(symbol: str) -> str:
    """A Mark's point symbol as a Matplotlib marker."""
    return symbol if symbol in ("x", "o", "+", "*", "^", "s") else "x"


class _MarkLayer:
    """The mission's changing marks (:meth:`Mission.frame_marks`), drawn on every frame as one
    polygon collection under the agents (circles as 24-gons; points are not drawn)."""

    def __init__(self, mission: Any, recorder: Recorder, axes: Any) -> None:
        from matplotlib.collections import PolyCollection

        self.mission, self.recorder = mission, recorder
        last = mission.frame_marks(recorder, recorder.count - 1)
        self.legend_marks = list({m.legend: m for m in last if m.legend}.values())
        self.collection: Any = None
        if last:  # the mission has changing marks: an animated collection on ``axes``
            self.collection = PolyCollection([], animated=True, zorder=1.5, linewidths=0)
            axes.add_collection(self.collection, autolim=False)

    def draw(self, axes: Any, row: int) -> None:
        """Draw record ``row``'s changing marks."""
        if self.collection is None:
            return
        marks = [m for m in self.mission.frame_marks(self.recorder, row) if m.shape != "point"]
        self.collection.set_verts([_outline(m) for m in marks])
        self.collection.set_facecolor([m.colour if m.fill else "none" for m in marks] or "none")
        self.collection.set_edgecolor([m.colour for m in marks] or "none")
        axes.draw_artist(self.collection)


def _outline(mark: Mark) -> np.ndarray:
    """A rectangle's or a circle's outline as polygon vertices, world units, shape (K, 2)."""
    if mark.shape == "rect":
        x0, y0, x1, y1 = mark.x, mark.y, mark.x + mark.width, mark.y + mark.height
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    angle = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    return np.column_stack([mark.x + mark.size * np.cos(angle), mark.y + mark.size * np.sin(angle)])


def _draw_world(axes: Any, world: tuple[float, float], marks: Sequence[Mark]) -> None:
    """The static map on ``axes``: the world box and the marks with their labels."""
    from matplotlib.patches import Circle, Rectangle

    width, height = world
    axes.set_xlim(0, width)
    axes.set_ylim(0, height)
    axes.set_aspect("equal", adjustable="box")
    axes.set_xlabel("x [world units]")
    axes.set_ylabel("y [world units]")
    pad = DRONE_RADIUS * max(world)
    for mark in marks:
        style: dict[str, Any] = {"edgecolor": mark.colour, "zorder": 1}
        style["facecolor"] = mark.colour if mark.fill else "none"
        if mark.shape == "circle":
            axes.add_patch(Circle((mark.x, mark.y), mark.size, **style))
            at = (mark.x - mark.size - 0.5 * pad, mark.y, "right", "center")
        elif mark.shape == "rect":
            axes.add_patch(Rectangle((mark.x, mark.y), mark.width, mark.height, **style))
            at = (mark.x, mark.y + mark.height + 0.3 * pad, "left", "bottom")
        else:
            axes.plot(
                [mark.x],
                [mark.y],
                marker=_marker(mark.symbol),
                color=mark.colour,
                markersize=mark.size or 7,
                linestyle="none",
                zorder=2,
            )
            at = (mark.x + pad, mark.y + pad, "left", "bottom")
        if mark.label:
            x, y, ha, va = at
            axes.text(x, y, mark.label, fontsize=8, ha=ha, va=va, zorder=2)


def draw_frame(
    recorder: Recorder, scenario: Scenario, row: int = 0, dpi: int = 80, **options: Any
) -> Image.Image:
    """The picture of record ``row`` as an RGB image (e.g. to show in a notebook).

    ``row`` indexes records (0 is the initial state), not iterations; with decimated
    recording, record ``row`` holds iteration ``recorder.iterations[row]``. ``options`` are
    :class:`FramePainter`'s (marks, events, follow, inset).
    """
    return FramePainter(recorder, scenario, dpi, **options).draw(row)


def write_animation(
    recorder: Recorder,
    scenario: Scenario,
    path: str | Path,
    video: str = "gif",
    frame_every: int = 10,
    dpi: int = 80,
    fps: int = 20,
    progress: bool | None = None,
    **options: Any,
) -> ViewStats:
    """Draw the run as a video at ``path`` ("gif" or "mp4"), streaming frame by frame.

    Args:
        recorder: the run's records; see :func:`frame_rows` for which rows become frames.
        scenario: the run's scenario (world size, name).
        path: the file to write (overwritten).
        video: "gif", or "mp4" (H.264; needs the ``[video]`` extra, imageio-ffmpeg).
        frame_every: iterations between frames (one frame per window of this many).
        dpi: pixels per inch; frames are ``FIGSIZE * dpi`` pixels (800 x 480 at 80), wider
            where the panel's widest value needs more room.
        fps: frames per second when played (a GIF's: see :func:`~.video.open_stream`).
        progress: show a progress bar; by default only on a terminal.
        options: :class:`FramePainter`'s marks, events, follow and inset.

    Returns:
        frames written, wall seconds, the path and the file size in bytes.
    """
    from pyautonomousagent.render.video import open_stream

    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    start = time.perf_counter()
    path = Path(path)
    rows = frame_rows(recorder, frame_every)
    painter = FramePainter(recorder, scenario, dpi, **options)
    bar = Progress(len(rows), video, enabled=progress)
    with open_stream(video, path, painter.size, fps) as stream:
        for done, row in enumerate(rows, start=1):
            stream.add(painter.render(int(row)))
            bar.update(done)
    bar.close()
    return ViewStats(stream.frames, time.perf_counter() - start, path, path.stat().st_size)
