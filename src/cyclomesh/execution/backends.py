"""The one execution layer of every kind of study: chunks of items, here or on a cluster.

A study hands over a picklable *chunk function* ``task(start, stop) -> {name: array}``
that computes items ``start .. stop − 1`` (rings of a tolerance study, points of a
design map, torques of a stiffness curve, ...; the leading axis of every array is the
item). :func:`run_chunks` splits the items into chunks, runs them serially, on local
processes (:class:`ProcessBackend`) or on a Dask ``distributed`` cluster
(:class:`DaskBackend`), keeps a bounded number of chunks in flight (about two per
worker), writes each finished chunk into preallocated per-item arrays and forgets it,
so memory does not grow with the number of chunks. When item k's result depends only
on k (as a tolerance ring's does, see :mod:`cyclomesh.tolerance.sampling`), results are
bit-for-bit identical for every chunking and every backend.

Every item is stored exactly once: the engine counts the chunks that cover each item
and refuses to return if one is missing or was stored twice. On a Dask cluster a chunk
whose worker dies is recomputed elsewhere by the scheduler; its future completes once,
so it is stored once. On local processes a dead worker breaks the process pool: the
pool is rebuilt and the chunks that never came back run again.

``distributed`` is imported only when a scheduler address is given. Nothing here
prints: progress goes to the ``progress`` callback (the CLI draws the bar).
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import re
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from cyclomesh.exceptions import CyclomeshError
from cyclomesh.execution.runtime import start_worker, tune_allocator, usable_cpus

__all__ = [
    "ExecutionError",
    "ClusterError",
    "ChunkFunction",
    "Backend",
    "SerialBackend",
    "ProcessBackend",
    "DaskBackend",
    "make_backend",
    "default_chunk_size",
    "chunk_bounds",
    "run_chunks",
]

ChunkResult = Mapping[str, NDArray[Any]]
ChunkFunction = Callable[[int, int], ChunkResult]
Chunk = tuple[int, int]


class ExecutionError(CyclomeshError):
    """The chunks could not be run (a worker process died, the cluster is unusable)."""


class ClusterError(ExecutionError):
    """The Dask cluster cannot be used (``distributed`` missing, scheduler unreachable)."""


def chunk_bounds(items: int, chunk_size: int, first: int = 0) -> list[Chunk]:
    """Split items ``first .. first + items − 1`` into (start, stop) chunks of chunk_size."""
    if chunk_size < 1:
        raise ValueError("chunk_size must be at least 1")
    stop = first + items
    return [(s, min(s + chunk_size, stop)) for s in range(first, stop, chunk_size)]


class Backend(Protocol):
    """Runs chunks and yields ((start, stop), result) as they finish, any order."""

    workers: int

    def start(self) -> None:
        """Start the workers now (before a progress display starts its thread)."""
        ...

    def run(self, task: ChunkFunction, chunks: Iterable[Chunk]) -> Iterator[tuple[Chunk, Any]]:
        """Run ``task`` on every chunk."""
        ...

    def close(self) -> None:
        """Release the workers or the connection."""
        ...


@dataclass
class SerialBackend:
    """Runs the chunks one after the other in this process (for tests and debugging)."""

    workers: int = 1

    def start(self) -> None:
        pass

    def run(self, task: ChunkFunction, chunks: Iterable[Chunk]) -> Iterator[tuple[Chunk, Any]]:
        for chunk in chunks:
            yield chunk, task(*chunk)

    def close(self) -> None:
        pass


class ProcessBackend:
    """Runs chunks on local cores with a ``ProcessPoolExecutor``.

    The worker processes are forked when this process has no other thread (they start
    in milliseconds and inherit the imported modules), else spawned (a fork of a
    process that runs, say, a progress-bar thread could inherit a held lock): call
    :meth:`start` before starting such threads.

    Parameters
    ----------
    workers : int, optional
        Number of processes (default: the CPUs this process may use).
    in_flight_per_worker : int
        Chunks submitted ahead per worker; bounds the memory held by results.
    """

    def __init__(
        self, workers: int | None = None, in_flight_per_worker: int = 2, max_restarts: int = 3
    ) -> None:
        self.workers = workers or usable_cpus()
        self.in_flight = max(1, in_flight_per_worker * self.workers)
        self.max_restarts = max_restarts
        self.restarts = 0
        self._pool: ProcessPoolExecutor | None = None

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            method = (
                "fork"
                if threading.active_count() == 1
                and "fork" in multiprocessing.get_all_start_methods()
                else "spawn"
            )
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=multiprocessing.get_context(method),
                initializer=start_worker,
                initargs=(os.getpid(),),
            )
        return self._pool

    def start(self) -> None:
        """Start the worker processes now (forked if no other thread runs yet)."""
        self._executor().submit(_nothing).result()

    def worker_pids(self) -> list[int]:
        """Process ids of the live pool's workers (empty before the first chunk)."""
        processes = getattr(self._pool, "_processes", None) or {}
        return sorted(processes)

    def run(self, task: ChunkFunction, chunks: Iterable[Chunk]) -> Iterator[tuple[Chunk, Any]]:
        """Run the chunks; if a worker process dies, the pool is rebuilt and every chunk
        that had not come back is run again (up to ``max_restarts`` times), so no ring is
        lost, and none is stored twice since only chunks that never returned are rerun."""
        pending: dict[Future[Any], Chunk] = {}
        rerun: list[Chunk] = []
        todo = iter(chunks)
        try:
            while True:
                while len(pending) < self.in_flight:
                    chunk = rerun.pop() if rerun else next(todo, None)
                    if chunk is None:
                        break
                    pending[self._executor().submit(task, *chunk)] = chunk
                if not pending:
                    return
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                lost = []
                for future in done:
                    chunk = pending.pop(future)
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        lost.append(chunk)
                        continue
                    yield chunk, result
                if lost:
                    # the whole pool is gone: every chunk still out must run again
                    rerun.extend(lost + list(pending.values()))
                    pending.clear()
                    self._discard_pool()
                    self.restarts += 1
                    if self.restarts > self.max_restarts:
                        raise ExecutionError(
                            f"local worker processes died {self.restarts} times (out of "
                            "memory?); try fewer --workers or smaller chunks"
                        )
        finally:
            for future in pending:
                future.cancel()

    def _discard_pool(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def terminate(self) -> None:
        """Stop the workers at once, without waiting for their chunks (after Ctrl-C or
        a failure: nothing they compute would be used)."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        for process in list((getattr(pool, "_processes", None) or {}).values()):
            with contextlib.suppress(OSError, ValueError):
                process.kill()
        pool.shutdown(wait=False, cancel_futures=True)


_ADDRESS = re.compile(r"inproc://\S+|(?:(?:tcp|tls|ucx|ws|wss)://)?[\w.\-\[\]:]+:\d{1,5}")
"""A Dask scheduler address: ``[scheme://]host:port``."""


class DaskBackend:
    """Runs chunks on an existing Dask ``distributed`` cluster.

    Parameters
    ----------
    address : str
        Scheduler address, e.g. ``tcp://10.0.0.5:8786``.
    timeout_s : float
        Connection timeout [s].
    in_flight_per_worker : int
        Chunks submitted ahead per worker thread; bounds the memory held by results.
    client : distributed.Client, optional
        An existing client to use instead of connecting (not closed by :meth:`close`).
    no_worker_timeout_s : float
        How long the cluster may have no worker at all before the run fails [s] (a
        run never waits forever on a cluster whose workers all died).

    A lost scheduler or a run stuck without workers is a one-line :class:`ClusterError`
    naming the address.
    """

    def __init__(
        self,
        address: str | None = None,
        timeout_s: float = 5.0,
        in_flight_per_worker: int = 2,
        client: Any = None,
        no_worker_timeout_s: float = 60.0,
    ) -> None:
        try:
            import distributed
        except ImportError:
            raise ClusterError(
                "--scheduler needs the optional package 'distributed' "
                "(pip install 'cyclomesh[cluster]')"
            ) from None
        self._distributed = distributed
        self._own = client is None
        if client is None and not _ADDRESS.fullmatch(str(address or "")):
            raise ClusterError(
                f"--scheduler {address!r}: expected a Dask scheduler address such as "
                "tcp://HOST:PORT"
            )
        if client is None:
            try:
                client = distributed.Client(address, timeout=f"{timeout_s}s", set_as_default=False)
            except Exception as exc:  # OSError, TimeoutError, ValueError (bad address), ...
                first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                raise ClusterError(
                    f"cannot reach the Dask scheduler at {address!r} "
                    f"within {timeout_s:g} s: {first}"
                ) from None
        self.client = client
        self.address = address
        self.poll_s = 1.0
        self.no_worker_timeout_s = no_worker_timeout_s
        threads = sum(client.nthreads().values())
        self.workers = max(1, threads)
        self._per_worker = max(1, in_flight_per_worker)

    def start(self) -> None:
        pass

    def run(self, task: ChunkFunction, chunks: Iterable[Chunk]) -> Iterator[tuple[Chunk, Any]]:
        """Run the chunks on the cluster; a scheduler lost at any step (submitting,
        counting workers, gathering) is one :class:`ClusterError` naming its address."""
        try:
            yield from self._run(task, chunks)
        except CyclomeshError:
            raise
        except Exception as exc:  # the scheduler went away between two steps
            raise self._lost(exc) from None

    def _run(self, task: ChunkFunction, chunks: Iterable[Chunk]) -> Iterator[tuple[Chunk, Any]]:
        distributed = self._distributed
        client = self.client
        token = os.urandom(6).hex()
        in_flight = max(1, self._per_worker * max(1, sum(client.nthreads().values())))
        todo = iter(chunks)
        keys: dict[str, Chunk] = {}

        def submit(chunk: Chunk) -> Any:
            key = f"cyclomesh-chunk-{token}-{chunk[0]}-{chunk[1]}"
            keys[key] = chunk
            return client.submit(_call, task, *chunk, key=key, pure=False)

        first = []
        for _ in range(in_flight):
            chunk = next(todo, None)
            if chunk is None:
                break
            first.append(submit(chunk))
        queue = distributed.as_completed(first, loop=client.loop, with_results=False)
        idle_since: float | None = None
        checked = time.monotonic()
        try:
            while not queue.is_empty():
                try:
                    done = queue.next_batch(block=False)
                except Exception as exc:  # the scheduler is gone
                    raise self._lost(exc) from None
                if not done:  # nothing finished: is there a worker left?
                    now = time.monotonic()
                    if now - checked >= self.poll_s:
                        checked = now
                        idle_since = self._check_workers(idle_since)
                    time.sleep(0.02)
                    continue
                idle_since = None
                for future in done:
                    chunk = keys.pop(future.key)
                    try:
                        result = self._result(future)
                    except CyclomeshError:
                        raise
                    except Exception as exc:  # cancelled: scheduler lost, or a worker error
                        raise self._lost(exc) from None
                    future.release()
                    nxt = next(todo, None)
                    if nxt is not None:
                        queue.add(submit(nxt))
                    yield chunk, result
        finally:
            for future in list(queue.futures):
                with contextlib.suppress(Exception):
                    future.cancel()

    def _result(self, future: Any) -> Any:
        """The result of a future that :func:`distributed.as_completed` gave as done.

        Fetching it can still wait for ever: a worker that dies holding a finished result
        sends its task back to the scheduler, to be run again on a worker that may never
        come. So it is fetched in steps of :attr:`poll_s`, checking for a worker in
        between (:meth:`_check_workers` raises after :attr:`no_worker_timeout_s`)."""
        idle_since: float | None = None
        while True:
            try:
                return future.result(timeout=self.poll_s)
            except TimeoutError:
                idle_since = self._check_workers(idle_since)

    def _where(self) -> str:
        if self.address:
            return str(self.address)
        scheduler = getattr(self.client, "scheduler", None)
        return str(getattr(scheduler, "address", "the scheduler"))

    def _lost(self, exc: BaseException) -> ClusterError:
        first = (str(exc).splitlines() or [""])[0] or type(exc).__name__
        return ClusterError(f"lost the Dask cluster at {self._where()}: {first}")

    def _check_workers(self, idle_since: float | None) -> float | None:
        """Raise if the cluster has had no worker for :attr:`no_worker_timeout_s`."""
        try:
            workers = self.client.scheduler_info(n_workers=-1).get("workers", {})
        except TypeError:  # older distributed
            workers = self.client.scheduler_info().get("workers", {})
        except Exception as exc:
            raise self._lost(exc) from None
        if workers:
            return None
        now = time.monotonic()
        if idle_since is None:
            return now
        if now - idle_since > self.no_worker_timeout_s:
            raise ClusterError(
                f"no Dask worker left at {self._where()} for "
                f"{self.no_worker_timeout_s:g} s: restart the workers and run again"
            )
        return idle_since

    def close(self) -> None:
        if self._own:
            self.client.close()


def _nothing() -> None:
    return None


def _call(task: ChunkFunction, start: int, stop: int) -> Any:
    tune_allocator()
    return task(start, stop)


def make_backend(scheduler: str | None = None, workers: int | None = None) -> Backend:
    """The Dask backend for a scheduler address, else local processes (or serial for 1)."""
    if scheduler:
        return DaskBackend(scheduler)
    if workers == 1:
        return SerialBackend()
    return ProcessBackend(workers)


def default_chunk_size(items: int, workers: int, largest: int = 16) -> int:
    """Chunk size: at least ~4 chunks per worker for balance, at most ``largest`` items."""
    return max(1, min(largest, math.ceil(items / (4 * max(1, workers)))))


def run_chunks(
    task: ChunkFunction,
    items: int,
    *,
    backend: Backend | None = None,
    chunk_size: int | None = None,
    first: int = 0,
    progress: Callable[[int], None] | None = None,
) -> dict[str, NDArray[Any]]:
    """Run ``task`` over items ``first .. first + items − 1`` and gather the results.

    Parameters
    ----------
    task : callable (start, stop) -> {name: array}
        Picklable chunk function (a module-level function or a dataclass instance);
        every array has ``stop − start`` rows.
    items : int
        Number of items.
    backend : Backend, optional
        Where to run (default: serial, in this process).
    chunk_size : int, optional
        Items per chunk (default: :func:`default_chunk_size`).
    first : int
        Index of the first item.
    progress : callable, optional
        Called with the number of items finished by each completed chunk.

    Returns
    -------
    dict of ndarray
        Per-item arrays, row i = item first + i.

    Raises
    ------
    RuntimeError
        If an item was not stored exactly once (an engine bug, never expected).
    """
    backend = backend or SerialBackend()
    chunk_size = chunk_size or default_chunk_size(items, backend.workers)
    chunks = chunk_bounds(items, chunk_size, first)
    out: dict[str, NDArray[Any]] = {}
    stored = np.zeros(items, dtype=np.int32)
    for (start, stop), result in backend.run(task, chunks):
        rows = slice(start - first, stop - first)
        for name, value in result.items():
            arr = np.asarray(value)
            if arr.shape[:1] != (stop - start,):
                raise RuntimeError(
                    f"chunk {start}..{stop}: {name!r} has {arr.shape[:1]} rows, "
                    f"expected {stop - start}"
                )
            if name not in out:
                out[name] = np.zeros((items, *arr.shape[1:]), dtype=arr.dtype)
            elif np.result_type(out[name].dtype, arr.dtype) != out[name].dtype:
                # longer text, or NaN where earlier chunks had integers: keep it whole
                out[name] = out[name].astype(np.result_type(out[name].dtype, arr.dtype))
            out[name][rows] = arr
        stored[rows] += 1
        if progress is not None:
            progress(stop - start)
    if not np.all(stored == 1):
        bad = np.nonzero(stored != 1)[0][:5] + first
        raise RuntimeError(f"items not stored exactly once (first: {bad.tolist()})")
    return out
