"""What a run shows besides its data: the animation (GIF or MP4), ``replay.html`` and the
traced agents' Groot2 logs, written in one call (``pyaa run``, ``pyaa replay``)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyautonomousagent.recording import Recorder
from pyautonomousagent.simulation.scenario import Scenario


@dataclass
class Views:
    """Which views to write and how.

    Attributes:
        video: "gif", "mp4", or None for no animation.
        replay: write ``replay.html``.
        btlog: agents (names) whose trace is also written as ``AGENT.btlog`` for Groot2.
        follow: the agent the animation's panel and inset show (name or index).
        inset: draw the tree inset in the animation.
        progress: progress bars (None: only on a terminal).
    """

    video: str | None = "gif"
    replay: bool = True
    btlog: Sequence[str] = ()
    follow: int | str = 0
    inset: bool = False
    progress: bool | None = None
    written: list[Path] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)


def write_views(
    recorder: Recorder,
    scenario: Scenario,
    events: Iterable[Mapping[str, Any]],
    out: Path,
    views: Views,
) -> Views:
    """Write the chosen views of a recorded run into ``out``; ``views.written`` and
    ``views.timings`` (seconds per view) say what was done."""
    events = list(events)
    mission = scenario.create_mission()  # its marks, and the replay's changing marks
    marks = mission.marks()
    if views.video:
        from pyautonomousagent.render.animation import write_animation

        stats = write_animation(
            recorder,
            scenario,
            out / f"animation.{views.video}",
            views.video,
            frame_every=scenario.frame_every,
            progress=views.progress,
            marks=marks,
            events=events,
            follow=views.follow,
            inset=views.inset,
        )
        views.timings["animation"] = stats.seconds
        views.written.append(stats.path)
    if views.replay:
        from pyautonomousagent.render.replay import write_replay

        replay = write_replay(
            recorder,
            out / "replay.html",
            scenario.world,
            scenario.name,
            marks,
            events,
            frame_marks=lambda row: mission.frame_marks(recorder, row),
        )
        views.timings["replay"] = replay.seconds
        views.written.append(replay.path)
    for agent in views.btlog:
        from pyautonomousagent.render.btlog import write_btlog

        iterations = recorder.iterations[: recorder.count]
        path = write_btlog(
            out / f"{agent}.btlog", recorder.nodes[0], iterations, recorder.trace(agent)
        )
        views.written.append(path)
    return views
