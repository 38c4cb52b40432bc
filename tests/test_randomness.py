"""The counter-based generator's one-agent twin (``randomness.bits_of_one``,
``uniform_of_one``, what compiled and GPU kernels call) against its NumPy path, bit for bit."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyautonomousagent import jit, randomness
from pyautonomousagent.randomness import CounterRandom, bits_of_one, seed_halves, uniform_of_one

WORD = 2**64 - 1
#: Keys where uint64 arithmetic wraps: zero, small, around 2**32, 2**53, 2**63 and 2**64.
EDGES = [0, 1, 2, 2**31, 2**32 - 1, 2**32, 2**53 + 1, 2**62, 2**63 - 1, 2**63, WORD]


def assert_twin_gives_numpy_bits(seed: int, stream: int, row: int, iteration: int,
                                 draw: int, low: float, high: float) -> None:  # fmt: skip
    reference = CounterRandom(seed)
    expected = reference.bits(stream, row, iteration, draw)[0]
    with np.errstate(over="ignore"):  # without numba the twin wraps NumPy scalars, warning
        got = bits_of_one(*seed_halves(seed), stream, row, iteration, draw)
        twin = uniform_of_one(*seed_halves(seed), stream, row, iteration, low, high, draw)
    assert int(got) == int(expected), (seed, stream, row, iteration, draw)
    value = reference.uniform(stream, row, iteration, low, high, draw)
    assert np.float64(twin).view(np.uint64) == np.float64(value).view(np.uint64)


def test_the_twin_gives_the_numpy_bits_on_a_grid_of_wrapping_keys() -> None:
    streams = [0, 1, 2**31 + 7, 2**32 - 1]  # stream keys are 32-bit (crc32)
    rows = [0, 1, 255, 256, 10**8, 2**40, 2**62]
    iterations = [0, 1, 39, 40, 10**6, 2**62]
    for seed, stream, row, iteration in itertools.product(EDGES, streams, rows, iterations):
        assert_twin_gives_numpy_bits(seed, stream, row, iteration, 0, 0.0, 360.0)
    for seed, draw in itertools.product(EDGES, [0, 1, 2**20]):
        assert_twin_gives_numpy_bits(seed, 5, 3, 7, draw, -1.5, 2.25)


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 2**70),  # the NumPy path keys the low 64 bits
    stream=st.integers(0, 2**32 - 1),
    row=st.integers(0, 2**62),
    iteration=st.integers(0, 2**62),
    draw=st.integers(0, 2**16),
    low=st.floats(-1e6, 1e6),
    width=st.floats(0.0, 1e6),
)
def test_the_twin_gives_the_numpy_bits_on_any_key(
    seed: int, stream: int, row: int, iteration: int, draw: int, low: float, width: float
) -> None:
    assert_twin_gives_numpy_bits(seed, stream, row, iteration, draw, low, low + width)


@pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")
def test_the_twin_as_python_gives_the_same_bits(monkeypatch: pytest.MonkeyPatch) -> None:
    """The functions as Python on NumPy scalars (what numba's CUDA simulator runs): uint64
    scalars wrap as the arrays do."""
    for name in ("_mix_one", "bits_of_one"):
        monkeypatch.setattr(randomness, name, getattr(randomness, name).py_func)
    python = uniform_of_one.py_func
    with np.errstate(over="ignore"):
        for seed, row in itertools.product(EDGES, [0, 3, 2**62]):
            key = (*seed_halves(seed), 77, row, 40)
            value = CounterRandom(seed).uniform(77, row, 40, 0.0, 360.0)
            assert python(*key, 0.0, 360.0, 0) == value


def test_seed_halves_keep_the_low_64_bits() -> None:
    assert seed_halves(0) == (0, 0)
    assert seed_halves(2**64 + 2**32 + 5) == (1, 5)
    assert seed_halves(WORD) == (2**32 - 1, 2**32 - 1)
