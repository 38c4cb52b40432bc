"""Physics invariants over whole runs, and what happens at zero energy."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.missions.drones.sensors import (
    RadiationSource,
    accumulate_damage,
    drain_energy,
    radiation_level,
)


@pytest.fixture(params=["gathering", "patrol"])
def full_run(request, gathering_run, patrol_run) -> Simulation:
    return {"gathering": gathering_run, "patrol": patrol_run}[request.param]


def test_speed_within_limits(full_run):
    speed = full_run.recorder.column("speed")
    assert speed.min() >= 0.0
    assert speed.max() <= 0.1
    assert speed.max() == 0.1  # they do fly at cruise speed


def test_heading_in_0_360(full_run):
    heading = full_run.recorder.column("heading")
    assert heading.min() >= 0.0
    assert heading.max() < 360.0


def test_energy_and_damage_within_0_100(full_run):
    for key in ("energy", "damage", "radiation"):
        values = full_run.recorder.column(key)
        assert values.min() >= 0.0, key
        assert values.max() <= 100.0, key


def test_displacement_equals_previous_speed(full_run):
    r = full_run.recorder
    x, y, speed = r.column("x"), r.column("y"), r.column("speed")
    step = np.hypot(np.diff(x, axis=0), np.diff(y, axis=0))
    np.testing.assert_allclose(step, speed[:-1], rtol=0, atol=1e-12)


def test_displacement_direction_is_previous_heading(full_run):
    r = full_run.recorder
    x, y, speed, heading = r.column("x"), r.column("y"), r.column("speed"), r.column("heading")
    rad = np.radians(heading[:-1])
    np.testing.assert_allclose(np.diff(x, axis=0), speed[:-1] * np.sin(rad), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.diff(y, axis=0), speed[:-1] * np.cos(rad), rtol=0, atol=1e-12)


def test_speed_and_heading_change_by_one_control_step(full_run):
    r = full_run.recorder
    dv = np.abs(np.diff(r.column("speed"), axis=0))
    assert dv.max() <= 0.1 + 1e-15
    dh = np.abs((np.diff(r.column("heading"), axis=0) + 180.0) % 360.0 - 180.0)
    np.testing.assert_array_less(dh, 1.0 + 1e-9)
    assert np.isin(np.round(dh, 9), [0.0, 1.0]).all()


def test_energy_drains_0_05_per_iteration_while_flying(full_run):
    energy = full_run.recorder.column("energy")
    change = np.diff(energy, axis=0)
    draining = change < 0
    np.testing.assert_allclose(change[draining], -0.05, rtol=0, atol=1e-9)
    # otherwise it is refuelling: at most +2 - 0.05 per iteration
    assert change.max() <= 2.0


def test_drones_stay_in_the_world(full_run):
    x, y = full_run.recorder.column("x"), full_run.recorder.column("y")
    width, height = full_run.scenario.world
    assert x.min() >= 0 and x.max() <= width
    assert y.min() >= 0 and y.max() <= height


# --------------------------------------------------------------------------- zero energy


@pytest.fixture(scope="module")
def exhausted() -> Simulation:
    """Gathering with energy used so fast that every drone runs dry before refuelling."""
    scenario = load("gathering").with_overrides(energy_use=3.0, iterations=300)
    return Simulation.create(scenario, seed=0).run(progress=False)


def test_zero_energy_one_alert_per_agent(exhausted):
    alerts = [e for e in exhausted.events if e["event"] == "alert"]
    assert sorted(e["agent"] for e in alerts) == ["drone1", "drone2", "drone3", "drone4"]
    # 100 / 3 -> the 34th iteration's drain empties the battery
    assert all(e["iteration"] == 34 for e in alerts)
    assert all("zero energy" in e["message"] for e in alerts)


def test_zero_energy_agent_stops_moving(exhausted):
    r = exhausted.recorder
    x, y, speed, energy = r.column("x"), r.column("y"), r.column("speed"), r.column("energy")
    assert (energy[34:] == 0.0).all()
    assert (energy[:34] > 0.0).all()
    assert (speed[33] > 0.0).all()  # it was flying...
    np.testing.assert_array_equal(x[34:], np.broadcast_to(x[33], x[34:].shape))  # ...and stops dead
    np.testing.assert_array_equal(y[34:], np.broadcast_to(y[33], y[34:].shape))
    assert (speed[34:] == 0.0).all()


def test_zero_energy_sensors_off(exhausted):
    # an unpowered agent keeps its last radiation reading (no source is active here anyway)
    assert (exhausted.recorder.column("radiation") == 0.0).all()


def test_zero_energy_warns_once_per_agent(caplog):
    scenario = load("gathering").with_overrides(energy_use=100.0, iterations=20)
    with caplog.at_level(logging.WARNING, logger="pyautonomousagent"):
        sim = Simulation.create(scenario, seed=0).run(progress=False)
    warnings = [rec for rec in caplog.records if "zero energy" in rec.getMessage()]
    assert len(warnings) == 4
    alerts = [e for e in sim.events if e["event"] == "alert"]
    assert [(e["iteration"], e["agent"]) for e in alerts] == [
        (1, "drone1"), (1, "drone2"), (1, "drone3"), (1, "drone4"),
    ]  # fmt: skip
    # on its slot, the tree refuels it a little each tick, but Phase 2 drains it again
    r = sim.recorder
    assert (r.column("speed") == 0.0).all()
    np.testing.assert_array_equal(r.column("x"), np.broadcast_to(r.column("x")[0], (21, 4)))
    np.testing.assert_array_equal(r.column("y"), np.broadcast_to(r.column("y")[0], (21, 4)))


def test_no_alert_with_normal_energy_use(gathering_run, patrol_run):
    for sim in (gathering_run, patrol_run):
        assert [e for e in sim.events if e["event"] == "alert"] == []


# --------------------------------------------------------------------------- sensors


def test_drain_energy_never_below_zero():
    np.testing.assert_array_equal(drain_energy(np.array([10.0, 0.03, 0.0]), 0.05), [9.95, 0.0, 0.0])


def test_radiation_level_from_sources():
    sources = (RadiationSource(40, 40, 10, active=True), RadiationSource(0, 0, 10, active=False))
    level = radiation_level(
        np.array([40.0, 45.0, 50.0, 0.0]), np.array([40.0, 40.0, 40.0, 0.0]), sources
    )
    np.testing.assert_allclose(level, [100.0, 50.0, 0.0, 0.0])
    both = (RadiationSource(0, 0, 10, True), RadiationSource(10, 0, 10, True))
    np.testing.assert_allclose(radiation_level(np.array([5.0]), np.array([0.0]), both), [100.0])
    np.testing.assert_allclose(radiation_level(np.array([0.0]), np.array([0.0]), both), [100.0])
    np.testing.assert_allclose(radiation_level(np.array([2.0]), np.array([0.0]), both[:1]), [80.0])


def test_damage_accumulates_with_radiation():
    damage = accumulate_damage(np.array([0.0, 10.0, 99.99]), np.array([100.0, 50.0, 100.0]), 0.1)
    np.testing.assert_allclose(damage, [0.1, 10.05, 100.0])


def test_active_radiation_source_damages_drones_in_range():
    scenario = load("gathering").with_overrides(
        iterations=50,
        radiation_sources=[{"x": 20.0, "y": 65.0, "range": 10.0, "active": True}],
    )
    sim = Simulation.create(scenario, seed=0).run(progress=False)
    damage = sim.recorder.column("damage")
    radiation = sim.recorder.column("radiation")
    assert radiation[1, 0] == pytest.approx(100.0, abs=0.1)  # drone1 starts on the source
    assert radiation[1, 1] == pytest.approx(0.0)  # drone2 is exactly 10 away: outside
    assert damage[-1, 0] > 2.0
    # each iteration adds radiation_damage_factor (0.1) % per 100 % of that iteration's reading
    np.testing.assert_allclose(np.diff(damage, axis=0), 0.1 * radiation[1:] / 100.0, atol=1e-12)
    assert (np.diff(damage, axis=0) >= 0).all()
