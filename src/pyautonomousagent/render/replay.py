"""``replay.html``: one self-contained page that replays a recorded run in any browser, offline.

The page (``replay_template.html``: no external script, style or font) and the run's data,
JSON inside a ``<script type="application/json">``, are one file (docs/data.md). The large
arrays are base64-encoded: ``positions`` (frames, N, 3) and ``altitude`` (frames, N; None
without column ``z``) as uint16 steps of 1/65535 of their range, ``statuses`` int8 (frames,
traced, nodes), ``values`` float64 (frames, traced, columns).
"""

from __future__ import annotations

import base64
import html
import json
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from pyautonomousagent.bt.status import NAMES
from pyautonomousagent.recording import Recorder, node_list
from pyautonomousagent.render.animation import ALTITUDE, ViewStats, altitude_range, frame_rows
from pyautonomousagent.render.events import placed_events
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.render.panel import UNITS

MAX_FRAMES = 2000
"""Default most frames in a replay."""
MAX_AGENT_FRAMES = 400_000
"""Most agent positions (frames x agents) in a replay: about 3.2 MB of base64."""
TEMPLATE = "replay_template.html"
"""The page, next to this module; ``/*__DATA__*/`` marks where the data goes."""


def replay_rows(
    recorder: Recorder, max_frames: int = MAX_FRAMES, keep: Iterable[int] = ()
) -> np.ndarray:
    """Record rows shown as frames: evenly spaced, at most about ``max_frames`` (fewer for a
    large swarm, see :data:`MAX_AGENT_FRAMES`), plus the rows of the iterations ``keep``
    (events) and of the iteration after each. Ascending row indices, int64."""
    agents = max(1, len(recorder.names))
    budget = max(2, min(max_frames, MAX_AGENT_FRAMES // agents))
    last = int(recorder.iterations[recorder.count - 1])
    step = max(1, math.ceil((last + 1) / budget))
    rows = set(frame_rows(recorder, step).tolist())
    recorded = {int(it): r for r, it in enumerate(recorder.iterations[: recorder.count])}
    for iteration in keep:
        rows.update(recorded[i] for i in (iteration, iteration + 1) if i in recorded)
    return np.array(sorted(rows), dtype=np.int64)


def replay_data(
    recorder: Recorder,
    world: tuple[float, float],
    title: str,
    marks: Sequence[Mark] = (),
    events: Iterable[Mapping[str, Any]] = (),
    max_frames: int = MAX_FRAMES,
    frame_marks: Callable[[int], Sequence[Mark]] | None = None,
) -> dict[str, Any]:
    """The replay's data as plain JSON values (see the module docstring for the arrays).

    Args:
        recorder: the run's records; traces and values are shown for its traced agents.
        world: (width, height) of the world, world units.
        title: the page's title (e.g. the scenario's name).
        marks: the mission's static marks.
        events: the run's events (``sim.events``).
        max_frames: most frames (before events are added).
        frame_marks: the marks of record ``row`` that change during the run
            (:meth:`Mission.frame_marks`), e.g. the area cleaned so far.
    """
    if recorder.count == 0:
        raise ValueError("the recorder holds no records to replay")
    placed = placed_events(events, recorder)
    rows = replay_rows(recorder, max_frames, {e.iteration for e in placed})
    traced = recorder.traced
    columns = [c for group in recorder.groups.values() for c in group]
    values = np.stack([recorder.columns[c][rows][:, traced] for c in columns], axis=2)
    if recorder.behaviour is not None:
        behaviour = recorder.behaviour[rows][:, traced].astype(np.float64)
        values = np.concatenate([values.astype(np.float64), behaviour[..., None]], axis=2)
        columns.append("behaviour")
    docs = {c: recorder.docs.get(c, ("", "")) for c in columns}
    return {
        "title": title,
        "world": [float(world[0]), float(world[1])],
        "names": list(recorder.names),
        "iterations": recorder.iterations[rows].tolist(),
        "positions": _positions(recorder, rows),
        "altitude": _altitudes(recorder, rows),
        "traced": [int(i) for i in traced],
        "nodes": node_list(recorder.nodes),
        "status_names": {str(k): v for k, v in NAMES.items()},
        "statuses": _b64(recorder.traces[rows].transpose(0, 2, 1).astype(np.int8)),
        "columns": columns,
        "groups": {**recorder.groups, "behaviour": ["behaviour"]},
        "units": {c: UNITS.get(unit, unit) for c, (unit, _) in docs.items()},
        "descriptions": {c: doc for c, (_, doc) in docs.items()},
        "values": _b64(np.ascontiguousarray(values, dtype=np.float64)),
        "marks": [asdict(m) for m in marks],
        "changing_marks": changing_marks(frame_marks, rows) if frame_marks else [],
        "events": [e.as_dict() for e in placed],
    }


def changing_marks(
    frame_marks: Callable[[int], Sequence[Mark]], rows: np.ndarray
) -> list[dict[str, Any]]:
    """Each mark that ``frame_marks`` gives at some of ``rows``, once, with the frames where it
    is shown: ``frames`` = [[first, last], ...] (frame indices, inclusive), so a mark that
    stays (a cleaned cell) costs one interval, not one copy per frame. Marks are listed in the
    order they first appear (and, within a frame, ``frame_marks``'s order), so the same run
    gives the same file in every process."""
    shown: dict[Mark, list[list[int]]] = {}
    previous: dict[Mark, None] = {}
    for frame, row in enumerate(rows.tolist()):
        now = dict.fromkeys(frame_marks(int(row)))
        for mark in now:
            if mark not in previous:
                shown.setdefault(mark, []).append([frame, frame])
            shown[mark][-1][1] = frame
        previous = now
    return [{**asdict(mark), "frames": frames} for mark, frames in shown.items()]


def _positions(recorder: Recorder, rows: np.ndarray) -> dict[str, Any]:
    """x, y, heading of every agent at ``rows`` as uint16 triplets (frames, N, 3), base64,
    with each quantity's offset and step: ``value = offset + code * step``."""
    out: dict[str, Any] = {"offset": [], "step": []}
    codes = []
    for key in ("x", "y", "heading"):
        v = recorder.columns[key][rows]
        low, high = (0.0, 360.0) if key == "heading" else (float(v.min()), float(v.max()))
        codes.append(_quantised(v, low, high))
        out["offset"].append(low)
        out["step"].append((high - low) / 65535 or 1.0)
    out["data"] = _b64(np.stack(codes, axis=2))
    return out


def _altitudes(recorder: Recorder, rows: np.ndarray) -> dict[str, Any] | None:
    """The altitude of every agent at ``rows`` as uint16 (frames, N), base64, with its
    ``offset``, ``step`` and ``top`` (the colour scale's top, world units); None where the
    run records no altitude."""
    scale = altitude_range(recorder)
    if scale is None:
        return None
    low, high = scale
    codes = _quantised(recorder.columns[ALTITUDE][rows], low, high)
    return {"offset": low, "step": (high - low) / 65535, "top": high, "data": _b64(codes)}


def _quantised(values: np.ndarray, low: float, high: float) -> np.ndarray:
    """``values`` as uint16 codes of steps ``(high - low) / 65535`` (1 where that is 0) from
    ``low``, clipped to 0..65535; same shape."""
    step = (high - low) / 65535 or 1.0
    return np.clip(np.rint((values.astype(np.float64) - low) / step), 0, 65535).astype("<u2")


def _b64(array: np.ndarray) -> str:
    """The array's bytes (little-endian, C order) as base64 text."""
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def render_page(data: Mapping[str, Any]) -> str:
    """The self-contained HTML page with ``data`` inside."""
    template = resources.files("pyautonomousagent.render").joinpath(TEMPLATE).read_text("utf-8")
    text = json.dumps(data, separators=(",", ":"), allow_nan=False)
    # "</" would end the script element early; JSON allows "<\/" for "</".
    text = text.replace("</", "<\\/")
    title = html.escape(data["title"], quote=False)
    return template.replace("/*__DATA__*/", text, 1).replace("__TITLE__", title)


def write_replay(
    recorder: Recorder,
    path: str | Path,
    world: tuple[float, float],
    title: str,
    marks: Sequence[Mark] = (),
    events: Iterable[Mapping[str, Any]] = (),
    max_frames: int = MAX_FRAMES,
    frame_marks: Callable[[int], Sequence[Mark]] | None = None,
) -> ViewStats:
    """Write ``replay.html`` for a recorded run at ``path`` (see :func:`replay_data`)."""
    start = time.perf_counter()
    data = replay_data(recorder, world, title, marks, events, max_frames, frame_marks)
    path = Path(path)
    path.write_text(render_page(data), encoding="utf-8")
    seconds = time.perf_counter() - start
    return ViewStats(len(data["iterations"]), seconds, path, path.stat().st_size)
