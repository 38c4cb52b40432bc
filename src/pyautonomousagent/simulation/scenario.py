"""A scenario: agents, world, tree and parameters, validated from a plain mapping (YAML).

Every field is checked with a message that names it: a negative count, a string where a
number belongs or an unknown key raise :class:`ScenarioError` with one clear line.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pyautonomousagent.inputs import InputError, finite, shown
from pyautonomousagent.models.x8 import TURBULENCE_INTENSITIES, X8Settings
from pyautonomousagent.sensors import RadiationSource

Point = tuple[float, float]

#: Motion models a scenario can name: the paper's 2-D drone and the Skywalker X8 (6-DOF).
MODELS = ("drone2d", "x8")


class ScenarioError(InputError):
    """Bad scenario input; the message names the field and what it must be."""


@dataclass(frozen=True)
class Parameters:
    """Model and behaviour parameters; leaf ports take their defaults from here.

    Speeds are world units per iteration, rates percent per iteration, levels percent.
    """

    reference_speed: float = 0.1
    max_speed: float = 0.1
    speed_step: float = 0.1
    turn_step: float = 1.0
    energy_use: float = 0.05
    refuel_rate: float = 2.0
    low_energy_threshold: float = 40.0
    destination_tolerance: float = 0.5
    radiation_damage_factor: float = 0.1
    radiation_threshold: float = 0.0
    damage_limit: float = 70.0
    repair_rate: float = 1.0
    datalink_range: float = 1000.0
    gathering_iteration: int = 5000
    gathering_sender: str = "drone1"


@dataclass(frozen=True)
class Scenario:
    """Everything a run needs besides the seed and the engine.

    Attributes:
        name: registry name, e.g. ``"gathering"``.
        description: one line for ``pyaa scenarios``.
        tree: the behaviour tree: a tree file (.xml, .yaml; relative paths are resolved
            against the scenario file by :func:`pyautonomousagent.scenarios.load`) or a
            built-in tree name (see :mod:`pyautonomousagent.bt.trees`).
        agents: number of agents N (named ``drone1``..``droneN``).
        iterations: iterations to simulate.
        world: (width, height) in world units.
        refueling_positions: refuelling slots, used in turn by agents 1, 2, ... (cycled).
        surveillance_positions: surveillance positions, used in turn (cycled); may be
            left out when ``patrol_positions`` is given.
        patrol_positions: the two positions patrolled by every agent, or (); the first is
            every agent's first surveillance position.
        initial_heading: degrees clockwise from north, or "random" (drawn from the seed).
        frame_every: iterations between animation frames.
        radiation_sources: sources of the radiation sensor.
        parameters: model and behaviour parameters.
        model: the motion model, one of :data:`MODELS`.
        x8: the X8's settings when ``model`` is "x8", else None.
    """

    name: str
    description: str
    tree: str
    agents: int
    iterations: int
    world: Point
    refueling_positions: tuple[Point, ...]
    surveillance_positions: tuple[Point, ...] = ()
    patrol_positions: tuple[Point, ...] = ()
    initial_heading: float | str = 0.0
    frame_every: int = 10
    radiation_sources: tuple[RadiationSource, ...] = ()
    parameters: Parameters = field(default_factory=Parameters)
    model: str = "drone2d"
    x8: X8Settings | None = None

    @classmethod
    def from_mapping(cls, data: Any, source: str = "scenario") -> Scenario:
        """Validate a mapping (a parsed YAML file) into a scenario.

        Raises:
            ScenarioError: naming ``source`` and the offending field.
        """
        return _Reader(source).scenario(data)

    def with_overrides(self, **changes: Any) -> Scenario:
        """A copy with top-level fields or ``parameters`` keys replaced, validated again.

        ``None`` values are ignored, so CLI options that were not given change nothing.
        """
        data = to_mapping(self)
        for key, value in changes.items():
            if value is None:
                continue
            if key in data["parameters"] and key not in data:
                data["parameters"][key] = value
            else:
                data[key] = value
        return Scenario.from_mapping(data, source=f"scenario {self.name!r}")


def to_mapping(scenario: Scenario) -> dict[str, Any]:
    """The scenario as plain data (what :meth:`Scenario.from_mapping` reads back)."""
    data = dataclasses.asdict(scenario)
    data["radiation_sources"] = [dataclasses.asdict(s) for s in scenario.radiation_sources]
    for key in ("world", "refueling_positions", "surveillance_positions", "patrol_positions"):
        data[key] = _lists(data[key])
    return data


def _lists(value: Any) -> Any:
    return [_lists(v) for v in value] if isinstance(value, list | tuple) else value


class _Reader:
    """Checks one field at a time, naming it in every error."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, must: str, value: Any) -> ScenarioError:
        return ScenarioError(f"{self.source}: {path} must be {must}, got {shown(value)}")

    def keys(self, data: Any, path: str, allowed: list[str], required: list[str]) -> dict[str, Any]:
        if not isinstance(data, Mapping):
            raise self.fail(path or "the file", "a mapping of keys to values", data)
        for key in data:
            if key not in allowed:
                close = difflib.get_close_matches(str(key), allowed, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                where = f"{path}.{key}" if path else str(key)
                raise ScenarioError(f"{self.source}: unknown key {shown(where)}{hint}")
        for key in required:
            if key not in data:
                raise ScenarioError(
                    f"{self.source}: missing key {f'{path}.{key}' if path else key!r}"
                )
        return dict(data)

    def number(
        self,
        value: Any,
        path: str,
        kind: type = float,
        minimum: float | None = None,
        above: float | None = None,
    ) -> Any:
        whole = kind is int
        must = "a whole number" if whole else "a number"
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(path, must, value)
        if not finite(value):
            raise self.fail(path, f"a finite {must[2:]}", value)
        if whole and float(value) != int(value):
            raise self.fail(path, must, value)
        if minimum is not None and value < minimum:
            raise self.fail(path, f"{must} >= {minimum:g}", value)
        if above is not None and value <= above:
            raise self.fail(path, f"{must} > {above:g}", value)
        return kind(value)

    def text(self, value: Any, path: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.fail(path, "a non-empty string", value)
        return value

    def point(self, value: Any, path: str) -> Point:
        if not isinstance(value, list | tuple) or len(value) != 2:
            raise self.fail(path, "a pair [x, y]", value)
        return (self.number(value[0], f"{path}[0]"), self.number(value[1], f"{path}[1]"))

    def points(
        self, value: Any, path: str, least: int = 1, most: int | None = None
    ) -> tuple[Point, ...]:
        if (
            not isinstance(value, list | tuple)
            or len(value) < least
            or (most and len(value) > most)
        ):
            count = f"exactly {least}" if least == most else f"at least {least}"
            raise self.fail(path, f"a list of {count} [x, y] pairs", value)
        return tuple(self.point(p, f"{path}[{i}]") for i, p in enumerate(value))

    def parameters(self, data: Any) -> Parameters:
        fields = {f.name: f for f in dataclasses.fields(Parameters)}
        given = self.keys(data, "parameters", list(fields), [])
        values: dict[str, Any] = {}
        for key, value in given.items():
            default = getattr(Parameters(), key)
            path = f"parameters.{key}"
            if isinstance(default, str):
                values[key] = self.text(value, path)
            else:
                values[key] = self.number(value, path, type(default), minimum=0)
        return Parameters(**values)

    def x8_settings(self, data: Any, model: str) -> X8Settings | None:
        """The ``x8`` mapping as :class:`X8Settings` (defaults for a missing key), or None."""
        if model != "x8":
            if data is not None:
                raise self.fail("model", '"x8" when x8 settings are given', model)
            return None
        fields = {f.name: f for f in dataclasses.fields(X8Settings)}
        given = self.keys(data if data is not None else {}, "x8", list(fields), [])
        values: dict[str, Any] = {}
        for key, value in given.items():
            default, path = getattr(X8Settings(), key), f"x8.{key}"
            if isinstance(default, bool):
                if not isinstance(value, bool):
                    raise self.fail(path, "true or false", value)
                values[key] = value
            elif isinstance(default, str):
                if value not in TURBULENCE_INTENSITIES:
                    raise self.fail(path, f"one of {', '.join(TURBULENCE_INTENSITIES)}", value)
                values[key] = value
            else:
                above = 0 if key in ("dt", "initial_airspeed") else None
                values[key] = self.number(value, path, float, minimum=0, above=above)
        return X8Settings(**values)

    def radiation(self, data: Any) -> tuple[RadiationSource, ...]:
        if not isinstance(data, list):
            raise self.fail("radiation_sources", "a list", data)
        sources = []
        for i, item in enumerate(data):
            path = f"radiation_sources[{i}]"
            item = self.keys(item, path, ["x", "y", "range", "active"], ["x", "y", "range"])
            active = item.get("active", False)
            if not isinstance(active, bool):
                raise self.fail(f"{path}.active", "true or false", active)
            x, y = self.number(item["x"], f"{path}.x"), self.number(item["y"], f"{path}.y")
            sources.append(
                RadiationSource(x, y, self.number(item["range"], f"{path}.range", above=0), active)
            )
        return tuple(sources)

    def scenario(self, data: Any) -> Scenario:
        allowed = [f.name for f in dataclasses.fields(Scenario)]
        required = ["name", "tree", "agents", "iterations", "world", "refueling_positions"]
        d = self.keys(data, "", allowed, required)
        heading = d.get("initial_heading", 0.0)
        if heading != "random":
            heading = self.number(heading, "initial_heading")
        world = self.point(d["world"], "world")
        if min(world) <= 0:
            raise self.fail("world", "a positive [width, height]", d["world"])
        return Scenario(
            name=self.text(d["name"], "name"),
            description=str(d.get("description", "")),
            tree=self.text(d["tree"], "tree"),
            agents=self.number(d["agents"], "agents", int, minimum=1),
            iterations=self.number(d["iterations"], "iterations", int, minimum=1),
            world=world,
            refueling_positions=self.points(d["refueling_positions"], "refueling_positions"),
            surveillance_positions=self.points(
                d.get("surveillance_positions"), "surveillance_positions"
            )
            if d.get("surveillance_positions") or not d.get("patrol_positions")
            else (),
            patrol_positions=self.points(d["patrol_positions"], "patrol_positions", 2, 2)
            if d.get("patrol_positions")
            else (),
            initial_heading=heading,
            frame_every=self.number(d.get("frame_every", 10), "frame_every", int, minimum=1),
            radiation_sources=self.radiation(d.get("radiation_sources", [])),
            parameters=self.parameters(d.get("parameters", {})),
            model=self.model(d.get("model", "drone2d")),
            x8=self.x8_settings(d.get("x8"), d.get("model", "drone2d")),
        )

    def model(self, value: Any) -> str:
        if value not in MODELS:
            raise self.fail("model", f"one of {', '.join(MODELS)}", value)
        return str(value)
