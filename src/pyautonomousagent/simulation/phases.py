"""The paper's phases (Fig. 3), each one function over the whole swarm.

Phase 1 :func:`create_agents`; Phase 2 :func:`estimate_state` (the mission's sensors, motion,
then the messages received last iteration); Phase 3 :func:`decide`; Phase 4 :func:`control`;
Phase 5 :func:`deliver_messages`; Phase 6 :func:`record`. Phase 7 (the animation) runs after
the loop, in :mod:`pyautonomousagent.render`. What is particular to a mission (its blackboard,
placement, sensors and message handlers) comes from its
:class:`~pyautonomousagent.simulation.mission.Mission`; nothing here names one.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from pyautonomousagent.datalink import Datalink, message_events
from pyautonomousagent.names import AgentNames, agent_index
from pyautonomousagent.randomness import CounterRandom
from pyautonomousagent.simulation.mission import Mission
from pyautonomousagent.state import Swarm
from pyautonomousagent.world import World

if TYPE_CHECKING:
    from pyautonomousagent.kernels import SensorKernel
    from pyautonomousagent.simulation.engine_api import LoopView
    from pyautonomousagent.simulation.scenario_view import ScenarioView

log = logging.getLogger("pyautonomousagent")


def create_world(scenario: ScenarioView, seed: int) -> World:
    """The world of a run: its size, datalink, the mission's objects, the leaves' randomness."""
    return World(
        width=scenario.world[0],
        height=scenario.world[1],
        datalink=Datalink(scenario.parameters.datalink_range),
        objects=scenario.objects,
        random=CounterRandom(seed),
    )


def create_agents(
    mission: Mission, world: World, rng: np.random.Generator, extra_keys: dict | None = None
) -> Swarm:
    """Phase 1: N agents with the mission's columns and blackboard, placed by the mission
    (then the world knows them by name: ``world.agent_index``).

    Args:
        mission: the run's mission (its scenario gives N).
        world: the world the agents start in.
        rng: the run's generator (random placement).
        extra_keys: more blackboard keys (e.g. those a tree declares), key -> dtype.
    """
    scenario = mission.scenario
    names = AgentNames(mission.agent_prefix, scenario.agents)
    keys = {"number_ticks": np.int64, **mission.blackboard(), **(extra_keys or {})}
    swarm = Swarm.create(names, keys, mission.columns)
    s = swarm.columns
    if scenario.initial_heading == "random":
        s["heading"][:] = rng.uniform(0.0, 360.0, swarm.size)
    else:
        s["heading"][:] = float(scenario.initial_heading) % 360.0
    mission.place(swarm, world, rng)
    s["requested_heading"][:] = s["heading"]
    world.agent_index = agent_index(swarm.names)
    return swarm


def estimate_state(sim: LoopView) -> None:
    """Phase 2: the mission's sensors, then motion, then last iteration's messages.

    Agents the sensors leave unable to move (e.g. out of energy) stay where they are.
    """
    moving = sim.mission.sense(sim)
    sim.model.advance(sim.swarm.columns, sim.everyone if moving is None else moving)
    process_messages(sim)


def process_messages(sim: LoopView) -> None:
    """Hand last iteration's deliveries to the mission's handlers, by message type.

    A delivered type that no handler takes is logged once per run (not silently dropped).
    """
    for delivery in sim.inbox:
        kind = delivery.messages.type
        handler = sim.handlers.get(kind)
        if handler is not None:
            if handler.handle is not None:
                handler.handle(sim, delivery)
        elif kind not in sim.unhandled:
            sim.unhandled.add(kind)
            log.warning(
                "message type %r was delivered but mission %r has no handler for it (known: %s)",
                kind,
                sim.mission.name,
                ", ".join(sim.handlers) or "none",
            )
    sim.inbox = []


def decide(sim: LoopView) -> None:
    """Phase 3: tick every agent's behaviour tree once."""
    sim.engine.tick()


def control(sim: LoopView) -> None:
    """Phase 4: the motion model's control signals toward the requested speed and heading."""
    sim.model.control(sim.swarm.columns)


def deliver_messages(sim: LoopView) -> None:
    """Phase 5: deliver this iteration's messages within range; the channel is cleared."""
    sim.inbox = sim.world.datalink.deliver(sim.swarm.columns["x"], sim.swarm.columns["y"])
    if sim.recorded_types and sim.inbox:
        sim.events.extend(
            message_events(sim.inbox, sim.recorded_types, sim.world.iteration, sim.swarm.names)
        )


def record(sim: LoopView) -> None:
    """Phase 6: store the state and blackboard of every agent, the active behaviours and the
    traced agents' node statuses (on recorded iterations)."""
    recorder = sim.recorder
    if recorder.due(sim.world.iteration):
        statuses = sim.engine.node_statuses() if recorder.wants_statuses else None
        recorder.record(sim.world.iteration, sim.swarm, sim.model.columns(), statuses)


def account_fused(
    sim: LoopView, sensors: SensorKernel, start: int, count: int, stopped: np.ndarray
) -> None:
    """Phases 2 and 6's bookkeeping of iterations ``start + 1 .. start + count`` that a fused
    loop ran: the sensors' alerts and what the swarm sensor kept, in order of iteration (an
    iteration's alerts first, as Phase 2 raises them, the clock set to it meanwhile), then
    the recorder's iterations and count and its listeners. The clock is left as it was (the
    simulation advances it by the iterations a call ran).

    Args:
        sensors: the mission's compiled sensors the loop ran.
        stopped: the iteration at which each agent was found unable to move, shape (N,),
            int64 (-1: it was not).
    """
    now = sim.world.iteration
    collect = sensors.swarm.collect if sensors.swarm is not None else None
    for t in np.unique(stopped[stopped >= 0]).tolist():
        if collect is not None:
            collect(sim, t - 1)
        sim.world.iteration = t
        if sensors.stopped is not None:
            sensors.stopped(sim, np.flatnonzero(stopped == t))
    if collect is not None:
        collect(sim, start + count)
    sim.world.iteration = now
    recorder, every = sim.recorder, sim.recorder.every
    due = np.arange((start // every + 1) * every, start + count + 1, every)  # Recorder.due's
    recorder.iterations[recorder.count : recorder.count + due.size] = due
    recorder.count += due.size
    for listener in recorder.listeners:  # e.g. the states written while the run goes
        listener(recorder.count)
