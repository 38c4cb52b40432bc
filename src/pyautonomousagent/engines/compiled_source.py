"""The compiled engine's code generator: a tree (and the run's sensors and motion) as Python
source for numba.

Every node of the flattened tree (:class:`~pyautonomousagent.bt.program.Program`)
becomes a block of straight-line code that ticks it for agent row ``a`` at iteration ``t``
(:func:`tree_body`, written by :mod:`pyautonomousagent.bt.tree_source` from the node types'
rules): ``st`` holds the node statuses (nodes, N) int8 and ``cur`` what each node with
``memory`` remembers (one row per such node, (M, N) int32), exactly as the batched engine
keeps them; ``c0, c1, ...`` are the swarm's columns and blackboard arrays in
:attr:`Layout.names` order. A leaf calls its :class:`~pyautonomousagent.kernels.LeafKernel`.
``tick`` ticks every agent; ``block_serial``/``block_parallel`` run whole iterations
(sensors, the 2-D drone's motion, with the 3-D drone's altitude where
:attr:`Layout.vertical` is set, the tree, control and recording) agent by agent.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pyautonomousagent.bt import tree_source as source
from pyautonomousagent.bt.program import Program
from pyautonomousagent.kernels import LeafKernel, SensorKernel
from pyautonomousagent.loop.layout import Layout, Messaging
from pyautonomousagent.loop.source import (
    _later,
    _later_pass,
    _swarm_args,
    alias,
    call,
    fused_arguments,
    handler_call,
    import_lines,
    kernel_imports,
    motion_functions,
    swarm_state_names,
)

#: Agents ticked together over a run of iterations in the fused loop: their records of one
#: iteration are contiguous (2 KiB per column), and their state stays in the L2 cache.
CHUNK = 256


def _call(kernel: LeafKernel, layout: Layout, node: int) -> str:
    outbox = [f"o{node}"] if kernel.sends is not None else []
    return call(alias(kernel.function), ["a"], layout, kernel.names, outbox, f"leaf {node}",
                kernel.constants)  # fmt: skip


def _leaf_lines(i: int, kernels: Mapping[int, LeafKernel], layout: Layout, ticks: str) -> list[str]:
    """Leaf ``i``'s call of its kernel for agent ``a`` (and its ``Later`` step, or its mark in
    ``pend`` where deferred), then its tick counted."""
    lines = [f"st[{i}, a] = {_call(kernels[i], layout, i)}"]
    later = kernels[i].later
    if later is not None:
        lines.append(f"pend[a] = {i}" if i in layout.deferred else _later(later, layout))
    return [*lines, f"{ticks}[a] += 1"]


def tree_body(
    program: Program, kernels: Mapping[int, LeafKernel], layout: Layout, indent: str
) -> str:
    """The tick of agent ``a`` at iteration ``t`` as straight-line code, indented by
    ``indent`` (:func:`pyautonomousagent.bt.tree_source.tree_body`, the node types' rules),
    after the outboxes are cleared (nothing sent yet this tick)."""
    ticks = layout.array("number_ticks")
    clear = "".join(f"{indent}o{i}[0, a] = 0.0\n" for i in layout.outboxes)
    body = source.tree_body(
        program,
        lambda i: _leaf_lines(i, kernels, layout, ticks),
        layout.memory_rows,
        indent,
        layout.time_step,
        lambda key: f"{layout.array(key)}[a]",
    )
    return clear + body


def _swarm_apply(sensors: SensorKernel, layout: Layout) -> str:
    """After agent ``a``'s sensors, what the swarm sensor found for it (a line of its own);
    "" without a swarm sensor."""
    if sensors.swarm is None:
        return ""
    return f"\nWA({', '.join(['a', 'moving', *_swarm_args(sensors.swarm, layout)])})"


def _swarm_detect(sensors: SensorKernel, layout: Layout) -> str:
    """At the start of iteration ``t``: the swarm sensor over every agent, stopping before
    the iteration where it has too little room; "" without a swarm sensor."""
    if sensors.swarm is None:
        return ""
    args = ", ".join(["t", *_swarm_args(sensors.swarm, layout)])
    return f"""        if W({args}) != 0:
            return done"""


#: What the fused functions pass for a parameter of this name of the motion model's
#: functions (:func:`~pyautonomousagent.loop.source.motion_functions`); the 3-D drone's are
#: read from :attr:`Layout.vertical`, any other is the column.
_MOTION_ARGS = {"u_speed": "us", "u_heading": "uh", "u_climb": "uc"} | {
    name: name for name in ("a", "moving", "max_speed", "speed_step", "turn_step")
}
_VERTICAL = ("max_climb_rate", "climb_step", "max_altitude")


def _model_calls(functions: Sequence[Any], layout: Layout, indent: str) -> str:
    """A line per function: its call for agent ``a``, its arguments matched by name."""
    vertical = dict(zip(_VERTICAL, layout.constants.refs("drone3d", layout.vertical or ()),
                        strict=False))  # fmt: skip
    lines = []
    for function in functions:
        names = inspect.signature(getattr(function, "py_func", function)).parameters
        args = [_MOTION_ARGS.get(n) or vertical.get(n) or layout.array(n) for n in names]
        lines.append(f"{indent}{alias(function)}({', '.join(args)})")
    return "\n".join(lines)


def _motion(layout: Layout, sensors: SensorKernel, indent: str) -> str:
    """Phase 2 for agent ``a``: the sensors, the motion model's step
    (:func:`~pyautonomousagent.loop.source.motion_functions`; one that cannot move stops),
    ``stopped_at`` keeping the first iteration it could not."""
    state = [f"ss{j}" for j in range(len(sensors.state))]
    sense = call("S", ["a"], layout, sensors.names, state, "sensors", sensors.constants)
    lines = f"""moving = {sense}{_swarm_apply(sensors, layout)}
{_model_calls(motion_functions(layout)[0], layout, "")}
if not moving and stopped_at[a] < 0:
    stopped_at[a] = t"""
    return "\n".join(indent + line for line in lines.splitlines())


def _control(layout: Layout, indent: str) -> str:
    """Phase 4 for agent ``a``: the motion model's control
    (:func:`~pyautonomousagent.loop.source.motion_functions`)."""
    return _model_calls(motion_functions(layout)[1], layout, indent)


def _phase4(kernels: Mapping[int, LeafKernel], layout: Layout, agents: str, indent: str) -> str:
    """Phase 4 for the agents whose tree was just ticked in a loop over ``agents`` at
    ``indent``: inside that loop, or, where ``Later`` steps were deferred, in a loop of its
    own after them."""
    if not layout.deferred:
        return _control(layout, indent + " " * 4)
    return _later_pass(kernels, layout, agents, _control(layout, indent + " " * 4), indent)


#: A tree of more nodes than this is written once, in a group function that both fused
#: variants call (:meth:`_Fused.group_function`); a smaller one (every
#: mission's: 7-19 nodes) inside each. numba's parallel passes over a loop that holds the
#: tree grow faster than the tree: written inside, the serial and the parallel variant took
#: 17 s and 49 s to compile for patrol's 16 nodes, 22 s and 72 s for 26 nodes, 37 s and more
#: than 300 s for 42; grouped, 29 s and 16 s for 26 nodes. Called from the parallel loop,
#: the group function runs 20-40 % slower per agent (patrol, 1000 drones).
INLINE_NODES = 20


def grouped(program: Program) -> bool:
    """Whether the fused variants call one group function for ``program``'s tree."""
    return len(program.nodes) > INLINE_NODES


def _record_group(layout: Layout, indent: str) -> str:
    """Phase 6 of the agents ``first`` to ``last`` into record row ``row``, at ``indent``:
    the columns, then the node statuses."""
    statuses = "    record_statuses(a, row, st, traces, traced_at, behaviour, leaf_rows)"
    lines = [f"r{j}[row, first:last] = c{j}[first:last]" for j in range(len(layout.names))]
    lines += ["for a in range(U(first), U(last)):", statuses]
    return "\n".join(indent + line for line in lines)


def _handle(messaging: Messaging, layout: Layout) -> str:
    """Phase 2's handlers: each type delivered last iteration, in the inbox's ``order``."""
    lines = ["for j in range(order.shape[0]):", "    k = order[j]"]
    for k in range(len(messaging.handlers)):
        handle = handler_call(messaging, layout, k, f"ib_s{k}", f"ib_d{k}", f"counts[{k}]")
        lines += [f"    if k == {k}:", f"        {handle}"]
    return "\n".join(" " * 8 + line for line in lines)


#: The bounding box of the positions seen so far grown by ``(px, py)`` (``bad``: a NaN).
_GROW_BOX = """bad = bad or px != px or py != py
low_x = min(low_x, px)
high_x = max(high_x, px)
low_y = min(low_y, py)
high_y = max(high_y, py)""".splitlines()


def _collect(messaging: Messaging, layout: Layout) -> str:
    """Phase 5: this iteration's messages into the inboxes, by type in canonical order (by
    sender, then sending node), each type's lowest sending node in ``lowest``, the bounding
    box of the agents and senders (``bad``: a NaN), then ``order``: the types sent, by their
    first sending node (the order in which the batched engine sends them)."""
    x, y = layout.array("x"), layout.array("y")
    lines = [
        "for k in range(counts.shape[0]):",
        "    counts[k] = 0",
        "    lowest[k] = -1",
        f"low_x = high_x = {x}[0]",
        f"low_y = high_y = {y}[0]",
        "bad = False",
        "for a in range(U(0), U(n)):",
        f"    px = {x}[a]",
        f"    py = {y}[a]",
        *("    " + line for line in _GROW_BOX),
    ]
    for i, (k, rows) in messaging.senders.items():
        copy = "\n".join(f"    ib_d{k}[{f}, m] = o{i}[{row}, a]" for f, row in enumerate(rows))
        block = f"""if o{i}[0, a] == 1.0:
    m = counts[{k}]
    ib_s{k}[m] = a
{copy}
    counts[{k}] = m + 1
    if lowest[{k}] < 0 or lowest[{k}] > {i}:
        lowest[{k}] = {i}
    px = o{i}[1, a]
    py = o{i}[2, a]"""
        lines += ["    " + line for line in [*block.splitlines(), *("    " + g for g in _GROW_BOX)]]
    lines += ["for j in range(order.shape[0]):", "    order[j] = -1", "j = 0"]
    for i, (k, _) in messaging.senders.items():
        lines += [
            f"if counts[{k}] > 0 and lowest[{k}] == {i}:",
            f"    order[j] = {k}",
            "    j += 1",
        ]
    return "\n".join(" " * 8 + line for line in lines)


def _groups(body: str, indent: str) -> str:
    """``body`` (code for the agents ``first`` to ``last``, indented by 4) for every group of
    ``chunk`` agents, the groups shared among the cores in a parallel function."""
    head = """for group in prange(groups):
    first = group * chunk
    last = min(n, first + chunk)"""
    return "\n".join(indent + line for line in head.splitlines()) + "\n" + body


@dataclass(frozen=True)
class _Fused:
    """The fused loop's functions of a tree: its program, its leaves' kernels, the layout and
    the mission's compiled sensors."""

    program: Program
    kernels: Mapping[int, LeafKernel]
    layout: Layout
    sensors: SensorKernel

    def group_body(self, indent: str) -> str:
        """Iterations ``t0 + 1 .. t0 + count`` of Phases 2 (sensors, motion), 3, 4 and 6 for
        the agents ``first`` to ``last``, indented by ``indent``; the record of iteration ``t``
        in row ``t // every - row0`` of the record arrays (a block of record rows,
        :mod:`~pyautonomousagent.record_blocks`)."""
        layout = self.layout
        body = f"""for t in range(t0 + 1, t0 + count + 1):
    for a in range(U(first), U(last)):
{_motion(layout, self.sensors, " " * 8)}
{tree_body(self.program, self.kernels, layout, " " * 8)}
{_phase4(self.kernels, layout, "range(U(first), U(last))", " " * 4)}
    if t % every == 0:  # a contiguous run of each record row, column by column
        row = t // every - row0
{_record_group(layout, " " * 8)}"""
        return "\n".join(indent + line if line.strip() else line for line in body.splitlines())

    def tick_and_control(self, indent: str) -> str:
        """Phases 3 and 4 of the agents ``first`` to ``last`` at iteration ``t``."""
        agents = "range(U(first), U(last))"
        return f"""{indent}for a in {agents}:
{tree_body(self.program, self.kernels, self.layout, indent + " " * 4)}
{_phase4(self.kernels, self.layout, agents, indent)}"""

    def group_function(self, stepwise: bool) -> str:
        """What both fused variants call for a tree of more than :data:`INLINE_NODES` nodes,
        compiled once: ``block_group(first, last, t0, count, every, row0, <the fused
        parameters>)``, their body (:meth:`group_body`), or with ``stepwise``
        ``tick_group(first, last, t, <the fused parameters>)``, the :meth:`tick_and_control`
        of :meth:`stepwise_block_function`."""
        if stepwise:
            head = "tick_group(first, last, t"
            body = self.tick_and_control(" " * 4)
        else:
            head = "block_group(first, last, t0, count, every, row0"
            body = self.group_body(" " * 4)
        return f"""
@njit(cache=True, nogil=True, error_model="numpy")
def {head}, {fused_arguments(self.layout, self.sensors)}):
{body}
"""

    def block_function(self, parallel: bool) -> str:
        """``block_serial``/``block_parallel(t0, count, every, row0, chunk, st, cur, pend, kf,
        ki, arrays..., us, uh, uc, records..., traces, traced_at, behaviour, leaf_rows,
        stopped_at, max_speed, speed_step, turn_step, sensor state...) -> count``: iterations
        ``t0 + 1 .. t0 + count`` of Phases 2 (sensors, motion), 3, 4 and 6 for every agent,
        ``chunk`` agents at a time, the groups shared among the cores in the parallel one (no
        agent hears another: the tree sends no message): :meth:`group_body`, written in place
        or, for a large tree (:func:`grouped`), a call of ``block_group``. ``us``, ``uh``,
        ``uc``: the control signals u_v, u_a and (3-D drone) u_w, shape (N,)."""
        arguments = fused_arguments(self.layout, self.sensors)
        if grouped(self.program):
            body = f"        block_group(first, last, t0, count, every, row0, {arguments})"
        else:
            body = self.group_body(" " * 8)
        name = "block_parallel" if parallel else "block_serial"
        return f"""
@njit(cache=True, parallel={parallel}, nogil=True, error_model="numpy")
def {name}(t0, count, every, row0, chunk, {arguments}):
    n = {self.layout.array("x")}.shape[0]
    for group in prange((n + chunk - 1) // chunk):
        first = group * chunk
        last = min(n, first + chunk)
{body}
    return count
"""

    def stepwise_block_function(self, messaging: Messaging | None, parallel: bool) -> str:
        """``block_messages_serial``/``_parallel`` (given ``messaging``: a tree that sends
        messages) or ``block_swarm_serial``/``_parallel`` (sensors that sense the whole swarm,
        ``sensors.swarm``, called once an iteration before the agents' sensors) ``(t0, count,
        every, row0, chunk, <the fused parameters>[, reach, order, counts, lowest, inboxes...,
        handler state...][, swarm state...]) -> iterations done``: up to ``count`` whole
        iterations, Phase by Phase over every agent (``chunk`` at a time), the record of
        iteration ``t`` in row ``t // every - row0``. The inboxes hold the messages handled in
        the first iteration (``order``: the types delivered, -1 after them; ``counts`` per
        type); it stops after an iteration whose messages do not all reach every agent
        (``reach``: the datalink's range, world units) or include a recorded type (the caller
        delivers those), and before one the swarm sensor has no room for."""
        layout, sensors = self.layout, self.sensors
        sense_and_move = f"""            for a in range(U(first), U(last)):
{_motion(layout, sensors, " " * 16)}"""
        if grouped(self.program):
            arguments = fused_arguments(layout, sensors)
            tick_and_control = f"            tick_group(first, last, t, {arguments})"
        else:
            tick_and_control = self.tick_and_control(" " * 12)
        record = _record_group(layout, " " * 16)
        extra, handle, collect = "", "", ""
        if messaging is not None:
            recorded = [k for k, flag in enumerate(messaging.recorded) if flag]
            deliver_here = " or ".join(f"counts[{k}] > 0" for k in recorded) or "False"
            names = ["reach", "order", "counts", "lowest", *messaging.inbox_names]
            extra = ",\n           " + ", ".join(names + messaging.state_names)
            handle = "\n" + _handle(messaging, layout)
            collect = f"""
{_collect(messaging, layout)}
        if j > 0:
            if bad or not hypot(high_x - low_x, high_y - low_y) <= reach:
                return done
            if {deliver_here}:
                return done"""
        if swarm_state_names(sensors.swarm):
            extra += ",\n           " + ", ".join(swarm_state_names(sensors.swarm))
        kind = "messages" if messaging is not None else "swarm"
        name = f"block_{kind}_{'parallel' if parallel else 'serial'}"
        arguments = fused_arguments(layout, sensors) + extra
        return f"""
@njit(cache=True, parallel={parallel}, nogil=True, error_model="numpy")
def {name}(t0, count, every, row0, chunk, {arguments}):
    n = {layout.array("x")}.shape[0]
    groups = (n + chunk - 1) // chunk
    done = 0
    for t in range(t0 + 1, t0 + count + 1):
{_swarm_detect(sensors, layout)}
{_groups(sense_and_move, " " * 8)}{handle}
{_groups(tick_and_control, " " * 8)}
        if t % every == 0:
            row = t // every - row0
{_groups(record, " " * 12)}
        done += 1{collect}
    return done
"""


def tick_function(program: Program, kernels: Mapping[int, LeafKernel], layout: Layout) -> str:
    """``tick(t, st, cur, pend, kf, ki, arrays..., outboxes...)``: Phase 3 for every agent at
    iteration ``t``."""
    return f"""
@njit(cache=True, error_model="numpy")
def tick(t, st, cur, pend, kf, ki, {layout.arrays}):
    n = st.shape[1]
    for a in range(U(0), U(n)):
{tree_body(program, kernels, layout, " " * 8)}
{_later_pass(kernels, layout, "range(U(0), U(n))", "", " " * 4) if layout.deferred else ""}
"""


HEADER = """# Generated by pyautonomousagent.engines.compiled_source; do not edit.
import math

from numba import njit, prange
from numpy import uint64 as U  # agent rows as unsigned: no check for negative indices

from pyautonomousagent.loop.runtime import halt, record_statuses
from pyautonomousagent.kernels import hypot
"""


def module_source(
    program: Program,
    kernels: Mapping[int, LeafKernel],
    layout: Layout,
    sensors: SensorKernel | None,
    messaging: Messaging | None = None,
) -> str:
    """The whole generated module: imports of the kernels, ``tick`` and, given ``sensors``,
    the fused loop: ``block_messages_serial`` and ``block_messages_parallel`` where the tree
    sends messages (given ``messaging``), ``block_swarm_serial`` and ``block_swarm_parallel``
    where it sends none and ``sensors`` sense the whole swarm, else ``block_serial`` and
    ``block_parallel``."""
    used = kernel_imports(kernels, layout)
    if sensors is not None:
        used["S"] = sensors.function
    if sensors is not None and sensors.swarm is not None:
        used["W"], used["WA"] = sensors.swarm.detect, sensors.swarm.apply
    for k, handler in enumerate(messaging.handlers if messaging is not None else ()):
        used[f"H{k}"] = handler.function
    lines = [HEADER, *import_lines(used), tick_function(program, kernels, layout)]
    if sensors is None or (layout.outboxes and messaging is None):
        return "\n".join(lines) + "\n"  # no fused loop
    stepwise = bool(layout.outboxes) or sensors.swarm is not None
    fused = _Fused(program, kernels, layout, sensors)
    if grouped(program):
        lines.append(fused.group_function(stepwise))
    for p in (False, True):
        if stepwise:
            lines.append(fused.stepwise_block_function(messaging, p))
        else:
            lines.append(fused.block_function(p))
    return "\n".join(lines) + "\n"
