"""Generated modules: written once to a cache folder under a name that hashes their source,
then imported (numba's cache keeps their compiled functions beside them)."""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
from pathlib import Path
from types import ModuleType


def cache_folder() -> Path:
    """Where generated modules are kept: ``$PYAA_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/pyautonomousagent/compiled`` (``~/.cache`` by default)."""
    if os.environ.get("PYAA_CACHE_DIR"):
        return Path(os.environ["PYAA_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pyautonomousagent" / "compiled"


def module_name(source: str) -> str:
    """The name of generated ``source``'s module: a hash of it and of the files of the
    modules it imports from (numba's cache checks only the generated file, so a changed
    kernel must give a new name)."""
    digest = hashlib.sha256(source.encode())
    for module in sorted(set(re.findall(r"^from (\S+) import", source, re.MULTILINE))):
        spec = importlib.util.find_spec(module)
        if spec is not None and spec.origin and os.path.isfile(spec.origin):
            digest.update(Path(spec.origin).read_bytes())
    return "pyaa_tree_" + digest.hexdigest()[:24]


def load_source(source: str) -> ModuleType:
    """Import generated ``source`` as a module from a file named by :func:`module_name`
    (written once; numba caches the compiled functions beside it)."""
    name = module_name(source)
    if name in sys.modules:
        return sys.modules[name]
    folder = cache_folder()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.py"
    if not path.exists():
        temporary = folder / f"{name}.{os.getpid()}.tmp"
        temporary.write_text(source)
        temporary.replace(path)
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
