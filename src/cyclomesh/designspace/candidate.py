"""One candidate of a design map: the sweepable parameters, the metrics and their limits,
and a candidate's metrics (the mesh's, and the RV stage's with ``stage``), SI units.

:mod:`cyclomesh.designspace.sweep` runs these over a grid (its module doc names every
metric and cites the model, Li et al., Machines 10 (2022) 672).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.drive.solve import LOST_MOTION_FRACTION, solve_drive
from cyclomesh.exceptions import DesignError
from cyclomesh.quantities import QUANTITIES
from cyclomesh.units import RAD_PER_ARCMIN, RAD_PER_ARCSEC

NONFINITE_FAILED = "NaN: the candidate failed (undercut, interference, no solution): see reason"
"""The ``nonfinite`` attribute of the metric variables of a design map."""

FloatArray = NDArray[np.float64]


PARAMETERS: dict[str, tuple[str, float, str, str]] = {
    # study key: (Modification field, SI per study unit, units, long name)
    "pin_circle_radius_um": ("pin_circle_radius", 1e-6, "um", "shift modification Δa"),
    "pin_radius_um": ("pin_radius", 1e-6, "um", "equidistant modification Δρ"),
    "rotation_urad": ("rotation", 1e-6, "urad", "rotation modification Δδ"),
}
"""Sweepable modification parameters: study key → (field of Modification, scale to SI,
units, name)."""

GEOMETRY: dict[str, tuple[str, float, str, str]] = {
    # study key: (PairDesign field, SI per study unit, units, long name)
    "pin_circle_radius_mm": ("pin_circle_radius", 1e-3, "mm", "pin-circle radius a"),
    "pin_radius_mm": ("pin_radius", 1e-3, "mm", "pin radius ρp"),
    "eccentricity_mm": ("eccentricity", 1e-3, "mm", "eccentricity e"),
    "width_mm": ("width", 1e-3, "mm", "face width B"),
}
"""Sweepable geometry: study key → (field of PairDesign, scale to SI, units, name). A
swept pin radius keeps the groove clearance ρg − ρp of the base design."""

DESIGN_PREFIX = "design."  # prefix of a PairDesign field in DesignTask.axes


def parameter(key: str) -> tuple[str, float, str, str]:
    """(field, SI per study unit, units, long name) of a sweepable key; the field of a
    geometry key is prefixed ``design.``."""
    if key in PARAMETERS:
        return PARAMETERS[key]
    field, scale, units, name = GEOMETRY[key]
    return DESIGN_PREFIX + field, scale, units, name


def parameter_value(design: PairDesign, modification: Modification, key: str) -> float:
    """The value of a sweepable key in a design and modification [study units]."""
    field, scale, _, _ = parameter(key)
    if field.startswith(DESIGN_PREFIX):
        return float(getattr(design, field[len(DESIGN_PREFIX) :])) / scale
    return float(getattr(modification, field)) / scale


METRICS: dict[str, tuple[str, float, str, str, bool]] = {
    # core name: (Dataset variable, SI per unit, units, long name, larger is worse)
    "max_contact_stress": (
        "max_contact_stress_mpa",
        1e6,
        "MPa",
        "max. pin-tooth Hertzian pressure",
        True,
    ),
    "te_pp": ("te_pp_arcsec", RAD_PER_ARCSEC, "arcsec", "peak-to-peak loaded TE", True),
    "min_contacts": ("min_contacts", 1.0, "1", "fewest loaded pins", False),
    "max_mesh_force": (
        "max_mesh_force_n",
        1.0,
        "N",
        "largest mesh force on a disc (crank bearing load)",
        True,
    ),
    "max_torque_share": ("max_torque_share_nm", 1.0, "N·m", "largest torque on one disc", True),
    "min_torque_share": ("min_torque_share_nm", 1.0, "N·m", "smallest torque on one disc", False),
    "max_play": ("play_arcmin", RAD_PER_ARCMIN, "arcmin", "largest unloaded play", True),
    "min_play": ("min_play_arcmin", RAD_PER_ARCMIN, "arcmin", "smallest unloaded play", False),
    "lost_motion": (
        "lost_motion_arcmin",
        RAD_PER_ARCMIN,
        "arcmin",
        "lost motion TE(-3 % T) - TE(+3 % T)",
        True,
    ),
    "efficiency": ("efficiency", 1.0, "1", "forward efficiency (with friction)", False),
    "stage_l10": ("stage_l10_h_min", 3600.0, "h", "L10h of the weakest crank bearing", False),
    "stage_rigidity": (
        "stage_torsional_rigidity_nm_per_arcmin_min",
        1.0 / RAD_PER_ARCMIN,
        "N·m/arcmin",
        "smallest torsional rigidity of the stage",
        False,
    ),
    "stage_lost_motion": (
        "stage_lost_motion_arcmin_max",
        RAD_PER_ARCMIN,
        "arcmin",
        "largest lost motion of the stage",
        True,
    ),
    "loss_fraction": (
        "loss_fraction",
        1.0,
        "1",
        "power loss over input power, 1 - efficiency (with friction)",
        True,
    ),
    "stage_efficiency": (
        "stage_efficiency",
        1.0,
        "1",
        "forward efficiency of the RV stage (with friction)",
        False,
    ),
}
METRICS = {
    key: (var, si, QUANTITIES[var].unit, QUANTITIES[var].long_name, worse)
    for key, (var, si, _, _, worse) in METRICS.items()
}
"""Metrics: core name → (Dataset variable, SI per unit, units, long name, larger is worse);
units and long names are those of the variable's row of :data:`cyclomesh.quantities.QUANTITIES`."""

OBJECTIVES: dict[str, str] = {
    "max_contact_stress": "max_contact_stress",
    "te_pp": "te_pp",
    "lost_motion": "lost_motion",
    "play": "max_play",
    "efficiency": "loss_fraction",
    "stage_l10": "stage_l10",
    "stage_rigidity": "stage_rigidity",
    "stage_lost_motion": "stage_lost_motion",
    "stage_efficiency": "stage_efficiency",
}
"""Objective names of a study → metric, minimised where larger is worse, else maximised
(``stage_l10``, ``stage_rigidity``, ``stage_efficiency``)."""

STAGE_METRICS = ("stage_l10", "stage_rigidity", "stage_lost_motion", "stage_efficiency")
"""Metrics of the RV stage (a map with ``stage``; ``stage_efficiency`` with friction too)."""

ROBUST_PERCENTILE = 95.0


@dataclass(frozen=True)
class Constraints:
    """Feasibility limits of a design map, SI units; None = no limit.

    Parameters
    ----------
    max_play, min_play : float, optional
        Bounds on the play [rad] (``max_play`` on the largest, ``min_play`` on the smallest).
    allowable_contact_stress : float, optional
        Upper bound on the max. contact stress [Pa].
    max_te_pp : float, optional
        Upper bound on the peak-to-peak TE [rad].
    min_contacts : int, optional
        Lower bound on the fewest loaded pins.
    max_lost_motion : float, optional
        Upper bound on the lost motion [rad] (the map then computes it).
    min_efficiency : float, optional
        Lower bound on the forward efficiency [-] (needs friction).
    min_stage_l10 : float, optional
        Lower bound on L10 of the weakest crank bearing [s] (needs a stage with a bearing).
    min_stage_rigidity : float, optional
        Lower bound on the stage's smallest torsional rigidity [N·m/rad] (needs a stage).
    max_stage_lost_motion : float, optional
        Upper bound on the stage's largest lost motion [rad] (needs a stage).
    min_stage_efficiency : float, optional
        Lower bound on the stage's forward efficiency [-] (needs a stage and friction).
    """

    max_play: float | None = None
    min_play: float | None = None
    allowable_contact_stress: float | None = None
    max_te_pp: float | None = None
    min_contacts: int | None = None
    max_lost_motion: float | None = None
    min_efficiency: float | None = None
    min_stage_l10: float | None = None
    min_stage_rigidity: float | None = None
    max_stage_lost_motion: float | None = None
    min_stage_efficiency: float | None = None

    def checks(self) -> list[tuple[str, str, float, str]]:
        """(metric, "<=" or ">=", limit [SI], name) of every limit set."""
        out = []
        for metric, op, value, name in (
            ("max_play", "<=", self.max_play, "max_play"),
            ("min_play", ">=", self.min_play, "min_play"),
            ("max_contact_stress", "<=", self.allowable_contact_stress, "allowable_stress"),
            ("te_pp", "<=", self.max_te_pp, "max_te_pp"),
            ("min_contacts", ">=", self.min_contacts, "min_contacts"),
            ("lost_motion", "<=", self.max_lost_motion, "max_lost_motion"),
            ("efficiency", ">=", self.min_efficiency, "min_efficiency"),
            ("stage_l10", ">=", self.min_stage_l10, "min_stage_l10"),
            ("stage_rigidity", ">=", self.min_stage_rigidity, "min_stage_rigidity"),
            ("stage_lost_motion", "<=", self.max_stage_lost_motion, "max_stage_lost_motion"),
            ("stage_efficiency", ">=", self.min_stage_efficiency, "min_stage_efficiency"),
        ):
            if value is not None:
                out.append((metric, op, float(value), name))
        return out


_UNREAD = ("force_angle", "overlap")
"""Fields of the drive no metric of a candidate reads (left out of its solves:
:func:`cyclomesh.drive.solve.solve_drive` ``without``)."""


def candidate_metrics(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors | None,
    torque: float,
    crank_angles: ArrayLike,
    groove_deformation: bool = True,
    lost_motion: bool = False,
    contact_law: str = "half_plane",
    discs: int = 1,
    disc_body: Any = "rigid",
    friction: Any = None,
    stage: Any = None,
    stage_disc_body: Any = "rigid",
) -> dict[str, FloatArray]:
    """Metrics of one candidate modification (see module doc), per ring, SI units.

    ``contact_law`` is the tooth term of the contact law (:func:`cyclomesh.core.ltca.solve_ltca`);
    ``torque`` [N·m] is the torque on the stack of ``discs`` discs
    (:func:`cyclomesh.drive.solve.solve_drive`). With ``friction``
    (:class:`~cyclomesh.core.friction.Friction`) a second solve, friction in the equilibrium,
    gives the forward ``efficiency`` and ``loss_fraction`` (the other metrics stay those of
    the frictionless model, as without it). With ``stage``
    (:class:`~cyclomesh.stage.design.StageDesign`) :func:`stage_metrics` adds the stage's,
    solved with ``stage_disc_body`` (``"rigid"`` or the free disc body); with friction too,
    the stage's forward ``stage_efficiency``.

    Returns
    -------
    dict of ndarray
        Keys of :data:`METRICS` (``lost_motion`` only if asked, the efficiency only with
        friction, the stage's only with a stage), each of the errors' ring shape.
    """
    if not (isinstance(torque, int | float) and math.isfinite(torque) and torque > 0):
        raise DesignError(f"torque must be a positive number of N·m, got {torque!r}")
    phi = np.atleast_1d(np.asarray(crank_angles, float))
    # one unloaded contact for the loaded solve, the play and the lost motion's ±3 %
    light = LOST_MOTION_FRACTION * torque
    torques = [torque, -light, light] if lost_motion else [torque]
    res = solve_drive(
        design,
        modification,
        errors,
        torques,
        phi,
        groove_deformation,
        discs,
        contact_law=contact_law,
        disc_body=disc_body,
        without=_UNREAD,
    )
    te = res.transmission_error  # (..., torque, angle), the stack's
    angles_discs = (-2, -1)
    out = {
        "max_contact_stress": res.contact_stress[..., 0, :, :, :].max(axis=(-3, -2, -1)),
        "te_pp": te[..., 0, :].max(axis=-1) - te[..., 0, :].min(axis=-1),
        "min_contacts": res.contacts[..., 0, :, :].min(axis=angles_discs).astype(float),
        "max_mesh_force": res.mesh_force[..., 0, :, :].max(axis=angles_discs),
        "max_play": res.play.max(axis=-1),
        "min_play": res.play.min(axis=-1),
    }
    if discs > 1:
        share = res.torque_share[..., 0, :, :]
        out["max_torque_share"] = share.max(axis=angles_discs)
        out["min_torque_share"] = share.min(axis=angles_discs)
    if lost_motion:
        out["lost_motion"] = np.max(te[..., 1, :] - te[..., 2, :], axis=-1)
    mesh_friction = stage is None or isinstance(disc_body, str)  # not the FE disc's
    if friction is not None and not friction.frictionless and mesh_friction:
        fr = solve_drive(
            design,
            modification,
            errors,
            [torque],
            phi,
            groove_deformation,
            discs,
            contact_law=contact_law,
            disc_body=disc_body,
            friction=friction,
            without=_UNREAD,
        ).friction
        loss = np.sum(fr["power_loss_tooth"] + fr["power_loss_groove"], axis=(-2, -1))
        loss = np.mean(loss + np.sum(fr["power_loss_bearing"], axis=-1), axis=-1)[..., 0]
        p_out = torque * friction.speed / design.teeth
        out["efficiency"] = p_out / (p_out + loss)
        out["loss_fraction"] = loss / (p_out + loss)
    if stage is not None:
        out.update(
            stage_metrics(
                design,
                modification,
                errors,
                torque,
                phi,
                stage,
                groove_deformation,
                contact_law,
                discs,
                stage_disc_body,
                friction,
            )
        )
    return out


def stage_metrics(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors | None,
    torque: float,
    crank_angles: FloatArray,
    stage: Any,
    groove_deformation: bool = True,
    contact_law: str = "half_plane",
    discs: int = 1,
    disc_body: Any = "rigid",
    friction: Any = None,
) -> dict[str, FloatArray]:
    """The RV stage's metrics of a candidate, per ring, SI units (see the module doc).

    One stage solve at ±3 %, ±50 % and ±100 % of ``torque`` [N·m] (the rated torque T_r
    of the catalogue definitions, :func:`cyclomesh.drive.torsion.torsion_metrics`); L10
    [s] at +T_r (:func:`cyclomesh.stage.solve.bearing_life`), only with a crank bearing.
    ``disc_body``: ``"rigid"`` or the free disc body of the stage
    (:class:`~cyclomesh.core.discbody.FreeDiscBody`, ``disc_body = "fe"``). With
    ``friction`` (:class:`~cyclomesh.core.friction.Friction`, not frictionless) one more
    solve per ring at +T_r, the crank driving it with friction in the stage's equilibrium,
    gives ``stage_efficiency`` [-] (:func:`cyclomesh.stage.efficiency.stage_efficiency`,
    as a tolerance ring's); the other metrics stay those of the frictionless stage.

    Raises
    ------
    DesignError
        A stage that does not fit the candidate (rollers wider than the disc, holes that
        jam), or a failed solve (ConvergenceError).
    """
    from cyclomesh.core.case import Case, Model
    from cyclomesh.drive.torsion import torsion_metrics, torsion_torques
    from cyclomesh.stage.solve import bearing_life, solve

    stage.check_fits(design, discs)
    torques = torsion_torques(torque, 2)
    res = solve(
        Case(design, modification, errors, torques, crank_angles),
        Model(contact_law, groove_deformation, disc_body, discs, stage),
    )
    lost, rigidity = torsion_metrics(res.transmission_error, torques, torque)
    out = {"stage_rigidity": rigidity.min(axis=-1), "stage_lost_motion": lost.max(axis=-1)}
    if stage.bearing is not None:
        at = int(np.flatnonzero(torques == torque)[0])
        _, _, hours = bearing_life(res, stage, design.pins)  # (..., Q, D, N)
        out["stage_l10"] = hours[..., at, :, :].min(axis=(-2, -1)) * 3600.0
    if friction is not None and not friction.frictionless:
        out["stage_efficiency"] = _stage_efficiency(
            Case(design, modification, errors, [torque], crank_angles),
            Model(contact_law, groove_deformation, disc_body, discs, stage, friction),
        )
    return out


def _stage_efficiency(case: Any, model: Any) -> FloatArray:
    """``stage_efficiency`` of every ring of ``case`` (the ring shape of its errors; the
    stage with friction solves one ring at a time)."""
    from cyclomesh.core.pair import PinErrors
    from cyclomesh.stage.efficiency import stage_efficiency

    errors = case.errors if case.errors is not None else PinErrors()
    pins = case.design.pins
    shape = errors.ring_shape(pins)
    out = np.empty(shape)
    for ring in np.ndindex(shape):
        one = PinErrors(
            *(
                np.broadcast_to(np.asarray(getattr(errors, k), float), (*shape, pins))[ring]
                if np.ndim(getattr(errors, k))
                else getattr(errors, k)
                for k in ("radial", "angular", "pin_radius")
            ),
            np.broadcast_to(np.asarray(errors.eccentricity, float), shape)[ring],
        )
        out[ring] = stage_efficiency(case.replace(errors=one), model)["stage_efficiency"]
    return out


def robust_value(name: str, values: FloatArray) -> float:
    """Reduce a metric over rings: 95th percentile if larger is worse, else 5th.

    Conservative order statistics (numpy's ``higher``/``lower`` methods): the value is one
    that a ring actually has, and at least 95 % of the rings do as well or better.
    """
    if values.ndim == 0:
        return float(values)
    if METRICS[name][4]:
        return float(np.percentile(values.reshape(-1), ROBUST_PERCENTILE, method="higher"))
    return float(np.percentile(values.reshape(-1), 100.0 - ROBUST_PERCENTILE, method="lower"))
