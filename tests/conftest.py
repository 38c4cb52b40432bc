"""Shared fixtures: small engines for tiny trees, and the full scenario runs (once per session)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
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


#: Session fixtures (per xdist worker) worth building once: their tests share a worker.
SHARED_RUNS = ("gathering_run", "patrol_run")


def _shared_keys(item: pytest.Item) -> list[str]:
    """What ``item`` shares with other tests when they run on its worker: the module-scoped
    fixtures it uses (its module's tests) and :data:`SHARED_RUNS`."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return []
    keys = [f"runs-{name}" for name in SHARED_RUNS if name in info.names_closure]
    for name in info.names_closure:
        definitions = info.name2fixturedefs.get(name, ())
        if any(d.scope == "module" for d in definitions):
            keys.append(f"module-{item.path.stem}")
            break
    return keys


def _groups(items: list[pytest.Item]) -> dict[pytest.Item, str]:
    """The group of each test that shares something (:func:`_shared_keys`): tests sharing a
    key, directly or through others, are in one group, named by its first key."""
    parent: dict[str, str] = {}

    def root(key: str) -> str:
        while parent.setdefault(key, key) != key:
            key = parent[key]
        return key

    keys = {item: _shared_keys(item) for item in items}
    for item_keys in keys.values():
        for key in item_keys[1:]:
            parent[root(key)] = root(item_keys[0])
    return {item: root(k[0]) for item, k in keys.items() if k}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests that read the executed lessons run on one xdist worker (``--dist loadgroup``),
    so that the lessons are executed and the docs site built once, not once per worker
    (about 4 minutes each time). Likewise the tests of a module with a module-scoped
    fixture (a run, a sweep, a browser), and those of a session's scenario run
    (:data:`SHARED_RUNS`), share a worker: xdist would split them and build the fixture on
    both. The lessons' tests come first: with ``--no-loadscope-reorder`` (``make test``)
    xdist hands out the groups in this order, and the longest starts at once. First among
    the hooks: xdist's own hook turns the mark into the test's group, and a mark added after
    it is ignored."""
    lessons, others = [], []
    for item in items:
        if "executed_lessons" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group("lessons"))
            lessons.append(item)
        else:
            others.append(item)
    for item, group in _groups(others).items():
        item.add_marker(pytest.mark.xdist_group(group))
    items[:] = lessons + others


@pytest.fixture(scope="session")
def executed_lessons(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding every lesson notebook executed top to bottom from a fresh kernel
    (same file names, outputs included; the exercise cells replaced by the reference
    solutions of tests/lesson_solutions/), run once per test session."""
    from tests.lesson_runner import execute_lessons

    dest = tmp_path_factory.mktemp("lessons")
    execute_lessons(dest)
    return dest


@pytest.fixture(scope="session")
def compiled_loop() -> Callable[[str], None]:
    """Factory: ``compiled_loop(name)`` has the fused loop of scenario ``name`` compiled in
    this process, from numba's shared cache (``$PYAA_CACHE_DIR`` or ``~/.cache``), once per
    worker. A test that points ``PYAA_CACHE_DIR`` at an empty folder after it (to see its
    marker missing, then written) finds the module in memory and does not compile the tree
    a second time (about a minute on two cores). One worker compiles, the other waits for
    it under a lock and loads the code from the cache."""
    import fcntl

    from pyautonomousagent.loop.modules import cache_folder

    done: set[str] = set()

    def compile_(name: str) -> None:
        if name in done:
            return
        folder = cache_folder()
        folder.mkdir(parents=True, exist_ok=True)
        with open(folder / f"tests-{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
            probe = load(name).with_overrides(agents=1, iterations=1)
            Simulation.create(probe, seed=0, engine="compiled")
        done.add(name)

    return compile_


@pytest.fixture
def studio(tmp_path: Path) -> Iterator[Any]:
    """A studio server on the gathering scenario in the test's folder, shut down after."""
    from pyautonomousagent.studio import Studio

    server = Studio("gathering", tmp_path)
    server.start()
    yield server
    server.shutdown()
