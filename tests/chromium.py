"""Debian's headless Chromium for the browser tests, offline: every host but 127.0.0.1
resolves to nothing and every proxy is refused, in a fresh profile removed afterwards.

Needs ``/usr/bin/chromium`` and ``chromedriver`` (``make test`` installs Debian's
``chromium`` and ``chromium-driver`` when missing and it can) and selenium (the ``[test]``
extra); :func:`offline_chromium` skips the test, with the reason, without them.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = "/usr/bin/chromium"


def driver_path() -> str | None:
    """chromedriver's path, or None."""
    return shutil.which("chromedriver") or (
        "/usr/bin/chromedriver" if Path("/usr/bin/chromedriver").exists() else None
    )


@contextmanager
def offline_chromium(width: int, height: int, console: bool = False) -> Iterator[Any]:
    """A selenium driver of headless Chromium with a ``width`` x ``height`` window; with
    ``console`` the page's console is kept (``driver.get_log("browser")``)."""
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
    if not Path(CHROMIUM).exists() or driver_path() is None:
        pytest.skip("no chromium/chromedriver: apt-get install chromium chromium-driver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="pyaa-chromium-")
    flags = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
             "--no-first-run", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", f"--window-size={width},{height}",
             "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
             "--proxy-server=http://127.0.0.1:9", f"--user-data-dir={profile}")  # fmt: skip
    for flag in flags:
        options.add_argument(flag)
    if console:
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(driver_path()), options=options)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
