"""Which motion model a run uses: the scenario names the aircraft, the engine the implementation.

- ``model: drone2d`` (the default): the paper's 2-D drone, whatever the engine.
- ``model: x8``: the Skywalker X8. The py_trees engine flies the reference implementation
  (one PyFly simulator per agent, as the paper did); the batched engine flies the vectorised
  one. ``implementation`` overrides that choice, e.g. to hold the two against each other on
  the same engine.
"""

from __future__ import annotations

from importlib.util import find_spec
from typing import TYPE_CHECKING

from pyautonomousagent.models.drone2d import Drone2D, DroneParameters
from pyautonomousagent.models.x8 import X8Settings
from pyautonomousagent.simulation.scenario import Scenario, ScenarioError
from pyautonomousagent.state import Swarm

if TYPE_CHECKING:
    from pyautonomousagent.simulation.run import Model

#: X8 implementations: the PyFly reference and the vectorised model.
X8_IMPLEMENTATIONS = ("pyfly", "vectorised")


def x8_implementation(engine: str, implementation: str | None = None) -> str:
    """The X8 implementation for ``engine``: "vectorised" on "batched", else "pyfly"."""
    if implementation is None:
        return "vectorised" if engine == "batched" else "pyfly"
    if implementation not in X8_IMPLEMENTATIONS:
        raise ValueError(
            f"unknown X8 implementation {implementation!r}; choose from "
            f"{', '.join(X8_IMPLEMENTATIONS)}"
        )
    return implementation


def pyfly_installed() -> bool:
    """Whether ``pyfly-fixed-wing`` (the ``[x8]`` extra) can be imported."""
    return find_spec("pyfly") is not None


def build_model(
    scenario: Scenario, swarm: Swarm, engine: str, seed: int, implementation: str | None = None
) -> Model:
    """The motion model of ``scenario`` for ``swarm``, set at the agents' initial state.

    Args:
        scenario: the scenario (its ``model`` and settings).
        swarm: the agents after Phase 1; an X8 fills their columns from its state.
        engine: the decision engine's name.
        seed: the run's seed (seeds the PyFly simulators).
        implementation: for the X8, "pyfly" or "vectorised" instead of the engine's default.

    Raises:
        ScenarioError: the X8 without the ``[x8]`` extra, or with turbulence on the vectorised
            model.
    """
    p = scenario.parameters
    if scenario.model == "drone2d":
        return Drone2D(DroneParameters(p.max_speed, p.speed_step, p.turn_step), swarm.size)
    settings = scenario.x8 or X8Settings()
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
