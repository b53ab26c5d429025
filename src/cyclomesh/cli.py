"""The ``cyclomesh`` command: a thin layer over the study pipeline, with progress.

``cyclomesh run STUDY.toml --out DIR`` runs the cases of a study file,
``cyclomesh tolerance`` and ``cyclomesh allocate`` its ``[tolerance]`` section,
``cyclomesh stiffness`` the torsion curve of every case from its ``[stiffness]`` section
(``docs/drive.md``), ``cyclomesh check`` validates every section without running
anything (see ``docs/study-files.md`` and ``docs/pipeline.md``). Every refused input comes out as
``error: <one line>`` on stderr with exit status 2 and no traceback; a command gets
that behaviour from :func:`cli_errors`::

    from cyclomesh.cli import app, cli_errors

    @app.command()
    @cli_errors()
    def stiffness(...): ...

Progress bars and tables live here only; the studies report progress through
callbacks. Heavy modules are imported inside the commands, so ``--help`` is fast.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer
import typer.core

from cyclomesh.exceptions import CyclomeshError, StudyError

__all__ = [
    "app",
    "cli_errors",
    "fail",
    "stderr_console",
    "progress_bar",
    "output_options",
    "EXIT_INPUT_ERROR",
]

EXIT_INPUT_ERROR = 2
"""Exit status for an input that cyclomesh refuses (as for a usage error)."""


class _OneLineUsage(typer.core.TyperGroup):
    """The command group, with usage errors (unknown option, bad value, missing
    argument) as one line ``error: ...`` and exit status 2, like every refused input."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            rv = super().main(*args, standalone_mode=False, **kwargs)
        except typer.TyperException as exc:  # Click's usage errors (typer vendors Click)
            if type(exc).__name__ == "NoArgsIsHelpError" or not hasattr(exc, "format_message"):
                exc.show()  # type: ignore[attr-defined]
                sys.exit(getattr(exc, "exit_code", EXIT_INPUT_ERROR))
            ctx = getattr(exc, "ctx", None)
            where = ctx.command_path if ctx is not None else "cyclomesh"
            line = " ".join(exc.format_message().split())
            typer.echo(f"error: {where}: {line} (see {where} --help)", err=True)
            sys.exit(EXIT_INPUT_ERROR)
        except typer.Abort:
            typer.echo("Aborted!", err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


app = typer.Typer(
    name="cyclomesh",
    cls=_OneLineUsage,
    help="Loaded tooth contact analysis of cycloid-pin gear pairs (RV reducers).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_show_locals=False,
    rich_markup_mode=None,  # keep "[deg]" and "[tolerance]" in help texts as typed
)


def fail(message: str) -> typer.Exit:
    """Print ``error: <message>`` (one line) on stderr; return the Exit to raise."""
    line = " ".join(part.strip() for part in str(message).splitlines() if part.strip())
    typer.echo(f"error: {line}", err=True)
    return typer.Exit(EXIT_INPUT_ERROR)


def _pydantic_error(exc: BaseException) -> str | None:
    pydantic = sys.modules.get("pydantic")  # not imported: cannot be a pydantic error
    if pydantic is None or not isinstance(exc, pydantic.ValidationError):
        return None
    first = exc.errors(include_url=False)[0]
    key = ".".join(str(part) for part in first["loc"])
    return f"{key}: {first['msg']}" if key else first["msg"]


@contextmanager
def cli_errors() -> Iterator[None]:
    """Turn refused inputs into ``error: <one line>`` on stderr and exit status 2.

    Catches :class:`~cyclomesh.exceptions.CyclomeshError` (which includes
    ``StudyError``, ``DesignError`` and ``ConvergenceError``), pydantic validation
    errors, TOML syntax errors and operating-system errors (missing file, no
    permission). Use it as a context manager or as a decorator of a command.
    """
    import os
    import tomllib

    if os.environ.get("CYCLOMESH_TRACEBACK"):
        yield
        return
    try:
        yield
    except CyclomeshError as exc:
        raise fail(str(exc)) from None
    except tomllib.TOMLDecodeError as exc:
        raise fail(f"invalid TOML: {exc}") from None
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        raise fail(f"{where}{exc.strerror or exc}") from None
    except RecursionError:
        raise fail("input nested too deeply") from None
    except MemoryError:
        raise fail(
            "out of memory: ask for less work (fewer crank angles, rings or points)"
        ) from None
    except ValueError as exc:
        message = _pydantic_error(exc)
        if message is None:
            raise fail(_internal(exc)) from None
        raise fail(message) from None
    except (typer.Exit, typer.Abort, KeyboardInterrupt, SystemExit):
        raise
    except Exception as exc:  # a bug: still one line, never a traceback
        raise fail(_internal(exc)) from None


def _internal(exc: BaseException) -> str:
    return (
        f"internal error ({type(exc).__name__}: {exc}); please report it with the study file "
        "(CYCLOMESH_TRACEBACK=1 shows the traceback)"
    )


def stderr_console(quiet: bool = False) -> Any:
    """A Rich console on stderr for progress (silent when ``quiet``)."""
    from rich.console import Console

    return Console(stderr=True, quiet=quiet, highlight=False)


@contextmanager
def progress_bar(
    total: int, label: str, quiet: bool, unit: str = "rings"
) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr (none when quiet or not a terminal); yields ``advance(n)``."""
    console = stderr_console(quiet)
    if quiet or not console.is_terminal:
        yield lambda done: None
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn() if unit else TaskProgressColumn(),
        TimeElapsedColumn(),
        TextColumn("left"),
        TimeRemainingColumn(),
        console=console,
    ) as bar:
        task = bar.add_task(label, total=total)
        yield lambda done: bar.advance(task, done)


def _say(message: str, quiet: bool) -> None:
    if not quiet:
        stderr_console().print(message)


def _version(value: bool) -> None:
    if value:
        from cyclomesh.publish.report import cyclomesh_version

        typer.echo(f"cyclomesh {cyclomesh_version()}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_version, is_eager=True, help="Show the version."),
    ] = False,
) -> None:
    """Loaded tooth contact analysis of cycloid-pin gear pairs (Li et al., Machines 2022)."""
    from cyclomesh.execution.runtime import tune_allocator

    tune_allocator()


@contextmanager
def _dask_hidden(hide: bool = True) -> Iterator[None]:
    """Hide an installed dask from xarray while a command runs.

    xarray checks every new array and index for dask arrays, and imports ``dask`` and
    ``dask.array`` to do so when they are installed (the ``cluster`` extra): 0.5 s,
    more than the solve of a run. A command without ``--scheduler`` never gives xarray
    a dask array, so if neither is imported yet, ``sys.modules["dask"] = None`` makes
    xarray (and the forked figure workers) see dask as absent. Undone on exit, with
    xarray's cached answers, so that the rest of a process (tests) sees dask again.
    """
    if not hide or "dask" in sys.modules or "xarray" in sys.modules:
        yield
        return
    sys.modules["dask"] = None  # type: ignore[assignment]
    try:
        yield
    finally:
        if "dask" in sys.modules and sys.modules["dask"] is None:
            del sys.modules["dask"]
        _forget_no_dask()


def _forget_no_dask() -> None:
    """Drop xarray's cached "dask is not installed" (see :func:`_dask_hidden`)."""
    utils = sys.modules.get("xarray.namedarray.utils")
    clear = getattr(getattr(utils, "module_available", None), "cache_clear", None)
    if clear is not None:
        clear()
    pycompat = sys.modules.get("xarray.namedarray.pycompat")
    cached = getattr(pycompat, "_cached_duck_array_modules", None)
    if isinstance(cached, dict) and not getattr(cached.get("dask"), "available", True):
        del cached["dask"]
    ops = sys.modules.get("xarray.core.duck_array_ops")
    if getattr(ops, "dask_available", None) is False:
        ops.dask_available = utils.module_available("dask")  # type: ignore[union-attr]


def _without_dask(command: Callable[..., Any]) -> Callable[..., Any]:
    """Run ``command`` with dask hidden (:func:`_dask_hidden`) unless it was given
    a Dask ``scheduler``."""
    import functools

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with _dask_hidden(kwargs.get("scheduler") is None):
            return command(*args, **kwargs)

    return wrapper


def _overrides(crank_step_deg: float | None) -> dict:
    return {} if crank_step_deg is None else {"analysis": {"crank_step_deg": crank_step_deg}}


StudyArg = Annotated[
    Path, typer.Argument(help="Study file (TOML).", show_default=False, metavar="STUDY.toml")
]
OutOption = Annotated[Path, typer.Option("--out", "-o", help="Output folder (created if needed).")]
QuietOption = Annotated[
    bool, typer.Option("--quiet", "-q", help="No progress and no summary table.")
]
StepOption = Annotated[
    float | None,
    typer.Option(
        "--crank-step-deg",
        help="Override analysis.crank_step_deg of every case [deg] (for a quick look).",
        show_default=False,
    ),
]
CacheDirOption = Annotated[
    Path | None,
    typer.Option(
        "--cache-dir",
        help='Cache of the FE coefficients of [analysis] disc_body = "fe" (default: '
        "$XDG_CACHE_HOME/cyclomesh or ~/.cache/cyclomesh).",
        show_default=False,
    ),
]


def _cache_dir(path: Path | None) -> None:
    """Point the disc body's cache at ``path`` for this process and its workers."""
    if path is not None:
        os.environ["CYCLOMESH_CACHE_DIR"] = str(path)


FiguresOption = Annotated[
    str | None,
    typer.Option(
        "--figures",
        help="Figure formats, comma-separated: png, svg, pdf; or none "
        "(default: figures.formats of the study file, png).",
        show_default=False,
    ),
]
CsvOption = Annotated[
    bool,
    typer.Option(
        "--csv",
        help="Also write the full pin-level results.csv of every case (the same numbers "
        "are in results.parquet and results.nc).",
    ),
]
RingsOption = Annotated[
    int | None,
    typer.Option(
        "--rings", min=1, help="Rings to draw (default: tolerance.rings).", show_default=False
    ),
]
SchedulerOption = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        help="Dask scheduler address (tcp://HOST:PORT) of an existing cluster; "
        "default: all local cores.",
        show_default=False,
    ),
]
WorkersOption = Annotated[
    int | None,
    typer.Option(
        "--workers", min=1, help="Local worker processes (default: all cores).", show_default=False
    ),
]
NoLimitOption = Annotated[
    bool,
    typer.Option(
        "--no-work-limit",
        help="Run even a study that asks for more than the work limits (docs/study-files.md).",
    ),
]
ChunkOption = Annotated[
    int | None,
    typer.Option(
        "--chunk-rings",
        min=1,
        help="Rings per chunk of work (default: one core call, 16 rings at 1°).",
        show_default=False,
    ),
]


def output_options(study: Any, figures: str | None, csv: bool = False) -> Any:
    """The pipeline's :class:`~cyclomesh.publish.pipeline.OutputOptions` from the CLI options."""
    from cyclomesh.publish.pipeline import OutputOptions

    return OutputOptions.from_study(study, figures, csv)


@app.command()
@cli_errors()
def check(
    study: StudyArg, crank_step_deg: StepOption = None, no_work_limit: NoLimitOption = False
) -> None:
    """Validate a study file (every section) without running it."""
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded = load_study(study, _overrides(crank_step_deg))
    check_study_work(loaded, "check", allow=no_work_limit)
    if any(case.analysis.disc_body == "fe" for case in loaded.cases):
        from cyclomesh.results.dataset import FE_EXTRA_MESSAGE, fe_extra_available

        if not fe_extra_available():
            raise StudyError(f"{study}: [analysis] {FE_EXTRA_MESSAGE}")
    names = ", ".join(case.name for case in loaded.cases)
    more = "; [tolerance] OK" if loaded.tolerance is not None else ""
    if any(case.stiffness is not None for case in loaded.cases):
        more += "; [stiffness] OK"
    if loaded.file.design_space is not None:
        more += "; [design_space] OK"
    if loaded.file.fe is not None:
        more += "; [fe] OK"
    if loaded.file.requirements != type(loaded.file.requirements)():
        more += "; [requirements] OK"
    typer.echo(f"{study}: {len(loaded.cases)} case(s) OK: {names}{more}")


@app.command()
@cli_errors()
@_without_dask
def run(
    study: StudyArg,
    out: OutOption,
    quiet: QuietOption = False,
    crank_step_deg: StepOption = None,
    figures: FiguresOption = None,
    csv: CsvOption = False,
    cache_dir: CacheDirOption = None,
    no_work_limit: NoLimitOption = False,
) -> None:
    """Run every case of a study; write results, figures, summary.json and report.html."""
    _cache_dir(cache_dir)
    from cyclomesh.publish.pipeline import publish, study_stamp
    from cyclomesh.studies import run as kind
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded = load_study(study, _overrides(crank_step_deg))
    check_study_work(loaded, "run", allow=no_work_limit)
    options = output_options(loaded, figures, csv)
    with _folder(out, "run"), _figure_pool(options) as pool:  # pool forked now: it imports
        early = kind.input_figures(loaded) if options.figures else []  # matplotlib meanwhile
        if pool is not None:  # the profile is drawn while the cases are solved
            pool.submit(early, options.figures, options.dpi)
        with progress_bar(len(loaded.cases), "cases", quiet) as advance:
            result = kind.compute_run(loaded, on_done=lambda name: advance(1))
        jobs = kind.run_figures(result, early) if options.figures else []
        if pool is not None:  # drawn while the result files are written
            pool.submit(jobs, options.figures, options.dpi)
        _say("writing results, figures and report", quiet)
        files = kind.write_run(result, out, options)
        publish(
            out,
            loaded.title,
            kind.run_sections(result),
            jobs,
            files,
            options,
            study_stamp(loaded),
            pool=pool,
        )
    if not quiet:
        _print_summary(result.summaries, out, result.checks, result.study_warnings())


def _print_warnings(warnings: list[str]) -> None:
    from rich.console import Console
    from rich.markup import escape

    console = Console()
    for warning in warnings:
        console.print(f"warning: {escape(warning)}")


def _print_summary(
    summaries: dict, out: Path, checks: dict | None = None, warnings: list[str] = ()
) -> None:
    from rich.console import Console

    from cyclomesh.publish.console import RUN_ROWS, print_checks, print_metrics

    console = Console(highlight=False)
    records = {
        (
            f"{name} ({'/'.join(f'{t:g}' for t in r['torque_nm'])} N·m)"
            if isinstance(r.get("torque_nm"), list)
            else name
        ): r
        for name, r in summaries.items()
    }
    print_metrics(console, records, RUN_ROWS)
    if checks:
        print_checks(console, checks)
    overlap = [record.get("overlap") for record in summaries.values()]
    if any(any(v) if isinstance(v, list) else v for v in overlap):
        console.print(
            "warning: the disc interferes with unloaded-side pins (see max_overlap_arcsec)"
        )
    _print_warnings(list(warnings))
    console.print(f"report: {out / 'report.html'}")


@app.command()
@cli_errors()
def export(
    study: StudyArg,
    out: OutOption,
    format: Annotated[
        str,
        typer.Option("--format", help="Comma-separated: dxf, svg, csv."),
    ] = "dxf,svg,csv",
    chord_tolerance_um: Annotated[
        float,
        typer.Option(
            "--chord-tolerance-um",
            help="Largest distance between the exported polyline and the exact profile [µm].",
        ),
    ] = 0.1,
    quiet: QuietOption = False,
) -> None:
    """Export the whole modified disc profile (every tooth) and the pins: DXF, SVG, CSV.

    Writes <case>/profile.dxf (polyline and splines, mm), profile.svg, profile.csv (points
    with outward unit normals) and export.json. Datum: disc centre, tooth space 1 on +x.
    """
    from cyclomesh.output.export import export_study, parse_formats
    from cyclomesh.studyfile import load_study

    formats = parse_formats(format)
    if not (math.isfinite(chord_tolerance_um) and chord_tolerance_um >= 0.001):
        raise StudyError(
            f"--chord-tolerance-um: expected a number of at least 0.001, got {chord_tolerance_um}"
        )
    loaded = load_study(study)
    with _folder(out, "export"):  # locked; summary.json (files, sizes) written last
        written = export_study(loaded, out, formats, chord_tolerance_um * 1e-6)
    if not quiet:
        for name, files in written.items():
            import json

            meta = json.loads(files["json"].read_text())
            typer.echo(
                f"{name}: {meta['vertices']} points, tip radius {meta['tip_radius_mm']:.4f} mm, "
                f"root radius {meta['root_radius_mm']:.4f} mm, chord tolerance "
                f"{chord_tolerance_um:g} µm"
            )
            typer.echo("  " + ", ".join(str(p) for p in files.values()))


@app.command()
@cli_errors()
@_without_dask
def stiffness(
    study: StudyArg,
    out: OutOption,
    quiet: QuietOption = False,
    crank_step_deg: StepOption = None,
    figures: FiguresOption = None,
    cache_dir: CacheDirOption = None,
    no_work_limit: NoLimitOption = False,
) -> None:
    """Torsion curve of every case ([stiffness] section): play, lost motion, rigidity.

    Writes <case>/stiffness.nc, summary.json, the figures and report.html. The numbers
    are those of the cycloid-pin mesh alone (see docs/drive.md).
    """
    _cache_dir(cache_dir)
    from cyclomesh.publish.pipeline import publish, study_stamp
    from cyclomesh.studies import stiffness as kind
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded = load_study(study, _overrides(crank_step_deg))
    kind.check_stiffness(loaded)
    check_study_work(loaded, "stiffness", allow=no_work_limit)
    options = output_options(loaded, figures)
    with _folder(out, "stiffness"), _figure_pool(options) as pool:
        with progress_bar(len(loaded.cases), "cases", quiet, unit="cases") as advance:
            result = kind.compute_stiffness(loaded, progress=advance)
        files = kind.write_stiffness(result, out)
        jobs = kind.stiffness_figures(result) if options.figures else []
        publish(
            out,
            f"{loaded.title}: torsion curve",
            kind.stiffness_sections(result),
            jobs,
            files,
            options,
            study_stamp(loaded),
            pool=pool,
        )
    if not quiet:
        _print_warnings(result.study_warnings())
        _print_stiffness(result.summaries, out, result.checks)


_STIFFNESS_ROWS = (
    ("rated_torque_nm", "rated torque [N·m]", 1.0),
    ("play_arcmin_max", "max play [arcmin]", 1.0),
    ("lost_motion_arcmin_mean", "lost motion [arcmin]", 1.0),
    ("lost_motion_arcmin_max", "max lost motion [arcmin]", 1.0),
    ("torsional_rigidity_nm_per_arcmin_mean", "rigidity [N·m/arcmin]", 1.0),
    ("torsional_rigidity_nm_per_arcmin_min", "min rigidity [N·m/arcmin]", 1.0),
    ("drive_lost_motion_arcmin_max", "drive lost motion [arcmin]", 1.0),
    ("drive_torsional_rigidity_nm_per_arcmin_min", "drive rigidity [N·m/arcmin]", 1.0),
    ("stage_lost_motion_arcmin_max", "stage lost motion [arcmin]", 1.0),
    ("stage_torsional_rigidity_nm_per_arcmin_min", "stage rigidity [N·m/arcmin]", 1.0),
    ("stage_l10_h_min", "bearing L10h [h]", 1.0),
)


def _print_stiffness(summaries: dict, out: Path, checks: dict | None = None) -> None:
    from rich.console import Console

    from cyclomesh.publish.console import print_checks, print_metrics

    console = Console(highlight=False)
    print_metrics(console, summaries, _STIFFNESS_ROWS)
    if checks:
        print_checks(console, checks)
    console.print(
        "the mesh alone: crank bearings, crankshafts and the first stage are not included"
    )
    if any("stage_lost_motion_arcmin_max" in record for record in summaries.values()):
        console.print("stage: the RV stage of [stage] (mesh + crank bearings), beside the mesh")
    console.print(f"report: {out / 'report.html'}")


def _check_workers(workers: int | None) -> None:
    """Refuse ``--workers`` above 4 per usable CPU (each worker holds its own memory)."""
    import os

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    most = 4 * max(1, cpus or 1)
    if workers is not None and workers > most:
        raise StudyError(f"--workers {workers}: at most {most} (4 per usable CPU, {cpus} here)")


def _folder(out: Path, command: str) -> Any:
    """The output folder of a command, locked while it runs, its ``summary.json``
    (the completion marker) removed now and written last
    (:class:`~cyclomesh.output.folder.ResultFolder`)."""
    from cyclomesh.output.folder import ResultFolder

    return ResultFolder(out, command)


def _figure_pool(options: Any) -> Any:
    """Figure workers, started before any progress thread (none without figures)."""
    from contextlib import nullcontext

    if not options.figures:
        return nullcontext(None)
    import gc

    import xarray  # noqa: F401  (needed here anyway: inherited by the forked workers)

    from cyclomesh.figures.render import FigurePool

    gc.freeze()  # the workers' collections then leave the inherited objects (and pages) alone
    return FigurePool(options.figure_workers)


def _preload(figures: bool) -> Any:
    """Import xarray (and matplotlib) in a thread while the workers compute.

    Started after the worker processes are forked; joined before anything else forks,
    so the figure workers inherit the imported modules.
    """
    import threading

    def work() -> None:
        import numpy as np
        import xarray as xr

        xr.DataArray(np.zeros(1))  # the first array sets up xarray's array backends
        if figures:
            from cyclomesh.figures.render import warm_up

            warm_up(draw=True)  # the figure workers forked later inherit it
        import gc

        gc.freeze()  # nor do their collections scan what they inherit

    thread = threading.Thread(target=work, name="cyclomesh-preload", daemon=True)
    thread.start()
    return thread


@contextmanager
def _workers(
    scheduler: str | None, workers: int | None, figures: bool, parallel: bool = True
) -> Iterator[Any]:
    """The execution backend (local processes or Dask; None unless ``parallel``), started,
    with the import preload thread; closed on exit, the preload joined after success."""
    from cyclomesh.execution.backends import make_backend

    backend = make_backend(scheduler, workers) if parallel else None
    try:
        if backend is not None:
            backend.start()
        preload = _preload(figures)
        yield backend
    finally:
        if backend is not None:
            backend.close()
    preload.join()


@app.command()
@cli_errors()
@_without_dask
def tolerance(
    study: Annotated[
        Path,
        typer.Argument(help="Study file (TOML) with a [tolerance] section.", metavar="STUDY.toml"),
    ],
    out: OutOption,
    rings: RingsOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    workers: WorkersOption = None,
    chunk_rings: ChunkOption = None,
    figures: FiguresOption = None,
    cache_dir: CacheDirOption = None,
    no_work_limit: NoLimitOption = False,
) -> None:
    """Monte Carlo tolerance study: per-ring metrics, statistics, worst ring, report."""
    _cache_dir(cache_dir)
    from cyclomesh.studies import tolerance as kind
    from cyclomesh.studyfile.limits import check_study_work

    loaded, spec = kind.load_tolerance_study(study)
    check_study_work(loaded, "tolerance", rings=rings, allow=no_work_limit)
    _check_workers(workers)
    options = output_options(loaded, figures)
    n = spec.rings if rings is None else rings
    with _folder(out, "tolerance"):
        with _workers(scheduler, workers, bool(options.figures)) as backend:
            _say(
                f"tolerance study: {n} rings, "
                f"{len(spec.crank_angles_deg(loaded.base.analysis))} crank angles, "
                f"{backend.workers} worker(s)",
                quiet,
            )
            with progress_bar(n, "rings", quiet) as advance:
                result = kind.compute_tolerance(
                    loaded, rings=rings, backend=backend, chunk_rings=chunk_rings, progress=advance
                )
        kind.publish_tolerance(result, out, options)
    if not quiet:
        _print_tolerance(result.summary, out)


@app.command()
@cli_errors()
@_without_dask
def allocate(
    study: Annotated[
        Path,
        typer.Argument(help="Study file (TOML) with a [tolerance] section.", metavar="STUDY.toml"),
    ],
    out: OutOption,
    target_probability: Annotated[
        float | None,
        typer.Option(
            "--target-probability",
            help="Acceptable probability of exceeding the allowable contact stress "
            "(default: tolerance.allocation.target_probability, 0.01).",
            show_default=False,
        ),
    ] = None,
    rings: RingsOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    workers: WorkersOption = None,
    chunk_rings: ChunkOption = None,
    figures: FiguresOption = None,
    cache_dir: CacheDirOption = None,
    no_work_limit: NoLimitOption = False,
) -> None:
    """Largest scale factor on the tolerances that meets the target exceedance probability."""
    _cache_dir(cache_dir)
    from cyclomesh.studies import tolerance as kind
    from cyclomesh.studyfile.limits import check_study_work

    loaded, spec = kind.load_tolerance_study(study)
    check_study_work(loaded, "allocate", rings=rings, allow=no_work_limit)
    _check_workers(workers)
    options = output_options(loaded, figures)
    n = spec.rings if rings is None else rings
    alloc = spec.allocation
    with _folder(out, "allocate"):
        with _workers(scheduler, workers, bool(options.figures)) as backend:
            _say(
                f"tolerance allocation: {n} rings, scale factors up to {alloc.factor_max:g} in "
                f"{alloc.factor_steps} steps + {alloc.bisections} bisections, "
                f"{backend.workers} worker(s)",
                quiet,
            )
            with progress_bar(n, "rings", quiet) as advance:
                result = kind.compute_allocation(
                    loaded,
                    target_probability=target_probability,
                    rings=rings,
                    backend=backend,
                    chunk_rings=chunk_rings,
                    progress=advance,
                )
        kind.publish_allocation(result, out, options)
    if not quiet:
        typer.echo(result.allocation.statement())
        _print_warnings(result.record.get("warnings", []))
        typer.echo(f"files: {out}")


def _print_tolerance(stats: dict[str, Any], out: Path) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from cyclomesh.results.metrics import METRICS

    table = Table(title=f"{stats['rings']} rings (seed {stats['seed']})")
    for col in ("metric", "mean", "std", "P5", "P50", "P95", "P99"):
        table.add_column(col, justify="left" if col == "metric" else "right")
    for name, s in stats["metrics"].items():
        m = METRICS.get(name)
        label = name if m is None else m.label + ("" if m.unit == "1" else f" [{m.unit}]")
        table.add_row(
            escape(label),
            f"{s['mean']:.4g}",
            f"{s['std']:.3g}",
            *(f"{q['estimate']:.4g}" for q in s["percentiles"]),
        )
    console = Console(highlight=False)
    console.print(table)
    if stats.get("checks"):
        from cyclomesh.publish.console import print_checks

        print_checks(console, {"tolerance": stats["checks"]})
    ex = stats["exceedance"]["max_contact_stress_mpa"]
    conf = stats["confidence"]
    console.print(
        f"P(max_contact_stress_mpa > {stats['allowable_contact_stress_mpa']:g}) = "
        f"{ex['probability']:.4g}, {conf:.0%} Clopper-Pearson [{ex['lower']:.4g}, "
        f"{ex['upper']:.4g}] ({ex['count']} of {ex['rings']} rings)"
    )
    _print_warnings(stats.get("warnings", []))
    worst = stats["worst_ring"]
    console.print(
        f"worst ring {worst['ring']}: {worst['max_contact_stress_mpa']:.5g} MPa -> "
        f"{out / 'worst_ring.toml'}"
    )
    console.print(
        f"percentile intervals: {out / 'tolerance_summary.json'}; "
        f"report: {out / 'report.html'} ({stats['rings_per_second']:.1f} rings/s)"
    )


@app.command()
@cli_errors()
@_without_dask
def design(
    study: Annotated[
        Path,
        typer.Argument(
            help="Study file (TOML) with a [design_space] section.", metavar="STUDY.toml"
        ),
    ],
    out: OutOption,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    workers: WorkersOption = None,
    figures: FiguresOption = None,
    cache_dir: CacheDirOption = None,
    no_work_limit: NoLimitOption = False,
) -> None:
    """Design map: sweep the modification, map the metrics, mark the optimum.

    A nominal map runs in this process unless --workers or --scheduler is given; a
    robust map (design_space.rings > 0) runs on all local cores by default.
    """
    _cache_dir(cache_dir)
    from cyclomesh.publish.pipeline import publish
    from cyclomesh.studies import designmap as kind
    from cyclomesh.studyfile.limits import check_study_work

    loaded, space = kind.load_design_study(study)
    check_study_work(loaded, "design", allow=no_work_limit)
    _check_workers(workers)
    options = output_options(loaded, figures)
    n = math.prod(len(v) for v in space.axes().values())
    parallel = scheduler is not None or workers not in (None, 1) or (space.rings and workers != 1)
    with _folder(out, "design"):
        with _workers(scheduler, workers, bool(options.figures), parallel) as backend:
            _say(
                f"design map: {n} candidates"
                + (f" x {space.rings} rings" if space.rings else "")
                + f", {backend.workers if backend else 1} worker(s)",
                quiet,
            )
            with progress_bar(n, "candidates", quiet) as advance:
                result = kind.compute_design(
                    loaded, backend=backend, chunk=1 if backend else None, progress=advance
                )
        files = kind.write_design(result, out)
        publish(
            out,
            f"{loaded.title}: design map",
            kind.design_sections(result),
            kind.design_figures(result) if options.figures else [],
            files,
            options,
            {"SHA-256 of the study file": loaded.sha256},
        )
    if not quiet:
        s = result.summary
        typer.echo(
            f"{s['candidates']} candidates, {s['feasible_candidates']} feasible, "
            f"{s['failed_candidates']} failed ({result.seconds:.1f} s)"
        )
        if s["optimum"] is None:
            typer.echo("no feasible candidate: relax the constraints or widen the ranges")
        else:
            where = ", ".join(f"{k} = {v:g}" for k, v in s["optimum"]["parameters"].items())
            value = s["optimum"]["metrics"][s["objective_variable"]]
            typer.echo(f"optimum: {where} ({s['objective_variable']} = {value:.6g})")
            if s.get("checks"):
                from rich.console import Console

                from cyclomesh.publish.console import print_checks

                print_checks(Console(highlight=False), {"optimum": s["checks"]})
        _print_warnings(s.get("warnings", []))
        typer.echo(f"report: {out / 'report.html'}")


@app.command()
@cli_errors()
def fe(
    study: StudyArg,
    out: OutOption,
    crank_angles: Annotated[
        str | None,
        typer.Option(
            "--crank-angles",
            help="Comma-separated crank angles [deg] (default: [fe] crank_angles_deg).",
        ),
    ] = None,
    convergence: Annotated[
        bool, typer.Option(help="Also solve the first angle at half the contact mesh density.")
    ] = True,
    quiet: QuietOption = False,
    figures: FiguresOption = None,
    cache_dir: CacheDirOption = None,
) -> None:
    """Whole-disc finite-element model beside the LTCA, per case (needs the fe extra).

    Writes <case>/fe.nc, <case>/convergence.csv, summary.json, the figures and
    report.html (docs/contact-law.md). The LTCA runs under the study's [analysis]
    settings (contact_law, disc_body).
    """
    _cache_dir(cache_dir)
    try:
        import gmsh  # noqa: F401
        import skfem  # noqa: F401
    except (ImportError, OSError) as exc:  # gmsh's wheel also needs X11/OpenGL libraries
        raise StudyError(
            f"cyclomesh fe needs the fe extra: pip install -e '.[fe]' ({exc})".replace("\n", " ")
        ) from None
    from cyclomesh.publish.pipeline import publish, study_stamp
    from cyclomesh.studies import fe as kind
    from cyclomesh.studyfile import load_study

    angles = None
    if crank_angles:
        from cyclomesh.studyfile.limits import MAX_ABS_CRANK_DEG

        try:
            angles = [float(a) for a in crank_angles.split(",")]
        except ValueError:
            raise StudyError(
                f"--crank-angles: expected numbers separated by commas, got {crank_angles!r}"
            ) from None
        if not 1 <= len(angles) <= 24 or not all(abs(a) <= MAX_ABS_CRANK_DEG for a in angles):
            raise StudyError(
                f"--crank-angles: expected 1 to 24 angles within ±{MAX_ABS_CRANK_DEG:g} deg, "
                f"got {crank_angles!r}"
            )
    loaded = load_study(study)
    kind.check_fe(loaded)
    options = output_options(loaded, figures)
    console = stderr_console(quiet)
    with _folder(out, "fe"):
        result = kind.compute_fe(
            loaded, crank_angles_deg=angles, convergence=convergence, progress=console.print
        )
        files = kind.write_fe(result, out)
        publish(
            out,
            f"{loaded.title}: FE check",
            kind.fe_sections(result),
            kind.fe_figures(result) if options.figures else [],
            files,
            options,
            study_stamp(loaded),
        )
    if not quiet:
        _print_fe(result.summaries, out, result.checks)


def _print_fe(summaries: dict, out: Path, checks: dict | None = None) -> None:
    from rich.console import Console

    from cyclomesh.publish.console import print_checks, print_metrics
    from cyclomesh.results.metrics import FE_METRICS

    rows = [
        (key, m.label + ("" if m.unit == "1" else f" [{m.unit}]"), 1.0)
        for key, m in FE_METRICS.items()
    ]
    console = Console(highlight=False)
    print_metrics(console, summaries, rows)
    if checks:
        print_checks(console, checks)
    console.print(f"report: {out / 'report.html'}")
