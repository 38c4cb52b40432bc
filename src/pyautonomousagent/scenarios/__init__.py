"""Named scenarios, each described by a validated YAML file.

``load("gathering")`` reads the packaged ``gathering.yaml``; ``load("my.yaml")`` reads a
file of one's own. :func:`register` adds a name. A scenario's ``tree`` names a tree file
(``gathering.xml``), found next to the scenario file (else among the packaged tree files),
or a built-in tree name.
"""

from __future__ import annotations

import difflib
from importlib import resources
from pathlib import Path

from pyautonomousagent.bt.files import is_tree_file
from pyautonomousagent.inputs import InputError, load_yaml, read_text, shown
from pyautonomousagent.simulation.scenario import Scenario, ScenarioError

_PACKAGED = resources.files(__name__)
REGISTRY: dict[str, Path] = {
    "gathering": Path(str(_PACKAGED / "gathering.yaml")),
    "patrol": Path(str(_PACKAGED / "patrol.yaml")),
    "x8-patrol": Path(str(_PACKAGED / "x8-patrol.yaml")),
}


def register(name: str, path: str | Path) -> None:
    """Make the scenario file ``path`` loadable as ``name``."""
    REGISTRY[name] = Path(path)


def names() -> list[str]:
    """The registered scenario names."""
    return list(REGISTRY)


def load(name_or_path: str | Path) -> Scenario:
    """A registered scenario by name, or a scenario YAML file by path.

    Raises:
        ScenarioError: unknown name, unreadable file, bad YAML, or bad fields.
    """
    key = str(name_or_path)
    if key in REGISTRY:
        path = REGISTRY[key]
    elif key.endswith((".yaml", ".yml")):
        path = Path(key)
    else:
        close = difflib.get_close_matches(key, names(), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ScenarioError(
            f"unknown scenario {shown(key)}{hint}; known: {', '.join(names())} "
            "(or give a scenario file ending in .yaml)"
        )
    try:
        data = load_yaml(read_text(path, "scenario file"), str(path))
    except InputError as error:
        raise ScenarioError(str(error)) from None
    if isinstance(data, dict) and isinstance(data.get("tree"), str) and is_tree_file(data["tree"]):
        data["tree"] = str(tree_path(data["tree"], path.parent))
    return Scenario.from_mapping(data, source=str(path.name))


def tree_path(tree: str, folder: Path) -> Path:
    """A scenario's tree file: relative to the scenario's ``folder``, else a packaged tree
    file of that name (so a copy of ``gathering.yaml`` still finds ``gathering.xml``)."""
    path = folder / tree
    packaged = Path(str(_PACKAGED / tree))
    if not path.exists() and not Path(tree).is_absolute() and packaged.is_file():
        return packaged
    return path
