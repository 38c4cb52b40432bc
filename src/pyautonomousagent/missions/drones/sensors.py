"""Sensors of Phase 2: energy, radiation and damage, over the whole swarm.

Levels are percentages in [0, 100]. Functions take and return arrays of shape ``(N,)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyautonomousagent.arrays import hypot


@dataclass(frozen=True)
class RadiationSource:
    """A radiation source at (x, y) that irradiates within ``range`` world units.

    Its level at distance d is ``100 * (1 - d / range)`` percent inside the range, 0 outside.
    """

    x: float
    y: float
    range: float
    active: bool = False


def radiation_level(
    x: np.ndarray, y: np.ndarray, sources: tuple[RadiationSource, ...]
) -> np.ndarray:
    """Radiation read at (x, y): the levels of all active sources added, clipped to 100 %.

    Args:
        x, y: positions, shape (N,).
        sources: the world's radiation sources.

    Returns:
        Level in percent, shape (N,).
    """
    level = np.zeros(np.shape(x))
    for source in sources:
        if source.active:
            distance = hypot(x - source.x, y - source.y)
            level += np.where(distance < source.range, 100.0 * (1.0 - distance / source.range), 0.0)
    return np.minimum(level, 100.0)


def drain_energy(energy: np.ndarray, use_per_iteration: float) -> np.ndarray:
    """Energy after one iteration's use, percent, never below 0."""
    return np.maximum(energy - use_per_iteration, 0.0)


def accumulate_damage(damage: np.ndarray, radiation: np.ndarray, factor: float) -> np.ndarray:
    """Damage after one iteration of exposure: ``factor`` % per iteration at 100 % radiation."""
    return np.minimum(damage + factor * radiation / 100.0, 100.0)
