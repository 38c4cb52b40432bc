"""What a mission and a motion model see of a scenario: :class:`ScenarioView`.

:class:`~pyautonomousagent.simulation.scenario.Scenario` names its mission class, so the
mission API and the motion models, which the scenario imports, are typed with this protocol
instead (no import cycle). ``Scenario`` is one.
"""

from __future__ import annotations

from typing import Any, Protocol

from pyautonomousagent.simulation.params import Point, Values


class ScenarioView(Protocol):
    """A scenario, read-only: what is simulated, besides the seed and the engine.

    Attributes:
        name: registry name, e.g. ``"gathering"``.
        agents: number of agents N.
        iterations: iterations to simulate.
        world: (width, height) in world units.
        objects: the mission's world objects, name -> validated value.
        initial_heading: degrees clockwise from north, or "random" (drawn from the seed).
        frame_every: iterations between animation frames.
        parameters: the core's, the motion model's and the mission's parameters.
        model: the motion model's name.
        model_settings: the motion model's own settings section (e.g. ``x8:``), or None.
        mission_type: the mission class.
    """

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
