"""Named scenarios, each described by a validated YAML file.

``load("gathering")`` reads the registered ``gathering.yaml`` (the built-in missions register
theirs, see :mod:`pyautonomousagent.missions`); ``load("my.yaml")`` reads a file of one's
own. :func:`register` adds a name. A scenario's ``tree`` names a tree file (``gathering.xml``),
found next to the scenario file (else next to a registered scenario file), or a built-in tree
name; its ``mission`` may name a Python file next to it.
"""

from __future__ import annotations

from pathlib import Path

from pyautonomousagent.bt.files import is_tree_file
from pyautonomousagent.inputs import InputError, load_yaml, read_text
from pyautonomousagent.registry import Registry
from pyautonomousagent.simulation.scenario import Scenario, ScenarioError

SCENARIOS: Registry[Path] = Registry("scenario")


def register(name: str, path: str | Path) -> None:
    """Make the scenario file ``path`` loadable as ``name``."""
    SCENARIOS.register(name, Path(path), replace=True)


def names() -> list[str]:
    """The registered scenario names."""
    return SCENARIOS.names()


def load(name_or_path: str | Path) -> Scenario:
    """A registered scenario by name, or a scenario YAML file by path.

    Raises:
        ScenarioError: unknown name, unreadable file, bad YAML, or bad fields.
    """
    key = str(name_or_path)
    if key in SCENARIOS:
        path = SCENARIOS.get(key)
    elif key.endswith((".yaml", ".yml")):
        path = Path(key)
    else:
        raise ScenarioError(
            SCENARIOS.unknown_message(key) + "; or give a scenario file "
            "(.yaml); `pyaa scenarios` lists them"
        )
    try:
        data = load_yaml(read_text(path, "scenario file"), str(path))
    except InputError as error:
        raise ScenarioError(str(error)) from None
    if isinstance(data, dict) and isinstance(data.get("tree"), str) and is_tree_file(data["tree"]):
        data["tree"] = str(tree_path(data["tree"], path.parent))
    return Scenario.from_mapping(data, source=str(path.name), folder=path.parent.resolve())


def tree_path(tree: str, folder: Path) -> Path:
    """A scenario's tree file: relative to the scenario's ``folder``, else a file of that name
    next to a registered scenario (so a copy of ``gathering.yaml`` still finds
    ``gathering.xml``)."""
    path = folder / tree
    if path.exists() or Path(tree).is_absolute():
        return path
    for known in SCENARIOS.values():
        if (known.parent / tree).is_file():
            return known.parent / tree
    return path
