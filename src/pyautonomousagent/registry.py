"""One small registry type for everything users add by name: leaf types, missions, motion
models, engines and control node types are each kept in a :class:`Registry`."""

from __future__ import annotations

import difflib
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Generic, TypeVar

T = TypeVar("T")


class UnknownNameError(LookupError):
    """A name no entry of a registry has; the message lists the closest known names."""


class Registry(Generic[T]):
    """Named entries of one kind, e.g. ``Registry[type[Leaf]]("leaf type")``.

    Args:
        kind: what an entry is, for messages (``"unknown leaf type 'X'"``).
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, T] = {}

    def register(self, name: str, entry: T, *, replace: bool = False) -> T:
        """Add ``entry`` under ``name`` and return it.

        Raises:
            ValueError: ``name`` is taken by another entry and ``replace`` is False.
        """
        if not isinstance(name, str) or not name:
            raise ValueError(f"a {self.kind} needs a non-empty name, got {name!r}")
        old = self._entries.get(name)
        if old is not None and old is not entry and not replace:
            raise ValueError(
                f"{self.kind} {name!r} is already registered ({old!r}); unregister it first "
                "or pass replace=True"
            )
        self._entries[name] = entry
        return entry

    def get(self, name: str) -> T:
        """The entry called ``name``.

        Raises:
            UnknownNameError: no such entry; the message names the closest known ones.
        """
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise UnknownNameError(self.unknown_message(name)) from None

    def unknown_message(self, name: object) -> str:
        """``unknown leaf type 'X'; did you mean 'Y'? (known: ...)``."""
        text = str(name)[:80]
        close = difflib.get_close_matches(text, list(self._entries), n=3)
        hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        known = ", ".join(self._entries) if len(self._entries) <= 12 else ""
        listing = f" (known: {known})" if known and not close else ""
        return f"unknown {self.kind} {text!r}{hint}{listing}"

    def unregister(self, name: str) -> T:
        """Remove and return the entry called ``name`` (UnknownNameError if there is none)."""
        entry = self.get(name)
        del self._entries[name]
        return entry

    @contextmanager
    def override(self, name: str, entry: T) -> Iterator[T]:
        """Within the block, ``name`` is ``entry``; afterwards the registry is as before."""
        missing = object()
        old = self._entries.get(name, missing)
        self._entries[name] = entry
        try:
            yield entry
        finally:
            if old is missing:
                self._entries.pop(name, None)
            else:
                self._entries[name] = old  # type: ignore[assignment]

    @contextmanager
    def scoped(self) -> Iterator[Registry[T]]:
        """Within the block, register and unregister freely; afterwards the registry holds
        exactly what it held before (what a test registers, it removes)."""
        saved = dict(self._entries)
        try:
            yield self
        finally:
            self._entries.clear()
            self._entries.update(saved)

    def names(self) -> list[str]:
        """The registered names, in order of registration."""
        return list(self._entries)

    def items(self) -> list[tuple[str, T]]:
        """(name, entry) pairs, in order of registration."""
        return list(self._entries.items())

    def values(self) -> list[T]:
        """The entries, in order of registration."""
        return list(self._entries.values())

    def __getitem__(self, name: str) -> T:
        return self.get(name)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._entries  # a list from a file: False

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {len(self)} entries)"
