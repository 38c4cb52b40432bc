"""Agent names ``PREFIX1`` to ``PREFIXN``, made when asked instead of held as N strings.

A list of 20 million names such as ``"drone12345678"`` takes about 1.4 GB of memory with
the dictionary that finds an agent's row by its name (about 70 bytes a string and 60 an
index entry); :class:`AgentNames` and :class:`AgentIndex` hold the prefix and the count.
"""

from __future__ import annotations

import operator
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, SupportsIndex, overload


class AgentNames(Sequence[str]):
    """The names ``f"{prefix}{i + 1}"`` of ``count`` agents, as a read-only sequence.

    Reads like the list it replaces: ``names[0] == "drone1"``, ``names.index("drone3") == 2``,
    ``"drone9" in names``, and it equals a list of the same names.
    """

    def __init__(self, prefix: str, count: int) -> None:
        if count < 0:
            raise ValueError(f"count must be >= 0, got {count}")
        self.prefix, self.size = prefix, int(count)

    def __len__(self) -> int:
        return self.size

    @overload
    def __getitem__(self, index: SupportsIndex) -> str: ...

    @overload
    def __getitem__(self, index: slice) -> list[str]: ...

    def __getitem__(self, index: SupportsIndex | slice) -> str | list[str]:
        if isinstance(index, slice):
            return [f"{self.prefix}{i + 1}" for i in range(*index.indices(self.size))]
        i = operator.index(index)
        if i < 0:
            i += self.size
        if not 0 <= i < self.size:
            raise IndexError(f"agent index {operator.index(index)} out of range 0..{self.size - 1}")
        return f"{self.prefix}{i + 1}"

    def __iter__(self) -> Iterator[str]:
        return (f"{self.prefix}{i + 1}" for i in range(self.size))

    def position(self, name: object) -> int | None:
        """The row of the agent called ``name``, or None if no agent has that name."""
        if not isinstance(name, str) or not name.startswith(self.prefix):
            return None
        digits = name[len(self.prefix) :]
        if not (digits.isascii() and digits.isdigit()) or digits.startswith("0"):
            return None
        row = int(digits) - 1
        return row if row < self.size else None

    def __contains__(self, name: object) -> bool:
        return self.position(name) is not None

    def index(self, name: Any, start: int = 0, stop: int | None = None) -> int:
        """The row of the agent called ``name``; ValueError if there is none (in start..stop)."""
        row = self.position(name)
        if row is None or not start <= row < (self.size if stop is None else stop):
            raise ValueError(f"{name!r} is not in the agents' names")
        return row

    def __eq__(self, other: object) -> bool:
        if isinstance(other, AgentNames):
            return (self.prefix, self.size) == (other.prefix, other.size)
        if isinstance(other, Sequence) and not isinstance(other, str):
            return len(other) == self.size and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # equal to lists, so unhashable like them

    def __repr__(self) -> str:
        return f"AgentNames({self.prefix!r}, {self.size})"


class AgentIndex(Mapping[str, int]):
    """Agent name -> row, for :class:`AgentNames`, without a dictionary of N entries."""

    def __init__(self, names: AgentNames) -> None:
        self.names = names

    def __getitem__(self, name: str) -> int:
        row = self.names.position(name)
        if row is None:
            raise KeyError(name)
        return row

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)


def agent_index(names: Sequence[str]) -> Mapping[str, int]:
    """Agent name -> row: an :class:`AgentIndex` for :class:`AgentNames`, else a dict."""
    if isinstance(names, AgentNames):
        return AgentIndex(names)
    return {name: i for i, name in enumerate(names)}
