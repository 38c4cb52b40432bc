"""Saving a run as a transaction: a run folder is complete, marked partial, or not there.

    sim = Simulation.create(load("gathering"))
    status = simulate(sim)                       # "complete", or "interrupted" on Ctrl-C
    saved = save_run(sim, "runs/gathering", status=status)

A run's files (docs/data.md) are written into a temporary folder beside the target
(``.NAME.tmp-*``) and put in place whole with a rename, so an earlier run is never deleted by
a failure and never mixed with a new one. ``run.json``, written last, lists every file with
its size and SHA-256, and the run's status:

- ``complete``: every iteration was simulated and every file written;
- ``interrupted``: Ctrl-C stopped the simulation (the data holds the iterations done, a
  valid table) or the views (the data is complete, the views are left out);
- ``failed``: a view could not be drawn (the data is complete; ``note`` says why).

An earlier run in the folder is replaced only when asked (``overwrite=True``, ``pyaa run
--overwrite``; other folders: :func:`check_target`), never by an interrupted run, which is
saved beside it as ``NAME-interrupted-YYYYMMDD-HHMMSS``. One writer at a time:
:func:`claim_run` locks the folder and repairs what a killed writer left
(:mod:`pyautonomousagent.folders`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import platform
import re
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pyautonomousagent.bt.files import is_tree_file
from pyautonomousagent.folders import (
    BusyError,
    Claim,
    claimed,
    commit,
    hidden_folder,
    hidden_folders,
    lock_path,
)
from pyautonomousagent.inputs import InputError, shown
from pyautonomousagent.recording import node_list, write_table
from pyautonomousagent.simulation.scenario import to_mapping

if TYPE_CHECKING:
    from pyautonomousagent.render.views import Views
    from pyautonomousagent.simulation.run import Simulation
    from pyautonomousagent.streaming import StatesStream

STATUSES = ("complete", "interrupted", "failed")
#: The folder that default run folders live in.
RUNS = Path("runs")
SUMMARY = "run.json"
#: The packages whose versions ``run.json`` records (with Python's).
VERSIONED = ("pyautonomousagent", "numpy", "py_trees", "pyarrow", "matplotlib", "pillow")


class RunError(InputError):
    """A run that cannot be saved (one line: the reason, the fix): an output folder that
    cannot be used, or a :func:`save_run` of something that is no simulation, or of a
    simulation that never ran."""


class SaveError(OSError):
    """Writing a run failed (disk full, folder removed...); nothing was put in place."""


@dataclass
class SavedRun:
    """What :func:`save_run` put in place.

    Attributes:
        folder: the run folder.
        status: one of :data:`STATUSES`.
        files: the files written, ``run.json`` last.
        note: why the run is not complete, or where it went instead of the asked folder.
        notes: what taking the folder repaired (see :func:`claim_run`), one line each.
    """

    folder: Path
    status: str
    files: list[Path] = field(default_factory=list)
    note: str = ""
    notes: list[str] = field(default_factory=list)


def default_folder(name: str) -> Path:
    """``runs/NAME`` for a scenario name, made safe: it never leaves ``runs/``.

    Characters other than letters, digits, ``.``, ``_`` and ``-`` become ``_`` (so ``/`` and
    ``..`` cannot climb out), and leading dots are dropped (no hidden folders).
    """
    safe = re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip(".")[:100] or "run"
    return RUNS / safe


def is_run_folder(path: Path) -> bool:
    """Whether ``path`` is a folder written by :func:`save_run` (it holds ``run.json``)."""
    return (path / SUMMARY).is_file()


def check_target(folder: str | Path, overwrite: bool = False, create: bool = True) -> Path:
    """``folder`` if a run can be saved there; checked before a run starts. With ``create``
    false nothing is written (the parent is not made nor probed): the check ``pyaa run``
    makes before setting up a run (a compile can take minutes), so that a bad folder is
    refused at once.

    Raises:
        RunError: it is a file, it holds an earlier run and ``overwrite`` is false, it is
            a folder of other files, it is a mount point, or its parent cannot be created
            or written.
    """
    path = Path(folder)
    fix = "choose another folder with --out (out= in Python)"
    try:
        if path.exists() and not path.is_dir():
            raise RunError(f"output folder {path} is a file, not a folder; {fix}")
        if path.is_dir() and any(path.iterdir()):
            if not is_run_folder(path):
                raise RunError(
                    f"output folder {path} holds other files (no {SUMMARY}), which a run "
                    f"never writes into; {fix}"
                )
            if not overwrite:
                raise RunError(
                    f"output folder {path} holds an earlier run; pass --overwrite "
                    f"(overwrite=True) to replace it, or {fix}"
                )
        if os.path.ismount(path):
            raise RunError(
                f"output folder {path} is a mount point, which a run cannot be renamed into; "
                f"use a folder inside it (--out {path / 'NAME'}), or {fix}"
            )
        if not create:
            _check_ancestors(path)
            return path
        path.absolute().parent.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(FileNotFoundError):  # a claim's recovery may have taken it
            hidden_folder(path, "probe").rmdir()  # the parent is writable
    except OSError as error:
        raise RunError(f"cannot use output folder {path}: {_reason(error)}; {fix}") from None
    return path


def _check_ancestors(path: Path) -> None:
    """Raise NotADirectoryError where the nearest existing folder above ``path`` is a file."""
    nearest = next((a for a in path.absolute().parents if a.exists()), None)
    if nearest is not None and not nearest.is_dir():
        raise NotADirectoryError(20, "Not a directory", str(nearest))


@contextlib.contextmanager
def claim_run(
    folder: str | Path,
    overwrite: bool = False,
    keep: Sequence[Path] = (),
    report: Callable[[str], None] | None = None,
) -> Iterator[Claim]:
    """Hold ``folder`` for one run: checked (:func:`check_target`), locked, and repaired.

    ``Claim.notes`` says what a killed writer had left and what was done about it (an
    earlier run put back, temporary folders deleted), and each note goes to ``report`` as
    soon as it is done, before the folder is checked again; ``keep`` lists temporary
    folders of this process. The lock is released on leaving (or when the process ends).

    Raises:
        RunError: another process is writing ``folder``, or :func:`check_target` refuses it.
    """
    path = check_target(folder, overwrite=True)  # an earlier run: refused once repaired
    try:
        with claimed(path, keep, is_run_folder) as held:
            if report is not None:
                for note in held.notes:
                    report(note)
            check_target(path, overwrite)  # again: recovery may have put a run back
            yield held
    except BusyError as error:
        raise RunError(
            f"output folder {path} is being written by another run ({error.strerror}); "
            "wait for it to finish, or choose another folder with --out (out= in Python)"
        ) from None
    except OSError as error:
        if error.filename != str(lock_path(path)):
            raise
        raise RunError(f"cannot use output folder {path}: {_reason(error)}") from None


def recover_run(folder: str | Path) -> list[str]:
    """Repair what a killed ``pyaa run`` left at ``folder``: put an earlier run back, delete
    its temporary folders; one line per thing done (see :mod:`pyautonomousagent.folders`).

    Raises:
        RunError: another process is writing ``folder``.
    """
    with claim_existing(folder) as held:
        return held.notes


def simulate(sim: Simulation, progress: bool | None = None, *, lines: bool = False) -> str:
    """Run ``sim``'s remaining iterations; ``"complete"``, or ``"interrupted"`` on Ctrl-C.
    ``progress`` and ``lines`` as for ``Simulation.run`` (``lines``: progress lines in a
    log for a run that takes over 10 s).

    After an interruption the records hold every iteration recorded before it (a record
    is counted only once written whole), so the data saved is a valid table.
    """
    try:
        sim.run(progress=progress, lines=lines)
    except KeyboardInterrupt:
        return "interrupted"
    return "complete"


def save_run(
    sim: Simulation,
    folder: str | Path,
    *,
    status: str = "complete",
    fmt: str = "parquet",
    animation: bool = True,
    views: Views | None = None,
    progress: bool | None = None,
    overwrite: bool = False,
    command: Sequence[str] | None = None,
    overrides: Mapping[str, Any] | None = None,
    stream: StatesStream | None = None,
    claim: Claim | None = None,
) -> SavedRun:
    """Save ``sim``'s data, animation and ``run.json`` into ``folder``, all or nothing.

    Args:
        sim: the simulation (run to its end, or interrupted: see :func:`simulate`).
        folder: the run folder; see the module's docstring for an existing one.
        status: ``"complete"`` or ``"interrupted"`` (what :func:`simulate` returned).
        fmt: data format, ``"parquet"`` or ``"csv"``.
        animation: write the default views (``animation.gif``, ``replay.html``) when
            ``views`` is not given; not for an interrupted simulation.
        views: the views to write (see :class:`pyautonomousagent.render.views.Views`).
        progress: show the animation's progress bar (default: on a terminal).
        overwrite: replace an earlier run in ``folder``.
        command: the command line to record (default ``sys.argv``).
        overrides: the parameter overrides to record (default: those the scenario was
            given by ``Scenario.with_overrides`` since it was read).
        stream: the states written while the run went on (:func:`streaming` for ``folder``
            and ``fmt``): finished here instead of writing the table.
        claim: the caller's :func:`claim_run` on ``folder``; without it, ``folder`` is
            claimed here for the time of the saving (what it repaired: ``SavedRun.notes``).

    Raises:
        RunError: ``sim`` is no :class:`~pyautonomousagent.simulation.run.Simulation`, or
            it never ran (no iteration done), or ``status`` is not one of :data:`STATUSES`,
            or the folder cannot be used, or another run is writing it (all before anything
            is written).
        SaveError: writing failed; the temporary folder is removed, an earlier run is intact.
    """
    _check_saveable(sim, status)
    if views is None and animation and status == "complete":
        from pyautonomousagent.render.views import Views

        views = Views(progress=progress)
    keep = [stream.path.parent] if stream is not None else []
    with contextlib.ExitStack() as held:
        if claim is None or claim.folder != Path(folder):
            claim = held.enter_context(claim_run(folder, overwrite or status != "complete", keep))
        saved = SavedRun(claim.folder, status, notes=list(claim.notes))
        if status != "complete" and is_run_folder(saved.folder):
            stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")
            beside = saved.folder.with_name(f"{saved.folder.name}-{status}-{stamp}")
            saved.folder = held.enter_context(claim_run(beside)).folder
            saved.note = f"{folder} holds an earlier run, kept; this run was saved as {beside}"
        temp = keep[0] if keep else _temp_folder(saved.folder)
        _save_into(sim, saved, temp, views, fmt, stream, overwrite, command, overrides)
    return saved


def _save_into(
    sim: Simulation,
    saved: SavedRun,
    temp: Path,
    views: Views | None,
    fmt: str,
    stream: StatesStream | None,
    overwrite: bool,
    command: Sequence[str] | None,
    overrides: Mapping[str, Any] | None,
) -> None:
    """Write the run into ``temp`` and commit it to ``saved.folder`` (see :func:`save_run`)."""
    target = saved.folder
    try:
        start = time.perf_counter()
        with _held_interrupts() as caught:
            if stream is not None:
                saved.files.append(stream.finish())
                sim.timings["write_data_thread"] = stream.busy
            else:
                saved.files.append(write_table(sim.table(), temp / f"states.{fmt}", fmt))
            if sim.recorder.traced.size:
                traces = write_table(sim.trace_table(), temp / f"traces.{fmt}", fmt)
                saved.files.append(traces)
        sim.timings["write_data"] = time.perf_counter() - start
        if caught:
            saved.status, saved.note = "interrupted", "Ctrl-C while writing the data: no views"
        if views is not None and saved.status == "complete":
            _write_views(sim, temp, views, saved)
        with _held_interrupts():
            _write_json(temp / SUMMARY, summarise(sim, saved, temp, command, overrides))
            commit(temp, target, replace=overwrite)
    except OSError as error:
        shutil.rmtree(temp, ignore_errors=True)
        where = f"; the earlier run in {target} is intact" if is_run_folder(target) else ""
        raise SaveError(f"cannot save the run in {target}: {_reason(error)}{where}") from None
    except BaseException:
        shutil.rmtree(temp, ignore_errors=True)
        raise
    saved.files = [target / path.name for path in saved.files] + [target / SUMMARY]


def _check_saveable(sim: Any, status: Any) -> None:
    """RunError unless ``sim`` is a simulation that ran and ``status`` one of :data:`STATUSES`."""
    from pyautonomousagent.simulation.run import Simulation

    if not isinstance(sim, Simulation):
        raise RunError(
            "save_run saves a Simulation (sim = Simulation.create(load(NAME)); "
            f"simulate(sim)), got {type(sim).__name__} {shown(sim)}"
        )
    if status not in STATUSES:
        raise RunError(f"status must be one of {', '.join(STATUSES)}, got {shown(status)}")
    if sim.world.iteration == 0 and sim.scenario.iterations > 0 and status == "complete":
        raise RunError(
            "the simulation never ran (0 of its "
            f"{sim.scenario.iterations} iterations): run it first with simulate(sim) or "
            "sim.run(), then save it"
        )


def _temp_folder(target: Path) -> Path:
    """A new temporary folder beside ``target`` (``.NAME.tmp-*``), where a run is written."""
    try:
        return hidden_folder(target, "tmp")
    except OSError as error:
        raise SaveError(f"cannot write in {target.absolute().parent}: {_reason(error)}") from None


@contextlib.contextmanager
def streaming(
    sim: Simulation, folder: str | Path, fmt: str = "parquet"
) -> Iterator[StatesStream | None]:
    """Write ``sim``'s states to Parquet while it runs, for :func:`save_run` into ``folder``.

    Yields a :class:`~pyautonomousagent.streaming.StatesStream` writing ``states.parquet``
    in a temporary folder beside ``folder`` (the one :func:`save_run` then fills and puts in
    place), or None for CSV or where no folder can be made there (:func:`save_run` then
    writes the table at the end, and reports why it cannot). Whatever :func:`save_run` did
    not put in place is removed on leaving: a failed or abandoned run leaves nothing.

        with streaming(sim, out) as stream:
            status = simulate(sim)
            save_run(sim, out, status=status, stream=stream)
    """
    try:
        temp = _temp_folder(Path(folder)) if fmt == "parquet" else None
    except SaveError:
        temp = None
    if temp is None:
        yield None
        return
    from pyautonomousagent.streaming import StatesStream

    stream = StatesStream(sim.recorder, temp / "states.parquet")
    try:
        yield stream
    finally:
        stream.close()
        shutil.rmtree(temp, ignore_errors=True)  # gone already once put in place


def _write_views(sim: Simulation, temp: Path, views: Views, saved: SavedRun) -> None:
    """Write the views into ``temp``; on Ctrl-C or a drawing error, none and a marked run."""
    from pyautonomousagent.render.views import write_views

    before = set(temp.iterdir())
    try:
        write_views(sim.recorder, sim.scenario, sim.events, temp, views)
    except OSError:
        raise
    except (KeyboardInterrupt, Exception) as error:
        for path in set(temp.iterdir()) - before:  # partial views go; the data stays
            path.unlink(missing_ok=True)
        if isinstance(error, KeyboardInterrupt):
            saved.status, saved.note = "interrupted", "Ctrl-C during the animation: no views"
        else:
            message = error.args[0] if isinstance(error, KeyError) and error.args else error
            saved.status, saved.note = "failed", f"the views failed: {shown(str(message), 200)}"
        return
    sim.timings.update(views.timings)
    saved.files.extend(views.written)


def summarise(
    sim: Simulation,
    saved: SavedRun,
    folder: Path,
    command: Sequence[str] | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The contents of ``run.json`` for ``sim`` and the files ``saved`` lists in ``folder``."""
    summary: dict[str, Any] = {
        "status": saved.status,
        "iterations_done": last_recorded(sim),  # the data's: after Ctrl-C, its last record
        "iterations_run": int(sim.world.iteration),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "command": list(sys.argv if command is None else command),
        "overrides": dict(sim.scenario.overrides if overrides is None else overrides),
        "scenario": to_mapping(sim.scenario),
        "tree": tree_record(sim.scenario.tree),
        "seed": sim.seed,
        "engine": sim.engine.name,
        "record_every": sim.recorder.every,
        "records": sim.recorder.count,
        "versions": versions(),
        "timings_s": {k: round(v, 4) for k, v in sim.timings.items()},
        "events": sim.events,
        "trace": {
            "agents": [sim.swarm.names[i] for i in sim.recorder.traced],
            "nodes": node_list(sim.recorder.nodes),
        },
        "files": [file_record(folder / path.name) for path in saved.files],
    }
    device = getattr(sim.engine, "device", None)  # the GPU engine's device, driver, CuPy
    if callable(device):
        summary["device"] = device()
    if saved.note:
        summary["note"] = saved.note
    return summary


def last_recorded(sim: Simulation) -> int:
    """The iteration of the run's last record (0 if none): the iterations its data holds.
    A complete run always records its last iteration; a run stopped by Ctrl-C may have run
    up to ``record_every - 1`` iterations past it (``run.json``'s ``iterations_run``)."""
    recorder = sim.recorder
    return int(recorder.iterations[recorder.count - 1]) if recorder.count else 0


def tree_record(tree: str) -> dict[str, Any]:
    """The run's tree: a built-in name, or a tree file's path, SHA-256 and content."""
    if not is_tree_file(tree):
        return {"builtin": tree}
    path = Path(tree)
    try:
        content = path.read_bytes()
    except OSError as error:
        return {"file": str(path), "error": _reason(error)}
    return {
        "file": str(path),
        "sha256": hashlib.sha256(content).hexdigest(),
        "content": content.decode("utf-8", errors="replace"),
    }


def file_record(path: Path) -> dict[str, Any]:
    """A file's name, size (bytes) and SHA-256, as ``run.json`` lists it."""
    with path.open("rb") as file:
        digest = hashlib.file_digest(file, "sha256").hexdigest()
    return {"name": path.name, "bytes": path.stat().st_size, "sha256": digest}


def verify(folder: str | Path) -> dict[str, Any]:
    """``run.json`` of a run folder, after checking every file it lists against its hash.

    Raises:
        RunError: a file is missing or differs from what ``run.json`` recorded; where a
            killed ``pyaa run`` left the earlier run renamed aside, the message names it.
    """
    folder = Path(folder)
    try:
        summary = json.loads((folder / SUMMARY).read_text(encoding="utf-8"))
        for entry in summary["files"]:
            if file_record(folder / entry["name"]) != entry:
                raise RunError(f"{folder / entry['name']} differs from {SUMMARY}")
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise RunError(f"{folder} is not a complete run folder: {error}{_aside(folder)}") from None
    return dict(summary)


def _aside(folder: Path) -> str:
    """Where a killed run left the earlier run of ``folder``, as the end of a message."""
    for kind, path in hidden_folders(folder):
        if kind == "old" and is_run_folder(path / folder.name):
            return (
                f"; a run killed while replacing it left the earlier run in {path / folder.name}"
                f", which the next pyaa run into {folder} (runs.recover_run) puts back"
            )
    return ""


def add_files(folder: str | Path, paths: Sequence[Path]) -> None:
    """List files written into a finished run folder afterwards (``pyaa replay``) in its
    ``run.json``, with their sizes and hashes, so :func:`verify` still holds; ``run.json`` is
    replaced in one rename. Paths outside ``folder`` are left out."""
    folder = Path(folder)
    summary = json.loads((folder / SUMMARY).read_text(encoding="utf-8"))
    records = {entry["name"]: entry for entry in summary["files"]}
    for path in paths:
        if path.resolve().parent == folder.resolve():
            records[path.name] = file_record(path)
    summary["files"] = list(records.values())
    temp = folder / f".{SUMMARY}.{os.getpid()}.tmp"
    try:
        _write_json(temp, summary)
        os.replace(temp, folder / SUMMARY)
    finally:
        temp.unlink(missing_ok=True)


def run_files(folder: Path) -> set[str]:
    """The names of a run folder's own files: ``run.json`` and those it lists (none if
    ``folder`` holds no run)."""
    try:
        summary = json.loads((folder / SUMMARY).read_text(encoding="utf-8"))
        listed = {str(entry["name"]) for entry in summary["files"]}
    except (OSError, ValueError, KeyError, TypeError):
        return {SUMMARY} if is_run_folder(folder) else set()
    return listed | {SUMMARY}


def check_output(path: str | Path, run: Path | None = None, views: Sequence[str] = ()) -> Path:
    """``path`` made absolute (links resolved), if writing it harms no run folder.

    Refused: a folder, any run folder's own files (:func:`run_files`), except the
    ``views`` of the folder ``run`` (``pyaa replay`` rewrites them and lists them again),
    and a sweep folder's own files (its manifest, results and journal).

    Raises:
        RunError: ``path`` is one of those.
    """
    from pyautonomousagent.experiments.store import JOURNAL, MANIFEST, RESULTS

    resolved = Path(path).resolve()
    if resolved.is_dir():
        raise RunError(f"{path} is a folder; give a file name")
    here = resolved.parent
    ours = run is not None and here == run.resolve() and resolved.name in views
    if resolved.name in run_files(here) and not ours:
        raise RunError(
            f"{path} is a file of the run in {here}, which nothing but pyaa run writes; "
            "choose another file"
        )
    sweep = here.parent if here.name == JOURNAL else here
    if (sweep / MANIFEST).is_file() and (here != sweep or resolved.name in (MANIFEST, RESULTS)):
        raise RunError(
            f"{path} is a file of the sweep in {sweep}, which nothing but pyaa sweep writes; "
            "choose another file"
        )
    return resolved


@contextlib.contextmanager
def claim_existing(folder: str | Path) -> Iterator[Claim]:
    """Hold the run folder ``folder`` while files are added to it (``pyaa replay``); what a
    killed writer left is repaired first (``Claim.notes``).

    Raises:
        RunError: its parent folder does not exist, or another process is writing it.
    """
    path = Path(folder)
    if not path.absolute().parent.is_dir():
        raise RunError(f"{path}: no such folder; give a folder that pyaa run wrote")
    try:
        with claimed(path, complete=is_run_folder) as held:
            yield held
    except BusyError as error:
        raise RunError(f"{path} is being written by another run ({error.strerror})") from None


def versions(packages: Iterable[str] = VERSIONED) -> dict[str, str]:
    """Python's and the given installed packages' versions (those not installed left out)."""
    found = {"python": platform.python_version()}
    for name in packages:
        with contextlib.suppress(metadata.PackageNotFoundError):
            found[name] = metadata.version(name)
    return found


def _write_json(path: Path, data: Mapping[str, Any]) -> None:
    with path.open("w", encoding="utf-8") as file:
        file.write(json.dumps(data, indent=2, default=str) + "\n")
        file.flush()
        os.fsync(file.fileno())


@contextlib.contextmanager
def _held_interrupts() -> Iterator[list[int]]:
    """Hold Ctrl-C during a short write: the list yielded says whether one came.

    Only the main thread may set signal handlers; elsewhere nothing is held.
    """
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return
    previous = signal.signal(signal.SIGINT, lambda number, frame: caught.append(number))
    try:
        yield caught
    finally:
        signal.signal(signal.SIGINT, previous)


def _reason(error: OSError) -> str:
    return error.strerror or str(error) or type(error).__name__
