"""Screenshots of the studio for docs/studio.md, taken in Debian's headless Chromium, offline.

Usage::

    python scripts/studio_screenshots.py                 # -> docs/images/studio-*.png
    python scripts/studio_screenshots.py --out DIR --no-jupyterlab

Each picture is taken on a fresh studio (the gathering scenario, in a temporary folder):

- ``studio-blocks.png``: the gathering tree (Fig. 6) built block by block from an empty
  canvas with real pointer drags, each block's name typed as the scenario's file names it
  (the browser test's helpers), and stepped once, the palette's *Mission leaves* open beside
  it;
- ``studio-live.png``: the run played at 1000 iterations per second, paused and stepped to
  iteration 5003 (just after the gathering order), drone2 followed: each block shows
  drone2's status and how many drones have the node active, beside the map, the energy
  plot, the node list and drone2's blackboard;
- ``studio-invalid.png``: an Inverter given two children: the loader's message on the block
  (its warning opened) and above the canvas, Play, Step, Reset and Save run disabled;
- ``studio-jupyterlab.png`` (unless ``--no-jupyterlab``): the studio shown by a notebook
  cell in JupyterLab's own page, stepped once, the file browser closed
  (``tests/jupyterlab_server.py``).

Needs the built front-end (``make demo`` or ``make test``), Debian's ``chromium`` and
``chromium-driver``, selenium and, for the last picture, jupyterlab (the ``[test]`` extra).
Run from the repository's root; about two minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
# The browser test's helpers drag blocks as a student does: one piece of code for that job.
from tests.chromium import CHROMIUM, driver_path, offline_chromium  # noqa: E402
from tests.test_studio_browser import (  # noqa: E402
    add_block,
    build,
    follow_agent,
    open_category,
    open_empty,
    packaged_gathering,
    wait_for,
)

#: The browser window of each picture, CSS pixels: wide enough for the studio's two columns
#: (the palette open beside the tree, whose blocks show their names, needs more), high
#: enough for what the picture shows.
WINDOWS = {"blocks": (1900, 900), "live": (1400, 1000), "invalid": (1400, 900),
           "jupyterlab": (1400, 1000)}  # fmt: skip
#: The iteration the live picture shows: the first after the gathering order (5000) and two.
LIVE_AT = 5003


#: Move the tree (the workspace's top block) right of the open palette, 24 px apart.
BESIDE_FLYOUT = """
const ws = window.studio.workspace();
const tree = ws.getTopBlocks(true)[0];
const flyout = ws.getToolbox().getFlyout();
const right = flyout.getWorkspace().getParentSvg().getBoundingClientRect().left
  + flyout.getWidth();
const left = tree.getSvgRoot().getBoundingClientRect().left;
tree.moveBy((right + 24 - left) / ws.scale, 0);
"""
#: Scroll the notebook back to its first cell (the code, then the studio's frame).
NOTEBOOK_TOP = "document.querySelector('.jp-WindowedPanel-outer').scrollTop = 0;"
#: JupyterLab's open tab in its left side bar (the file browser): a click closes it.
LEFT_TAB = ".jp-SideBar.jp-mod-left .lm-TabBar-tab.lm-mod-current"
#: Move the tree down and right, so that an opened warning has room above it.
ROOM_ABOVE = "window.studio.workspace().getTopBlocks(true)[0].moveBy(60, 110);"


@contextmanager
def fresh_studio() -> Iterator[Any]:
    """A studio on the gathering scenario serving a temporary folder, shut down after."""
    from pyautonomousagent.studio import Studio

    folder = Path(tempfile.mkdtemp(prefix="pyaa-shots-"))
    studio = Studio("gathering", folder).start()
    try:
        yield studio
    finally:
        studio.shutdown()
        shutil.rmtree(folder, ignore_errors=True)


def blocks(browser: Any, out: Path) -> Path:
    """The gathering tree built from blocks, with the palette's mission leaves open."""
    with fresh_studio() as studio:
        open_empty(browser, studio)
        build(browser, packaged_gathering())  # each block's name typed, as in the file
        browser.find_element("id", "cat-mission").click()
        wait_for(lambda: browser.execute_script("return window.studio.openCategory()"))
        browser.execute_script(BESIDE_FLYOUT)  # a move: checked again, the run starts anew
        wait_for(lambda: not browser.execute_script("return window.studio.busy()"))
        wait_for(lambda: browser.execute_script("return window.studio.runnable()"))
        browser.find_element("id", "step").click()  # the map shows the swarm
        wait_for(lambda: browser.execute_script("return window.studio.iteration()") == 1)
        open_category(browser, "cat-mission")  # Step's click closed it
        return shot(browser, out / "studio-blocks.png")


def control(studio: Any, **request: Any) -> None:
    """What a button of the page asks the studio (``/api/control``), from here."""
    body = json.dumps(request).encode()
    post = urllib.request.Request(f"{studio.url}api/control", data=body, method="POST")
    post.add_header("Content-Type", "application/json")
    urllib.request.urlopen(post, timeout=60).close()


def live(browser: Any, out: Path) -> Path:
    """Played to about LIVE_AT, stepped to it exactly, drone2 followed."""
    from selenium.webdriver.support.ui import Select

    with fresh_studio() as studio:
        browser.get(studio.url)
        wait_for(lambda: "can run" in browser.find_element("id", "message").text)
        Select(browser.find_element("id", "speed")).select_by_value("1000")
        browser.find_element("id", "play").click()
        wait_for(lambda: studio.session.iteration() >= LIVE_AT - 300, 60)
        control(studio, action="pause")  # Pause, on time however busy the browser is
        reached = studio.session.iteration()
        if reached >= LIVE_AT:
            raise SystemExit(f"studio_screenshots: played past {LIVE_AT} ({reached}); again")
        control(studio, action="step", steps=LIVE_AT - reached)
        iteration = "return window.studio.iteration() || 0"
        wait_for(lambda: browser.execute_script(iteration) == LIVE_AT)
        follow_agent(browser, 1)
        running = "return document.querySelectorAll('#nodes [data-status=running]').length"
        wait_for(lambda: browser.execute_script(running) > 0)
        return shot(browser, out / "studio-live.png", wait=0.5)


def invalid(browser: Any, out: Path) -> Path:
    """An Inverter with two children: the message on the block, opened."""
    with fresh_studio() as studio:
        open_empty(browser, studio)
        inverter = add_block(browser, "Inverter", None)
        add_block(browser, "Condition_Low_Energy_Level", inverter)
        add_block(browser, "Action_Refuel_A", inverter)
        wait_for(lambda: "needs exactly 1 child" in browser.find_element("id", "message").text)
        browser.execute_script(ROOM_ABOVE)  # a move: the page checks the tree again
        wait_for(lambda: not browser.execute_script("return window.studio.busy()"))
        warning = "return window.studio.warning(arguments[0])"
        wait_for(lambda: "needs exactly 1 child" in (browser.execute_script(warning, inverter)
                                                     or ""))  # fmt: skip
        browser.execute_script(
            "window.studio.workspace().getBlockById(arguments[0]).getIcon('warning')"
            ".setBubbleVisible(true)",
            inverter,
        )
        return shot(browser, out / "studio-invalid.png", wait=0.5)


def jupyterlab(browser: Any, out: Path) -> Path:
    """The studio in a notebook cell of JupyterLab, stepped once in its frame."""
    from tests.jupyterlab_server import jupyterlab as lab_server
    from tests.jupyterlab_server import notebook_json
    from tests.test_studio_jupyterlab import CELLS, drive

    with tempfile.TemporaryDirectory(prefix="pyaa-lab-") as home, lab_server(Path(home)) as lab:
        (lab.root / "studio.ipynb").write_text(notebook_json(*CELLS), encoding="utf-8")
        drive(browser, lab)
        browser.find_element("css selector", LEFT_TAB).click()  # the file browser closes
        wait_for(lambda: not browser.find_elements("css selector", LEFT_TAB))
        browser.execute_script(NOTEBOOK_TOP)
        return shot(browser, out / "studio-jupyterlab.png", wait=1.0)


def shot(browser: Any, path: Path, wait: float = 0.3) -> Path:
    """Save the window's picture to ``path`` after ``wait`` seconds (a last redraw)."""
    import time

    time.sleep(wait)
    path.parent.mkdir(parents=True, exist_ok=True)
    browser.save_screenshot(str(path))
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images",
                        help="folder of the pictures (default: docs/images)")  # fmt: skip
    parser.add_argument("--no-jupyterlab", action="store_true",
                        help="skip the picture in JupyterLab")  # fmt: skip
    args = parser.parse_args(argv)
    from pyautonomousagent.studio import has_bundle

    if not has_bundle():
        print("studio_screenshots: the studio's front-end is not built: cd studio && npm ci "
              "&& npm run build", file=sys.stderr)  # fmt: skip
        return 2
    if not Path(CHROMIUM).exists() or driver_path() is None:
        print("studio_screenshots: no chromium/chromedriver: apt-get install chromium "
              "chromium-driver", file=sys.stderr)  # fmt: skip
        return 2
    takes = [blocks, live, invalid] + ([] if args.no_jupyterlab else [jupyterlab])
    for take in takes:
        with offline_chromium(*WINDOWS[take.__name__]) as browser:
            print(take(browser, args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
