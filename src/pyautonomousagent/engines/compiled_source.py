"""The compiled engine's code generator: a tree (and the run's sensors and motion) as Python
source for numba.

Every node of the flattened tree (:class:`~pyautonomousagent.engines.batched.Program`)
becomes a block of straight-line code that ticks it for agent row ``a`` at iteration ``t``
(:func:`tree_body`): ``st`` holds the node statuses (nodes, N) int8 and ``cur`` the remembered
child of each Sequence/Fallback (one row per such node, (M, N) int32), exactly as the batched
engine keeps them; ``c0, c1, ...`` are the swarm's columns and blackboard arrays in
:attr:`Layout.names` order. A leaf calls its :class:`~pyautonomousagent.kernels.LeafKernel`.
The rules are the batched engine's (``_sequence``, ``_selector``, ``_decorator``), written
for one agent. ``tick`` ticks every agent; ``block_serial``/``block_parallel`` run whole
iterations (sensors, the 2-D drone's motion, the tree, control and recording) agent by agent.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pyautonomousagent.bt.nodes import NODE_TYPES
from pyautonomousagent.bt.status import FAILURE, NAMES, RUNNING, SUCCESS
from pyautonomousagent.engines.batched import Program
from pyautonomousagent.kernels import ITERATION, LeafKernel, SensorKernel

_CODES = {name: code for code, name in NAMES.items()}

#: Agents ticked together over a run of iterations in the fused loop: their records of one
#: iteration are contiguous (2 KiB per column), and their state stays in the L2 cache.
CHUNK = 256


@dataclass(frozen=True)
class Layout:
    """Where the generated code finds things.

    Attributes:
        names: the arrays ``c0, c1, ...``: swarm columns, then blackboard keys.
        memory_rows: node index -> its row of ``cur`` (Sequence and Fallback nodes).
    """

    names: tuple[str, ...]
    memory_rows: Mapping[int, int]

    @property
    def arrays(self) -> str:
        """The argument list of every node function after ``a, t, st, cur``."""
        return ", ".join(f"c{j}" for j in range(len(self.names)))

    def array(self, name: str) -> str:
        """The variable holding array ``name`` (``t`` for the iteration)."""
        return "t" if name == ITERATION else f"c{self.names.index(name)}"


def supported(program: Program) -> bool:
    """Whether every control node of ``program`` has a compiled form (Sequence, Fallback and
    status-mapping decorators, without scripts)."""
    for node in program.nodes:
        if node.scripts:
            return False
        plain = node.type in ("Sequence", "Fallback") or not node.is_control
        if not plain and NODE_TYPES.get(node.type).status_map is None:
            return False
    return True


def alias(function: Any) -> str:
    """The name a kernel function is imported under: its module and name, made one word."""
    py = getattr(function, "py_func", function)
    return "K_" + f"{py.__module__}.{py.__qualname__}".replace(".", "_")


def _call(kernel: LeafKernel, layout: Layout) -> str:
    args = ["a", *(layout.array(name) for name in kernel.names)]
    args += [repr(value) for value in kernel.constants]
    return f"{alias(kernel.function)}({', '.join(args)})"


def _halts(program: Program, kids: Sequence[int], indent: str) -> list[str]:
    return [f"{indent}halt(a, st, {k}, {program.end[k]})" for k in kids]


def _sequence(program: Program, i: int, row: int, memory: bool) -> list[str]:
    kids = program.children[i]
    lines = [f"    fresh = st[{i}, a] != {RUNNING}", "    if fresh:"]
    lines += _halts(program, kids, "        ") or ["        pass"]
    if not kids:
        return [*lines, f"    st[{i}, a] = {SUCCESS}", f"    cur[{row}, a] = -1"]
    lines.append(f"    start = cur[{row}, a] if not fresh else 0" if memory else "    start = 0")
    for k, child in enumerate(kids):
        lines += [f"    if start <= {k}:"]
        if memory:
            lines.append(f"        cur[{row}, a] = {k}")
        lines += [f"        n{child}(a, t, st, cur, ARRAYS)", f"        res = st[{child}, a]"]
        lines.append(f"        if res != {SUCCESS}:")
        if not memory:
            lines += _halts(program, kids[k + 1 :], "            ")
        lines += [f"            st[{i}, a] = res", "            return"]
    return [*lines, f"    st[{i}, a] = {SUCCESS}"]


def _selector(program: Program, i: int, row: int, memory: bool) -> list[str]:
    kids = program.children[i]
    lines = [f"    if st[{i}, a] != {RUNNING}:", f"        cur[{row}, a] = 0"]
    if not kids:
        return [*lines, f"    st[{i}, a] = {FAILURE}", f"    cur[{row}, a] = -1"]
    lines.append(f"    previous = cur[{row}, a]")
    for k in range(len(kids) - 1) if memory else ():
        lines += [f"    if previous > {k}:", *_halts(program, [kids[k]], "        ")]
    lines.append("    start = previous" if memory else "    start = 0")
    for k, child in enumerate(kids):
        lines += [f"    if start <= {k}:", f"        n{child}(a, t, st, cur, ARRAYS)"]
        lines += [f"        res = st[{child}, a]", f"        if res != {FAILURE}:"]
        lines += [f"            cur[{row}, a] = {k}", f"            if previous != {k}:"]
        lines += _halts(program, kids[k + 1 :], "                ") or ["                pass"]
        lines += [f"            st[{i}, a] = res", "            return"]
    return [*lines, f"    st[{i}, a] = {FAILURE}", f"    cur[{row}, a] = {len(kids) - 1}"]


def _decorator(program: Program, i: int) -> list[str]:
    child = program.children[i][0]
    mapping = {code: code for code in NAMES}
    for before, after in (NODE_TYPES.get(program.nodes[i].type).status_map or {}).items():
        mapping[_CODES[before]] = _CODES[after]
    table = ", ".join(str(mapping[code]) for code in sorted(mapping))
    return [
        f"    n{child}(a, t, st, cur, ARRAYS)",
        f"    res = st[{child}, a]",
        f"    new = ({table},)[res]",
        f"    if new != {RUNNING} and res == {RUNNING}:",
        f"        halt(a, st, {child}, {program.end[child]})",
        f"    st[{i}, a] = new",
    ]


def _node_lines(
    program: Program, i: int, kernels: Mapping[int, LeafKernel], layout: Layout, ticks: str
) -> list[str]:
    """Node ``i``'s rules, indented by 4, its children as ``n<child>(...)`` lines."""
    node = program.nodes[i]
    if not node.is_control:
        return [f"    st[{i}, a] = {_call(kernels[i], layout)}", f"    {ticks}[a] += 1"]
    if node.type in ("Sequence", "Fallback"):
        build = _sequence if node.type == "Sequence" else _selector
        return build(program, i, layout.memory_rows[i], bool(program.params[i]["memory"]))
    return _decorator(program, i)


_CHILD = re.compile(r"^(\s*)n(\d+)\(a, t, st, cur, ARRAYS\)$")
_LOCALS = re.compile(r"\b(fresh|start|previous|res|new)\b")


def tree_body(
    program: Program, kernels: Mapping[int, LeafKernel], layout: Layout, indent: str
) -> str:
    """The tick of agent ``a`` at iteration ``t`` as straight-line code, indented by
    ``indent``: each control node is a ``while True:`` block left with ``break`` (its
    ``return``), children written in place, locals suffixed with the node index. One body
    with no calls between nodes: numba passes no arrays between functions (which costs
    reference counting per call and made a tick ten times slower)."""
    ticks = layout.array("number_ticks")

    def expand(i: int) -> list[str]:
        lines = []
        for line in _node_lines(program, i, kernels, layout, ticks):
            line = _LOCALS.sub(lambda m: f"{m.group(1)}_{i}", line[4:])
            child = _CHILD.match(line)
            if child:
                lines += [child.group(1) + inner for inner in expand(int(child.group(2)))]
            else:
                lines.append(re.sub(r"\breturn\b", "break", line))
        if not program.nodes[i].is_control:
            return lines
        return ["while True:", *("    " + line for line in lines), "    break"]

    return "\n".join(indent + line for line in expand(0))


def _sensor_call(sensors: SensorKernel, layout: Layout) -> str:
    args = ["a", *(layout.array(name) for name in sensors.names)]
    args += [repr(value) for value in sensors.constants]
    return f"S({', '.join(args)})"


def block_function(
    program: Program,
    kernels: Mapping[int, LeafKernel],
    layout: Layout,
    sensors: SensorKernel,
    parallel: bool,
) -> str:
    """``block_serial``/``block_parallel(t0, count, every, chunk, st, cur, arrays..., us, uh,
    cache (3, N), records..., traces, traced_at, behaviour, leaf_rows, stopped_at, max_speed,
    speed_step,
    turn_step)``: iterations ``t0 + 1 .. t0 + count`` of Phases 2 (sensors, motion), 3, 4 and
    6 for every agent, ``chunk`` agents at a time. ``cache`` rows: the heading whose sine
    and cosine are in rows 1 and 2 (the same inputs give the same bits)."""
    c = {name: layout.array(name) for name in layout.names}
    x, y, v, h = c["x"], c["y"], c["speed"], c["heading"]
    rs, rh = c["requested_speed"], c["requested_heading"]
    records = ", ".join(f"r{j}" for j in range(len(layout.names)))
    store = "\n".join(
        f"                r{j}[row, first:last] = c{j}[first:last]"
        for j in range(len(layout.names))
    )
    name = "block_parallel" if parallel else "block_serial"
    return f"""
@njit(cache=True, parallel={parallel}, error_model="numpy")
def {name}(t0, count, every, chunk, st, cur, {layout.arrays}, us, uh, cache,
           {records}, traces, traced_at, behaviour, leaf_rows, stopped_at,
           max_speed, speed_step, turn_step):
    n = {x}.shape[0]
    for group in prange((n + chunk - 1) // chunk):
        first = group * chunk
        last = min(n, first + chunk)
        for t in range(t0 + 1, t0 + count + 1):
            for a in range(first, last):
                moving = {_sensor_call(sensors, layout)}
                if moving:
                    heading = {h}[a]
                    speed = {v}[a]
                    if heading != cache[0, a]:
                        rad = heading * DEGREE
                        cache[0, a] = heading
                        cache[1, a] = math.sin(rad)
                        cache[2, a] = math.cos(rad)
                    {x}[a] = {x}[a] + speed * cache[1, a]
                    {y}[a] = {y}[a] + speed * cache[2, a]
                    {v}[a] = np_minimum(np_maximum(speed + us[a], 0.0), max_speed)
                    {h}[a] = wrap_degrees(heading + uh[a])
                else:
                    {v}[a] = 0.0
                    if stopped_at[a] < 0:
                        stopped_at[a] = t
{tree_body(program, kernels, layout, " " * 16)}
                us[a] = speed_step * np_sign({rs}[a] - {v}[a])
                error = wrap_degrees({rh}[a] - {h}[a])
                if error > 180.0:
                    error = error - 360.0
                uh[a] = turn_step * np_sign(error)
            if t % every == 0:  # a contiguous run of each record row, column by column
                row = t // every
{store}
                for a in range(first, last):
                    record_statuses(a, row, st, traces, traced_at, behaviour, leaf_rows)
"""


def tick_function(program: Program, kernels: Mapping[int, LeafKernel], layout: Layout) -> str:
    """``tick(t, st, cur, arrays...)``: Phase 3 for every agent at iteration ``t``."""
    return f"""
@njit(cache=True, error_model="numpy")
def tick(t, st, cur, {layout.arrays}):
    for a in range(st.shape[1]):
{tree_body(program, kernels, layout, " " * 8)}
"""


HEADER = """# Generated by pyautonomousagent.engines.compiled_source; do not edit.
import math

from numba import njit, prange

from pyautonomousagent.engines.compiled_runtime import halt, record_statuses
from pyautonomousagent.kernels import np_maximum, np_minimum, np_sign, wrap_degrees

DEGREE = math.pi / 180.0
"""


def module_source(
    program: Program,
    kernels: Mapping[int, LeafKernel],
    layout: Layout,
    sensors: SensorKernel | None,
) -> str:
    """The whole generated module: imports of the kernels, node functions, ``tick_all`` and,
    given ``sensors``, the fused ``block_serial`` and ``block_parallel``."""
    lines = [HEADER]
    used = {alias(k.function): k.function for k in kernels.values()}
    if sensors is not None:
        used["S"] = sensors.function
    for name, function in sorted(used.items()):
        py = getattr(function, "py_func", function)
        lines.append(f"from {py.__module__} import {py.__qualname__} as {name}")
    lines.append(tick_function(program, kernels, layout))
    if sensors is not None:
        lines += [block_function(program, kernels, layout, sensors, p) for p in (False, True)]
    return "\n".join(lines) + "\n"
