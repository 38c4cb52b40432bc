"""Every shell and Python block of README.md and docs/*.md, run as a reader would run it.

Each page runs in a fresh temporary folder (with ``examples/`` and ``scripts/`` linked from
the repository, so paths written from a clone's root work), its blocks in order, one test per
block; a block's test first runs the page's earlier blocks when they have not run yet. The
rules (also in docs/about-this-site.md, "How the pages are tested"):

- ``python`` blocks run with ``exec`` in one namespace per page.
- ``sh`` blocks run line by line (``\\`` continues a line, ``#`` starts a comment,
  ``NAME=value`` sets a variable that ``$NAME`` reads). ``pyaa ...`` runs the command in this
  process (``pyautonomousagent.cli.main``) and must exit 0; ``python scripts/X.py ...`` runs
  the repository's script. Any other command fails the test: mark its block skipped.
- Runs are kept short: every ``--iterations`` is at most :data:`ITERATIONS` (and added to
  ``pyaa run``, ``bench`` and ``sweep`` without one), ``--agents`` at most :data:`AGENTS`
  (a list keeps its values up to it; ``pyaa bench`` its first only: each case is a process),
  ``--record-every`` at most the iterations, ``--seeds`` at most :data:`SEEDS`, ``--repeat``
  1; a sweep without ``--workers`` or ``--dask`` runs ``--serial``, without ``--seeds``
  gets ``--seeds 2``. A ``pyaa run`` without ``--out`` gets ``--overwrite``: each line is an
  example on its own, and several write the default folder.
- A line that needs an optional extra this installation lacks (``--video mp4``:
  imageio-ffmpeg) is left out, and its block's test, once the other lines ran, is skipped
  naming it; a block about the X8 is skipped without the ``[x8]`` extra.
- A block after ``<!-- file: PATH -->`` is written to PATH in the page's folder, not run.
- A block after ``<!-- files: PAGE -->`` (``docs/missions.md``) runs after the file blocks
  of that page are written to its page's folder: an example that builds on another page's.
- A block after ``<!-- output: COMMAND -->`` must be what the ``pyaa`` command prints.
- A block after ``<!-- skip: REASON -->`` is not run: its test is skipped with that reason.
- Blocks in other languages (``xml``, ``yaml``, ``text``, output listings) are not run; an
  unlabelled block that holds a command is an error (label it ``sh``).
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import re
import runpy
import shlex
import sys
import traceback
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent.cli import main
from pyautonomousagent.experiments.measures import MEASURES
from pyautonomousagent.testing import scoped_registrations

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

#: The short runs' sizes (see the module's docstring).
ITERATIONS = 20
AGENTS = 100
SEEDS = 2

PYTHON = {"python", "py", "python3"}
SHELL = {"sh", "bash", "shell", "console"}
FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})\s*(?P<info>.*)$")
MARKER = re.compile(r"^\s*<!--\s*(?P<kind>skip|file|files|output):\s*(?P<value>.*?)\s*-->\s*$")
COMMAND_START = re.compile(r"^\s*(\$ )?(pyaa|python3?|pip|make) ")
#: Options whose line needs an optional extra: without it the line is left out and the
#: block's test, once its other lines ran, is skipped naming it.
EXTRAS = {"--video": ("imageio_ffmpeg", "the [video] extra")}


@dataclass(frozen=True)
class Block:
    """A fenced code block of a page: its language, text and marker."""

    page: str  # the page, relative to the repository
    line: int  # the line of its opening fence (1-based)
    lang: str
    text: str
    skip: str = ""  # the reason of a <!-- skip: ... --> marker
    file: str = ""  # the path of a <!-- file: ... --> marker
    files: str = ""  # the page of a <!-- files: ... --> marker
    output: str = ""  # the command of a <!-- output: ... --> marker

    @property
    def runs(self) -> bool:
        return bool(self.output) or not self.file and (self.lang in PYTHON or self.lang in SHELL)

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"


def blocks(path: Path) -> list[Block]:
    """The fenced code blocks of the Markdown file ``path`` (MyST directives excluded)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, indent, info = m["fence"], len(m["indent"]), m["info"].strip()
        end = i + 1
        while end < len(lines):
            close = FENCE.match(lines[end])
            same = close and close["fence"][0] == fence[0]
            if same and len(close["fence"]) >= len(fence) and not close["info"].strip():
                break
            end += 1
        body = "\n".join(line[indent:] if not line[:indent].strip() else line.lstrip()
                         for line in lines[i + 1 : end])  # fmt: skip
        lang = info.split()[0] if info else ""
        before = i - 1
        while before >= 0 and not lines[before].strip():
            before -= 1
        marker = MARKER.match(lines[before]) if before >= 0 else None
        if not lang.startswith("{"):  # a MyST directive ({toctree}, {include}), not code
            found.append(
                Block(
                    page=str(path.relative_to(ROOT)),
                    line=i + 1,
                    lang=lang,
                    text=body + "\n",
                    skip=marker["value"] if marker and marker["kind"] == "skip" else "",
                    file=marker["value"] if marker and marker["kind"] == "file" else "",
                    files=marker["value"] if marker and marker["kind"] == "files" else "",
                    output=marker["value"] if marker and marker["kind"] == "output" else "",
                )
            )
        i = end + 1
    return found


ALL_BLOCKS = [block for page in PAGES for block in blocks(page)]
RUNNABLE = [block for block in ALL_BLOCKS if block.runs]


# ---- shell commands ------------------------------------------------------------------------


def commands(text: str) -> Iterator[str]:
    """The command lines of a shell block: continuation lines joined, blank lines dropped."""
    pending = ""
    for raw in text.splitlines():
        line = raw.rstrip()
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        line, pending = pending + line, ""
        if line.strip():
            yield line.strip()
    if pending.strip():
        yield pending.strip()


def _numbers(value: str) -> list[int]:
    return [int(v) for v in value.split(",")]


def _at_most(value: str, most: int) -> str:
    """A number or comma-separated list of numbers, each at most ``most``."""
    return ",".join(str(min(v, most)) for v in _numbers(value))


def _agents(value: str) -> str:
    """An --agents list keeps its values up to AGENTS (at least its smallest, cut to it)."""
    values = _numbers(value)
    kept = [v for v in values if v <= AGENTS] or [min(min(values), AGENTS)]
    return ",".join(str(v) for v in kept)


def shorten(argv: list[str]) -> list[str]:
    """``argv`` (after ``pyaa`` or a script's name) with the short runs' sizes."""
    options: dict[str, Any] = {
        "--iterations": lambda v: _at_most(v, ITERATIONS),
        "--reference-iterations": lambda v: _at_most(v, ITERATIONS),
        "--agents": _agents,
        "--record-every": lambda v: _at_most(v, ITERATIONS),
        "--seeds": lambda v: _at_most(v, SEEDS) if v.isdigit() else v,
        "--repeat": lambda v: "1",
    }
    out: list[str] = []
    args = iter(argv)
    for arg in args:
        name, equals, value = arg.partition("=")
        if name in options:
            value = value if equals else next(args)
            out += [name, options[name](value)]
        else:
            out.append(arg)
    command = argv[0] if argv else ""
    if command == "bench" and "--agents" in out:  # each case is a process of its own
        where = out.index("--agents") + 1
        out[where] = out[where].split(",")[0]
    if command == "sweep" and not {"--workers", "--dask", "--serial"} & set(out):
        out.append("--serial")  # no pool of processes to start
    if command == "sweep" and "--seeds" not in out:  # an experiment file's seeds
        out += ["--seeds", str(SEEDS)]
    if command in ("run", "bench", "sweep") and "--iterations" not in out:
        out += ["--iterations", str(ITERATIONS)]
    if command == "run" and "--out" not in out and "--overwrite" not in out:
        out.append("--overwrite")
    return out


def missing_extra(argv: list[str]) -> str:
    """The extra the command needs and this installation lacks, or ""."""
    for option, (module, extra) in EXTRAS.items():
        if option in argv and importlib.util.find_spec(module) is None:
            return extra
    return ""


def run_command(line: str, variables: dict[str, str], left_out: list[str]) -> str:
    """Run one shell line of a block; what it printed. AssertionError if it failed; a line
    that needs a missing extra is added to ``left_out`` instead."""
    assignment = re.fullmatch(r"([A-Za-z_]\w*)=(\S*)", line)
    if assignment:
        variables[assignment[1]] = assignment[2]
        return ""
    expanded = re.sub(r"\$\{?([A-Za-z_]\w*)\}?", lambda m: variables.get(m[1], ""), line)
    argv = shlex.split(expanded, comments=True)
    if not argv:
        return ""
    if missing_extra(argv):
        left_out.append(f"{line!r} (needs {missing_extra(argv)})")
        return ""
    out = io.StringIO()
    code: Any
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        if argv[0] == "pyaa":
            code = main(shorten(argv[1:]))
        elif argv[0] in ("python", "python3") and argv[1:2] and argv[1].endswith(".py"):
            script = str(ROOT / argv[1])
            saved = sys.argv
            sys.argv = [script, *shorten(argv[2:])]
            try:
                runpy.run_path(script, run_name="__main__")
                code = 0
            except SystemExit as stop:
                code = stop.code or 0
            finally:
                sys.argv = saved
        else:
            raise AssertionError(
                f"the docs test does not run {argv[0]!r} ({line!r}): mark the block "
                "<!-- skip: REASON --> or show a command it runs"
            )
    printed = out.getvalue()
    assert code == 0, f"{expanded}\nexit status {code}:\n{printed}"
    return printed


# ---- pages ----------------------------------------------------------------------------------


@dataclass
class Page:
    """A page being run: its folder, its Python namespace, its shell variables."""

    folder: Path
    scope: contextlib.ExitStack = field(default_factory=contextlib.ExitStack)
    namespace: dict[str, Any] = field(default_factory=dict)
    variables: dict[str, str] = field(default_factory=dict)
    done: int = 0  # blocks of the page handled so far

    def run(self, block: Block) -> None:
        cwd = Path.cwd()
        os.chdir(self.folder)
        try:
            for other in (b for b in ALL_BLOCKS if block.files and b.page == block.files):
                if other.file:
                    self.run(other)
            if block.output:
                printed = run_command(block.output, self.variables, [])
                shown = [line.rstrip() for line in printed.strip().splitlines()]
                wrong = f"{block.output} prints:\n{printed}"
                assert shown == block.text.strip().splitlines(), wrong
            elif block.file:
                target = self.folder / block.file
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_text(block.text, encoding="utf-8")
            elif block.lang in PYTHON:  # from a file: tracebacks show it, numba can cache
                source = self.folder / ("block_" + re.sub(r"\W", "_", block.id) + ".py")
                source.write_text(block.text, encoding="utf-8")
                code = compile(block.text, str(source), "exec")
                with contextlib.redirect_stdout(io.StringIO()):
                    exec(code, self.namespace)  # noqa: S102 - the page's own code
            elif block.lang in SHELL:
                left_out: list[str] = []
                for line in commands(block.text):
                    run_command(line, self.variables, left_out)
                if left_out:
                    pytest.skip(f"{block.id}: the other lines ran; left out: {left_out}")
        finally:
            os.chdir(cwd)


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Page]]:
    """The pages being run, one folder each; registrations made by them are undone after."""
    made: dict[str, Page] = {}
    saved = os.environ.get("PYAA_CACHE_DIR")
    os.environ["PYAA_CACHE_DIR"] = str(tmp_path_factory.mktemp("numba-cache"))
    with scoped_registrations(), MEASURES.scoped():
        yield made
    if saved is None:
        os.environ.pop("PYAA_CACHE_DIR", None)
    else:
        os.environ["PYAA_CACHE_DIR"] = saved
    for page in made.values():
        page.scope.close()
        page.namespace.clear()


def page_of(pages: dict[str, Page], name: str, tmp_path_factory: pytest.TempPathFactory) -> Page:
    """The page ``name``, started if it was not: the pages run one after the other, each in
    its own registrations (two pages may load the same mission file from their folders)."""
    if name not in pages:
        for other in pages.values():
            other.scope.close()
        folder = tmp_path_factory.mktemp(re.sub(r"\W", "_", name))
        for linked in ("examples", "scripts"):
            (folder / linked).symlink_to(ROOT / linked, target_is_directory=True)
        pages[name] = Page(folder)
        pages[name].scope.enter_context(scoped_registrations())
        pages[name].scope.enter_context(MEASURES.scoped())
    return pages[name]


@pytest.mark.parametrize("block", RUNNABLE, ids=[b.id for b in RUNNABLE])
def test_block_runs(
    block: Block, pages: dict[str, Page], tmp_path_factory: pytest.TempPathFactory
) -> None:
    if block.skip:
        pytest.skip(f"marked in {block.id}: {block.skip}")
    if "x8-" in block.text:
        pytest.importorskip("pyfly", reason="needs the [x8] extra (pyfly-fixed-wing)")
    page = page_of(pages, block.page, tmp_path_factory)
    own = [b for b in ALL_BLOCKS if b.page == block.page]
    index = own.index(block)
    for earlier in own[page.done : index]:
        if earlier.file or (earlier.runs and not earlier.skip):
            try:
                page.run(earlier)
            except pytest.skip.Exception:
                pass  # it ran but for a line that needs a missing extra
            except BaseException as error:
                page.done = index + 1
                failed = f"an earlier block of the page, {earlier.id}, failed"
                raise AssertionError(failed) from error
    page.done = index + 1
    try:
        page.run(block)
    except AssertionError:
        raise
    except Exception as error:
        raise AssertionError(f"{block.id} raised:\n{traceback.format_exc()}") from error


# ---- the blocks themselves ------------------------------------------------------------------


def test_the_pages_have_blocks_to_run() -> None:
    assert len(RUNNABLE) >= 30
    assert {b.page for b in RUNNABLE} >= {"README.md", "docs/missions.md", "docs/tree-files.md"}


def test_no_unlabelled_block_holds_a_command() -> None:
    """A block without a language is not run: one that holds a command would go untested."""
    unlabelled = [b.id for b in ALL_BLOCKS if not b.lang and COMMAND_START.match(b.text)]
    assert not unlabelled, f"label these blocks sh (or text): {unlabelled}"


def test_markers_mark_blocks_that_would_run() -> None:
    pages = {b.page for b in ALL_BLOCKS}
    sources = [b.id for b in ALL_BLOCKS if b.files and b.files not in pages]
    assert not sources, f"<!-- files: PAGE --> names no page with blocks: {sources}"
    useless = [b.id for b in ALL_BLOCKS if b.skip and not b.runs]
    assert not useless, f"a skip marker before a block that is not run anyway: {useless}"
    unreasoned = [b.id for b in ALL_BLOCKS if b.skip and len(b.skip) < 10]
    assert not unreasoned, f"a skip marker must say why: {unreasoned}"


def test_shorten() -> None:
    assert shorten(["run", "patrol", "--agents", "100000", "--record-every", "100"]) == [
        "run", "patrol", "--agents", "100", "--record-every", "20",
        "--iterations", "20", "--overwrite",
    ]  # fmt: skip
    assert shorten(["bench", "patrol", "--agents=1,10,100,1000", "--iterations", "4000"]) == [
        "bench", "patrol", "--agents", "1", "--iterations", "20",
    ]  # fmt: skip
    assert shorten(["run", "gathering", "--out", "runs/g3"])[-2:] == ["--iterations", "20"]
    assert list(commands("a \\\n  b\n\nc  # note\n")) == ["a    b", "c  # note"]
