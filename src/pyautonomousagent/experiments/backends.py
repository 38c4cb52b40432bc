"""Where the runs of a sweep execute: this process (:class:`SerialBackend`), a local pool of
"spawn" processes (:class:`PoolBackend`, the default) or a Dask cluster (:class:`DaskBackend`,
``dask[distributed]`` imported only there); see docs/experiments.md, "Backends".

Every backend yields ``(task, outcome)`` as runs finish, ``outcome`` being the function's
result or the exception that stopped the worker. The function is the same everywhere
(:func:`~pyautonomousagent.experiments.runner.execute`), so a seed gives the same numbers on
every backend. At most 4 runs per worker are in flight, so a sweep of a million runs does not
hold a million futures. A pool that breaks (a worker killed, out of memory) is started again
and its runs given again, up to :data:`ATTEMPTS` times each; a Dask run is submitted under
its own key (never ``pure=True``'s hash, which would merge identical runs); the pool and Dask
backends count their lost workers (:class:`Watched`).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import time
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


def quiet(line: str) -> None:
    """The default ``report``: say nothing."""


class Watched:
    """A backend that says what happened to its workers (the pool and Dask backends).

    Attributes:
        seen: every worker that ran for the sweep (a process id or a Dask address), in the
            order first seen.
        lost: the workers that died or left mid-sweep, in that order.
        retried: how many times a run was given again after its worker was lost.
        report: called with one line when a worker is lost and its runs are given again.
    """

    def __init__(self) -> None:
        self.seen: list[str] = []
        self.lost: list[str] = []
        self.retried = 0
        self.report: Callable[[str], None] = quiet

    def see(self, workers: Sequence[str]) -> None:
        """Add the workers not seen before."""
        self.seen += [w for w in workers if w not in self.seen]

    def lose(self, worker: str) -> bool:
        """Mark ``worker`` lost; whether it was not lost before."""
        if worker in self.lost:
            return False
        self.see([worker])
        self.lost.append(worker)
        return True

    def stats(self) -> dict[str, Any]:
        """``{"workers_seen", "workers_lost", "runs_retried", "seen", "lost"}``: the workers
        by process id (pool) or address (Dask)."""
        return {
            "workers_seen": len(self.seen),
            "workers_lost": len(self.lost),
            "runs_retried": self.retried,
            "seen": list(self.seen),
            "lost": list(self.lost),
        }


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


class PoolBackend(Watched):
    """A local pool of worker processes (``workers``: default all cores)."""

    name = "pool"

    def __init__(self, workers: int | None = None) -> None:
        super().__init__()
        if workers is not None and workers < 1:
            raise ValueError(f"workers must be a whole number >= 1, got {workers}")
        self._workers = workers or os.cpu_count() or 1
        self._pool: ProcessPoolExecutor | None = None
        self._known: dict[str, Any] = {}  # process id -> process of the pool

    def workers(self) -> int:
        return self._workers

    def _look(self) -> None:
        """Note the pool's processes (they start as runs are submitted)."""
        processes = getattr(self._pool, "_processes", None) or {}
        self._known.update({f"process {pid}": p for pid, p in list(processes.items())})
        self.see(list(self._known))

    def _lost(self, again: int) -> None:
        """The pool broke: name the processes that died (not those the pool then stopped).
        The pool's own thread reaps its processes meanwhile, so an exit code may show a
        moment late: wait for them (at most 2 s; the pool stops every process it had)."""
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline and any(p.exitcode is None for p in self._known.values()):
            time.sleep(0.01)
        dead = [n for n, p in self._known.items() if p.exitcode not in (None, -signal.SIGTERM)]
        for name in dead or ["a process"]:
            if self.lose(name):
                code = self._known[name].exitcode if name in self._known else "?"
                self.report(
                    f"pool worker {name} died (exit code {code}); {again} run(s) given again"
                )
        self.retried += again
        self._known.clear()

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
            while pending and len(running) < 4 * self._workers:
                task, tries = pending.popleft()
                running[pool.submit(fn, task)] = (task, tries)
            self._look()  # before a worker can die: a broken pool forgets its processes
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            broken = False
            again = 0
            for future in done:
                task, tries = running.pop(future)
                error = future.exception()
                if isinstance(error, BrokenProcessPool):
                    broken = True
                    if tries + 1 < ATTEMPTS:
                        pending.appendleft((task, tries + 1))
                        again += 1
                    else:
                        yield task, RuntimeError(f"a worker died {ATTEMPTS} times running it")
                else:
                    yield task, future.result() if error is None else error
            if broken:  # every future of a broken pool fails: give them all again
                for future, (task, tries) in running.items():
                    future.cancel()
                    pending.appendleft((task, tries))
                self._lost(again + len(running))
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


class StartLog:
    """The start events of a sweep's runs on Dask, read once each: which worker started each
    run last, and the runs started again on another worker.

    The scheduler stamps each event with its own clock; the events pushed to the client and
    its log carry the same stamps, so an event is new when it is later than the last one
    read, or at that time and not read yet.
    """

    def __init__(self) -> None:
        self.starts: dict[str, str] = {}  # run key -> the worker that last started it
        self.until = 0.0
        self.at_until: set[tuple[str, str]] = set()

    def read(self, events: Sequence[Any]) -> list[tuple[str, str, str]]:
        """``(key, worker, previous worker)`` of each run in ``events`` (``(time, {"key",
        "worker"})``, any order, read before or not) started again on another worker."""
        again = []
        for when, message in sorted(events, key=lambda event: event[0]):
            ident = (str(message.get("key")), str(message.get("worker")))
            if when < self.until or (when == self.until and ident in self.at_until):
                continue
            if when > self.until:
                self.until, self.at_until = when, set()
            self.at_until.add(ident)
            key, worker = ident
            before = self.starts.get(key)
            self.starts[key] = worker
            if before is not None and before != worker:
                again.append((key, worker, before))
        return again


class DaskBackend(Watched):
    """A Dask distributed cluster.

    Args:
        address: the scheduler's address (``tcp://host:8786``), or None to start a local
            cluster of ``workers`` single-threaded worker processes for the sweep.
        workers: workers of the local cluster (default all cores).
        timeout: seconds to wait for the scheduler.

    Raises:
        BackendError: Dask is not installed, or no scheduler answers at ``address``.
    """

    name = "dask"

    def __init__(
        self,
        address: str | None = None,
        workers: int | None = None,
        timeout: float = 20.0,
    ) -> None:
        super().__init__()
        try:
            from distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover - depends on the installation
            raise BackendError(
                "the Dask backend needs dask[distributed]: pip install 'pyautonomousagent[dask]'"
            ) from None
        self._cluster = None
        if address is None:
            self._cluster = LocalCluster(
                n_workers=workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,  # no dashboard; its HTTP server on a free port, not
                scheduler_kwargs={"dashboard_address": ":0"},  # 8787 (a warning if it is taken)
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
        self._prefix = f"pyaa-run-{uuid.uuid4().hex[:8]}"
        self._log = StartLog()
        self._inbox: list[Any] = []  # start events pushed by the scheduler (topic below)
        self._topic = f"{self._prefix}-starts"
        self._last_look = 0.0
        self.client.subscribe_topic(self._topic, self._inbox.append)
        self.see(list(self._worker_info()))

    def stats(self) -> dict[str, Any]:
        """:meth:`Watched.stats`, read from the start of every run, which each run logs to
        the scheduler."""
        self._look(force=True)
        return super().stats()

    def _look(self, force: bool = False) -> None:
        """Count the runs started again and the workers gone (at most once a second, unless
        ``force``: then from the scheduler's whole log of this sweep's starts)."""
        now = time.monotonic()
        if not force and now - self._last_look < 1.0:
            return
        self._last_look = now
        with contextlib.suppress(Exception):  # a closed client: keep what was counted
            present = list(self._worker_info())
            events = self.client.get_events(self._topic) if force else self._inbox[:]
            del self._inbox[: len(self._inbox)]
            self.see(present)
            self.see([str(message.get("worker")) for _, message in events])
            for key, worker, before in self._log.read(events):
                self._restarted(key, worker, before, present)
            for worker in self.seen:
                if worker not in present and self.lose(worker):
                    self.report(f"dask worker {worker} lost")

    def _restarted(self, key: str, worker: str, before: str, present: Sequence[str]) -> None:
        """Run ``key`` started again on ``worker`` after starting on ``before``."""
        self.retried += 1
        if before in present:  # not lost (e.g. its result went missing): started again
            self.report(f"run {key} started again on {worker} (it started on {before})")
            return
        if self.lose(before):
            self.report(f"dask worker {before} lost")
        self.report(f"run {key} given again on {worker} (its worker {before} was lost)")

    def _worker_info(self) -> dict[str, Any]:
        return dict(self.client.scheduler_info().get("workers", {}))

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

        queue = deque(enumerate(tasks))
        owner: dict[str, T] = {}

        def submit() -> Any:
            index, task = queue.popleft()
            key = f"{self._prefix}-{index}"
            owner[key] = task
            return self.client.submit(_logged, fn, task, key, self._topic, key=key, pure=False)

        running = as_completed([submit() for _ in range(min(4 * self.workers(), len(queue)))])
        for future in running:
            task = owner.pop(future.key)
            try:
                outcome = future.result()
            except Exception as error:  # KilledWorker, cancelled, lost: the run failed
                outcome = error
            self._look()
            yield task, outcome
            future.release()
            if queue:
                running.add(submit())

    def close(self) -> None:
        self._look(force=True)
        with contextlib.suppress(Exception):
            self.client.unsubscribe_topic(self._topic)
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def _logged(fn: Callable[[T], Any], task: T, key: str, topic: str) -> Any:
    """``fn(task)`` on a Dask worker, after logging the start (key, worker) to ``topic``."""
    from distributed import get_worker

    with contextlib.suppress(ValueError):  # not on a worker: nothing to log
        worker = get_worker()
        worker.log_event(topic, {"key": key, "worker": worker.address})
    return fn(task)


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
