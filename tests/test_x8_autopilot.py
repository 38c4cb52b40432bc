"""The X8 autopilot: per-agent PID state, guidance conventions, PyFly's attitude law."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyautonomousagent.models.autopilot import PID, Guidance, GuidanceGains, wrap_angle


def test_wrap_angle():
    angles = np.array([0.0, math.pi / 2, 3 * math.pi / 2, -3 * math.pi / 2, 2 * math.pi + 0.1])
    np.testing.assert_allclose(
        wrap_angle(angles), [0.0, math.pi / 2, -math.pi / 2, math.pi / 2, 0.1], atol=1e-12
    )


def test_pid_keeps_each_agents_state_apart():
    pid = PID(kp=1.0, ki=0.5, kd=0.1, limit=10.0, dt=0.01, n=2)
    first = pid.update(np.array([1.0, -2.0]))
    np.testing.assert_allclose(first, [1.0 + 0.5 * 0.01, -2.0 - 0.5 * 0.02])  # no derivative kick
    second = pid.update(np.array([1.5, -2.0]))
    np.testing.assert_allclose(pid.integral, [0.025, -0.04])
    np.testing.assert_allclose(second, [1.5 + 0.5 * 0.025 + 0.1 * 50.0, -2.0 - 0.5 * 0.04])
    # the same error sequence for agent 0 alone gives agent 0's outputs
    alone = PID(kp=1.0, ki=0.5, kd=0.1, limit=10.0, dt=0.01, n=1)
    assert alone.update(np.array([1.0]))[0] == first[0]
    assert alone.update(np.array([1.5]))[0] == second[0]


def test_pid_output_is_clipped():
    pid = PID(kp=1.0, ki=0.0, kd=0.0, limit=0.5, dt=0.01, n=2)
    np.testing.assert_allclose(pid.update(np.array([3.0, -3.0])), [0.5, -0.5])


def guidance(n: int = 1) -> Guidance:
    return Guidance(GuidanceGains(), altitude=20.0, min_airspeed=18.0, dt=0.01, n=n)


def test_course_error_is_wrapped_and_turns_the_short_way():
    g = guidance(2)
    # course 10 deg, requested 350 deg: turn left 20 deg (negative roll);
    # course 350 deg (as -10 deg), requested 10 deg: turn right 20 deg
    course = np.radians([10.0, -10.0])
    roll, _, _ = g.references(course, np.full(2, 20.0), np.array([350.0, 10.0]), np.full(2, 22.0))
    error = np.radians([-20.0, 20.0])
    np.testing.assert_allclose(roll, 1.0 * error + 1e-5 * (error * 0.01))  # kp e + ki e dt


def test_roll_and_pitch_references_are_limited():
    g = guidance(2)
    roll, pitch, _ = g.references(
        np.zeros(2), np.array([0.0, 100.0]), np.array([179.0, 181.0]), np.full(2, 22.0)
    )
    np.testing.assert_allclose(roll, np.radians([45.0, -45.0]))
    np.testing.assert_allclose(pitch, np.radians([30.0, -30.0]))


def test_airspeed_reference_is_floored_while_refuelling():
    g = guidance(3)
    _, _, airspeed = g.references(
        np.zeros(3), np.full(3, 20.0), np.zeros(3), np.array([0.0, 22.0, 17.0])
    )
    np.testing.assert_allclose(airspeed, [18.0, 22.0, 18.0])


def test_vectorised_attitude_law_equals_pyflys_controller():
    pytest.importorskip("pyfly", reason="needs the [x8] extra (pyfly-fixed-wing)")
    from pyfly.pid_controller import PIDController

    from pyautonomousagent.models.autopilot import AttitudeController, attitude_gains

    rng = np.random.default_rng(3)
    n, dt = 5, 0.01
    ours = AttitudeController(attitude_gains(dt), dt, n)
    theirs = [PIDController(dt) for _ in range(n)]
    for _ in range(30):
        refs = (rng.uniform(-0.8, 0.8, n), rng.uniform(-0.5, 0.5, n), rng.uniform(15, 25, n))
        roll, pitch = rng.uniform(-0.8, 0.8, n), rng.uniform(-0.5, 0.5, n)
        airspeed, p, q = rng.uniform(15, 25, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        got = np.array(ours.commands(refs, roll, pitch, airspeed, p, q))
        for i, pid in enumerate(theirs):
            pid.set_reference(phi=refs[0][i], theta=refs[1][i], va=refs[2][i])
            want = pid.get_action(roll[i], pitch[i], airspeed[i], [p[i], q[i], 0.0])
            np.testing.assert_allclose(got[:, i], want, rtol=1e-12, atol=1e-12)
