"""How fast the studio plays, measured in headless Chromium (a script, not a timed test).

Usage (from the repository root, with the front-end built)::

    python scripts/studio_frames.py                      # patrol, 1000 drones, 5 s
    python scripts/studio_frames.py --agents 100 --seconds 10 --speed 1000

Starts a studio on the scenario with that many agents, opens it in Debian's headless Chromium
(offline), presses Play and counts the frames the page draws (each frame: the canvas, the node
list and the blocks' labels) over the given seconds; then follows drone 1 and counts again;
then pauses with the page's own request and reports how long until the server says it stopped
and how many iterations ran after the press. Prints one line per figure.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from pyautonomousagent.studio import Studio

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
PAUSE = """
const done = arguments[arguments.length - 1];
const t0 = performance.now();
fetch("/api/control", {method: "POST", body: JSON.stringify({action: "pause"})})
  .then((r) => r.json()).then(async () => {
    const acknowledged = performance.now() - t0;
    const first = await (await fetch("/api/frame")).json();
    await new Promise((ok) => setTimeout(ok, 500));
    const later = await (await fetch("/api/frame")).json();
    done({acknowledged, at: first.iteration, later: later.iteration, playing: later.playing});
  });
"""


def browser(profile: str) -> Any:
    """Headless Chromium with the test suite's offline flags."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--window-size=1500,1000",
        f"--user-data-dir={profile}",
        "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
        "--proxy-server=http://127.0.0.1:9",
    ):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def frames_per_second(driver: Any, seconds: float) -> tuple[float, int]:
    """Frames the page drew per second over ``seconds``, and the iterations run."""
    count = "return window.studio.framesDrawn()"
    iteration = "return window.studio.iteration()"
    frames0, it0, t0 = driver.execute_script(count), driver.execute_script(iteration), time.time()
    time.sleep(seconds)
    frames, it = driver.execute_script(count), driver.execute_script(iteration)
    return (frames - frames0) / (time.time() - t0), it - it0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenario", default="patrol")
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--speed", type=int, default=200, help="iterations per second")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="pyaa-studio-"))
    profile = tempfile.mkdtemp(prefix="pyaa-chromium-")
    studio = Studio(args.scenario, root).start()
    studio.session.configure({"agents": args.agents})
    driver = browser(profile)
    try:
        driver.get(studio.url)
        while "can run" not in driver.find_element("id", "message").text:
            time.sleep(0.1)
        driver.execute_script(f"document.getElementById('speed').value = '{args.speed}'")
        driver.find_element("id", "reset").click()
        driver.find_element("id", "play").click()
        time.sleep(1.0)
        fps, iterations = frames_per_second(driver, args.seconds)
        print(
            f"{args.scenario}, {args.agents} agents, play at {args.speed} it/s: "
            f"{fps:.1f} frames/s drawn, {iterations / args.seconds:.0f} iterations/s run"
        )
        point = driver.execute_script("return window.studio.agentPoint(0)")
        from selenium.webdriver.common.action_chains import ActionChains

        click = ActionChains(driver)
        click.w3c_actions.pointer_action.move_to_location(int(point["x"]), int(point["y"]))
        click.w3c_actions.pointer_action.click()
        click.perform()
        fps, _ = frames_per_second(driver, args.seconds)
        print(f"  following a drone (its statuses on the blocks): {fps:.1f} frames/s drawn")
        pause = driver.execute_async_script(PAUSE)
        print(
            f"  pause: acknowledged in {pause['acknowledged']:.0f} ms; iteration "
            f"{pause['at']} then {pause['later']} 0.5 s later (playing: {pause['playing']})"
        )
    finally:
        driver.quit()
        studio.shutdown()
        shutil.rmtree(profile, ignore_errors=True)
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
