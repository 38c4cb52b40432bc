"""The documentation site, built as ``make docs`` builds it (``sphinx-build -W``: warnings are
errors) from the lessons this session executed already (``executed_lessons``): every page is
there, every internal link and anchor holds, and headless Chromium shows lesson 2's node
statuses and lesson 6's plot.

Screenshots go to ``$PYAA_SCREENSHOTS`` when set (else the test's temporary folder).
"""

from __future__ import annotations

import html
import importlib.util
import pkgutil
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from types import ModuleType

import nbformat
import pytest

import pyautonomousagent
from tests.lesson_runner import lesson_paths
from tests.test_replay_browser import browser, shots_dir  # noqa: F401  (the Chromium fixture)

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "build_docs.py"
STATUSES = {"SUCCESS", "FAILURE", "RUNNING"}
#: The narrowest replay page without a horizontal scroll, pixels: its map and side columns
#: (at least 360 and 380), the gap between them and the padding (replay_template.html).
REPLAY_WIDTH = 360 + 380 + 8 + 2 * 8


def _build_docs() -> ModuleType:
    spec = importlib.util.spec_from_file_location("build_docs", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def site(executed_lessons: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built by ``scripts/build_docs.py`` from the executed lessons, once per
    session: its tests share a worker with the lessons' (``xdist_group``), which may run
    between them, and a module-scoped site was built again after each (about 4 minutes)."""
    pytest.importorskip("sphinx", reason="the [docs] extra is not installed (make docs)")
    pytest.importorskip("myst_nb", reason="the [docs] extra is not installed (make docs)")
    out = tmp_path_factory.mktemp("site") / "site"
    command = [sys.executable, str(SCRIPT), "--executed", str(executed_lessons), "--out", str(out)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "no warnings" in done.stdout
    return out


def test_every_page_is_built(site: Path) -> None:
    pages = {"index", "getting-started", "course", "howto", "guide", "api", "about-this-site"}
    pages |= {p.stem for p in (ROOT / "docs").glob("*.md") if p.name != "README.md"}
    missing = [p for p in sorted(pages) if not (site / f"{p}.html").exists()]
    assert missing == []
    lessons = [p.stem for p in lesson_paths()]
    assert lessons and all((site / "lessons" / f"{name}.html").exists() for name in lessons)
    index = (site / "course.html").read_text()
    assert all(f'href="lessons/{name}.html"' in index for name in lessons)
    modules = [
        m.name for m in pkgutil.walk_packages(pyautonomousagent.__path__, "pyautonomousagent.")
    ]
    missing = [m for m in modules if not (site / "api" / f"{m}.html").exists()]
    assert missing == [] and len(modules) > 50


def _text(page: Path) -> str:
    """A page's text: tags dropped, white space collapsed."""
    return " ".join(re.sub(r"<[^>]+>", " ", html.unescape(page.read_text())).split())


def test_pages_are_generated_from_their_sources_not_copied(site: Path) -> None:
    """Getting started shows the README's set-up section (included, not a copy); the API
    reference shows a docstring; a docs/ page shows its own text."""
    start = _text(site / "getting-started.html")
    assert "make demo" in start and "runs/gathering/states.parquet" in start
    testing = _text(site / "api" / "pyautonomousagent.testing.html")
    assert "check_engines_agree" in testing and "Test tools for a user" in testing
    # A module shadowed by a package attribute of its name (bt.leaf, the function) still
    # gets its own page: the module's docstring, not the function's.
    assert "What a leaf node is" in _text(site / "api" / "pyautonomousagent.bt.leaf.html")
    first_line = (ROOT / "docs" / "missions.md").read_text().splitlines()[0].lstrip("# ")
    assert first_line in _text(site / "missions.html")


def test_internal_links_and_anchors_hold(site: Path) -> None:
    problems, external = _build_docs().check_links(site)
    assert problems == []
    assert all(link.startswith(("https://", "http://", "mailto:", "data:")) for link in external)


def test_the_link_check_finds_a_broken_link_and_anchor(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "a.html").write_text(
        '<a id="top" href="b.html#there">ok</a><a href="b.html#nowhere">bad anchor</a>'
        '<a href="c.html">missing</a><a href="#top">self</a><a href="https://x y">bad url</a>'
    )
    (tmp_path / "b.html").write_text('<h1 id="there">B</h1>')
    monkeypatch.chdir(tmp_path.parent)  # a relative folder, as make docs gives it
    problems, external = _build_docs().check_links(Path(tmp_path.name))
    assert problems == [
        "a.html: b.html#nowhere: no anchor #nowhere",
        "a.html: c.html: no such file",
        "a.html: https://x y: malformed URL",
    ]
    assert external == ["https://x y"]


def test_a_lesson_that_failed_is_refused(executed_lessons: Path, tmp_path: Path) -> None:
    """The site never shows a traceback: a lesson with an error output stops the build."""
    broken = tmp_path / "executed"
    broken.mkdir()
    lessons = sorted(executed_lessons.glob("*.ipynb"))
    for path in lessons:
        notebook = nbformat.read(path, as_version=4)
        if path == lessons[0]:
            cell = next(c for c in notebook.cells if c.cell_type == "code")
            cell.outputs = [nbformat.v4.new_output("error", ename="ValueError", evalue="boom")]
        nbformat.write(notebook, broken / path.name)
    command = [sys.executable, str(SCRIPT), "--executed", str(broken), "--out", str(tmp_path / "s")]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    assert done.returncode != 0
    assert f"lesson {lessons[0].name} failed: ValueError: boom" in done.stdout + done.stderr
    assert not (tmp_path / "s").exists()


class _Tables(HTMLParser):
    """The text of every cell of every ``pyaa-tick-table`` in an HTML fragment."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[str]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "table" and "pyaa-tick-table" in (dict(attrs).get("class") or ""):
            self.tables.append([])
        elif tag in ("td", "th") and self.tables:
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1].append(" ".join("".join(self._cell).split()))
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def _lesson(executed: Path, prefix: str) -> nbformat.NotebookNode:
    paths = sorted(executed.glob(f"{prefix}_*.ipynb"))
    if not paths:
        pytest.skip(f"no lesson {prefix} in notebooks/")
    return nbformat.read(paths[0], as_version=4)


def _open(browser, page: Path) -> None:  # noqa: F811
    from selenium.webdriver.support.ui import WebDriverWait

    browser.get(page.resolve().as_uri())
    WebDriverWait(browser, 20).until(
        lambda d: d.execute_script("return document.readyState") == "complete"
    )


def test_lesson_2_page_shows_the_node_statuses(browser, site, executed_lessons, tmp_path):  # noqa: F811
    from selenium.webdriver.common.by import By

    notebook = _lesson(executed_lessons, "02")
    parser = _Tables()
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            parser.feed(output.get("data", {}).get("text/html", ""))
    assert parser.tables, "lesson 2 shows no table of node statuses"
    page = next((site / "lessons").glob("02_*.html"))
    _open(browser, page)
    tables = browser.find_elements(By.CSS_SELECTOR, "table.pyaa-tick-table")
    assert len(tables) == len(parser.tables)
    for shown, computed in zip(tables, parser.tables, strict=True):
        cells = shown.find_elements(By.CSS_SELECTOR, "th, td")
        assert [" ".join(c.text.split()) for c in cells] == computed
        assert shown.size["height"] > 0 and shown.size["width"] > 0
    shown_statuses = {c.text for t in tables for c in t.find_elements(By.TAG_NAME, "td")}
    assert shown_statuses >= STATUSES
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", tables[0])
    browser.save_screenshot(str(shots_dir(tmp_path) / "site-lesson-02-statuses.png"))


def test_lesson_6_page_shows_its_plot(browser, site, executed_lessons, tmp_path):  # noqa: F811
    from selenium.webdriver.common.by import By

    notebook = _lesson(executed_lessons, "06")
    pictures = sum(
        "image/png" in output.get("data", {})
        for cell in notebook.cells
        for output in cell.get("outputs", [])
    )
    assert pictures >= 1, "lesson 6 shows no plot"
    page = next((site / "lessons").glob("06_*.html"))
    _open(browser, page)
    images = browser.find_elements(By.CSS_SELECTOR, ".cell_output img")
    assert len(images) == pictures
    for image in images:
        natural = browser.execute_script(
            "return [arguments[0].complete, arguments[0].naturalWidth, arguments[0].naturalHeight]",
            image,
        )
        assert natural[0] is True and natural[1] > 100 and natural[2] > 100
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", images[0])
    browser.save_screenshot(str(shots_dir(tmp_path) / "site-lesson-06-plot.png"))
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == []


def test_lesson_3_page_gives_its_replay_room(browser, site, tmp_path):  # noqa: F811
    """The embedded replay fills the content's width (no "On this page" column beside it):
    its map and side panels side by side without a horizontal scroll, the whole page in the
    frame's height; its button opens the replay full page in a tab of its own."""
    from selenium.webdriver.common.by import By

    page = next((site / "lessons").glob("03_*.html"))
    _open(browser, page)
    assert not browser.find_elements(By.CSS_SELECTOR, ".bd-sidebar-secondary")
    frame = browser.find_element(By.CSS_SELECTOR, ".pyaa-replay iframe")
    assert frame.size["width"] >= REPLAY_WIDTH and frame.size["height"] >= 600, frame.size
    browser.execute_script("arguments[0].scrollIntoView({block: 'start'})", frame)
    browser.save_screenshot(str(shots_dir(tmp_path) / "site-lesson-03-replay.png"))
    browser.switch_to.frame(frame)
    inside = browser.execute_script(
        "const e = document.documentElement, box = id => document.getElementById(id)"
        ".getBoundingClientRect();"
        "return [e.scrollWidth, e.clientWidth, e.scrollHeight, e.clientHeight,"
        " box('map').width, box('map').right, box('side').left, box('side').right];"
    )
    browser.switch_to.default_content()
    scroll_width, width, scroll_height, height, map_width, map_right, side, side_right = inside
    assert scroll_width <= width and scroll_height <= height, inside  # nothing to scroll
    assert map_right <= side and side_right <= width, inside  # side by side, all shown
    here = browser.current_window_handle
    browser.find_element(By.CSS_SELECTOR, ".pyaa-replay button").click()
    opened = [h for h in browser.window_handles if h != here]
    assert len(opened) == 1
    browser.switch_to.window(opened[0])
    try:
        assert browser.find_element(By.ID, "map").size["width"] > map_width
    finally:
        browser.close()
        browser.switch_to.window(here)
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == []


def test_lesson_9_page_shows_no_empty_studio_frame(site: Path, executed_lessons: Path) -> None:
    """Lesson 9's studio cell output a frame served by its kernel; on the site no kernel
    serves it, so the cell (tagged remove-output) shows its code and no frame."""
    notebook = _lesson(executed_lessons, "09")
    frames = [
        output
        for cell in notebook.cells
        for output in cell.get("outputs", [])
        if "<iframe" in output.get("data", {}).get("text/html", "")
    ]
    assert len(frames) == 1  # the kernel did output the studio
    page = next((site / "lessons").glob("09_*.html"))
    assert "<iframe" not in page.read_text(encoding="utf-8")
    text = _text(page)
    assert "Without a mouse" in text and "Studio" in text  # the lesson, its code shown
