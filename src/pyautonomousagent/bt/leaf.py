"""What a leaf node is, independent of any engine, and the registry of leaf types.

A leaf type is a subclass of :class:`Leaf` registered under the paper's class name (e.g.
``"Condition_Low_Energy_Level"``). Its :meth:`Leaf.evaluate` is written with array
expressions against an :class:`~pyautonomousagent.state.AgentView`: called for one agent
it sees plain numbers, called for a batch it sees arrays. Both engines call the same
method, so they cannot drift apart.
"""

from __future__ import annotations

import math
from collections.abc import Container, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from pyautonomousagent.bt.spec import BlackboardRef, Node, TreeError, check_structure
from pyautonomousagent.inputs import shown
from pyautonomousagent.kernels import LeafKernel
from pyautonomousagent.randomness import stream_key
from pyautonomousagent.registry import Registry, UnknownNameError
from pyautonomousagent.state import AgentView, Swarm
from pyautonomousagent.world import World


@dataclass(frozen=True)
class Port:
    """A leaf parameter.

    Attributes:
        name: the parameter's name in a tree description or file.
        type: float, int or str; a value is converted to it (bools are refused for numbers).
        default: the scenario parameter that supplies the value when the tree does not.
        minimum: the smallest value allowed (numbers only), or None.
        doc: what the parameter means, with its unit.
    """

    name: str
    type: type
    default: str
    minimum: float | None = None
    doc: str = ""

    def parse(self, value: Any, where: str) -> Any:
        """Like :meth:`convert`, but a number port also takes text (an XML attribute)."""
        if isinstance(value, str) and self.type is not str:
            text = value.strip()
            try:
                value = int(text) if self.type is int else float(text)
            except ValueError:
                kind = "a whole number" if self.type is int else "a number"
                raise LeafError(
                    f"{where}: port {self.name!r} must be {kind}, got {shown(text)}"
                ) from None
            if value != value or value in (float("inf"), float("-inf")):
                raise LeafError(
                    f"{where}: port {self.name!r} must be a finite number, got {text!r}"
                )
        return self.convert(value, where)

    def hint(self) -> str:
        """What a good value looks like, for error messages: ``a number >= 0``."""
        kind = {str: "text", int: "a whole number", float: "a number"}[self.type]
        return kind + (f" >= {self.minimum:g}" if self.minimum is not None else "")

    def convert(self, value: Any, where: str) -> Any:
        """``value`` as this port's type; LeafError naming ``where`` if it is not one."""
        if self.type is str:
            if not isinstance(value, str):
                raise LeafError(f"{where}: port {self.name!r} must be a string, got {shown(value)}")
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise LeafError(f"{where}: port {self.name!r} must be a number, got {shown(value)}")
        if not math.isfinite(value):
            raise LeafError(
                f"{where}: port {self.name!r} must be a finite number, got {shown(value)}"
            )
        if self.type is int and float(value) != int(value):
            raise LeafError(f"{where}: port {self.name!r} must be a whole number, got {value!r}")
        converted = self.type(value)
        if self.minimum is not None and converted < self.minimum:
            raise LeafError(f"{where}: port {self.name!r} must be >= {self.minimum}, got {value!r}")
        return converted


class LeafError(ValueError):
    """A leaf that cannot be made: unknown type, unknown port or bad value."""


class Leaf:
    """Base class of the leaf library.

    Subclasses set :attr:`type_name`, :attr:`ports`, :attr:`keys` (the blackboard keys
    they use) and implement :meth:`evaluate`. Port values become attributes; :attr:`stream`
    keys the leaf's random numbers (:meth:`uniform`) and is set from the node's name.
    """

    type_name: ClassVar[str]
    ports: ClassVar[tuple[Port, ...]] = ()
    #: True for leaves whose ports are text they read themselves (``{key}`` included).
    text_ports: ClassVar[bool] = False
    keys: ClassVar[tuple[str, ...]] = ()
    stream: int = 0

    def __init__(self, **values: Any) -> None:
        for name, value in values.items():
            setattr(self, name, value)

    @classmethod
    def create(cls, params: Mapping[str, Any], defaults: Mapping[str, Any], where: str) -> Leaf:
        """An instance with ports from ``params``, else from the scenario's ``defaults``.

        Raises:
            LeafError: an unknown port (with the known ones), a bad value, or a default
                the scenario lacks.
        """
        known = {p.name: p for p in cls.ports}
        unknown = sorted(set(params) - set(known))
        if unknown:
            raise LeafError(
                f"{where}: unknown port(s) {unknown}; {cls.type_name} has {sorted(known)}"
            )
        values = {}
        for port in cls.ports:
            if port.name in params:
                raw = params[port.name]
            elif port.default in defaults:
                raw = defaults[port.default]
            else:
                raise LeafError(f"{where}: port {port.name!r} has no value and no default")
            values[port.name] = port.convert(raw, where)
        return cls(**values)

    @classmethod
    def summary(cls) -> str:
        """The first line of the class's docstring, ``...`` marks dropped ("" for none)."""
        return (cls.__doc__ or "").strip().split("\n", 1)[0].strip().replace("``", "")

    @classmethod
    def required_ports(cls) -> list[str]:
        """The ports a tree must give (the others default to the scenario's parameters)."""
        return []

    @classmethod
    def port_names(cls) -> list[str]:
        """The names of the ports a tree may set."""
        return [p.name for p in cls.ports]

    @classmethod
    def parse_port(cls, name: str, value: Any, where: str) -> Any:
        """A port value from a tree file (XML text or a YAML value) as the port's type.

        Raises:
            LeafError: the value does not fit the port.
        """
        port = {p.name: p for p in cls.ports}[name]
        return port.parse(value, where)

    @classmethod
    def port_hint(cls, name: str) -> str:
        """What a good value of port ``name`` looks like (for error messages)."""
        return {p.name: p for p in cls.ports}[name].hint()

    def evaluate(self, agents: AgentView, world: World) -> Any:
        """Run the leaf for ``agents``; return a status code, or an int8 array of them."""
        raise NotImplementedError

    def halt(self, agents: AgentView, world: World) -> None:
        """Called when the leaf is interrupted while RUNNING (BehaviorTree.CPP's
        ``onHalted``) for ``agents``; by default it does nothing."""

    def kernel(self, world: World) -> LeafKernel | None:
        """The leaf's per-agent form for the compiled engine, or None (the default: a tree
        with this leaf runs on the batched engine). See :mod:`pyautonomousagent.kernels`."""
        return None

    def broadcast(
        self, agents: AgentView, world: World, kind: str, data: Mapping[str, Any]
    ) -> None:
        """Each agent of the view sends everyone a message of type ``kind`` from where it is.

        Args:
            agents: the senders (one agent or a group).
            world: the world (its datalink).
            kind: a message type of the mission (``MessageType.name``).
            data: payload name -> a number, or a value per agent in view shape.
        """
        if agents.one:  # plain numbers: one message costs no arrays until delivery
            world.datalink.send(int(agents.index), kind, data, (agents.x, agents.y))
            return
        payload = {k: agents.compact(v) for k, v in data.items()}
        position = (agents.compact(agents.x), agents.compact(agents.y))
        world.datalink.send(agents.indices, kind, payload, position)

    def uniform(
        self, agents: AgentView, world: World, low: float = 0.0, high: float = 1.0, draw: int = 0
    ) -> Any:
        """Uniform random numbers in [low, high), one per agent of the view (view shape).

        An agent draws the same number at an iteration whichever engine ticks it: the
        number is keyed by the run's seed, this node (:attr:`stream`), the agent, the
        iteration and ``draw`` (use 0, 1, ... for several draws in one tick).
        """
        return world.random.uniform(self.stream, agents.rows, world.iteration, low, high, draw)

    def __repr__(self) -> str:
        params = ", ".join(f"{p.name}={getattr(self, p.name)!r}" for p in self.ports)
        return f"{type(self).__name__}({params})"


class BlackboardPorts(Leaf):
    """A leaf with ports written ``{key}``: before each tick, each such port is set to the
    agent's (or group's, per agent) blackboard entry, then the leaf runs."""

    type_name = "BlackboardPorts"
    inner: Leaf
    refs: dict[str, str]

    def __init__(self, inner: Leaf, refs: Mapping[str, str]) -> None:
        super().__init__(inner=inner, refs=dict(refs))
        self.keys = (*inner.keys, *refs.values())  # type: ignore[misc]

    @classmethod
    def around(
        cls,
        leaf_cls: type[Leaf],
        params: Mapping[str, Any],
        refs: Mapping[str, str],
        defaults: Mapping[str, Any],
        where: str,
    ) -> BlackboardPorts:
        """``leaf_cls`` made with placeholders for the ``{key}`` ports, wrapped."""
        ports = {p.name: p for p in leaf_cls.ports}
        values = dict(params)
        for name in refs:
            port = ports.get(name)
            if port is None:
                raise LeafError(f"{where}: unknown port {name!r}")
            values[name] = defaults.get(port.default, port.minimum or port.type())
        return cls(leaf_cls.create(values, defaults, where), refs)

    def evaluate(self, agents: AgentView, world: World) -> Any:
        for name, key in self.refs.items():
            setattr(self.inner, name, getattr(agents.blackboard, key))
        return self.inner.evaluate(agents, world)

    def halt(self, agents: AgentView, world: World) -> None:
        self.inner.halt(agents, world)

    def __repr__(self) -> str:
        return f"{self.inner!r} with {self.refs}"


LEAF_TYPES: Registry[type[Leaf]] = Registry("leaf type")

#: Leaf type names known to an engine only (hand-written py_trees behaviours, added by
#: ``register_behaviour``): tree files may use them, with their ports passed through as written.
ENGINE_LEAF_TYPES: set[str] = set()


def register_leaf(cls: type[Leaf]) -> type[Leaf]:
    """Class decorator: make ``cls`` available under ``cls.type_name`` in tree descriptions.

    Raises:
        TypeError: ``cls`` is no :class:`Leaf` subclass with a ``type_name``.
        ValueError: another class is registered under that name.
    """
    if not (isinstance(cls, type) and issubclass(cls, Leaf)) or not getattr(cls, "type_name", ""):
        raise TypeError(f"register_leaf takes a Leaf subclass with a type_name, got {cls!r}")
    return LEAF_TYPES.register(cls.type_name, cls)


def leaf_type(type_name: str) -> type[Leaf]:
    """The registered leaf class; LeafError with the closest known names if there is none."""
    try:
        return LEAF_TYPES.get(type_name)
    except UnknownNameError as error:
        raise LeafError(str(error)) from None


def make_leaf(node: Node, defaults: Mapping[str, Any]) -> Leaf:
    """The leaf instance for a leaf node, ports from the node or ``defaults``; TreeError if bad."""
    try:
        cls = leaf_type(node.type)
    except LeafError as error:
        raise TreeError(f"node {node.name!r}: {error}") from None
    where = f"leaf {node.name!r} ({node.type})"
    refs = {k: v.key for k, v in node.params.items() if isinstance(v, BlackboardRef)}
    made: Leaf
    try:
        if refs and not cls.text_ports:
            ported = BlackboardPorts.around(cls, node.params, refs, defaults, where)
            ported.inner.stream = stream_key(node.name)
            made = ported
        else:
            made = cls.create(node.params, defaults, where=where)
    except LeafError as error:
        raise TreeError(str(error)) from None
    made.stream = stream_key(node.name)
    return made


def check_leaves(
    tree: Node, swarm: Swarm, defaults: Mapping[str, Any], skip: Container[str] = ()
) -> None:
    """Raise TreeError for a bad structure, an unknown leaf type, bad ports, or a blackboard
    key the swarm lacks. Leaf types in ``skip`` (hand-written behaviours) are not checked."""
    check_structure(tree)
    for node in tree.leaves():
        if node.type in skip:
            continue
        leaf = make_leaf(node, defaults)
        missing = [k for k in leaf.keys if k not in swarm.blackboard]
        if missing:
            raise TreeError(f"leaf {node.name!r} ({node.type}) needs blackboard key(s) {missing}")
