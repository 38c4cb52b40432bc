"""The paper's phases (Fig. 3), each one function over the whole swarm.

Phase 1 :func:`create_agents`; Phase 2 :func:`estimate_state` (sensors, energy and damage,
motion, then the messages received last iteration); Phase 3 :func:`decide`; Phase 4
:func:`control`; Phase 5 :func:`deliver_messages`; Phase 6 :func:`record`. Phase 7 (the
animation) runs after the loop, in :mod:`pyautonomousagent.render`.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from pyautonomousagent.bt.library import DESTINATION, PATROL, REFUELING, SURVEILLANCE
from pyautonomousagent.datalink import GATHERING, SHARING_DATA, message_events
from pyautonomousagent.sensors import accumulate_damage, drain_energy, radiation_level
from pyautonomousagent.simulation.scenario import Scenario
from pyautonomousagent.state import Swarm

if TYPE_CHECKING:
    from pyautonomousagent.simulation.run import Simulation

log = logging.getLogger("pyautonomousagent")

#: Message types written to the run's events (sharing data is too frequent to list).
RECORDED_MESSAGE_TYPES = (GATHERING,)


def blackboard_keys(scenario: Scenario) -> dict[str, type]:
    """The blackboard of every agent: the paper's Table 3, plus the patrol keys if it patrols."""
    keys: dict[str, type] = {"number_ticks": np.int64}
    keys.update({k: np.float64 for k in SURVEILLANCE + REFUELING + DESTINATION})
    if scenario.patrol_positions:
        keys.update({k: np.float64 for k in PATROL})
        keys["index_current_surveillance_position"] = np.int64
    return keys


def _cycled(points: tuple[tuple[float, float], ...], n: int) -> np.ndarray:
    """Points given to agents 1..n in turn, shape (n, 2)."""
    return np.asarray([points[i % len(points)] for i in range(n)], dtype=np.float64)


def create_agents(scenario: Scenario, rng: np.random.Generator) -> Swarm:
    """Phase 1: N agents on their refuelling slots, full of energy, undamaged, at rest.

    Each agent's first destination is its surveillance position. With
    ``initial_heading: random`` the headings are drawn uniformly from ``rng``.
    """
    n = scenario.agents
    swarm = Swarm.create([f"drone{i + 1}" for i in range(n)], blackboard_keys(scenario))
    s, bb = swarm.columns, swarm.blackboard
    refuel = _cycled(scenario.refueling_positions, n)
    s["x"][:], s["y"][:] = refuel[:, 0], refuel[:, 1]
    if scenario.initial_heading == "random":
        s["heading"][:] = rng.uniform(0.0, 360.0, n)
    else:
        s["heading"][:] = float(scenario.initial_heading) % 360.0
    s["requested_heading"][:] = s["heading"]
    s["energy"][:] = 100.0
    bb["x_refueling_position"][:], bb["y_refueling_position"][:] = refuel[:, 0], refuel[:, 1]
    if scenario.patrol_positions:
        (x1, y1), (x2, y2) = scenario.patrol_positions
        bb["x_surveillance_position_1"][:], bb["y_surveillance_position_1"][:] = x1, y1
        bb["x_surveillance_position_2"][:], bb["y_surveillance_position_2"][:] = x2, y2
        bb["index_current_surveillance_position"][:] = 1
        surveillance = np.tile([x1, y1], (n, 1))
    else:
        surveillance = _cycled(scenario.surveillance_positions, n)
    bb["x_surveillance_position"][:], bb["y_surveillance_position"][:] = surveillance.T
    bb["x_current_destination_position"][:] = surveillance[:, 0]
    bb["y_current_destination_position"][:] = surveillance[:, 1]
    return swarm


def estimate_state(sim: Simulation) -> None:
    """Phase 2: read sensors, update energy and damage, move, then act on last iteration's messages.

    An agent with no energy reads no sensor and does not move; the first time it happens
    an alert event is recorded and logged once.
    """
    s, p = sim.swarm.columns, sim.scenario.parameters
    s["energy"][:] = drain_energy(s["energy"], p.energy_use)
    powered = s["energy"] > 0.0
    if any(source.active for source in sim.world.radiation_sources):
        reading = radiation_level(s["x"], s["y"], sim.world.radiation_sources)
        np.copyto(s["radiation"], reading, where=powered)
        s["damage"][:] = accumulate_damage(s["damage"], s["radiation"], p.radiation_damage_factor)
    # else: no source is active, so every reading is 0 and damage does not grow
    sim.model.advance(s, powered)
    if not powered.all():
        _raise_alerts(sim, ~powered)
    process_messages(sim)


def _raise_alerts(sim: Simulation, unpowered: np.ndarray) -> None:
    for i in np.flatnonzero(unpowered & ~sim.alerted):
        sim.alerted[i] = True
        name = sim.swarm.names[i]
        sim.events.append(
            {
                "iteration": sim.world.iteration,
                "event": "alert",
                "agent": name,
                "message": "zero energy: sensors off, not moving",
            }
        )
        log.warning("iteration %d: %s has zero energy", sim.world.iteration, name)


def process_messages(sim: Simulation) -> None:
    """Act on the messages delivered last iteration.

    "gathering": the receiver's surveillance position becomes the message's position (the
    last one, in canonical order, if several arrived).
    "sharing data": the receiver keeps the latest data per sender in ``sim.shared``.
    """
    bb = sim.swarm.blackboard
    for delivery in sim.inbox:
        if delivery.messages.type == GATHERING:
            receivers, rows = delivery.pairs(sim.swarm.size)
            last = _last_per_receiver(receivers)
            data = delivery.messages.data
            bb["x_surveillance_position"][receivers[last]] = data["x"][rows[last]]
            bb["y_surveillance_position"][receivers[last]] = data["y"][rows[last]]
        elif delivery.messages.type == SHARING_DATA:
            sim.shared.store(delivery, sim.world.iteration - 1)
    sim.inbox = []


def _last_per_receiver(receivers: np.ndarray) -> np.ndarray:
    """Positions of each receiver's last delivery."""
    return receivers.size - 1 - np.unique(receivers[::-1], return_index=True)[1]


def decide(sim: Simulation) -> None:
    """Phase 3: tick every agent's behaviour tree once."""
    sim.engine.tick()


def control(sim: Simulation) -> None:
    """Phase 4: the motion model's control signals toward the requested speed and heading."""
    sim.model.control(sim.swarm.columns)


def deliver_messages(sim: Simulation) -> None:
    """Phase 5: deliver this iteration's messages within range; the channel is cleared."""
    sim.inbox = sim.world.datalink.deliver(sim.swarm.columns["x"], sim.swarm.columns["y"])
    sim.events.extend(
        message_events(sim.inbox, RECORDED_MESSAGE_TYPES, sim.world.iteration, sim.swarm.names)
    )


def record(sim: Simulation) -> None:
    """Phase 6: store the state and blackboard of every agent, the active behaviours and the
    traced agents' node statuses (on recorded iterations)."""
    recorder = sim.recorder
    if recorder.due(sim.world.iteration):
        statuses = sim.engine.node_statuses() if recorder.wants_statuses else None
        recorder.record(sim.world.iteration, sim.swarm, sim.model.columns(), statuses)
