"""One chain from a :class:`~cyclomesh.core.case.Case` and a
:class:`~cyclomesh.core.case.Model` to a result: :func:`run`.

The pattern of pvlib's ``ModelChain``, which gear people who script their analyses
know: what is analysed (the case) apart from how (the model), and one call that runs
them::

    from cyclomesh.core.case import Case, Model
    from cyclomesh.results.chain import run

    case = Case(TABLE1, Modification(pin_radius=8e-6), torque=250.0,
                crank_angles=np.deg2rad(np.arange(0, 360, 1.0)))
    result = run(case, Model(contact_law="paper"))
    result.to_dataset()          # the Dataset of cyclomesh.analyse
    result.summary()             # the headline numbers (cyclomesh.results.metrics)
    run(case, Model(discs=2, stage=stage), what="torsion").summary()

``what="loads"`` (the default) solves the loaded contact at the case's torque(s),
``what="torsion"`` the torsion curve with the case's torque as the rated torque. The
model's ``stage`` (a :class:`~cyclomesh.stage.solve.StageDesign`) puts the crank bearings
and the carrier around the mesh; its ``disc_body = "fe"`` is resolved here, once, to the
influence coefficients of the fe extra. The solvers are those of the public API
(:func:`cyclomesh.drive.solve.drive`, :func:`~cyclomesh.drive.solve.torsion`,
:func:`cyclomesh.stage.solve.solve`, :func:`~cyclomesh.stage.solve.stage_torsion`), which
:func:`cyclomesh.analyse`, :func:`cyclomesh.stiffness`, ``solve_drive``, ``solve_stage``
and the torsion curves call with the same case and model: the numbers are the same.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.core.case import Case, Model
from cyclomesh.drive.solve import drive, torsion
from cyclomesh.exceptions import DesignError
from cyclomesh.results.dataset import drive_dataset, resolve_disc_body, summarize
from cyclomesh.results.stage import stage_dataset
from cyclomesh.results.torsion import summarize_stiffness, torsion_dataset
from cyclomesh.stage.solve import solve as solve_stage_case
from cyclomesh.stage.solve import stage_torsion

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Result", "run", "WHAT"]

WHAT = ("loads", "torsion")
"""What :func:`run` solves: the loaded contact at the case's torque(s), or the torsion
curve (case torque = rated torque)."""


@dataclass(frozen=True)
class Result:
    """What :func:`run` returns: the case, the model (disc body resolved), what was solved,
    the solver's result (SI: ``Drive``, ``TorsionCurve``, ``Stage`` or ``StageTorsion``)
    and the options of the solve."""

    case: Case
    model: Model
    what: str
    solution: Any
    options: dict

    def to_dataset(self) -> xr.Dataset:
        """The labelled Dataset (engineering units, ``units`` attributes; the registry's
        rows, :mod:`cyclomesh.quantities`)."""
        if self.what == "torsion":
            if self.model.stage is not None:
                raise DesignError("run: the stage's torsion curve has no Dataset yet")
            return torsion_dataset(
                self.solution,
                self.case,
                self.model,
                self.options["points"],
                None,
                self.options.get("series_stiffness_nm_per_arcmin"),
            )
        if self.model.stage is not None:
            return stage_dataset(self.solution, self.model.stage, self.case.design.pins)
        return drive_dataset(self.solution, self.case, self.model, np.ndim(self.case.torque) > 0)

    def summary(self) -> dict[str, Any]:
        """The headline numbers, metric name → value (arrays for rings, torques)."""
        if self.what == "torsion" and self.model.stage is not None:
            from cyclomesh.units import RAD_PER_ARCMIN

            curve = self.solution
            return {
                "stage_lost_motion_arcmin_mean": float(np.mean(curve.lost_motion) / RAD_PER_ARCMIN),
                "stage_lost_motion_arcmin_max": float(np.max(curve.lost_motion) / RAD_PER_ARCMIN),
                "stage_torsional_rigidity_nm_per_arcmin_mean": float(
                    np.mean(curve.torsional_rigidity) * RAD_PER_ARCMIN
                ),
                "stage_torsional_rigidity_nm_per_arcmin_min": float(
                    np.min(curve.torsional_rigidity) * RAD_PER_ARCMIN
                ),
            }
        if self.model.stage is not None:
            raise DesignError("run: the stage's loads have no summary yet (see results.stage)")
        ds = self.to_dataset()
        reduced = summarize_stiffness(ds) if self.what == "torsion" else summarize(ds)
        return {name: reduced[name].values[()] for name in reduced.data_vars}


def run(
    case: Case,
    model: Model | None = None,
    what: str = "loads",
    *,
    points: int = 41,
    series_stiffness_nm_per_arcmin: float | None = None,
    crank_holes: Any = None,
    cache_dir: Any = None,
) -> Result:
    """Solve ``case`` with ``model``: the one chain of the mesh, stacks and the RV stage.

    Parameters
    ----------
    case : Case
    model : Model, optional
        Default ``Model()``: the half-plane law, groove deformation, a rigid disc, one
        disc, no stage.
    what : {"loads", "torsion"}
        The loaded contact at the case's torque(s), or the torsion curve (±3, ±50, ±100 %
        of the case's torque, ``points`` torques).
    points : int
        Torques of a torsion curve (:func:`cyclomesh.drive.solve.torsion_torques`).
    series_stiffness_nm_per_arcmin : float, optional
        Rest of the drive in series with the mesh's torsion curve [N·m/arcmin].
    crank_holes, cache_dir
        Where the FE disc body is held and its cache (``model.disc_body == "fe"``).

    Returns
    -------
    Result
    """
    model = Model() if model is None else model
    if what not in WHAT:
        raise DesignError(f"run: what must be one of {', '.join(WHAT)}, got {what!r}")
    design, modification = case.design, case.modification
    if isinstance(model.disc_body, str) and model.disc_body == "fe":
        body = resolve_disc_body(
            "fe", design, modification, crank_holes, cache_dir, stage=model.stage is not None
        )
        model = model.replace(disc_body=body)
    options: dict[str, Any] = {"points": points}
    if what == "torsion":
        if model.stage is not None:
            solution = stage_torsion(case, model, points)
        else:
            series = None
            if series_stiffness_nm_per_arcmin is not None:
                from cyclomesh.units import RAD_PER_ARCMIN

                series = float(series_stiffness_nm_per_arcmin) / RAD_PER_ARCMIN
                options["series_stiffness_nm_per_arcmin"] = series_stiffness_nm_per_arcmin
            solution = torsion(case, model, points, series)
    elif model.stage is not None:
        solution = solve_stage_case(case, model)
    else:
        solution = drive(case, model)
    return Result(case, model, what, solution, options)
