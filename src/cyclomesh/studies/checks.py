"""The verdict table of every kind of study: requirements and design warnings per case.

:func:`case_checks` holds one case's metrics against ``[requirements]`` (limits
defaulted from the materials' allowable contact stress) and adds the design warnings
(:mod:`cyclomesh.results.requirements`); :func:`checks_section` is its report section and
:func:`checks_rows` the rows of a CLI table. The result is a JSON-ready dict stored as
``"checks"`` in each case record of ``summary.json``.
"""

from __future__ import annotations

import html
from typing import TYPE_CHECKING, Any

from cyclomesh.results.requirements import (
    VERDICT_MARK,
    check_requirements,
    checks_rows,
    design_warnings,
    jam_row,
    jam_warning,
    jams,
    min_play_arcmin,
    peak_stress_warning,
    stage_parts,
    verdict_counts,
)

if TYPE_CHECKING:
    from cyclomesh.publish.report import Section
    from cyclomesh.studyfile.schema import CaseInputs, CaseSpec, Study

__all__ = ["case_checks", "case_warnings", "checks_section", "percentile_summary"]


def case_warnings(case: CaseSpec, inputs: CaseInputs, ds: Any, *extra: str | None) -> list[str]:
    """The warnings of one solved case of a run or a torsion study: the study's (contact
    law, crank-angle coverage of pin errors), the jam of its smallest play ``ds``
    (:func:`~cyclomesh.results.requirements.min_play_arcmin`), the stage's notes, then
    the kind's own ``extra`` notes (None: no note), in that order."""
    from cyclomesh.studyfile.warnings import (
        has_pin_errors,
        stage_friction_note,
        stage_warning,
        study_warnings,
    )

    notes = (jam_warning(min_play_arcmin(ds)), stage_warning(inputs), stage_friction_note(inputs))
    return study_warnings(
        inputs.contact_law,
        case.analysis.crank_angles_deg(),
        has_pin_errors(inputs.errors_um, case.errors.eccentricity_um),
    ) + [w for w in (*notes, *extra) if w]


def case_checks(
    study: Study,
    case: CaseSpec,
    inputs: CaseInputs,
    summary: dict[str, Any],
    ds: Any = None,
    where: str = "",
) -> dict[str, Any]:
    """Requirement checks and design warnings of one case (JSON-ready).

    Parameters
    ----------
    summary : dict
        The case's metrics (summary record of the kind of study).
    ds : xarray.Dataset, optional
        The case's :func:`cyclomesh.analyse` results, for the warning on the contact
        curvature at the peak stress, and any result with a ``play`` variable for the
        jam row (negative play at zero load fails).
    where : str
        How the values were taken (e.g. ``"P95 of 1000 rings"``), shown with the table.
    """
    limits, notes = study.file.requirements.limits(case.material)
    stage = None if inputs.stage is None else stage_parts(inputs.stage, inputs.disc_body)
    rows, unchecked = check_requirements(limits, summary, notes, stage)
    rows += design_warnings(inputs.design, inputs.modification)
    if ds is not None and "contact_stress" in ds:
        row = peak_stress_warning(ds, inputs.design.pin_radius * 1e3)
        if row is not None:
            rows.append(row)
    play = min_play_arcmin(ds)
    if jams(play):  # the pins jam the disc: a failing row
        rows.append(jam_row(play))
    return {
        "rows": rows,
        "not_checked": unchecked,
        "counts": verdict_counts(rows),
        "values": where,
    }


def percentile_summary(per_ring: Any, percentile: float) -> dict[str, float]:
    """Metrics of many rings (a Dataset with a ``ring`` dimension) as the values that
    ``percentile`` % of the rings meet: the ``percentile``-th percentile for an upper
    limit, the (100 − ``percentile``)-th for a lower limit (method "linear")."""
    import numpy as np

    from cyclomesh.results.requirements import REQUIREMENTS

    out: dict[str, float] = {}
    for req in REQUIREMENTS.values():
        q = percentile if req.kind == "max" else 100.0 - percentile
        for source, _ in req.sources:
            if source in per_ring:
                values = np.asarray(per_ring[source].values, dtype=float)
                values = values[np.isfinite(values)]
                if len(values):
                    out[source] = float(np.percentile(values, q))
    return out


def _counts_html(case: dict[str, Any]) -> str:
    summary = ", ".join(f"{v} {k}" for k, v in case["counts"].items())
    values = f"; values: {html.escape(case['values'])}" if case.get("values") else ""
    return f"<p>{html.escape(summary)}{values}</p>"


def _matrix_html(checks: dict[str, dict[str, Any]]) -> str:
    """Several cases: one row per check, a "value VERDICT (margin)" cell per case, the
    notes of failures and warnings below."""
    names = list(checks)
    order: dict[str, list[str]] = {}
    cells: dict[str, dict[str, str]] = {}
    notes = []
    for name in names:
        case = checks[name]
        for row, text in zip(case["rows"], checks_rows(case), strict=True):
            label, limit = order.setdefault(row["check"], [text[0], text[1]])
            if limit != text[1]:
                order[row["check"]][1] = "per case"
            cls = {"fail": "fail", "warning": "warn"}.get(row["verdict"], "")
            pct = "" if row.get("margin_pct") is None else f" ({row['margin_pct']:+.0f}%)"
            cells.setdefault(row["check"], {})[name] = (
                f'<td class="{cls}" title="{html.escape(row["note"])}">'
                f"{html.escape(text[2])} {VERDICT_MARK.get(row['verdict'], '')}{pct}</td>"
            )
            if cls:
                notes.append(
                    f"{html.escape(name)}, {html.escape(text[0])}: {html.escape(row['note'])}"
                )
    head = "".join(f"<th>{html.escape(h)}</th>" for h in ("check", "limit", *names))
    body = "".join(
        f"<tr><td>{html.escape(label)}</td><td>{html.escape(limit)}</td>"
        + "".join(cells[key].get(n, "<td>–</td>") for n in names)
        + "</tr>"
        for key, (label, limit) in order.items()
    )
    counts = "; ".join(
        f"{html.escape(n)}: " + ", ".join(f"{v} {k}" for k, v in checks[n]["counts"].items())
        for n in names
    )
    out = f"<p>{counts}</p>" + (
        f'<table class="verdict"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'
    )
    if notes:
        out += "<ul>" + "".join(f"<li>{n}</li>" for n in notes) + "</ul>"
    return out


def checks_section(checks: dict[str, dict[str, Any]], heading: str = "Verdict") -> Section:
    """Report section: one verdict table per case, then what was not checked."""
    from cyclomesh.publish.report import Section

    parts = [
        "<p>Requirements of <code>[requirements]</code> (the contact-stress limits default "
        "to the materials' allowable, no safety factor) and design warnings. Margin: "
        "limit − value for an upper limit, value − limit for a lower one; negative fails.</p>"
    ]
    checks = {name: case for name, case in checks.items() if case["rows"]}
    if len(checks) == 1:
        name, case = next(iter(checks.items()))
        parts.append(_counts_html(case))
        head = "".join(
            f"<th>{h}</th>" for h in ("check", "limit", "value", "margin", "verdict")
        ) + ('<th class="t">note</th>')
        body = []
        for row, text in zip(case["rows"], checks_rows(case), strict=True):
            cls = {"fail": "fail", "warning": "warn"}.get(row["verdict"], "")
            cells = "".join(f"<td>{html.escape(t)}</td>" for t in text)
            body.append(
                f'<tr class="{cls}">{cells}<td class="note">{html.escape(row["note"])}</td></tr>'
            )
        parts.append(
            f'<table class="verdict"><thead><tr>{head}</tr></thead>'
            f"<tbody>{''.join(body)}</tbody></table>"
        )
    elif checks:
        parts.append(_matrix_html(checks))
    unchecked = sorted({k for case in checks.values() for k in case["not_checked"]})
    if unchecked:
        parts.append(
            "<p>Not computed by this kind of study, not checked: "
            + ", ".join(f"<code>{html.escape(k)}</code>" for k in unchecked)
            + "</p>"
        )
    return Section(heading, "".join(parts))
