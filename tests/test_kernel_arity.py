"""A kernel whose function takes other arguments than it is declared to be passed is refused
where it is declared, before any code is generated or compiled: the count of its arguments
(kernels.check_arity), and its columns matched to its array parameters by name
(kernels.bind_columns), each error naming the function and what does not match."""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent.jit import njit
from pyautonomousagent.kernels import (
    ITERATION,
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


@njit
def _between(a, x, y, low, high):
    return 1


def _detect_xy(t, x, y):
    return 0


def _apply_yx(a, moving, y, x):
    pass


def test_a_column_named_otherwise_than_its_parameter_is_refused_naming_both() -> None:
    with pytest.raises(TypeError) as error:
        LeafKernel(_leaf, ("fuel",), (40.0,), sends=Sends("ping", ()))
    assert str(error.value) == (
        "LeafKernel _leaf(a, energy, outbox, threshold) would be passed column 'fuel' as "
        "parameter 'energy': name the parameter as the column, or give the columns by name "
        "({'energy': 'fuel', ...})"
    )


def test_swapped_columns_of_the_right_count_are_refused() -> None:
    """The count check alone passed this: two arrays swapped, each read as the other."""
    with pytest.raises(TypeError, match=r"column 'y' as parameter 'x'"):
        LeafKernel(_between, ("y", "x"), (0.0, 1.0))
    with pytest.raises(TypeError, match=r"column 'y' as parameter 'x'"):
        Later(lambda x, y: x, ("y", "x"), "heading")


@pytest.mark.parametrize(
    "columns, constants, named",
    [
        ({"y": "y"}, (0.0, 1.0, 2.0), "but not for its array parameter(s) 'x' (its arrays: x)"),
        ({"x": "x", "z": "y"}, (0.0, 1.0), "for 'z', but not for its array parameter(s) 'y'"),
    ],
    ids=["missing", "not a parameter"],
)
def test_a_mapping_missing_a_parameter_or_naming_another_is_refused(
    columns, constants, named
) -> None:
    with pytest.raises(TypeError) as error:
        SensorKernel(_between, columns, constants)
    assert named in str(error.value)
    assert str(error.value).startswith("SensorKernel _between(a, x, y, low, high) is given")


def test_a_mapping_is_resolved_to_the_parameter_order() -> None:
    kernel = LeafKernel(_between, {"y": "altitude", "x": "range"}, (0.0, 1.0))
    assert kernel.names == ("range", "altitude")
    later = Later(lambda t, x: x, {"x": "energy", "t": ITERATION}, "heading")
    assert later.names == (ITERATION, "energy")


def test_the_iteration_is_passed_by_a_mapping() -> None:
    def wander(a, t, x, seed):
        return 1

    assert LeafKernel(wander, {"t": ITERATION, "x": "x"}, (7,)).names == (ITERATION, "x")
    with pytest.raises(TypeError, match="column '@iteration' as parameter 't'"):
        LeafKernel(wander, (ITERATION, "x"), (7,))


@pytest.mark.parametrize(
    "columns", [("x", "y"), {"x": "x", "y": "y"}], ids=["tuple", "mapping"]
)  # fmt: skip
def test_swarm_sensor_functions_taking_their_arrays_in_other_orders_are_refused(columns) -> None:
    with pytest.raises(TypeError, match="SwarmSensorKernel apply _apply_yx"):
        SwarmSensorKernel(_detect_xy, _apply_yx, columns)
    steps = SwarmSensorKernel(_detect_xy, lambda a, moving, x, y: None, columns)
    assert steps.names == ("x", "y")


def test_a_handler_and_its_receive_form_must_name_their_arrays_alike() -> None:
    def everyone(t, senders, data, count, px, py):
        pass

    def one(r, m, t, senders, data, to_x, to_y):
        pass

    columns = {"px": "x_surveillance_position", "py": "y_surveillance_position"}
    handler = HandlerKernel(everyone, ("x", "y"), columns)
    assert handler.names == ("x_surveillance_position", "y_surveillance_position")
    with pytest.raises(TypeError, match=r"Receive .*one\(r, m, t, senders, data, to_x, to_y\)"):
        HandlerKernel(everyone, ("x", "y"), columns, receive=Receive(one))


def test_a_function_with_star_args_takes_no_mapping() -> None:
    with pytest.raises(TypeError, match="cannot take columns by name"):
        LeafKernel(lambda a, *arrays: 1, {"x": "x"})


def test_a_receive_form_without_state_is_passed_none_of_the_handlers_state() -> None:
    """The GPU engine passes a per-receiver form only its own state (``Receive.state``), so a
    handler with run state and a state-less receive form takes the arrays and constants."""

    def everyone(t, senders, data, count, x, seen):
        pass

    def one(r, m, t, senders, data, x):
        pass

    def one_with_state(r, m, t, senders, data, x, seen):
        pass

    state = (np.zeros(4),)
    handler = HandlerKernel(everyone, ("v",), ("x",), state=state, receive=Receive(one))
    assert handler.names == ("x",)
    with pytest.raises(TypeError, match=r"Receive .*one_with_state.* takes 7 arguments"):
        HandlerKernel(everyone, ("v",), ("x",), state=state, receive=Receive(one_with_state))
