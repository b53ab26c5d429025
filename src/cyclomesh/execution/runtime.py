"""Process-wide settings that make the solver fast, applied where a process starts and
nowhere else: the ``cyclomesh`` command's entry (``cli.main``), the initializer of its
local worker processes (:func:`start_worker`) and of Dask workers
(:mod:`cyclomesh.execution.backends`). Library calls (:func:`cyclomesh.analyse`,
:func:`cyclomesh.stiffness`, ...) leave the process alone: a script or notebook that
wants the faster allocator calls :func:`tune_allocator` itself, once, first thing.
"""

from __future__ import annotations

import os
import sys
import threading
import time

__all__ = [
    "usable_cpus",
    "version",
    "tune_allocator",
    "tune_blas",
    "skip_pydantic_plugins",
    "pause_gc",
    "resume_gc",
    "die_with_parent",
    "start_worker",
]

MMAP_THRESHOLD = 32 * 1024 * 1024
"""Arrays up to this size [bytes] come from the heap, not from a fresh mmap."""
TRIM_THRESHOLD = 64 * 1024 * 1024
"""Free heap memory above this size [bytes] is given back to the system."""

_TUNED = False


def tune_allocator() -> None:
    """Keep glibc from mapping and unmapping every temporary array of the solver.

    glibc's malloc gives each allocation above its mmap threshold (128 KiB at start) a
    fresh mapping and unmaps it on free, so the temporaries of a vectorised solve (a few
    MB each) cost a page fault per page on every use; its dynamic threshold only partly
    adapts, and setting any malloc threshold (Dask's nanny sets
    ``MALLOC_TRIM_THRESHOLD_``) switches the adaptation off. A fixed mmap threshold of
    32 MiB and trim threshold of 64 MiB keep the temporaries on the heap: measured
    1.6–1.7× on ``benchmarks/bench_core.py`` with identical results, while memory above
    64 MiB is still given back. Once per process; glibc only (elsewhere nothing happens);
    left alone when the user set ``MALLOC_MMAP_THRESHOLD_`` themselves.
    """
    global _TUNED
    if _TUNED:
        return
    _TUNED = True
    if "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, MMAP_THRESHOLD)  # M_MMAP_THRESHOLD
        libc.mallopt(-1, TRIM_THRESHOLD)  # M_TRIM_THRESHOLD
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


BLAS_THREAD_TIMEOUT = "20"
"""``OPENBLAS_THREAD_TIMEOUT``: an idle OpenBLAS thread spins 2**20 cycles (about
0.3 ms) before it sleeps, instead of OpenBLAS's 2**28 (about 0.1 s)."""


def tune_blas() -> None:
    """Keep OpenBLAS's idle threads from spinning for 0.1 s after each use.

    NumPy's OpenBLAS starts its threads when NumPy is imported, and an idle thread
    busy-waits 2**28 cycles (about 0.1 s) before it sleeps: every process that imports
    NumPy burns about 0.08 CPU-seconds that way (measured: ``import numpy`` 0.17 → 0.09
    CPU-s on the 2-core machine), taken from the command's other process (the overview's
    figure process) and from the other jobs. :data:`BLAS_THREAD_TIMEOUT` shortens the
    spin to about 0.3 ms: the threads, and BLAS's speed, are the same. OpenBLAS reads
    the variable when it is loaded, so this acts only before NumPy is imported (and in
    the processes started from this one); left alone when the user set it. The
    command's entry only (library calls leave the process alone)."""
    os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", BLAS_THREAD_TIMEOUT)


def skip_pydantic_plugins() -> None:
    """Build the study file's models without looking for pydantic plugins: pydantic
    reads the entry points of every installed distribution when it builds its first
    model (0.02 s of a 36-step run), for observability plugins the command has no use
    for. Left alone when the user set ``PYDANTIC_DISABLE_PLUGINS`` themselves; the
    command's entry only (library calls leave the process alone)."""
    os.environ.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")


_GC_PAUSED = False


def pause_gc() -> None:
    """Pause Python's cyclic garbage collector while the command starts: its imports
    (typer, pydantic, NumPy, the study file's models, the kind's modules) and the
    study's loading make hundreds of thousands of objects that live as long as the
    process, and the collector scans them again and again as they come (0.01–0.02
    CPU-s of a 36-step ``run --figures none``, measured with it off). Only where nothing
    else ran yet and GC is on: the command's entry (``cyclomesh.__main__.main``);
    :func:`resume_gc` turns it back on before any work that makes garbage. Library calls
    leave the process alone."""
    global _GC_PAUSED
    import gc

    if not _GC_PAUSED and gc.isenabled():
        gc.disable()
        _GC_PAUSED = True


def resume_gc() -> None:
    """Turn the collector paused by :func:`pause_gc` back on, after moving every object
    made so far (modules, classes, the loaded study) to the permanent generation
    (``gc.freeze``), which later collections leave alone. Does nothing if
    :func:`pause_gc` did not pause it (a library call, a command run in a process
    by ``app([...])``)."""
    global _GC_PAUSED
    import gc

    if _GC_PAUSED:
        _GC_PAUSED = False
        gc.freeze()
        gc.enable()


PR_SET_PDEATHSIG = 1
"""``prctl`` option: the signal a process gets when its parent dies (Linux)."""


def die_with_parent(parent: int) -> None:
    """Make this (worker) process die with its parent ``parent`` (a PID).

    On Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills the worker when the
    process that started it ends, even by ``kill -9``, so no orphan keeps its memory.
    Elsewhere a daemon thread checks every second that the parent is still there.
    """
    import signal

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0:
                if os.getppid() != parent:  # the parent died before the prctl
                    os._exit(1)
                return
        except (OSError, AttributeError):  # pragma: no cover - no prctl
            pass

    def watch() -> None:  # pragma: no cover - not Linux
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="cyclomesh-watchdog", daemon=True).start()


def start_worker(parent: int) -> None:
    """Initializer of a local worker process: it dies with ``parent``
    (:func:`die_with_parent`), leaves Ctrl-C (SIGINT, sent by a terminal to every
    process of the command) to its parent, which stops it, and tunes its allocator
    (:func:`tune_allocator`)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent)
    tune_allocator()


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask; at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def version() -> str:
    """The installed cyclomesh version (``importlib.metadata``), or ``"unknown"``."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed

    try:
        return installed("cyclomesh")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"
