"""Tables the ``cyclomesh`` command prints: they fit an 80-column terminal.

A study of one case is a vertical key/value table; several cases are a table with one
row per metric and one column per case, in blocks of at most :data:`CASES_PER_TABLE`
cases. Headers are the metrics' short labels with their units. The verdict table
(requirements and design warnings) is one table per case: check, limit, value, margin,
verdict.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cyclomesh.quantities import QUANTITIES

__all__ = [
    "CASES_PER_TABLE",
    "cell",
    "print_metrics",
    "print_checks",
    "print_warnings",
    "print_run",
    "print_stiffness",
    "print_tolerance",
    "unsolved_text",
    "print_allocation",
    "print_design",
    "print_fe",
    "print_export",
    "RUN_ROWS",
    "row",
    "STIFFNESS_ROWS",
]


CASES_PER_TABLE = 4
"""Cases side by side in one table (4 × 13 columns + labels fit 80 columns)."""


def row(name: str, unit: str | None = None, factor: float = 1.0) -> tuple[str, str, float]:
    """A table row of the metric ``name``: its label and unit from the quantity registry
    (:mod:`cyclomesh.quantities`), or ``unit`` with the ``factor`` to it."""
    q = QUANTITIES[name]
    unit = q.unit if unit is None else unit
    return name, q.label if unit == "1" else f"{q.label} [{unit}]", factor


RUN_ROWS: tuple[tuple[str, str, float], ...] = (
    row("te_pp_arcsec"),
    row("te_mean_arcsec"),
    row("max_pin_load_n"),
    row("max_contact_stress_mpa"),
    row("max_groove_stress_mpa"),
    row("contacts"),
    row("gear_ratio_ripple_pct"),
    row("play_arcsec_max", "arcmin", 1.0 / 60.0),
    row("max_mesh_force_n"),
    row("stage_lost_motion_arcmin_max"),
    row("stage_torsional_rigidity_nm_per_arcmin_min"),
    row("stage_max_crank_bearing_load_n"),
    row("stage_l10_h_min"),
    row("efficiency", "%", 100.0),
    row("backdrive_efficiency", "%", 100.0),
)
"""Rows of the run summary: metric key, short label with unit, factor to that unit."""


def cell(value: Any, factor: float = 1.0) -> str:
    """A number with 4 significant digits ("–" for none; a list per torque joined by /)."""
    if isinstance(value, list):
        return " / ".join(cell(v, factor) for v in value)
    if value is None:
        return "–"
    if isinstance(value, int):
        return str(value)
    return f"{value * factor:.4g}"


def _value(record: dict[str, Any], key: str, factor: float) -> str:
    if key == "contacts":  # fewest–most pins in contact
        low, high = record.get("min_contacts"), record.get("max_contacts")
        if isinstance(low, list):
            return " / ".join(f"{a}–{b}" for a, b in zip(low, high, strict=True))
        return "–" if low is None else f"{low}–{high}"
    return cell(record.get(key), factor)


def print_metrics(
    console: Any,
    records: dict[str, dict[str, Any]],
    rows: Sequence[tuple[str, str, float]],
    title: str | None = None,
) -> None:
    """Print ``rows`` of the records: key/value for one case, metric × case for several.

    Rows whose metric no case has are left out.
    """
    from rich.markup import escape
    from rich.table import Table

    rows = [r for r in rows if any(_has(rec, r[0]) for rec in records.values())]
    names = list(records)
    for start in range(0, len(names), CASES_PER_TABLE):
        block = names[start : start + CASES_PER_TABLE]
        if len(names) == 1:
            table = Table("metric", "value", title=title or escape(block[0]))
        else:
            table = Table("metric", *(escape(n) for n in block), title=title)
        for key, label, factor in rows:
            table.add_row(escape(label), *(_value(records[n], key, factor) for n in block))
        for column in table.columns[1:]:
            column.justify = "right"
            column.overflow = "fold"
        console.print(table)


def _has(record: dict[str, Any], key: str) -> bool:
    if key == "contacts":
        return record.get("min_contacts") is not None
    return record.get(key) is not None


def print_checks(console: Any, checks: dict[str, dict[str, Any]]) -> None:
    """Print the verdict table: check, limit, value, margin, verdict for one case; for
    several, one row per check and a "value verdict" column per case (blocks of
    :data:`CASES_PER_TABLE`)."""
    from rich.markup import escape
    from rich.table import Table

    from cyclomesh.results.requirements import VERDICT_MARK, checks_rows

    checks = {name: case for name, case in checks.items() if case["rows"]}
    if not checks:
        return
    style = {"fail": "bold red", "warning": "yellow"}
    if len(checks) == 1:
        name, case = next(iter(checks.items()))
        title = f"verdict: {name}" + (f" ({case['values']})" if case.get("values") else "")
        table = Table("check", "limit", "value", "margin", "verdict", title=escape(title))
        for row, text in zip(case["rows"], checks_rows(case), strict=True):
            table.add_row(*(escape(t) for t in text), style=style.get(row["verdict"]))
        for column in table.columns[1:4]:
            column.justify = "right"
        console.print(table)
    else:
        names = list(checks)
        for start in range(0, len(names), CASES_PER_TABLE):
            block = names[start : start + CASES_PER_TABLE]
            order: dict[str, tuple[str, str]] = {}
            cells: dict[str, dict[str, str]] = {}
            for name in block:
                case = checks[name]
                for row, text in zip(case["rows"], checks_rows(case), strict=True):
                    limit = order.get(row["check"], (text[0], text[1]))[1]
                    order[row["check"]] = (text[0], limit if limit == text[1] else "per case")
                    mark = VERDICT_MARK.get(row["verdict"], row["verdict"])
                    color = style.get(row["verdict"])
                    value = f"{text[2]} {mark}"
                    cells.setdefault(row["check"], {})[name] = (
                        f"[{color}]{escape(value)}[/]" if color else escape(value)
                    )
            table = Table("check", "limit", *(escape(n) for n in block), title="verdict")
            for key, (label, limit) in order.items():
                table.add_row(escape(label), limit, *(cells[key].get(n, "–") for n in block))
            for column in table.columns[1:]:
                column.justify = "right"
            console.print(table)
    unchecked = sorted({k for case in checks.values() for k in case["not_checked"]})
    if unchecked:
        console.print("not computed here, not checked: " + ", ".join(unchecked), highlight=False)


def print_warnings(warnings: list[str]) -> None:
    from rich.console import Console
    from rich.markup import escape

    console = Console()
    for warning in warnings:
        console.print(f"warning: {escape(warning)}")


def print_run(
    summaries: dict, out: Path, checks: dict | None = None, warnings: list[str] = ()
) -> None:
    from rich.console import Console

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
    overlap = [record.get("any_overlap") for record in summaries.values()]
    if any(any(v) if isinstance(v, list) else v for v in overlap):
        console.print(
            "warning: the disc interferes with unloaded-side pins (see max_overlap_arcsec)"
        )
    print_warnings(list(warnings))
    if any("stage_l10_h_min" in r or "stage_rated_torque_nm" in r for r in summaries.values()):
        console.print(
            "with \\[stage]: loads, stresses, TE and contacts are those of the RV stage "
            "(discs on their crank bearings and, when given, crankshafts and carrier); lost "
            "motion and rigidity of the stage, without main bearings, housing and first stage: "
            "the reducer is softer"
        )
    console.print(f"report: {out / 'report.html'}")


STIFFNESS_ROWS = (
    row("rated_torque_nm"),
    row("play_arcmin_max"),
    row("lost_motion_arcmin_mean"),
    row("lost_motion_arcmin_max"),
    row("torsional_rigidity_nm_per_arcmin_mean"),
    row("torsional_rigidity_nm_per_arcmin_min"),
    row("hysteresis_arcmin_max"),
    row("drive_lost_motion_arcmin_max"),
    row("drive_torsional_rigidity_nm_per_arcmin_min"),
    row("stage_lost_motion_arcmin_max"),
    row("stage_torsional_rigidity_nm_per_arcmin_min"),
    row("stage_l10_h_min"),
    row("measured_torsional_rigidity_nm_per_arcmin"),
    row("measured_lost_motion_arcmin"),
    row("measured_backlash_arcmin"),
    row("reconciling_compliance_arcmin_per_knm"),
)
"""Rows of the stiffness summary (labels and units from the quantity registry)."""


def print_stiffness(summaries: dict, out: Path, checks: dict | None = None) -> None:
    from rich.console import Console

    console = Console(highlight=False)
    print_metrics(console, summaries, STIFFNESS_ROWS)
    if checks:
        print_checks(console, checks)
    if any("stage_lost_motion_arcmin_max" in record for record in summaries.values()):
        console.print(
            "stage rows: the RV stage of \\[stage] (mesh, crank bearings and, when given, "
            "crankshafts and carrier), which the requirements check; the other rows: the mesh "
            "alone. Main bearings, housing and the first stage are not included: the reducer "
            "is softer"
        )
    else:
        console.print(
            "the mesh alone: crank bearings, crankshafts and the first stage are not "
            "included: the reducer is softer"
        )
    if any("measured_lost_motion_arcmin" in record for record in summaries.values()):
        console.print(
            "measured: the loop of \\[stiffness] measured_file by the same definitions; the "
            "reconciling compliance is reported, not applied"
        )
    console.print(f"report: {out / 'report.html'}")


EFFICIENCY_ROWS = (
    row("peak_efficiency", "%", 100.0),
    row("peak_torque_nm"),
    row("peak_speed_rpm"),
    row("rated_efficiency", "%", 100.0),
    row("rated_backdrive_efficiency", "%", 100.0),
    row("rated_input_power_w"),
)


def print_efficiency(summaries: dict, out: Path, checks: dict | None = None) -> None:
    from rich.console import Console

    console = Console(highlight=False)
    print_metrics(console, summaries, EFFICIENCY_ROWS)
    if checks:
        print_checks(console, checks)
    console.print("losses: pin contacts and crank bearings; churning, seals not modelled")
    console.print(f"report: {out / 'report.html'}")


def unsolved_text(block: dict[str, Any]) -> str:
    """The sentence on the rings a solver did not converge on (``block``: the ``unsolved``
    of a summary): "N rings did not converge (first: ring k, <message>), written to
    unsolved_ring.toml", plain text; "" when every ring converged."""
    n = int(block.get("count") or 0)
    if not n:
        return ""
    return (
        f"{n} ring{'s' if n > 1 else ''} did not converge (first: ring {block['first_ring']}, "
        f"{block['message']}), written to {block['file']}"
    )


def print_tolerance(stats: dict[str, Any], out: Path) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from cyclomesh.results.metrics import DRIVE_METRICS, METRICS, STAGE_RING_METRICS

    jam = stats.get("jam") or {}
    jammed = int(jam.get("count") or 0)
    unsolved = stats.get("unsolved") or {}
    failed = int(unsolved.get("count") or 0)
    title = f"{stats['rings']} rings (seed {stats['seed']})"
    if jammed or failed:
        left = ", ".join(
            ([f"{jammed} jammed"] if jammed else []) + ([f"{failed} unsolved"] if failed else [])
        )
        title = (
            f"{stats['rings'] - jammed - failed} of {stats['rings']} rings (seed "
            f"{stats['seed']}; {left}, not in these statistics)"
        )
    table = Table(title=title)
    for col in ("metric", "mean", "std", "P5", "P50", "P95", "P99"):
        table.add_column(col, justify="left" if col == "metric" else "right")
    for name, s in stats["metrics"].items():
        m = METRICS.get(name) or DRIVE_METRICS.get(name) or STAGE_RING_METRICS.get(name)
        label = name if m is None else m.label + ("" if m.unit == "1" else f" [{m.unit}]")
        table.add_row(
            escape(label),
            f"{s['mean']:.4g}",
            f"{s['std']:.3g}",
            *(f"{q['estimate']:.4g}" for q in s["percentiles"]),
        )
    console = Console(highlight=False)
    if jammed + failed < stats["rings"]:
        console.print(table)
    else:
        console.print(f"no statistics: every one of the {stats['rings']} rings jams the disc")
    if stats.get("checks"):
        print_checks(console, {"tolerance": stats["checks"]})
    ex = stats["exceedance"]["max_contact_stress_mpa"]
    conf = stats["confidence"]
    console.print(
        f"P(max σH tooth > {stats['allowable_contact_stress_mpa']:g} MPa) = "
        f"{ex['probability']:.4g}, {conf:.0%} Clopper-Pearson [{ex['lower']:.4g}, "
        f"{ex['upper']:.4g}] ({ex['count']} of {ex['rings']} rings)"
    )
    if jammed:
        console.print(
            f"[bold red]jam[/]: P(the pins jam the disc) = {jam['probability']:.4g}, {conf:.0%} "
            f"Clopper-Pearson [{jam['lower']:.4g}, {jam['upper']:.4g}] ({jam['count']} of "
            f"{jam['rings']} rings; counted as exceeding) -> {escape(str(out / jam['file']))}"
        )
    if failed:
        said = unsolved_text({**unsolved, "file": str(out / unsolved["file"])})
        console.print(f"[bold red]unsolved[/]: {escape(said)}; counted as exceeding")
    print_warnings(stats.get("warnings", []))
    worst = stats["worst_ring"]
    if worst is not None:
        console.print(
            f"worst ring {worst['ring']}: {worst['max_contact_stress_mpa']:.5g} MPa -> "
            f"{escape(str(out / 'worst_ring.toml'))}"
        )
    stage = stats.get("stage_worst_ring")
    if stage:
        life = stage.get("stage_l10_h_min")
        console.print(
            f"stage: weakest ring {stage['ring']}"
            + ("" if life is None else f", L10h of its weakest crank bearing {life:.5g} h")
            + f", largest crank bearing load {stage['stage_max_crank_bearing_load_n']:.5g} N"
        )
    console.print(
        f"percentile intervals: {out / 'tolerance_summary.json'}; "
        f"report: {out / 'report.html'} ({stats['rings_per_second']:.1f} rings/s)"
    )


def print_fe(summaries: dict, out: Path, checks: dict | None = None) -> None:
    from rich.console import Console

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


def print_allocation(statement: str, warnings: list[str], out: Path) -> None:
    """The allocation's statement, its warnings and where the files are."""
    from rich.console import Console

    console = Console(highlight=False)
    console.print(statement, markup=False)
    print_warnings(warnings)
    console.print(f"files: {out}", markup=False)


def print_design(summary: dict[str, Any], seconds: float, out: Path) -> None:
    """Candidates, the optimum and its verdict table, warnings, where the report is."""
    from rich.console import Console

    console = Console(highlight=False)
    s = summary
    console.print(
        f"{s['candidates']} candidates, {s['feasible_candidates']} feasible, "
        f"{s['failed_candidates']} failed ({seconds:.1f} s)",
        markup=False,
    )
    if s["optimum"] is None:
        console.print("no feasible candidate: relax the constraints or widen the ranges")
    else:
        where = ", ".join(f"{k} = {v:g}" for k, v in s["optimum"]["parameters"].items())
        value = s["optimum"]["metrics"][s["objective_variable"]]
        console.print(f"optimum: {where} ({s['objective_variable']} = {value:.6g})", markup=False)
        if s.get("checks"):
            print_checks(console, {"optimum": s["checks"]})
    print_warnings(s.get("warnings", []))
    console.print(f"report: {out / 'report.html'}", markup=False)


def print_export(
    written: dict[str, dict[str, Path]],
    chord_tolerance_um: float,
    same: dict[str, str] | None = None,
) -> None:
    """Per case of an export: points, tip and root radii, the files written; a case
    whose drawing is an earlier case's (``same``: case → that case) in one line."""
    import json

    from rich.console import Console

    console = Console(highlight=False)
    for name, files in written.items():
        meta = json.loads(files["json"].read_text())
        console.print(
            f"{name}: {meta['vertices']} points, tip radius {meta['tip_radius_mm']:.4f} mm, "
            f"root radius {meta['root_radius_mm']:.4f} mm, chord tolerance "
            f"{chord_tolerance_um:g} µm",
            markup=False,
        )
        console.print("  " + ", ".join(str(p) for p in files.values()), markup=False)
    for name, first in (same or {}).items():
        folder = written[first]["json"].parent
        console.print(
            f"{name}: the same drawing as {first} (only non-profile keys differ): "
            f"written once, in {folder}",
            markup=False,
        )
