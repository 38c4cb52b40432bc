"""replay.html in a real headless Chromium, offline: play, scrub to iteration 5001 of the
gathering run, click drone2 on the map, and read back what the page shows.

Needs Debian's ``chromium`` and ``chromium-driver`` (``make test`` installs them when missing
and it can) and selenium (the ``[test]`` extra); skipped, with the reason, without them.
Screenshots go to ``$PYAA_SCREENSHOTS`` when set (else the test's temporary folder).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent.bt.status import NAMES
from pyautonomousagent.cli import main
from pyautonomousagent.recording import read_table
from tests.chromium import offline_chromium

NODES = ("sequence_gathering", "condition_low_energy_level", "action_navigate_to_destination_a_1")
"""Three nodes whose shown status is checked."""
AT = 5001
"""The iteration scrubbed to: the first after the gathering order (given at 5000)."""


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with offline_chromium(1400, 900, console=True) as driver:
        yield driver


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``pyaa run gathering`` just past the gathering order, every iteration recorded."""
    out = tmp_path_factory.mktemp("gathering")
    args = ["run", "gathering", "--iterations", "5100", "--no-gif", "--out", str(out), "--quiet"]
    assert main(args) == 0
    return out


def shots_dir(tmp_path: Path) -> Path:
    folder = Path(os.environ.get("PYAA_SCREENSHOTS", tmp_path))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def test_replay_offline_shows_the_recorded_statuses_and_blackboard(browser, run_dir, tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    shots = shots_dir(tmp_path)
    page = run_dir / "replay.html"
    browser.get(page.resolve().as_uri())
    WebDriverWait(browser, 20).until(lambda d: d.execute_script("return !!window.replay"))
    assert browser.current_url.startswith("file://")
    browser.save_screenshot(str(shots / "replay-1-loaded.png"))

    # Play for a while, then pause: the iteration moves on.
    browser.find_element(By.ID, "play").click()
    WebDriverWait(browser, 10).until(lambda d: d.execute_script("return replay.frame") > 5)
    browser.find_element(By.ID, "play").click()
    paused = browser.execute_script("return replay.frame")
    assert browser.execute_script("return replay.playing") is False
    assert browser.execute_script("return replay.frame") == paused
    browser.save_screenshot(str(shots / "replay-2-played.png"))

    # Scrub to iteration 5001, then click drone2 on the map.
    frame = browser.execute_script(
        "const its = JSON.parse(document.getElementById('replay-data').textContent).iterations;"
        f"const s = document.getElementById('scrub'); s.value = its.indexOf({AT});"
        "s.dispatchEvent(new Event('input')); return Number(s.value);"
    )
    assert frame > 0
    label = browser.find_element(By.ID, "iteration-label").text
    assert label.startswith(f"iteration {AT} ")
    browser.find_element(By.CSS_SELECTOR, 'circle.agent[data-agent="drone2"]').click()
    assert browser.find_element(By.ID, "tree-agent").text == "drone2"
    browser.save_screenshot(str(shots / "replay-3-drone2-at-5001.png"))

    # What the page shows equals the recorded trace and states.
    traces = read_table(run_dir / "traces.parquet").to_pylist()
    states = read_table(run_dir / "states.parquet").to_pylist()
    trace = next(r for r in traces if r["iteration"] == AT and r["agent"] == "drone2")
    state = next(r for r in states if r["iteration"] == AT and r["agent"] == "drone2")
    for node in NODES:
        shown = browser.find_element(By.CSS_SELECTOR, f'.node[data-node="{node}"]')
        assert shown.get_attribute("data-status") == NAMES[trace[node]], node
    shown_statuses = {NAMES[trace[n]] for n in NODES}
    assert len(shown_statuses) >= 2  # the three nodes do not all agree: a real check
    blackboard = [
        "number_ticks",
        "x_surveillance_position",
        "y_surveillance_position",
        "x_current_destination_position",
        "y_current_destination_position",
    ]
    for key in blackboard:
        row = browser.find_element(By.CSS_SELECTOR, f'tr[data-key="{key}"]')
        assert float(row.get_attribute("data-value")) == state[key], key
    behaviour = browser.find_element(By.CSS_SELECTOR, 'tr[data-key="behaviour"]')
    assert behaviour.get_attribute("data-value") == state["behaviour"]

    # Offline: nothing but the file itself was loaded, and no console errors.
    urls = browser.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name)"
    )
    assert [u for u in urls if not u.startswith(("data:", "file:"))] == []
    text = page.read_text()
    loading = r"""(?:src|href)\s*=\s*["']?(?!data:)[a-z]+:|url\(\s*["']?http|fetch\("""
    loads = re.findall(loading, text)
    assert loads == [] and "XMLHttpRequest" not in text
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == []


def test_vacuum_replay_draws_the_cleaned_area_of_each_frame(browser, tmp_path):
    """The cleaned cells (the mission's changing marks) show up as the robot cleans."""
    out = tmp_path / "vacuum"
    args = ["run", "vacuum", "--iterations", "600", "--no-gif", "--out", str(out), "--quiet"]
    assert main(args) == 0
    browser.get((out / "replay.html").resolve().as_uri())
    count_shown = (
        "return [...document.querySelectorAll('#changing-marks > g')]"
        ".filter((g) => g.getAttribute('visibility') === 'visible').length"
    )
    scrub = (
        "const s = document.getElementById('scrub'); s.value = arguments[0];"
        "s.dispatchEvent(new Event('input'));"
    )
    data = browser.execute_script(
        "return JSON.parse(document.getElementById('replay-data').textContent)"
    )
    last = len(data["iterations"]) - 1
    browser.execute_script(scrub, 0)
    assert browser.execute_script(count_shown) == 0
    browser.execute_script(scrub, last)
    expected = sum(any(a <= last <= b for a, b in m["frames"]) for m in data["changing_marks"])
    assert expected > 10
    assert browser.execute_script(count_shown) == expected
    browser.save_screenshot(str(shots_dir(tmp_path) / "replay-4-vacuum-cleaned.png"))
