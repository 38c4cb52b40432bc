"""Runs as transactions: every run folder is complete or marked partial, and an earlier run
is never lost or mixed with a new one (disk full, read-only folder, Ctrl-C, re-runs)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.cli import main
from pyautonomousagent.runs import (
    RunError,
    check_target,
    default_folder,
    save_run,
    verify,
)

SHORT = ["--iterations", "60", "--quiet"]
SRC = str(Path(__file__).resolve().parents[1] / "src")


def run_cli(out: Path, *extra: str) -> int:
    return main(["run", "gathering", "--out", str(out), *SHORT, *extra])


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def leftovers(parent: Path) -> list[str]:
    return [p.name for p in parent.iterdir() if p.name.startswith(".")]


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_a_run_lists_its_files_with_checksums(tmp_path):
    out = tmp_path / "run"
    assert run_cli(out, "--no-gif", "--no-replay", "--set", "energy_use=0.1") == 0
    summary = verify(out)
    assert summary["status"] == "complete"
    assert summary["iterations_done"] == 60
    assert [f["name"] for f in summary["files"]] == ["states.parquet", "traces.parquet"]
    assert summary["trace"]["agents"] == ["drone1", "drone2", "drone3", "drone4"]
    assert summary["overrides"] == {"energy_use": 0.1}
    assert summary["tree"]["sha256"] and "<root" in summary["tree"]["content"]
    assert summary["versions"]["pyautonomousagent"]
    assert summary["command"][0] == "pyaa"
    assert sorted(p.name for p in out.iterdir()) == ["run.json", "states.parquet", "traces.parquet"]
    (out / "states.parquet").write_bytes(b"changed")
    with pytest.raises(RunError, match="differs from run.json"):
        verify(out)


def test_a_rerun_is_refused_and_the_earlier_run_kept(tmp_path, capsys):
    out = tmp_path / "run"
    assert run_cli(out, "--no-gif") == 0
    before = snapshot(out)
    capsys.readouterr()
    assert run_cli(out, "--no-gif", "--seed", "4") == 2
    assert "holds an earlier run; pass --overwrite" in one_line(capsys.readouterr().err)
    assert snapshot(out) == before


def test_overwrite_replaces_the_whole_folder_no_stale_files(tmp_path):
    out = tmp_path / "run"
    assert run_cli(out, "--frame-every", "30") == 0
    assert (out / "animation.gif").exists()
    assert (out / "replay.html").exists()
    argv = ["--no-gif", "--no-replay", "--format", "csv", "--overwrite", "--seed", "2"]
    assert run_cli(out, *argv) == 0
    assert sorted(p.name for p in out.iterdir()) == ["run.json", "states.csv", "traces.csv"]
    assert verify(out)["seed"] == 2
    assert leftovers(tmp_path) == []


def test_a_folder_of_other_files_is_never_written_into(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    assert run_cli(tmp_path, "--no-gif", "--overwrite") == 2
    assert "holds other files" in one_line(capsys.readouterr().err)
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]


def test_scenario_names_cannot_leave_runs():
    for name in ("../../x", "/etc/passwd", "..", "a/../../b", ".hidden"):
        folder = default_folder(name)
        assert folder.parent == Path("runs") and not folder.name.startswith("."), name
        assert ".." not in folder.parts


def test_the_python_api_saves_the_same_way(tmp_path):
    scenario = load("patrol").with_overrides(agents=2, iterations=30)
    sim = Simulation.create(scenario).run(progress=False)
    saved = save_run(sim, tmp_path / "api", animation=False, command=["notebook"])
    assert saved.status == "complete" and verify(saved.folder)["command"] == ["notebook"]
    with pytest.raises(RunError, match="earlier run"):
        save_run(sim, tmp_path / "api", animation=False)
    with pytest.raises(RunError, match="is a file"):
        check_target(tmp_path / "api" / "run.json")


@pytest.fixture
def tmpfs(tmp_path):
    """A 4 MB tmpfs (needs root and mount; skipped with the reason elsewhere)."""
    mount = tmp_path / "small"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(mount)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        reason = f"cannot mount a tmpfs here: {done.stderr.strip() or done.returncode}"
        print(reason)
        pytest.skip(reason)
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=False)


def fill(folder: Path) -> None:
    """Fill the file system of ``folder`` to the last byte."""
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT)
    try:
        for size in (65536, 512, 1):
            with contextlib.suppress(OSError):
                while True:
                    os.write(fd, b"\0" * size)
    finally:
        os.close(fd)


def test_disk_full_keeps_the_earlier_run(tmpfs, capsys):
    out = tmpfs / "run"
    assert run_cli(out, "--no-gif") == 0
    before = snapshot(out)
    fill(tmpfs)
    capsys.readouterr()
    assert run_cli(out, "--frame-every", "20", "--overwrite") == 1
    line = one_line(capsys.readouterr().err)
    assert "No space left on device" in line and "earlier run" in line and "intact" in line
    assert snapshot(out) == before
    verify(out)
    assert leftovers(tmpfs) == []


def test_read_only_folder_is_one_line_and_changes_nothing(tmpfs, capsys):
    out = tmpfs / "run"
    assert run_cli(out, "--no-gif") == 0
    before = snapshot(out)
    subprocess.run(["mount", "-o", "remount,ro", str(tmpfs)], check=True)
    capsys.readouterr()
    assert run_cli(out, "--no-gif", "--overwrite") == 2
    assert "Read-only file system" in one_line(capsys.readouterr().err)
    assert snapshot(out) == before
    assert run_cli(tmpfs / "new", "--no-gif") == 2
    assert "cannot" in one_line(capsys.readouterr().err)


DRIVER = """
import sys
from pyautonomousagent import cli
from pyautonomousagent.simulation.run import Simulation
from pyautonomousagent.render import animation

step, draw = Simulation.step, animation.write_animation
WHEN = sys.argv.pop(1)

def signal_when(at):
    print("READY", at, flush=True)

def patched_step(self):
    step(self)
    if self.world.iteration == 200 and WHEN == "simulation":
        signal_when("simulation")

def patched_draw(*args, **kwargs):
    if WHEN == "animation":
        signal_when("animation")
    return draw(*args, **kwargs)

Simulation.step = patched_step
animation.write_animation = patched_draw
sys.exit(cli.main(sys.argv[1:]))
"""


def interrupt(when: str, argv: list[str]) -> tuple[int, str]:
    """Run ``pyaa argv`` in a subprocess; send SIGINT once it reports READY."""
    env = {**os.environ, "PYTHONPATH": SRC}
    with subprocess.Popen(
        [sys.executable, "-c", DRIVER, when, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    ) as child:
        assert child.stdout is not None
        line = child.stdout.readline()
        assert line.startswith("READY"), child.stderr.read() if child.stderr else line
        child.send_signal(signal.SIGINT)
        _, err = child.communicate(timeout=60)
    return child.returncode, err


def test_ctrl_c_during_the_simulation_saves_a_marked_partial_run(tmp_path):
    out = tmp_path / "run"
    assert run_cli(out, "--no-gif") == 0
    before = snapshot(out)
    # the batched engine: the driver signals from Simulation.step, which the compiled
    # engine's fused loop does not call
    argv = ["run", "patrol", "--agents", "3", "--iterations", "2000000", "--record-every",
            "50", "--out", str(out), "--overwrite", "--engine", "batched"]  # fmt: skip
    code, err = interrupt("simulation", argv)
    assert code == 130, err
    assert "saved a partial run marked 'interrupted'" in one_line(err)
    assert snapshot(out) == before  # the earlier run is kept...
    (partial,) = [p for p in tmp_path.iterdir() if p.name.startswith("run-interrupted-")]
    summary = verify(partial)  # ...and the partial one is beside it, valid
    assert summary["status"] == "interrupted"
    done = summary["iterations_done"]
    assert 200 <= done < 2_000_000
    table = pq.read_table(partial / "states.parquet")
    assert table.num_rows == 3 * (done // 50 + 1) == 3 * summary["records"]
    assert leftovers(tmp_path) == []


def test_ctrl_c_during_the_animation_keeps_the_data_marked(tmp_path):
    out = tmp_path / "run"
    argv = ["run", "gathering", "--iterations", "3000", "--frame-every", "2", "--out", str(out)]
    code, err = interrupt("animation", argv)
    assert code == 130, err
    assert "Ctrl-C during the animation" in one_line(err)
    summary = verify(out)
    assert summary["status"] == "interrupted" and summary["iterations_done"] == 3000
    assert sorted(p.name for p in out.iterdir()) == ["run.json", "states.parquet", "traces.parquet"]
    assert leftovers(tmp_path) == []


def test_the_summary_splits_the_time_by_stage() -> None:
    from pyautonomousagent.cli import timings_line

    timings = {"setup": 0.01, "simulate": 2.1, "write_data": 0.05, "animation": 3.1,
               "replay": 0.1}  # fmt: skip
    views = "views 3.20 s (animation 3.10 s, replay 0.10 s)"
    assert timings_line(timings) == f"set-up 0.01 s, loop 2.10 s, writing 0.05 s, {views}"
    assert timings_line({"setup": 0.5, "simulate": 1.0}) == "set-up 0.50 s, loop 1.00 s"


def test_the_summary_shows_the_writing_beside_the_loop() -> None:
    from pyautonomousagent.cli import timings_line

    timings = {"setup": 0.5, "simulate": 1.0, "write_data": 0.05, "write_data_thread": 0.9}
    expected = "set-up 0.50 s, loop 1.00 s, writing 0.05 s after the loop (thread 0.90 s CPU)"
    assert timings_line(timings) == expected
