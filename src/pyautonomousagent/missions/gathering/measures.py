"""The gathering mission's measure for experiments: how long the gathering takes."""

from __future__ import annotations

import numpy as np

from pyautonomousagent.experiments.measures import RunData, register_documented


def gathering_time(run: RunData) -> float:
    """Iterations from the first gathering order until every agent has come within the
    destination tolerance of the gathering point (NaN: no order, or not all arrived)."""
    orders = [e for e in run.events if e.get("event") == "message" and e.get("type") == "gathering"]
    if not orders:
        return float("nan")
    order = orders[0]
    gx, gy = order["data"]["x"], order["data"]["y"]
    tolerance = run.parameter("destination_tolerance", 0.5)
    after = run.iterations >= order["iteration"]
    near = np.hypot(run.columns["x"] - gx, run.columns["y"] - gy) <= tolerance
    near &= after[:, None]
    if not near.any(axis=0).all():
        return float("nan")
    arrival = run.iterations[near.argmax(axis=0)]
    return float(arrival.max() - order["iteration"])


register_documented(gathering_time, "iterations")
