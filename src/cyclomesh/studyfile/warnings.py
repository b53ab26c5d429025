"""Warnings a study carries into its summary.json, the CLI and the report.

They flag results that are computed exactly but that a designer could misread:

* under ``contact_law = "paper"`` (Eq. 20 of [1] as published) the ratio ripple and the TE
  peak-to-peak are not converged in the crank step: a pin crossing an inflection point
  of the modified profile loses its load for about one crank step, so both grow without
  bound as the step shrinks (``docs/contact-law.md``, ``benchmarks/step_convergence.py``);
* with pin errors (or rings drawn from ``[tolerance]``) every crank angle meets other
  pins in other places, so crank angles covering less than a full revolution under-sample
  the errors (a mesh cycle suffices only for a perfect ring).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "PAPER_LAW_WARNING",
    "contact_law_warning",
    "coverage_warning",
    "study_warnings",
    "covered_deg",
    "has_pin_errors",
    "merge_warnings",
    "stage_warning",
]

PAPER_LAW_WARNING = (
    'contact_law = "paper": the ratio ripple and the TE peak-to-peak are not converged in '
    "the crank step (they grow as the step shrinks, docs/contact-law.md); use the default "
    '"half_plane" for design numbers'
)


def contact_law_warning(contact_law: str) -> str | None:
    """The warning of a contact law (None for the converged half-plane law)."""
    return PAPER_LAW_WARNING if contact_law == "paper" else None


def covered_deg(crank_angles_deg: ArrayLike) -> float:
    """Crank angle covered by evenly stepped angles: last − first + one step [deg]."""
    phi = np.sort(np.atleast_1d(np.asarray(crank_angles_deg, float)))
    if phi.size < 2:
        return 0.0
    return float(phi[-1] - phi[0] + np.min(np.diff(phi)))


def coverage_warning(crank_angles_deg: ArrayLike, what: str = "pin errors") -> str | None:
    """A warning when crank angles with pin errors (or rings) cover less than 360°."""
    covered = covered_deg(crank_angles_deg)
    if covered >= 360.0 - 1e-6:
        return None
    return (
        f"the crank angles cover {covered:.4g}° of the revolution: with {what} every crank "
        "angle meets other pins, so less than a full revolution under-samples them "
        "(crank_start_deg = 0, crank_stop_deg = 360)"
    )


def has_pin_errors(errors_um: Mapping[str, ArrayLike], eccentricity_um: float = 0.0) -> bool:
    """Whether a case has any pin error (radial, angular, radius) or eccentricity error."""
    return bool(eccentricity_um) or any(np.any(np.asarray(v) != 0) for v in errors_um.values())


def study_warnings(
    contact_law: str, crank_angles_deg: ArrayLike, pin_errors: bool, what: str = "pin errors"
) -> list[str]:
    """The warnings of one analysis: contact law, and crank coverage when it has errors."""
    out = [contact_law_warning(contact_law)]
    if pin_errors:
        out.append(coverage_warning(crank_angles_deg, what))
    return [w for w in out if w]


def stage_warning(inputs: Any) -> str | None:
    """The RV stage's warning of a case's core inputs (crank hole errors beyond the bearing
    clearance, :meth:`~cyclomesh.stage.design.StageDesign.preload_warning`), or None."""
    if getattr(inputs, "stage", None) is None:
        return None
    return inputs.stage.preload_warning(inputs.discs)


def stage_friction_note(inputs: Any) -> str | None:
    """Friction with the compliant disc is solved in the RV stage only: say that the mesh
    alone on rigid bearings is frictionless (:attr:`~cyclomesh.studyfile.schema.CaseInputs.
    mesh_friction`), or None."""
    if getattr(inputs, "friction", None) is None or inputs.mesh_friction is not None:
        return None
    return (
        'friction with disc_body = "fe" is solved in the RV stage\'s equilibrium only: the '
        "stage's results carry it, the mesh alone on rigid bearings "
        "(rigid_bearing_transmission_error, the stiffness study's mesh values) is frictionless"
    )


def merge_warnings(per_case: Mapping[str, Iterable[str]]) -> list[str]:
    """One list for a study: a warning of every case once, the others prefixed by case."""
    lists = {name: list(ws) for name, ws in per_case.items()}
    out: list[str] = []
    for name, warnings in lists.items():
        for w in warnings:
            if all(w in other for other in lists.values()):
                if w not in out:
                    out.append(w)
            else:
                out.append(f"{name}: {w}")
    return out
