"""The motion models' per-agent forms (``*_agent``: what the compiled engine's loop and the
GPU kernel call) equal their NumPy forms bit for bit over every row of random states, for
agents that move and agents that cannot, compiled and as plain Python (the GPU simulator's)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from pyautonomousagent.models import drone2d, drone3d
from pyautonomousagent.models.drone2d import Drone2D, DroneParameters
from pyautonomousagent.models.drone3d import Drone3D, Drone3DParameters

N = 4000
P2 = DroneParameters(max_speed=0.3, speed_step=0.07, turn_step=2.5)
P3 = Drone3DParameters(max_speed=0.3, speed_step=0.07, turn_step=2.5, max_climb_rate=0.04,
                       climb_step=0.015, max_altitude=80.0)  # fmt: skip


def _some(rng: np.random.Generator, values: np.ndarray, special: list[float]) -> np.ndarray:
    """``values`` with a quarter of its entries replaced by ``special`` ones (bounds, ties)."""
    rows = rng.random(values.size) < 0.25
    values[rows] = rng.choice(special, int(rows.sum()))
    return values


def _state(rng: np.random.Generator, p: Drone3DParameters) -> dict[str, np.ndarray]:
    """Random columns, shape (N,) each, with many values on bounds and ties."""
    heading = _some(rng, rng.uniform(0.0, 360.0, N), [0.0, 90.0, 180.0, np.nextafter(360.0, 0)])
    speed = _some(rng, rng.uniform(0.0, p.max_speed, N), [0.0, p.max_speed])
    turn = _some(rng, rng.uniform(-360.0, 360.0, N), [0.0, 180.0, -180.0, 1e-13])
    z = _some(rng, rng.uniform(0.0, p.max_altitude, N), [0.0, p.max_altitude])
    climb = _some(rng, rng.uniform(-1, 1, N) * p.max_climb_rate, [0.0, p.max_climb_rate])
    return {
        "x": rng.uniform(-500.0, 500.0, N), "y": rng.uniform(-500.0, 500.0, N),
        "speed": speed, "heading": heading, "z": z, "climb_rate": climb,
        "requested_speed": _some(rng, rng.uniform(0.0, p.max_speed, N), [*speed[:4]]),
        "requested_heading": (heading + turn) % 360.0,
        "requested_altitude": _some(rng, rng.uniform(-10.0, 90.0, N), [*(z + climb)[:4]]),
    }  # fmt: skip


def _signals(rng: np.random.Generator, model: Drone2D | Drone3D, p: Drone3DParameters) -> None:
    """The model's last control signals, at random among their values."""
    model.u_speed = rng.choice([-p.speed_step, 0.0, p.speed_step], N)
    model.u_heading = rng.choice([-p.turn_step, 0.0, p.turn_step], N)
    if isinstance(model, Drone3D):
        model.u_climb = _some(rng, rng.uniform(-1, 1, N) * p.climb_step, [p.climb_step])


def _form(function: Any, compiled: bool) -> Callable[..., None]:
    """The njit ``function``, or its Python (without numba both are the Python)."""
    return function if compiled else getattr(function, "py_func", function)


def _assert_bits(got: dict[str, np.ndarray], want: dict[str, np.ndarray]) -> None:
    for key, value in want.items():
        np.testing.assert_array_equal(got[key].view(np.uint64), value.view(np.uint64), key)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("seed", [0, 1])
def test_drone2d_per_agent_forms_equal_the_numpy_forms(compiled: bool, seed: int) -> None:
    rng = np.random.default_rng(seed)
    s = _state(rng, P3)
    model = Drone2D(P2, N)
    _signals(rng, model, P3)
    moving = rng.random(N) < 0.8
    one = {k: v.copy() for k, v in s.items()}
    step, control = _form(drone2d.step_agent, compiled), _form(drone2d.control_agent, compiled)
    for a in range(N):
        step(a, bool(moving[a]), one["x"], one["y"], one["speed"], one["heading"],
             model.u_speed, model.u_heading, P2.max_speed)  # fmt: skip
    model.advance(s, moving)
    _assert_bits(one, s)
    u = {"u_speed": np.zeros(N), "u_heading": np.zeros(N)}
    for a in range(N):
        control(a, s["speed"], s["heading"], s["requested_speed"], s["requested_heading"],
                u["u_speed"], u["u_heading"], P2.speed_step, P2.turn_step)  # fmt: skip
    model.control(s)
    _assert_bits(u, {"u_speed": model.u_speed, "u_heading": model.u_heading})


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("seed", [0, 1])
def test_drone3d_per_agent_forms_equal_the_numpy_forms(compiled: bool, seed: int) -> None:
    rng = np.random.default_rng(seed)
    s = _state(rng, P3)
    model = Drone3D(P3, N)
    _signals(rng, model, P3)
    moving = rng.random(N) < 0.8
    one = {k: v.copy() for k, v in s.items()}
    step, climb = _form(drone2d.step_agent, compiled), _form(drone3d.climb_agent, compiled)
    for a in range(N):
        step(a, bool(moving[a]), one["x"], one["y"], one["speed"], one["heading"],
             model.u_speed, model.u_heading, P3.max_speed)  # fmt: skip
        climb(a, bool(moving[a]), one["z"], one["climb_rate"], model.u_climb,
              P3.max_climb_rate, P3.max_altitude)  # fmt: skip
    model.advance(s, moving)
    _assert_bits(one, s)
    u = np.zeros(N)
    control = _form(drone3d.climb_control_agent, compiled)
    for a in range(N):
        control(a, s["z"], s["climb_rate"], s["requested_altitude"], u,
                P3.max_climb_rate, P3.climb_step)  # fmt: skip
    model.control(s)
    _assert_bits({"u_climb": u}, {"u_climb": model.u_climb})
