"""BehaviorTree.CPP's built-in leaves that read and write the blackboard, and ``Sleep``.

- ``Script code="..."``: runs a script (:mod:`pyautonomousagent.bt.script`); SUCCESS.
- ``ScriptCondition code="..."``: SUCCESS where the expression holds, else FAILURE.
- ``SetBlackboard output_key="key" value="..."``: writes ``value`` (a number, true/false,
  ``{other_key}`` for a copy, or any other text as an enum value) to ``key``; SUCCESS.
- ``Sleep msec="..."``: RUNNING until ``msec`` of simulated time has passed (one iteration
  is the scenario's ``time_step`` seconds, 1 if it has none), then SUCCESS.

Each agent runs them on its own blackboard row; the batched engine runs them once for all the
agents a tick reaches, as array expressions. The entries they write are declared by the tree
(:func:`declared_keys`) and created with the swarm, so they are recorded like the others.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.bt.leaf import Leaf, LeafError, register_leaf
from pyautonomousagent.bt.script import DTYPES, Script, ScriptError, literal, parse, widest
from pyautonomousagent.bt.status import RUNNING, SUCCESS, success_if
from pyautonomousagent.state import AgentView
from pyautonomousagent.world import World


class _PortsByName(Leaf):
    """A leaf whose ports are text checked by :meth:`check`, not :class:`Port` records."""

    names: ClassVar[tuple[str, ...]] = ()
    hints: ClassVar[Mapping[str, str]] = {}
    text_ports = True

    @classmethod
    def port_names(cls) -> list[str]:
        return list(cls.names)

    @classmethod
    def port_hint(cls, name: str) -> str:
        return cls.hints.get(name, "text")

    @classmethod
    def required_ports(cls) -> list[str]:
        return list(cls.names)

    @classmethod
    def parse_port(cls, name: str, value: Any, where: str) -> Any:
        text = value if isinstance(value, str) else _literal_text(value)
        cls.check(name, text, where)
        return text

    @classmethod
    def check(cls, name: str, text: str, where: str) -> None:
        """LeafError if ``text`` is no good value of port ``name``."""

    @classmethod
    def create(cls, params: Mapping[str, Any], defaults: Mapping[str, Any], where: str) -> Leaf:
        missing = [n for n in cls.names if n not in params]
        unknown = sorted(set(params) - set(cls.names))
        if missing or unknown:
            raise LeafError(
                f"{where}: {cls.type_name} takes the port(s) {list(cls.names)}"
                + (f"; missing {missing}" if missing else f"; unknown {unknown}")
            )
        for name in cls.names:
            cls.check(name, _literal_text(params[name]), where)
        return cls._make({n: _literal_text(params[n]) for n in cls.names}, defaults)

    @classmethod
    def _make(cls, ports: dict[str, str], defaults: Mapping[str, Any]) -> Leaf:
        raise NotImplementedError

    @classmethod
    def declared(cls, params: Mapping[str, Any], known: dict[str, str]) -> dict[str, str]:
        """Blackboard key -> type name ("bool", "int", "float") of the entries it writes."""
        return {}


def _literal_text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


class _ScriptLeaf(_PortsByName):
    names = ("code",)
    hints = {"code": "a script, e.g. laps := laps + 1"}
    script: Script

    @classmethod
    def check(cls, name: str, text: str, where: str) -> None:
        try:
            parse(text)
        except ScriptError as error:
            raise LeafError(f"{where}: port {name!r}: {error}") from None

    @classmethod
    def _make(cls, ports: dict[str, str], defaults: Mapping[str, Any]) -> Leaf:
        script = parse(ports["code"])
        leaf = cls(script=script)
        leaf.keys = tuple(sorted(script.reads() | set(script.assigned({}))))  # type: ignore[misc]
        return leaf

    @classmethod
    def declared(cls, params: Mapping[str, Any], known: dict[str, str]) -> dict[str, str]:
        if "code" not in params:
            return {}  # create() names the missing port
        return parse(_literal_text(params["code"])).assigned(known)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(code={self.script.code!r})"


@register_leaf
class ScriptAction(_ScriptLeaf):
    """BT.CPP ``Script``: runs the script on the agent's blackboard; SUCCESS."""

    type_name = "Script"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        self.script.run(agents.blackboard)
        return SUCCESS


@register_leaf
class ScriptCondition(_ScriptLeaf):
    """BT.CPP ``ScriptCondition``: SUCCESS where the script's value holds, else FAILURE."""

    type_name = "ScriptCondition"

    def evaluate(self, agents: AgentView, world: World) -> Any:
        return success_if(self.script.truth(agents.blackboard))


@register_leaf
class SetBlackboard(_PortsByName):
    """BT.CPP ``SetBlackboard``: writes ``value`` to the entry ``output_key``; SUCCESS."""

    type_name = "SetBlackboard"
    names = ("output_key", "value")
    hints = {
        "output_key": "a blackboard key, e.g. laps",
        "value": "a number, true/false, {other_key} or a word (an enum value)",
    }
    output_key: str
    value: Any
    kind: str

    @classmethod
    def check(cls, name: str, text: str, where: str) -> None:
        if name == "output_key" and not text.isidentifier():
            raise LeafError(
                f"{where}: output_key must be a key name (letters, digits, _), got {text!r}"
            )

    @classmethod
    def _make(cls, ports: dict[str, str], defaults: Mapping[str, Any]) -> Leaf:
        value, kind = literal(ports["value"])
        leaf = cls(output_key=ports["output_key"], value=value, kind=kind)
        reads = (value,) if kind == "key" else ()
        leaf.keys = (ports["output_key"], *reads)  # type: ignore[misc]
        return leaf

    @classmethod
    def declared(cls, params: Mapping[str, Any], known: dict[str, str]) -> dict[str, str]:
        if "value" not in params or "output_key" not in params:
            return {}  # create() names the missing port
        value, kind = literal(_literal_text(params["value"]))
        kind = known.get(value, "float") if kind == "key" else kind
        key = _literal_text(params["output_key"])
        return {key: widest(kind, known.get(key, kind))}

    def evaluate(self, agents: AgentView, world: World) -> Any:
        board = agents.blackboard
        value = getattr(board, self.value) if self.kind == "key" else self.value
        setattr(board, self.output_key, value)
        return SUCCESS

    def __repr__(self) -> str:
        return f"SetBlackboard(output_key={self.output_key!r}, value={self.value!r})"


def time_step(defaults: Mapping[str, Any]) -> float:
    """The scenario's time step, seconds (``time_step``, 1 where not given)."""
    return float(defaults.get("time_step", 1.0))


def iterations(msec: float, defaults: Mapping[str, Any]) -> int:
    """Simulated milliseconds as whole iterations (rounded up) of ``time_step`` seconds."""
    return max(0, math.ceil(msec / (1000.0 * time_step(defaults)) - 1e-9))


@register_leaf
class Sleep(_PortsByName):
    """BT.CPP ``Sleep``: RUNNING for ``msec`` of simulated time, then SUCCESS."""

    type_name = "Sleep"
    names = ("msec",)
    hints = {"msec": "a whole number of milliseconds >= 0"}
    ticks: int
    deadline: np.ndarray | None = None

    @classmethod
    def check(cls, name: str, text: str, where: str) -> None:
        if not text.strip().isdigit():
            raise LeafError(f"{where}: msec must be a whole number >= 0, got {text!r}")

    @classmethod
    def _make(cls, ports: dict[str, str], defaults: Mapping[str, Any]) -> Leaf:
        return cls(ticks=iterations(int(ports["msec"]), defaults))

    def _deadlines(self, agents: AgentView) -> np.ndarray:
        if self.deadline is None:
            self.deadline = np.zeros(agents.swarm.size, dtype=np.int64)  # 0: not sleeping
        return self.deadline

    def evaluate(self, agents: AgentView, world: World) -> Any:
        deadline = self._deadlines(agents)
        rows = agents.indices
        start = deadline[rows] == 0
        deadline[rows] = np.where(start, world.iteration + self.ticks, deadline[rows])
        awake = deadline[rows] <= world.iteration
        deadline[rows] = np.where(awake, 0, deadline[rows])
        result = np.where(awake, SUCCESS, RUNNING).astype(np.int8)
        if agents.is_one:
            return int(result[0])
        if agents.masked:
            full = np.full(agents.swarm.size, RUNNING, dtype=np.int8)
            full[rows] = result
            return full
        return result

    def halt(self, agents: AgentView, world: World) -> None:
        self._deadlines(agents)[agents.indices] = 0


def declared_keys(
    leaf_type: type[Leaf], params: Mapping[str, Any], known: dict[str, str]
) -> dict[str, str]:
    """The entries a leaf of ``leaf_type`` with ``params`` writes: key -> type name."""
    if issubclass(leaf_type, _PortsByName):
        return leaf_type.declared(params, known)
    return {}


__all__ = ["DTYPES", "ScriptAction", "ScriptCondition", "SetBlackboard", "Sleep", "declared_keys"]
