"""Folders written as a whole: an exclusive claim, a commit by renames, and recovery.

A folder ``PARENT/NAME`` is written by one process at a time: :func:`claimed` holds an
exclusive lock on ``PARENT/.NAME.lock`` (the kernel releases it when the process ends, even
on ``kill -9``), so a second writer is refused at once. The new contents are written in a
hidden folder beside it (:func:`hidden_folder`, ``.NAME.tmp-*``) and put in place by
:func:`commit`:

1. ``.NAME.tmp-X`` is renamed to ``NAME`` when ``NAME`` is absent or empty; or else
2. ``NAME`` is renamed aside into ``.NAME.old-Y/NAME``, ``.NAME.tmp-X`` renamed to ``NAME``
   (on failure the earlier folder is renamed back), and ``.NAME.old-Y`` deleted.

A process killed at any point leaves either the earlier folder or the new one at ``NAME``,
or (between the two renames of step 2) the earlier one in ``.NAME.old-Y``. The next claim
on ``NAME`` runs :func:`recover`: it puts such an earlier folder back, and deletes the
temporary folders that killed writers left, saying what it did.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: The kinds of hidden folders beside a target: a new folder being written, an earlier
#: folder renamed aside during a commit, a probe of the parent's permissions.
KINDS = ("tmp", "old", "probe")


class BusyError(OSError):
    """Another process holds the claim on a folder."""


@dataclass
class Claim:
    """An exclusive claim on a folder (see :func:`claimed`).

    Attributes:
        folder: the claimed folder (it may not exist yet).
        notes: what :func:`recover` did when the claim was taken, one line each.
    """

    folder: Path
    notes: list[str] = field(default_factory=list)


def lock_path(folder: Path) -> Path:
    """The lock file of ``folder``: ``.NAME.lock`` beside it."""
    return folder.absolute().parent / f".{folder.name}.lock"


def hidden_folder(target: Path, kind: str) -> Path:
    """A new, empty hidden folder beside ``target``: ``.NAME.KIND-XXXXXXXXXXXX``."""
    parent = target.absolute().parent
    while True:
        path = parent / f".{target.name}.{kind}-{secrets.token_hex(6)}"
        with contextlib.suppress(FileExistsError):  # taken: draw another name
            path.mkdir()
            return path


def hidden_folders(target: Path) -> list[tuple[str, Path]]:
    """The hidden folders beside ``target`` (:data:`KINDS`), as (kind, path), by name."""
    pattern = re.compile(rf"\.{re.escape(target.name)}\.({'|'.join(KINDS)})-[0-9a-f]{{12}}")
    parent = target.absolute().parent
    found = []
    with contextlib.suppress(OSError):
        for path in sorted(parent.iterdir()):
            match = pattern.fullmatch(path.name)
            if match and path.is_dir() and not path.is_symlink():
                found.append((match.group(1), path))
    return found


@contextlib.contextmanager
def claimed(
    folder: str | Path, keep: Sequence[Path] = (), complete: Callable[[Path], bool] = bool
) -> Iterator[Claim]:
    """Hold ``folder`` for this process: lock it, then :func:`recover` it.

    Args:
        folder: the folder to write; its parent is created.
        keep: hidden folders of this process that recovery must not delete.
        complete: whether a folder is a whole one (for :func:`recover`).

    Raises:
        BusyError: another process holds the claim (its process id in the message).
        OSError: the parent cannot be created or the lock file written.
    """
    path = Path(folder)
    path.absolute().parent.mkdir(parents=True, exist_ok=True)
    fd = _lock(lock_path(path))
    try:
        yield Claim(path, recover(path, complete, keep))
    finally:
        with contextlib.suppress(OSError):
            if sys.platform != "win32":  # unlinked while held: see _lock
                lock_path(path).unlink()
        os.close(fd)
        if sys.platform == "win32":
            with contextlib.suppress(OSError):
                lock_path(path).unlink()


def _lock(path: Path) -> int:
    """Open and lock ``path`` exclusively, without waiting; the open descriptor.

    The holder unlinks the file before it lets go, so a lock taken on a file that is no
    longer at ``path`` is worthless: it is dropped and taken again on the new file.
    """
    for _ in range(100):
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            if not _try_lock(fd):
                raise BusyError(errno.EBUSY, f"held by process {_holder(path)}", str(path))
            if sys.platform == "win32" or os.path.samestat(os.fstat(fd), os.stat(path)):
                with contextlib.suppress(OSError):  # only shown to a refused writer
                    os.ftruncate(fd, 0)
                    os.write(fd, f"{os.getpid()}\n".encode())
                return fd
        except FileNotFoundError:
            pass  # unlinked between the open and the stat: take the new one
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)
    raise BusyError(errno.EBUSY, "its lock file keeps changing", str(path))


def _try_lock(fd: int) -> bool:
    """Lock ``fd`` exclusively; False if another process holds it."""
    if sys.platform == "win32":
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    import fcntl

    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


def _holder(path: Path) -> str:
    """The process id written in a lock file, or ``"?"``."""
    with contextlib.suppress(OSError, UnicodeDecodeError):
        return path.read_text(encoding="utf-8").strip() or "?"
    return "?"


def recover(
    target: Path, complete: Callable[[Path], bool] = bool, keep: Sequence[Path] = ()
) -> list[str]:
    """Tidy what killed writers left beside ``target``; one line per thing done.

    An earlier folder renamed aside (``.NAME.old-*``) is put back when ``target`` is absent
    or empty and it is ``complete``; deleted when ``target`` is ``complete`` (the commit had
    finished); left, and named, otherwise. Temporary folders (``.NAME.tmp-*``,
    ``.NAME.probe-*``) other than ``keep`` are deleted. Call it while holding the claim.
    """
    notes = []
    kept = {path.absolute() for path in keep}
    for kind, path in hidden_folders(target):
        if path.absolute() in kept:
            continue
        if kind == "old":
            notes.append(_recover_earlier(target, path, complete))
        else:
            shutil.rmtree(path, ignore_errors=True)
            notes.append(f"removed {path}, left unfinished by a writer that was stopped")
    return notes


def _recover_earlier(target: Path, aside: Path, complete: Callable[[Path], bool]) -> str:
    """Put back, delete or name the earlier folder in ``aside`` (see :func:`recover`)."""
    earlier = aside / target.name
    if not earlier.exists():
        shutil.rmtree(aside, ignore_errors=True)
        return f"removed {aside}, an empty folder left by a writer that was stopped"
    if complete(target):
        shutil.rmtree(aside, ignore_errors=True)
        return f"removed {aside}: the earlier folder that {target} replaced"
    if complete(earlier) and _absent_or_empty(target):
        if target.is_dir():
            target.rmdir()
        os.rename(earlier, target)
        shutil.rmtree(aside, ignore_errors=True)
        return (
            f"restored the earlier folder in {target} from {aside}, where a writer stopped "
            "while replacing it had left it"
        )
    return f"{aside} holds an earlier {target.name}, left by a writer that was stopped; check it"


def _absent_or_empty(path: Path) -> bool:
    return not path.exists() or (path.is_dir() and not any(path.iterdir()))


def commit(temp: Path, target: Path, replace: bool = False) -> None:
    """Put the finished folder ``temp`` in place of ``target`` by renames (module docstring).

    Raises:
        FileExistsError: ``target`` holds files and ``replace`` is false.
        OSError: a rename failed; ``target`` is as it was.
    """
    if _absent_or_empty(target):
        if sys.platform == "win32" and target.is_dir():
            target.rmdir()
        os.replace(temp, target)  # fails if a file came into target meanwhile
        sync_folder(target.absolute().parent)
        return
    if not replace:
        raise FileExistsError(errno.EEXIST, "it holds files", str(target))
    aside = hidden_folder(target, "old")
    try:
        os.rename(target, aside / target.name)
    except OSError:
        aside.rmdir()
        raise
    try:
        os.rename(temp, target)
    except OSError:
        os.rename(aside / target.name, target)
        aside.rmdir()
        raise
    sync_folder(target.absolute().parent)
    shutil.rmtree(aside, ignore_errors=True)


def sync_folder(folder: Path) -> None:
    """Flush ``folder``'s entries (renames into it) to disk, where the system allows it."""
    if sys.platform == "win32":
        return
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
