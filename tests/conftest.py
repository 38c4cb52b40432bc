"""Shared fixtures: small engines for tiny trees, and the full scenario runs (once per session)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt.spec import Node
from pyautonomousagent.datalink import Datalink
from pyautonomousagent.engines.batched import BatchedEngine
from pyautonomousagent.engines.pytrees import PyTreesEngine
from pyautonomousagent.missions.drones import DroneMission
from pyautonomousagent.state import Swarm
from pyautonomousagent.testing import Harness
from pyautonomousagent.world import World

#: The blackboard of the paper's Table 3 plus the patrol keys.
BLACKBOARD_KEYS: dict[str, type] = {
    "number_ticks": np.int64,
    "x_surveillance_position": np.float64,
    "y_surveillance_position": np.float64,
    "x_refueling_position": np.float64,
    "y_refueling_position": np.float64,
    "x_current_destination_position": np.float64,
    "y_current_destination_position": np.float64,
    "index_current_surveillance_position": np.int64,
    "x_surveillance_position_1": np.float64,
    "y_surveillance_position_1": np.float64,
    "x_surveillance_position_2": np.float64,
    "y_surveillance_position_2": np.float64,
}


def make_swarm(n: int = 1) -> Swarm:
    """N zero-filled drones ``drone1``..``droneN`` with the full blackboard."""
    return Swarm.create([f"drone{i + 1}" for i in range(n)], BLACKBOARD_KEYS, DroneMission.columns)


def default_parameters() -> dict[str, Any]:
    """The gathering scenario's parameters (every drone leaf's port default)."""
    return vars(load("gathering").parameters)


def make_world(swarm: Swarm, datalink_range: float = 1000.0) -> World:
    """A 100 x 100 world for ``swarm`` at iteration 0."""
    return World(
        width=100.0,
        height=100.0,
        datalink=Datalink(datalink_range),
        agent_index={name: i for i, name in enumerate(swarm.names)},
    )


def make_harness(
    tree: Node, n: int = 1, defaults: Mapping[str, Any] | None = None, engine: str = "pytrees"
) -> Harness:
    """Swarm + World + an engine ("pytrees" or "batched") for ``tree`` and ``n`` drones with
    the full blackboard (the shipped :class:`~pyautonomousagent.testing.Harness`)."""
    swarm = make_swarm(n)
    world = make_world(swarm)
    params = default_parameters() if defaults is None else defaults
    kind = PyTreesEngine if engine == "pytrees" else BatchedEngine
    return Harness(tree, swarm, world, kind(tree, swarm, world, params))


@pytest.fixture(autouse=True)
def _clear_pytrees_blackboard() -> None:
    """Hygiene: no test sees py_trees' global blackboard as another test left it."""
    py_trees.blackboard.Blackboard.clear()


@pytest.fixture(scope="session")
def gathering_run() -> Simulation:
    """The full gathering scenario (4 drones x 8000 iterations, seed 0), run once."""
    return Simulation.create(load("gathering"), seed=0).run(progress=False)


@pytest.fixture(scope="session")
def patrol_run() -> Simulation:
    """The patrol scenario with 10 drones x 4000 iterations (seed 0), run once."""
    scenario = load("patrol").with_overrides(agents=10, iterations=4000)
    return Simulation.create(scenario, seed=0).run(progress=False)


@pytest.fixture
def harness():
    """Factory: ``harness(tree, n=1, defaults=None)`` -> a :class:`Harness`."""
    return make_harness


@pytest.fixture
def swarm_world():
    """Factory: ``swarm_world(n=1, datalink_range=1000)`` -> (Swarm, World)."""

    def build(n: int = 1, datalink_range: float = 1000.0) -> tuple[Swarm, World]:
        swarm = make_swarm(n)
        return swarm, make_world(swarm, datalink_range)

    return build


def on_channel(link: Datalink) -> list[tuple]:
    """(sender, type, data, sender position, receivers) of each message waiting to go."""
    out = []
    for messages in link.channel:
        for row in range(len(messages)):
            targets = messages.receivers(row)
            out.append((
                int(messages.senders[row]),
                messages.type,
                {k: float(v[row]) for k, v in messages.data.items()},
                (float(messages.x[row]), float(messages.y[row])),
                None if targets is None else [int(t) for t in targets],
            ))  # fmt: skip
    return out


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests that read the executed lessons run on one xdist worker (``--dist loadgroup``),
    so that the lessons are executed once, not once per worker (about 90 s each time)."""
    for item in items:
        if "executed_lessons" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group("lessons"))


@pytest.fixture(scope="session")
def executed_lessons(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding every lesson notebook executed top to bottom from a fresh kernel
    (same file names, outputs included; the exercise cells replaced by the reference
    solutions of tests/lesson_solutions/), run once per test session."""
    from tests.lesson_runner import execute_lessons

    dest = tmp_path_factory.mktemp("lessons")
    execute_lessons(dest)
    return dest


@pytest.fixture
def studio(tmp_path: Path) -> Iterator[Any]:
    """A studio server on the gathering scenario in the test's folder, shut down after."""
    from pyautonomousagent.studio import Studio

    server = Studio("gathering", tmp_path)
    server.start()
    yield server
    server.shutdown()
