"""The simulation: the swarm, its world, mission and engine, and the loop in the paper's order."""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from pyautonomousagent.bt.behaviours import BEHAVIOUR_TYPES
from pyautonomousagent.bt.blackboard import tree_blackboard_keys
from pyautonomousagent.bt.files import is_tree_file, load_tree
from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.trees import tree_by_name
from pyautonomousagent.datalink import Delivery
from pyautonomousagent.engines.batched import BatchedEngine
from pyautonomousagent.engines.compiled import CompiledEngine, compilable
from pyautonomousagent.engines.gpu import GpuEngine, auto_takes_gpu, require_gpu
from pyautonomousagent.engines.pytrees import PyTreesEngine
from pyautonomousagent.inputs import shown
from pyautonomousagent.progress import LINE_SECONDS, Progress
from pyautonomousagent.recording import (
    Recorder,
    available_memory,
    check_memory,
    to_table,
    trace_table,
    traced_agents,
)
from pyautonomousagent.registry import Registry
from pyautonomousagent.simulation import phases
from pyautonomousagent.simulation.costs import pick_engine, run_costs
from pyautonomousagent.simulation.engine_api import Engine, fuses
from pyautonomousagent.simulation.fit import check_tree
from pyautonomousagent.simulation.mission import MessageType, Mission
from pyautonomousagent.simulation.motion import MOTION_MODELS, Model
from pyautonomousagent.simulation.scenario import Scenario, ScenarioError, to_mapping
from pyautonomousagent.state import CONTROL_COLUMNS, MOTION_COLUMNS, Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.kernels import SensorKernel

log = logging.getLogger("pyautonomousagent")


def _checked(
    scenario: Any, seed: Any, engine: Any, record_every: Any, tree: Any
) -> tuple[Scenario, Node | None]:
    """The arguments of :meth:`Simulation.create`, checked: TypeError or ValueError naming
    the argument. A scenario built directly is validated like a scenario file; a tree may
    be given as a tree file's path."""
    if not isinstance(scenario, Scenario):
        raise TypeError(
            f"scenario must be a Scenario, e.g. load({shown(scenario)}), got "
            f"{type(scenario).__name__}"
        )
    checked = Scenario.from_mapping(to_mapping(scenario), source=f"scenario {scenario.name!r}")
    scenario = dataclasses.replace(checked, overrides=dict(scenario.overrides))
    for name, value, least in (("seed", seed, 0), ("record_every", record_every, 1)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise TypeError(
                f"{name} must be a whole number, got {type(value).__name__} {shown(value)}"
            )
        if value < least:
            raise ValueError(f"{name} must be >= {least}, got {value}")
    if not isinstance(engine, str):
        raise TypeError(f"engine must be a name such as 'batched', got {shown(engine)}")
    if engine != "auto" and engine not in ENGINES:
        raise ValueError(f"engine: {ENGINES.unknown_message(engine)} (or 'auto')")
    if isinstance(tree, str | Path):
        return scenario, load_tree(tree)
    if tree is not None and not isinstance(tree, Node):
        raise TypeError(
            "tree must be a tree description (pyautonomousagent.bt) or a tree file's path, "
            f"got {type(tree).__name__}"
        )
    return scenario, tree


def recorded_columns(mission: Mission, tree: Node) -> int:
    """How many columns a run of ``tree`` in ``mission`` records (the motion model's aside)."""
    columns = len(MOTION_COLUMNS) + len(CONTROL_COLUMNS) + len(mission.columns)
    columns += 1 + len(mission.blackboard())  # number_ticks and the mission's keys
    return columns + len(tree_blackboard_keys(tree, mission.blackboard()))  # and the tree's


def _fitting_engine(
    scenario: Scenario, mission: Mission, tree: Node, engine: str, every: int
) -> str:
    """The run's engine (for "auto", :func:`choose_engine`'s), once a run whose records
    cannot fit in memory is refused, before anything is allocated."""
    columns = recorded_columns(mission, tree)
    if engine == "auto":
        engine = choose_engine(tree, scenario.agents, scenario.iterations, every, columns)
    nodes = sum(1 for _ in tree.walk())
    per_agent = 100 + nodes * (2000 if engine == "pytrees" else 16)
    check_memory(scenario.agents, scenario.iterations, every, columns, per_agent)
    return engine


#: Iterations a :class:`FusedEngine` runs per call of its ``loop`` (the progress bar's step).
FUSED = 500


#: What makes a run's decision engine: ``(tree, swarm, world, defaults) -> engine``.
EngineFactory = Callable[[Node, Swarm, World, Mapping[str, Any]], Engine]


def gpu_engine(tree: Node, swarm: Swarm, world: World, defaults: Mapping[str, Any]) -> GpuEngine:
    """The GPU engine on a compiled engine of ``tree``, its host: the host ticks the
    iterations stepped on the CPU and writes the per-agent code of the kernels (the two
    engines import none of each other).

    Raises:
        GpuUnavailableError: no numba-cuda, CuPy or device (checked first).
        TreeError: the compiled engine cannot take ``tree``.
    """
    require_gpu()
    return GpuEngine(CompiledEngine(tree, swarm, world, defaults))


ENGINES: Registry[EngineFactory] = Registry("engine")
ENGINES.register("pytrees", PyTreesEngine)
ENGINES.register("batched", BatchedEngine)
ENGINES.register("compiled", CompiledEngine)
ENGINES.register("gpu", gpu_engine)  # needs numba-cuda and a device (engines/gpu.py)


def choose_engine(
    tree: Node,
    agents: int = 10**6,
    iterations: int = 4000,
    record_every: int = 1,
    columns: int = 21,
    compiled_ready: bool = False,
) -> str:
    """The engine "auto" picks for a run of ``agents`` x ``iterations`` recording every
    ``record_every``-th iteration of ``columns`` columns: "pytrees" if a leaf of ``tree``
    is a hand-written py_trees behaviour; else "gpu" where the tree compiles and
    :func:`~pyautonomousagent.engines.gpu.auto_takes_gpu`; else the faster of "batched" and
    "compiled" within the memory by their estimated costs
    (:func:`~pyautonomousagent.simulation.costs.run_costs`: the compile is paid unless
    ``compiled_ready``, the loop is in numba's cache), "batched" where the tree does not
    compile (:func:`~pyautonomousagent.engines.compiled.compilable`). The figures:
    docs/performance.md, "How auto chooses". :meth:`Simulation.create` asks again with
    ``compiled_ready`` and takes "compiled" where the GPU kernel cannot run the run."""
    if any(node.type in BEHAVIOUR_TYPES for node in tree.leaves()):
        return "pytrees"
    if auto_takes_gpu(agents, iterations) and not compilable(tree):
        return "gpu"
    costs = run_costs(agents, iterations, record_every, columns, compiled_ready)
    if pick_engine(costs, available_memory()) == "batched":
        return "batched"
    why = compilable(tree)
    if why:
        log.debug("engine auto: batched, not compiled: %s", why)
        return "batched"
    return "compiled"


def scenario_tree(scenario: Scenario) -> Node:
    """The scenario's tree: loaded from its tree file, or a built-in tree by name."""
    if is_tree_file(scenario.tree):
        return load_tree(scenario.tree)
    return tree_by_name(scenario.tree)


@dataclass
class Simulation:
    """One run of a scenario. Make it with :meth:`create`, then :meth:`run` or :meth:`step`.

    Attributes:
        scenario: what is simulated.
        seed: the seed of ``rng``.
        rng: the run's source of sequential randomness (placement, sensors).
        mission: the run's mission (its sensors, message handlers, run state).
        swarm: the agents' state and blackboards.
        world: the shared world (clock, datalink, world objects, counter-based randomness).
        model: the motion model (Phase 2 motion, Phase 4 control).
        engine: the decision engine of Phase 3.
        recorder: Phase 6's preallocated records.
        handlers: the mission's message types by name.
        inbox: messages delivered in Phase 5, acted on in the next Phase 2.
        events: alerts and recorded messages, as plain dicts.
        timings: seconds spent per stage.
        could_compile: "auto" took the batched engine where the compiled engine would run
            whole iterations once this tree is compiled (``engine="compiled"`` once).
    """

    scenario: Scenario
    seed: int
    rng: np.random.Generator
    mission: Mission
    swarm: Swarm
    world: World
    model: Model
    engine: Engine
    recorder: Recorder
    handlers: dict[str, MessageType] = field(default_factory=dict)
    inbox: list[Delivery] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    everyone: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    recorded_types: tuple[str, ...] = ()
    unhandled: set[str] = field(default_factory=set)
    could_compile: bool = False
    _alerted: set[tuple[str, int]] = field(default_factory=set)

    @classmethod
    def create(
        cls,
        scenario: Scenario,
        seed: int = 0,
        engine: str = "auto",
        record_every: int = 1,
        tree: Node | None = None,
        implementation: str | None = None,
        trace: int | str | Sequence[str] | None = None,
    ) -> Simulation:
        """Phase 1 and set-up: mission, agents, world, engine and recorder for ``scenario``.

        Args:
            scenario: the scenario to run.
            seed: seed of the run's random generators.
            engine: name of the decision engine (see :data:`ENGINES`), or "auto"
                (:func:`choose_engine`).
            record_every: record every K-th iteration (and the initial state); a K longer
                than the run records the initial and the final state.
            tree: a tree description or a tree file's path, instead of the scenario's own.
            implementation: the X8's implementation, "pyfly" or "vectorised", instead of
                the engine's default (see :mod:`pyautonomousagent.simulation.motion`).
            trace: the agents whose node statuses are recorded: None (every agent of a
                small swarm, else the first :data:`~pyautonomousagent.recording.DEFAULT_TRACED`),
                a count, "all", or names (:func:`~pyautonomousagent.recording.traced_agents`).

        Raises:
            TypeError, ValueError: a bad argument, named in the message; ScenarioError: a bad
                scenario field; InputError: a run that cannot fit in memory; TreeError: a
                leaf that does not fit the mission (:mod:`~pyautonomousagent.simulation.fit`).
        """
        scenario, tree = _checked(scenario, seed, engine, record_every, tree)
        record_every = min(record_every, max(scenario.iterations, 1))  # initial and final
        tree = tree or scenario_tree(scenario)
        auto = engine == "auto"
        mission = scenario.create_mission()
        engine = _fitting_engine(scenario, mission, tree, engine, record_every)
        start = time.perf_counter()
        declared = tree_blackboard_keys(tree, mission.blackboard())  # scripts' entries
        check_tree(tree, scenario, declared)  # every leaf fits the mission
        rng = np.random.default_rng(seed)
        world = phases.create_world(scenario, seed)
        swarm = phases.create_agents(mission, world, rng, declared)
        build_model = MOTION_MODELS.get(scenario.model).build
        model = build_model(scenario, swarm, engine, seed, implementation)
        decision = ENGINES.get(engine)(tree, swarm, world, vars(scenario.parameters))
        handlers = {kind.name: kind for kind in mission.message_types()}
        recorder = Recorder(
            swarm,
            scenario.iterations,
            record_every,
            model.columns(),
            tree=tree,
            traced=_traced(swarm.names, trace),
            docs=mission.meanings,
        )
        sim = cls(
            scenario=scenario,
            seed=seed,
            rng=rng,
            mission=mission,
            swarm=swarm,
            world=world,
            model=model,
            engine=decision,
            recorder=recorder,
            handlers=handlers,
            everyone=np.ones(swarm.size, dtype=bool),
            recorded_types=tuple(name for name, kind in handlers.items() if kind.recorded),
        )
        if auto and engine == "batched" and not compilable(tree):
            _compiled_if_ready(sim, tree)
        if auto and isinstance(sim.engine, GpuEngine) and not sim.engine.runs(sim):
            log.debug("engine auto: compiled, not gpu: the kernel cannot run this run")
            sim.engine = sim.engine.host  # the compiled engine of the run's tree
        phases.record(sim)  # the initial state, iteration 0
        if fuses(sim.engine):
            sim.engine.prepare(sim)  # e.g. compile before the loop
        sim.timings["setup"] = time.perf_counter() - start
        return sim

    def step(self) -> None:
        """One iteration: Phases 2 to 6.

        Raises:
            RuntimeError: the run has done all its iterations (nothing is changed).
        """
        if self.world.iteration >= self.scenario.iterations:
            raise RuntimeError(
                f"step(): the run has done all its {self.scenario.iterations} iterations; "
                "create a Simulation of a longer scenario, e.g. "
                "scenario.with_overrides(iterations=...)"
            )
        if self._fused(1):
            self._settle()
            return
        self.world.iteration += 1
        phases.estimate_state(self)
        phases.decide(self)
        phases.control(self)
        phases.deliver_messages(self)
        phases.record(self)

    def run(
        self, progress: bool | None = None, iterations: int | None = None, *, lines: bool = False
    ) -> Simulation:
        """Run the scenario's remaining iterations (at most ``iterations`` of them); a
        progress bar if ``progress`` (by default when standard error is a terminal); with
        ``lines``, where standard error is not a terminal, a progress line every 10 s or
        5 % once the run has taken 10 s. Returns ``self``."""
        start = time.perf_counter()
        remaining = self.scenario.iterations - self.world.iteration
        if iterations is not None:
            remaining = max(0, min(remaining, iterations))
        label = f"{self.scenario.name} ({self.engine.name})"
        bar = Progress(remaining, label, enabled=progress, lines=lines, unit="iterations",
                       first_line_after=LINE_SECONDS)  # fmt: skip
        done = 0
        try:
            while done < remaining:
                fused = self._fused(min(remaining - done, FUSED))
                if not fused:
                    self.step()
                done += fused or 1
                if done % 50 == 0 or done == remaining or fused:
                    bar.update(done)
        finally:
            self._settle()  # also on Ctrl-C: the records run so far, whole
        bar.close()
        self.timings["simulate"] = self.timings.get("simulate", 0.0) + time.perf_counter() - start
        return self

    def _fused(self, count: int) -> int:
        """Up to ``count`` whole iterations in one call of an engine that runs them (the
        compiled engine's ``loop``), then the last one's Phase 5; how many were run (0: none,
        step the next one)."""
        done = int(self.engine.loop(self, count)) if fuses(self.engine) else 0
        if done:
            self.world.iteration += done
            self.inbox = []  # a fused loop handles the inbox in its first iteration
            phases.deliver_messages(self)
        return done

    def account_fused(
        self, sensors: SensorKernel, start: int, count: int, stopped: np.ndarray
    ) -> None:
        """The bookkeeping of fused iterations ``start + 1 .. start + count``
        (:func:`~pyautonomousagent.simulation.phases.account_fused`), called by the engine
        whose loop ran them, when their records reach the recorder."""
        phases.account_fused(self, sensors, start, count, stopped)

    def _settle(self) -> None:
        """Have an engine that keeps work in flight (the GPU engine's records and state)
        finish it: the recorder holds every iteration run, the swarm's arrays the state."""
        if fuses(self.engine):
            self.engine.sync(self)

    def trace_table(self) -> pa.Table:
        """The traced agents' node statuses: one row per record and traced agent."""
        return trace_table(self.recorder)

    def alert(self, rows: np.ndarray, kind: str, message: str) -> None:
        """Record an ``alert`` event (and log a warning) the first time each agent of ``rows``
        raises an alert of ``kind`` in this run.

        Args:
            rows: agent rows, int array.
            kind: a short name of the alert (e.g. ``"zero energy"``); each agent raises it once.
            message: what happened, for the event and the log.
        """
        for i in np.asarray(rows).tolist():
            if (kind, i) in self._alerted:
                continue
            self._alerted.add((kind, i))
            name = self.swarm.names[i]
            self.events.append(
                {"iteration": self.world.iteration, "event": "alert", "agent": name,
                 "message": message}
            )  # fmt: skip
            log.warning("iteration %d: %s: %s", self.world.iteration, name, message)

    def table(self) -> pa.Table:
        """The recorded data: one row per recorded iteration and agent."""
        return to_table(self.recorder)


def _compiled_if_ready(sim: Simulation, tree: Node) -> None:
    """Auto's second look, once ``sim`` is built on the batched engine: the compiled engine
    where this run's fused loop was compiled before on this machine (no wait) and
    :func:`choose_engine` takes it then (faster, within the memory); else note whether
    compiling it would serve (``sim.could_compile``)."""
    compiled = CompiledEngine(tree, sim.swarm, sim.world, vars(sim.scenario.parameters))
    if not compiled.ready(sim):
        sim.could_compile = compiled.fuses(sim)
        return
    s, recorder = sim.scenario, sim.recorder
    columns = len(recorder.columns)
    if choose_engine(tree, s.agents, s.iterations, recorder.every, columns, True) == "compiled":
        sim.engine = compiled


def _traced(names: Sequence[str], trace: int | str | Sequence[str] | None) -> list[int]:
    """:func:`traced_agents`, its ValueError as a ScenarioError (bad input)."""
    try:
        return traced_agents(names, trace)
    except ValueError as error:
        raise ScenarioError(str(error)) from None
