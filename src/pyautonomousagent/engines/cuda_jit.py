"""``numba.cuda.jit`` as the GPU engine compiles every kernel and device function.

No fast math, and no link-time optimisation (LTO). numba-cuda links with LTO by default where
nvJitLink is installed: NVVM then emits LTO-IR, and nvJitLink generates the machine code with
its own options, FMA contraction on, whatever ``-fma=0`` NVVM was given
(:func:`~pyautonomousagent.engines.gpu.no_fma`). On the lent H100 (numba-cuda 0.30.4,
2026-11-26) kernels compiled with LTO gave positions one unit in the last place away from
the NumPy engine's after 10 iterations, though their PTX, compiled apart, held no ``fma.``.
Without LTO, NVVM emits ``mul.rn``/``add.rn``, which ptxas may not contract.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def kernel(function: Callable[..., Any] | None = None, *, device: bool = False) -> Any:
    """``function`` compiled by ``numba.cuda.jit(fastmath=False, lto=False)`` (a device
    function with ``device=True``); used bare (``@kernel``) or called
    (``@kernel(device=True)``). Under numba's CUDA simulator, which links nothing and takes
    no ``lto``, without it."""
    from numba import config, cuda

    options: dict[str, Any] = {"device": device, "fastmath": False}
    if not getattr(config, "ENABLE_CUDASIM", False):
        options["lto"] = False
    if function is None:
        return cuda.jit(**options)
    return cuda.jit(**options)(function)
