"""A kernel whose function takes other arguments than it is declared to be passed is refused
where it is declared (kernels.check_arity), naming the function and what it is passed, before
any code is generated or compiled."""

from __future__ import annotations

import pytest

from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import (
    HandlerKernel,
    Later,
    LeafKernel,
    Receive,
    Sends,
    SensorKernel,
    SwarmSensorKernel,
)


@njit
def _leaf(a, energy, outbox, threshold):
    return 1


def _detect(t, x):
    return 0


def _apply(a, moving, x):
    pass


def test_a_leaf_kernel_passed_what_its_function_takes_is_accepted() -> None:
    kernel = LeafKernel(_leaf, ("energy",), (40.0,), sends=Sends("ping", ()))
    assert kernel.names == ("energy",)


def test_a_leaf_kernel_missing_its_outbox_names_the_function_and_what_it_is_passed() -> None:
    with pytest.raises(TypeError) as error:
        LeafKernel(_leaf, ("energy",), (40.0,))
    assert str(error.value) == (
        "LeafKernel _leaf(a, energy, outbox, threshold) takes 4 arguments, but is passed 3: "
        "a, 1 arrays, 1 constants"
    )


@pytest.mark.parametrize(
    "make",
    [
        lambda: SensorKernel(_leaf, ("energy", "x")),
        lambda: Later(lambda v: v, ("x", "y"), "heading"),
        lambda: HandlerKernel(_detect, ("x",)),
        lambda: HandlerKernel(
            lambda t, s, d, c, x: None,
            ("x",),
            names=("x",),
            receive=Receive(lambda r, m, t, s, d: None),
        ),  # fmt: skip
        lambda: SwarmSensorKernel(_detect, _apply, ("x", "y")),
        lambda: SwarmSensorKernel(_detect, _apply, ("x",), device=(_detect,)),
    ],
    ids=["sensor", "later", "handler", "receive", "swarm detect", "swarm device step"],
)
def test_each_kind_of_kernel_checks_its_functions(make) -> None:
    with pytest.raises(TypeError, match=r"takes \d+ arguments, but is passed \d+"):
        make()


def test_a_function_with_star_args_is_not_checked() -> None:
    assert LeafKernel(lambda a, *arrays: 1, ("x", "y", "z")).names == ("x", "y", "z")


def test_every_built_in_missions_kernels_pass_the_check() -> None:
    """Declared at import (leaves) and per run (sensors, handlers): a small run of each."""
    from pyautonomousagent import Simulation, load

    for name in ("gathering", "patrol", "patrol-3d", "radiation-search", "vacuum", "crowded"):
        scenario = load(name).with_overrides(agents=4, iterations=3)
        Simulation.create(scenario, engine="compiled").run(progress=False)
