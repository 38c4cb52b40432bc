"""A real JupyterLab server for the browser tests: local, offline, fixed token, throw-away.

:func:`jupyterlab` starts ``python -m jupyterlab`` (the ``[test]`` extra installs it) on
127.0.0.1 at a free port, serving a temporary folder, with every Jupyter folder (config,
data, runtime, IPython's) inside a temporary folder too, so nothing of the user's set-up is
read or written; JupyterLab's news and update checks are off (nothing is fetched). Its
kernel is this Python (a kernelspec written there), importing this checkout's package. The
server's log is kept in a file (:attr:`Lab.log`); on leaving, the server is asked to shut
down (its kernels with it), then terminated, then killed, by its own process id.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path

import pytest

#: The server's fixed token (it listens on 127.0.0.1 only, for one test).
TOKEN = "pyaa-studio-test"
#: The kernelspec the notebooks name: this Python.
KERNEL = "pyaa-test-python"
#: Seconds the server may take to answer.
START_SECONDS = 60.0


@dataclass(frozen=True)
class Lab:
    """A running JupyterLab.

    Attributes:
        url: its address, ``http://127.0.0.1:PORT/``.
        root: the folder it serves (notebooks go here; kernels start here).
        log: the file holding the server's standard output and error.
    """

    url: str
    root: Path
    log: Path

    def page(self, notebook: str) -> str:
        """The address of JupyterLab's own page with ``notebook`` (a path under root) open."""
        return f"{self.url}lab/tree/{notebook}?token={TOKEN}"

    def log_text(self) -> str:
        """The server's log so far (the end of it), for a failing test's message."""
        text = self.log.read_text(encoding="utf-8", errors="replace") if self.log.exists() else ""
        return text[-6000:]


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def write_kernelspec(data_dir: Path) -> None:
    """A kernelspec named :data:`KERNEL` that runs ipykernel on this Python."""
    folder = data_dir / "kernels" / KERNEL
    folder.mkdir(parents=True)
    spec = {
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python (pyaa test)",
        "language": "python",
    }
    (folder / "kernel.json").write_text(json.dumps(spec), encoding="utf-8")


def write_settings(config_dir: Path) -> None:
    """JupyterLab's user settings: no question about fetching news (a toast over the page)."""
    folder = config_dir / "lab" / "user-settings" / "@jupyterlab" / "apputils-extension"
    folder.mkdir(parents=True)
    (folder / "notification.jupyterlab-settings").write_text(
        json.dumps({"fetchNews": "false"}), encoding="utf-8"
    )


def notebook_json(*cells: str) -> str:
    """A notebook of code ``cells`` (no outputs) naming :data:`KERNEL`."""
    code = [
        {"cell_type": "code", "execution_count": None, "id": f"cell-{i}", "metadata": {},
         "outputs": [], "source": source}
        for i, source in enumerate(cells)
    ]  # fmt: skip
    spec = {"name": KERNEL, "display_name": "Python (pyaa test)", "language": "python"}
    notebook = {"cells": code, "metadata": {"kernelspec": spec}, "nbformat": 4,
                "nbformat_minor": 5}  # fmt: skip
    return json.dumps(notebook, indent=1)


def _environment(home: Path) -> dict[str, str]:
    """The server's environment: Jupyter's and IPython's folders under ``home``, and this
    checkout's package first on the kernel's path."""
    import pyautonomousagent

    source = str(Path(pyautonomousagent.__file__).resolve().parents[1])
    env = dict(os.environ)
    for name, sub in (("JUPYTER_CONFIG_DIR", "config"), ("JUPYTER_DATA_DIR", "data"),
                      ("JUPYTER_RUNTIME_DIR", "runtime"), ("IPYTHONDIR", "ipython")):  # fmt: skip
        (home / sub).mkdir(parents=True, exist_ok=True)
        env[name] = str(home / sub)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (source, env.get("PYTHONPATH")) if p)
    env["JUPYTER_PLATFORM_DIRS"] = "1"
    return env


def _command(root: Path, port: int) -> list[str]:
    command = [
        sys.executable, "-m", "jupyterlab", "--no-browser", "--ServerApp.ip=127.0.0.1",
        f"--ServerApp.port={port}", "--ServerApp.port_retries=0",
        f"--ServerApp.root_dir={root}", f"--IdentityProvider.token={TOKEN}",
        "--PasswordIdentityProvider.hashed_password=", "--LabApp.news_url=None",
        "--LabApp.check_for_updates_class="
        "jupyterlab.handlers.announcements.NeverCheckForUpdate",
    ]  # fmt: skip
    if hasattr(os, "getuid") and os.getuid() == 0:
        command.append("--allow-root")  # a container's root
    return command


def _answers(url: str) -> bool:
    try:
        with urllib.request.urlopen(f"{url}api/status?token={TOKEN}", timeout=2) as reply:
            return bool(reply.status == 200)
    except (urllib.error.URLError, OSError):
        return False


def _stop(process: subprocess.Popen[bytes], url: str) -> None:
    """Ask the server to shut down (its kernels too); terminate, then kill, if it lingers."""
    if process.poll() is None:
        request = urllib.request.Request(f"{url}api/shutdown?token={TOKEN}", method="POST")
        with suppress(urllib.error.URLError, OSError):
            urllib.request.urlopen(request, timeout=5).close()
    for signal_it in (None, process.terminate, process.kill):
        if signal_it is not None and process.poll() is None:
            signal_it()
        try:
            process.wait(timeout=10)
            return
        except subprocess.TimeoutExpired:
            continue


@contextmanager
def jupyterlab(home: Path) -> Iterator[Lab]:
    """A JupyterLab serving ``home/root``, its Jupyter folders and log under ``home``;
    skips the test when JupyterLab is not installed."""
    pytest.importorskip("jupyterlab", reason="jupyterlab is not installed (the [test] extra)")
    root = home / "root"
    root.mkdir(parents=True)
    env = _environment(home)
    write_kernelspec(Path(env["JUPYTER_DATA_DIR"]))
    write_settings(Path(env["JUPYTER_CONFIG_DIR"]))
    port = free_port()
    url = f"http://127.0.0.1:{port}/"
    log = home / "jupyterlab.log"
    with log.open("wb") as out:
        process = subprocess.Popen(_command(root, port), cwd=root, env=env, stdout=out,
                                   stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)  # fmt: skip
    lab = Lab(url, root, log)
    try:
        end = time.monotonic() + START_SECONDS
        while not _answers(url):
            if process.poll() is not None or time.monotonic() > end:
                raise AssertionError(f"JupyterLab did not start:\n{lab.log_text()}")
            time.sleep(0.2)
        yield lab
    finally:
        _stop(process, url)
