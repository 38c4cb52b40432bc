"""The plain-Python paths for one agent or a few give the same results as the NumPy paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyautonomousagent import datalink
from pyautonomousagent.arrays import arctan2
from pyautonomousagent.datalink import Datalink
from pyautonomousagent.state import Swarm


def _bits(value: float) -> tuple[float, float]:
    """A float with its sign (so that 0.0 and -0.0 differ)."""
    return value, math.copysign(1.0, value)


def test_arctan2_of_python_floats_gives_the_bits_of_the_general_path():
    rng = np.random.default_rng(13)
    y = rng.normal(size=4000) * rng.choice([1e-9, 1.0, 1e9], 4000)
    x = rng.normal(size=4000) * rng.choice([1e-9, 1.0, 1e9], 4000)
    y[:30], x[20:50] = 0.0, -0.0
    x[60:90] = y[60:90]  # on the diagonals
    x[90:120] = -y[90:120]
    for a, b in zip(y.tolist(), x.tolist(), strict=True):
        general = float(arctan2(np.float64(a), np.float64(b)))  # NumPy scalars: no float path
        assert _bits(arctan2(a, b)) == _bits(general)


@pytest.mark.parametrize("spread", [10.0, 99.0, 1000.0])
def test_all_in_range_of_a_few_agrees_with_numpy(monkeypatch, spread):
    rng = np.random.default_rng(int(spread))
    link = Datalink(150.0)
    for _ in range(50):
        x, y = rng.uniform(0, spread, 4), rng.uniform(0, spread, 4)
        for i in range(4):
            link.send(i, "t", {"v": float(i)}, (float(x[i]), float(y[i])))
        messages = datalink._packed(link._queue)[0]
        link._queue.clear()
        few = link._all_in_range(messages, x, y)
        monkeypatch.setattr(datalink, "FEW", 0)
        assert link._all_in_range(messages, x, y) == few
        monkeypatch.setattr(datalink, "FEW", 32)


def test_all_in_range_with_a_nan_position_takes_the_numpy_path():
    link = Datalink(150.0)
    link.send(0, "t", {"v": 1.0}, (0.0, 0.0))
    messages = datalink._packed(link._queue)[0]
    x, y = np.array([0.0, np.nan]), np.array([0.0, 1.0])
    assert link._all_in_range(messages, x, y) is False


def test_blackboard_attributes_for_one_agent_and_for_a_group():
    swarm = Swarm.create(["a", "b", "c"], {"level": np.float64, "keys": np.int64})
    swarm.blackboard["level"][:] = [1.0, 2.0, 3.0]
    one, group = swarm.agent(1).blackboard, swarm.agents(np.array([0, 2])).blackboard
    assert one.level == 2.0 and type(one.level) is float
    assert group.level.tolist() == [1.0, 3.0]
    one.level = 5.0
    assert swarm.blackboard["level"].tolist() == [1.0, 5.0, 3.0]
    assert callable(one.keys)  # a key named like a method leaves the method alone
    swarm.blackboard["later"] = np.array([7, 8, 9])  # a key added after the views' class
    assert one.later == 8
    del swarm.blackboard["level"]
    with pytest.raises(AttributeError, match="no blackboard key 'level'"):
        _ = one.level
