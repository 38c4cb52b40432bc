"""Declared, typed parameters and the checked reading of scenario values.

A mission, a motion model and the core each declare their parameters as :class:`Param`
records (type, default, unit, range, meaning). A scenario's ``parameters:`` mapping is checked
against them by :class:`Reader`, which names the field in every error, and the result is a
:class:`Values` (read-only attributes: ``values.low_energy_threshold``).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

from pyautonomousagent.inputs import InputError


class ScenarioError(InputError):
    """Bad scenario input; the message names the field and what it must be."""


Point = tuple[float, float]
#: The largest whole number a scenario may give (2**53: every smaller one is a float exactly,
#: and it fits the 64-bit integers of the swarm's arrays).
MAX_WHOLE = 2**53


@dataclass(frozen=True)
class Param:
    """One parameter: leaf ports take their defaults from parameters of the same name.

    Attributes:
        name: the key in a scenario's ``parameters:`` and in ``--set NAME=VALUE``.
        default: the value when the scenario does not give one; its type (float, int, str,
            bool) is the parameter's type.
        unit: e.g. ``"percent"``, ``"world units per iteration"``; "" for none.
        doc: what it means.
        minimum, maximum: the allowed range of a number (inclusive), or None.
    """

    name: str
    default: Any
    unit: str = ""
    doc: str = ""
    minimum: float | None = None
    maximum: float | None = None

    @property
    def type(self) -> type:
        """float, int, str or bool: the type of the default."""
        return type(self.default)


class Values(SimpleNamespace):
    """Read-only named values (``values.energy_use``); ``vars(values)`` is a plain dict."""

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError(f"parameters are read-only; use with_overrides({key}=...)")

    def __getattr__(self, key: str) -> Any:
        if key.startswith("__"):
            raise AttributeError(key)
        close = difflib.get_close_matches(key, list(vars(self)), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise AttributeError(f"no parameter {key!r}{hint}")


def plain(value: Any) -> Any:
    """A validated value as plain YAML data: dataclasses as mappings, tuples as lists."""
    if isinstance(value, Values):
        return {k: plain(v) for k, v in vars(value).items()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    return value


def shown(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters, for error messages."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class Reader:
    """Checks one field at a time, naming it (and ``source``, the file) in every error."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, must: str, value: Any) -> ScenarioError:
        """The error for field ``path`` that must be ``must`` but is ``value``."""
        return ScenarioError(f"{self.source}: {path} must be {must}, got {shown(value)}")

    def keys(self, data: Any, path: str, allowed: list[str], required: list[str]) -> dict[str, Any]:
        """``data`` as a dict, refusing unknown keys (with a suggestion) and missing ones."""
        if not isinstance(data, Mapping):
            raise self.fail(path or "the file", "a mapping of keys to values", data)
        for key in data:
            if key not in allowed:
                close = difflib.get_close_matches(str(key), allowed, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                where = f"{path}.{key}" if path else str(key)
                raise ScenarioError(f"{self.source}: unknown key {shown(where)}{hint}")
        for key in required:
            if key not in data:
                where = f"{path}.{key}" if path else key
                raise ScenarioError(f"{self.source}: missing key {where!r}")
        return dict(data)

    def number(
        self,
        value: Any,
        path: str,
        kind: type = float,
        minimum: float | None = None,
        above: float | None = None,
        maximum: float | None = None,
    ) -> Any:
        """A finite number of type ``kind`` (int or float) within the given bounds (a whole
        number at most :data:`MAX_WHOLE` in size)."""
        whole = kind is int
        must = "a whole number" if whole else "a number"
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(path, must, value)
        if isinstance(value, float) and not math.isfinite(value):
            raise self.fail(path, f"a finite {must[2:]}", value)
        limit = MAX_WHOLE if whole else sys.float_info.max
        if abs(value) > limit:  # exact for ints of any size: no overflow
            raise self.fail(path, f"{must} between -{limit:g} and {limit:g}", value)
        if whole and float(value) != int(value):
            raise self.fail(path, must, value)
        if minimum is not None and value < minimum:
            raise self.fail(path, f"{must} >= {minimum:g}", value)
        if above is not None and value <= above:
            raise self.fail(path, f"{must} > {above:g}", value)
        if maximum is not None and value > maximum:
            raise self.fail(path, f"{must} <= {maximum:g}", value)
        return kind(value)

    def text(self, value: Any, path: str) -> str:
        """A non-empty string."""
        if not isinstance(value, str) or not value:
            raise self.fail(path, "a non-empty string", value)
        return value

    def flag(self, value: Any, path: str) -> bool:
        """true or false."""
        if not isinstance(value, bool):
            raise self.fail(path, "true or false", value)
        return value

    def point(self, value: Any, path: str) -> Point:
        """A pair [x, y] of finite numbers."""
        if not isinstance(value, list | tuple) or len(value) != 2:
            raise self.fail(path, "a pair [x, y]", value)
        return (self.number(value[0], f"{path}[0]"), self.number(value[1], f"{path}[1]"))

    def points(
        self, value: Any, path: str, least: int = 1, most: int | None = None
    ) -> tuple[Point, ...]:
        """A list of ``least``..``most`` pairs [x, y]."""
        if (
            not isinstance(value, list | tuple)
            or len(value) < least
            or (most and len(value) > most)
        ):
            count = f"exactly {least}" if least == most else f"at least {least}"
            raise self.fail(path, f"a list of {count} [x, y] pairs", value)
        return tuple(self.point(p, f"{path}[{i}]") for i, p in enumerate(value))

    def param(self, param: Param, value: Any, path: str) -> Any:
        """``value`` checked against ``param``'s type and range."""
        if param.type is str:
            return self.text(value, path)
        if param.type is bool:
            return self.flag(value, path)
        return self.number(value, path, param.type, param.minimum, maximum=param.maximum)

    def params(self, data: Any, params: Iterable[Param], path: str = "parameters") -> Values:
        """A ``parameters:`` mapping checked against ``params``; defaults for missing keys."""
        declared = {p.name: p for p in params}
        given = self.keys(data if data is not None else {}, path, list(declared), [])
        values = {name: p.default for name, p in declared.items()}
        for key, value in given.items():
            values[key] = self.param(declared[key], value, f"{path}.{key}")
        return Values(**values)
