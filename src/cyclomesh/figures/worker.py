"""One figure process forked as a command starts, for a kind whose default figures are
drawn from NumPy arrays (the overview of ``cyclomesh run``, issue 27).

Importing matplotlib and drawing the overview take longer than everything else a short
run does (a 36-step case: ~0.35 s of imports and ~0.25 s of drawing, against ~0.4 s for
loading, solving and writing). :class:`FigureProcess` forks one process before the
study is loaded (this module imports nothing heavy: the command forks it as soon as
it knows its name and raw options, :mod:`cyclomesh.figures.early`, once NumPy is
imported, which both processes need); the process imports matplotlib while this one
imports, loads, solves and writes, then
draws the one batch of figures it is sent and sends the drawn file contents back. It
has the interface of :class:`~cyclomesh.figures.render.FigurePool` that
:func:`~cyclomesh.figures.render.render_figures` and
:func:`cyclomesh.studies.execute.execute` use (``active``, ``submit``, ``map``,
``close``, a context manager); files are written by this process only, so nothing is
written for a study that fails, and :meth:`~FigureProcess.close` kills the process (a
refused study does not wait for matplotlib's import).
"""

from __future__ import annotations

import os
import pickle
import signal
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["FigureProcess"]


def _read_all(fd: int) -> bytes:
    """Everything written to the pipe ``fd`` until its writer closes it (closes ``fd``)."""
    with os.fdopen(fd, "rb") as pipe:
        return pipe.read()


def _import_matplotlib() -> None:
    """Import what the figure process draws with (while the parent computes), without
    matplotlib's 3D toolkit: ``matplotlib.projections`` imports ``mpl_toolkits.mplot3d``
    only to register the ``"3d"`` projection, which no figure of cyclomesh uses (about
    a tenth of matplotlib's import). This process only draws figures, so its
    ``sys.modules`` is its own to change; matplotlib's warning that Axes3D is missing is
    silenced.

    While matplotlib's modules are imported, :func:`matplotlib.artist.kwdoc` (the text
    of the property table that each Artist class's ``set`` docstring and the
    ``%(Line2D:kwdoc)s`` placeholders of docstrings get) returns an empty string; the
    function is restored afterwards. The tables are documentation only (nothing draws
    with them) and were a fifth of matplotlib's import: ~0.06 CPU-s, measured; figures
    byte for byte the same (tested)."""
    import sys
    import warnings

    sys.modules.setdefault("mpl_toolkits.mplot3d", None)  # type: ignore[arg-type]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Unable to import Axes3D")
        import matplotlib.artist as artist

        kwdoc = artist.kwdoc
        artist.kwdoc = _no_property_table
        try:
            import matplotlib.backends.backend_agg  # noqa: F401
            import matplotlib.figure  # noqa: F401
        finally:
            artist.kwdoc = kwdoc


def _no_property_table(artist: Any) -> str:
    """Stand-in for :func:`matplotlib.artist.kwdoc` while the figure process imports
    matplotlib (:func:`_import_matplotlib`): no property table in docstrings."""
    return ""


def _serve(jobs_fd: int, done_fd: int, parent: int) -> None:
    """The figure process: import the renderer, wait for one batch of jobs, draw them,
    send back ``("ok", contents)`` or ``("error", exception)``. Python's cyclic garbage
    collector is off in it: the process imports matplotlib, draws one batch and ends,
    and the collector's scans of matplotlib's objects as they come were 0.03 of its
    ~0.5 CPU-s (measured: a 36-step run's overview)."""
    import gc

    from cyclomesh.execution.runtime import die_with_parent

    gc.disable()  # one batch, then the process ends: its garbage goes with it
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C: the parent stops it
    die_with_parent(parent)
    _import_matplotlib()

    from cyclomesh.figures.render import render_job

    data = _read_all(jobs_fd)
    if not data:  # closed without jobs: nothing to draw
        return
    try:
        jobs, formats, dpi = pickle.loads(data)
        reply: tuple[str, Any] = ("ok", [render_job(job, formats, dpi) for job in jobs])
        payload = pickle.dumps(reply)
    except Exception as exc:  # re-raised in the parent, as a drawing there would raise
        try:
            payload = pickle.dumps(("error", exc))
        except Exception:  # an exception that does not pickle
            payload = pickle.dumps(("error", RuntimeError(f"{type(exc).__name__}: {exc}")))
    with os.fdopen(done_fd, "wb") as pipe:
        pipe.write(payload)


class FigureProcess:
    """A forked process that draws one batch of figures (module doc).

    Forked at construction where ``fork`` exists, this process has a single thread and
    the machine a second usable CPU (as :class:`~cyclomesh.figures.render.FigurePool`
    with ``one=True``); otherwise :attr:`active` is False and the figures are drawn in
    this process.
    """

    def __init__(self) -> None:
        from cyclomesh.execution.runtime import usable_cpus

        self._pid: int | None = None
        self._sent: tuple[tuple[int, ...], tuple[str, ...], int] | None = None
        self._jobs: list[Any] = []
        self._sender: threading.Thread | None = None
        if not hasattr(os, "fork") or threading.active_count() != 1 or usable_cpus() < 2:
            return
        jobs_r, jobs_w = os.pipe()
        done_r, done_w = os.pipe()
        parent = os.getpid()
        pid = os.fork()
        if pid == 0:  # the figure process: never returns into the command
            code = 1
            try:
                os.close(jobs_w)
                os.close(done_r)
                _serve(jobs_r, done_w, parent)
                code = 0
            finally:
                os._exit(code)
        os.close(jobs_r)
        os.close(done_w)
        self._pid, self._jobs_fd, self._done_fd = pid, jobs_w, done_r

    @property
    def active(self) -> bool:
        """Whether the process is there and has not drawn its batch yet."""
        return self._pid is not None

    def submit(self, jobs: Sequence[Any], formats: Sequence[str], dpi: int) -> None:
        """Send ``jobs`` (the one batch) to be drawn now; a second batch is drawn in this
        process by :meth:`map`. The jobs are written to the pipe by a thread, so that
        this process goes on while the figure process still imports matplotlib."""
        if self._pid is None or self._sent is not None or not jobs:
            return
        data = pickle.dumps((list(jobs), tuple(formats), int(dpi)))
        self._jobs = list(jobs)  # kept: their ids stay unique
        self._sent = (tuple(id(job) for job in jobs), tuple(formats), int(dpi))
        fd, self._jobs_fd = self._jobs_fd, None

        def send() -> None:
            try:
                with os.fdopen(fd, "wb") as pipe:
                    pipe.write(data)
            except OSError:  # the process was stopped (close): nothing to send to
                pass

        self._sender = threading.Thread(target=send, name="cyclomesh-figures", daemon=True)
        self._sender.start()

    def map(
        self, jobs: Sequence[Any], folder: Path | None, formats: Sequence[str], dpi: int
    ) -> list[Any]:
        """Draw ``jobs`` (in the figure process if they are its batch, else here), write
        their files into ``folder`` and return them
        (:class:`~cyclomesh.figures.render.RenderedFigure`) in order of the jobs."""
        from cyclomesh.figures.render import render_job, save_job

        self.submit(jobs, formats, dpi)
        key = (tuple(id(job) for job in jobs), tuple(formats), int(dpi))
        contents = None
        if self._pid is not None and self._sent == key:
            contents = self._collect()
        if contents is None:  # another batch, or the process is gone: drawn here
            contents = [render_job(job, tuple(formats), dpi) for job in jobs]
        return [save_job(job, c, folder, formats) for job, c in zip(jobs, contents, strict=True)]

    def _collect(self) -> list[dict[str, bytes]] | None:
        """The drawn contents of the batch (None if the process ended without them);
        re-raises an error of a plot function."""
        assert self._pid is not None
        data = _read_all(self._done_fd)
        self._done_fd = None
        os.waitpid(self._pid, 0)
        self._pid = None
        if self._sender is not None:
            self._sender.join()
        if not data:
            return None
        status, value = pickle.loads(data)
        if status == "error":
            raise value
        return value

    def close(self) -> None:
        """Stop the process (killed if it has not finished) and close the pipes."""
        if self._pid is not None:
            try:
                os.kill(self._pid, signal.SIGKILL)
            except ProcessLookupError:  # pragma: no cover - already gone
                pass
            os.waitpid(self._pid, 0)
            self._pid = None
        for name in ("_jobs_fd", "_done_fd"):
            fd = getattr(self, name, None)
            if fd is not None:
                os.close(fd)
                setattr(self, name, None)
        if self._sender is not None:
            self._sender.join()
            self._sender = None

    def __enter__(self) -> FigureProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
