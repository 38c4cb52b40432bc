"""Build the documentation site: execute the lessons, stage docs/, sphinx-build -W, check links.

Usage (``make docs`` runs the first)::

    python scripts/build_docs.py                                # -> site/
    python scripts/build_docs.py --executed DIR --out OUT       # lessons executed already

The site's sources are ``docs/`` (Markdown pages and ``conf.py``), the lessons in
``notebooks/`` and the docstrings in ``src/``. Nothing is written into the source tree:
``docs/`` and the README are staged in a temporary folder, with the executed lessons in its
``docs/lessons/`` and the API pages (one per module) in ``docs/api/``, and Sphinx builds from
there with every warning an error. Then every internal link and anchor of the built site is checked
(``check_links``); external links are checked for form only (the build has no network).
Exit code 0 when the site is built and its links hold; 1 otherwise, with the reasons.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import nbformat

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
# The lessons are executed as the test suite executes them (fresh kernels, reference
# solutions in the exercise cells): one piece of code for that job.
from tests.lesson_runner import errors, execute_lessons, lesson_paths, tagged  # noqa: E402

#: The cell tag MyST-NB folds behind a "show code" button: the exercise's answer.
FOLDED = "hide-input"


def module_names() -> list[str]:
    """Every module of the package, found in ``src/`` (``pyautonomousagent``, ``...bt``,
    ``...bt.leaf``, ...), in order."""
    src = ROOT / "src"
    names = []
    for path in sorted((src / "pyautonomousagent").rglob("*.py")):
        parts = path.relative_to(src).with_suffix("").parts
        parts = parts[:-1] if parts[-1] == "__init__" else parts
        if not any(part.startswith("_") for part in parts):
            names.append(".".join(parts))
    return sorted(names)


def write_api_pages(folder: Path) -> None:
    """One page per module, ``folder/NAME.rst``: the module's docstring and members
    (autodoc), and a table of contents of its submodules.

    Written here rather than by autosummary's recursion, which takes the package attribute of
    the same name for the module (``pyautonomousagent.bt.leaf`` is also a function)."""
    folder.mkdir(parents=True)
    names = module_names()
    for name in names:
        children = [n for n in names if n.rpartition(".")[0] == name]
        lines = [name, "=" * len(name), "", f".. automodule:: {name}", ""]
        if children:
            lines += [".. toctree::", "   :maxdepth: 1", "", *(f"   {n}" for n in children), ""]
        (folder / f"{name}.rst").write_text("\n".join(lines), encoding="utf-8")


def stage(folder: Path, executed: Path) -> Path:
    """Copy ``docs/`` and the README into ``folder``, the executed lessons into
    ``folder/docs/lessons``; return the Sphinx source folder (``folder/docs``)."""
    source = folder / "docs"
    shutil.copytree(
        ROOT / "docs", source, ignore=shutil.ignore_patterns("_build", "lessons", "api")
    )
    write_api_pages(source / "api")
    shutil.copy2(ROOT / "README.md", folder / "README.md")
    shutil.copytree(ROOT / "examples", folder / "examples")
    lessons = source / "lessons"
    lessons.mkdir()
    for path in lesson_paths():
        done = executed / path.name
        if not done.exists():
            raise SystemExit(f"build_docs: {done}: lesson {path.name} was not executed")
        notebook = nbformat.read(done, as_version=4)
        if errors(notebook):  # the site shows no traceback
            raise SystemExit(f"build_docs: lesson {path.name} failed: {errors(notebook)[0]}")
        for cell in tagged(notebook, "exercise"):  # the answer, folded: try it first
            tags = notebook.cells[cell].setdefault("metadata", {}).setdefault("tags", [])
            tags.append(FOLDED)
        nbformat.write(notebook, lessons / path.name)
    return source


def sphinx_build(source: Path, out: Path) -> subprocess.CompletedProcess[str]:
    """``sphinx-build -W --keep-going -b html SOURCE OUT``, quiet but for warnings."""
    doctrees = source.parent / "doctrees"
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    command += ["-d", str(doctrees), str(source), str(out)]
    env = {**os.environ, "PYAA_REPO": str(ROOT), "PYTHONPATH": str(ROOT / "src")}
    env.setdefault("MPLBACKEND", "Agg")
    return subprocess.run(command, env=env, text=True, capture_output=True, check=False)


class _Page(HTMLParser):
    """The ids (anchors) of one HTML page and the links it holds (href and src)."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        for key in ("id", "name") if tag == "a" else ("id",):
            if values.get(key):
                self.ids.add(str(values[key]))
        for key in ("href", "src"):
            link = values.get(key)
            if link is not None and not (tag == "link" and values.get("rel") == "preconnect"):
                self.links.append(link)


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def external_problem(link: str) -> str | None:
    """Why an external link is malformed, or None (checked for form only: no network)."""
    parts = urlsplit(link)
    if parts.scheme in ("http", "https"):
        ok = bool(parts.netloc) and "." in parts.netloc and " " not in link
        return None if ok else "malformed URL"
    if parts.scheme == "mailto":
        return None if "@" in parts.path else "malformed mail address"
    if parts.scheme == "data":
        return None
    return f"unexpected scheme {parts.scheme!r}"


def site_pages(site: Path) -> list[Path]:
    """The site's HTML pages (not the theme's files under ``_static/``)."""
    return sorted(p for p in site.rglob("*.html") if "_static" not in p.relative_to(site).parts)


def check_links(site: Path) -> tuple[list[str], list[str]]:
    """Every link of every page of ``site``: internal ones must name an existing file, and an
    anchor that page holds; external ones are only checked for form.

    Returns (problems, external links): each problem is ``page: link: reason``."""
    site = site.resolve()
    pages = {path: _parse(path) for path in site_pages(site)}
    problems: list[str] = []
    external: set[str] = set()
    for path, page in pages.items():
        for link in page.links:
            where = f"{path.relative_to(site)}: {link}"
            parts = urlsplit(link)
            if parts.scheme or link.startswith("//"):
                external.add(link)
                reason = external_problem(link)
                if reason:
                    problems.append(f"{where}: {reason}")
                continue
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            if not target.is_relative_to(site) or not target.exists():
                problems.append(f"{where}: no such file")
                continue
            if parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    problems.append(f"{where}: no anchor #{parts.fragment}")
    return problems, sorted(external)


def build(
    out: Path, executed: Path | None, keep: Path | None = None
) -> tuple[subprocess.CompletedProcess[str], float]:
    """Build the site into ``out`` (replaced); return Sphinx's result and the seconds taken.
    The staged sources go to a temporary folder, or to ``keep`` (replaced) to look at them."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="pyaa-docs-") as tmp:
        folder = Path(tmp) if keep is None else keep
        if keep is not None and keep.exists():
            shutil.rmtree(keep)
        if executed is None:
            executed = folder / "executed"
            execute_lessons(executed)
        source = stage(folder / "stage", executed)
        # Built beside the sources, then moved: MyST-NB writes its scratch folder
        # (jupyter_execute/) beside the output folder.
        html = folder / "html"
        result = sphinx_build(source, html)
        if out.exists():
            shutil.rmtree(out)
        if result.returncode == 0:
            shutil.move(html, out)
    return result, time.perf_counter() - start


def main(argv: Iterable[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "site", help="default: site/")
    parser.add_argument(
        "--executed", type=Path, help="a folder of the lessons executed already (same names)"
    )
    parser.add_argument("--keep-stage", type=Path, help="stage the sources here and keep them")
    args = parser.parse_args(None if argv is None else list(argv))
    args.out = args.out.resolve()
    result, seconds = build(args.out, args.executed, args.keep_stage)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        print(f"build_docs: sphinx-build failed (warnings are errors): {args.out}")
        return 1
    problems, external = check_links(args.out)
    for problem in problems:
        print(f"build_docs: broken link: {problem}")
    if problems:
        return 1
    pages = len(site_pages(args.out))
    print(
        f"build_docs: {pages} pages in {seconds:.0f} s, no warnings; internal links and anchors"
        f" hold; {len(external)} external links (form checked): {args.out / 'index.html'}"
    )
    for link in external:
        print(f"  external: {link}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
