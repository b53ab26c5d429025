"""The ``cyclomesh`` command.

``cyclomesh run STUDY.toml --out DIR`` runs a study file (see ``docs/study-files.md``)
and writes its results, figures and report. Every refused input comes out as
``error: <one line>`` on stderr with exit status 2 and no traceback; commands get that
behaviour from :func:`cli_errors`::

    from cyclomesh.cli import app, cli_errors

    @app.command()
    @cli_errors()
    def tolerance(...): ...
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer
from pydantic import ValidationError

from cyclomesh.exceptions import CyclomeshError

__all__ = ["app", "cli_errors", "fail", "stderr_console", "EXIT_INPUT_ERROR"]

EXIT_INPUT_ERROR = 2
"""Exit status for an input that cyclomesh refuses (as for a usage error)."""

app = typer.Typer(
    name="cyclomesh",
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


@contextmanager
def cli_errors() -> Iterator[None]:
    """Turn refused inputs into ``error: <one line>`` on stderr and exit status 2.

    Catches :class:`~cyclomesh.exceptions.CyclomeshError` (which includes
    ``StudyError``, ``DesignError`` and ``ConvergenceError``), pydantic validation
    errors, TOML syntax errors and operating-system errors (missing file, no
    permission). Use it as a context manager or as a decorator of a command.
    """
    try:
        yield
    except CyclomeshError as exc:
        raise fail(str(exc)) from None
    except ValidationError as exc:
        first = exc.errors(include_url=False)[0]
        key = ".".join(str(part) for part in first["loc"])
        raise fail(f"{key}: {first['msg']}" if key else first["msg"]) from None
    except tomllib.TOMLDecodeError as exc:
        raise fail(f"invalid TOML: {exc}") from None
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        raise fail(f"{where}{exc.strerror or exc}") from None


def stderr_console(quiet: bool = False):
    """A Rich console on stderr for progress (silent when ``quiet``)."""
    from rich.console import Console

    return Console(stderr=True, quiet=quiet)


def _version(value: bool) -> None:
    if value:
        from cyclomesh.report import cyclomesh_version

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


def _overrides(crank_step_deg: float | None) -> dict:
    return {} if crank_step_deg is None else {"analysis": {"crank_step_deg": crank_step_deg}}


StudyArg = Annotated[
    Path, typer.Argument(help="Study file (TOML).", show_default=False, metavar="STUDY.toml")
]
StepOption = Annotated[
    float | None,
    typer.Option(
        "--crank-step-deg",
        help="Override analysis.crank_step_deg of every case [deg] (for a quick look).",
        show_default=False,
    ),
]


@app.command()
@cli_errors()
def check(study: StudyArg, crank_step_deg: StepOption = None) -> None:
    """Validate a study file without running it."""
    from cyclomesh.study import load_study

    loaded = load_study(study, _overrides(crank_step_deg))
    names = ", ".join(case.name for case in loaded.cases)
    typer.echo(f"{study}: {len(loaded.cases)} case(s) OK: {names}")


@app.command()
@cli_errors()
def run(
    study: StudyArg,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (created if needed).")],
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="No progress and no summary table.")
    ] = False,
    crank_step_deg: StepOption = None,
) -> None:
    """Run every case of a study; write results, figures, summary.json and report.html."""
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from cyclomesh.study import load_study
    from cyclomesh.study.runner import compute_study, study_figures, write_study

    loaded = load_study(study, _overrides(crank_step_deg))
    console = stderr_console(quiet)
    progress = Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        BarColumn(),
        TimeElapsedColumn(),
        console=console,
        disable=quiet or not console.is_terminal,
    )
    with progress:
        tasks = {
            case.name: progress.add_task(case.name, total=1, start=False) for case in loaded.cases
        }
        finish = progress.add_task("figures, files, report", total=1, start=False)
        result = compute_study(
            loaded,
            on_start=lambda name: progress.start_task(tasks[name]),
            on_done=lambda name: progress.update(tasks[name], completed=1),
        )
        progress.start_task(finish)
        figs = study_figures(result) if loaded.figures.enabled else {}
        write_study(result, out, figs)
        progress.update(finish, completed=1)
    if not quiet:
        _print_summary(result.summaries, out)


_SUMMARY_COLUMNS = (
    ("te_pp_arcsec", "TE p-p [arcsec]"),
    ("max_pin_load_n", "max pin load [N]"),
    ("max_contact_stress_mpa", "max σH tooth [MPa]"),
    ("max_groove_stress_mpa", "max σH groove [MPa]"),
    ("contacts_min", "min pins in contact"),
    ("contacts_max", "max pins in contact"),
    ("gear_ratio_ripple_pct", "ratio ripple [%]"),
)


def _print_summary(summaries: dict, out: Path) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table("case", *(escape(label) for _, label in _SUMMARY_COLUMNS))
    for name, record in summaries.items():
        cells = [record.get(key) for key, _ in _SUMMARY_COLUMNS]
        table.add_row(escape(name), *("–" if v is None else f"{v:.4g}" for v in cells))
    console = Console()
    console.print(table)
    if any(record.get("overlap") for record in summaries.values()):
        console.print(
            "warning: the disc interferes with unloaded-side pins (see max_overlap_arcsec)"
        )
    console.print(f"report: {out / 'report.html'}")


@app.command()
@cli_errors()
def fe(
    study: Annotated[Path, typer.Argument(help="study file (TOML)")],
    out: Annotated[Path, typer.Option("--out", help="output folder")] = Path("fe-results"),
    crank_angles: Annotated[
        str | None, typer.Option("--crank-angles", help="comma-separated crank angles [deg]")
    ] = None,
    convergence: Annotated[
        bool, typer.Option(help="also solve the first angle at half the contact mesh density")
    ] = True,
) -> None:
    """Whole-disc finite-element model beside the LTCA (needs the fe extra)."""
    try:
        from cyclomesh.fe.study import run_fe_study
    except ImportError as exc:
        raise fail(
            f"cyclomesh fe needs the fe extra: pip install 'cyclomesh[fe]' ({exc})"
        ) from None
    angles = None
    if crank_angles:
        try:
            angles = [float(a) for a in crank_angles.split(",")]
        except ValueError:
            raise fail(
                f"--crank-angles: expected numbers separated by commas, got {crank_angles!r}"
            ) from None
    console = stderr_console()
    for path in run_fe_study(study, out, angles, convergence, progress=console.print):
        console.print(f"written: {path}")


def _add_layer_commands() -> None:
    """Commands of the other layers: ``tolerance`` and ``allocate`` (cyclomesh.tolerance)."""
    from cyclomesh.tolerance.commands import register

    register(app)


_add_layer_commands()
