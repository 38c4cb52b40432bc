"""What a mission and a motion model see of a scenario: :class:`ScenarioView`.

:class:`~pyautonomousagent.simulation.scenario.Scenario` names its mission class, so the
mission API and the motion models, which the scenario imports, are typed with this protocol
instead (no import cycle). ``Scenario`` is one.
"""

from __future__ import annotations

from typing import Any, Protocol

from pyautonomousagent.simulation.params import Point, Values


class ScenarioView(Protocol):
    """A scenario, read-only: what is simulated, besides the seed and the engine (the
    attributes are :class:`~pyautonomousagent.simulation.scenario.Scenario`'s)."""

    @property
    def name(self) -> str: ...
    @property
    def agents(self) -> int: ...
    @property
    def iterations(self) -> int: ...
    @property
    def world(self) -> Point: ...
    @property
    def objects(self) -> Values: ...
    @property
    def initial_heading(self) -> float | str: ...
    @property
    def frame_every(self) -> int: ...
    @property
    def parameters(self) -> Values: ...
    @property
    def model(self) -> str: ...
    @property
    def model_settings(self) -> Any: ...
    @property
    def mission_type(self) -> type[Any]: ...
