"""Requirement checks and design warnings: one verdict table per case.

A designer's requirements (``[requirements]`` of a study file, study units) are held
against the metrics a kind of study computes: a run gives stresses, TE, contacts, ratio
ripple, play and mesh force; ``cyclomesh stiffness`` the lost motion and the torsional
rigidity; a tolerance study the same metrics as a run at a stated percentile of the
rings. A requirement whose quantity a kind of study does not compute is listed as not
checked there, never as passed.

Every row of the table is a plain dict (JSON-ready)::

    {"check": "max_contact_stress_mpa", "label": "peak contact stress, pin-tooth",
     "unit": "MPa", "limit": 1500.0, "value": 1210.3, "margin": 289.7,
     "margin_pct": 19.3, "verdict": "pass", "note": "..."}

``margin`` is limit − value for an upper limit and value − limit for a lower one (in the
unit; negative = failed), ``margin_pct`` the same in % of the limit. Design warnings
(K1, the undercut margin, a peak stress on a convex part of the tooth with ρc < ρp) are
rows with the verdict ``"warning"`` or ``"ok"``.

The thresholds of the warnings are rules of thumb, stated here, not limits of a standard:
K1 = e·n1/a above :data:`K1_WARNING` (0.75; a short-width coefficient above about 0.75
gives pointed teeth and high curvature at the tips); an undercut margin (smallest convex
curvature radius of the pin-centre locus over the generating pin radius, minus 1) below
:data:`UNDERCUT_MARGIN_WARNING`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cyclomesh.core.pair import Modification, PairDesign

__all__ = [
    "Requirement",
    "REQUIREMENTS",
    "K1_WARNING",
    "UNDERCUT_MARGIN_WARNING",
    "check_requirements",
    "design_warnings",
    "stage_parts",
    "peak_stress_warning",
    "jam_row",
    "jam_warning",
    "jams",
    "min_play_arcmin",
    "verdict_counts",
    "SHORT",
    "short_label",
    "checks_rows",
    "VERDICT_MARK",
]

K1_WARNING = 0.75
"""K1 = e·n1/a above which a design warning is given [-]."""
UNDERCUT_MARGIN_WARNING = 0.1
"""Undercut margin R_min/ρ' − 1 below which a design warning is given [-]."""


@dataclass(frozen=True)
class Requirement:
    """A requirement key: upper (``max``) or lower (``min``) limit on a metric.

    ``sources`` are the summary keys that give the value, in order of preference, each
    with the factor to the requirement's unit.
    """

    key: str
    kind: str  # "max" or "min"
    unit: str
    label: str
    sources: tuple[tuple[str, float], ...]


REQUIREMENTS: dict[str, Requirement] = {
    r.key: r
    for r in (
        Requirement(
            "max_contact_stress_mpa",
            "max",
            "MPa",
            "peak contact stress, pin-tooth",
            (("max_contact_stress_mpa", 1.0), ("fe_max_contact_stress_mpa", 1.0)),
        ),
        Requirement(
            "max_groove_stress_mpa",
            "max",
            "MPa",
            "peak contact stress, pin-groove",
            (("max_groove_stress_mpa", 1.0),),
        ),
        Requirement(
            "max_te_pp_arcsec", "max", "arcsec", "TE peak-to-peak", (("te_pp_arcsec", 1.0),)
        ),
        Requirement("min_contacts", "min", "1", "fewest pins in contact", (("min_contacts", 1.0),)),
        Requirement(
            "max_gear_ratio_ripple_pct",
            "max",
            "%",
            "gear-ratio ripple",
            (("gear_ratio_ripple_pct", 1.0),),
        ),
        Requirement(
            "max_play_arcmin",
            "max",
            "arcmin",
            "largest play at zero load",
            (("play_arcmin_max", 1.0), ("play_arcsec_max", 1.0 / 60.0)),
        ),
        Requirement(
            "max_lost_motion_arcmin",
            "max",
            "arcmin",
            "largest lost motion",
            (
                ("drive_lost_motion_arcmin_max", 1.0),
                ("stage_lost_motion_arcmin_max", 1.0),
                ("lost_motion_arcmin_max", 1.0),
            ),
        ),
        Requirement(
            "min_torsional_rigidity_nm_per_arcmin",
            "min",
            "N·m/arcmin",
            "smallest torsional rigidity",
            (
                ("drive_torsional_rigidity_nm_per_arcmin_min", 1.0),
                ("stage_torsional_rigidity_nm_per_arcmin_min", 1.0),
                ("torsional_rigidity_nm_per_arcmin_min", 1.0),
            ),
        ),
        Requirement(
            "max_mesh_force_n", "max", "N", "largest mesh force", (("max_mesh_force_n", 1.0),)
        ),
        Requirement(
            "min_bearing_life_h",
            "min",
            "h",
            "L10h of the weakest crank bearing (ISO 281)",
            (("stage_l10_h_min", 1.0),),
        ),
        Requirement(
            "min_efficiency",
            "min",
            "1",
            "forward efficiency (with [friction])",
            (("stage_efficiency", 1.0), ("efficiency", 1.0), ("efficiency_min", 1.0)),
        ),
        Requirement(
            "min_backdrive_efficiency",
            "min",
            "1",
            "back-driving efficiency (with [friction])",
            (
                ("stage_backdrive_efficiency", 1.0),
                ("backdrive_efficiency", 1.0),
                ("backdrive_efficiency_min", 1.0),
            ),
        ),
    )
}
"""Every requirement key of ``[requirements]``, with the metrics that check it."""


_COMPLIANCE = ("max_lost_motion_arcmin", "min_torsional_rigidity_nm_per_arcmin")
"""Requirements a designer writes for the whole reducer, checked on a part of it."""


_STAGE_PARTS = ("crank bearings", "crankshafts", "carrier")
"""Parts of the RV stage around the mesh that a ``[stage]`` may model."""


def stage_parts(stage: Any, disc_body: str = "rigid") -> tuple[str, ...]:
    """The parts of an RV stage (a :class:`~cyclomesh.stage.solve.StageDesign`) that its
    solve models around the mesh, by name: "crank bearings" (``[stage.crank_bearing]``),
    "crankshafts" (``[stage.crankshaft]`` or a crankshaft stiffness), "carrier"
    (``[stage.carrier]`` or a carrier stiffness), "compliant disc" (``disc_body = "fe"``).
    """
    parts = []
    if getattr(stage, "bearing", None) is not None:
        parts.append("crank bearings")
    if getattr(stage, "crankshaft", None) is not None or (
        getattr(stage, "crankshaft_stiffness", None) is not None
    ):
        parts.append("crankshafts")
    if getattr(stage, "carrier", None) is not None or (
        getattr(stage, "carrier_stiffness", None) is not None
    ):
        parts.append("carrier")
    if disc_body == "fe":
        parts.append("compliant disc")
    return tuple(parts)


def _stage_note(parts: tuple[str, ...] | None) -> tuple[str, str]:
    """What a stage row checked ("stage: mesh + crank bearings + ...") and what the
    reducer adds to it (the parts of the stage not modelled, main bearings, housing,
    first stage). ``parts`` None: the stage's parts are not known (crank bearings)."""
    parts = ("crank bearings",) if parts is None else parts
    what = "stage: " + " + ".join(("mesh", *parts))
    missing = [p for p in _STAGE_PARTS if p not in parts]
    return what, ", ".join(["main bearings", "housing", "first stage", *missing])


def _worst(value: Any, kind: str) -> float | None:
    """One number from a metric value (a list per torque: the worst of them)."""
    if value is None:
        return None
    values = [v for v in (value if isinstance(value, list) else [value]) if v is not None]
    if not values:
        return None
    return float(max(values) if kind == "max" else min(values))


def _row(
    key: str, label: str, unit: str, kind: str, limit: float, value: float, note: str = ""
) -> dict[str, Any]:
    margin = limit - value if kind == "max" else value - limit
    return {
        "check": key,
        "label": label,
        "unit": unit,
        "limit": limit,
        "value": value,
        "margin": margin,
        "margin_pct": 100.0 * margin / abs(limit) if limit else None,
        "verdict": "pass" if margin >= 0 else "fail",
        "note": note,
    }


def check_requirements(
    limits: dict[str, float],
    summary: dict[str, Any],
    notes: dict[str, str] | None = None,
    stage: tuple[str, ...] | None = None,
) -> tuple[list[dict[str, Any]], list[str]]:
    """Hold the metrics of one case against the requirements.

    Parameters
    ----------
    limits : dict
        Requirement key (:data:`REQUIREMENTS`) → limit, in the key's unit.
    summary : dict
        Metric name → value of a kind of study (a summary record; a list of values, one
        per torque, is checked at its worst).
    notes : dict, optional
        Requirement key → a note for its row (e.g. where a default limit came from).
    stage : tuple of str, optional
        The parts the stage solve modelled around the mesh (:func:`stage_parts`), named
        in the note of a row checked on the stage; None: crank bearings.

    Returns
    -------
    rows, unchecked : list of dict, list of str
        One row per requirement the summary has a value for; the keys it has none for.
    """
    rows, unchecked = [], []
    notes = notes or {}
    for key, limit in limits.items():
        req = REQUIREMENTS[key]
        value, note = None, notes.get(key, "")
        for source, factor in req.sources:
            worst = _worst(summary.get(source), req.kind)
            if worst is not None:
                value = worst * factor
                what = ""
                left_out = "main bearings, housing, first stage, crank bearings, crankshafts"
                if source.startswith("drive_"):
                    what = "whole drive (mesh + series stiffness)"
                elif source.startswith("stage_"):
                    what, left_out = _stage_note(stage)
                elif source.startswith("fe_"):
                    what = "FE model, at its crank angles"
                elif key in _COMPLIANCE:
                    what = "mesh alone"
                if key in _COMPLIANCE and not source.startswith("drive_"):
                    what += f"; the reducer's is worse ({left_out} not included)"
                if what:
                    note = (note + "; " if note else "") + what
                break
        if value is None or not math.isfinite(value):
            unchecked.append(key)
            continue
        rows.append(_row(key, req.label, req.unit, req.kind, float(limit), value, note))
    return rows, unchecked


def _warning(
    key: str, label: str, unit: str, kind: str, limit: float, value: float, note: str
) -> dict[str, Any]:
    row = _row(key, label, unit, kind, limit, value, note)
    row["verdict"] = "ok" if row["margin"] >= 0 else "warning"
    return row


def design_warnings(design: PairDesign, modification: Modification | None) -> list[dict[str, Any]]:
    """Design warnings of the geometry alone: K1 and the undercut margin (rows as above).

    K1 = e·n1/a (short-width coefficient); the undercut margin is R_min/ρ' − 1 with R_min
    the smallest convex curvature radius of the pin-centre locus (Eq. 4 of [1]: ρc + ρ')
    and ρ' = ρp + Δρ the generating pin radius: 0 is an undercut (refused on loading).
    """
    from cyclomesh.core.profile import curvature_radius, generating_radii

    modification = modification or Modification()
    k1 = design.short_amplitude_coefficient
    rows = [
        _warning(
            "k1",
            "short-width coefficient K1 = e·n1/a",
            "1",
            "max",
            K1_WARNING,
            k1,
            "rule of thumb: above about 0.75 the teeth get pointed",
        )
    ]
    _, rho = generating_radii(design, modification)
    theta = np.linspace(0.0, 2.0 * np.pi / design.teeth, 4001)
    locus_radius = curvature_radius(theta, design, modification) + rho
    convex = locus_radius[locus_radius > 0]
    if len(convex):
        margin = float(convex.min()) / rho - 1.0
        row = _warning(
            "undercut_margin",
            "undercut margin R_min/ρ' − 1",
            "1",
            "min",
            UNDERCUT_MARGIN_WARNING,
            margin,
            f"R_min = {convex.min() * 1e3:.4g} mm is {100.0 * margin:.3g} % above the "
            f"generating pin radius ρ' = {rho * 1e3:.4g} mm (0: undercut); smallest convex "
            f"curvature radius ρc = {(convex.min() - rho) * 1e3:.3g} mm",
        )
        # the margin is itself relative: a % of the rule-of-thumb threshold means nothing
        row["margin_pct"] = None
        rows.append(row)
    return rows


def peak_stress_warning(ds: Any, pin_radius_mm: float) -> dict[str, Any] | None:
    """Warning row if the peak tooth contact stress of ``ds`` (:func:`cyclomesh.analyse`)
    lies on a convex part of the tooth whose curvature radius ρc is below the pin radius
    ρp (a convex-on-convex contact sharper than the pin itself). None without a contact."""
    stress = np.asarray(ds["contact_stress"].values, dtype=float)
    if not np.any(np.isfinite(stress)) or np.nanmax(stress) <= 0:
        return None
    at = np.unravel_index(np.nanargmax(stress), stress.shape)
    rho_c = float(ds["curvature_radius"].transpose(*ds["contact_stress"].dims).values[at])  # [mm]
    angle = float(ds["crank_angle"].values[at[ds["contact_stress"].dims.index("crank_angle")]])
    pin = int(ds["pin"].values[at[ds["contact_stress"].dims.index("pin")]])
    value = rho_c if rho_c > 0 else math.inf
    row = _warning(
        "peak_stress_curvature",
        "ρc at the peak contact stress (convex: ≥ ρp)",
        "mm",
        "min",
        pin_radius_mm,
        value if math.isfinite(value) else 1e300,
        f"pin {pin} at crank angle {angle:g} deg; "
        + ("concave part of the tooth" if rho_c <= 0 else f"convex, ρc = {rho_c:.4g} mm"),
    )
    row["value"] = rho_c
    row["margin"] = None if rho_c <= 0 else rho_c - pin_radius_mm
    row["margin_pct"] = None if rho_c <= 0 else 100.0 * row["margin"] / pin_radius_mm
    return row


def min_play_arcmin(ds: Any) -> float | None:
    """Smallest play at zero load of a result with a ``play`` variable [arcmin] (its
    ``units`` attribute: arcsec or arcmin); None without one."""
    if ds is None or "play" not in ds:
        return None
    values = np.asarray(ds["play"].values, dtype=float)
    if not np.any(np.isfinite(values)):
        return None
    factor = {"arcsec": 1.0 / 60.0, "arcmin": 1.0}[ds["play"].attrs.get("units", "arcsec")]
    return float(np.nanmin(values)) * factor


#: A play below minus this is a jam [arcmin]. The play is a difference of two rest
#: positions of tens of arcsec, so a pair with zero clearance (the unmodified profile of
#: Table 2, case 4) gives a play of round-off size, about ±1e-9 arcmin, not a jam; 1e-6
#: arcmin (0.3 nrad, an overlap of 0.02 nm at the pin circle) is far above that and far
#: below any overlap that matters.
JAM_TOLERANCE_ARCMIN = 1e-6


def jams(play_arcmin: float | None) -> bool:
    """Whether the smallest play at zero load [arcmin] means the pins jam the disc
    (below ``-JAM_TOLERANCE_ARCMIN``; a play of round-off size is a zero play)."""
    return play_arcmin is not None and play_arcmin < -JAM_TOLERANCE_ARCMIN


def jam_row(play_arcmin: float) -> dict[str, Any]:
    """Verdict row of the smallest play at zero load: negative fails (the pins jam the
    disc: at rest the disc overlaps the pins of the other flank, so the loaded results
    describe a pair that cannot be assembled or turned)."""
    row = _row(
        "jam",
        "smallest play at zero load (negative: the pins jam the disc)",
        "arcmin",
        "min",
        0.0,
        play_arcmin,
        "negative play: the pins jam the disc; enlarge the clearance of [modification] "
        "or reduce [errors]"
        if jams(play_arcmin)
        else "the pins do not jam the disc",
    )
    row["margin_pct"] = None  # of a zero limit
    return row


def jam_warning(play_arcmin: float | None) -> str | None:
    """The warning of a negative play at zero load (None if it is not negative)."""
    if not jams(play_arcmin):
        return None
    return (
        f"negative play at zero load ({play_arcmin:.4g} arcmin): the pins jam the disc, "
        "the loaded results are of a pair that cannot turn (enlarge the clearance of "
        "[modification] or reduce [errors])"
    )


SHORT = {
    "max_contact_stress_mpa": "σH tooth [MPa]",
    "max_groove_stress_mpa": "σH groove [MPa]",
    "max_te_pp_arcsec": "TE p-p [arcsec]",
    "min_contacts": "pins in contact",
    "max_gear_ratio_ripple_pct": "ratio ripple [%]",
    "max_play_arcmin": "play [arcmin]",
    "max_lost_motion_arcmin": "lost motion [arcmin]",
    "min_torsional_rigidity_nm_per_arcmin": "rigidity [N·m/arcmin]",
    "max_mesh_force_n": "mesh force [N]",
    "min_bearing_life_h": "bearing L10h [h]",
    "min_efficiency": "efficiency",
    "min_backdrive_efficiency": "back-drive efficiency",
    "k1": "K1 = e·n1/a",
    "undercut_margin": "undercut margin",
    "peak_stress_curvature": "ρc at peak σH [mm]",
    "jam": "jam: play [arcmin]",
}
"""Short names of the checks with their units, for tables that must fit 80 columns."""


def short_label(row: dict[str, Any]) -> str:
    """The short name of a row's check ("drive ..." when the whole drive was checked)."""
    name = SHORT.get(row["check"], row["check"])
    note = row.get("note", "")
    if "whole drive" in note:
        name = "drive " + name
    elif "stage: mesh" in note:
        name = "stage " + name
    elif "mesh alone" in note:
        name = "mesh " + name
    return name


VERDICT_MARK = {"pass": "PASS", "fail": "FAIL", "warning": "WARN", "ok": "ok"}
"""How tables show a verdict."""


def _number(value: Any) -> str:
    if value is None:
        return "–"
    if isinstance(value, int) or (
        isinstance(value, float) and value.is_integer() and abs(value) < 1e6
    ):
        return f"{value:.0f}" if abs(value) >= 1 or value == 0 else f"{value:.4g}"
    return f"{value:.4g}"


def checks_rows(checks: dict[str, Any]) -> list[list[str]]:
    """Rows (check, limit, value, margin, verdict) of a table, as text."""
    out = []
    for row in checks["rows"]:
        margin = row["margin"]
        pct = row.get("margin_pct")
        margin_text = "–" if margin is None else f"{margin:+.3g}"
        if pct is not None and margin is not None:
            margin_text += f" ({pct:+.0f}%)"
        out.append(
            [
                short_label(row),
                _number(row["limit"]),
                _number(row["value"]),
                margin_text,
                VERDICT_MARK.get(row["verdict"], row["verdict"]),
            ]
        )
    return out


def verdict_counts(rows: list[dict[str, Any]]) -> dict[str, int]:
    """How many rows have each verdict (pass, fail, warning, ok)."""
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["verdict"]] = counts.get(row["verdict"], 0) + 1
    return counts
