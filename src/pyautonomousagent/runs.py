"""Saving a run as a transaction: a run folder is complete, marked partial, or not there.

    sim = Simulation.create(load("gathering"))
    status = simulate(sim)                       # "complete", or "interrupted" on Ctrl-C
    saved = save_run(sim, "runs/gathering", status=status)

A run's files (``states.parquet`` or ``states.csv``, ``traces.*``, the views: ``animation.gif``,
``replay.html``, Groot2 logs; ``run.json``) are
written into a temporary folder beside the target (``.NAME.tmp-*``) and put in place whole
with a rename, so an earlier run is never deleted by a failure and never mixed with a new
one. ``run.json`` is written last and lists every file with its size and SHA-256, the
command line, the overrides, the tree file's content and hash, the package version, the
time and the status:

- ``complete``: every iteration was simulated and every file written;
- ``interrupted``: Ctrl-C stopped the simulation (the data holds the iterations done, a
  valid table) or the views (the data is complete, the views are left out);
- ``failed``: a view could not be drawn (the data is complete; ``note`` says why).

The convention for an existing folder: a folder holding a run (it has ``run.json``) is
replaced only when asked (``overwrite=True``, ``pyaa run --overwrite``); the earlier run is
then renamed aside, the new one renamed in, and the earlier one deleted. Any other folder
that is not empty is never written into. An interrupted run does not replace an earlier
run: it is saved beside it, as ``NAME-interrupted-YYYYMMDD-HHMMSS``.
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
import tempfile
import threading
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pyautonomousagent.bt.files import is_tree_file
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
    """

    folder: Path
    status: str
    files: list[Path] = field(default_factory=list)
    note: str = ""


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


def check_target(folder: str | Path, overwrite: bool = False) -> Path:
    """``folder`` if a run can be saved there; checked before a run starts.

    Raises:
        RunError: it is a file, it holds an earlier run and ``overwrite`` is false, it is
            a folder of other files, or its parent cannot be created or written.
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
        parent = path.absolute().parent
        parent.mkdir(parents=True, exist_ok=True)
        os.rmdir(tempfile.mkdtemp(prefix=f".{path.name}.probe-", dir=parent))  # writable?
    except OSError as error:
        raise RunError(f"cannot use output folder {path}: {_reason(error)}; {fix}") from None
    return path


def simulate(sim: Simulation, progress: bool | None = None) -> str:
    """Run ``sim``'s remaining iterations; ``"complete"``, or ``"interrupted"`` on Ctrl-C.

    After an interruption the records hold every iteration recorded before it (a record
    is counted only once written whole), so the data saved is a valid table.
    """
    try:
        sim.run(progress=progress)
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
        overrides: the parameter overrides to record.
        stream: the states written while the run went on (:func:`streaming` for ``folder``
            and ``fmt``): finished here instead of writing the table.

    Raises:
        RunError: ``sim`` is no :class:`~pyautonomousagent.simulation.run.Simulation`, or
            it never ran (no iteration done), or ``status`` is not one of :data:`STATUSES`,
            or the folder cannot be used (all before anything is written).
        SaveError: writing failed; the temporary folder is removed, an earlier run is intact.
    """
    _check_saveable(sim, status)
    target = check_target(folder, overwrite or status != "complete")
    if status != "complete" and is_run_folder(target):
        stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")
        target = check_target(target.with_name(f"{target.name}-{status}-{stamp}"))
    saved = SavedRun(target, status)
    if target != Path(folder):
        saved.note = f"{folder} holds an earlier run, kept; this run was saved as {target}"
    temp = stream.path.parent if stream is not None else _temp_folder(target)
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
        if views is None and animation:
            from pyautonomousagent.render.views import Views

            views = Views(progress=progress)
        if views is not None and saved.status == "complete":
            _write_views(sim, temp, views, saved)
        with _held_interrupts():
            _write_json(temp / SUMMARY, summarise(sim, saved, temp, command, overrides))
            _commit(temp, target)
    except OSError as error:
        shutil.rmtree(temp, ignore_errors=True)
        where = f"; the earlier run in {target} is intact" if is_run_folder(target) else ""
        raise SaveError(f"cannot save the run in {target}: {_reason(error)}{where}") from None
    except BaseException:
        shutil.rmtree(temp, ignore_errors=True)
        raise
    saved.files = [target / path.name for path in saved.files] + [target / SUMMARY]
    return saved


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
        return Path(tempfile.mkdtemp(prefix=f".{target.name}.tmp-", dir=target.absolute().parent))
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
    if fmt != "parquet":
        yield None
        return
    from pyautonomousagent.streaming import StatesStream

    try:
        temp = _temp_folder(Path(folder))
    except SaveError:
        yield None
        return
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
    except BaseException as error:
        for path in set(temp.iterdir()) - before:  # partial views go; the data stays
            path.unlink(missing_ok=True)
        if isinstance(error, KeyboardInterrupt):
            saved.status, saved.note = "interrupted", "Ctrl-C during the animation: no views"
        elif isinstance(error, Exception):
            message = error.args[0] if isinstance(error, KeyError) and error.args else error
            saved.status, saved.note = "failed", f"the views failed: {shown(str(message), 200)}"
        else:
            raise
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
        "iterations_done": int(sim.world.iteration),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "command": list(sys.argv if command is None else command),
        "overrides": dict(overrides or {}),
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
    digest = hashlib.sha256()
    with path.open("rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return {"name": path.name, "bytes": path.stat().st_size, "sha256": digest.hexdigest()}


def verify(folder: str | Path) -> dict[str, Any]:
    """``run.json`` of a run folder, after checking every file it lists against its hash.

    Raises:
        RunError: a file is missing or differs from what ``run.json`` recorded.
    """
    folder = Path(folder)
    try:
        summary = json.loads((folder / SUMMARY).read_text(encoding="utf-8"))
        for entry in summary["files"]:
            if file_record(folder / entry["name"]) != entry:
                raise RunError(f"{folder / entry['name']} differs from {SUMMARY}")
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise RunError(f"{folder} is not a complete run folder: {error}") from None
    return dict(summary)


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
    temp = folder / f".{SUMMARY}.tmp"
    _write_json(temp, summary)
    os.replace(temp, folder / SUMMARY)


def versions(
    packages: Iterable[str] = (
        "pyautonomousagent",
        "numpy",
        "py_trees",
        "pyarrow",
        "matplotlib",
        "pillow",
    ),
) -> dict[str, str]:
    """Python's and the given installed packages' versions (those not installed left out)."""
    found = {"python": platform.python_version()}
    for name in packages:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return found


def _write_json(path: Path, data: Mapping[str, Any]) -> None:
    with path.open("w", encoding="utf-8") as file:
        file.write(json.dumps(data, indent=2, default=str) + "\n")
        file.flush()
        os.fsync(file.fileno())


def _commit(temp: Path, target: Path) -> None:
    """Put the finished folder ``temp`` in place of ``target`` (renames only)."""
    if target.is_dir():
        if any(target.iterdir()):
            old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=temp.parent))
            os.replace(target, old / target.name)
            os.replace(temp, target)
            shutil.rmtree(old, ignore_errors=True)
            return
        target.rmdir()
    os.replace(temp, target)


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
