"""A scenario: mission, agents, world, tree and parameters, validated from a plain mapping (YAML).

The generic fields are checked here; the ``parameters:`` against the parameters the core, the
motion model and the mission declare, and the ``world:`` objects against the mission's
:class:`~pyautonomousagent.simulation.mission.WorldObject` list. Every error is a
:class:`ScenarioError` with one line naming the field.

A scenario file::

    name: gathering
    mission: gathering          # a registered mission, or mission.py next to this file
    tree: gathering.xml
    agents: 4
    iterations: 8000
    world:
      size: [100, 100]          # width, height (world units)
      refueling_positions: [[20, 65], [20, 55]]   # the mission's world objects
    parameters:
      low_energy_threshold: 40
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyautonomousagent.simulation.mission import Mission, resolve_mission
from pyautonomousagent.simulation.motion import MOTION_MODELS, MotionModel
from pyautonomousagent.simulation.params import (
    Param,
    Point,
    Reader,
    ScenarioError,
    Values,
    plain,
)
from pyautonomousagent.simulation.scenario_view import ScenarioView

#: Parameters of the core itself (the datalink is part of the core).
CORE_PARAMETERS = (
    Param(
        "datalink_range",
        1000.0,
        "world units",
        "largest sender-receiver distance a message crosses",
        minimum=0.0,
    ),
)

REQUIRED = ("name", "mission", "tree", "agents", "iterations", "world")
#: The top-level keys of a scenario file other than the motion model's settings section.
FIELDS = (*REQUIRED, "description", "initial_heading", "frame_every", "parameters", "model")


@dataclass(frozen=True)
class Scenario:
    """Everything a run needs besides the seed and the engine.

    Attributes:
        name: registry name, e.g. ``"gathering"``.
        description: one line for ``pyaa scenarios``.
        mission: the mission as the file names it (files and folders made absolute).
        tree: the behaviour tree: a tree file (.xml, .yaml; relative paths are resolved
            against the scenario file by :func:`pyautonomousagent.scenarios.load`) or a
            built-in tree name (see :mod:`pyautonomousagent.bt.trees`).
        agents: number of agents N.
        iterations: iterations to simulate.
        world: (width, height) in world units.
        objects: the mission's world objects, name -> validated value.
        initial_heading: degrees clockwise from north, or "random" (drawn from the seed).
        frame_every: iterations between animation frames.
        parameters: the core's, the motion model's and the mission's parameters.
        model: the motion model, a name of :data:`MOTION_MODELS`.
        model_settings: the motion model's own settings section (e.g. ``x8:``), or None.
        mission_type: the mission class (resolved from ``mission``).
        overrides: what :meth:`with_overrides` changed since the scenario was read, name ->
            value, in order (``save_run`` records it in ``run.json``).
    """

    name: str
    description: str
    mission: str
    tree: str
    agents: int
    iterations: int
    world: Point
    objects: Values = field(default_factory=Values)
    initial_heading: float | str = 0.0
    frame_every: int = 10
    parameters: Values = field(default_factory=Values)
    model: str = "drone2d"
    model_settings: Any = None
    mission_type: type[Mission] = field(default=Mission, compare=False, repr=False)
    overrides: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def from_mapping(
        cls, data: Any, source: str = "scenario", folder: Path | None = None
    ) -> Scenario:
        """Validate a mapping (a parsed YAML file) into a scenario.

        Args:
            data: the parsed file.
            source: the file's name, for messages.
            folder: the file's folder: a mission file (``mission: mine.py``) is found there.

        Raises:
            ScenarioError: naming ``source`` and the offending field.
        """
        return _read(Reader(source), data, folder)

    def with_overrides(self, **changes: Any) -> Scenario:
        """A copy with top-level fields, ``parameters`` keys or world objects replaced,
        validated again.

        ``None`` values are ignored, so CLI options that were not given change nothing.
        """
        data = to_mapping(self)
        applied = {k: v for k, v in changes.items() if v is not None}
        for key, value in applied.items():
            if key in data["parameters"] and key not in data:
                data["parameters"][key] = value
            elif key in data["world"] and key not in data:
                data["world"][key] = value
            else:
                data[key] = value
        changed = _read(Reader(f"scenario {self.name!r}"), data, None)
        return dataclasses.replace(changed, overrides={**self.overrides, **applied})

    def create_mission(self) -> Mission:
        """A new instance of the scenario's mission, for one run."""
        return self.mission_type(self)


def to_mapping(scenario: Scenario) -> dict[str, Any]:
    """The scenario as plain data (what :meth:`Scenario.from_mapping` reads back)."""
    data: dict[str, Any] = {
        "name": scenario.name,
        "description": scenario.description,
        "mission": scenario.mission,
        "tree": scenario.tree,
        "agents": scenario.agents,
        "iterations": scenario.iterations,
        "world": {"size": list(scenario.world), **plain(scenario.objects)},
        "initial_heading": scenario.initial_heading,
        "frame_every": scenario.frame_every,
        "parameters": plain(scenario.parameters),
        "model": scenario.model,
    }
    section = MOTION_MODELS.get(scenario.model).section
    if section and scenario.model_settings is not None:
        data[section] = plain(scenario.model_settings)
    return data


def parameter_list(scenario: Scenario) -> list[tuple[str, Param]]:
    """(owner, parameter) of every parameter a scenario has: core, motion model, mission."""
    model = MOTION_MODELS.get(scenario.model)
    return [
        *(("core", p) for p in CORE_PARAMETERS),
        *((f"model {model.name}", p) for p in model.parameters),
        *((f"mission {scenario.mission_type.name}", p) for p in scenario.mission_type.parameters),
    ]


def _read(reader: Reader, data: Any, folder: Path | None) -> Scenario:
    if not isinstance(data, Mapping):
        raise reader.fail("the file", "a mapping of keys to values", data)
    model_name = data.get("model", "drone2d")
    if model_name not in MOTION_MODELS:
        raise ScenarioError(f"{reader.source}: model: {MOTION_MODELS.unknown_message(model_name)}")
    model = MOTION_MODELS.get(model_name)
    allowed = [*FIELDS, *([model.section] if model.section else [])]
    d = reader.keys(data, "", allowed, list(REQUIRED))
    mission_ref = reader.text(d["mission"], "mission")
    mission = resolve_mission(mission_ref, folder)
    if folder is not None and ".py" in mission_ref:
        file, sep, rest = mission_ref.partition(":")
        mission_ref = str((folder / file).resolve()) + sep + rest
    size, objects = _world(reader, d["world"], mission)
    scenario = Scenario(
        name=_name(reader, d["name"]),
        description=str(d.get("description", "")),
        mission=mission_ref,
        tree=reader.text(d["tree"], "tree"),
        agents=reader.number(d["agents"], "agents", int, minimum=1),
        iterations=reader.number(d["iterations"], "iterations", int, minimum=1),
        world=size,
        objects=objects,
        initial_heading=_heading(reader, d.get("initial_heading", 0.0)),
        frame_every=reader.number(d.get("frame_every", 10), "frame_every", int, minimum=1),
        parameters=reader.params(
            d.get("parameters"), [*CORE_PARAMETERS, *model.parameters, *mission.parameters]
        ),
        model=model.name,
        model_settings=_settings(reader, model, d),
        mission_type=mission,
    )
    mission.check(scenario, reader)
    return scenario


def _name(reader: Reader, value: Any) -> str:
    """A scenario name: it names the run's folder, so no path separators or dots first."""
    name = reader.text(value, "name")
    if "/" in name or "\\" in name or name.startswith(".") or len(name) > 100:
        raise reader.fail("name", "a plain name (no '/', '\\' or leading '.')", value)
    return name


def _heading(reader: Reader, value: Any) -> float | str:
    if value == "random":
        return "random"
    return reader.number(value, "initial_heading")


def _world(reader: Reader, value: Any, mission: type[Mission]) -> tuple[Point, Values]:
    """``world:`` as (width, height) and the mission's objects; ``[w, h]`` is short for
    ``{size: [w, h]}``."""
    if isinstance(value, list | tuple):
        value = {"size": value}
    kinds = {o.name: o for o in mission.world_objects}
    required = ["size", *(o.name for o in kinds.values() if o.required)]
    given = reader.keys(value, "world", ["size", *kinds], required)
    width, height = reader.point(given["size"], "world.size")
    if width <= 0 or height <= 0:
        raise reader.fail("world.size", "a positive [width, height]", given["size"])
    objects = {
        name: kind.read(reader, given[name], f"world.{name}") if name in given else kind.default
        for name, kind in kinds.items()
    }
    return (width, height), Values(**objects)


def _settings(reader: Reader, model: MotionModel, d: dict[str, Any]) -> Any:
    if model.read_settings is None:
        return None
    return model.read_settings(reader, d.get(model.section or ""))


def check_point_in_world(reader: Reader, scenario: ScenarioView, point: Point, path: str) -> None:
    """Raise if ``point`` lies outside ``[0, width] x [0, height]``."""
    width, height = scenario.world
    if not (0.0 <= point[0] <= width and 0.0 <= point[1] <= height):
        raise reader.fail(path, f"inside the world [0, {width:g}] x [0, {height:g}]", list(point))


__all__ = [
    "CORE_PARAMETERS",
    "Scenario",
    "ScenarioError",
    "check_point_in_world",
    "parameter_list",
    "to_mapping",
]
