"""The run's events as the studio's live view shows them: counts for the plots, and the
recent ones placed on the map as the GIF places them, each message with the receivers in
its range.

Only the public run API is read (``sim.events``, ``sim.handlers``, the swarm's columns, the
recorder's positions); :class:`EventFeed` reads each event once.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from pyautonomousagent.render.animation import EVENT_SHOWN
from pyautonomousagent.render.events import placed_events
from pyautonomousagent.simulation import Simulation

#: The measure each event kind counts, in the plot's order.
MEASURES = {"alert": "alerts", "collision": "collisions", "message": "messages"}
#: Most recent events a frame carries (the newest).
MAX_RECENT = 50
#: Most receivers a message's lines go to.
MAX_RECEIVERS = 200


def reported_kinds(sim: Simulation) -> list[str]:
    """The event kinds the run's scenario reports: alerts always; collisions where the
    swarm counts them (column ``collisions``); messages where the mission records a type."""
    kinds = ["alert"]
    if "collisions" in sim.swarm.columns:
        kinds.append("collision")
    if any(kind.recorded for kind in sim.handlers.values()):
        kinds.append("message")
    return kinds


class EventFeed:
    """The events of one run, read as it goes.

    Args:
        sim: the run; its ``events`` list only grows.
    """

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.seen = 0
        self.counts = {kind: 0 for kind in reported_kinds(sim)}
        self.recent: deque[dict[str, Any]] = deque(maxlen=MAX_RECENT)
        #: Iterations an event stays on the map (the GIF's share of the run, at least 1).
        self.window = max(1, round(EVENT_SHOWN * sim.scenario.iterations))
        self.reach = float(vars(sim.scenario.parameters).get("datalink_range", math.inf))
        self.index = sim.world.agent_index  # name -> row, without a dict of N names

    def frame(self) -> dict[str, Any]:
        """``measures``: per kind reported, the events so far (e.g. ``{"alerts": 2}``);
        ``events``: those of the last :attr:`window` iterations, oldest first, each with
        its kind, text, colour, place (x, y: world units, None if it has none) and, for a
        message, its sender's position (``from``) and the receivers in range (``to``)."""
        new = self.sim.events[self.seen :]  # those since the last frame
        self.seen += len(new)
        for event in new:
            kind = str(event.get("event", "event"))
            self.counts[kind] = self.counts.get(kind, 0) + 1
            self.recent.append(self._drawn(event))
        now = int(self.sim.world.iteration)
        return {
            "measures": {MEASURES.get(k, f"{k}s"): n for k, n in self.counts.items()},
            "events": [e for e in self.recent if e["iteration"] > now - self.window],
        }

    def _drawn(self, event: dict[str, Any]) -> dict[str, Any]:
        """One event as the canvas draws it."""
        drawn = placed_events([event], self.sim.recorder)[0].as_dict()
        if drawn["kind"] == "message":
            drawn.update(self._in_range(event))
        return drawn

    def _in_range(self, event: dict[str, Any]) -> dict[str, Any]:
        """The sender's position and the receivers within the datalink's range of it at the
        message's iteration (the recorded positions), at most :data:`MAX_RECEIVERS`."""
        recorder = self.sim.recorder
        sender = str(event.get("sender", ""))
        if sender not in self.index or recorder.count == 0:
            return {"from": None, "to": []}
        iterations = recorder.iterations[: recorder.count]
        row = max(0, int(np.searchsorted(iterations, int(event["iteration"]), "right")) - 1)
        x, y = recorder.columns["x"][row], recorder.columns["y"][row]
        i = self.index[sender]
        near = np.hypot(x - x[i], y - y[i]) <= self.reach
        near[i] = False
        receivers = event.get("receivers", "all")
        if not isinstance(receivers, str):
            listed = np.zeros_like(near)
            listed[[self.index[r] for r in receivers if r in self.index]] = True
            near &= listed
        rows = np.flatnonzero(near)[:MAX_RECEIVERS]
        return {
            "from": [round(float(x[i]), 3), round(float(y[i]), 3)],
            "to": [[round(float(x[k]), 3), round(float(y[k]), 3)] for k in rows],
        }
