"""A mission: the one unit a user writes to model a new agent, sensor, message or world.

A mission is a subclass of :class:`Mission`. Its class attributes declare what a scenario may
say about it (``parameters``, ``world_objects``) and what every agent carries (``columns``);
its methods are called by the generic loop:

- Phase 1, :meth:`Mission.blackboard` and :meth:`Mission.place`: the blackboard schema and
  where the agents start;
- Phase 2, :meth:`Mission.sense`: the sensors, over the swarm's arrays, and which agents can
  move; then the handlers of :meth:`Mission.message_types` act on last iteration's messages;
- Phase 7 and the replay, :meth:`Mission.marks`: what is drawn besides the agents (and
  :meth:`Mission.frame_marks`, what changes during the run, in the animation).

The loop (:mod:`pyautonomousagent.simulation.phases`) knows no mission: gathering, patrol,
vacuum and radiation-search (``pyautonomousagent.missions``) are written with this API only.
A scenario names its mission with ``mission:`` — a registered name, a Python file next to
the scenario (``mission.py`` or ``mission.py:ClassName``), a module (``package.module:Class``)
or an installed package's entry point in the group ``pyautonomousagent.missions``.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pyautonomousagent.datalink import Delivery
from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import HandlerKernel, SensorKernel
from pyautonomousagent.registry import Registry
from pyautonomousagent.render.marks import Mark
from pyautonomousagent.simulation.params import Param, Point, Reader, ScenarioError
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.recording import Recorder
    from pyautonomousagent.simulation.scenario_view import ScenarioView
    from pyautonomousagent.simulation.view import SimulationView

_REQUIRED = object()


@dataclass(frozen=True)
class WorldObject:
    """A kind of world object a scenario lists in its ``world:`` section.

    Attributes:
        name: the key in ``world:`` (e.g. ``"obstacles"``); ``world.objects[name]`` at run time.
        read: checks and converts the YAML value: ``read(reader, value, path)``; raise
            ``reader.fail(path, "what it must be", value)`` for bad input.
        default: the value when the scenario leaves it out; required when not given.
        doc: what it is, with units.
    """

    name: str
    read: Callable[[Reader, Any, str], Any]
    default: Any = _REQUIRED
    doc: str = ""

    @property
    def required(self) -> bool:
        """Whether a scenario must give it."""
        return self.default is _REQUIRED


@dataclass(frozen=True)
class MessageType:
    """A message type of a mission and what a receiver does with it.

    Attributes:
        name: the type leaves send (``world.datalink.send(..., type=name, ...)``).
        handle: ``handle(sim, delivery)``, called in the receivers' next Phase 2 with the
            messages of this type delivered last iteration; None to ignore them quietly.
        recorded: whether each message is written to the run's events.
        doc: what it carries.
        kernel: ``handle`` compiled, for the compiled engine's fused loop (see
            :class:`~pyautonomousagent.kernels.HandlerKernel`), or None: runs that send this
            type then tick compiled but deliver in Python, iteration by iteration.
    """

    name: str
    handle: Callable[[SimulationView, Delivery], None] | None
    recorded: bool = False
    doc: str = ""
    kernel: HandlerKernel | None = None


@njit
def _no_sensors(a: int) -> bool:
    """The default sensors for one agent: nothing is sensed, every agent moves."""
    return True


class Mission:
    """Base class of missions; subclass it, set the class attributes, override what you need.

    An instance belongs to one run: it is made by :meth:`Simulation.create` with the run's
    scenario and may keep run state of its own (e.g. what each agent heard).

    Class attributes:
        name: the mission's registered name.
        description: one line for listings.
        agent_prefix: agents are called ``<prefix>1``, ``<prefix>2``, ...
        parameters: typed parameters read from the scenario's ``parameters:``; leaf ports
            take their defaults from parameters of the same name.
        world_objects: what the scenario's ``world:`` section may list.
        columns: the mission's state columns, name -> dtype, recorded with the others
            (e.g. ``{"energy": np.float64}``); leaves read them as ``agents.energy``.
        meanings: unit and meaning of its columns and blackboard keys, name -> (unit,
            meaning), written into the data's schema and shown by the animation and replay.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    agent_prefix: ClassVar[str] = "agent"
    parameters: ClassVar[tuple[Param, ...]] = ()
    world_objects: ClassVar[tuple[WorldObject, ...]] = ()
    columns: ClassVar[Mapping[str, Any]] = {}
    meanings: ClassVar[Mapping[str, tuple[str, str]]] = {}

    def __init__(self, scenario: ScenarioView) -> None:
        self.scenario = scenario
        self.params = scenario.parameters

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """Checks across fields, after each field was read (e.g. a named agent exists);
        raise ``reader.fail(...)``. Nothing by default."""

    @classmethod
    def world_for(cls, scenario: ScenarioView, agents: int) -> Point:
        """The world (width, height), world units, that a run of ``scenario`` with ``agents``
        agents needs: the scenario's own by default; a mission whose layout grows with the
        swarm gives a larger one where the scenario's is too small (``pyaa bench`` runs
        swarms of any size in it)."""
        return scenario.world

    def blackboard(self) -> dict[str, Any]:
        """Phase 1: every agent's blackboard keys, key -> dtype (``number_ticks`` is added)."""
        return {}

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """Phase 1: initial state and blackboard values (arrays are zero before)."""

    def sense(self, sim: SimulationView) -> np.ndarray | None:
        """Phase 2: read the sensors into the swarm's columns.

        Returns:
            Which agents can move this iteration (bool, shape (N,)), or None for all.
        """
        return None

    def compiled_sensors(self, sim: SimulationView) -> SensorKernel | None:
        """Phase 2's :meth:`sense` for one agent, for the compiled engine; None where the
        sensors have no compiled form (the engine then calls :meth:`sense` every iteration).
        A mission that keeps the default :meth:`sense` senses nothing, which compiles."""
        if type(self).sense is Mission.sense:
            return SensorKernel(_no_sensors, ())
        return None

    def message_types(self) -> list[MessageType]:
        """The message types this mission's leaves send, with their handlers."""
        return []

    def marks(self) -> list[Mark]:
        """Static marks drawn on the world map (animation, replay), world units."""
        return []

    def frame_marks(self, recorder: Recorder, row: int) -> list[Mark]:
        """Marks that change during the run (e.g. the area cleaned so far), for record
        ``row`` of a recorded run, computed from the records (``recorder.columns[k][:row + 1]``,
        shape (records, N)); the animation draws them under the agents on every frame.
        Called on a fresh instance (no run state). None by default."""
        return []


MISSIONS: Registry[type[Mission]] = Registry("mission")


def register_mission(cls: type[Mission]) -> type[Mission]:
    """Class decorator: make a :class:`Mission` subclass known by its ``name``."""
    if not (isinstance(cls, type) and issubclass(cls, Mission)) or not cls.name:
        raise TypeError(f"register_mission takes a Mission subclass with a name, got {cls!r}")
    return MISSIONS.register(cls.name, cls)


ENTRY_POINT_GROUP = "pyautonomousagent.missions"


def resolve_mission(ref: str, folder: Path | None = None) -> type[Mission]:
    """The mission class a scenario's ``mission:`` names.

    Args:
        ref: a registered name; ``file.py`` or ``file.py:Class`` (relative to ``folder``);
            ``package.module:Class``; or the name of an entry point of group
            :data:`ENTRY_POINT_GROUP`.
        folder: the scenario file's folder, for relative file names.

    Raises:
        ScenarioError: nothing of that name, or the file/module has no such mission.
    """
    if ref in MISSIONS:
        return MISSIONS.get(ref)
    file, _, attribute = ref.partition(":") if ".py" in ref else ("", "", "")
    if file.endswith(".py"):
        path = Path(file) if folder is None else folder / file
        return _pick(_import_file(path.resolve()), attribute, ref)
    if ":" in ref:
        module_name, _, attribute = ref.partition(":")
        try:
            module = importlib.import_module(module_name)
        except ImportError as error:
            raise ScenarioError(
                f"mission {ref!r}: cannot import {module_name!r}: {error}"
            ) from None
        return _pick(module, attribute, ref)
    for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name == ref:
            loaded = entry.load()
            return _pick(sys.modules[loaded.__module__], loaded.__name__, ref)
    raise ScenarioError(
        MISSIONS.unknown_message(ref) + "; or name a file (mission: mission.py) or a module "
        "(mission: package.module:Class)"
    )


def _import_file(path: Path) -> Any:
    """Import a Python file once per process (its leaves and missions register on import)."""
    digest = hashlib.sha1(str(path).encode()).hexdigest()[:12]
    name = f"pyautonomousagent_user_{path.stem}_{digest}"
    if name in sys.modules:
        return sys.modules[name]
    if not path.is_file():
        raise ScenarioError(f"mission file {path} does not exist")
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ScenarioError(f"mission file {path} cannot be imported")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except Exception:
        del sys.modules[name]
        raise
    return module


def _pick(module: Any, attribute: str, ref: str) -> type[Mission]:
    """The Mission subclass ``attribute`` of ``module``, or its only one."""
    if attribute:
        found = getattr(module, attribute, None)
        if not (inspect.isclass(found) and issubclass(found, Mission)):
            raise ScenarioError(f"mission {ref!r}: {attribute!r} is not a Mission subclass")
        return found
    own = [
        c
        for c in vars(module).values()
        if inspect.isclass(c) and issubclass(c, Mission) and c.__module__ == module.__name__
    ]
    if len(own) != 1:
        names = ", ".join(c.__name__ for c in own) or "none"
        raise ScenarioError(
            f"mission {ref!r}: the file must define exactly one Mission subclass (found "
            f"{names}); name one as {ref}:ClassName"
        )
    return own[0]
