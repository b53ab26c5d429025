"""The ``cyclomesh`` command: options in, one :func:`~cyclomesh.studies.execute.execute`
per kind of study, tables out.

``cyclomesh run STUDY.toml --out DIR`` runs the cases of a study file, ``stiffness`` the
torsion curve of every case, ``tolerance`` and ``allocate`` its ``[tolerance]`` section,
``design`` its ``[design_space]``, ``fe`` the finite-element check, ``export`` writes the
disc profile for manufacturing, ``explore`` serves the explorer in the browser
(``docs/explore.md``) and ``check`` validates every section without running
anything (``docs/study-files.md``, ``docs/pipeline.md``). Every refused input comes out
as ``error: <one line>`` on stderr with exit status 2 (:mod:`cyclomesh.cli.errors`);
options and the progress display are in :mod:`cyclomesh.cli.options`, the tables in
:mod:`cyclomesh.publish.console`. Heavy modules are imported inside the commands, so
``--help`` is fast.
"""

from __future__ import annotations

import math
from typing import Annotated

import typer

from cyclomesh.cli.errors import EXIT_INPUT_ERROR, OneLineUsage, cli_errors, fail
from cyclomesh.cli.options import (
    CacheDirOption,
    ChordOption,
    ChunkOption,
    ConvergenceOption,
    CrankAnglesOption,
    CsvOption,
    DesignStudyArg,
    FiguresOption,
    FormatOption,
    KindOption,
    NoLimitOption,
    OutOption,
    QuietOption,
    RingsOption,
    SchedulerOption,
    StepOption,
    StudyArg,
    TargetOption,
    TolStudyArg,
    WorkersOption,
    bar,
    crank_angles_from,
    output_options,
    overrides,
    progress_bar,
    require_fe_extra,
    run_backend,
    say,
    show_version,
    stderr_console,
    use_cache_dir,
)
from cyclomesh.exceptions import StudyError
from cyclomesh.explore.options import NoBrowserOption, PortOption
from cyclomesh.studies.preflight import preflight

__all__ = [
    "app",
    "cli_errors",
    "fail",
    "stderr_console",
    "progress_bar",
    "output_options",
    "EXIT_INPUT_ERROR",
]

app = typer.Typer(
    name="cyclomesh",
    cls=OneLineUsage,
    help="Loaded tooth contact analysis of cycloid-pin gear pairs (RV reducers).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_show_locals=False,
    rich_markup_mode=None,  # keep "[deg]" and "[tolerance]" in help texts as typed
)


@app.callback()
def main(
    version: Annotated[
        bool,
        typer.Option("--version", callback=show_version, is_eager=True, help="Show the version."),
    ] = False,
) -> None:
    """Loaded tooth contact analysis of cycloid-pin gear pairs (Li et al., Machines 2022)."""
    from cyclomesh.execution.runtime import tune_allocator

    tune_allocator()


@app.command()
@cli_errors()
def check(
    study: StudyArg,
    crank_step_deg: StepOption = None,
    no_work_limit: NoLimitOption = False,
    kind: KindOption = None,
) -> None:
    """Validate a study file (every section) without running it, and refuse what the
    commands would refuse before computing: with --kind that command's refusals, else
    those of every command the file is written for (run, and stiffness, tolerance,
    allocate, design or fe when it has their section)."""
    from cyclomesh.studies.preflight import check_kinds
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded = load_study(study, overrides(crank_step_deg))
    check_study_work(loaded, "check", allow=no_work_limit)
    if any(case.analysis.disc_body == "fe" for case in loaded.cases):
        from cyclomesh.results.dataset import FE_EXTRA_MESSAGE, fe_extra_available

        if not fe_extra_available():
            raise StudyError(f"{study}: [analysis] {FE_EXTRA_MESSAGE}")
    kinds = check_kinds(loaded, kind, allow_work=no_work_limit)
    names = ", ".join(case.name for case in loaded.cases)
    more = "; [tolerance] OK" if loaded.tolerance is not None else ""
    if any(case.stiffness is not None for case in loaded.cases):
        more += "; [stiffness] OK"
    if loaded.file.design_space is not None:
        more += "; [design_space] OK"
    if loaded.file.fe is not None:
        more += "; [fe] OK"
    if any(inputs.friction is not None for inputs in loaded.inputs):
        more += "; [friction] OK"
    if loaded.file.efficiency is not None:
        more += "; [efficiency] OK"
    if loaded.file.requirements != type(loaded.file.requirements)():
        more += "; [requirements] OK"
    typer.echo(f"{study}: {len(loaded.cases)} case(s) OK: {names}{more}; for {', '.join(kinds)}")


@app.command()
@cli_errors()
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
    use_cache_dir(cache_dir)
    from cyclomesh.publish.console import print_run
    from cyclomesh.studies import run as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded = load_study(study, overrides(crank_step_deg))
    check_study_work(loaded, "run", allow=no_work_limit)
    preflight(loaded, "run", work=False)  # what check --kind run refuses
    options = output_options(loaded, figures, csv)
    progress = bar(len(loaded.cases), "cases", quiet)
    result = execute(kind.RUN, loaded, out, options, progress=progress)
    if not quiet:
        print_run(result.summaries, out, result.checks, result.study_warnings())


@app.command()
@cli_errors()
def export(
    study: StudyArg,
    out: OutOption,
    format: FormatOption = "dxf,svg,csv",
    chord_tolerance_um: ChordOption = 0.1,
    quiet: QuietOption = False,
) -> None:
    """Export the whole modified disc profile (every tooth) and the pins: DXF, SVG, CSV.

    Writes <case>/profile.dxf (polyline and splines, mm), profile.svg, profile.csv (points
    with outward unit normals) and export.json. Datum: disc centre, tooth space 1 on +x.
    """
    from cyclomesh.output.export import parse_formats
    from cyclomesh.publish.pipeline import OutputOptions
    from cyclomesh.studies.execute import execute
    from cyclomesh.studies.export import EXPORT
    from cyclomesh.studyfile import load_study

    formats = parse_formats(format)
    if not (math.isfinite(chord_tolerance_um) and chord_tolerance_um >= 0.001):
        raise StudyError(
            f"--chord-tolerance-um: expected a number of at least 0.001, got {chord_tolerance_um}"
        )
    loaded = load_study(study)
    preflight(loaded, "export", work=False)  # what check --kind export refuses
    result = execute(
        EXPORT,
        loaded,
        out,
        OutputOptions(figures=()),
        formats=formats,
        chord_tolerance=chord_tolerance_um * 1e-6,
    )
    if not quiet:
        from pathlib import Path

        from cyclomesh.publish.console import print_export

        # the kind records the files relative to its (staged) folder: here in ``out``
        written = {
            case: {key: Path(out) / rel for key, rel in files.items()}
            for case, files in result.written.items()
        }
        print_export(written, chord_tolerance_um, result.same)


@app.command()
@cli_errors()
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
    are those of the cycloid-pin mesh alone (docs/drive.md); with [stage], also those
    of the RV stage (mesh + crank bearings, docs/stage.md), which the requirements
    check. The whole reducer is softer than both.
    """
    use_cache_dir(cache_dir)
    from cyclomesh.publish.console import print_stiffness, print_warnings
    from cyclomesh.studies import stiffness as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded = load_study(study, overrides(crank_step_deg))
    check_study_work(loaded, "stiffness", allow=no_work_limit)
    preflight(loaded, "stiffness", work=False)  # what check --kind stiffness refuses
    options = output_options(loaded, figures)
    progress = bar(len(loaded.cases), "cases", quiet)
    result = execute(kind.STIFFNESS, loaded, out, options, progress=progress)
    if not quiet:
        print_warnings(result.study_warnings())
        print_stiffness(result.summaries, out, result.checks)


@app.command()
@cli_errors()
def efficiency(
    study: StudyArg,
    out: OutOption,
    quiet: QuietOption = False,
    crank_step_deg: StepOption = None,
    figures: FiguresOption = None,
) -> None:
    """Efficiency map of every case ([efficiency] and [friction]): forward and back-driving
    efficiency over torque × input speed, the loss breakdown at the rated point."""
    from cyclomesh.publish.console import print_efficiency
    from cyclomesh.studies import efficiency as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studyfile import load_study

    loaded = load_study(study, overrides(crank_step_deg))
    kind.check_efficiency(loaded)
    options = output_options(loaded, figures)
    progress = bar(len(loaded.cases), "cases", quiet)
    result = execute(kind.EFFICIENCY, loaded, out, options, progress=progress)
    if not quiet:
        print_efficiency(result.summaries, out, result.checks)


@app.command()
@cli_errors()
def tolerance(
    study: TolStudyArg,
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
    use_cache_dir(cache_dir)
    from cyclomesh.publish.console import print_tolerance
    from cyclomesh.studies import tolerance as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studyfile.limits import check_study_work

    loaded, spec = kind.load_tolerance_study(study)
    check_study_work(loaded, "tolerance", rings=rings, allow=no_work_limit)
    preflight(loaded, "tolerance", work=False)  # what check --kind tolerance refuses
    backend = run_backend(scheduler, workers)
    options = output_options(loaded, figures)
    n = spec.rings if rings is None else rings
    angles = len(spec.crank_angles_deg(loaded.base.analysis))
    say(f"tolerance study: {n} rings, {angles} crank angles, {backend.workers} worker(s)", quiet)
    result = execute(
        kind.TOLERANCE,
        loaded,
        out,
        options,
        backend=backend,
        parallel=True,
        progress=bar(n, "rings", quiet),
        rings=rings,
        chunk_rings=chunk_rings,
    )
    if not quiet:
        print_tolerance(result.summary, out)


@app.command()
@cli_errors()
def allocate(
    study: TolStudyArg,
    out: OutOption,
    target_probability: TargetOption = None,
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
    use_cache_dir(cache_dir)
    from cyclomesh.publish.console import print_allocation
    from cyclomesh.studies import allocate as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studies.rings import load_tolerance_study
    from cyclomesh.studyfile.limits import check_study_work

    loaded, spec = load_tolerance_study(study)
    check_study_work(loaded, "allocate", rings=rings, allow=no_work_limit)
    preflight(loaded, "allocate", work=False)  # what check --kind allocate refuses
    if target_probability is not None and not 0.0 < target_probability < 1.0:
        raise StudyError(f"--target-probability must lie in (0, 1), got {target_probability:g}")
    backend = run_backend(scheduler, workers)
    options = output_options(loaded, figures)
    n = spec.rings if rings is None else rings
    alloc = spec.allocation
    say(
        f"tolerance allocation: {n} rings, scale factors up to {alloc.factor_max:g} in "
        f"{alloc.factor_steps} steps + {alloc.bisections} bisections, "
        f"{backend.workers} worker(s)",
        quiet,
    )
    result = execute(
        kind.ALLOCATE,
        loaded,
        out,
        options,
        backend=backend,
        parallel=True,
        progress=bar(n, "rings", quiet),
        target_probability=target_probability,
        rings=rings,
        chunk_rings=chunk_rings,
    )
    if not quiet:
        print_allocation(result.allocation.statement(), result.record.get("warnings", []), out)


@app.command()
@cli_errors()
def design(
    study: DesignStudyArg,
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
    use_cache_dir(cache_dir)
    from cyclomesh.publish.console import print_design
    from cyclomesh.studies import designmap as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studyfile.limits import check_study_work

    loaded, space = kind.load_design_study(study)
    check_study_work(loaded, "design", allow=no_work_limit)
    preflight(loaded, "design", work=False)  # what check --kind design refuses
    parallel = scheduler is not None or workers not in (None, 1) or (space.rings and workers != 1)
    backend = run_backend(scheduler, workers, bool(parallel))
    options = output_options(loaded, figures)
    n = math.prod(len(v) for v in space.axes().values())
    say(
        f"design map: {n} candidates"
        + (f" x {space.rings} rings" if space.rings else "")
        + f", {backend.workers if backend else 1} worker(s)",
        quiet,
    )
    result = execute(
        kind.DESIGN,
        loaded,
        out,
        options,
        backend=backend,
        parallel=True,
        progress=bar(n, "candidates", quiet),
        chunk=1 if backend else None,
    )
    if not quiet:
        print_design(result.summary, result.seconds, out)


@app.command()
@cli_errors()
def fe(
    study: StudyArg,
    out: OutOption,
    crank_angles: CrankAnglesOption = None,
    convergence: ConvergenceOption = True,
    quiet: QuietOption = False,
    figures: FiguresOption = None,
    cache_dir: CacheDirOption = None,
) -> None:
    """Whole-disc finite-element model beside the LTCA, per case (needs the fe extra).

    Writes <case>/fe.nc, <case>/convergence.csv, summary.json, the figures and
    report.html (docs/contact-law.md). The LTCA runs under the study's [analysis]
    settings (contact_law, disc_body).
    """
    use_cache_dir(cache_dir)
    require_fe_extra()
    from cyclomesh.publish.console import print_fe
    from cyclomesh.studies import fe as kind
    from cyclomesh.studies.execute import execute
    from cyclomesh.studyfile import load_study

    angles = crank_angles_from(crank_angles)
    loaded = load_study(study)
    preflight(loaded, "fe", work=False)  # what check --kind fe refuses
    options = output_options(loaded, figures)
    log = stderr_console(quiet).print
    result = execute(
        kind.FE, loaded, out, options, crank_angles_deg=angles, convergence=convergence, log=log
    )
    if not quiet:
        print_fe(result.summaries, out, result.checks)


@app.command()
@cli_errors()
def explore(study: StudyArg, port: PortOption = 8050, no_browser: NoBrowserOption = False) -> None:
    """Explore a study in the browser: change the modification, load or pin errors and see
    loads, stresses and TE at once (needs the explore extra; docs/explore.md)."""
    from cyclomesh.explore.app import serve

    serve(study, port=port, open_browser=not no_browser, echo=typer.echo)
