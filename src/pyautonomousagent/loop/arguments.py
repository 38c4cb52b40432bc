"""The fused functions' arguments matched to their parameters by name.

The engines build a fused function's arguments as a mapping, parameter name -> value, stage
by stage; :func:`ordered` puts them in the order of the generated function's parameters,
read from the function itself (:func:`parameters`), so that the generated signature is the
only place that order is written.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any


class ArgumentsError(ValueError):
    """A generated function's parameters and the arguments built for it do not match."""


def parameters(function: Any, leading: int = 0) -> tuple[str, ...]:
    """The parameter names of generated ``function`` after its first ``leading`` ones: of a
    numba dispatcher (its ``py_func``), a CUDA kernel (``py_func``; ``fn`` under the
    simulator) or a plain function."""
    py = getattr(function, "py_func", None) or getattr(function, "fn", None) or function
    code = py.__code__
    return tuple(code.co_varnames[leading : code.co_argcount])


def ordered(names: Sequence[str], values: Mapping[str, Any], where: str) -> list[Any]:
    """``values`` in the order of ``names`` (the parameters of the function ``where``).

    Raises:
        ArgumentsError: a name has no value, or a value no name (each named).
    """
    if len(values) == len(names):
        try:
            return [values[name] for name in names]
        except KeyError:
            pass  # named below
    missing = [name for name in names if name not in values]
    extra = sorted(set(values) - set(names))
    problems = [f"no argument for parameter {name!r}" for name in missing]
    problems += [f"argument {name!r} is no parameter" for name in extra]
    raise ArgumentsError(f"{where}: {'; '.join(problems)}")
