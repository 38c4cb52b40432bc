"""Run folders are never lost nor written where they must not be: one writer at a time, a
commit that survives kill -9 at every step, stale temporary folders cleaned, outputs that
never land on a run's own files, and mount points refused before anything is deleted."""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pyautonomousagent import folders, runs
from pyautonomousagent.cli import main
from pyautonomousagent.experiments import Experiment, ExperimentError, sweep
from pyautonomousagent.runs import RunError, claim_run, recover_run, verify

from .test_experiments import same_rows
from .test_runs import SHORT, SRC, leftovers, one_line, run_cli, snapshot, tmpfs  # noqa: F401

FOLDERS_PY = str(Path(SRC) / "pyautonomousagent" / "folders.py")


@pytest.fixture
def earlier(tmp_path) -> Path:
    """A complete run in ``tmp_path/run`` (seed 1)."""
    out = tmp_path / "run"
    assert run_cli(out, "--no-gif", "--no-replay", "--seed", "1") == 0
    return out


# --- one writer at a time -------------------------------------------------------------------


def test_a_second_writer_is_refused_in_one_line(tmp_path, capsys):
    out = tmp_path / "new"
    with claim_run(out) as held:
        assert held.folder == out and held.notes == []
        assert run_cli(out, "--no-gif", "--overwrite") == 2
        line = one_line(capsys.readouterr().err)
        assert "is being written by another run" in line and str(os.getpid()) in line
        assert not out.exists()
    assert run_cli(out, "--no-gif", "--no-replay") == 0  # released on leaving
    verify(out)
    assert leftovers(tmp_path) == []  # no lock file left behind


HOLDER = """
import sys
from pyautonomousagent.runs import claim_run
with claim_run(sys.argv[1], overwrite=True):
    print("READY", flush=True)
    sys.stdin.read()
"""


def test_a_claim_held_by_another_process_refuses_and_dies_with_it(earlier, capsys):
    before = snapshot(earlier)
    env = {**os.environ, "PYTHONPATH": SRC}
    with subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(earlier)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    ) as holder:
        assert holder.stdout is not None and holder.stdout.readline().startswith("READY")
        capsys.readouterr()
        assert run_cli(earlier, "--no-gif", "--overwrite", "--seed", "2") == 2
        assert f"process {holder.pid}" in one_line(capsys.readouterr().err)
        assert snapshot(earlier) == before
        holder.kill()  # kill -9: the kernel lets go of the lock
        holder.wait()
    assert run_cli(earlier, "--no-gif", "--no-replay", "--overwrite", "--seed", "2") == 0
    assert verify(earlier)["seed"] == 2


def test_two_runs_into_one_new_folder_at_once_keep_one_whole_run(tmp_path):
    out = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": SRC}
    argv = [sys.executable, "-m", "pyautonomousagent.cli", "run", "gathering", "--out"]
    argv += [str(out), *SHORT, "--no-gif"]
    children = [
        subprocess.Popen([*argv, "--seed", str(seed)], stderr=subprocess.PIPE, text=True, env=env)
        for seed in (1, 2)
    ]
    results = [(child.wait(timeout=300), child.stderr.read()) for child in children]  # type: ignore[union-attr]
    assert sorted(code for code, _ in results) == [0, 2], results
    (err,) = [err for code, err in results if code == 2]
    assert "being written by another run" in err or "holds an earlier run" in err
    (code_0_seed,) = [seed for seed, (code, _) in zip((1, 2), results, strict=True) if code == 0]
    assert verify(out)["seed"] == code_0_seed  # the run that exited 0 is the one kept
    assert leftovers(tmp_path) == []


# --- kill -9 during the commit ----------------------------------------------------------------

COMMIT_DRIVER = """
import importlib.util, os, sys
from pathlib import Path
spec = importlib.util.spec_from_file_location("folders", sys.argv[1])
folders = importlib.util.module_from_spec(spec)
sys.modules["folders"] = folders
spec.loader.exec_module(folders)
step, temp, target = int(sys.argv[2]), Path(sys.argv[3]), Path(sys.argv[4])
done = [0]
def dying(call):
    def wrapper(*args, **kwargs):
        done[0] += 1
        if done[0] == step:
            os._exit(137)  # as kill -9: no handler, no cleanup
        return call(*args, **kwargs)
    return wrapper
for name in ("mkdir", "rename", "replace", "rmdir", "unlink"):
    setattr(os, name, dying(getattr(os, name)))
folders.commit(temp, target, replace=True)
"""


def test_a_commit_killed_at_any_step_leaves_a_run_that_verifies_or_is_put_back(earlier, tmp_path):
    new = tmp_path / "source"
    assert run_cli(new, "--no-gif", "--seed", "2") == 0
    pristine = tmp_path / "pristine"
    shutil.copytree(earlier, pristine)
    outcomes = []
    for step in range(1, 40):
        shutil.rmtree(earlier, ignore_errors=True)
        shutil.copytree(pristine, earlier)
        temp = folders.hidden_folder(earlier, "tmp")
        shutil.copytree(new, temp, dirs_exist_ok=True)
        code = subprocess.run(
            [sys.executable, "-c", COMMIT_DRIVER, FOLDERS_PY, str(step), str(temp), str(earlier)],
            check=False,
        ).returncode
        outcomes.append(_check_after_kill(earlier, code))
        if code == 0:
            break
    print("states after a kill at each step:", outcomes)
    assert code == 0 and len(outcomes) >= 6, outcomes  # mkdir, 2 renames, the deletions
    assert "hidden" in outcomes and "new" in outcomes and "earlier" in outcomes


def _check_after_kill(target: Path, code: int) -> str:
    """After a commit killed (or not): the run at ``target`` verifies, or verify names the
    earlier run and recovery puts it back; then nothing is left beside it."""
    try:
        seed = verify(target)["seed"]
        state = "new" if seed == 2 else "earlier"
    except RunError as error:
        assert ".run.old-" in str(error) and "puts back" in str(error), error
        state = "hidden"
    notes = recover_run(target)
    assert verify(target)["seed"] == (1 if state == "hidden" else 2 if state == "new" else 1)
    if state == "hidden":
        assert any(note.startswith("restored the earlier folder") for note in notes), notes
    assert leftovers(target.parent) == []
    assert code in (0, 137)
    return state


DIE_IN_COMMIT = """
import os, sys
from pyautonomousagent import cli, runs
commit, step = runs.commit, int(sys.argv.pop(1))
def dying_commit(temp, target, replace=False):
    rename, done = os.rename, [0]
    def counted(*args):
        done[0] += 1
        if done[0] == step:
            os._exit(137)
        return rename(*args)
    os.rename = counted
    commit(temp, target, replace)
runs.commit = dying_commit
sys.exit(cli.main(sys.argv[1:]))
"""


@pytest.mark.parametrize("step", [1, 2, 3])
def test_pyaa_run_killed_in_its_commit_is_repaired_by_the_next_run(earlier, capsys, step):
    """Killed before the 1st rename (the earlier run aside), before the 2nd (the new run
    in), or not at all (there is no 3rd): the next run puts back or keeps a whole run."""
    before = snapshot(earlier)
    argv = ["run", "gathering", "--out", str(earlier), *SHORT, "--no-gif", "--overwrite"]
    env = {**os.environ, "PYTHONPATH": SRC}
    done = subprocess.run(
        [sys.executable, "-c", DIE_IN_COMMIT, str(step), *argv], env=env, check=False
    )
    assert done.returncode == (137 if step < 3 else 0)
    if step == 2:
        assert not (earlier / "run.json").exists()
        with pytest.raises(RunError, match=r"left the earlier run in .*\.run\.old-"):
            verify(earlier)
    capsys.readouterr()
    assert run_cli(earlier, "--no-gif") == 2  # repaired, then refused: it holds a run
    err = capsys.readouterr().err.strip().splitlines()
    assert "Traceback" not in "".join(err) and "holds an earlier run" in err[-1], err
    if step == 1:  # the earlier run stayed; the empty folder made for it and the new run go
        assert len(err) == 3 and ".run.old-" in err[0] and ".run.tmp-" in err[1], err
    if step == 2:  # the earlier run is put back; the new run, not committed, goes
        assert err[0].startswith("pyaa: restored the earlier folder in") and len(err) == 3
        assert err[1].startswith("pyaa: removed") and ".run.tmp-" in err[1]
    assert (snapshot(earlier) == before) == (step < 3)
    assert verify(earlier)["seed"] == (1 if step < 3 else 0)
    assert leftovers(earlier.parent) == []


def test_stale_temporary_folders_are_removed_with_a_message(tmp_path, capsys):
    out = tmp_path / "run"
    stale = tmp_path / ".run.tmp-0123456789ab"
    (stale / "sub").mkdir(parents=True)
    (stale / "states.parquet").write_bytes(b"half")
    mine = tmp_path / ".run.tmp-mine"  # not a name pyaa makes: never touched
    mine.mkdir()
    other = tmp_path / ".runs.tmp-0123456789ab"  # another folder's: left to it
    other.mkdir()
    assert run_cli(out, "--no-gif", "--no-replay") == 0
    err = capsys.readouterr().err.strip()
    assert err == f"pyaa: removed {stale}, left unfinished by a writer that was stopped"
    assert sorted(leftovers(tmp_path)) == [".run.tmp-mine", ".runs.tmp-0123456789ab"]
    verify(out)


# --- a rename that cannot be done -------------------------------------------------------------


@pytest.mark.parametrize("failing", [1, 2])
def test_a_failed_rename_in_the_commit_keeps_the_earlier_run(earlier, monkeypatch, capsys, failing):
    before = snapshot(earlier)
    rename, calls = os.rename, []

    def busy(source, target):
        calls.append(source)
        if len(calls) == failing:
            raise OSError(errno.EBUSY, "Device or resource busy", str(source))
        rename(source, target)

    monkeypatch.setattr(folders.os, "rename", busy)
    capsys.readouterr()
    assert run_cli(earlier, "--no-gif", "--overwrite", "--seed", "3") == 1
    line = one_line(capsys.readouterr().err)
    assert "Device or resource busy" in line and "the earlier run" in line and "intact" in line
    assert snapshot(earlier) == before
    assert verify(earlier)["seed"] == 1
    assert leftovers(earlier.parent) == []


def test_a_mount_point_is_refused_before_anything_is_deleted(tmpfs, capsys):  # noqa: F811
    assert run_cli(tmpfs / "inside", "--no-gif", "--no-replay") == 0
    for path in (tmpfs / "inside").iterdir():
        path.rename(tmpfs / path.name)  # a run folder that is itself a mount point
    (tmpfs / "inside").rmdir()
    before = snapshot(tmpfs)
    capsys.readouterr()
    assert run_cli(tmpfs, "--no-gif", "--overwrite") == 2
    assert "is a mount point" in one_line(capsys.readouterr().err)
    assert snapshot(tmpfs) == before
    verify(tmpfs)


# --- outputs that would land on a run's own files ------------------------------------------


@pytest.mark.parametrize("name", ["states.parquet", "run.json", "traces.parquet"])
def test_replay_never_writes_over_a_runs_own_files(earlier, tmp_path, capsys, name):
    before = snapshot(earlier)
    capsys.readouterr()
    assert main(["replay", str(earlier), "--out", str(earlier / name)]) == 2
    assert "is a file of the run in" in one_line(capsys.readouterr().err)
    assert main(["replay", str(earlier), "--out", str(tmp_path / "x" / ".." / "run" / name)]) == 2
    other = tmp_path / "other"
    shutil.copytree(earlier, other)
    assert main(["replay", str(earlier), "--out", str(other / name)]) == 2
    capsys.readouterr()
    assert snapshot(earlier) == before and snapshot(other) == before
    verify(earlier)


def test_replay_writes_the_named_file_only(earlier, tmp_path, capsys):
    elsewhere = tmp_path / "pages"
    elsewhere.mkdir()
    (elsewhere / "replay.html").write_text("mine")
    assert main(["replay", str(earlier), "--out", str(elsewhere / "page.html")]) == 0
    assert (elsewhere / "replay.html").read_text() == "mine"  # not written, then renamed
    assert sorted(p.name for p in elsewhere.iterdir()) == ["page.html", "replay.html"]
    assert main(["replay", str(earlier), "--out", str(earlier / "page.html")]) == 0
    assert "page.html" in {f["name"] for f in verify(earlier)["files"]}
    assert main(["replay", str(earlier)]) == 0  # its own replay.html: rewritten, listed
    assert "replay.html" in {f["name"] for f in verify(earlier)["files"]}
    assert leftovers(earlier) == [] and leftovers(elsewhere) == []


def test_pyaa_verify_says_one_line_and_exits_1_naming_what_differs(earlier, capsys):
    assert main(["verify", str(earlier)]) == 0
    (line,) = capsys.readouterr().out.splitlines()
    assert line.startswith(f"{earlier}: complete run of ") and line.endswith("match run.json")
    states = earlier / "states.parquet"
    states.write_bytes(states.read_bytes() + b"x")
    assert main(["verify", str(earlier)]) == 1
    assert "states.parquet differs from run.json" in one_line(capsys.readouterr().err)
    assert main(["verify", str(earlier.parent / "nothing-here")]) == 1
    assert "is not a complete run folder" in one_line(capsys.readouterr().err)


def test_check_output_refuses_folders_and_run_files(earlier):
    with pytest.raises(RunError, match="is a folder"):
        runs.check_output(earlier)
    with pytest.raises(RunError, match="is a file of the run"):
        runs.check_output(earlier / "states.parquet", earlier, ["replay.html"])
    assert runs.check_output(earlier / "x.html") == (earlier / "x.html").resolve()


# --- sweeps ------------------------------------------------------------------------------------

SMALL = {
    "scenario": "patrol",
    "iterations": 20,
    "set": {"agents": 3},
    "vary": {"low_energy_threshold": [96, 99]},
    "seeds": 2,
    "measures": ["minimum_energy"],
}


@pytest.mark.parametrize("name", ["../../x", "..", "a/b", "/tmp/x", "a\\b"])
def test_a_sweep_name_cannot_leave_the_sweeps_folder(tmp_path, monkeypatch, capsys, name):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "exp.yaml").write_text(json.dumps({**SMALL, "name": name}))
    assert main(["sweep", "exp.yaml", "--serial", "--quiet"]) == 2
    assert "name must be a folder name" in one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp.yaml"]  # nothing written


def test_a_sweep_into_a_linked_folder_outside_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs" / "sweeps").mkdir(parents=True)
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "runs" / "sweeps" / "exp").symlink_to(tmp_path / "elsewhere")
    (tmp_path / "exp.yaml").write_text(json.dumps(SMALL))
    assert main(["sweep", "exp.yaml", "--serial", "--quiet"]) == 2
    assert "outside runs/sweeps" in one_line(capsys.readouterr().err)
    assert list((tmp_path / "elsewhere").iterdir()) == []


def test_a_torn_journal_part_is_set_aside_and_its_runs_run_again(tmp_path, capsys):
    experiment = Experiment.from_mapping(SMALL)
    out = tmp_path / "s"
    first = sweep(experiment, out, "serial", flush_every=1)
    parts = sorted((out / "journal").glob("part-*.parquet"))
    assert first.counts["ok"] == 4 and len(parts) == 4
    parts[1].write_bytes(b"")  # empty
    parts[2].write_bytes(parts[2].read_bytes()[:-20])  # torn: no footer
    (out / "journal" / f".part-000009.parquet.{'0' * 32}.tmp").write_bytes(b"half")
    notes: list[str] = []
    again = sweep(experiment, out, "serial", resume=True, report=notes.append)
    assert again.counts == {"ok": 2, "failed": 0, "skipped": 2}
    assert len(notes) == 3 and notes[0].startswith("removed 1 temporary file"), notes
    assert all("cannot be read" in n and "its runs run again" in n for n in notes[1:]), notes
    assert same_rows(again.table, first.table, ignore=("seconds",))
    names = sorted(p.name for p in (out / "journal").iterdir())
    assert names == [".part-000001.parquet.torn", ".part-000002.parquet.torn"] + [
        f"part-00000{i}.parquet" for i in (0, 3, 4)
    ]
    assert sweep(experiment, out, "serial", resume=True).counts["skipped"] == 4


def test_pyaa_sweep_resume_says_in_one_line_what_it_reruns(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "exp.yaml").write_text(json.dumps(SMALL))
    assert main(["sweep", "exp.yaml", "--serial", "--quiet"]) == 0
    (part,) = (tmp_path / "runs" / "sweeps" / "exp" / "journal").glob("part-*.parquet")
    part.write_bytes(b"PAR1")
    capsys.readouterr()
    assert main(["sweep", "exp.yaml", "--serial", "--quiet", "--resume"]) == 0
    assert "its runs run again" in one_line(capsys.readouterr().err)
    manifest = tmp_path / "runs" / "sweeps" / "exp" / "experiment.json"
    manifest.write_text('{"experiment": ')  # torn
    assert main(["sweep", "exp.yaml", "--serial", "--quiet", "--resume"]) == 2
    assert "experiment.json cannot be read" in one_line(capsys.readouterr().err)


def test_a_sweep_into_a_folder_another_process_holds_is_refused(tmp_path):
    experiment = Experiment.from_mapping(SMALL)
    out = tmp_path / "s"
    with folders.claimed(out), pytest.raises(ExperimentError, match="being written by another"):
        sweep(experiment, out, "serial")
    assert not out.exists()
    assert sweep(experiment, out, "serial").counts["ok"] == 4
    assert leftovers(tmp_path) == []


def test_replay_removes_what_a_killed_replay_left_in_the_run_folder(earlier, capsys):
    stale = earlier / ".replay.html.tmp-0123456789ab"
    stale.mkdir()
    (stale / "replay.html").write_text("half")
    capsys.readouterr()
    assert main(["replay", str(earlier)]) == 0
    assert f"pyaa: removed {stale}" in capsys.readouterr().err
    assert leftovers(earlier) == []
    verify(earlier)


def test_tree_output_never_lands_on_a_runs_own_files(earlier, capsys):
    before = snapshot(earlier)
    for name, fmt in (("run.json", "xml"), ("states.parquet", "yaml"), ("traces.parquet", "png")):
        argv = ["tree", "gathering", "--format", fmt, "--out", str(earlier / name)]
        assert main(argv) == 2
        assert "is a file of the run in" in one_line(capsys.readouterr().err)
    assert snapshot(earlier) == before
    assert main(["tree", "gathering", "--format", "xml", "--out", str(earlier / "t.xml")]) == 0


def test_tree_output_never_lands_on_a_sweeps_own_files(tmp_path, capsys):
    sweep = tmp_path / "sweep"
    (sweep / "journal").mkdir(parents=True)
    for name in ("experiment.json", "results.parquet", "journal/part-0.parquet"):
        (sweep / name).write_text("the sweep's")
    for name in ("experiment.json", "results.parquet", "journal/part-0.parquet", "journal/x"):
        argv = ["tree", "gathering", "--format", "xml", "--out", str(sweep / name)]
        assert main(argv) == 2
        assert "is a file of the sweep in" in one_line(capsys.readouterr().err)
    assert all((sweep / n).read_text() == "the sweep's" for n in ("experiment.json",
               "results.parquet", "journal/part-0.parquet"))  # fmt: skip
    assert main(["tree", "gathering", "--format", "xml", "--out", str(sweep / "t.xml")]) == 0


def test_recovery_never_deletes_an_earlier_run_it_cannot_put_back(earlier, tmp_path):
    aside = tmp_path / ".run.old-0123456789ab"
    aside.mkdir()
    earlier.rename(aside / "run")
    earlier.mkdir()
    (earlier / "notes.txt").write_text("someone else's")  # not a run, not empty
    (note,) = recover_run(earlier)
    assert note == f"{aside} holds an earlier run, left by a writer that was stopped; check it"
    verify(aside / "run")
    assert [p.name for p in earlier.iterdir()] == ["notes.txt"]
    with pytest.raises(RunError, match="left the earlier run in"):
        verify(earlier)
