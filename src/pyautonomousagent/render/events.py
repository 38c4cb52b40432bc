"""A run's events (``sim.events``, ``run.json``) as things to draw: when, where, what.

Events are the plain dicts of docs/data.md; :func:`placed_events` gives each one a place on
the map (the agent's position, or a message's ``x, y`` data) and a short text.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from pyautonomousagent.recording import Recorder

EVENT_COLOURS = {"alert": "#d62728", "message": "#9467bd"}
"""Marker colour per event kind; other kinds are drawn in grey."""


@dataclass(frozen=True)
class PlacedEvent:
    """One event to draw.

    Attributes:
        iteration: when it happened.
        kind: ``"alert"``, ``"message"``, ...
        text: a one-line description, e.g. ``"gathering order from drone1 to all"``.
        x, y: where to mark it on the map (world units); NaN when it has no place.
        agent: the agent it concerns (alert: the agent; message: the sender), or "".
        colour: the marker colour.
    """

    iteration: int
    kind: str
    text: str
    x: float
    y: float
    agent: str
    colour: str

    def as_dict(self) -> dict[str, Any]:
        """Plain values for JSON (NaN as None)."""

        def number(v: float) -> float | None:
            return None if np.isnan(v) else round(v, 4)

        return {**asdict(self), "x": number(self.x), "y": number(self.y)}


def placed_events(events: Iterable[Mapping[str, Any]], recorder: Recorder) -> list[PlacedEvent]:
    """Each event with its text and map position, in iteration order."""
    return sorted((_place(event, recorder) for event in events), key=lambda e: e.iteration)


def _place(event: Mapping[str, Any], recorder: Recorder) -> PlacedEvent:
    iteration = int(event.get("iteration", 0))
    kind = str(event.get("event", "event"))
    colour = EVENT_COLOURS.get(kind, "#7f7f7f")
    if kind == "message":
        data = event.get("data") or {}
        receivers = event.get("receivers", "all")
        to = receivers if isinstance(receivers, str) else f"{len(receivers)} agent(s)"
        sender = str(event.get("sender", ""))
        text = f"{event.get('type', 'message')} message from {sender} to {to}"
        x, y = float(data.get("x", np.nan)), float(data.get("y", np.nan))
        if np.isnan(x) or np.isnan(y):
            x, y = _position(recorder, sender, iteration)
        return PlacedEvent(iteration, kind, text, x, y, sender, colour)
    agent = str(event.get("agent", ""))
    text = f"{kind} {agent}: {event.get('message', '')}".strip().rstrip(":")
    x, y = _position(recorder, agent, iteration)
    return PlacedEvent(iteration, kind, text, x, y, agent, colour)


def _position(recorder: Recorder, agent: str, iteration: int) -> tuple[float, float]:
    """The agent's recorded position at the last record at or before ``iteration``."""
    if agent not in recorder.names or recorder.count == 0:
        return float("nan"), float("nan")
    i = recorder.names.index(agent)
    row = max(
        0, int(np.searchsorted(recorder.iterations[: recorder.count], iteration, "right")) - 1
    )
    return float(recorder.columns["x"][row, i]), float(recorder.columns["y"][row, i])
