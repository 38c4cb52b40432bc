"""Size and load time of ``replay.html`` files in headless Chromium (the load event).

    python scripts/replay_load_time.py RUN_DIR [RUN_DIR ...] [--rounds 3]

Prints, per run folder, the page's size in MB and the time from navigation start to the end
of the load event (the page has parsed its data and drawn its first frame), the least of
``--rounds`` loads. Needs Debian's ``chromium`` and ``chromium-driver`` and selenium.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    profile = tempfile.mkdtemp(prefix="pyaa-chromium-")
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", f"--user-data-dir={profile}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    try:
        for run in args.runs:
            page = (run / "replay.html").resolve()
            times = []
            for _ in range(args.rounds):
                driver.get(page.as_uri())
                times.append(
                    driver.execute_script(
                        "const t = performance.getEntriesByType('navigation')[0];"
                        "return t.loadEventEnd - t.startTime;"
                    )
                )
            size = page.stat().st_size / 1e6
            print(f"{run}: {size:.2f} MB, load {min(times):.0f} ms (least of {args.rounds})")
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    main()
