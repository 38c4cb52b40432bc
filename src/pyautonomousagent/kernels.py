"""Per-agent kernels for the compiled engine: what a leaf or a mission's sensors supply.

The compiled engine (:mod:`pyautonomousagent.engines.compiled`) runs the whole tree, the
sensors and the motion model agent by agent in code compiled with numba. A leaf takes part by
returning a :class:`LeafKernel` from :meth:`~pyautonomousagent.bt.leaf.Leaf.kernel`; a mission
by returning a :class:`SensorKernel` from
:meth:`~pyautonomousagent.simulation.mission.Mission.compiled_sensors`. A tree with a leaf
that has no kernel runs on the batched engine instead.

A kernel function takes the agent's row ``a`` first, then the arrays it names (shape (N,),
read and written at ``[a]``; matched to its parameters by name, :data:`Columns`), then its
constants; it must give the same bits as the NumPy ``evaluate``/``sense`` it stands for (the
engine-identity tests hold them equal).

Messages: a leaf that broadcasts declares what it sends (:class:`Sends`) and its kernel gets
an outbox after its arrays; a mission's message type may have a :class:`HandlerKernel`, the
compiled form of its handler for deliveries that reached every agent (and, optionally,
:class:`Receive`, one message for one receiver, for those that reached only some; and
``by_sender``, for an everyone form whose messages touch only their senders' entries: the
GPU engine handles a delivery to everyone in parallel with either). The helpers
below repeat :mod:`pyautonomousagent.arrays` and NumPy's element-wise rules operation for
operation on one number, so kernels can use them.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pyautonomousagent.arrays import _SERIES, _SQRT3, _TAN_PI_12, _sincos_float
from pyautonomousagent.jit import njit

if TYPE_CHECKING:
    from pyautonomousagent.simulation.view import SimulationView

#: The name that passes the iteration number (an int) to a kernel instead of an array.
ITERATION = "@iteration"


#: How a kernel names the swarm columns (or blackboard keys) it is passed: a tuple, in the order
#: of its function's array parameters, each parameter named as its column; or a mapping from
#: parameter name to column (any order), where they differ (e.g. a kernel used for several
#: columns, or :data:`ITERATION`).
Columns = tuple[str, ...] | Mapping[str, str]


def _qualified(function: Callable[..., Any], names: tuple[str, ...]) -> str:
    """``name(a, b, ...)`` of ``function`` (its ``py_func``'s for an njit function)."""
    python = getattr(function, "py_func", function)
    return f"{getattr(python, '__qualname__', python)!s}({', '.join(names)})"


def bind_columns(what: str, function: Callable[..., Any], leading: tuple[str, ...],
                 columns: Columns) -> tuple[str, ...]:  # fmt: skip
    """The columns ``function`` is passed, in the order of its array parameters (those after
    the ``leading`` ones), matched by name: a tuple's columns must be named as the parameters
    they are passed as, a mapping's keys must be exactly those parameters. Raises TypeError
    naming the kernel, the parameter and the column that do not match, where the kernel is
    declared, before any code is generated or compiled. A function with ``*args`` takes a
    tuple unchecked."""
    names = _parameter_names(function)
    if names is None:
        if isinstance(columns, Mapping):
            raise TypeError(f"{what} {_qualified(function, ('*args',))} cannot take columns "
                            "by name: it has no named array parameters")  # fmt: skip
        return tuple(columns)
    arrays = names[len(leading) : len(leading) + len(columns)]
    if isinstance(columns, Mapping):
        unknown = [k for k in columns if k not in arrays]
        missing = [p for p in arrays if p not in columns]
        if unknown or missing:
            raise TypeError(
                f"{what} {_qualified(function, names)} is given columns for "
                f"{', '.join(map(repr, unknown)) or 'no other parameter'}, but not for its "
                f"array parameter(s) {', '.join(map(repr, missing)) or '(none)'} "
                f"(its arrays: {', '.join(arrays)})"
            )
        return tuple(columns[p] for p in arrays)
    for parameter, column in zip(arrays, columns, strict=False):
        if parameter != column:
            raise TypeError(
                f"{what} {_qualified(function, names)} would be passed column {column!r} as "
                f"parameter {parameter!r}: name the parameter as the column, or give the "
                f"columns by name ({{{parameter!r}: {column!r}, ...}})"
            )
    return tuple(columns)


def check_arity(what: str, function: Callable[..., Any], leading: tuple[str, ...],
                passed: dict[str, int]) -> None:  # fmt: skip
    """Raise TypeError, naming the kernel and what it is passed, where ``function`` (an
    njit function, or plain Python) does not take exactly the ``leading`` arguments plus
    ``passed``'s counts: a mismatch found where the kernel is declared, before the engine
    generates and compiles any code around it. A function with ``*args`` is not checked."""
    names = _parameter_names(function)
    expected = len(leading) + sum(passed.values())
    if names is not None and len(names) != expected:
        given = ", ".join([*leading, *(f"{n} {k}" for k, n in passed.items() if n)])
        raise TypeError(
            f"{what} {_qualified(function, names)} takes {len(names)} arguments, but is "
            f"passed {expected}: {given}"
        )


def _bind(kernel: Any, *functions: tuple[str, Callable[..., Any], tuple[str, ...]]) -> None:
    """Set ``kernel.names`` to its columns in the order of its functions' array parameters
    (:func:`bind_columns`), the same for each of ``functions`` (what, function, leading)
    that are passed the same arrays."""
    bound = [bind_columns(what, f, leading, kernel.names) for what, f, leading in functions]
    for (what, function, _), columns in zip(functions[1:], bound[1:], strict=True):
        if columns != bound[0]:
            raise TypeError(
                f"{what} {_qualified(function, columns)} takes its arrays in another order "
                f"than {functions[0][0]}: {', '.join(bound[0])}"
            )
    object.__setattr__(kernel, "names", bound[0])


@functools.lru_cache(maxsize=4096)
def _parameter_names(function: Callable[..., Any]) -> tuple[str, ...] | None:
    """``function``'s parameter names (its ``py_func``'s for an njit function), or None where
    it has ``*args``/``**kwargs`` or no signature. Kept per function: missions make their
    sensor kernels anew whenever the engine asks (in a run stepped on the CPU, every
    iteration), and ``inspect.signature`` costs about 15 us."""
    python = getattr(function, "py_func", function)
    try:
        parameters = list(inspect.signature(python).parameters.values())
    except (TypeError, ValueError):  # a builtin or a compiled object without a signature
        return None
    if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in parameters):
        return None
    return tuple(p.name for p in parameters)


@dataclass(frozen=True)
class Sends:
    """What a leaf's kernel broadcasts: one message of ``type`` per tick at most.

    Its kernel gets an outbox, shape (3 + len(fields), N) float64, after its arrays: to send
    from agent ``a`` it sets ``outbox[0, a] = 1.0``, rows 1 and 2 to the sender's x and y
    (world units) and rows 3, 4, ... to the payload ``fields`` in order. The engine clears
    row 0 before every tick and hands what was sent to the datalink as
    :meth:`~pyautonomousagent.bt.leaf.Leaf.broadcast` would (senders in ascending rows).

    Attributes:
        type: the message type (a mission's ``MessageType.name``).
        fields: the payload's names, in outbox row order.
    """

    type: str
    fields: tuple[str, ...]


@dataclass(frozen=True)
class Later:
    """The last step of a leaf that always returns RUNNING: ``target[a] = function(*values)``,
    ``values`` the agent's entries of the ``names`` arrays. The engine may take it out of the
    tick and do it for all agents after the tree, where nothing ticked after the leaf can
    see it (its ancestors all stop at RUNNING): a loop over agents with no tree between
    them, which the CPU runs many agents at a time (the drones' bearing, a chain of 40
    dependent operations, costs a fifth of it there).

    Attributes:
        function: ``function(*values) -> value`` (an njit function of numbers).
        names: the swarm columns or blackboard keys whose entries it takes (:data:`Columns`).
        target: the column or key it writes.
    """

    function: Callable[..., Any]
    names: Columns
    target: str

    def __post_init__(self) -> None:
        check_arity("Later", self.function, (), {"values": len(self.names)})
        _bind(self, ("Later", self.function, ()))


@dataclass(frozen=True)
class LeafKernel:
    """A leaf's per-agent form.

    Attributes:
        function: ``function(a, *arrays, [outbox,] *constants) -> status code`` (an njit
            function).
        names: the swarm columns or blackboard keys passed as arrays (:data:`Columns`);
            :data:`ITERATION` passes the iteration number.
        constants: numbers passed after the arrays (port values, an agent row, ...).
        sends: what the leaf broadcasts (its outbox comes after the arrays), or None.
        later: the leaf's last step, which the engine does after ``function`` (right after
            it, or for all agents after the tree), or None.
    """

    function: Callable[..., int]
    names: Columns
    constants: tuple[float | int, ...] = ()
    sends: Sends | None = None
    later: Later | None = None

    def __post_init__(self) -> None:
        passed = {"arrays": len(self.names), "outbox": int(self.sends is not None),
                  "constants": len(self.constants)}  # fmt: skip
        check_arity("LeafKernel", self.function, ("a",), passed)
        _bind(self, ("LeafKernel", self.function, ("a",)))


@dataclass(frozen=True)
class Receive:
    """A handler's per-receiver form: what one message does to one receiver, for deliveries
    that reached only some agents (the GPU engine hands each receiver the messages in range,
    in message order, the batched engine's delivery order), and, unless the handler is
    ``by_sender``, for a delivery to everyone of a few messages (the GPU engine hands each
    receiver every message not its own, in message order: the everyone form must do just
    that, as gathering's and radiation-search's loops of this form do).

    Attributes:
        function: ``function(r, m, t, senders, data, *arrays, *state, *constants)``: message
            ``m`` (column ``m`` of ``data``, sent by ``senders[m]`` at iteration ``t - 1``)
            received by agent ``r``; the arrays and constants are the handler's. It may
            write only receiver ``r``'s entries (receivers run in parallel), and handling the
            same messages again must leave the same state (see ``state``).
        state: ``state(room) -> arrays``: the mission's run state this form writes, as
            arrays with room for ``room`` entries per receiver, the first a flag of shape
            (1,) int64 that ``function`` sets to 1 where a receiver had no room left (the
            engine then calls ``keep``, asks for twice the room and handles the messages
            again); None: no state.
        keep: ``keep(arrays)`` takes the state back (the arrays ``state`` gave, written).
    """

    function: Callable[..., None]
    state: Callable[[int], tuple[Any, ...]] | None = None
    keep: Callable[[tuple[Any, ...]], None] | None = None


@dataclass(frozen=True)
class HandlerKernel:
    """A message type's handler, compiled, for messages that reached every agent but their
    sender (``Delivery.to_all``), the usual case of a long-range datalink; optionally its
    per-receiver form for deliveries that reached only some (:class:`Receive`).

    Attributes:
        function: ``function(t, senders, data, count, *arrays, *state, *constants)``, called
            once per iteration ``t`` with messages delivered (an njit function): ``senders``
            shape (>= count,) int64 and ``data`` shape (len(fields), >= count) float64 hold
            the ``count`` messages sent at iteration ``t - 1``, in canonical order (by sender,
            then sending order); it must do what the Python handler does with them.
        fields: the payload names, in ``data`` row order.
        names: swarm columns or blackboard keys passed as arrays (shape (N,);
            :data:`Columns`).
        state: arrays of the mission's run state passed as they are (e.g. what each agent
            heard), in order.
        constants: numbers passed last.
        receive: the per-receiver form, or None (such deliveries are then handled by the
            mission's Python handler).
        by_sender: the everyone form's effect of a message touches only its sender's
            entries (of the arrays and state), so ``function`` may be called on each
            sender's messages apart (a slice of ``senders`` and ``data``, in order), all
            senders at once: the GPU engine does so, one thread per sender.
    """

    function: Callable[..., None]
    fields: tuple[str, ...]
    names: Columns = ()
    state: tuple[Any, ...] = ()
    constants: tuple[float | int, ...] = ()
    receive: Receive | None = None
    by_sender: bool = False

    def __post_init__(self) -> None:
        passed = {"arrays": len(self.names), "state arrays": len(self.state),
                  "constants": len(self.constants)}  # fmt: skip
        everyone, one = ("t", "senders", "data", "count"), ("r", "m", "t", "senders", "data")
        check_arity("HandlerKernel", self.function, everyone, passed)
        if self.receive is not None and self.receive.state is None:  # else: its state's size
            check_arity("Receive", self.receive.function, one, passed | {"state arrays": 0})
        receive = () if self.receive is None else (("Receive", self.receive.function, one),)
        _bind(self, ("HandlerKernel", self.function, everyone), *receive)


@dataclass(frozen=True)
class SwarmSensorKernel:
    """A mission's Phase 2 sensing of the whole swarm at once (e.g. each agent's nearest
    neighbour, collisions between agents), compiled: the fused loop calls ``detect`` once an
    iteration, between the iterations' per-agent phases, and ``apply`` per agent.

    Attributes:
        detect: ``detect(t, *arrays, *state, *constants) -> int`` (njit), once per iteration
            ``t`` before the per-agent sensors: reads the arrays (columns the per-agent
            sensors do not write, e.g. the positions at the iteration's start) of every
            agent and writes only ``state``. Returns 0; or, changing nothing the run sees,
            not 0 where ``state`` has too little room: the fused call then stops before
            iteration ``t`` (the NumPy path runs it; ``collect`` makes room).
        apply: ``apply(a, moving, *arrays, *state, *constants)`` (njit, inline), for agent
            ``a`` right after its per-agent sensors (``moving``: what they returned): puts
            what ``detect`` found into the agent's columns.
        names: the swarm columns or blackboard keys passed as arrays (:data:`Columns`).
        state: arrays of the mission's run state passed as they are, in order.
        constants: numbers passed last.
        collect: ``collect(sim, through)``, after a fused call, as many times as it needs,
            with ``through`` rising to the last iteration run: what ``detect`` kept for the
            run (e.g. events) for the iterations up to ``through``, in order.
        device: ``detect``'s form for the GPU engine, or () for none (the GPU engine then
            refuses the run): steps ``step(a, t, *arrays, *state, *constants)`` (njit,
            inline, called from CUDA kernels only: they may use ``numba.cuda.atomic``), each
            run for every agent ``a`` as one launch, the steps in order (every agent ends a
            step before any starts the next). Together they must leave the arrays and the
            state as ``detect`` does, whatever order the threads run in (e.g. an atomic
            minimum of agent rows to find the lowest, not a race).
    """

    detect: Callable[..., int]
    apply: Callable[..., None]
    names: Columns
    state: tuple[Any, ...] = ()
    constants: tuple[float | int, ...] = ()
    collect: Callable[[SimulationView, int], None] | None = None
    device: tuple[Callable[..., None], ...] = ()

    def __post_init__(self) -> None:
        passed = {"arrays": len(self.names), "state arrays": len(self.state),
                  "constants": len(self.constants)}  # fmt: skip
        check_arity("SwarmSensorKernel detect", self.detect, ("t",), passed)
        check_arity("SwarmSensorKernel apply", self.apply, ("a", "moving"), passed)
        for step in self.device:
            check_arity("SwarmSensorKernel device step", step, ("a", "t"), passed)
        steps = [("SwarmSensorKernel device step", step, ("a", "t")) for step in self.device]
        _bind(self, ("SwarmSensorKernel detect", self.detect, ("t",)),
              ("SwarmSensorKernel apply", self.apply, ("a", "moving")), *steps)  # fmt: skip


@dataclass(frozen=True)
class SensorKernel:
    """A mission's Phase 2 sensors for one agent.

    Attributes:
        function: ``function(a, *arrays, *state, *constants) -> bool``: updates agent ``a``'s
            sensed columns and says whether it can move this iteration (an njit function).
        names: the swarm columns or blackboard keys passed as arrays (:data:`Columns`).
        constants: numbers passed after the arrays and the state.
        stopped: ``stopped(sim, rows)`` is called, with ``sim.world.iteration`` set, for the
            agents (int array) found unable to move for the first time in a run of
            iterations (the mission's alerts), in order of iteration.
        swarm: the sensing of the whole swarm done with them (after ``function`` in an
            iteration, as the NumPy path does), or None.
        state: arrays the sensors read (never write) passed as they are, after the named
            arrays, in order (e.g. obstacles as arrays of corners or centres and radii).
    """

    function: Callable[..., bool]
    names: Columns
    constants: tuple[float | int, ...] = ()
    stopped: Callable[[SimulationView, Any], None] | None = None
    swarm: SwarmSensorKernel | None = None
    state: tuple[Any, ...] = ()

    def __post_init__(self) -> None:
        passed = {"arrays": len(self.names), "state arrays": len(self.state),
                  "constants": len(self.constants)}  # fmt: skip
        check_arity("SensorKernel", self.function, ("a",), passed)
        _bind(self, ("SensorKernel", self.function, ("a",)))


@njit(inline="always")
def np_maximum(a: float, b: float) -> float:
    """``numpy.maximum`` of two numbers (NaN propagates; ``b`` when they are equal)."""
    return a if (a > b or a != a) else b


@njit(inline="always")
def np_minimum(a: float, b: float) -> float:
    """``numpy.minimum`` of two numbers (NaN propagates; ``b`` when they are equal)."""
    return a if (a < b or a != a) else b


@njit(inline="always")
def np_sign(v: float) -> float:
    """``numpy.sign`` of a number: -1, +1, +0 for either zero, NaN for NaN."""
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return v if v != v else 0.0


@njit(inline="always")
def wrap_degrees(angle: float) -> float:
    """:func:`pyautonomousagent.arrays.wrap_degrees` of one angle in [-360, 720), degrees."""
    if angle < 0.0:
        angle = angle + 360.0
    return angle - 360.0 if angle >= 360.0 else angle


@njit(inline="always")
def _atan_unit(t: float) -> float:
    """:func:`pyautonomousagent.arrays._atan_unit` (the array path), one number."""
    big = 1.0 if t > _TAN_PI_12 else 0.0
    u = big * ((t * _SQRT3 - 1.0) / (t + _SQRT3)) + (1.0 - big) * t
    z = u * u
    c = _SERIES  # Horner's rule, innermost first, as the loop of the array path (no loop here)
    total = (((((((((((((((z * c[15] + c[14]) * z + c[13]) * z + c[12]) * z + c[11]) * z
        + c[10]) * z + c[9]) * z + c[8]) * z + c[7]) * z + c[6]) * z + c[5]) * z + c[4]) * z
        + c[3]) * z + c[2]) * z + c[1]) * z + c[0])  # fmt: skip
    return (math.pi / 6.0) * big + u * total


@njit(inline="always")
def arctan2(y: float, x: float) -> float:
    """:func:`pyautonomousagent.arrays.arctan2`, operation for operation, radians."""
    ay, ax = abs(y), abs(x)
    steep = 1.0 if ay > ax else 0.0
    high = np_maximum(ay, ax)
    angle = _atan_unit(np_minimum(ay, ax) / (high + (1.0 if high == 0.0 else 0.0)))
    angle = (math.pi / 2.0) * steep + (1.0 - 2.0 * steep) * angle
    west = 1.0 - math.copysign(1.0, x)
    angle = (math.pi / 2.0) * west + (1.0 - west) * angle
    return math.copysign(angle, y)


@njit(inline="always")
def hypot(dx: float, dy: float) -> float:
    """:func:`pyautonomousagent.arrays.hypot` of one pair: ``sqrt(dx * dx + dy * dy)``."""
    return math.sqrt(dx * dx + dy * dy)


@njit(inline="always")
def bearing(x: float, y: float, to_x: float, to_y: float) -> float:
    """:func:`pyautonomousagent.arrays.bearing` of one agent: degrees clockwise from north,
    [0, 360)."""
    return wrap_degrees(arctan2(to_x - x, to_y - y) * (180.0 / math.pi))


#: :func:`pyautonomousagent.arrays.sincos_degrees` of one angle in [0, 360) degrees: the
#: scalar path's own function (``arrays._sincos_float``) compiled, so the same operations in
#: the same order: (sine, cosine).
sincos_degrees = njit(inline="always")(_sincos_float)
