"""The registry type: register, look up with "did you mean", unregister, scoped override."""

from __future__ import annotations

import pytest

from pyautonomousagent.registry import Registry, UnknownNameError


def test_register_get_unregister() -> None:
    reg: Registry[int] = Registry("number")
    assert reg.register("one", 1) == 1
    assert reg.get("one") == 1
    assert "one" in reg and len(reg) == 1 and reg.names() == ["one"]
    assert reg.unregister("one") == 1
    assert "one" not in reg


def test_unknown_name_suggests_close_names() -> None:
    reg: Registry[int] = Registry("number")
    reg.register("gathering", 1)
    reg.register("patrol", 2)
    with pytest.raises(UnknownNameError, match=r"'gatherin'; did you mean 'gathering'"):
        reg.get("gatherin")
    with pytest.raises(UnknownNameError, match=r"known: gathering, patrol"):
        reg.get("zzz")


def test_a_taken_name_is_refused_unless_replaced() -> None:
    reg: Registry[int] = Registry("number")
    reg.register("a", 1)
    with pytest.raises(ValueError, match="already registered"):
        reg.register("a", 2)
    reg.register("a", 2, replace=True)
    assert reg.get("a") == 2
    with pytest.raises(ValueError, match="non-empty name"):
        reg.register("", 3)


def test_override_restores_the_previous_entry_or_absence() -> None:
    reg: Registry[int] = Registry("number")
    reg.register("a", 1)
    with reg.override("a", 5), reg.override("b", 6):
        assert reg.get("a") == 5 and reg.get("b") == 6
    assert reg.get("a") == 1 and "b" not in reg
    with pytest.raises(RuntimeError), reg.override("c", 7):
        raise RuntimeError
    assert "c" not in reg


def test_scoped_restores_everything() -> None:
    reg: Registry[int] = Registry("number")
    reg.register("a", 1)
    with reg.scoped():
        reg.register("b", 2)
        reg.unregister("a")
        assert reg.names() == ["b"]
    assert reg.names() == ["a"] and reg.get("a") == 1
