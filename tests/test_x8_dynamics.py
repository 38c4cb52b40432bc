"""The vectorised X8: parameters from the installed package, equations against PyFly's."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyfly", reason="needs the [x8] extra (pyfly-fixed-wing)")

from pyfly.pyfly import PyFly  # noqa: E402

from pyautonomousagent.models import x8_dynamics as dyn  # noqa: E402
from pyautonomousagent.models.x8 import X8Settings, initial_state  # noqa: E402
from pyautonomousagent.models.x8_params import (  # noqa: E402
    CONFIG_FILE,
    PARAMETER_FILE,
    load_parameters,
    pyfly_file,
)

PARAMS = load_parameters()
K = dyn.Constants.of(PARAMS)


def test_data_files_come_from_the_installed_package(tmp_path, monkeypatch):
    import pyfly

    package = Path(pyfly.__path__[0]).resolve()
    monkeypatch.chdir(tmp_path)  # the working directory plays no part
    for name in (PARAMETER_FILE, CONFIG_FILE):
        assert pyfly_file(name).resolve().parent == package
    assert Path(PARAMS.source).resolve().parent == package


def test_parameters_read_from_the_files():
    a, act = PARAMS.airframe, PARAMS.actuators
    assert (a.mass, a.b, a.S_wing) == (3.364, 2.1, 0.75)
    assert (PARAMS.rho, PARAMS.g, PARAMS.dt) == (1.225, 9.81, 0.01)
    assert PARAMS.aero.C_L_alpha == pytest.approx(4.0203, abs=1e-4)
    # elevon limits are given in degrees, the rate limit in rad/s (200 deg/s)
    assert (act.elevon_min, act.elevon_max) == (math.radians(-30), math.radians(35))
    assert act.elevon_rate_max == 3.4907
    assert (act.omega_0, act.zeta, act.throttle_tau) == (100, 1.71, 0.2)


def random_states(rng: np.random.Generator, n: int) -> list[dict]:
    def u(lo, hi):
        return float(rng.uniform(lo, hi))

    return [
        {
            "roll": u(-0.8, 0.8),
            "pitch": u(-0.4, 0.4),
            "yaw": u(-3, 3),
            "omega_p": u(-1, 1),
            "omega_q": u(-1, 1),
            "omega_r": u(-1, 1),
            "position_n": u(0, 1000),
            "position_e": u(0, 1000),
            "position_d": u(-40, -5),
            "velocity_u": u(12, 28),
            "velocity_v": u(-3, 3),
            "velocity_w": u(-3, 3),
            "elevon_right": (u(-0.5, 0.6), u(-5, 5)),  # rates beyond the limit get clipped
            "elevon_left": (u(-0.5, 0.6), u(-5, 5)),
            "throttle": (u(0, 1), 0.0),
        }
        for _ in range(n)
    ]


def test_right_hand_side_equals_pyflys_at_random_states():
    rng = np.random.default_rng(4)
    aircraft = PyFly(str(pyfly_file(CONFIG_FILE)), str(pyfly_file(PARAMETER_FILE)))
    aircraft.seed(0)
    for state in random_states(rng, 20):
        aircraft.reset(state=state)
        command = [rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(0, 1)]
        aircraft.actuation.set_and_constrain_commands(list(command))
        names = ["omega_p", "omega_q", "omega_r", "position_n", "position_e", "position_d"]
        names += ["velocity_u", "velocity_v", "velocity_w"]
        y = np.array(
            [*aircraft.state["attitude"].value, *aircraft.get_states_vector(names)]
            + aircraft.actuation.get_values()
        )
        # PyFly's actuator rows: values (right, left, throttle), then rates (right, left, -)
        expected = aircraft._dynamics(1e-9, y)  # t > 0: the states are read from y
        ours = np.concatenate([y[:13], y[[13, 14, 16, 17, 15]]])[:, None]
        elevons = dyn.elevon_commands(np.array([command[0]]), np.array([command[1]]), K)
        got = dyn.derivatives(ours, np.array([*elevons, [command[2]]]), K)[:, 0]
        want = np.concatenate([expected[:13], expected[[13, 14, 16, 17, 15]]])
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_euler_quaternion_round_trip_and_rotation_is_orthonormal():
    rng = np.random.default_rng(1)
    roll, pitch, yaw = rng.uniform(-3, 3, 50), rng.uniform(-1.5, 1.5, 50), rng.uniform(-3, 3, 50)
    e = dyn.quaternion_from_euler(roll, pitch, yaw)
    np.testing.assert_allclose((e * e).sum(axis=0), 1.0, atol=1e-12)
    back = dyn.euler_from_quaternion(e)
    np.testing.assert_allclose(back, (roll, pitch, yaw), atol=1e-9)
    m = np.moveaxis(dyn.rotation(e), -1, 0)
    np.testing.assert_allclose(
        m @ np.swapaxes(m, 1, 2), np.broadcast_to(np.eye(3), m.shape), atol=1e-12
    )


def test_heading_90_flies_east_and_0_north():
    zeros = np.zeros(2)
    e = dyn.quaternion_from_euler(zeros, zeros, np.radians([90.0, 0.0]))
    ned = dyn.body_to_ned(e, np.full(2, 22.0), zeros, zeros)
    np.testing.assert_allclose(ned, [[0.0, 22.0], [22.0, 0.0], [0.0, 0.0]], atol=1e-12)


def test_actuators_respect_the_rate_limit_and_settle_on_the_command():
    act = PARAMS.actuators
    a = np.zeros((5, 1))
    commands = np.array([[act.elevon_max], [act.elevon_min], [0.7]])
    for _ in range(1000):  # 5 s: 25 throttle time constants
        moved = dyn._actuator_half_step(a, commands, K)
        step = np.abs(moved[0:2] - a[0:2])
        assert (step <= act.elevon_rate_max * PARAMS.dt / 2 + 1e-12).all()
        a = moved
    np.testing.assert_allclose(a[0:2, 0], [act.elevon_max, act.elevon_min], atol=1e-6)
    assert a[4, 0] == pytest.approx(0.7, abs=1e-9)


def test_agents_do_not_interact():
    rng = np.random.default_rng(7)
    n = 6
    y = initial_state(
        X8Settings(), rng.uniform(0, 1000, n), rng.uniform(0, 1000, n), rng.uniform(0, 360, n)
    )
    commands = np.array(
        [rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n), rng.uniform(0, 1, n)]
    )
    together = y
    alone = [y[:, [i]] for i in range(n)]
    for _ in range(50):
        together = dyn.step(together, commands, K)
        alone = [dyn.step(s, commands[:, [i]], K) for i, s in enumerate(alone)]
    np.testing.assert_allclose(together, np.hstack(alone), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose((together[dyn.QUATERNION] ** 2).sum(axis=0), 1.0, atol=1e-14)
