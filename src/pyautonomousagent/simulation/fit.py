"""Which leaves fit a scenario: checked before every run, listed by ``pyaa leaves``.

A leaf fits a scenario when its mission gives the leaf everything it uses: a value for each
port (written in the tree, or the scenario parameter the port's default names), the
blackboard keys it declares, and the state columns, blackboard keys and world objects it
reads or writes when ticked. The last are found by ticking the leaf once on a *probe*: two
agents of the scenario's mission, placed as in Phase 1, in a world of their own (no run is
touched; its world is at iteration 0, before any run's first tick), whose views raise
:class:`MissingError` for anything the mission lacks. A leaf that fails on the probe for
any other reason is left to the run: the probe looks for what the mission lacks, not for a
leaf's own mistakes. (A leaf that logs its ticks sees the probe's at iteration 0.)

- :func:`check_tree`: refuse, before a run, a tree with a leaf that does not fit, naming the
  leaf, why, the missions it belongs to and the leaves that do fit;
- :func:`fitting_leaves`: the leaf types that fit a scenario (``pyaa leaves SCENARIO``);
- :func:`leaf_missions`: the registered missions a leaf type fits.
"""

from __future__ import annotations

import difflib
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.bt.blackboard import tree_blackboard_keys
from pyautonomousagent.bt.leaf import LEAF_TYPES, Leaf, make_leaf
from pyautonomousagent.bt.spec import Node, TreeError, leaf
from pyautonomousagent.simulation import phases
from pyautonomousagent.simulation.params import ScenarioError, Values
from pyautonomousagent.simulation.scenario import Scenario
from pyautonomousagent.state import AgentView, BlackboardView, Swarm
from pyautonomousagent.world import World

#: Agents of a probe.
PROBE_AGENTS = 2
#: Leaves that fit, named in a refusal (the rest: ``pyaa leaves SCENARIO``).
NAMED_FITS = 4


class MissingError(AttributeError):
    """What a probe's views raise for a column, key or world object the mission lacks (an
    AttributeError, so a leaf's own ``getattr(agents, name, default)`` still works)."""

    def __init__(self, what: str, name: str) -> None:
        super().__init__(f"{what} {name!r}")
        self.what, self.name = what, name


def _view_getattr(view: AgentView, key: str) -> Any:
    if key.startswith("__"):
        raise AttributeError(key)
    raise MissingError("state column", key)


def _view_setattr(view: AgentView, key: str, value: Any) -> None:
    if not any(key in vars(kind) for kind in type(view).__mro__):  # columns: descriptors
        raise MissingError("state column", key)
    object.__setattr__(view, key, value)


def _board_column(board: BlackboardView, key: str) -> np.ndarray:
    try:
        return board._board[key]
    except KeyError:
        raise MissingError("blackboard key", key) from None


class _ProbeObjects(Values):
    """The world objects of a probe: an unknown one raises :class:`MissingError`."""

    def __getattr__(self, key: str) -> Any:
        if key.startswith("__"):
            raise AttributeError(key)
        raise MissingError("world object", key)


@dataclass
class Probe:
    """A few agents of a scenario's mission, whose views raise :class:`MissingError`.

    Attributes:
        scenario: the scenario probed.
        swarm: its agents (at most :data:`PROBE_AGENTS`), placed by the mission.
        world: their world (its own datalink and objects).
    """

    scenario: Scenario
    swarm: Swarm
    world: World

    @classmethod
    def of(cls, scenario: Scenario, keys: Mapping[str, Any] | None = None) -> Probe:
        """A probe of ``scenario``'s mission; ``keys``: more blackboard keys (those the
        tree writes), key -> dtype."""
        small = _small(scenario)
        mission = small.create_mission()
        world = phases.create_world(small, 0)
        swarm = phases.create_agents(mission, world, np.random.default_rng(0), dict(keys or {}))
        world.objects = _ProbeObjects(**vars(small.objects))
        view = {"__slots__": (), "__getattr__": _view_getattr, "__setattr__": _view_setattr}
        swarm.view_type = type("ProbeView", (swarm.view_type,), view)
        board = {"__slots__": (), "_column": _board_column}
        swarm.board_type = type("ProbeBoard", (swarm.board_type,), board)
        return cls(scenario, swarm, world)

    @property
    def defaults(self) -> dict[str, Any]:
        """The scenario's parameters, which give ports their defaults."""
        return vars(self.scenario.parameters)


def _small(scenario: Scenario) -> Scenario:
    """``scenario`` with at most :data:`PROBE_AGENTS` agents (itself where that is refused)."""
    if scenario.agents <= PROBE_AGENTS:
        return scenario
    try:
        return scenario.with_overrides(agents=PROBE_AGENTS)
    except (ScenarioError, ValueError):
        return scenario


def misfit(node: Node, probe: Probe) -> str | None:
    """Why the leaf ``node`` cannot run in the probe's scenario, or None if it can.

    A port value the tree gets wrong is no misfit: the engine reports it, with the port.
    """
    cls = LEAF_TYPES.get(node.type)
    for port in cls.ports:
        if port.name not in node.params and port.default not in probe.defaults:
            return (
                f"its port {port.name!r} takes its default from parameter "
                f"{port.default!r}, which the scenario does not have"
            )
    try:
        made = make_leaf(node, probe.defaults)
    except TreeError:
        return None
    missing = [key for key in made.keys if key not in probe.swarm.blackboard]
    if missing:
        return f"it needs blackboard key(s) {', '.join(map(repr, missing))}"
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            made.evaluate(probe.swarm.agent(0), probe.world)
            made.evaluate(probe.swarm.agents(), probe.world)
    except MissingError as error:
        return f"it uses {error}, which the mission's agents and world do not have"
    except Exception:  # the leaf's own matter: the run shows it
        return None
    return None


def fitting_leaves(scenario: Scenario, keys: Mapping[str, Any] | None = None) -> list[type[Leaf]]:
    """The registered leaf types that fit ``scenario`` (in order of registration), with
    their ports' defaults; ``keys``: more blackboard keys, key -> dtype."""
    probe = Probe.of(scenario, keys)
    return [cls for name, cls in LEAF_TYPES.items() if misfit(leaf(name, "probe"), probe) is None]


def is_general(cls: type[Leaf]) -> bool:
    """Whether a leaf type belongs to no mission (the package's own: Script, Sleep, ...)."""
    return cls.__module__.startswith("pyautonomousagent.bt.")


def leaf_missions(type_name: str) -> list[str]:
    """The registered missions whose first registered scenario leaf type ``type_name``
    fits (ports at their defaults)."""
    from pyautonomousagent.scenarios import load, names

    found: dict[str, bool] = {}
    for name in names():
        try:
            scenario = load(name)
        except ScenarioError:
            continue
        mission = scenario.mission_type.name
        if mission not in found:
            found[mission] = misfit(leaf(type_name, "probe"), Probe.of(scenario)) is None
    return [mission for mission, fits in found.items() if fits]


def check_tree(tree: Node, scenario: Scenario, keys: Mapping[str, Any] | None = None) -> None:
    """Refuse a tree with a leaf that does not fit ``scenario``, before anything runs.

    Args:
        tree: the tree to run.
        scenario: the scenario it is run in.
        keys: the blackboard keys the tree writes besides the mission's, key -> dtype
            (default: found in the tree, ``bt.blackboard.tree_blackboard_keys``).

    Raises:
        TreeError: the first leaf that does not fit: its name and type, why, the missions
            it belongs to, and the leaves that fit (``pyaa leaves`` lists them all).
    """
    nodes = [node for node in tree.leaves() if node.type in LEAF_TYPES]
    if not nodes:
        return
    if keys is None:
        keys = tree_blackboard_keys(tree, scenario.create_mission().blackboard())
    probe = Probe.of(scenario, keys)
    for node in nodes:
        reason = misfit(node, probe)
        if reason is not None:
            raise TreeError(_refusal(node, reason, scenario, keys))


def _refusal(node: Node, reason: str, scenario: Scenario, keys: Mapping[str, Any] | None) -> str:
    """The message of :func:`check_tree` for ``node``, which does not fit ``scenario``."""
    mission = scenario.mission_type.name
    owners = [] if is_general(LEAF_TYPES.get(node.type)) else leaf_missions(node.type)
    owners = [m for m in owners if m != mission]
    belongs = f"; it is a leaf of mission {', '.join(owners)}" if owners else ""
    fits = [cls.type_name for cls in fitting_leaves(scenario, keys) if not is_general(cls)]
    return (
        f"leaf {node.name!r} ({node.type}) does not fit scenario {scenario.name!r} "
        f"(mission {mission}): {reason}{belongs}; leaves that fit: "
        f"{', '.join(_closest(node.type, fits)) or 'none'} "
        f"(all {len(fits)}, with their ports: pyaa leaves {scenario.name})"
    )


def _closest(name: str, names: list[str]) -> list[str]:
    """At most :data:`NAMED_FITS` of ``names``: those of the same kind as ``name``
    (``Action_``, ``Condition_``) first, the most alike first."""
    kind = name.split("_", 1)[0]

    def rank(other: str) -> tuple[bool, float]:
        alike = difflib.SequenceMatcher(None, name, other).ratio()
        return other.split("_", 1)[0] != kind, -alike

    return sorted(names, key=rank)[:NAMED_FITS]
