"""The 3-D drone (issue 18, part 1): one step worked by hand, the altitude loop, the 3-D
patrol visiting its points at their altitudes on every engine with identical data (on both
SIMD levels), the 3-D leaves on both engines, and the 3-D gathering."""

from __future__ import annotations

import base64
import json

import matplotlib
import numpy as np
import pytest

from pyautonomousagent import Simulation, jit, load
from pyautonomousagent.bt.leaf import Leaf, leaf_type
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.missions.drones3d import leaves as leaves3d
from pyautonomousagent.models.drone3d import (
    Drone3D,
    Drone3DParameters,
    advance_vertical,
    climb_control,
)
from pyautonomousagent.render.animation import FramePainter
from pyautonomousagent.render.replay import replay_data
from pyautonomousagent.state import AgentView
from pyautonomousagent.testing import check_engines_agree, check_leaf
from tests.test_simd_levels import _enabled_avx512, simd_digests

ENGINES = ("pytrees", "batched", *(("compiled",) if jit.available() else ()))


def _swarm(**values: float) -> dict[str, np.ndarray]:
    """One agent's state columns, shape (1,) each."""
    names = ("x", "y", "z", "speed", "heading", "climb_rate",
             "requested_speed", "requested_heading", "requested_altitude")  # fmt: skip
    return {k: np.array([float(values.get(k, 0.0))]) for k in names}


def test_one_step_worked_by_hand():
    # Defaults: max_speed 0.1, speed_step 0.1, turn_step 1, max_climb_rate 0.05,
    # climb_step 0.05, max_altitude 100. Heading 90 flies east: sin 90 deg = 1.
    model = Drone3D(Drone3DParameters(), 1)
    s = _swarm(x=1.0, y=2.0, z=3.0, speed=0.05, heading=90.0, climb_rate=0.02)
    model.u_speed[:], model.u_heading[:], model.u_climb[:] = 0.1, 1.0, -0.05
    model.advance(s, np.array([True]))
    assert s["x"][0] == pytest.approx(1.05, abs=1e-15)  # eq. 1: 1 + 0.05 * sin 90
    assert s["y"][0] == pytest.approx(2.0, abs=1e-15)  # eq. 2: 2 + 0.05 * cos 90
    assert s["speed"][0] == 0.1  # eq. 3: min(max(0.05 + 0.1, 0), 0.1)
    assert s["heading"][0] == 91.0  # eq. 4: 90 + 1
    assert s["z"][0] == pytest.approx(3.02, abs=1e-15)  # eq. 5: 3 + 0.02 (the old rate)
    assert s["climb_rate"][0] == pytest.approx(-0.03, abs=1e-15)  # eq. 6: 0.02 - 0.05
    # Phase 4 from there, asking for altitude 3.5, speed 0.1 and heading 80:
    s["requested_altitude"][:], s["requested_speed"][:], s["requested_heading"][:] = 3.5, 0.1, 80
    model.control(s)
    # eq. 7: w* = clip(3.5 - (3.02 - 0.03), -0.05, 0.05) = 0.05 (far: full climb);
    # u_w = clip(0.05 - (-0.03), -0.05, 0.05) = 0.05 (bang: one full step)
    assert model.u_climb[0] == pytest.approx(0.05, abs=1e-15)
    assert model.u_speed[0] == 0.0  # speed 0.1 = the request
    assert model.u_heading[0] == -1.0  # 80 is 11 degrees to the left


def test_the_last_step_is_trimmed_and_the_ground_holds():
    p = Drone3DParameters()
    # Near the request: z 10, w 0.05, h* 10.06: w* = clip(10.06 - 10.05) = 0.01 (within one
    # step), u_w = 0.01 - 0.05 = -0.04 (not the full -0.05 of a bang).
    u = climb_control(np.array([10.0]), np.array([0.05]), np.array([10.06]), p)
    assert u[0] == pytest.approx(-0.04, abs=1e-12)
    # The ground: z 0.01 sinking at 0.05 lands at 0, not -0.04 (eq. 5's clip).
    z, w = advance_vertical(np.array([0.01]), np.array([-0.05]), np.array([0.05]), p)
    assert z[0] == 0.0 and w[0] == 0.0
    # The ceiling: max_altitude 2, z 1.98 climbing at 0.05 stops at 2.
    z, _ = advance_vertical(
        np.array([1.98]), np.array([0.05]), np.zeros(1), Drone3DParameters(max_altitude=2.0)
    )
    assert z[0] == 2.0


@pytest.mark.parametrize(("start", "wanted"), [(0.0, 12.345), (30.0, 0.0), (9.97, 10.0)])
def test_the_altitude_settles_on_the_request_within_bounds(start: float, wanted: float):
    p = Drone3DParameters()
    z, w, u = np.array([start]), np.zeros(1), np.zeros(1)
    heights, rates = [], []
    for _ in range(1500):
        z, w = advance_vertical(z, w, u, p)
        u = climb_control(z, w, np.array([wanted]), p)
        heights.append(z[0])
        rates.append(w[0])
    assert min(heights) >= 0.0 and max(np.abs(rates)) <= p.max_climb_rate
    # reached in about |wanted - start| / max_climb_rate iterations and held there
    settle = int(abs(wanted - start) / p.max_climb_rate) + 5
    assert np.all(np.abs(np.array(heights[settle:]) - wanted) <= 1e-9), heights[settle - 5 :]


def _digest(sim: Simulation) -> dict[str, np.ndarray]:
    """Every recorded column, the traces and the events of a finished run."""
    r = sim.recorder
    data = {k: r.column(k) for k in r.columns}
    data["@traces"] = r.traces[: r.count]
    data["@events"] = np.frombuffer(json.dumps(sim.events).encode(), dtype=np.uint8)
    return data


def _visits(sim: Simulation, point: tuple[float, float, float], tolerance: float) -> np.ndarray:
    """For each agent: whether it came within ``tolerance`` of ``point`` horizontally and
    in altitude, shape (N,)."""
    r = sim.recorder
    x, y, z = (r.column(k) for k in ("x", "y", "z"))
    near = np.hypot(x - point[0], y - point[1]) <= tolerance
    return (near & (np.abs(z - point[2]) <= tolerance)).any(axis=0)


def test_patrol_3d_visits_its_points_at_their_altitudes_on_every_engine_alike():
    scenario = load("patrol-3d").with_overrides(agents=3, iterations=2600)
    points = scenario.objects.patrol_positions
    tolerance = scenario.parameters.destination_tolerance
    runs = {e: Simulation.create(scenario, seed=4, engine=e).run(progress=False) for e in ENGINES}
    if "compiled" in runs:
        assert runs["compiled"].engine.fuses(runs["compiled"])  # the fused loop flew it
    for engine, sim in runs.items():
        z = sim.recorder.column("z")
        assert z.min() >= 0.0 and z.max() <= scenario.parameters.max_altitude, engine
        for point in points:
            assert _visits(sim, point, tolerance).all(), (engine, point)
        energy = sim.recorder.column("energy")
        landed = (z == 0.0) & (np.diff(energy, axis=0, prepend=energy[:1]) > 0)
        assert landed.any(axis=0).all(), engine  # every drone refuelled on the ground
    reference = _digest(runs["pytrees"])
    for engine in ENGINES[1:]:
        other = _digest(runs[engine])
        assert reference.keys() == other.keys()
        for key, values in reference.items():
            assert np.array_equal(values, other[key], equal_nan=True), (engine, key)


def test_gathering_3d_gathers_at_the_senders_altitude_on_every_engine_alike():
    scenario = load("gathering-3d").with_overrides(iterations=2400, gathering_iteration=900)
    runs = {e: Simulation.create(scenario, seed=2, engine=e).run(progress=False) for e in ENGINES}
    reference = _digest(runs["pytrees"])
    for engine in ENGINES[1:]:
        other = _digest(runs[engine])
        for key, values in reference.items():
            assert np.array_equal(values, other[key], equal_nan=True), (engine, key)
    sim = runs["batched"]
    order = [e for e in sim.events if e["event"] == "message"]
    assert order and order[0]["data"] == {"x": 50.0, "y": 50.0, "z": 20.0}  # drone1's point
    bb = sim.swarm.blackboard
    assert np.all(bb["z_surveillance_position"] == 20.0)
    # after their next refuelling every drone flies there and hovers at 20 units
    there = _visits(sim, (50.0, 50.0, 20.0), scenario.parameters.destination_tolerance)
    assert there.all(), there
    assert np.all(sim.swarm.columns["z"] == 20.0), sim.swarm.columns["z"]


@pytest.mark.parametrize(
    ("leaf_type", "scenario", "ports"),
    [
        (leaves3d.ConditionDestinationReached3D, "patrol-3d", {"distance": 30.0}),
        (leaves3d.ActionNavigateToDestination3DA, "patrol-3d", {"distance": 20.0}),
        (leaves3d.ActionRequestAltitudeS, "patrol-3d", {"altitude": 7.5}),
        (leaves3d.ActionLand3DA, "patrol-3d", {}),
        (leaves3d.ActionSetDestinationEqualToSurveillance3DS, "gathering-3d", {}),
        (leaves3d.ActionSetDestinationEqualToRefueling3DS, "gathering-3d", {}),
        (leaves3d.ActionSetDestinationEqualToOtherSurveillance3DS, "patrol-3d", {}),
        (leaves3d.ActionSetDestinationEqualToCurrentSurveillance3DS, "patrol-3d", {}),
        (leaves3d.ActionTransmitGatheringMessage3DS, "gathering-3d", {}),
    ],
)
def test_each_3d_leaf_runs_alike_on_both_engines(leaf_type, scenario, ports):
    assert check_leaf(leaf_type, scenario, agents=6, iterations=40, **ports) == 40


#: Run in a subprocess: the 3-D patrol on every engine, a digest of each run's data.
COMPARE_3D = """
import hashlib, json, numpy as np
from pyautonomousagent import Simulation, load, jit
scenario = load("patrol-3d").with_overrides(agents=3, iterations=900)
digests = {}
for engine in ("pytrees", "batched") + (("compiled",) if jit.available() else ()):
    sim = Simulation.create(scenario, seed=5, engine=engine).run(progress=False)
    h = hashlib.sha256(json.dumps(sim.events).encode())
    for key in sorted(sim.recorder.columns):
        h.update(key.encode() + np.ascontiguousarray(sim.recorder.column(key)).tobytes())
    h.update(np.ascontiguousarray(sim.recorder.traces[: sim.recorder.count]).tobytes())
    digests[engine] = h.hexdigest()
print(json.dumps(digests))
"""


def test_patrol_3d_engines_agree_with_and_without_avx512():
    here = simd_digests(COMPARE_3D)
    assert len(here) >= 2 and len(set(here.values())) == 1, here
    features = _enabled_avx512()
    if not features:
        pytest.skip("this CPU has no AVX-512: only one SIMD level to test")
    without = simd_digests(COMPARE_3D, " ".join(features))
    assert len(set(without.values())) == 1, without  # the engines agree without AVX-512
    assert without == here  # and give the same bits on both SIMD levels


def test_animation_and_replay_show_the_altitude():
    scenario = load("gathering-3d").with_overrides(iterations=700)
    recorder = Simulation.create(scenario, engine="batched").run(progress=False).recorder
    z = recorder.column("z")
    row = 700  # drones hover at 20, 35, 10 and 25 units
    painter = FramePainter(recorder, scenario)
    assert painter.altitude == (0.0, z.max())
    assert [painter._label(a, row) for a in range(4)] == ["1 z=20", "2 z=35", "3 z=10", "4 z=25"]
    painter.render(row)
    colours = painter.bodies.get_facecolors()[:, :3]
    expected = matplotlib.colormaps["viridis"](z[row] / z.max())[:, :3]
    assert np.allclose(colours, expected)  # coloured by altitude, the highest yellow
    data = replay_data(recorder, scenario.world, scenario.name)
    altitude = data["altitude"]
    codes = np.frombuffer(base64.b64decode(altitude["data"]), dtype="<u2").reshape(-1, 4)
    frames = np.asarray(data["iterations"])
    decoded = altitude["offset"] + codes * altitude["step"]
    assert np.allclose(decoded, z[frames], atol=altitude["step"])
    flat = load("gathering").with_overrides(iterations=5)
    flat_recorder = Simulation.create(flat, engine="batched").run(progress=False).recorder
    assert replay_data(flat_recorder, flat.world, flat.name)["altitude"] is None
    assert FramePainter(flat_recorder, flat).altitude is None


def _one_drone(**values: float) -> tuple[Simulation, AgentView]:
    """A one-drone patrol-3d run (not stepped) with the given columns and blackboard keys."""
    sim = Simulation.create(load("patrol-3d").with_overrides(agents=1), engine="batched")
    for key, value in values.items():
        target = sim.swarm.columns if key in sim.swarm.columns else sim.swarm.blackboard
        target[key][:] = value
    return sim, sim.swarm.agent(0)


def _leaf(name: str, **ports: float) -> Leaf:
    defaults = {"destination_tolerance": 0.5, "reference_speed": 0.1, "descent_slope": 0.4,
                "cruise_altitude": 20.0}  # fmt: skip
    return leaf_type(name).create(ports, defaults, where=f"test {name}")


def test_navigate_3d_glides_down_and_climbs_at_once():
    # 30 units east of a destination on the ground, at 20 units: the glide path is at
    # 0 + 0.4 * 30 = 12 below 20, so the drone requests 12 (it has met the path)
    sim, drone = _one_drone(x=30.0, y=0.0, z=20.0, x_current_destination_position=0.0,
                            y_current_destination_position=0.0,
                            z_current_destination_position=0.0)  # fmt: skip
    leaf = _leaf("Action_Navigate_To_Destination_3D_A")
    assert leaf.evaluate(drone, sim.world) == RUNNING
    assert drone.requested_altitude == pytest.approx(12.0, abs=1e-12)
    assert drone.requested_speed == 0.1 and drone.requested_heading == 270.0  # due west
    # 100 units away the path is at 40, above 20: hold 20
    drone.x = 100.0
    leaf.evaluate(drone, sim.world)
    assert drone.requested_altitude == 20.0
    # a destination above: climb to it at once, whatever the distance
    sim.swarm.blackboard["z_current_destination_position"][:] = 35.0
    leaf.evaluate(drone, sim.world)
    assert drone.requested_altitude == 35.0
    # within 0.5 horizontally: hover (speed 0) and descend the rest of the way
    drone.x, drone.y = 0.3, 0.3  # 0.42 away
    leaf.evaluate(drone, sim.world)
    assert drone.requested_speed == 0.0


def test_destination_reached_3d_is_a_cylinder_and_land_waits_for_the_ground():
    sim, drone = _one_drone(x=0.3, y=0.4, z=10.4, x_current_destination_position=0.0,
                            y_current_destination_position=0.0,
                            z_current_destination_position=10.0)  # fmt: skip
    reached = _leaf("Condition_Destination_Reached_3D")
    assert reached.evaluate(drone, sim.world) == SUCCESS  # 0.5 across, 0.4 below: inside
    drone.z = 10.6
    assert reached.evaluate(drone, sim.world) == FAILURE  # 0.6 above
    land = _leaf("Action_Land_3D_A")
    drone.heading = 123.0
    assert land.evaluate(drone, sim.world) == RUNNING
    assert (drone.requested_speed, drone.requested_altitude) == (0.0, 0.0)
    assert drone.requested_heading == 123.0
    drone.z = 0.0
    assert land.evaluate(drone, sim.world) == SUCCESS
    request = _leaf("Action_Request_Altitude_S")
    assert request.evaluate(drone, sim.world) == SUCCESS and drone.requested_altitude == 20.0


@pytest.mark.skipif(not jit.available(), reason="numba is not installed")
def test_the_compiled_tick_steps_alike_too():
    # Simulation.step() ticks the compiled tree iteration by iteration (no fused loop):
    # every node status after every tick and every column equal to the batched engine's
    engines = ("batched", "compiled")
    assert check_engines_agree(None, "patrol-3d", 1, engines, agents=3, iterations=900) == 900
    assert (
        check_engines_agree(
            None, "gathering-3d", 1, engines, iterations=700, gathering_iteration=300
        )
        == 700
    )
