"""The portable sine and cosine of an angle in degrees (arrays.sincos_degrees, its kernel twin)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyautonomousagent import arrays, jit
from pyautonomousagent.arrays import DEGREE, sincos_degrees

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


def angles() -> np.ndarray:
    """Whole degrees, a fine grid, random angles, tiny ones and the neighbours of the
    quadrant and octant boundaries, all in [0, 360)."""
    rng = np.random.default_rng(20)
    edges = np.arange(0.0, 361.0, 45.0)
    near = np.concatenate([np.nextafter(edges, -1.0), edges, np.nextafter(edges, 400.0)])
    tiny = np.array([5e-324, 1e-300, 1e-200, 1e-20, 1e-10, 1e-5, 359.99999999999994])
    every = np.concatenate(
        [np.arange(360.0), np.linspace(0.0, 360.0, 100_000, endpoint=False), tiny, near]
    )
    every = np.concatenate([every, rng.uniform(0.0, 360.0, 100_000)])
    return every[(every >= 0.0) & (every < 360.0)]


def reference(angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """libm's sine and cosine after an exact reduction to [-45, 45] degrees."""
    k = np.floor((angle + 45.0) / 90.0)
    x = (angle - 90.0 * k) * DEGREE
    s = np.array([math.sin(v) for v in x.tolist()])
    c = np.array([math.cos(v) for v in x.tolist()])
    q = (k % 4).astype(int)
    return np.choose(q, [s, c, -s, -c]), np.choose(q, [c, -s, -c, s])


def ulps(value: np.ndarray, exact: np.ndarray) -> float:
    return float((np.abs(value - exact) / np.spacing(np.abs(exact))).max())


def bits(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.int64)


def test_within_an_ulp_of_the_library_and_close_to_sin_of_radians() -> None:
    a = angles()
    sine, cosine = sincos_degrees(a)
    exact_sine, exact_cosine = reference(a)
    assert ulps(sine, exact_sine) <= 1.0
    assert ulps(cosine, exact_cosine) <= 1.0
    # math.sin(radians) rounds the angle in radians first: a few ulp of 1 apart at most
    assert np.abs(sine - np.sin(a * DEGREE)).max() < 1e-15
    assert np.abs(cosine - np.cos(a * DEGREE)).max() < 1e-15
    assert np.all(np.abs(sine) <= 1.0) and np.all(np.abs(cosine) <= 1.0)


def test_whole_quadrants_are_exact() -> None:
    for angle, (s, c) in {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0)}.items():
        assert sincos_degrees(angle) == (s, c)
    assert sincos_degrees(270.0) == (-1.0, 0.0)
    assert sincos_degrees(5e-324) == (5e-324 * DEGREE, 1.0)


def test_one_agent_few_and_many_give_the_same_bits(monkeypatch: pytest.MonkeyPatch) -> None:
    a = angles()[:30_000]
    sine, cosine = sincos_degrees(a)
    pairs = [sincos_degrees(v) for v in a[::7].tolist()]
    assert np.array_equal(bits([p[0] for p in pairs]), bits(sine[::7]))
    assert np.array_equal(bits([p[1] for p in pairs]), bits(cosine[::7]))
    few_s, few_c = sincos_degrees(a[: arrays.SMALL])  # the scalar path, element by element
    assert np.array_equal(bits(few_s), bits(sine[: arrays.SMALL]))
    assert np.array_equal(bits(few_c), bits(cosine[: arrays.SMALL]))
    monkeypatch.setattr(arrays, "CHUNK", 1000)  # in pieces
    piece_s, piece_c = sincos_degrees(a)
    assert np.array_equal(bits(piece_s), bits(sine)) and np.array_equal(bits(piece_c), bits(cosine))


@needs_numba
def test_the_compiled_kernel_gives_the_bits_of_the_numpy_path() -> None:
    from numba import njit

    from pyautonomousagent.kernels import sincos_degrees as kernel

    @njit
    def both(angle: np.ndarray, sine: np.ndarray, cosine: np.ndarray) -> None:
        for i in range(angle.shape[0]):
            sine[i], cosine[i] = kernel(angle[i])

    a = angles()
    sine, cosine = np.empty_like(a), np.empty_like(a)
    both(a, sine, cosine)
    expected_sine, expected_cosine = sincos_degrees(a)
    assert np.array_equal(bits(sine), bits(expected_sine))
    assert np.array_equal(bits(cosine), bits(expected_cosine))
