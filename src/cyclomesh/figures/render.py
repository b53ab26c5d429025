"""Render figures to files: the one place where figures are saved.

A kind of study describes its figures as :class:`FigureJob` items (a plot function
that takes results and returns a :class:`~matplotlib.figure.Figure`, its arguments,
a caption and the report section it belongs to). :func:`render_figures` draws them,
saves each in the requested formats (PNG, SVG, PDF), keeps the PNG bytes for the
report, and uses a pool of forked processes when there are enough figures to pay for
it. Plot functions never write files.

:func:`new_figure` gives a figure on the Agg canvas without pyplot's global state;
:func:`decimate` thins a long line to the per-pixel minimum and maximum, so spikes
(the real gear-ratio spikes) survive.
"""

from __future__ import annotations

import io
import os
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.execution.runtime import usable_cpus

__all__ = [
    "FORMATS",
    "FigureJob",
    "RenderedFigure",
    "new_figure",
    "decimate",
    "plain_log_axis",
    "steady_axis",
    "legend_outside",
    "render_figures",
    "FigurePool",
    "MAX_POINTS",
    "render_job",
    "save_job",
]

from cyclomesh.figures.sets import FORMATS  # noqa: E402  (file formats of a figure)

MAX_POINTS = 1500
"""Bins of :func:`decimate` along a line (a figure is at most ~1700 px wide at 150 dpi)."""

PNG_COMPRESSION = 3
"""zlib level of PNG files (matplotlib's default 6 takes about twice as long for files
about 10 % smaller)."""

POOL_MIN_FIGURES = 2
"""Fewest figures for which a process pool pays for its start (measured: a fork costs
~20 ms, a figure 70–600 ms of CPU; matplotlib is imported once before the fork)."""


@dataclass(frozen=True)
class FigureJob:
    """One figure of a study, described before it is drawn.

    Attributes
    ----------
    name : str
        File stem (``figures/<name>.png``).
    plot : callable
        A module-level plot function ``plot(*args, **kwargs) -> Figure``.
    args, kwargs
        Its arguments (results, not files).
    caption : str
        Caption in the report.
    section : str
        Heading of the report section the figure goes in (created if no section has it).
    """

    name: str
    plot: Callable[..., Any]
    args: tuple[Any, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    caption: str = ""
    section: str = ""


@dataclass(frozen=True)
class RenderedFigure:
    """A drawn figure: its PNG bytes (for the report) and the files written."""

    name: str
    caption: str
    section: str
    png: bytes
    files: tuple[Path, ...]


def new_figure(width: float, height: float, layout: str | None = None) -> Any:
    """A matplotlib Figure of ``width`` × ``height`` inches on the Agg canvas.

    ``layout`` is passed to matplotlib (``None``: plain subplot parameters, the
    fastest; ``"constrained"`` where colour bars or long labels need it).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout=layout)
    FigureCanvasAgg(fig)
    return fig


def fixed_figure(
    width: float,
    height: float,
    *,
    left: float,
    right: float,
    bottom: float,
    top: float,
    wspace: float | None = None,
    hspace: float | None = None,
) -> Any:
    """A :func:`new_figure` with fixed subplot margins given in inches (a layout engine
    costs more than the plot); ``wspace``/``hspace`` as in matplotlib (None: its
    default)."""
    fig = new_figure(width, height)
    fig.subplots_adjust(
        left=left / width,
        right=1 - right / width,
        bottom=bottom / height,
        top=1 - top / height,
        wspace=wspace,
        hspace=hspace,
    )
    return fig


def plain_log_axis(axis: Any) -> None:
    """Label a log-scaled axis in plain text ("0.01", "1e-05"): the figures are drawn with
    ``text.parse_math`` off (a case name is never mathtext), under which matplotlib's
    default log labels would print as raw ``$\\mathdefault{10^{-2}}$``."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    axis.set_major_formatter(FuncFormatter(lambda value, _pos: f"{value:g}"))
    axis.set_minor_formatter(NullFormatter())


def steady_axis(ax: Any, values: ArrayLike, rtol: float = 1e-3, zero: bool = False) -> None:
    """Keep the y axis of a nearly constant quantity honest: no offset notation, and a span
    of at least ``rtol`` of its magnitude around the values (round-off is not drawn as a
    swing); with ``zero``, the axis starts at 0 (a magnitude: a small ripple is shown at
    its true size)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    if not v.size:
        return
    lo, hi = float(v.min()), float(v.max())
    if zero and lo >= 0:
        ax.set_ylim(0.0, hi * 1.08 if hi > 0 else 1.0)
        return
    half = 0.5 * max(hi - lo, rtol * max(abs(lo), abs(hi)), 1e-300)
    mid = 0.5 * (lo + hi)
    ax.set_ylim(mid - 1.3 * half, mid + 1.3 * half)


def legend_outside(ax: Any, **kwargs: Any) -> Any:
    """A legend to the right of the axes, where it cannot hide a curve (the figure's
    right margin must leave room for it)."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **kwargs)


def decimate(
    x: ArrayLike, y: ArrayLike, bins: int = MAX_POINTS
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Min/max decimation of a line: in each of ``bins`` equal runs of points keep the
    first point, the minimum and the maximum (in their order), and the last point.

    A line with at most ``4 * bins`` points is returned unchanged. What is drawn at one
    pixel column is then the same vertical extent as for the full line, so narrow
    spikes are kept. NaN values (gaps) are kept as gaps.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    n = y.size
    if n <= 4 * bins:
        return x, y
    per = -(-n // bins)
    rows = -(-n // per)
    padded = np.full(rows * per, np.nan)
    padded[:n] = y
    padded = padded.reshape(rows, per)
    nan = np.isnan(padded)
    base = np.arange(rows) * per
    lowest = base + np.argmin(np.where(nan, np.inf, padded), axis=1)
    highest = base + np.argmax(np.where(nan, -np.inf, padded), axis=1)
    last = np.minimum(base + per - 1, n - 1)
    keep = np.concatenate([base, lowest, highest, last, np.flatnonzero(np.isnan(y))])
    keep = np.unique(keep[keep < n])
    return x[keep], y[keep]


def render_job(job: FigureJob, formats: Sequence[str], dpi: int) -> dict[str, bytes]:
    """Draw ``job`` and return its file contents: PNG (always, for the report) and
    every other format of ``formats``."""
    import matplotlib

    # text is plain: a case name or title such as "$x^{$" is not parsed as mathtext
    with matplotlib.rc_context({"text.parse_math": False}):
        fig = job.plot(*job.args, **dict(job.kwargs))
        contents = {}
        for fmt in ("png", *(f for f in formats if f != "png")):
            buffer = io.BytesIO()
            png = {"pil_kwargs": {"compress_level": PNG_COMPRESSION}} if fmt == "png" else {}
            fig.savefig(buffer, format=fmt, dpi=dpi, **png)
            contents[fmt] = buffer.getvalue()
    return contents


def save_job(
    job: FigureJob, contents: Mapping[str, bytes], folder: Path | None, formats: Sequence[str]
) -> RenderedFigure:
    """Write the drawn ``contents`` of ``job`` into ``folder`` (in this process, atomically)."""
    from cyclomesh.output.folder import write_bytes

    files = []
    if folder is not None:
        for fmt in formats:
            path = folder / f"{job.name}.{fmt}"
            write_bytes(path, contents[fmt])
            files.append(path)
    return RenderedFigure(job.name, job.caption, job.section, contents["png"], tuple(files))


def _draw(job: FigureJob, folder: Path | None, formats: Sequence[str], dpi: int) -> RenderedFigure:
    return save_job(job, render_job(job, formats, dpi), folder, formats)


_WARM = False
"""Whether this process has drawn :func:`warm_up`'s throw-away figure."""


def warm_up(draw: bool = False) -> None:
    """Import matplotlib's Agg backend (in a worker, while the study computes).

    With ``draw``, also draw one small figure and throw it away (once per process):
    fonts, text layout, markers and the PNG writer are set up on first use, 0.2–0.4 s
    that the first real figure would pay; processes forked afterwards inherit them.
    """
    global _WARM
    import matplotlib.backends.backend_agg  # noqa: F401

    if not draw or _WARM:
        return
    fig = new_figure(2.0, 1.5)
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0], ".-", label="φ1 µm °")
    ax.imshow(np.ma.masked_less_equal([[0.0, 1.0], [2.0, 3.0]], 0.0), aspect="auto")
    fig.colorbar(ax.images[0], ax=ax, label="[MPa]")
    ax.set_title("warm-up", fontsize="medium")
    ax.set_xlabel("crank angle [deg]")
    ax.legend(fontsize="small")
    fig.savefig(io.BytesIO(), format="png", dpi=20, pil_kwargs={"compress_level": PNG_COMPRESSION})
    _WARM = True


def _warm_worker(parent: int | None = None) -> None:
    """Start of a figure worker: it dies with ``parent`` (its PID,
    :func:`cyclomesh.execution.runtime.die_with_parent`), :func:`warm_up` with its
    figure (unless the parent drew it), then :func:`gc.freeze`: the objects of the
    imports are never scanned again (a tenth of a figure's time went to full collections
    over them)."""
    import gc

    if parent is not None:
        from cyclomesh.execution.runtime import die_with_parent

        die_with_parent(parent)
    warm_up(draw=True)
    gc.freeze()


def _nothing() -> None:
    return None


class FigurePool:
    """Processes that draw figures, forked early so that they import matplotlib while
    the study computes.

    Create it before any other thread starts (a progress bar): the workers are forked
    only when this process has a single thread and ``fork`` exists; otherwise (or
    with ``workers`` ≤ 1) the pool is empty and figures are drawn in this process.
    ``one``: a single worker (for a single figure, e.g. the overview of a run), forked
    where this process has a second core to leave it.
    Use as a context manager; pass it to :func:`render_figures`.

    :meth:`submit` starts jobs as soon as their inputs exist (the profile before the
    solve, the result figures before the result files are written); the workers only
    draw, this process writes the files when :meth:`map` (:func:`render_figures`)
    collects them, so nothing is written for a study that fails.
    """

    def __init__(self, workers: int | None = None, *, one: bool = False) -> None:
        self.workers = usable_cpus() if workers is None else workers
        if one:  # one worker beside this process (a single figure), where there are 2 cores
            self.workers = 1 if self.workers > 1 else 0
        self._pool: Any = None  # a ProcessPoolExecutor
        self._pending: dict[tuple[int, tuple[str, ...], int], tuple[FigureJob, Any]] = {}
        import multiprocessing  # here: a process that only draws never imports them
        from concurrent.futures import ProcessPoolExecutor

        if (
            self.workers >= (1 if one else 2)
            and "fork" in multiprocessing.get_all_start_methods()
            and threading.active_count() == 1
        ):
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=multiprocessing.get_context("fork"),
                initializer=_warm_worker,
                initargs=(os.getpid(),),
            )
            self._pool.submit(_nothing)  # fork all workers now

    @property
    def active(self) -> bool:
        """Whether there are worker processes."""
        return self._pool is not None

    def submit(self, jobs: Sequence[FigureJob], formats: Sequence[str], dpi: int) -> None:
        """Start drawing ``jobs`` now (no file is written until :meth:`map`); jobs
        already submitted are not drawn twice. Does nothing without workers."""
        if self._pool is None:
            return
        for job in jobs:
            key = (id(job), tuple(formats), dpi)
            if key not in self._pending:
                future = self._pool.submit(render_job, job, tuple(formats), dpi)
                self._pending[key] = (job, future)  # the job is kept: its id stays unique

    def map(
        self, jobs: Sequence[FigureJob], folder: Path | None, formats: Sequence[str], dpi: int
    ) -> list[RenderedFigure]:
        """Draw ``jobs`` in the workers (those not yet submitted), write their files into
        ``folder`` and return them in order of the jobs."""
        assert self._pool is not None
        self.submit(jobs, formats, dpi)
        futures = [self._pending.pop((id(job), tuple(formats), dpi))[1] for job in jobs]
        return [
            save_job(job, future.result(), folder, formats)
            for job, future in zip(jobs, futures, strict=True)
        ]

    def close(self) -> None:
        """Stop the workers."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        self._pending.clear()

    def __enter__(self) -> FigurePool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def render_figures(
    jobs: Sequence[FigureJob],
    folder: Path | None,
    formats: Sequence[str] = ("png",),
    dpi: int = 150,
    workers: int | None = None,
    pool: FigurePool | None = None,
) -> list[RenderedFigure]:
    """Draw every job, save it into ``folder`` in ``formats``, return them in order.

    Parameters
    ----------
    jobs : sequence of FigureJob
    folder : Path or None
        Where to write ``<name>.<format>`` (created); None writes no file (the PNG
        bytes are still returned, e.g. for the report).
    formats : sequence of {"png", "svg", "pdf"}
    dpi : int
        Resolution of PNG files and of the report's images [dots/inch].
    workers : int, optional
        Without ``pool``: processes to draw in (default: the usable CPUs when there
        are at least :data:`POOL_MIN_FIGURES` figures, else 1).
    pool : FigurePool, optional
        Workers started earlier (see :class:`FigurePool`).
    """
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise ValueError(f"unknown figure format {unknown[0]!r}, expected one of {FORMATS}")
    if folder is not None and jobs:
        folder.mkdir(parents=True, exist_ok=True)
    if pool is not None and pool.active and jobs:  # its workers are warm already
        return pool.map(jobs, folder, formats, dpi)
    if workers is None:
        workers = usable_cpus() if len(jobs) >= POOL_MIN_FIGURES else 1
    workers = min(workers, len(jobs))
    if workers > 1:
        warm_up(draw=True)  # once here rather than in every forked worker
        with FigurePool(workers) as own:
            if own.active:
                return own.map(jobs, folder, formats, dpi)
    return [_draw(job, folder, formats, dpi) for job in jobs]
