"""Pieces of generated source that the compiled engine's fused functions and the GPU
engine's kernels both write: the kernels' imports and calls (handlers' too), the deferred
``Later`` steps, the swarm sensor's arguments, the fused functions' parameters, and the
record of the per-agent stages (sensors and motion, the tree, control) that the host engine
writes (:class:`Stages`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pyautonomousagent.bt.program import Program
from pyautonomousagent.kernels import Later, LeafKernel, SensorKernel, SwarmSensorKernel
from pyautonomousagent.loop.layout import Layout, Messaging
from pyautonomousagent.models import drone2d, drone3d


@dataclass(frozen=True)
class Stages:
    """The per-agent source of a fused loop's stages for agent ``a`` at iteration ``t``,
    written by the engine whose tree it is (the compiled engine's generator) and used as it
    is by the GPU kernels.

    Attributes:
        motion: Phase 2, ``motion(layout, sensors, indent)``: the sensors, then the motion.
        tree: Phase 3, ``tree(program, kernels, layout, indent)``: the tick, straight-line.
        control: Phase 4, ``control(layout, indent)``: the control signals.
    """

    motion: Callable[[Layout, SensorKernel, str], str]
    tree: Callable[[Program, Mapping[int, LeafKernel], Layout, str], str]
    control: Callable[[Layout, str], str]


def motion_functions(layout: Layout) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """The motion model's per-agent functions (njit, in :mod:`~pyautonomousagent.models`),
    each group called in order: Phase 2's step, Phase 4's control: the 2-D drone's, then,
    where :attr:`Layout.vertical` is set, the 3-D drone's altitude's."""
    if layout.vertical is None:
        return (drone2d.step_agent,), (drone2d.control_agent,)
    return ((drone2d.step_agent, drone3d.climb_agent),
            (drone2d.control_agent, drone3d.climb_control_agent))  # fmt: skip


def alias(function: Any) -> str:
    """The name a kernel function is imported under: its module and name, made one word."""
    py = getattr(function, "py_func", function)
    return "K_" + f"{py.__module__}.{py.__qualname__}".replace(".", "_")


def kernel_imports(kernels: Mapping[int, LeafKernel], layout: Layout) -> dict[str, Any]:
    """Name -> function of the leaves' kernels (and their ``Later`` steps') and the motion
    model's (:func:`motion_functions`), each under its :func:`alias`."""
    used: dict[str, Any] = {alias(f): f for group in motion_functions(layout) for f in group}
    used |= {alias(k.function): k.function for k in kernels.values()}
    return used | {alias(k.later.function): k.later.function for k in kernels.values() if k.later}


def import_lines(used: Mapping[str, Any]) -> list[str]:
    """``from module import function as name`` for each of ``used``, by name."""
    lines = []
    for name, function in sorted(used.items()):
        py = getattr(function, "py_func", function)
        lines.append(f"from {py.__module__} import {py.__qualname__} as {name}")
    return lines


def call(
    function: str, first: Iterable[str], layout: Layout, names: Iterable[str],
    state: Iterable[str], site: str, constants: Sequence[Any],
) -> str:  # fmt: skip
    """The call of a kernel ``function``: ``first``, the arrays of ``names``, ``state``, then
    the constants of call site ``site`` (:meth:`Constants.refs`)."""
    args = [*first, *(layout.array(name) for name in names), *state]
    return f"{function}({', '.join(args + layout.constants.refs(site, constants))})"


def handler_call(messaging: Messaging, layout: Layout, k: int, senders: str, data: str,
                 count: str) -> str:  # fmt: skip
    """The call of message type ``k``'s handler ``H<k>`` on the messages ``senders``, ``data``
    (source expressions: an inbox or a slice of it), ``count`` of them."""
    handler = messaging.handlers[k]
    state = [f"hs{k}_{j}" for j in range(len(handler.state))]
    return call(f"H{k}", ["t", senders, data, count], layout, handler.names, state,
                f"handler {k}", handler.constants)  # fmt: skip


def _later(later: Later, layout: Layout) -> str:
    """The statement of a ``Later`` step for agent ``a``."""
    values = ", ".join(f"{layout.array(name)}[a]" for name in later.names)
    return f"{layout.array(later.target)}[a] = {alias(later.function)}({values})"


def _later_pass(
    kernels: Mapping[int, LeafKernel], layout: Layout, agents: str, then: str, indent: str
) -> str:
    """A loop over ``agents`` doing the deferred ``Later`` steps the tree marked in ``pend``,
    then ``then`` (code for agent ``a``, indented by 4, e.g. Phase 4), indented by
    ``indent``."""
    lines = [f"for a in {agents}:", "    p = pend[a]", "    if p >= 0:"]
    for i in layout.deferred:
        later = kernels[i].later
        assert later is not None
        lines += [f"        if p == {i}:", f"            {_later(later, layout)}"]
    lines.append("        pend[a] = -1")
    if then:  # a loop of its own: the steps above run many agents at a time
        lines.append(f"for a in {agents}:")
    body = "\n".join(indent + line for line in lines)
    return body + ("\n" + then if then else "")


def _swarm_args(swarm: SwarmSensorKernel, layout: Layout) -> list[str]:
    """The arguments of a swarm sensor's functions after the first ones: its arrays, its state
    ``ws0, ws1, ...`` (arguments of the fused function) and its constants."""
    args = [layout.array(name) for name in swarm.names]
    args += swarm_state_names(swarm)
    return args + layout.constants.refs("swarm", swarm.constants)


def swarm_state_names(swarm: SwarmSensorKernel | None) -> list[str]:
    """The swarm sensor's state parameters ``ws0, ws1, ...`` ([] without one)."""
    return [f"ws{j}" for j in range(len(swarm.state))] if swarm is not None else []


def fused_parameters(layout: Layout, sensors: SensorKernel) -> list[list[str]]:
    """The parameters of the fused functions (and the GPU kernels) from the node statuses
    on, by stage (a line each in the source): the tree's state (node statuses, remembered
    children, deferred steps, constants, arrays, outboxes) and the control signals, the
    records, then the motion's parameters and the sensors' state ``ss0, ss1, ...``
    (``SensorKernel.state``)."""
    state = ["st", "cur", "pend", "kf", "ki", *layout.array_names, "us", "uh", "uc"]
    parameters = ["max_speed", "speed_step", "turn_step"]
    sensed = [f"ss{j}" for j in range(len(sensors.state))]
    return [state, record_parameters(layout), parameters + sensed]


def record_parameters(layout: Layout) -> list[str]:
    """The record arrays' parameters: a column's ``r0, r1, ...``, the traced agents' node
    statuses ``traces``, their rows ``traced_at``, the active behaviour, the leaves' rows
    in the traces, and the iteration each agent stopped at."""
    return [*layout.record_names, "traces", "traced_at", "behaviour", "leaf_rows", "stopped_at"]


def fused_arguments(layout: Layout, sensors: SensorKernel) -> str:
    """:func:`fused_parameters` as the source of a parameter list."""
    return ",\n           ".join(", ".join(line) for line in fused_parameters(layout, sensors))
