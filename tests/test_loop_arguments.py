"""The fused functions' arguments, matched to the generated parameters by name
(:mod:`pyautonomousagent.loop.arguments`): a missing or extra one is named."""

from __future__ import annotations

from typing import Any

import pytest

from pyautonomousagent import Simulation, jit, load
from pyautonomousagent.engines.compiled import CompiledEngine
from pyautonomousagent.loop.arguments import ArgumentsError, ordered, parameters

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


def _generated(t0: int, count: int, st: Any, kf: Any, max_speed: float) -> None:
    """Stands for a generated fused function."""


def test_arguments_go_in_the_order_of_the_generated_parameters() -> None:
    names = parameters(_generated, 2)
    assert names == ("st", "kf", "max_speed")
    assert ordered(names, {"max_speed": 3.0, "st": "S", "kf": "K"}, "f") == ["S", "K", 3.0]


def test_a_missing_or_an_extra_argument_is_named() -> None:
    names = parameters(_generated, 2)
    with pytest.raises(ArgumentsError, match="f: no argument for parameter 'kf'$"):
        ordered(names, {"max_speed": 3.0, "st": "S"}, "f")
    with pytest.raises(ArgumentsError, match="argument 'ss0' is no parameter"):
        ordered(names, {"max_speed": 3.0, "st": "S", "kf": "K", "ss0": 1}, "f")
    with pytest.raises(ArgumentsError, match="'kf'; argument 'uc' is no parameter"):
        ordered(names, {"max_speed": 3.0, "st": "S", "uc": 1}, "f")


@needs_numba
@pytest.mark.parametrize("dropped", ["turn_step", "r0", "uc", "st"])
def test_the_compiled_engine_names_an_argument_it_does_not_build(
    dropped: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The fused call of patrol with one stage's argument left out of the mapping fails
    naming it (before anything runs)."""
    built = CompiledEngine._arguments

    def without(self: CompiledEngine, *args: Any) -> dict[str, Any]:
        arguments = built(self, *args)
        assert dropped in arguments  # (a name the engine does build)
        return {k: v for k, v in arguments.items() if k != dropped}

    monkeypatch.setattr(CompiledEngine, "_arguments", without)
    with pytest.raises(ArgumentsError, match=f"no argument for parameter '{dropped}'"):
        Simulation.create(load("patrol").with_overrides(agents=3, iterations=5), seed=0,
                          engine="compiled")  # fmt: skip
