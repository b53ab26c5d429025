"""``cyclomesh tolerance`` and ``cyclomesh allocate``: Monte Carlo tolerance studies.

Plain functions with Typer annotations; :func:`register` adds them to a Typer app
(``cyclomesh.cli.app``) with the CLI's error handling (any ``CyclomeshError`` ->
``error: <one line>`` on stderr, exit status 2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

__all__ = ["tolerance", "allocate", "register"]

StudyArg = Annotated[
    Path,
    typer.Argument(help="Study file (TOML) with a [tolerance] section.", metavar="STUDY.toml"),
]
OutOption = Annotated[Path, typer.Option("--out", "-o", help="Output folder (created if needed).")]
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
ChunkOption = Annotated[
    int | None,
    typer.Option(
        "--chunk-rings",
        min=1,
        help="Rings per chunk of work (default: 16; best a multiple of 16).",
        show_default=False,
    ),
]
QuietOption = Annotated[
    bool, typer.Option("--quiet", "-q", help="No progress bar and no summary table.")
]


def tolerance(
    study: StudyArg,
    out: OutOption,
    rings: RingsOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    workers: WorkersOption = None,
    chunk_rings: ChunkOption = None,
) -> None:
    """Monte Carlo tolerance study: per-ring metrics, statistics, worst ring, report."""
    from cyclomesh.tolerance.runner import run_tolerance

    result = run_tolerance(
        study,
        out,
        rings=rings,
        scheduler=scheduler,
        workers=workers,
        chunk_rings=chunk_rings,
        quiet=quiet,
    )
    if not quiet:
        _print_tolerance(result.summary, out)


def allocate(
    study: StudyArg,
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
) -> None:
    """Largest scale factor on the tolerances that meets the target exceedance probability."""
    from cyclomesh.tolerance.runner import run_allocation

    result = run_allocation(
        study,
        out,
        target_probability=target_probability,
        rings=rings,
        scheduler=scheduler,
        workers=workers,
        chunk_rings=chunk_rings,
        quiet=quiet,
    )
    if not quiet:
        typer.echo(result.allocation.statement())
        typer.echo(f"files: {out}")


def register(app: typer.Typer) -> None:
    """Add ``tolerance`` and ``allocate`` to ``app`` with the CLI's error handling."""
    from cyclomesh.cli import cli_errors

    app.command("tolerance")(cli_errors()(tolerance))
    app.command("allocate")(cli_errors()(allocate))


def _print_tolerance(stats: dict[str, Any], out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{stats['rings']} rings (seed {stats['seed']})")
    for col in ("metric", "mean", "std", "P5", "P50", "P95", "P99"):
        table.add_column(col, justify="left" if col == "metric" else "right")
    for name, s in stats["metrics"].items():
        table.add_row(
            name,
            f"{s['mean']:.4g}",
            f"{s['std']:.3g}",
            *(f"{q['estimate']:.4g}" for q in s["percentiles"]),
        )
    console = Console(highlight=False)
    console.print(table)
    ex = stats["exceedance"]["max_contact_stress_mpa"]
    conf = stats["confidence"]
    console.print(
        f"P(max_contact_stress_mpa > {stats['allowable_contact_stress_mpa']:g}) = "
        f"{ex['probability']:.4g}, {conf:.0%} Clopper-Pearson [{ex['lower']:.4g}, "
        f"{ex['upper']:.4g}] ({ex['count']} of {ex['rings']} rings)"
    )
    worst = stats["worst_ring"]
    console.print(
        f"worst ring {worst['ring']}: {worst['max_contact_stress_mpa']:.5g} MPa -> "
        f"{out / 'worst_ring.toml'}"
    )
    console.print(
        f"percentile intervals: {out / 'tolerance_summary.json'}; "
        f"report: {out / 'report.html'} ({stats['rings_per_second']:.1f} rings/s)"
    )
