"""Options shared by the commands of ``cyclomesh``, and the progress display (stderr)."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from cyclomesh.exceptions import StudyError

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
FiguresOption = Annotated[
    str | None,
    typer.Option(
        "--figures",
        help="Figures, comma-separated: formats png, svg, pdf (default: figures.formats "
        "of the study file, png), and 'all' for every figure of a run (default: its one "
        "overview figure); or none.",
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
        help="Rings per chunk of work (default: up to 8 core calls of 16 rings at 1°).",
        show_default=False,
    ),
]


def stderr_console(quiet: bool = False) -> Any:
    """A Rich console on stderr for progress (silent when ``quiet``)."""
    from rich.console import Console

    return Console(stderr=True, quiet=quiet, highlight=False)


@contextmanager
def progress_bar(
    total: int, label: str, quiet: bool, unit: str = "rings"
) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr (none when quiet or not a terminal); yields ``advance(n)``."""
    if quiet:  # nothing shown: Rich not imported
        yield lambda done: None
        return
    console = stderr_console(quiet)
    if not console.is_terminal:
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


def say(message: str, quiet: bool) -> None:
    if not quiet:
        stderr_console().print(message)


def overrides(crank_step_deg: float | None) -> dict:
    return {} if crank_step_deg is None else {"analysis": {"crank_step_deg": crank_step_deg}}


def use_cache_dir(path: Path | None) -> None:
    """Point the disc body's cache at ``path`` for this process and its workers."""
    if path is not None:
        os.environ["CYCLOMESH_CACHE_DIR"] = str(path)


def check_workers(workers: int | None) -> None:
    """Refuse ``--workers`` above 4 per usable CPU (each worker holds its own memory)."""
    from cyclomesh.execution.runtime import usable_cpus

    cpus = usable_cpus()
    most = 4 * cpus
    if workers is not None and workers > most:
        raise StudyError(f"--workers {workers}: at most {most} (4 per usable CPU, {cpus} here)")


def output_options(study: Any, figures: str | None, csv: bool = False) -> Any:
    """The pipeline's :class:`~cyclomesh.publish.pipeline.OutputOptions` from the CLI options."""
    from cyclomesh.publish.pipeline import OutputOptions

    return OutputOptions.from_study(study, figures, csv)


TolStudyArg = Annotated[
    Path,
    typer.Argument(help="Study file (TOML) with a [tolerance] section.", metavar="STUDY.toml"),
]


DesignStudyArg = Annotated[
    Path,
    typer.Argument(help="Study file (TOML) with a [design_space] section.", metavar="STUDY.toml"),
]
TargetOption = Annotated[
    float | None,
    typer.Option(
        "--target-probability",
        help="Acceptable probability of exceeding the allowable contact stress "
        "(default: tolerance.allocation.target_probability, 0.01).",
        show_default=False,
    ),
]
CrankAnglesOption = Annotated[
    str | None,
    typer.Option(
        "--crank-angles",
        help="Comma-separated crank angles [deg] (default: [fe] crank_angles_deg).",
    ),
]
ConvergenceOption = Annotated[
    bool, typer.Option(help="Also solve the first angle at half the contact mesh density.")
]
FormatOption = Annotated[str, typer.Option("--format", help="Comma-separated: dxf, svg, csv.")]
ChordOption = Annotated[
    float,
    typer.Option(
        "--chord-tolerance-um",
        help="Largest distance between the exported polyline and the exact profile [µm].",
    ),
]


def bar(total: int, label: str, quiet: bool) -> Callable[[], Any]:
    """A progress bar to be started later (by :func:`cyclomesh.studies.execute.execute`)."""
    return lambda: progress_bar(total, label, quiet)


KindOption = Annotated[
    str | None,
    typer.Option(
        "--kind",
        help="Check for this command only: run, stiffness, tolerance, allocate, design, "
        "fe, efficiency or export (default: every command the file is written for).",
    ),
]


def run_backend(scheduler: str | None, workers: int | None, parallel: bool = True) -> Any:
    """The execution backend of ``--scheduler``/``--workers`` (None unless ``parallel``)."""
    from cyclomesh.execution.backends import make_backend

    check_workers(workers)
    if not parallel:
        return None
    if scheduler is not None:
        from cyclomesh.cli.errors import quiet_logs

        quiet_logs()
    return make_backend(scheduler, workers)


def show_version(value: bool) -> None:
    if value:
        from cyclomesh.execution.runtime import version

        typer.echo(f"cyclomesh {version()}")
        raise typer.Exit()


OPTIONS: dict[str, tuple[Any, Any]] = {
    "quiet": (QuietOption, False),
    "crank_step_deg": (StepOption, None),
    "figures": (FiguresOption, None),
    "csv": (CsvOption, False),
    "cache_dir": (CacheDirOption, None),
    "no_work_limit": (NoLimitOption, False),
    "rings": (RingsOption, None),
    "scheduler": (SchedulerOption, None),
    "workers": (WorkersOption, None),
    "chunk_rings": (ChunkOption, None),
    "target_probability": (TargetOption, None),
    "crank_angles": (CrankAnglesOption, None),
    "convergence": (ConvergenceOption, True),
    "format": (FormatOption, "dxf,svg,csv"),
    "chord_tolerance_um": (ChordOption, 0.1),
}
"""Every option a kind of study's command may take (``KindSpec.options``): its type
(with the flag and help) and default."""

ARGUMENTS = {"study": StudyArg, "tolerance": TolStudyArg, "design_space": DesignStudyArg}
"""The ``STUDY.toml`` argument of a command by the section the file must have."""
