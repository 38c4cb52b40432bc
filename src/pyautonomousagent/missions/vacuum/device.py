"""The vacuum robot's cleaning grid on the GPU: ``kernels.clean_grid`` as two device steps.

``SwarmSensorKernel.device`` of :meth:`VacuumMission.compiled_sensors
<pyautonomousagent.missions.vacuum.VacuumMission.compiled_sensors>`: the GPU engine launches
:func:`claim_cell` for every robot, then :func:`take_cell`, before each iteration's per-robot
phases. Together they clean what ``clean_grid`` cleans in robot order, whatever order the
threads run in: of the brushing robots on a free cell not cleaned yet, the lowest row wins
(an atomic minimum), as ``CleaningGrid.clean`` credits it. Called from CUDA kernels only
(``numba.cuda.atomic``); the cell of a robot is ``kernels.cell_of``, the CPU's arithmetic.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import cuda as numba_cuda

from pyautonomousagent.jit import njit
from pyautonomousagent.missions.vacuum.kernels import NOBODY, cell_of

cuda: Any = numba_cuda  # numba's stubs type cuda.atomic poorly


@njit(inline="always")
def claim_cell(a: int, t: int, x: np.ndarray, y: np.ndarray, vacuuming: np.ndarray,
               cleaned_cells: np.ndarray, free: np.ndarray, cleaned: np.ndarray,
               fresh: np.ndarray, winner: np.ndarray, cell: float) -> None:  # fmt: skip
    """``kernels.clean_grid`` on the GPU, step 1 of 2 (``SwarmSensorKernel.device``): a brushing
    robot on a free cell not cleaned yet claims it, an atomic minimum of its row into
    ``winner`` (every entry ``kernels.NOBODY`` before), so the lowest row wins."""
    fresh[a] = 0
    if vacuuming[a] == 1:
        rows, cols = cleaned.shape
        row, col = cell_of(x[a], y[a], cell, rows, cols)
        if free[row, col] and not cleaned[row, col]:
            cuda.atomic.min(winner, row * cols + col, np.int64(a))


@njit(inline="always")
def take_cell(a: int, t: int, x: np.ndarray, y: np.ndarray, vacuuming: np.ndarray,
              cleaned_cells: np.ndarray, free: np.ndarray, cleaned: np.ndarray,
              fresh: np.ndarray, winner: np.ndarray, cell: float) -> None:  # fmt: skip
    """``kernels.clean_grid`` on the GPU, step 2 of 2: the winner of its cell cleans it, counts
    it as fresh and sets the cell's ``winner`` back to ``kernels.NOBODY`` (a robot that lost
    reads the winner's row or NOBODY, neither its own)."""
    if vacuuming[a] == 1:
        rows, cols = cleaned.shape
        row, col = cell_of(x[a], y[a], cell, rows, cols)
        k = row * cols + col
        if winner[k] == a:
            winner[k] = NOBODY
            cleaned[row, col] = True
            fresh[a] = 1
