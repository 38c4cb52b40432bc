"""The X8's take-off and landing (issue 18, part 3): the ground, the phases, the leaves, the
cycles of x8-patrol, the PyFly reference against the vectorised model, and the engines.

``short`` is the x8-landing scenario (x8-patrol cut to one cycle): launched on the extended
centre line at the approach fix (250 m out), heading for the runway, at the glide path's
altitude, with a low-energy threshold that sends it to land at once; it lands, refuels, takes
off and is back at cruise altitude after about 32 s (3200 iterations).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

pytest.importorskip("pyfly", reason="needs the [x8] extra (pyfly-fixed-wing)")

from pyautonomousagent import Simulation, jit, load  # noqa: E402
from pyautonomousagent.bt.status import RUNNING, SUCCESS  # noqa: E402
from pyautonomousagent.cli import main  # noqa: E402
from pyautonomousagent.models import x8_dynamics as dyn  # noqa: E402
from pyautonomousagent.models import x8_modes as modes  # noqa: E402
from pyautonomousagent.models.x8 import X8Settings, observe  # noqa: E402
from pyautonomousagent.models.x8_flight_log import FlightLog, stall_speed  # noqa: E402
from pyautonomousagent.simulation.scenario import Scenario, to_mapping  # noqa: E402

SHORT = 3300  # iterations of one whole cycle of ``short``
#: PyFly against the vectorised model over that cycle (measured: 1.9 cm, 1.25 mm, 0.63 mm/s):
#: position (m), altitude (m), airspeed (m/s); phase changes in the same iteration (+-1).
AGREEMENT = {"position": 0.5, "altitude": 0.1, "airspeed": 0.05}


def short(agents: int = 1, iterations: int = SHORT) -> Scenario:
    return load("x8-landing").with_overrides(agents=agents, iterations=iterations)


def watched(sim: Simulation) -> tuple[FlightLog, np.ndarray]:
    """Run ``sim`` to its end, watching every iteration; agent 0's x, y, altitude, airspeed
    and phase per iteration."""
    log = FlightLog(sim.swarm.size)
    trace = np.empty((5, sim.scenario.iterations))
    for i in range(sim.scenario.iterations):
        sim.step()
        log.watch(sim.model)
        f = sim.model.flight
        trace[:, i] = f.east[0], f.north[0], f.altitude[0], f.airspeed[0], sim.model.phase[0]
    return log, trace


def check(log: FlightLog, sim: Simulation) -> None:
    """No limit broken, every aircraft through a whole cycle, one touchdown per cycle (and
    perhaps one more, in a cycle the run ends in)."""
    stall = stall_speed()
    print(log.summary(stall))
    assert log.problems(stall) == []
    assert (log.cycles >= 1).all()
    extra = sim.model.touchdowns - log.cycles
    assert ((extra == 0) | (extra == 1)).all(), (sim.model.touchdowns, log.cycles)


# --- the ground ---------------------------------------------------------------------------


def one_aircraft(roll: float, pitch: float, yaw: float, ned_velocity, down: float) -> np.ndarray:
    state = np.zeros((dyn.STATES, 1))
    state[dyn.QUATERNION] = dyn.quaternion_from_euler(
        np.array([roll]), np.array([pitch]), np.array([yaw])
    )
    rot = dyn.rotation(state[dyn.QUATERNION])[:, :, 0]
    state[dyn.VELOCITY, 0] = rot.T @ np.asarray(ned_velocity, dtype=float)
    state[dyn.RATES, 0] = 0.3, -0.2, 0.1
    state[dyn.PD] = down
    return state


def test_the_ground_stops_sinking_levels_the_wings_and_brakes():
    state = one_aircraft(0.2, -0.05, 1.0, [12.0, 5.0, 1.5], down=0.02)
    contact = modes.ground_contact(state, np.array([0.4]), math.radians(12))
    f = observe(state)
    assert state[dyn.PD, 0] == 0.0 and f.altitude[0] == 0.0
    assert abs(f.roll[0]) < 1e-12 and abs(f.pitch[0]) < 1e-12  # level; pitch -0.05 -> 0
    assert f.climb[0] == pytest.approx(0.0, abs=1e-12)  # no sinking
    assert contact.sink[0] == pytest.approx(1.5)
    # the velocity along the heading (yaw 1 rad), less mu times the sink; sideways: none
    along = 12.0 * math.cos(1.0) + 5.0 * math.sin(1.0)
    assert f.airspeed[0] == pytest.approx(along - 0.4 * 1.5, rel=1e-12)
    assert f.course[0] == pytest.approx(1.0, abs=1e-12)
    assert state[dyn.P, 0] == 0.0 and state[dyn.R, 0] == 0.0 and state[dyn.Q, 0] == 0.0


def test_the_ground_keeps_pitch_within_limits_and_stops_an_aircraft():
    state = one_aircraft(0.0, 0.4, -2.0, [0.05, 0.0, 0.5], down=0.0)
    contact = modes.ground_contact(state, np.array([0.4]), math.radians(12))
    f = observe(state)
    assert f.pitch[0] == pytest.approx(math.radians(12), abs=1e-12)
    assert f.airspeed[0] == 0.0 and contact.stopped[0]  # friction took the last 5 cm/s
    assert (state[dyn.VELOCITY, 0] == 0.0).all()


def test_an_aircraft_above_the_ground_or_lifting_off_is_left_alone():
    along = [15.0 * math.cos(0.5), 15.0 * math.sin(0.5), -1.0]  # along its heading, 0.5 rad
    state = one_aircraft(0.0, 0.1, 0.5, along, down=0.0)
    before = state.copy()
    contact = modes.ground_contact(state, np.array([0.04]), math.radians(12))
    assert contact.sink[0] == 0.0  # climbing: no normal impulse, no friction
    f, g = observe(state), observe(before)
    assert f.climb[0] == pytest.approx(g.climb[0], abs=1e-12)
    assert f.airspeed[0] == pytest.approx(g.airspeed[0], rel=1e-12)


def test_phases_follow_the_requested_modes():
    m = X8Settings().mode_settings()
    phase = np.array([modes.FLIGHT, modes.APPROACH, modes.APPROACH, modes.PARKED,
                      modes.GROUND_ROLL, modes.CLIMB_OUT, modes.FLIGHT])  # fmt: skip
    mode = np.array([modes.LAND, modes.LAND, modes.CRUISE, modes.TAKE_OFF, modes.TAKE_OFF,
                     modes.TAKE_OFF, modes.CRUISE], dtype=float)  # fmt: skip
    altitude = np.array([20.0, 2.9, 10.0, 0.0, 0.0, 18.5, 20.0])
    airspeed = np.array([22.0, 16.0, 16.0, 0.0, 14.0, 18.0, 22.0])
    modes.transitions(phase, mode, altitude, airspeed, m)
    assert phase.tolist() == [modes.APPROACH, modes.FLARE, modes.FLIGHT, modes.GROUND_ROLL,
                              modes.CLIMB_OUT, modes.FLIGHT, modes.FLIGHT]  # fmt: skip
    o = modes.overrides(phase, np.full(7, 7.0), altitude, np.zeros(7), m)
    assert o.altitude.tolist() == [7.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0]
    assert o.throttle[3] == 1.0 and o.throttle[4] == 1.0 and np.isnan(o.throttle[0])
    assert o.pitch[4] == m.rotation_pitch and o.roll[4] == 0.0 and np.isnan(o.roll[0])


def test_touching_the_ground_ends_a_flight_and_a_stop_parks():
    phase = np.array([modes.FLARE, modes.APPROACH, modes.ROLLOUT, modes.GROUND_ROLL])
    contact = modes.Contact(np.zeros(4), np.zeros(4), np.array([False, False, True, True]))
    landed = modes.after_contact(phase, np.arange(4), contact)
    assert landed.tolist() == [True, True, False, False]
    assert phase.tolist() == [modes.ROLLOUT, modes.ROLLOUT, modes.PARKED, modes.GROUND_ROLL]


# --- the leaves ---------------------------------------------------------------------------


def leaf_states(sim: Simulation) -> dict[str, list[float]]:
    s, bb = sim.swarm.columns, sim.swarm.blackboard
    keys = ["requested_heading", "requested_speed", "requested_altitude", "autopilot_mode"]
    return {k: s[k].tolist() for k in keys} | {"leg": bb["approach_leg"].tolist()}


@pytest.mark.parametrize("type_name", ["Action_Land_A", "Action_Take_Off_A"])
def test_landing_leaves_give_the_same_bits_per_agent_for_all_and_compiled(type_name):
    from pyautonomousagent.bt.leaf import leaf_type

    sim = Simulation.create(load("x8-patrol").with_overrides(agents=4), engine="batched")
    s = sim.swarm.columns
    s["x"][:], s["y"][:] = [100.0, 930.0, 560.0, 480.0], [900.0, 480.0, 505.0, 500.0]
    s["heading"][:] = [10.0, 250.0, 271.0, 269.0]
    s[modes.PHASE_COLUMN][:] = [modes.FLIGHT, modes.FLIGHT, modes.APPROACH, modes.PARKED]
    sim.swarm.blackboard["approach_leg"][:] = [0, 0, 1, 1]
    node = leaf_type(type_name).create({}, vars(sim.scenario.parameters), where="test")
    start = {k: v.copy() for k, v in s.items()}, sim.swarm.blackboard["approach_leg"].copy()

    def reset() -> None:
        for k, v in start[0].items():
            s[k][:] = v
        sim.swarm.blackboard["approach_leg"][:] = start[1]

    statuses = np.asarray(node.evaluate(sim.swarm.agents(), sim.world)).tolist()
    together = leaf_states(sim)
    reset()
    alone = [int(node.evaluate(sim.swarm.agent(a), sim.world)) for a in range(4)]
    assert alone == statuses and leaf_states(sim) == together
    reset()
    kernel = node.kernel(sim.world)
    arrays = [s[n] if n in s else sim.swarm.blackboard[n] for n in kernel.names]
    compiled = [int(kernel.function(a, *arrays, *kernel.constants)) for a in range(4)]
    assert compiled == statuses and leaf_states(sim) == together
    if type_name == "Action_Land_A":  # far: to the fix; near it and on final: land; parked
        assert statuses == [RUNNING, RUNNING, RUNNING, SUCCESS]
        assert together["autopilot_mode"] == [modes.CRUISE, modes.LAND, modes.LAND, modes.LAND]
        assert together["leg"] == [0, 1, 1, 0]
        assert together["requested_speed"][:3] == [22.0, 15.0, 15.0]
        glide = math.tan(math.radians(3.0)) * math.hypot(60.0, 5.0)
        assert together["requested_altitude"][2] == pytest.approx(glide)
        west_by_south = 270.0 - math.degrees(math.atan2(5.0, 60.0))  # from (560, 505)
        assert together["requested_heading"][2] == pytest.approx(west_by_south)
    else:  # flying: done; else take off straight ahead
        assert statuses == [SUCCESS, SUCCESS, RUNNING, RUNNING]
        assert together["autopilot_mode"] == [modes.CRUISE, modes.CRUISE, modes.TAKE_OFF,
                                              modes.TAKE_OFF]  # fmt: skip
        assert together["requested_heading"] == [10.0, 250.0, 271.0, 269.0]


# --- whole cycles -------------------------------------------------------------------------


def test_every_uav_lands_refuels_and_takes_off_again():
    """The acceptance's checks on x8-patrol, shortened: 3 UAVs, 12,000 iterations (120 s,
    one cycle each; ``scripts/x8_cycles.py`` runs the paper's 4 x 200,000)."""
    scenario = load("x8-patrol").with_overrides(agents=3, iterations=12_000)
    sim = Simulation.create(scenario, seed=0, engine="batched", record_every=100)
    log, _ = watched(sim)
    check(log, sim)
    assert sim.events == []  # nobody ran out of energy
    energy = sim.recorder.column("energy")
    assert energy.max() == 100.0 and energy[-1].min() > 60.0  # refuelled on the ground


def test_pyfly_flies_the_cycle_as_the_vectorised_model_does():
    logs, traces = {}, {}
    for implementation in ("pyfly", "vectorised"):
        sim = Simulation.create(short(), seed=0, engine="pytrees", implementation=implementation)
        logs[implementation], traces[implementation] = watched(sim)
        check(logs[implementation], sim)
    a, b = traces["pyfly"], traces["vectorised"]
    gaps = {
        "position": np.hypot(a[0] - b[0], a[1] - b[1]).max(),
        "altitude": np.abs(a[2] - b[2]).max(),
        "airspeed": np.abs(a[3] - b[3]).max(),
    }
    print("largest differences over the cycle:", {k: f"{v:.2e}" for k, v in gaps.items()})
    for key, bound in AGREEMENT.items():
        assert gaps[key] < bound, (key, gaps[key])
    for phase in range(len(modes.PHASES)):  # every phase, entered in the same iteration
        first = [int(np.argmax(t[4] == phase)) for t in (a, b)]
        assert (a[4] == phase).any() and abs(first[0] - first[1]) <= 1, (phase, first)
    sink = [logs[k].sinks[0] for k in ("pyfly", "vectorised")]
    assert abs(sink[0] - sink[1]) < 0.01, sink


NEEDS_NUMBA = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


@pytest.mark.parametrize("engine", ["pytrees", pytest.param("compiled", marks=NEEDS_NUMBA)])
def test_engines_make_the_same_cycle_as_the_batched_engine(engine):
    """Same implementation (vectorised), same bits: decisions and data."""
    scenario = short(agents=2)
    batched = Simulation.create(scenario, engine="batched").run(progress=False)
    other = Simulation.create(scenario, engine=engine, implementation="vectorised")
    other.run(progress=False)
    assert (batched.model.touchdowns == 1).all()
    for key, values in batched.recorder.columns.items():
        np.testing.assert_array_equal(other.recorder.column(key), values, err_msg=key)


def numpy_reference(monkeypatch, scenario: Scenario) -> Simulation:
    """``scenario`` run on the batched engine with the X8's NumPy code (the reference), not
    its kernel."""
    from pyautonomousagent.models import x8 as x8_module

    original = x8_module.X8Vectorised.__init__

    def forced(self, *args, **kwargs):
        kwargs["agent_by_agent"] = False
        original(self, *args, **kwargs)

    monkeypatch.setattr(x8_module.X8Vectorised, "__init__", forced)
    sim = Simulation.create(scenario, engine="batched")
    monkeypatch.setattr(x8_module.X8Vectorised, "__init__", original)
    assert not sim.model.agent_by_agent
    return sim.run(progress=False)


@NEEDS_NUMBA
def test_the_compiled_engine_flies_whole_cycles_as_the_numpy_reference(monkeypatch):
    """Issue 28: on the compiled engine the phases and the ground run in the X8's compiled
    kernel; through a whole land-refuel-take-off cycle of each UAV its records, phases,
    touchdowns and final states are the NumPy code's, bit for bit."""
    scenario = short(agents=3)
    reference = numpy_reference(monkeypatch, scenario)
    compiled = Simulation.create(scenario, engine="compiled").run(progress=False)
    assert compiled.engine.name == "compiled" and compiled.model.compiled
    phases = reference.recorder.column(modes.PHASE_COLUMN)
    for a in range(3):  # every phase of the cycle, ending in flight
        assert set(np.unique(phases[:, a])) == set(range(len(modes.PHASES))), a
        assert phases[-1, a] == modes.FLIGHT
    energy = reference.recorder.column("energy")
    assert (np.diff(energy, axis=0) > 0.0).any(axis=0).all()  # each refuelled
    for key, values in reference.recorder.columns.items():
        np.testing.assert_array_equal(compiled.recorder.column(key), values, err_msg=key)
    for name in ("touchdowns", "strikes", "touchdown_sink", "touchdown_speed", "phase", "state"):
        want = getattr(reference.model, name)
        np.testing.assert_array_equal(getattr(compiled.model, name), want, err_msg=name)
    assert (reference.model.touchdowns == 1).all()


def test_the_kernel_and_the_numpy_code_land_with_the_same_bits(monkeypatch):
    from pyautonomousagent.models import x8 as x8_module

    runs = []
    for agent_by_agent in (True, False):
        original = x8_module.X8Vectorised.__init__

        def forced(self, *args, _original=original, _flag=agent_by_agent, **kwargs):
            kwargs["agent_by_agent"] = _flag
            _original(self, *args, **kwargs)

        monkeypatch.setattr(x8_module.X8Vectorised, "__init__", forced)
        sim = Simulation.create(short(agents=2), engine="batched").run(progress=False)
        assert sim.model.agent_by_agent is agent_by_agent
        runs.append(sim)
        monkeypatch.setattr(x8_module.X8Vectorised, "__init__", original)
    assert (runs[0].model.touchdowns == 1).all()
    for key, values in runs[0].recorder.columns.items():
        np.testing.assert_array_equal(runs[1].recorder.column(key), values, err_msg=key)


# --- bad input ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("runway", "says"),
    [
        ({"x": 1200, "y": 500, "heading": 270}, "world.runway must be inside the world"),
        ({"x": 900, "y": 500, "heading": 270}, "its approach fix"),
        ({"x": 500, "y": 500}, "world.runway"),
        ({"x": 500, "y": "north", "heading": 270}, "world.runway.y"),
    ],
)
def test_a_landing_site_outside_the_world_is_one_clear_line(runway, says, tmp_path, capsys):
    data = to_mapping(load("x8-patrol"))
    data["world"]["runway"] = runway
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    out_dir = str(tmp_path / "out")
    code = main(["run", str(path), "--iterations", "1", "--quiet", "--out", out_dir])
    out, err = capsys.readouterr()
    assert code == 2
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert "bad.yaml" in err and says in err, err
