"""Reproducible randomness for leaves and sensors, identical whichever engine runs.

The py_trees engine ticks agents one by one and the batched engine ticks groups of them, so a
sequential generator would hand out its numbers in a different order on each engine. A
counter-based generator does not depend on order: the number an agent draws is a pure
function of (seed, stream, agent row, iteration, draw), computed with the SplitMix64 mixing
function on 64-bit unsigned integers. One agent and a thousand agents go through the same
NumPy integer operations, so both engines get the same bits on every CPU.

:func:`bits_of_one` and :func:`uniform_of_one` are the same operations on one agent for
compiled kernels (numba, and numba-cuda on a device: plain uint64 arithmetic, which wraps
modulo 2**64 there as in NumPy).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.jit import njit

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_TO_UNIT = 2.0**-53
_S11, _S27, _S30, _S31, _S32 = (np.uint64(k) for k in (11, 27, 30, 31, 32))
_ONE = np.uint64(1)


def _mix(z: Any) -> Any:
    """SplitMix64's finaliser: a bijection of uint64 (one, or an array) that spreads every
    input bit. Every constant is a uint64: numba would make a mixed uint64/int64 operation
    a float64 one."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


#: :func:`_mix` of one uint64, for compiled kernels.
_mix_one = njit(inline="always")(_mix)


def stream_key(name: str) -> int:
    """A stable 32-bit key for a named stream (e.g. a leaf's node name), the same in every
    process (unlike ``hash``)."""
    return zlib.crc32(name.encode("utf-8"))


@dataclass(frozen=True)
class CounterRandom:
    """Uniform numbers keyed by (seed, stream, agent, iteration, draw).

    Attributes:
        seed: the run's seed (a whole number >= 0).
    """

    seed: int

    def bits(self, stream: int, rows: Any, iteration: int, draw: int = 0) -> np.ndarray:
        """64 random bits per agent row, shape of ``rows`` (at least 1-D).

        Args:
            stream: a stream key (see :func:`stream_key`), whole number >= 0.
            rows: agent rows, an int or an int array.
            iteration: the current iteration.
            draw: which draw of this agent at this iteration (0, 1, ...).
        """
        with np.errstate(over="ignore"):
            z: Any = np.uint64(self.seed & 0xFFFFFFFFFFFFFFFF)
            for part in (stream, iteration, draw):
                z = _mix(z + _GAMMA * np.uint64(int(part) & 0xFFFFFFFFFFFFFFFF))
            agents = np.atleast_1d(np.asarray(rows)).astype(np.uint64)
            return _mix(z + _GAMMA * (agents + np.uint64(1)))

    def uniform(
        self,
        stream: int,
        rows: Any,
        iteration: int,
        low: float = 0.0,
        high: float = 1.0,
        draw: int = 0,
    ) -> Any:
        """Uniform numbers in [low, high): a float for an int ``rows``, else an array."""
        unit = (self.bits(stream, rows, iteration, draw) >> np.uint64(11)) * _TO_UNIT
        values = low + (high - low) * unit
        return float(values[0]) if np.ndim(rows) == 0 else values


@njit(inline="always")
def bits_of_one(
    seed_high: int, seed_low: int, stream: int, row: int, iteration: int, draw: int
) -> np.uint64:
    """:meth:`CounterRandom.bits` of one agent row, operation for operation: 64 random bits.

    The seed comes as its two 32-bit halves (``seed >> 32`` and ``seed & 0xFFFFFFFF``, see
    :func:`seed_halves`): a compiled kernel's integer constants are int64, too small for a
    64-bit seed. All arguments are whole numbers >= 0.
    """
    z = (np.uint64(seed_high) << _S32) | np.uint64(seed_low)
    z = _mix_one(z + _GAMMA * np.uint64(stream))
    z = _mix_one(z + _GAMMA * np.uint64(iteration))
    z = _mix_one(z + _GAMMA * np.uint64(draw))
    return _mix_one(z + _GAMMA * (np.uint64(row) + _ONE))


@njit(inline="always")
def uniform_of_one(
    seed_high: int, seed_low: int, stream: int, row: int, iteration: int,
    low: float, high: float, draw: int,
) -> float:  # fmt: skip
    """:meth:`CounterRandom.uniform` of one agent row (see :func:`bits_of_one`): a number in
    [low, high), the same bits."""
    unit = (bits_of_one(seed_high, seed_low, stream, row, iteration, draw) >> _S11) * _TO_UNIT
    return low + (high - low) * unit


def seed_halves(seed: int) -> tuple[int, int]:
    """A run's seed as it is keyed (its low 64 bits), in two 32-bit halves, high first: the
    form :func:`bits_of_one` takes."""
    key = seed & 0xFFFFFFFFFFFFFFFF
    return key >> 32, key & 0xFFFFFFFF
