"""Motion models: a registry of the aircraft a scenario can name with ``model:``.

- ``drone2d`` (the default): the paper's 2-D drone, whatever the engine; its parameters
  (``max_speed``, ``speed_step``, ``turn_step``) are read from ``parameters:``.
- ``drone3d``: the 2-D drone with altitude and climb rate (docs/drone3d.md); its mission
  declares the columns it moves (``models.drone3d.COLUMNS_3D``);
- ``x8``: the Skywalker X8, with its settings in the scenario's ``x8:`` section. The py_trees
  engine flies the reference implementation (one PyFly simulator per agent, as the paper
  did); the batched engine flies the vectorised one. ``implementation`` overrides that
  choice, e.g. to hold the two against each other on the same engine.

A new model is one :class:`MotionModel` record registered in :data:`MOTION_MODELS`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from importlib.util import find_spec
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from pyautonomousagent.models.drone2d import Drone2D, DroneParameters
from pyautonomousagent.models.drone3d import COLUMNS_3D, Drone3D, Drone3DParameters
from pyautonomousagent.models.x8 import TURBULENCE_INTENSITIES, X8Settings
from pyautonomousagent.registry import Registry
from pyautonomousagent.simulation.params import Param, Reader, ScenarioError
from pyautonomousagent.state import Swarm

if TYPE_CHECKING:
    from pyautonomousagent.simulation.scenario_view import ScenarioView


class Model(Protocol):
    """What the loop needs of a motion model."""

    name: str

    def columns(self) -> dict[str, np.ndarray]: ...

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None: ...

    def control(self, s: dict[str, np.ndarray]) -> None: ...


@dataclass(frozen=True)
class MotionModel:
    """A motion model a scenario can name.

    Attributes:
        name: the scenario's ``model:`` value.
        build: ``build(scenario, swarm, engine, seed, implementation)`` -> the model, set at
            the agents' initial state.
        parameters: its parameters, read from the scenario's ``parameters:``.
        section: the top-level key of its own settings (e.g. ``"x8"``), or None.
        read_settings: ``read_settings(reader, mapping or None)`` -> its settings.
        doc: one line.
    """

    name: str
    build: Callable[[ScenarioView, Swarm, str, int, str | None], Model]
    parameters: tuple[Param, ...] = ()
    section: str | None = None
    read_settings: Callable[[Reader, Any], Any] | None = None
    doc: str = ""


MOTION_MODELS: Registry[MotionModel] = Registry("motion model")

#: X8 implementations: the PyFly reference and the vectorised model.
X8_IMPLEMENTATIONS = ("pyfly", "vectorised")


def x8_implementation(engine: str, implementation: str | None = None) -> str:
    """The X8 implementation for ``engine``: "pyfly" on "pytrees", else "vectorised"."""
    if implementation is None:
        return "pyfly" if engine == "pytrees" else "vectorised"
    if implementation not in X8_IMPLEMENTATIONS:
        raise ValueError(
            f"unknown X8 implementation {implementation!r}; choose from "
            f"{', '.join(X8_IMPLEMENTATIONS)}"
        )
    return implementation


def pyfly_installed() -> bool:
    """Whether ``pyfly-fixed-wing`` (the ``[x8]`` extra) can be imported."""
    return find_spec("pyfly") is not None


def _drone2d(
    scenario: ScenarioView, swarm: Swarm, engine: str, seed: int, implementation: str | None
) -> Model:
    p = scenario.parameters
    return Drone2D(DroneParameters(p.max_speed, p.speed_step, p.turn_step), swarm.size)


def _drone3d(
    scenario: ScenarioView, swarm: Swarm, engine: str, seed: int, implementation: str | None
) -> Model:
    """The 3-D drone; its mission must declare the columns of ``COLUMNS_3D``.

    Raises:
        ScenarioError: a column is missing.
    """
    missing = [k for k in COLUMNS_3D if k not in swarm.columns]
    if missing:
        raise ScenarioError(
            f"scenario {scenario.name!r}: model drone3d moves the state columns "
            f"{', '.join(COLUMNS_3D)}, which mission {scenario.mission_type.name!r} does not "
            "declare (add them to its columns: models.drone3d.COLUMNS_3D)"
        )
    p = scenario.parameters
    params = Drone3DParameters(
        p.max_speed, p.speed_step, p.turn_step, p.max_climb_rate, p.climb_step, p.max_altitude
    )
    return Drone3D(params, swarm.size)


def _x8(
    scenario: ScenarioView, swarm: Swarm, engine: str, seed: int, implementation: str | None
) -> Model:
    """The X8: vectorised on the batched engine, PyFly on the py_trees engine.

    Raises:
        ScenarioError: without the ``[x8]`` extra, or with turbulence on the vectorised model.
    """
    settings = scenario.model_settings or X8Settings()
    if not pyfly_installed():
        raise ScenarioError(
            f"scenario {scenario.name!r} flies the Skywalker X8, which needs the [x8] extra: "
            'pip install "pyautonomousagent[x8]"'
        )
    if x8_implementation(engine, implementation) == "vectorised":
        from pyautonomousagent.models.x8 import X8Vectorised

        if settings.turbulence:
            raise ScenarioError(
                "x8.turbulence is available on the PyFly reference model only "
                "(engine 'pytrees'); the vectorised X8 flies in still air"
            )
        return X8Vectorised(settings, swarm.columns)
    from pyautonomousagent.models.x8_pyfly import X8PyFly

    return X8PyFly(settings, swarm.columns, seed)


def read_x8_settings(reader: Reader, data: Any) -> X8Settings:
    """The ``x8:`` mapping as :class:`X8Settings` (defaults for a missing key)."""
    fields = [f.name for f in dataclasses.fields(X8Settings)]
    given = reader.keys(data if data is not None else {}, "x8", fields, [])
    values: dict[str, Any] = {}
    for key, value in given.items():
        default, path = getattr(X8Settings(), key), f"x8.{key}"
        if isinstance(default, bool):
            values[key] = reader.flag(value, path)
        elif isinstance(default, str):
            if value not in TURBULENCE_INTENSITIES:
                raise reader.fail(path, f"one of {', '.join(TURBULENCE_INTENSITIES)}", value)
            values[key] = value
        else:
            above = 0 if key in ("dt", "initial_airspeed") else None
            values[key] = reader.number(value, path, float, minimum=0, above=above)
    return X8Settings(**values)


def _at_least_zero(defaults: Any, *rows: tuple[str, str, str]) -> tuple[Param, ...]:
    """Parameters ``(name, unit, doc)`` >= 0, their defaults ``defaults``' attributes."""
    return tuple(Param(n, getattr(defaults, n), unit, doc, minimum=0.0) for n, unit, doc in rows)


_DRONE2D = _at_least_zero(
    DroneParameters(),
    ("max_speed", "world units per iteration", "upper speed limit"),
    ("speed_step", "world units per iteration", "magnitude of the speed control signal u_v"),
    ("turn_step", "degrees per iteration", "magnitude of the heading control signal u_a"),
)
_DRONE3D = _at_least_zero(
    Drone3DParameters(),
    ("max_climb_rate", "world units per iteration", "largest climb or sink rate"),
    (
        "climb_step",
        "world units per iteration per iteration",
        "largest change of the climb rate in one iteration (u_w)",
    ),
    ("max_altitude", "world units", "ceiling above the ground"),
)
for _model in (
    MotionModel(
        "drone2d", _drone2d, _DRONE2D, doc="the paper's 2-D drone (eqs. 1-4) with bang-bang control"
    ),
    MotionModel(
        "drone3d",
        _drone3d,
        (*_DRONE2D, *_DRONE3D),
        doc="the 2-D drone with altitude and climb rate (docs/drone3d.md)",
    ),
    MotionModel(
        "x8",
        _x8,
        section="x8",
        read_settings=read_x8_settings,
        doc="the Skywalker X8 6-DOF fixed wing (the [x8] extra)",
    ),
):
    MOTION_MODELS.register(_model.name, _model)
