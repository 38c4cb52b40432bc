"""The studio inside a real JupyterLab, in Debian's headless Chromium, offline.

A JupyterLab server (``python -m jupyterlab``, :mod:`tests.jupyterlab_server`) serves a
temporary folder holding a two-cell notebook; Chromium opens it in JupyterLab's own page; a
click in the first cell and Shift+Enter run ``Studio("gathering")`` in the kernel; the
studio's frame appears in that cell's output; Step is pressed inside the frame; the page's
iteration counter shows 1, and the second cell, run the same way, prints the iteration of the
run the kernel holds: 1.

Needs Debian's ``chromium`` and ``chromium-driver``, selenium and jupyterlab (the ``[test]``
extra) and the built front-end (``make test`` provides all of them); skipped, with the
reason, without them. On failure the message carries JupyterLab's log and a screenshot is
left in the test's folder.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent.studio import has_bundle
from tests.chromium import offline_chromium
from tests.jupyterlab_server import Lab, jupyterlab, notebook_json

CELLS = (
    "from pyautonomousagent.studio import Studio\n\nstudio = Studio('gathering')\nstudio",
    "print('the kernel is at iteration', studio.session.sim.world.iteration)",
)
"""The notebook: the studio as the first cell's value; the kernel's side of the run."""


def wait_for(check: Callable[[], Any], seconds: float, what: str) -> Any:
    """``check()``'s first truthy value within ``seconds``; a check that raises (an element
    JupyterLab has just re-rendered) counts as not yet. Fails with ``what`` otherwise."""
    from selenium.common.exceptions import WebDriverException

    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            value = check()
        except WebDriverException:
            value = None
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"not within {seconds:g} s: {what}")


def in_cell(browser: Any, index: int, selector: str) -> Any:
    """The first shown element matching ``selector`` in the notebook's cell ``index``."""
    cells = browser.find_elements("css selector", ".jp-Notebook .jp-Cell")
    if len(cells) <= index:
        return None
    shown = [e for e in cells[index].find_elements("css selector", selector) if e.is_displayed()]
    return shown[0] if shown else None


def run_cell(browser: Any, index: int) -> None:
    """Click into cell ``index``'s editor and press Shift+Enter, as a student does; again
    if JupyterLab did not take it (its prompt shows neither ``[*]`` nor a number)."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    def started() -> bool:
        prompt = in_cell(browser, index, ".jp-InputPrompt")
        return prompt is not None and prompt.text.strip() not in ("", "[ ]:")

    for _ in range(3):
        editor = wait_for(lambda: in_cell(browser, index, ".cm-content"), 30,
                          f"the editor of cell {index}")  # fmt: skip
        chain = ActionChains(browser).move_to_element(editor).click()
        chain.key_down(Keys.SHIFT).send_keys(Keys.ENTER).key_up(Keys.SHIFT).perform()
        try:
            wait_for(started, 5, f"cell {index} runs")
            return
        except AssertionError:
            continue
    raise AssertionError(f"cell {index} did not run after three Shift+Enter")


def drive(browser: Any, lab: Lab) -> tuple[str, str]:
    """Open the notebook in JupyterLab, show the studio, Step in its frame; the page's
    iteration line and the second cell's output."""
    browser.get(lab.page("studio.ipynb"))
    wait_for(
        lambda: browser.execute_script(
            "return document.querySelector('.jp-Notebook-ExecutionIndicator')"
            "?.dataset.status === 'idle'"
        ),
        90,
        "JupyterLab's page with the notebook's kernel idle",
    )
    run_cell(browser, 0)
    frame = wait_for(lambda: in_cell(browser, 0, ".jp-OutputArea-output iframe"), 90,
                     "the studio's frame in the first cell's output")  # fmt: skip
    assert frame.get_attribute("src").startswith("http://127.0.0.1:")
    browser.switch_to.frame(frame)
    try:
        wait_for(lambda: "can run" in browser.find_element("id", "message").text, 30,
                 "the studio's page checked the scenario's tree")  # fmt: skip
        browser.find_element("id", "step").click()
        shown = wait_for(
            lambda: (
                "iteration 1 " in (text := browser.find_element("id", "iteration").text) and text
            ),
            30,
            "the studio's page shows iteration 1 after Step",
        )
    finally:
        browser.switch_to.default_content()
    run_cell(browser, 1)
    printed = wait_for(
        lambda: (out := in_cell(browser, 1, ".jp-OutputArea-output")) is not None and out.text,
        60,
        "the second cell's output",
    )
    return shown, printed


def test_one_cell_shows_the_studio_in_jupyterlab_and_a_step_advances_it(tmp_path: Path) -> None:
    if not has_bundle():
        pytest.skip("the studio's front-end is not built: cd studio && npm ci && npm run build")
    with offline_chromium(1400, 1200) as browser, jupyterlab(tmp_path) as lab:
        (lab.root / "studio.ipynb").write_text(notebook_json(*CELLS), encoding="utf-8")
        try:
            shown, printed = drive(browser, lab)
        except Exception as error:
            browser.switch_to.default_content()
            browser.save_screenshot(str(tmp_path / "jupyterlab.png"))
            raise AssertionError(f"{error}\n--- JupyterLab's log ---\n{lab.log_text()}") from error
    assert shown == "iteration 1 of 8000"
    assert printed.strip() == "the kernel is at iteration 1"
