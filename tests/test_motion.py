"""Paper eqs. 1-4 and the Phase 4 bang-bang control, one step computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent.models.drone2d import DroneParameters, advance, control, heading_error

P = DroneParameters()


def step(x, y, v, a, uv=0.0, ua=0.0, params=P):
    out = advance(
        np.array([x], float),
        np.array([y], float),
        np.array([v], float),
        np.array([a], float),
        np.array([uv], float),
        np.array([ua], float),
        params,
    )
    return tuple(float(o[0]) for o in out)


def test_default_parameters_follow_reference_facts():
    assert (P.max_speed, P.speed_step, P.turn_step) == (0.1, 0.1, 1.0)


def test_heading_90_flies_east():
    x, y, v, a = step(10.0, 20.0, 0.1, 90.0)
    assert x == pytest.approx(10.1, abs=1e-15)
    assert y == pytest.approx(20.0, abs=1e-15)
    assert (v, a) == (0.1, 90.0)


def test_heading_0_flies_north():
    x, y, v, a = step(10.0, 20.0, 0.1, 0.0)
    assert x == 10.0  # sin(0) == 0 exactly
    assert y == pytest.approx(20.1, abs=1e-15)
    assert (v, a) == (0.1, 0.0)


def test_heading_180_flies_south_and_270_west():
    x, y, _, _ = step(10.0, 20.0, 0.1, 180.0)
    assert (x, y) == (pytest.approx(10.0, abs=1e-15), pytest.approx(19.9, abs=1e-15))
    x, y, _, _ = step(10.0, 20.0, 0.1, 270.0)
    assert (x, y) == (pytest.approx(9.9, abs=1e-15), pytest.approx(20.0, abs=1e-15))


def test_heading_30_degrees_by_hand():
    # sin(30 deg) = 0.5, cos(30 deg) = sqrt(3)/2 = 0.8660254037844386
    x, y, v, a = step(1.0, 2.0, 0.1, 30.0)
    assert x == pytest.approx(1.0 + 0.1 * 0.5, abs=1e-15)
    assert y == pytest.approx(2.0 + 0.1 * 0.8660254037844386, abs=1e-15)
    assert x == pytest.approx(1.05, abs=1e-15)
    assert y == pytest.approx(2.08660254037844386, abs=1e-15)
    assert (v, a) == (0.1, 30.0)


def test_motion_uses_previous_speed_and_heading_then_applies_controls():
    # eqs. 1-2 use v(t-1) and alpha(t-1); eqs. 3-4 add the controls for the next step.
    x, y, v, a = step(0.0, 0.0, 0.05, 90.0, uv=0.1, ua=1.0)
    assert x == pytest.approx(0.05, abs=1e-15)
    assert y == pytest.approx(0.0, abs=1e-15)
    assert v == 0.1  # 0.05 + 0.1 = 0.15 clipped to max_speed
    assert a == 91.0


def test_speed_increases_by_control_signal():
    _, _, v, _ = step(0.0, 0.0, 0.0, 0.0, uv=0.1, params=DroneParameters(max_speed=1.0))
    assert v == pytest.approx(0.1)
    _, _, v, _ = step(0.0, 0.0, 0.5, 0.0, uv=-0.1, params=DroneParameters(max_speed=1.0))
    assert v == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("speed", "u", "expected"),
    [(0.1, 0.1, 0.1), (0.05, 0.1, 0.1), (0.0, -0.1, 0.0), (0.05, -0.1, 0.0), (0.1, 0.0, 0.1)],
)
def test_speed_clipped_to_0_and_max_speed(speed, u, expected):
    _, _, v, _ = step(0.0, 0.0, speed, 0.0, uv=u)
    assert v == expected


@pytest.mark.parametrize(
    ("heading", "u", "expected"),
    [
        (359.5, 1.0, 0.5),
        (359.0, 1.0, 0.0),
        (0.0, -1.0, 359.0),
        (0.5, -1.0, 359.5),
        (180.0, 1.0, 181.0),
    ],
)
def test_heading_wraps_into_0_360(heading, u, expected):
    _, _, _, a = step(0.0, 0.0, 0.0, heading, ua=u)
    assert a == pytest.approx(expected, abs=1e-12)
    assert 0.0 <= a < 360.0


def test_advance_works_on_arrays():
    x, y, v, a = advance(
        np.array([0.0, 5.0]),
        np.array([0.0, 5.0]),
        np.array([0.1, 0.1]),
        np.array([0.0, 90.0]),
        np.array([0.0, -0.1]),
        np.array([-1.0, 1.0]),
        P,
    )
    np.testing.assert_allclose(x, [0.0, 5.1], atol=1e-15)
    np.testing.assert_allclose(y, [0.1, 5.0], atol=1e-15)
    np.testing.assert_array_equal(v, [0.1, 0.0])
    np.testing.assert_array_equal(a, [359.0, 91.0])


def ctrl(speed, heading, requested_speed, requested_heading, params=P):
    uv, ua = control(
        np.array([speed], float),
        np.array([heading], float),
        np.array([requested_speed], float),
        np.array([requested_heading], float),
        params,
    )
    return float(uv[0]), float(ua[0])


@pytest.mark.parametrize(
    ("current", "requested", "turn"),
    [
        (350.0, 10.0, 1.0),  # across the seam, clockwise
        (10.0, 350.0, -1.0),  # across the seam, counter-clockwise
        (90.0, 90.0, 0.0),  # equal
        (0.0, 0.0, 0.0),
        (10.0, 20.0, 1.0),
        (20.0, 10.0, -1.0),
        (0.0, 179.0, 1.0),
        (0.0, 181.0, -1.0),
        (359.0, 0.0, 1.0),
        (0.0, 359.0, -1.0),
    ],
)
def test_turn_direction_is_the_shorter_way(current, requested, turn):
    assert ctrl(0.1, current, 0.1, requested) == (0.0, turn)


@pytest.mark.parametrize(
    ("speed", "requested", "signal"),
    [(0.0, 0.1, 0.1), (0.1, 0.0, -0.1), (0.1, 0.1, 0.0), (0.05, 0.1, 0.1), (0.0, 0.0, 0.0)],
)
def test_speed_signal(speed, requested, signal):
    assert ctrl(speed, 0.0, requested, 0.0) == (signal, 0.0)


def test_turn_step_is_a_parameter():
    params = DroneParameters(turn_step=2.5, speed_step=0.05)
    assert ctrl(0.0, 350.0, 0.1, 10.0, params) == (0.05, 2.5)


@pytest.mark.parametrize(
    ("requested", "current", "error"),
    [
        (10.0, 350.0, 20.0),
        (350.0, 10.0, -20.0),
        (180.0, 0.0, 180.0),
        (0.0, 180.0, 180.0),
        (5.0, 5.0, 0.0),
    ],
)
def test_heading_error_in_minus_180_to_180(requested, current, error):
    assert float(heading_error(np.array([requested]), np.array([current]))[0]) == error


def test_control_then_advance_turns_toward_request_across_seam():
    # 350 -> 10: ten clockwise steps of 1 degree reach 360 == 0, ten more reach 10.
    heading = 350.0
    for _ in range(20):
        _, ua = ctrl(0.0, heading, 0.0, 10.0)
        heading = step(0.0, 0.0, 0.0, heading, ua=ua)[3]
    assert heading == 10.0
    assert ctrl(0.0, heading, 0.0, 10.0) == (0.0, 0.0)


def test_heading_error_is_the_shortest_signed_turn_on_a_grid():
    # every pair of headings on a 2.5-degree grid, including the 0/360 seam and 180 apart
    grid = np.arange(0.0, 360.0, 2.5)
    requested, current = (a.ravel() for a in np.meshgrid(grid, grid))
    error = heading_error(requested, current)
    assert (error > -180.0).all() and (error <= 180.0).all()
    landed = np.mod(current + error, 360.0)
    np.testing.assert_allclose(landed, requested, atol=1e-9)
    still = np.zeros_like(current)
    _, turn = control(still, current, still, requested, P)
    np.testing.assert_array_equal(turn, np.sign(error))
    assert (turn[requested == current] == 0).all()
