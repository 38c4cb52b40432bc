"""Keep freed memory in the process, so that large temporary arrays do not fault pages anew.

Each NumPy operation on (N,) arrays allocates its result. Above glibc's mmap threshold
(128 KiB at start, i.e. 16,384 float64) every such array is mapped from the kernel and
unmapped when freed, and on virtual machines each first touch of a page is costly: at
100,000 agents this was about a third of the batched engine's time. Raising the mmap and
trim thresholds lets glibc reuse freed blocks instead. The peak memory does not grow: the
blocks reused are those that were freed.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_LARGEST_MMAP_THRESHOLD = 32 * 1024 * 1024  # glibc's upper bound on 64-bit systems


@functools.cache
def reuse_freed_memory() -> bool:
    """Tell glibc's allocator to reuse freed blocks of up to 32 MiB; False where there is
    no glibc (the call is then a no-op). Done once per process."""
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        mallopt = ctypes.CDLL(name).mallopt
    except (OSError, AttributeError):
        return False
    ok = mallopt(_M_MMAP_THRESHOLD, _LARGEST_MMAP_THRESHOLD)
    ok &= mallopt(_M_TRIM_THRESHOLD, 4 * _LARGEST_MMAP_THRESHOLD)
    return bool(ok)
