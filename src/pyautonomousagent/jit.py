"""Optional compilation with numba (the ``[fast]`` extra).

``njit`` compiles a function with numba where numba is installed and compilation is not
switched off; elsewhere it returns the function unchanged, so the plain NumPy / Python code
stays the reference and runs on machines without a compiler. Compiled code never uses
``fastmath``: it must give the same bits as the reference.

Set the environment variable ``PYAA_NO_JIT=1`` to run without numba even where it is
installed (the tests do, to check the fallback).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])


def available() -> bool:
    """True when numba is installed and ``PYAA_NO_JIT`` does not switch it off."""
    if os.environ.get("PYAA_NO_JIT", "") not in ("", "0"):
        return False
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def njit(function: F | None = None, **options: Any) -> Any:
    """``numba.njit(cache=True, error_model="numpy", **options)`` where available, else the
    function itself (NumPy's error model: a division by zero gives inf or nan, as NumPy does,
    and costs no test).

    Usable bare (``@njit``) or with options (``@njit(parallel=True)``).
    """

    def wrap(f: F) -> F:
        if not available():
            return f
        import numba

        options.setdefault("cache", True)
        options.setdefault("error_model", "numpy")  # x / 0 is inf or nan, as in NumPy
        return numba.njit(**options)(f)

    return wrap(function) if function is not None else wrap
