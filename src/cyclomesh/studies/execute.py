"""One path for every command: :func:`execute` runs a kind of study into a result folder.

A kind of study is a :class:`StudyKind`: its command name, its compute function, its
result-file writer, its figure jobs and report sections (see ``docs/pipeline.md``).
:func:`execute` does the rest the same way for every kind:

1. locks the output folder (:class:`~cyclomesh.output.folder.ResultFolder`), whose
   files are written into its staging folder and moved into place only at the end, so
   a command that fails leaves an earlier result as it was;
2. starts the figure workers (forked before any thread starts) or, for a kind whose
   items run on an execution backend, the backend and an import preload thread;
3. computes, with the progress callback the caller gives;
4. writes the result files, renders the figures and writes the report
   (:func:`~cyclomesh.publish.pipeline.publish`); ``summary.json`` is written last,
   then everything is moved into ``out``.

The runtime helpers that keep a command fast (figure workers forked early and warmed
up, imports preloaded while the workers compute) live here too, so the command line
(:mod:`cyclomesh.cli`) only parses options and prints.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "StudyKind",
    "CommandSteps",
    "load_kind",
    "execute",
    "figure_pool",
    "figure_jobs",
    "report_title",
    "running_backend",
]

Progress = Callable[[int], None]


@dataclass(frozen=True)
class CommandSteps:
    """What a kind's command does around :func:`execute` beyond the steps every command
    takes (:mod:`cyclomesh.cli` runs them in this order; every field optional).

    ``options`` below is the mapping of the command's options by name (``study``,
    ``out``, ``quiet``, ``rings``, ...: ``cyclomesh.cli.options.OPTIONS``).

    Attributes
    ----------
    before : callable
        ``before(options) -> dict``: checks of the options before the study is loaded;
        returns compute options parsed from them.
    load : callable
        ``load(path, options) -> Study`` (default: ``load_study`` with
        ``--crank-step-deg``).
    check : callable
        ``check(study, options)``: a refusal of an option against the study, after the
        pre-flight.
    parallel : callable
        ``parallel(study, options) -> bool``: the kind runs on an execution backend
        (``--scheduler``, ``--workers``) when true; None: in this process.
    output : callable
        ``output(study, options) -> OutputOptions`` (default: from ``--figures``,
        ``--csv``).
    banner : callable
        ``banner(study, options, workers) -> str``: the line said before computing.
    progress : callable
        ``progress(study, options) -> (total, unit)`` of the progress bar.
    compute : callable
        ``compute(study, options, backend) -> dict``: options of the kind's compute.
    log : bool
        The compute takes ``log`` (a print on stderr, silent with ``--quiet``).
    show : callable
        ``show(result, out, options)``: the table printed after (not with ``--quiet``).
    """

    before: Callable[[Any], dict[str, Any]] | None = None
    load: Callable[[Path, Any], Any] | None = None
    check: Callable[[Any, Any], None] | None = None
    parallel: Callable[[Any, Any], bool] | None = None
    output: Callable[[Any, Any], Any] | None = None
    banner: Callable[[Any, Any, int], str] | None = None
    progress: Callable[[Any, Any], tuple[int, str]] | None = None
    compute: Callable[[Any, Any, Any], dict[str, Any]] | None = None
    log: bool = False
    show: Callable[[Any, Path, Any], None] | None = None


@dataclass(frozen=True)
class StudyKind:
    """A kind of study as every command runs it.

    Attributes
    ----------
    command : str
        The ``cyclomesh`` command (also the name the completion marker records).
    title : str
        Report title after the study's title ("" for none).
    compute : callable
        ``compute(study, *, backend, progress, **options) -> result``: no file written.
    write : callable
        ``write(result, out, options) -> list[Path]``: the result files.
    figures : callable
        ``figures(result, early) -> list[FigureJob]``, ``early`` the jobs of
        ``early_figures`` already submitted (the same objects, so none is drawn twice).
    sections : callable
        ``sections(result) -> list[Section]``.
    early_figures : callable, optional
        ``early_figures(study) -> list[FigureJob]``: figures of the inputs, drawn while
        the study computes.
    overview : callable, optional
        ``overview(result) -> list[FigureJob]``: the figures of the ``overview`` set
        (:data:`cyclomesh.figures.sets.SETS`, the default of ``--figures``), drawn
        instead of ``early_figures`` and ``figures``; None: the kind draws all its
        figures in every set.
    report_name : str or None
        File name of the report; None: the kind writes its files only (no figures,
        no report), as ``export`` does.
    keys_first : callable, optional
        ``keys_first(study)``: a refusal the pre-flight gives before the key usage
        (:func:`cyclomesh.studies.preflight.preflight`).
    preflight : callable, optional
        ``preflight(study)``: the kind's own refusals before computing, after the key
        usage (``cyclomesh check --kind`` gives the same).
    steps : CommandSteps
        What its command does around :func:`execute`.
    probe_free : bool
        The kind builds, reduces and writes its result without xarray's probe for Dask
        arrays (:mod:`cyclomesh.results.arrays`): a parallel run without figures then
        leaves ``dask.array`` unimported (:func:`running_backend`); otherwise the
        preload thread imports it while the workers compute.

    Its study-file side (section, keys, work estimate) and its command line (help,
    options) are its entry in :data:`cyclomesh.studyfile.kinds.KINDS`.
    """

    command: str
    title: str
    compute: Callable[..., Any]
    write: Callable[[Any, Path, Any], list[Path]]
    figures: Callable[[Any, list[Any]], list[Any]]
    sections: Callable[[Any], list[Any]]
    early_figures: Callable[[Any], list[Any]] | None = None
    overview: Callable[[Any], list[Any]] | None = None
    report_name: str | None = "report.html"
    keys_first: Callable[[Any], None] | None = None
    preflight: Callable[[Any], None] | None = None
    steps: CommandSteps = CommandSteps()
    probe_free: bool = False


def load_kind(command: str) -> StudyKind:
    """The :class:`StudyKind` of ``command``, imported from its registry entry's ``home``
    (:data:`cyclomesh.studyfile.kinds.KINDS`)."""
    from importlib import import_module

    from cyclomesh.studyfile.kinds import kind_spec

    module, name = kind_spec(command).home.split(":")
    return getattr(import_module(module), name)


def figure_pool(options: Any, datasets: bool = True) -> AbstractContextManager[Any]:
    """Figure workers, forked now (before any progress thread); none without figures.
    ``datasets``: the figures take xarray Datasets (imported first, so that the workers
    inherit it); the overview of a run takes NumPy arrays only."""
    if not options.figures:
        return nullcontext(None)
    if datasets:
        import xarray  # noqa: F401  (needed anyway: inherited by the forked workers)

    from cyclomesh.figures.render import FigurePool

    gc.freeze()  # the workers' collections then leave the inherited objects (and pages) alone
    return FigurePool(options.figure_workers, one=not datasets)


def _preload(figures: bool, probe: bool = True) -> threading.Thread:
    """Import xarray (and matplotlib) in a thread while the workers compute; ``probe``:
    also build a first array, whose probe for Dask arrays imports ``dask.array`` where
    Dask is installed (about 0.3 s, :mod:`cyclomesh.results.arrays`), for a result that
    builds its variables the usual way.

    Started after the worker processes are forked; joined before anything else forks,
    so the figure workers inherit the imported modules.
    """

    def work() -> None:
        import numpy as np
        import xarray as xr

        from cyclomesh.results.arrays import FIRST_ARRAYS

        if probe:  # the first array sets up xarray's array backends
            with FIRST_ARRAYS:  # not while the main thread imports Dask too
                xr.DataArray(np.zeros(1))
        if figures:
            from cyclomesh.figures.render import warm_up

            warm_up(draw=True)  # the figure workers forked later inherit it
        gc.freeze()  # nor do their collections scan what they inherit

    thread = threading.Thread(target=work, name="cyclomesh-preload", daemon=True)
    thread.start()
    return thread


@contextmanager
def running_backend(backend: Any, figures: bool, probe: bool = True) -> Iterator[Any]:
    """``backend`` (an :mod:`cyclomesh.execution.backends` backend, or None) started,
    with the import preload thread (``probe``: :func:`_preload`); closed on exit, the
    preload joined after success."""
    try:
        if backend is not None:
            backend.start()
        preload = _preload(figures, probe)
        yield backend
    except BaseException:  # Ctrl-C or a failure: the workers' chunks are not wanted
        if backend is not None and hasattr(backend, "terminate"):
            backend.terminate()
        raise
    finally:
        if backend is not None:
            backend.close()
    preload.join()


def execute(
    kind: StudyKind,
    study: Any,
    out: str | Path,
    options: Any,
    *,
    backend: Any = None,
    parallel: bool = False,
    progress: Callable[[], AbstractContextManager[Progress]] | None = None,
    figure_process: Any = None,
    **compute_options: Any,
) -> Any:
    """Run ``kind`` on ``study`` into the folder ``out``; return the computed result.

    Parameters
    ----------
    kind : StudyKind
        What to compute, write, draw and report.
    study : Study
        The loaded, validated study file.
    out : path
        Output folder: locked while the study runs, ``summary.json`` written last.
    options : OutputOptions
        Figure formats and the like (:class:`cyclomesh.publish.pipeline.OutputOptions`).
    backend : Backend, optional
        Where the items of a ``parallel`` kind run (local processes or Dask); started
        here and closed before the figures are drawn.
    parallel : bool
        Whether the kind runs on a backend (then the figure workers are forked only
        after it closed) or in this process (then they are forked first and draw
        while the study computes).
    progress : callable, optional
        ``progress() -> context manager yielding advance(n)``, entered once the workers
        are forked (a progress bar is a thread).
    figure_process : FigureProcess, optional
        The process the command forked as it started to draw the overview
        (:func:`cyclomesh.cli.early_figures`): it draws the overview set of a kind with
        ``overview``; otherwise (no figures, or all of them) it is stopped.
    **compute_options
        Passed on to ``kind.compute``.
    """
    from cyclomesh.output.folder import ResultFolder
    from cyclomesh.publish.pipeline import publish, study_stamp

    out = Path(out)
    bar = progress or (lambda: nullcontext(lambda n: None))
    with ResultFolder(out, kind.command) as folder:
        early: list[Any] = []
        if parallel:
            pool_context: AbstractContextManager[Any] = nullcontext(None)
            figures = bool(options.figures)
            probe = figures or not kind.probe_free
            with running_backend(backend, figures, probe) as started, bar() as advance:
                result = kind.compute(study, backend=started, progress=advance, **compute_options)
        overview = kind.overview is not None and options.figure_set == "overview"
        if not parallel:
            if figure_process is not None and overview and options.figures:
                pool_context = figure_process  # forked as the command started
            else:
                if figure_process is not None:  # not wanted after all
                    figure_process.close()
                pool_context = figure_pool(options, datasets=not overview)
        elif figure_process is not None:
            figure_process.close()
        with pool_context as pool:
            if not parallel:
                if options.figures and kind.early_figures is not None and not overview:
                    early = kind.early_figures(study)
                    if pool is not None:  # drawn while the study computes
                        pool.submit(early, options.figures, options.dpi)
                with bar() as advance:
                    result = kind.compute(study, backend=None, progress=advance, **compute_options)
            jobs = figure_jobs(kind, result, early, options)
            if pool is not None:  # drawn while the result files are written
                pool.submit(jobs, options.figures, options.dpi)
            files = kind.write(result, folder.path, options)  # moved into out at the end
            if kind.report_name is None:
                return result
            title = report_title(study.title, kind.title)
            publish(
                folder.path,
                title,
                kind.sections(result),
                jobs,
                files,
                options,
                study_stamp(study),
                report_name=kind.report_name,
                pool=pool,
            )
    return result


def figure_jobs(kind: StudyKind, result: Any, early: list[Any], options: Any) -> list[Any]:
    """The figures ``options`` ask of ``result`` (none, the overview, or all)."""
    if not options.figures:
        return []
    if kind.overview is not None and options.figure_set == "overview":
        return kind.overview(result)
    return kind.figures(result, early)


def report_title(study_title: str, kind_title: str) -> str:
    """The report's title: the study's, followed by the kind of study unless the study's
    title already says it ("Tolerance study: …" is not followed by ": tolerance study")."""
    if not kind_title or kind_title.casefold() in study_title.casefold():
        return study_title
    return f"{study_title}: {kind_title}"
