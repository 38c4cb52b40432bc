"""Where the runs of a sweep execute: this process, a local process pool, or Dask.

Every backend takes a function and a list of tasks and yields ``(task, outcome)`` as runs
finish, ``outcome`` being the function's result or the exception that stopped the worker.
The function is the same everywhere (:func:`pyautonomousagent.experiments.runner.execute`),
so the same seed gives the same numbers on every backend.

- :class:`SerialBackend`: one run after another in this process (debugging, notebooks).
- :class:`PoolBackend` (the default): a pool of ``workers`` processes started with "spawn".
  A worker that dies (killed, out of memory) breaks the pool; the pool is started again and
  the runs it held are given again, up to :data:`ATTEMPTS` times each.
- :class:`DaskBackend`: a Dask distributed cluster (``dask[distributed]``, imported only
  here), given by its scheduler address, or a local cluster started for the sweep. Each run
  is submitted under its own key (never ``pure=True``'s hash, which would merge identical
  calls), so two runs are never merged; Dask computes again the runs of a worker that dies.

At most ``window`` runs are submitted at a time, so a sweep of a million runs does not hold a
million futures.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import uuid
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol, TypeVar

T = TypeVar("T")


class BackendError(RuntimeError):
    """A backend that cannot be used (missing package, unreachable scheduler); one line."""


#: How often a run is given again after the worker holding it died.
ATTEMPTS = 3


class Backend(Protocol):
    """What a sweep needs of a backend."""

    name: str

    def workers(self) -> int:
        """How many runs execute at once."""

    def memory_per_worker(self) -> int | None:
        """Bytes a worker may use, or None if unknown."""

    def map_unordered(self, fn: Callable[[T], Any], tasks: Sequence[T]) -> Iterator[tuple[T, Any]]:
        """``(task, fn(task) or the exception)`` for every task, as they finish."""

    def close(self) -> None:
        """Stop what was started for the sweep (promptly, also mid-sweep)."""


def physical_memory() -> int | None:
    """This machine's memory in bytes (None where unknown)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


class SerialBackend:
    """Every run in this process, one after another."""

    name = "serial"

    def workers(self) -> int:
        return 1

    def memory_per_worker(self) -> int | None:
        return physical_memory()

    def map_unordered(self, fn: Callable[[T], Any], tasks: Sequence[T]) -> Iterator[tuple[T, Any]]:
        for task in tasks:
            yield task, fn(task)

    def close(self) -> None:
        pass


def _ignore_interrupts() -> None:
    """Pool workers leave Ctrl-C to the sweep, which stops them."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class PoolBackend:
    """A local pool of worker processes (``workers``: default all cores)."""

    name = "pool"

    def __init__(self, workers: int | None = None, window: int | None = None) -> None:
        if workers is not None and workers < 1:
            raise ValueError(f"workers must be a whole number >= 1, got {workers}")
        self._workers = workers or os.cpu_count() or 1
        self.window = window or 4 * self._workers
        self._pool: ProcessPoolExecutor | None = None

    def workers(self) -> int:
        return self._workers

    def memory_per_worker(self) -> int | None:
        total = physical_memory()
        return None if total is None else total // self._workers

    def _start(self) -> ProcessPoolExecutor:
        self._pool = ProcessPoolExecutor(
            self._workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_ignore_interrupts,
        )
        return self._pool

    def map_unordered(self, fn: Callable[[T], Any], tasks: Sequence[T]) -> Iterator[tuple[T, Any]]:
        pending: deque[tuple[T, int]] = deque((task, 0) for task in tasks)
        running: dict[Future[Any], tuple[T, int]] = {}
        pool = self._pool or self._start()
        while pending or running:
            while pending and len(running) < self.window:
                task, tries = pending.popleft()
                running[pool.submit(fn, task)] = (task, tries)
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            broken = False
            for future in done:
                task, tries = running.pop(future)
                error = future.exception()
                if isinstance(error, BrokenProcessPool):
                    broken = True
                    if tries + 1 < ATTEMPTS:
                        pending.appendleft((task, tries + 1))
                    else:
                        yield task, RuntimeError(f"a worker died {ATTEMPTS} times running it")
                else:
                    yield task, future.result() if error is None else error
            if broken:  # every future of a broken pool fails: give them all again
                for future, (task, tries) in running.items():
                    future.cancel()
                    pending.appendleft((task, tries))
                running.clear()
                self.close()
                pool = self._start()

    def close(self) -> None:
        pool, self._pool = self._pool, None
        if pool is None:
            return
        processes = list(getattr(pool, "_processes", {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:  # runs in flight are abandoned, not waited for
            process.terminate()
        for process in processes:
            process.join(timeout=5)


class DaskBackend:
    """A Dask distributed cluster.

    Args:
        address: the scheduler's address (``tcp://host:8786``), or None to start a local
            cluster of ``workers`` single-threaded worker processes for the sweep.
        workers: workers of the local cluster (default all cores).
        window: runs submitted at a time (default 4 per worker).
        timeout: seconds to wait for the scheduler.

    Raises:
        BackendError: Dask is not installed, or no scheduler answers at ``address``.
    """

    name = "dask"

    def __init__(
        self,
        address: str | None = None,
        workers: int | None = None,
        window: int | None = None,
        timeout: float = 20.0,
    ) -> None:
        try:
            from distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover - depends on the installation
            raise BackendError(
                "the Dask backend needs dask[distributed]: pip install 'pyautonomousagent[dask]'"
            ) from None
        self.address = address
        self._cluster = None
        if address is None:
            self._cluster = LocalCluster(
                n_workers=workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            )
            self.client = Client(self._cluster)
        else:
            try:
                self.client = Client(address, timeout=f"{timeout}s")
            except (OSError, ValueError, TypeError) as error:
                raise BackendError(
                    f"cannot reach a Dask scheduler at {address!r} within {timeout:g} s "
                    f"({type(error).__name__}); start one (dask scheduler) or check the address"
                ) from None
        self._window = window
        self._prefix = f"pyaa-run-{uuid.uuid4().hex[:8]}"

    def _worker_info(self) -> dict[str, Any]:
        info: dict[str, Any] = self.client.scheduler_info().get("workers", {})
        return info

    def workers(self) -> int:
        return max(sum(int(w.get("nthreads", 1)) for w in self._worker_info().values()), 1)

    def memory_per_worker(self) -> int | None:
        """The smallest memory limit of a worker thread (a worker's limit over its threads)."""
        limits = [
            int(w["memory_limit"]) // max(int(w.get("nthreads", 1)), 1)
            for w in self._worker_info().values()
            if w.get("memory_limit")
        ]
        return min(limits) if limits else None

    def map_unordered(self, fn: Callable[[T], Any], tasks: Sequence[T]) -> Iterator[tuple[T, Any]]:
        from distributed import as_completed

        window = self._window or 4 * self.workers()
        queue = deque(enumerate(tasks))
        owner: dict[str, T] = {}

        def submit() -> Any:
            index, task = queue.popleft()
            key = f"{self._prefix}-{index}"
            owner[key] = task
            return self.client.submit(fn, task, key=key, pure=False)

        running = as_completed([submit() for _ in range(min(window, len(queue)))])
        for future in running:
            task = owner.pop(future.key)
            try:
                outcome = future.result()
            except Exception as error:  # KilledWorker, cancelled, lost: the run failed
                outcome = error
            yield task, outcome
            future.release()
            if queue:
                running.add(submit())

    def close(self) -> None:
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_backend(
    kind: str = "pool", workers: int | None = None, address: str | None = None
) -> Backend:
    """A backend by name: "serial", "pool" (local processes) or "dask" (``address`` of a
    scheduler, or None for a local Dask cluster)."""
    if kind == "serial":
        return SerialBackend()
    if kind == "pool":
        return PoolBackend(workers)
    if kind == "dask":
        return DaskBackend(address, workers)
    raise ValueError(f"unknown backend {kind!r}; choose from serial, pool, dask")
