"""Acceptance: the paper's patrol scenario (Fig. 11-12), 10 drones x 4000 iterations."""

from __future__ import annotations

import numpy as np

TOLERANCE = 0.5  # Parameters.destination_tolerance


def min_distance(sim, point) -> np.ndarray:
    x, y = sim.recorder.column("x"), sim.recorder.column("y")
    return np.hypot(x - point[0], y - point[1]).min(axis=0)


def test_patrol_run_shape(patrol_run):
    assert patrol_run.swarm.size == 10
    assert patrol_run.world.iteration == 4000
    assert patrol_run.recorder.count == 4001
    assert patrol_run.scenario.parameters.destination_tolerance == TOLERANCE


def test_every_drone_visits_both_surveillance_positions(patrol_run):
    for point in patrol_run.scenario.objects.patrol_positions:
        assert (min_distance(patrol_run, point) <= TOLERANCE).all(), point


def test_every_drone_visits_its_refuelling_slot_and_refuels(patrol_run):
    (slot,) = patrol_run.scenario.objects.refueling_positions
    # they start there; a visit is a return after having left it
    x, y = patrol_run.recorder.column("x"), patrol_run.recorder.column("y")
    d = np.hypot(x - slot[0], y - slot[1])
    energy = patrol_run.recorder.column("energy")
    for agent in range(10):
        left = np.flatnonzero(d[:, agent] > 10.0)
        assert left.size > 0, agent
        assert (d[left[0] :, agent] <= TOLERANCE).any(), agent
        low = np.flatnonzero(energy[:, agent] <= 40.0)
        assert low.size > 0 and (energy[low[0] :, agent] == 100.0).any(), agent
    assert energy.min() > 0.0
    assert patrol_run.events == []


def test_drones_alternate_between_the_positions(patrol_run):
    index = patrol_run.recorder.column("index_current_surveillance_position")
    assert set(np.unique(index).tolist()) == {1, 2}
    switches = (np.diff(index, axis=0) != 0).sum(axis=0)
    # out to position 1, over to 2 and back to 1, with refuelling trips in between
    assert (switches >= 2).all(), switches
    # a switch happens only at the position the drone was heading for
    x, y = patrol_run.recorder.column("x"), patrol_run.recorder.column("y")
    t, agent = np.nonzero(np.diff(index, axis=0) != 0)
    t = t + 1
    was = index[t - 1, agent]
    target_y = np.where(was == 1, 80.0, 20.0)
    assert (np.hypot(x[t, agent] - 70.0, y[t, agent] - target_y) <= TOLERANCE).all()
