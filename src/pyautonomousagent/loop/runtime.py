"""Helpers the fused loop's generated code calls, on the CPU and the GPU (numba-compiled; see
engines/compiled_source.py and engines/gpu_source.py)."""

from __future__ import annotations

import numpy as np

from pyautonomousagent.bt.status import INVALID, RUNNING
from pyautonomousagent.jit import njit


@njit(inline="always")
def halt(a: int, status: np.ndarray, node: int, end: int) -> None:
    """The batched engine's ``_halt`` for agent ``a``: a node that is not INVALID becomes
    INVALID with its whole subtree ``[node, end)`` (status shape (nodes, N), int8)."""
    if status[node, a] != INVALID:
        for j in range(node, end):
            status[j, a] = INVALID


@njit(inline="always")
def record_statuses(
    a: int,
    row: int,
    status: np.ndarray,
    traces: np.ndarray,
    traced_at: np.ndarray,
    behaviour: np.ndarray,
    leaf_rows: np.ndarray,
) -> None:
    """Phase 6's node statuses of agent ``a`` into record ``row``: its trace (where
    ``traced_at[a] >= 0``, the agent's position among the traced, shape (N,)) and its active
    leaf (:func:`pyautonomousagent.recording.active_leaf`: the first RUNNING leaf in tick
    order, else the last ticked one, else -1).

    Args:
        status: node statuses, shape (nodes, N), int8.
        traces: shape (records, nodes, traced), int8.
        behaviour: shape (records, N), int16.
        leaf_rows: the leaves' node indices, ascending, shape (L,).
    """
    k = traced_at[a]
    if k >= 0:
        for j in range(status.shape[0]):
            traces[row, j, k] = status[j, a]
    found = -1
    for p in range(leaf_rows.shape[0]):
        code = status[leaf_rows[p], a]
        if code == RUNNING:
            found = leaf_rows[p]
            break
        if code != INVALID:
            found = leaf_rows[p]
    behaviour[row, a] = found
