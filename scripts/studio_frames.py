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
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from pyautonomousagent.studio import Studio

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
RESET = """
const done = arguments[arguments.length - 1];
fetch("/api/control", {method: "POST", body: JSON.stringify({action: "reset"})}).then(done);
"""
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


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far (Linux /proc; 0 if gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _tree(root: int) -> list[int]:
    """``root`` and every process below it (Linux /proc)."""
    parents: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        parents.setdefault(ppid, []).append(int(stat.parent.name))
    found, todo = [], [root]
    while todo:
        pid = todo.pop()
        found.append(pid)
        todo.extend(parents.get(pid, []))
    return found


def cpu_now(driver: Any) -> tuple[float, float]:
    """CPU seconds used so far by the browser (chromedriver and every Chromium process) and
    by this process (the studio's server threads)."""
    browser = sum(_cpu_seconds(pid) for pid in _tree(driver.service.process.pid))
    return browser, _cpu_seconds(os.getpid())


def frames_per_second(driver: Any, seconds: float) -> tuple[float, int, str]:
    """Frames the page drew per second over ``seconds``, the iterations run, and where a
    frame's time went (the page's own profile: milliseconds per frame for the request and
    its JSON, the map, the plots, the node list and the blocks' labels)."""
    count = "return window.studio.framesDrawn()"
    iteration = "return window.studio.iteration()"
    profile = "return window.studio.profile ? window.studio.profile() : null"
    frames0, it0, t0 = driver.execute_script(count), driver.execute_script(iteration), time.time()
    before, cpu0 = driver.execute_script(profile), cpu_now(driver)
    time.sleep(seconds)
    frames, it = driver.execute_script(count), driver.execute_script(iteration)
    after, cpu1 = driver.execute_script(profile), cpu_now(driver)
    fps = (frames - frames0) / (time.time() - t0)
    drawn = max(1, frames - frames0)
    cpu = (
        f"CPU ms per frame: browser {(cpu1[0] - cpu0[0]) * 1000 / drawn:.1f}, "
        f"server {(cpu1[1] - cpu0[1]) * 1000 / drawn:.1f}"
    )
    if before is None or after is None:
        return fps, it - it0, f"{cpu} (this page keeps no profile)"
    parts = ("fetch", "world", "plots", "nodes", "blocks")
    spent = ", ".join(f"{k} {(after[k] - before[k]) / drawn:.1f}" for k in parts)
    new = (after.get("new", 0) - before.get("new", 0)) / (time.time() - t0)
    return fps, it - it0, f"{new:.1f} new iterations shown/s; {cpu}; page ms: {spent}"


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
        driver.execute_async_script(RESET)  # the new run is made (and its code loaded) first
        driver.find_element("id", "play").click()
        time.sleep(1.0)
        fps, iterations, spent = frames_per_second(driver, args.seconds)
        print(
            f"{args.scenario}, {args.agents} agents, play at {args.speed} it/s: "
            f"{fps:.1f} frames/s drawn, {iterations / args.seconds:.0f} iterations/s run"
        )
        print(f"  {spent}")
        point = driver.execute_script("return window.studio.agentPoint(0)")
        from selenium.webdriver.common.action_chains import ActionChains

        click = ActionChains(driver)
        click.w3c_actions.pointer_action.move_to_location(int(point["x"]), int(point["y"]))
        click.w3c_actions.pointer_action.click()
        click.perform()
        fps, _, spent = frames_per_second(driver, args.seconds)
        print(f"  following a drone (its statuses on the blocks): {fps:.1f} frames/s drawn")
        print(f"  {spent}")
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
