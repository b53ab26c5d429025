"""Design map: the modification space swept, with the pin-ring tolerances in the loop.

Every candidate modification (a grid over any of Δa, Δρ, δ) is analysed by the full
model of [1] (:func:`cyclomesh.drive.solve.solve_drive`, one disc: bit for bit
:func:`cyclomesh.core.ltca.solve_ltca`) at the study's torque over its crank
angles, with the given pin errors, for the whole stack of discs (``discs``: the torque is
the stack's, split between the discs by their stiffness; per-disc metrics are reduced
over the discs). With a ring axis on the errors (K rings drawn once:
the same rings for every candidate, i.e. common random numbers), each metric is reduced
over the rings to a robust value: the 95th percentile of a metric where larger is worse,
the 5th percentile of one where smaller is worse (``min_contacts``, ``min_play``), taken
as conservative order statistics (a value some ring has), so at least 95 % of rings do
as well as the map says.

Metrics (per candidate, SI inside, engineering units in the Dataset):

* ``max_contact_stress`` — largest pin–tooth Hertzian pressure (Eq. 24) over the discs [Pa];
* ``te_pp`` — peak-to-peak loaded transmission error of the stack (Eq. 25) [rad];
* ``min_contacts`` — fewest pins in contact on a disc over the crank angles [-];
* ``max_mesh_force`` — largest mesh force on a disc (the crank bearing load) [N];
* ``max_torque_share``, ``min_torque_share`` (stacks only) — the range of the torque one
  disc carries over the crank angles and discs [N·m];
* ``max_play``, ``min_play`` — largest and smallest play over the crank angles: the
  TE of the reverse-flank rest position minus that of the forward-flank rest position,
  unloaded (Eq. 11 on both flanks) [rad];
* ``lost_motion`` (optional, it costs two more load solves a candidate, on the same
  unloaded contact) — largest
  TE(−0.03·T) − TE(+0.03·T) over the crank angles [rad]; the reverse flank is solved
  as the forward flank of the system mirrored about the x-axis
  (:func:`cyclomesh.drive.solve.solve_drive` with a negative torque); the play is
  :func:`cyclomesh.drive.solve.play`.

With an RV stage (``stage``: a :class:`~cyclomesh.stage.design.StageDesign`) the metrics
above stay those of the mesh on rigid bearings and one stage solve
(:func:`cyclomesh.stage.solve.solve`) at ±3 %, ±50 % and ±100 % of the map's torque (the
rated torque of the stage metrics) adds (docs/stage.md):

* ``stage_l10`` — L10 of the weakest crank bearing at the torque and the stage's output
  speed (ISO 281, equivalent load over the crank angles) [s; h in the Dataset];
* ``stage_rigidity`` — smallest torsional rigidity of the stage over the crank angles
  (secant 50–100 %, mean of both directions) [N·m/rad];
* ``stage_lost_motion`` — largest lost motion of the stage, TE(−3 %) − TE(+3 %) [rad];
* ``stage_efficiency`` (with ``friction`` too) — forward efficiency of the stage [-]: one
  more stage solve at the torque, the crank driving it with friction in the stage's
  equilibrium (:mod:`cyclomesh.stage.friction`); the other stage metrics stay those of
  the frictionless stage.

The geometry may be swept too (pin-circle radius a, pin radius ρp, eccentricity e,
face width B: :data:`GEOMETRY`); each such candidate is checked like a study's design
(K1 < 1, pins that do not overlap, a profile that is not undercut and seats the pin).
A candidate whose geometry is refused, whose profile is undercut, whose pins interfere
with the disc, or whose solve fails is infeasible with the reason recorded in full,
never dropped. With a compliant disc (``disc_body``) over swept geometry each candidate
geometry gets its own FE body from a builder, built where the candidate is computed
(:func:`candidate_bodies`); over the modification one body serves every candidate.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.ltca import check_contact_law
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.designspace.candidate import (
    DESIGN_PREFIX,
    GEOMETRY,
    METRICS,
    NONFINITE_FAILED,
    OBJECTIVES,
    PARAMETERS,
    ROBUST_PERCENTILE,
    STAGE_METRICS,
    Constraints,
    candidate_metrics,
    parameter,
    parameter_value,
    robust_value,
    stage_metrics,
)
from cyclomesh.exceptions import CyclomeshError, DesignError
from cyclomesh.units import RAD_PER_ARCMIN, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "PARAMETERS",
    "GEOMETRY",
    "check_body_axes",
    "is_builder",
    "candidate_bodies",
    "parameter",
    "parameter_value",
    "METRICS",
    "OBJECTIVES",
    "Constraints",
    "candidate_metrics",
    "DesignTask",
    "evaluate_grid",
    "feasibility",
    "design_map",
    "optimum",
    "stage_metrics",
    "STAGE_METRICS",
]


@dataclass(frozen=True)
class DesignTask:
    """Picklable chunk function: candidates ``start .. stop − 1`` of a grid (C order).

    Parameters
    ----------
    design : PairDesign
    base : Modification
        The study's modification; swept fields are replaced by the grid values.
    axes : tuple of (field, values [SI])
        Swept Modification fields and their values, in grid order.
    errors : PinErrors or None
        Pin errors, possibly with one leading ring axis (robust map).
    torque : float
        [N·m].
    crank_angles : ndarray
        [rad].
    groove_deformation : bool
    lost_motion : bool
        Also compute the lost motion.
    contact_law : {"paper", "half_plane"}
    discs : int
        Discs of the stack (``torque`` is the stack's).
    """

    design: PairDesign
    base: Modification
    axes: tuple[tuple[str, tuple[float, ...]], ...]
    errors: PinErrors | None
    torque: float
    crank_angles: tuple[float, ...]
    groove_deformation: bool = True
    lost_motion: bool = False
    contact_law: str = "half_plane"
    discs: int = 1
    disc_body: Any = "rigid"
    """The base design's disc body for every candidate (Δa, Δρ, δ of a few µm leave the
    body's compliance as it is), or a builder ``(design, modification) -> DiscBody``
    (:class:`cyclomesh.fe.influence.GeometryBody`) called with each candidate's design and
    the base modification: each geometry its own body (:func:`candidate_bodies`)."""
    friction: Any = None
    """:class:`~cyclomesh.core.friction.Friction` for the efficiency metrics, or None."""
    stage: Any = None
    """:class:`~cyclomesh.stage.design.StageDesign` for the stage metrics, or None."""
    stage_disc_body: Any = "rigid"
    """The base design's free disc body (:class:`~cyclomesh.core.discbody.FreeDiscBody`,
    crank-hole centres free) of the stage solves, or ``"rigid"``; like :attr:`disc_body`,
    one for every candidate modification, or a builder of each candidate geometry's."""

    @property
    def shape(self) -> tuple[int, ...]:
        """Grid shape."""
        return tuple(len(values) for _, values in self.axes)

    @property
    def size(self) -> int:
        """Number of candidates."""
        return math.prod(self.shape)

    def modification(self, index: int) -> Modification:
        """The modification of candidate ``index`` (flat, C order) of the grid."""
        return self.candidate(index)[1]

    def candidate(self, index: int) -> tuple[PairDesign, Modification]:
        """Design and modification of candidate ``index`` (flat, C order) of the grid.

        Raises
        ------
        DesignError
            A swept geometry the design refuses (K1 ≥ 1, interfering pins, ...), or a
            profile that is undercut or does not seat the pin
            (:func:`cyclomesh.core.profile.check_profile`); the message is the reason.
        """
        from cyclomesh.core.profile import check_profile

        where = np.unravel_index(index, self.shape)
        changes = {name: values[k] for (name, values), k in zip(self.axes, where, strict=True)}
        geometry = {
            name[len(DESIGN_PREFIX) :]: changes.pop(name)
            for name in list(changes)
            if name.startswith(DESIGN_PREFIX)
        }
        design = self.design
        if geometry:
            if "pin_radius" in geometry:  # the groove moves with the pin: same clearance
                clearance = design.groove_radius - design.pin_radius
                geometry["groove_radius"] = geometry["pin_radius"] + clearance
            design = replace(design, **geometry)  # validated: DesignError with the reason
        modification = replace(self.base, **changes)
        if geometry:
            check_profile(design, modification)
        return design, modification

    def metric_names(self) -> list[str]:
        """Metrics this task computes."""
        skip = set() if self.lost_motion else {"lost_motion"}
        if self.discs == 1:
            skip |= {"max_torque_share", "min_torque_share"}
        if self.friction is None:
            skip |= {"efficiency", "loss_fraction", "stage_efficiency"}
        elif not mesh_friction(self.stage, self.disc_body):
            skip |= {"efficiency", "loss_fraction"}
        if self.stage is None:
            skip |= set(STAGE_METRICS)
        elif self.stage.bearing is None:
            skip.add("stage_l10")
        return [m for m in METRICS if m not in skip]

    def __call__(self, start: int, stop: int) -> dict[str, NDArray[Any]]:
        names = self.metric_names()
        n = stop - start
        out: dict[str, NDArray[Any]] = {m: np.full(n, np.nan) for m in names}
        reason = [""] * n
        for row, index in enumerate(range(start, stop)):
            try:
                design, modification = self.candidate(index)
                disc_body, stage_disc_body = candidate_bodies(self, design)
                values = candidate_metrics(
                    design,
                    modification,
                    self.errors,
                    self.torque,
                    np.asarray(self.crank_angles),
                    self.groove_deformation,
                    self.lost_motion,
                    self.contact_law,
                    self.discs,
                    disc_body,
                    self.friction,
                    self.stage,
                    stage_disc_body,
                )
            except CyclomeshError as exc:  # undercut, interfering pin, failed solve
                reason[row] = str(exc)  # in full: design.nc keeps every character
                continue
            for m in names:
                out[m][row] = robust_value(m, values[m])
        out["reason"] = np.asarray(reason, dtype=str)
        return out


def mesh_friction(stage: Any, disc_body: Any) -> bool:
    """Whether the mesh on rigid bearings is solved with friction (its ``efficiency``):
    not with the compliant disc beside a stage, whose friction only the stage's
    equilibrium takes (as a study's
    :attr:`~cyclomesh.studyfile.schema.CaseInputs.mesh_friction`)."""
    return stage is None or isinstance(disc_body, str)


def is_builder(body: Any) -> bool:
    """Whether a disc body is a builder of each geometry's body (a callable), not
    ``"rigid"`` or one geometry's :class:`~cyclomesh.core.discbody.DiscBody`."""
    return not isinstance(body, str) and callable(body)


def candidate_bodies(task: DesignTask, design: PairDesign) -> tuple[Any, Any]:
    """The disc bodies (mesh, stage) of a candidate of ``design``: a builder's body of
    that geometry with the base modification (one body for every modification of a
    geometry, as a map over the modification shares the base design's), the task's
    own otherwise. Raises DesignError (the candidate's reason) when the body cannot be
    built; the stage's body only with a stage."""
    mesh = task.disc_body(design, task.base) if is_builder(task.disc_body) else task.disc_body
    stage = task.stage_disc_body
    if task.stage is not None and is_builder(stage):
        stage = stage(design, task.base)
    return mesh, stage


def evaluate_grid(
    task: DesignTask,
    backend: Any = None,
    chunk: int | None = None,
    progress: Any = None,
) -> dict[str, NDArray[Any]]:
    """Run a :class:`DesignTask` over its whole grid (serially, or on a tolerance backend).

    The result of every candidate depends only on the candidate, so it is bit-for-bit
    the same for every chunking and backend. Returns arrays of the grid's shape.
    """
    if backend is None:
        flat = dict(task(0, task.size))
        if progress is not None:
            progress(task.size)
    else:
        from cyclomesh.execution.backends import run_chunks

        flat = run_chunks(task, task.size, backend=backend, chunk_size=chunk, progress=progress)
    return {name: value.reshape(task.shape) for name, value in flat.items()}


def feasibility(
    metrics: Mapping[str, NDArray[Any]], constraints: Constraints
) -> tuple[NDArray[np.bool_], NDArray[np.str_]]:
    """Feasible candidates and, for the others, why not (first reason) [-].

    A candidate with a failure reason in ``metrics["reason"]`` is infeasible for it;
    otherwise every constraint must hold.
    """
    checks = constraints.checks()
    width = max([np.asarray(metrics["reason"]).dtype.itemsize // 4, 1])
    width = max([width, *(len(f"{name} violated") for *_, name in checks)])
    reason = np.asarray(metrics["reason"]).astype(f"<U{width}")
    ok = reason == ""
    for metric, op, limit, name in checks:
        value = metrics.get(metric)
        if value is None:
            raise DesignError(f"constraint {name} needs metric {metric}, which was not computed")
        with np.errstate(invalid="ignore"):
            good = value <= limit if op == "<=" else value >= limit
        fail = ok & ~good
        reason[fail] = f"{name} violated"
        ok &= good
    return ok, reason


def optimum(
    metrics: Mapping[str, NDArray[Any]], feasible: NDArray[np.bool_], objective: str
) -> tuple[int, ...] | None:
    """Grid index of the feasible candidate with the smallest objective (first on ties)."""
    metric = OBJECTIVES.get(objective, objective)
    if metric not in metrics:
        raise DesignError(
            f"objective {objective!r}: metric {metric} was not computed "
            f"(choose one of {', '.join(OBJECTIVES)})"
        )
    sign = 1.0 if METRICS[metric][4] else -1.0  # larger is better: maximised
    value = np.where(feasible, sign * metrics[metric], np.inf)
    if not np.any(feasible):
        return None
    return tuple(int(i) for i in np.unravel_index(np.argmin(value), value.shape))


def design_map(
    design: PairDesign,
    axes: Mapping[str, ArrayLike],
    *,
    base: Modification | None = None,
    errors: PinErrors | None = None,
    torque: float = 250.0,
    crank_angles_deg: ArrayLike = (0.0,),
    groove_deformation: bool = True,
    constraints: Constraints | None = None,
    objective: str = "max_contact_stress",
    lost_motion: bool | None = None,
    backend: Any = None,
    chunk: int | None = None,
    progress: Any = None,
    contact_law: str = "half_plane",
    discs: int = 1,
    disc_body: Any = "rigid",
    friction: Any = None,
    stage: Any = None,
    stage_disc_body: Any = "rigid",
) -> xr.Dataset:
    """Design map over a grid of modifications, as a labelled Dataset.

    Parameters
    ----------
    design : PairDesign
        Geometry and materials (SI).
    axes : mapping
        Swept parameters in study units, keys of :data:`PARAMETERS`
        (``pin_circle_radius_um``, ``pin_radius_um``, ``rotation_urad``) and of
        :data:`GEOMETRY` (``pin_circle_radius_mm``, ``pin_radius_mm``, ``eccentricity_mm``,
        ``width_mm``) → values. A geometry the design or the profile check refuses is an
        infeasible candidate with that reason in full.
    base : Modification, optional
        Fixed part of the modification (unswept fields, a profile table).
    errors : PinErrors, optional
        Pin errors; one leading ring axis makes the map robust (percentiles over rings).
    torque : float
        Torque on the stack of discs [N·m].
    crank_angles_deg : array_like
        Crank angles [deg].
    groove_deformation : bool
        Improved model of [1] (pin-groove deformation).
    constraints : Constraints, optional
        Feasibility limits (SI).
    objective : str
        ``max_contact_stress``, ``te_pp``, ``lost_motion`` or ``play`` (minimised), or
        ``efficiency`` (maximised: the loss fraction minimised; needs ``friction``).
    lost_motion : bool, optional
        Compute the lost motion (default: when it is the objective or constrained; a
        lost-motion constraint needs it).
    backend, chunk, progress
        Execution (see :func:`evaluate_grid`).
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (:func:`cyclomesh.core.ltca.solve_ltca`).
    discs : int
        Identical discs on the pin ring (:func:`cyclomesh.drive.solve.solve_drive`); the
        metrics are those of the stack, per-disc ones reduced over the discs.
    disc_body : "rigid", DiscBody or a builder
        The disc body of every candidate: the base design's coefficients (a
        modification of a few µm leaves the body's compliance as it is). One body
        refuses :data:`GEOMETRY` axes (its table belongs to one geometry); a builder
        ``(design, modification) -> DiscBody``
        (:class:`cyclomesh.fe.influence.GeometryBody`) gives each candidate geometry its
        own body, built with the base modification where the candidate is computed.
    friction : Friction, optional
        Friction at the pins (:mod:`cyclomesh.core.friction`): adds the ``efficiency`` and
        ``loss_fraction`` metrics (a second solve per candidate, friction in the
        equilibrium); needed by the ``efficiency`` objective and ``min_efficiency``.
    stage : StageDesign, optional
        The RV stage around the mesh: adds :data:`STAGE_METRICS` (a stage solve at six
        torques per candidate; with ``friction`` one more, friction in the stage's
        equilibrium, for ``stage_efficiency``); needed by the ``stage_*`` objectives and
        constraints.
    stage_disc_body : "rigid", FreeDiscBody or a builder
        The disc body of the stage solves (``disc_body = "fe"`` with ``[stage]``): the
        base design's free body for every candidate modification, or a builder of each
        geometry's, as ``disc_body``.

    Returns
    -------
    xarray.Dataset
        One dimension per swept parameter (coordinate in study units); every metric a
        variable with ``units`` (NaN only where ``reason`` says the candidate failed);
        ``feasible`` and ``reason``; attributes give the optimum and the inputs.
    """
    import xarray as xr

    if not axes:
        raise DesignError("design_space: sweep at least one parameter")
    for key in axes:
        if key not in PARAMETERS and key not in GEOMETRY:
            raise DesignError(
                f"design_space.{key}: not a sweepable parameter "
                f"(one of {', '.join([*PARAMETERS, *GEOMETRY])})"
            )
    if objective not in OBJECTIVES:
        raise DesignError(f"objective {objective!r}: choose one of {', '.join(OBJECTIVES)}")
    check_contact_law(contact_law)
    base = base or Modification()
    constraints = constraints or Constraints()
    if lost_motion is None:
        lost_motion = objective == "lost_motion" or constraints.max_lost_motion is not None
    if not lost_motion and (objective == "lost_motion" or constraints.max_lost_motion):
        raise DesignError("lost_motion=False, but the objective or a constraint needs it")
    if isinstance(discs, bool) or not isinstance(discs, int | np.integer) or discs < 1:
        raise DesignError(f"discs must be a whole number of at least 1, got {discs!r}")
    if friction is not None and friction.frictionless:
        friction = None
    if friction is None and (objective == "efficiency" or constraints.min_efficiency):
        raise DesignError(
            "the efficiency objective and min_efficiency need friction: add [friction]"
        )
    _check_stage(stage, objective, constraints, friction)
    if friction is not None and not mesh_friction(stage, disc_body):
        if objective == "efficiency" or constraints.min_efficiency:
            raise DesignError(
                "the efficiency objective and min_efficiency are the mesh's on rigid "
                'bearings, which has no friction with disc_body = "fe" beside [stage] (the '
                "stage's equilibrium takes it): use stage_efficiency and min_stage_efficiency"
            )
    fixed = any(not (isinstance(b, str) or is_builder(b)) for b in (disc_body, stage_disc_body))
    check_body_axes(fixed, tuple(axes))
    coords = {key: np.atleast_1d(np.asarray(v, dtype=float)) for key, v in axes.items()}
    task = DesignTask(
        design=design,
        base=base,
        axes=tuple(
            (parameter(key)[0], tuple(float(x) * parameter(key)[1] for x in values))
            for key, values in coords.items()
        ),
        errors=errors,
        torque=float(torque),
        crank_angles=tuple(np.deg2rad(np.atleast_1d(np.asarray(crank_angles_deg, float)))),
        groove_deformation=groove_deformation,
        lost_motion=lost_motion,
        contact_law=contact_law,
        discs=int(discs),
        disc_body=disc_body,
        friction=friction,
        stage=stage,
        stage_disc_body=stage_disc_body,
    )
    metrics = evaluate_grid(task, backend, chunk, progress)
    feasible, reason = feasibility(metrics, constraints)
    best = optimum(metrics, feasible, objective)
    dims = tuple(coords)
    data: dict[str, Any] = {}
    for name in task.metric_names():
        var, scale, units, long_name, _ = METRICS[name]
        attrs = {"units": units, "long_name": long_name, "nonfinite": NONFINITE_FAILED}
        data[var] = (dims, metrics[name] / scale, attrs)
    data["feasible"] = (dims, feasible.astype(np.int8), {"units": "1", "long_name": "feasible"})
    data["reason"] = (dims, reason, {"long_name": "why a candidate is infeasible ('' if not)"})
    ds = xr.Dataset(
        data,
        coords={
            key: (key, values, {"units": parameter(key)[2], "long_name": parameter(key)[3]})
            for key, values in coords.items()
        },
    )
    ring_shape = () if errors is None else errors.ring_shape(design.pins)
    rings = math.prod(ring_shape)
    ds.attrs.update(
        {
            "title": "cyclomesh design map",
            "objective": objective,
            "objective_variable": METRICS[OBJECTIVES[objective]][0],
            "torque_nm": float(torque),
            "disc_body": "rigid" if isinstance(disc_body, str) else "fe",
            "stage_disc_body": "rigid" if isinstance(stage_disc_body, str) else "fe",
            "rings": int(rings),
            "robust": int(bool(ring_shape)),
            "robust_percentile": ROBUST_PERCENTILE,
            "groove_deformation": int(bool(groove_deformation)),
            "contact_law": contact_law,
            "discs": int(discs),
            "crank_angles": len(task.crank_angles),
            "feasible_candidates": int(feasible.sum()),
            "candidates": int(task.size),
        }
    )
    if stage is not None:
        ds.attrs["stage"] = 1
        ds.attrs["stage_rated_torque_nm"] = float(torque)
    for name, value in _constraint_attrs(constraints).items():
        ds.attrs[name] = value
    if best is not None:
        for key, k in zip(dims, best, strict=True):
            ds.attrs[f"optimum_{key}"] = float(coords[key][k])
    return ds


def _constraint_attrs(constraints: Constraints) -> dict[str, float]:
    out = {}
    if constraints.max_play is not None:
        out["max_play_arcmin"] = constraints.max_play / RAD_PER_ARCMIN
    if constraints.min_play is not None:
        out["min_play_arcmin"] = constraints.min_play / RAD_PER_ARCMIN
    if constraints.allowable_contact_stress is not None:
        out["allowable_contact_stress_mpa"] = constraints.allowable_contact_stress * 1e-6
    if constraints.max_te_pp is not None:
        out["max_te_pp_arcsec"] = constraints.max_te_pp / RAD_PER_ARCSEC
    if constraints.min_contacts is not None:
        out["min_contacts"] = int(constraints.min_contacts)
    if constraints.max_lost_motion is not None:
        out["max_lost_motion_arcmin"] = constraints.max_lost_motion / RAD_PER_ARCMIN
    if constraints.min_efficiency is not None:
        out["min_efficiency"] = float(constraints.min_efficiency)
    if constraints.min_stage_l10 is not None:
        out["min_stage_l10_h"] = constraints.min_stage_l10 / 3600.0
    if constraints.min_stage_rigidity is not None:
        out["min_stage_rigidity_nm_per_arcmin"] = constraints.min_stage_rigidity * RAD_PER_ARCMIN
    if constraints.max_stage_lost_motion is not None:
        out["max_stage_lost_motion_arcmin"] = constraints.max_stage_lost_motion / RAD_PER_ARCMIN
    if constraints.min_stage_efficiency is not None:
        out["min_stage_efficiency"] = float(constraints.min_stage_efficiency)
    return out


def check_body_axes(compliant: bool, axes: tuple[str, ...]) -> None:
    """One-line DesignError for one compliant disc body (a
    :class:`~cyclomesh.core.discbody.DiscBody`, not a builder) over swept
    :data:`GEOMETRY`: its FE table belongs to one geometry, so every candidate of another
    geometry would be solved with a body that is not its own (``cyclomesh design`` passes
    a builder, :class:`cyclomesh.fe.influence.GeometryBody`, instead)."""
    swept = [key for key in axes if key in GEOMETRY]
    if compliant and swept:
        raise DesignError(
            f"design_space.{swept[0]}: a DiscBody is the FE table of one geometry, not of "
            "each candidate's; pass a builder of each geometry's body "
            "(cyclomesh.fe.influence.GeometryBody) or sweep the modification only"
        )


def _check_stage(stage: Any, objective: str, constraints: Constraints, friction: Any) -> None:
    """One-line DesignError for stage objectives or limits without a stage (or bearing,
    or friction for the stage's efficiency), and for friction the stage does not take."""
    wanted = [m for m in STAGE_METRICS if OBJECTIVES[objective] == m]
    wanted += [m for m, _, _, _ in constraints.checks() if m in STAGE_METRICS]
    if stage is None and wanted:
        raise DesignError(
            f"the {wanted[0]} objective or constraint needs the RV stage: add [stage] "
            "(docs/stage.md)"
        )
    if stage is not None and stage.bearing is None and "stage_l10" in wanted:
        raise DesignError(
            "the stage_l10 objective or min_stage_l10_h needs a crank bearing: add "
            "[stage.crank_bearing]"
        )
    if "stage_efficiency" in wanted and stage is not None and friction is None:
        raise DesignError(
            "the stage_efficiency objective or min_stage_efficiency needs friction: add [friction]"
        )
    if stage is not None and friction is not None:
        from cyclomesh.stage.friction import check_stage_friction

        check_stage_friction(friction, stage.bearing)


def grid_points(axes: Mapping[str, Sequence[float]]) -> list[dict[str, float]]:
    """Every candidate of a grid as {key: value}, C order (the first key slowest)."""
    keys = list(axes)
    return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*axes.values())]
