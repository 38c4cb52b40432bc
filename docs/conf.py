"""Sphinx configuration of the documentation site (``make docs``; see docs/about-this-site.md).

The site is built by ``scripts/build_docs.py``, which stages this folder beside the README,
puts the executed lessons in ``lessons/`` and runs ``sphinx-build -W`` (warnings are errors).
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from pathlib import Path

from docutils import nodes
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment

#: The repository: the package is documented from its source, not from an installed copy.
ROOT = Path(os.environ.get("PYAA_REPO", Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(ROOT / "src"))

from pyautonomousagent import __version__  # noqa: E402

project = "pyAutonomousAgent"
author = "pyAutonomousAgent contributors"
copyright = "pyAutonomousAgent contributors, MIT licence"  # noqa: A001
release = __version__

extensions = [
    "myst_nb",  # Markdown pages (MyST) and notebooks with their stored outputs
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",  # the Args:/Returns: sections some docstrings use
]

# Pages: the Markdown in this folder, the lessons (notebooks) and the generated API pages.
# The API pages are reST (automodule), the others Markdown (MyST) and notebooks.
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "README.md", "**/.ipynb_checkpoints"]
root_doc = "index"

# MyST: heading anchors as GitHub makes them, so the links docs/*.md use on GitHub
# (page.md#some-heading) work on the site too.
myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence", "deflist"]

# Notebooks are rendered with the outputs they hold: the build script gives executed copies
# (executing them is the build script's job, once; see scripts/build_docs.py).
nb_execution_mode = "off"
nb_merge_streams = True

# API reference from the docstrings (reST roles, some Google-style sections); the build
# script writes one page per module into api/.
# A module documents what it defines: the names a package re-exports (its __all__) are
# documented once, in the module that defines them.
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_member_order = "bysource"
# Type hints in the signatures: as fields ("description") Sphinx would look their names up
# fuzzily (``type`` would find every attribute called type).
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# "Attributes:" as fields of the class (not a second description of each attribute), and the
# "Class attributes:" sections of the mission classes read the same way.
napoleon_use_ivar = True
napoleon_attr_annotations = False
napoleon_custom_sections = [("Class attributes", "Attributes")]

html_theme = "pydata_sphinx_theme"
html_title = "pyAutonomousAgent"
html_static_path: list[str] = []
#: Pages that embed a replay (``lessons.embedded_replay``): without the right-hand "On this
#: page" column, the replay gets the content's full width (its map and side panels need about
#: 800 pixels side by side). Exact names: a second wildcard pattern would be a warning.
WIDE_PAGES = ["lessons/03_blackboard_and_datalink"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": {
        "**": ["page-toc", "edit-this-page", "sourcelink"],  # the theme's default
        **{page: [] for page in WIDE_PAGES},
    },
}
html_show_sourcelink = False
# Light or dark as the reader's system says (the theme's switch changes it); set, not left
# empty, so the theme's script has a mode to start from.
html_context = {"default_mode": "auto"}


def _exact_annotation_references(app: object, doctree: nodes.document) -> None:
    """Look the names in type annotations up exactly, not fuzzily.

    Sphinx 9 marks every annotation's reference ``refspecific`` (fuzzy: ``type`` would match
    any attribute called ``type`` and warn that it is ambiguous) even when it means not to
    (the flag's value is False, but the lookup tests whether it is present). Removing the
    false flags gives the exact lookup meant; unknown names (builtins) stay plain text.
    """
    for ref in doctree.findall(addnodes.pending_xref):
        if ref.get("refdomain") == "py" and "refspecific" in ref and not ref["refspecific"]:
            del ref["refspecific"]


def _exported_names(
    app: Sphinx, what: str, name: str, obj: object, options: object, lines: list[str]
) -> None:
    """A package's page lists the names it exports (its ``__all__``), each linked to the
    module that defines and documents it (``ignore-module-all`` documents them only there)."""
    refs = []
    for exported in getattr(obj, "__all__", []) if what == "module" else []:
        value = getattr(obj, exported, None)
        home, qualname = getattr(value, "__module__", None), getattr(value, "__qualname__", None)
        defined = inspect.isclass(value) or inspect.isfunction(value)
        if defined and isinstance(home, str) and isinstance(qualname, str) and home != name:
            role = "class" if isinstance(value, type) else "func"
            refs.append(f":{role}:`~{home}.{qualname}`")
    if refs:
        lines += ["", "Exported here (documented where each is defined): " + ", ".join(refs) + "."]


def _lookup(dotted: str) -> object | None:
    """The package's object of that dotted name (``pyautonomousagent.bt.Leaf``), or None."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            value: object = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            value = getattr(value, part, None)
        return value
    return None


def _canonical_reference(
    app: Sphinx, env: BuildEnvironment, node: addnodes.pending_xref, contnode: nodes.Element
) -> nodes.Element | None:
    """A reference to a re-exported name (``:class:`Leaf``` in ``pyautonomousagent.bt``)
    links to where the object is defined and documented (``pyautonomousagent.bt.leaf.Leaf``)."""
    if node.get("refdomain") != "py":
        return None
    target, module = node["reftarget"], node.get("py:module")
    for dotted in (target, f"{module}.{target}") if module else (target,):
        if not dotted.startswith("pyautonomousagent."):
            continue
        value = _lookup(dotted)
        home, qualname = getattr(value, "__module__", None), getattr(value, "__qualname__", None)
        if isinstance(home, str) and isinstance(qualname, str):
            canonical = f"{home}.{qualname}"
            if canonical != dotted:
                ref = node.deepcopy()
                ref["reftarget"] = canonical
                ref.attributes.pop("refspecific", None)
                domain = env.get_domain("py")
                kind = node["reftype"]
                return domain.resolve_xref(
                    env, node["refdoc"], app.builder, kind, canonical, ref, contnode
                )
    return None


def setup(app: Sphinx) -> None:
    app.connect("doctree-read", _exact_annotation_references)
    app.connect("autodoc-process-docstring", _exported_names)
    app.connect("missing-reference", _canonical_reference)
