"""`pip install .` alone (no extra): the package imports and runs the gathering scenario
without numba, numba-cuda or CuPy, and the compiled and GPU engines say in one line which
extra they need. numba is hidden from a fresh interpreter (``sys.modules[name] = None``
makes its import fail as if it were not installed)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

HIDE_EXTRAS = "import sys\nfor name in ('numba', 'cupy'): sys.modules[name] = None\n"


def _run(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", HIDE_EXTRAS + code], capture_output=True,
                          text=True, timeout=300)  # fmt: skip


def test_without_numba_the_package_runs_gathering(tmp_path: Path) -> None:
    out = tmp_path / "run"
    done = _run(
        "from pyautonomousagent import cli\n"
        f"sys.exit(cli.main(['run', 'gathering', '--iterations', '30', '--no-gif', '--quiet', "
        f"'--out', {str(out)!r}]))"
    )
    assert done.returncode == 0, done.stderr
    assert (out / "states.parquet").is_file() and (out / "run.json").is_file()


@pytest.mark.parametrize(("engine", "extra"), [("compiled", "[fast]"), ("gpu", "[gpu]")])
def test_without_numba_a_fast_engine_names_its_extra_in_one_line(
    engine: str, extra: str, tmp_path: Path
) -> None:
    done = _run(
        "from pyautonomousagent import cli\n"
        f"sys.exit(cli.main(['run', 'patrol', '--engine', {engine!r}, '--iterations', '5', "
        f"'--no-gif', '--quiet', '--out', {str(tmp_path / 'run')!r}]))"
    )
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert extra in line and "Traceback" not in done.stderr
    assert not (tmp_path / "run").exists()
