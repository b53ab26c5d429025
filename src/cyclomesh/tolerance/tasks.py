"""Chunk functions of the tolerance studies: rings → per-ring metrics through the core.

A :class:`RingModel` holds what is fixed across rings (the study's base case as core
objects, the crank angles, the sampling spec); :class:`ToleranceTask` and
:class:`AllocationTask` are picklable callables ``(start, stop) -> {name: array}`` for
:func:`cyclomesh.execution.backends.run_chunks`. They import the core and NumPy only (no
xarray), so worker processes start quickly.

The sampled errors are added to the base case's own per-pin errors (``[errors]`` of
the study file) in study units, then converted to SI exactly as the study loader does,
so that a ring written out as a study file has bit-for-bit the same errors.

Batches: the core solves several rings in one call (its ring axis), and its result for
a ring is bit for bit the same whichever rings share the call (the core sums pin
contributions in a fixed order). A chunk is solved in batches of about
:data:`BLOCK_PIN_STEPS` pin-steps (:func:`block_rings`: 16 rings at 1°, 160 at 10°)
only to bound the memory of one core call, so ring k's metrics depend on (seed, k)
alone. The metrics come straight from the core's arrays
(:func:`cyclomesh.results.dataset.drive_metrics`), without building a Dataset per batch.

Stacks: each ring is drawn once for the pin ring and the whole stack of discs is analysed
on it (:func:`cyclomesh.drive.solve.solve_drive`; one disc is bit for bit
:func:`cyclomesh.core.ltca.solve_ltca`), so the pin errors change the split of the torque
between the discs (``min_torque_share_nm``, ``max_torque_share_nm``) and the mesh force
of each disc (``max_mesh_force_n``).

The RV stage (:meth:`RingModel.stage_metrics`): a batch's rings are solved one after the
other, each ring's unloaded meshes (both flanks) formed once for its mesh-alone metrics
and its three stage solves, which compute only what the metrics read
(:func:`cyclomesh.stage.solve.solve` ``outputs`` and ``only_at``; the same bits as the
full solve of ``cyclomesh run``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.case import Case, Model
from cyclomesh.core.discbody import DiscBody, FreeDiscBody
from cyclomesh.core.pair import Modification, PairDesign, PinErrors, pin_errors_si
from cyclomesh.drive.friction import mean_backdrive_efficiency as ring_backdrive_efficiency
from cyclomesh.drive.friction import mean_efficiency as ring_efficiency
from cyclomesh.drive.solve import drive
from cyclomesh.exceptions import ConvergenceError, CyclomeshError, DesignError
from cyclomesh.results.dataset import drive_metrics
from cyclomesh.results.metrics import STRESS_METRIC
from cyclomesh.tolerance.sampling import RingErrors, ToleranceSpec, draw_ring_errors

__all__ = [
    "BLOCK_PIN_STEPS",
    "block_rings",
    "RingModel",
    "ring_outcomes",
    "ToleranceTask",
    "AllocationTask",
    "STRESS_METRIC",
    "ring_efficiency",
    "ring_backdrive_efficiency",
]

STAGE_OUTPUTS = ("transmission_error", "bearing_load", "contact_stress")
"""What a tolerance ring reads of its stage solve (:meth:`RingModel.stage_metrics`)."""

BLOCK_PIN_STEPS = 16 * 360 * 40
"""Pin-steps (rings × crank angles × pins) per core call: bounds the memory of one call
(about 100 MB of temporaries) while keeping the per-call overhead small."""


def block_rings(angles: int, pins: int, budget: int = BLOCK_PIN_STEPS) -> int:
    """Rings per core call for ``angles`` crank angles and ``pins`` pins (at least 1)."""
    return max(1, budget // max(1, angles * pins))


@dataclass(frozen=True)
class RingModel:
    """The fixed part of a tolerance study.

    Parameters
    ----------
    design, modification : PairDesign, Modification
        Core objects of the base case (SI).
    base_errors_um : dict of ndarray
        The base case's own per-pin errors in study units: ``radial_um`` [µm],
        ``angular_urad`` [µrad], ``pin_radius_um`` [µm], shape (n1,) each.
    base_eccentricity_um : float
        The base case's eccentricity error [µm].
    torque_nm : float
        Torque on the stack of discs [N·m].
    crank_angles_deg : ndarray
        Crank angles φin [deg].
    groove_deformation : bool
        Pin-groove deformation on (the improved model of [1]).
    spec : ToleranceSpec
        Distributions and seed.
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (:func:`cyclomesh.core.ltca.solve_ltca`).
    discs : int
        Identical discs on the pin ring (:func:`cyclomesh.drive.solve.solve_drive`).
    crank_range : (start, stop, step) [deg], optional
        Where ``crank_angles_deg`` came from (written into a ring's study file).
    disc_body : "rigid" or DiscBody
        The disc body (:func:`cyclomesh.core.ltca.solve_ltca`), resolved once by the
        parent and carried to the workers with the task (one table for all rings).
    friction : Friction, optional
        Friction in the equilibrium (:mod:`cyclomesh.core.friction`): every ring's
        forward ``efficiency`` joins its metrics (:func:`ring_efficiency`).
    backdrive : bool
        With friction, also solve every ring back-driven (the output driving the crank,
        :func:`cyclomesh.drive.solve.solve_drive` ``backdrive``): its
        ``backdrive_efficiency`` joins the metrics (:func:`ring_backdrive_efficiency`), at
        the cost of a second solve per ring.
    """

    design: PairDesign
    modification: Modification
    base_errors_um: dict[str, NDArray[np.float64]]
    base_eccentricity_um: float
    torque_nm: float
    crank_angles_deg: NDArray[np.float64]
    groove_deformation: bool
    spec: ToleranceSpec
    contact_law: str = "half_plane"
    discs: int = 1
    crank_range: tuple[float, float, float] | None = None
    disc_body: Any = "rigid"
    stage: Any = None
    """The RV stage (:class:`~cyclomesh.stage.design.StageDesign`, its own hole errors the
    base's), or None: the mesh alone. With a stage every ring is also solved as the whole
    stage (:meth:`stage_metrics`) and draws crank hole errors."""
    base_hole_errors_um: tuple[Any, Any] | None = None
    """The base case's crank hole errors in study units (radial, tangential) [µm], each
    broadcastable to (D, N); None without a stage."""
    stage_disc_body: Any = "rigid"
    """The stage's disc body: "rigid", or the compliant disc with its crank-hole centres
    free (:class:`~cyclomesh.core.discbody.FreeDiscBody`, ``disc_body = "fe"``,
    :func:`cyclomesh.fe.influence.free_influence`). It depends on the geometry only (not
    on the pin or hole errors), so the parent resolves it once (the FE cache) and it
    travels to the workers with the task, like :attr:`disc_body`."""
    friction: Any = None
    backdrive: bool = False
    stage_friction: Any = None
    """Friction in the stage's equilibrium (:mod:`cyclomesh.stage.friction`), or None:
    with a stage, every ring's ``stage_efficiency`` (and with :attr:`backdrive`
    ``stage_backdrive_efficiency``) joins its metrics
    (:func:`cyclomesh.stage.efficiency.stage_efficiency`).
    :attr:`friction` is the mesh's on rigid bearings (None with the compliant disc, whose
    friction only the stage solves)."""

    def __post_init__(self) -> None:
        # With a stage and the compliant disc, its supported bearing Jacobian kept between
        # the rings a process solves (:attr:`stage_keep`). An attribute, not a field: the
        # model's fields (its equality, ``dataclasses.fields``, ``replace``) are the study's
        keep = None
        if self.stage is not None and isinstance(self.stage_disc_body, FreeDiscBody):
            from cyclomesh.stage.assembly import SupportedJacobians

            keep = SupportedJacobians()
        object.__setattr__(self, "_stage_keep", keep)

    @property
    def stage_keep(self) -> Any:
        """With a stage and the compliant disc, the store of its supported bearing Jacobian
        kept between the rings a process solves
        (:class:`~cyclomesh.stage.assembly.SupportedJacobians`: the same for every ring,
        formed once; the same numbers; pickled empty, so each worker fills its own), else
        None."""
        return getattr(self, "_stage_keep", None)

    def draw(self, rings: ArrayLike) -> RingErrors:
        """Sampled errors of the given rings at the stated tolerances [µm, µrad]."""
        holes = None if self.stage is None else (self.discs, self.stage.holes.count)
        return draw_ring_errors(
            self.spec, self.design.pins, self.design.pin_circle_radius, np.asarray(rings), holes
        )

    def total_errors_um(self, drawn: RingErrors) -> dict[str, NDArray[np.float64]]:
        """Base errors plus the drawn ones, in study units (what a study file holds)."""
        out = {}
        for name in ("radial_um", "angular_urad", "pin_radius_um"):
            total = np.broadcast_to(self.base_errors_um[name], getattr(drawn, name).shape).copy()
            total += getattr(drawn, name)
            out[name] = total
        out["eccentricity_um"] = self.base_eccentricity_um + drawn.eccentricity_um
        if drawn.hole_radial_um is not None and self.base_hole_errors_um is not None:
            for name, base in zip(
                ("hole_radial_um", "hole_tangential_um"), self.base_hole_errors_um, strict=True
            ):
                drawn_um = getattr(drawn, name)
                total = np.broadcast_to(np.asarray(base, float), drawn_um.shape).copy()
                total += drawn_um
                out[name] = total
        return out

    def pin_errors(self, drawn: RingErrors) -> PinErrors:
        """Core errors (SI) of a batch of rings: base + drawn, leading axis = ring."""
        total = self.total_errors_um(drawn)
        return pin_errors_si(
            total["radial_um"],
            total["angular_urad"],
            total["pin_radius_um"],
            total["eccentricity_um"],
        )

    def metrics(self, drawn: RingErrors, efficiency: bool = True) -> dict[str, NDArray[Any]]:
        """Per-ring metrics of ``summarize(analyse(...))``, all rings in one core call;
        with a stage ring by ring, the mesh alone and the stage on the ring's unloaded
        meshes formed once (:meth:`_meshes`; a ring's arrays stay in the processor's cache,
        which a batch's do not: a batch of 16 rings' meshes cost a quarter more per ring).

        ``efficiency=False`` leaves out the stage's efficiency (its friction solves), which
        no other metric depends on (an allocation's steps).

        Raises
        ------
        CyclomeshError
            The core's error, prefixed with the first ring that fails.
        """
        try:
            if self.stage is None:
                return self._solve(drawn)
            parts = []
            for i in range(drawn.rings.size):
                ring = drawn.take([i])
                meshes = self._meshes(ring)
                part = self._solve(ring, meshes)
                part.update(self.stage_metrics(ring, efficiency, meshes))
                parts.append(part)
            return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}
        except CyclomeshError:
            self._blame(drawn)
            raise

    @property
    def _drive_body(self) -> DiscBody | None:
        """The mesh alone's disc body on its meshes (None for the rigid disc)."""
        return self.disc_body if isinstance(self.disc_body, DiscBody) else None

    def _meshes(self, drawn: RingErrors) -> tuple[Any, Any] | None:
        """With a stage, the unloaded meshes of the rings ``drawn`` (forward and mirror,
        :func:`cyclomesh.drive.mesh.stack_meshes`, with every contact's flank normals and
        without the force angles no metric reads), formed once for the mesh-alone solve and
        every ring's stage solve; their body is the stage's (the compliant disc's pins) or
        None, the tooth of every pin with either's. None without a stage (the mesh alone
        forms its own)."""
        if self.stage is None:
            return None
        from cyclomesh.drive.mesh import stack_meshes

        stage_body = self.stage_disc_body
        stage_body = stage_body.pins if isinstance(stage_body, FreeDiscBody) else None
        drive_body = self._drive_body
        fwd, rev = stack_meshes(
            self.design,
            self.modification,
            self.pin_errors(drawn),
            np.deg2rad(self.crank_angles_deg),
            self.discs,
            self.groove_deformation,
            True,
            True,
            self.contact_law,
            stage_body if stage_body is not None else drive_body,  # the tooth of every pin
            False,
        )
        if (stage_body if stage_body is not None else drive_body) is not None:
            fwd, rev = (dataclasses.replace(m, body=stage_body) for m in (fwd, rev))
        return fwd, rev

    def stage_metrics(
        self, drawn: RingErrors, efficiency: bool = True, meshes: tuple[Any, Any] | None = None
    ) -> dict[str, NDArray[Any]]:
        """The RV stage's metrics of every ring, solved one after the other.

        Each ring's stage carries its crank hole errors (the base's plus the drawn ones,
        µm → m as the study loader does) and is checked like a study's
        (:meth:`~cyclomesh.stage.design.StageDesign.check_fits`: hole errors that jam the
        stage raise DesignError, a jammed ring); one stage solve at the torque and at
        ∓3 % of it (:func:`cyclomesh.stage.solve.solve`, with :attr:`stage_disc_body`:
        the compliant disc with ``disc_body = "fe"``) gives:

        * ``stage_l10_h_min``: L10h of the weakest crank bearing at the torque [h];
        * ``stage_lost_motion_arcmin_max``: TE(−3 %) − TE(+3 %), the largest over the
          crank angles [arcmin];
        * ``stage_max_crank_bearing_load_n``: the largest crank bearing load [N];
        * ``stage_max_contact_stress_mpa``: the largest pin–tooth pressure in the stage [MPa].

        With :attr:`stage_friction` (and ``efficiency``) one more solve at the torque, the
        crank driving it with friction in the equilibrium, gives ``stage_efficiency``, and
        with :attr:`backdrive` one with the torque driving the crank back
        ``stage_backdrive_efficiency`` (:func:`cyclomesh.stage.efficiency.stage_efficiency`).
        The metrics above stay those of the frictionless stage (as a design map's, and the
        same whether or not friction is given).

        Each solve computes only what the metrics read (``outputs`` of
        :func:`~cyclomesh.stage.solve.solve`: the output twist, the crank bearings' loads,
        the contact stress; the same bits as ``cyclomesh run``'s full solve), on the
        rings' unloaded meshes ``meshes`` (:meth:`_meshes`; formed here if None).
        """
        from cyclomesh.drive.torsion import LOST_MOTION_FRACTION
        from cyclomesh.stage.efficiency import stage_efficiency
        from cyclomesh.stage.equilibrium import ring_mesh
        from cyclomesh.stage.solve import bearing_life, solve
        from cyclomesh.units import M_PER_UM, RAD_PER_ARCMIN

        total = self.total_errors_um(drawn)
        light = LOST_MOTION_FRACTION * self.torque_nm
        torques = np.array([self.torque_nm, -light, light])
        phi = np.deg2rad(self.crank_angles_deg)
        names = (
            "stage_l10_h_min",
            "stage_lost_motion_arcmin_max",
            "stage_max_crank_bearing_load_n",
            "stage_max_contact_stress_mpa",
        )
        friction = self.stage_friction if efficiency else None
        if friction is not None:
            names += ("stage_efficiency",) + (
                ("stage_backdrive_efficiency",) if self.backdrive else ()
            )
        out = {name: np.full(drawn.rings.size, np.nan) for name in names}
        if meshes is None:
            meshes = self._meshes(drawn)
        fwd, rev = meshes
        for i in range(drawn.rings.size):
            stage = self.stage
            if "hole_radial_um" in total:
                stage = dataclasses.replace(
                    stage,
                    hole_error_radial=np.asarray(total["hole_radial_um"][i], float) * M_PER_UM,
                    hole_error_tangential=np.asarray(total["hole_tangential_um"][i], float)
                    * M_PER_UM,
                )
            stage.check_fits(self.design, self.discs)
            model = Model(
                self.contact_law, self.groove_deformation, self.stage_disc_body, self.discs, stage
            )
            errors = pin_errors_si(  # one ring at a time: the errors without a ring axis
                *(total[k][i] for k in ("radial_um", "angular_urad", "pin_radius_um")),
                total["eccentricity_um"][i],
            )
            res = solve(
                Case(self.design, self.modification, errors, torques, phi),
                model,
                positions=False,  # no disc position is a metric: the floating ones left as solved
                outputs=STAGE_OUTPUTS,
                meshes=(ring_mesh(fwd, (i,)), ring_mesh(rev, (i,))),
                only_at={"contact_stress": (0,), "bearing_load": (0,)},  # at the torque
                keep=self.stage_keep,
            )
            te = res.transmission_error  # (Q, A)
            out["stage_lost_motion_arcmin_max"][i] = np.max(te[1] - te[2]) / RAD_PER_ARCMIN
            out["stage_max_crank_bearing_load_n"][i] = np.max(res.bearing_load[0])
            out["stage_max_contact_stress_mpa"][i] = np.max(res.contact_stress[0]) * 1e-6
            if stage.bearing is not None:
                hours = bearing_life(res, stage, self.design.pins)[2][0]
                out["stage_l10_h_min"][i] = np.min(hours)
            if friction is not None:
                case = Case(self.design, self.modification, errors, [self.torque_nm], phi)
                eff = stage_efficiency(
                    case, dataclasses.replace(model, friction=friction), self.backdrive
                )
                for name, value in eff.items():
                    out[name][i] = value
        if self.stage.bearing is None:
            del out["stage_l10_h_min"]
        return out

    @property
    def block_rings(self) -> int:
        """Rings per core call (see :func:`block_rings`)."""
        return block_rings(len(self.crank_angles_deg), self.design.pins * self.discs)

    def _solve(
        self, block: RingErrors, meshes: tuple[Any, Any] | None = None
    ) -> dict[str, NDArray[Any]]:
        """The mesh alone's metrics of the rings ``block`` (on their unloaded meshes
        ``meshes`` of :meth:`_meshes`, else formed by the solve)."""
        if meshes is not None:  # the mesh alone's body (the meshes carry the stage's)
            body = self._drive_body
            if body is not meshes[0].body:
                meshes = tuple(dataclasses.replace(m, body=body) for m in meshes)

        def solve(backdrive: bool = False) -> Any:
            return drive(
                Case(self.design, self.modification, errors, self.torque_nm, angles),
                Model(
                    self.contact_law,
                    self.groove_deformation,
                    self.disc_body,
                    self.discs,
                    friction=self.friction,
                ),
                backdrive,
                ("force_angle",),  # no ring metric reads the force directions
                meshes,
            )

        errors, angles = self.pin_errors(block), np.deg2rad(self.crank_angles_deg)
        result = solve()
        out = drive_metrics(result, self.design.teeth)
        if self.friction is not None:
            out["efficiency"] = ring_efficiency(result, self.design.teeth, self.friction.speed)
        if self.friction is not None and self.backdrive:
            out["backdrive_efficiency"] = ring_backdrive_efficiency(
                result, solve(backdrive=True), self.design.teeth, self.friction.speed
            )
        return out

    def _blame(self, block: RingErrors) -> None:
        """Re-solve ring by ring and raise the core's error naming the failing ring."""
        for i, k in enumerate(block.rings.tolist()):
            try:
                self._solve(block.take([i]))
            except CyclomeshError as exc:
                raise type(exc)(f"ring {k} (seed {self.spec.seed}): {exc}") from None


def _by_blocks(start: int, stop: int, solve: Any, size: int) -> dict[str, NDArray[Any]]:
    """Run ``solve(first, last)`` on batches of at most ``size`` rings covering
    [start, stop) and concatenate the results."""
    parts = [solve(first, min(stop, first + size)) for first in range(start, stop, size)]
    return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}


def ring_outcomes(
    model: RingModel, drawn: RingErrors, efficiency: bool = True
) -> dict[str, NDArray[Any]]:
    """Per-ring metrics of ``drawn`` (:meth:`RingModel.metrics`) with the rings that cannot
    be solved kept as outcomes, not errors.

    * ``jammed`` (bool per ring): the ring's errors jam the disc (a pin overlaps it at
      every rotation, :class:`~cyclomesh.exceptions.DesignError`): there is no contact to
      analyse;
    * ``unsolved`` (bool per ring): a solver did not converge on the ring
      (:class:`~cyclomesh.exceptions.ConvergenceError`), and ``unsolved_reason`` (str per
      ring) is the solver's one-line message ('' for every other ring).

    Either way the ring's metrics are NaN. A batch with such a ring is solved again ring by
    ring, which gives the other rings the same bits (a ring's result does not depend on
    its batch). Any other error propagates, as does one of the base case (no drawn
    errors), solved when no ring of the batch runs: the study stops there.
    """
    try:
        out = model.metrics(drawn, efficiency)
    except (DesignError, ConvergenceError):
        return _one_by_one(model, drawn, efficiency)
    out["jammed"] = np.zeros(drawn.rings.size, dtype=bool)
    out["unsolved"] = np.zeros(drawn.rings.size, dtype=bool)
    out["unsolved_reason"] = np.full(drawn.rings.size, "", dtype=str)
    return out


def _one_by_one(model: RingModel, drawn: RingErrors, efficiency: bool) -> dict[str, NDArray[Any]]:
    """:func:`ring_outcomes` ring by ring."""
    parts: list[dict[str, NDArray[Any]] | None] = []
    jammed, reason = [], []
    for i, k in enumerate(drawn.rings.tolist()):
        part, jam, why = None, False, ""
        try:
            part = model.metrics(drawn.take([i]), efficiency)
        except DesignError:
            jam = True
        except ConvergenceError as exc:
            why = _unprefixed(str(exc), k, model.spec.seed) or "did not converge"
        parts.append(part)
        jammed.append(jam)
        reason.append(why)
    solved = [p for p in parts if p is not None]
    # the metric names and shapes of a ring that runs (the base case's own if none: a
    # failure of the base case is not a ring's, it stops the study)
    like = solved[0] if solved else model.metrics(drawn.take([0]).scaled(np.zeros(1)), efficiency)
    out = {}
    for name, ref in like.items():
        filler = np.full_like(ref, False) if ref.dtype == np.bool_ else np.full(ref.shape, np.nan)
        out[name] = np.concatenate([filler if p is None else p[name] for p in parts])
    out["jammed"] = np.array(jammed, dtype=bool)
    out["unsolved"] = np.array([bool(r) for r in reason], dtype=bool)
    out["unsolved_reason"] = np.asarray(reason, dtype=str)
    return out


def _unprefixed(message: str, ring: int, seed: int) -> str:
    """The solver's message of ring ``ring`` solved alone, without the "ring k (seed s): "
    that :meth:`RingModel.metrics` puts in front (the ring is named beside it) and without
    the core's "ring 0, " (the index of the ring in a batch of one): the message that
    ``cyclomesh run`` gives for the ring's study file."""
    for prefix in (f"ring {ring} (seed {seed}): ", "ring 0, "):
        if message.startswith(prefix):
            message = message[len(prefix) :]
    return message


@dataclass(frozen=True)
class ToleranceTask:
    """Chunk function: per-ring metrics of rings start .. stop − 1 at the stated tolerances.

    ``jammed`` (bool per ring): the ring's errors jam the disc (a pin overlaps it at every
    rotation); ``unsolved`` (bool per ring): a solver did not converge on it, its message
    in ``unsolved_reason``. The metrics of both are NaN (:func:`ring_outcomes`).
    """

    model: RingModel

    def _block(self, first: int, last: int) -> dict[str, NDArray[Any]]:
        drawn = self.model.draw(np.arange(first, last))
        out = ring_outcomes(self.model, drawn)
        out["ring"] = drawn.rings
        return out

    def __call__(self, start: int, stop: int) -> dict[str, NDArray[Any]]:
        return _by_blocks(start, stop, self._block, self.model.block_rings)


STATED_METRICS = (
    "max_contact_stress_mpa",
    "max_mesh_force_n",
    "min_torque_share_nm",
    "max_torque_share_nm",
    "stage_l10_h_min",
    "stage_lost_motion_arcmin_max",
    "stage_max_crank_bearing_load_n",
    "stage_max_contact_stress_mpa",
    "efficiency",
    "backdrive_efficiency",
    "stage_efficiency",
    "stage_backdrive_efficiency",
)
"""Per-ring metrics an allocation also reports at the stated tolerances (f = 1); the
stage's with ``[stage]``, the forward efficiency with ``[friction]`` (the stage's with
both)."""


@dataclass(frozen=True)
class AllocationTask:
    """Chunk function: critical scale factor of every ring (common random numbers).

    The ring's draws are scaled by a factor f (all error kinds together). The ring's
    critical factor is the smallest f at which its peak tooth contact stress exceeds
    the allowable: found by stepping f over ``factors`` (first passage, so a ring that
    once exceeded counts as exceeding at every larger factor) and then bisecting
    within the step where it first exceeds. The result brackets it: ``lower < f* ≤
    upper`` (upper = +inf if the ring never exceeds up to the largest factor).

    The nominal ring (f = 0) must not exceed the allowable (checked by the caller). A
    ring whose scaled errors jam the disc (a pin overlaps it at every rotation), or on
    which a solver does not converge, counts as exceeding at that factor; ``unsolved`` and
    ``unsolved_reason`` (the first such message, naming the factor; ``unsolved_factor`` that
    factor, NaN for the other rings) mark the rings where a solve the allocation needed
    did not converge, and ``jammed`` the rings that jam at
    the stated tolerances (their stated metrics NaN, as those of a ring unsolved there).
    Every step solves the whole batch (rings already settled ride along and their
    results are ignored). One more solve at the stated tolerances (f = 1) gives each
    ring's :data:`STATED_METRICS` (peak stress, the largest mesh force on a disc and, for
    a stack, the range of the torque one disc carries; with friction, the efficiency).

    With friction (``model.friction``) every solve has it in the equilibrium: the
    tangential forces change the torque balance and so the pin loads and the contact
    stress the criterion is on.
    """

    model: RingModel
    factors: tuple[float, ...]
    bisections: int
    allowable_contact_stress_mpa: float
    metric: str = field(default=STRESS_METRIC)

    def _exceeds(
        self, drawn: RingErrors, factor: NDArray[np.float64]
    ) -> tuple[NDArray[np.bool_], list[str]]:
        """Whether each ring, its errors scaled by ``factor``, exceeds the allowable, and
        the solver's message for each ring that could not be solved ('' for the others).

        A ring whose scaled errors jam the disc (a pin overlaps it at every rotation,
        :class:`~cyclomesh.exceptions.DesignError`) cannot meet any allowable: it counts
        as exceeding; so does a ring on which a solver does not converge
        (:class:`~cyclomesh.exceptions.ConvergenceError`: nothing shows that it meets the
        allowable; conservative). The batch is then solved ring by ring, which gives the
        other rings the same bits (a ring's result does not depend on its batch).
        """
        try:
            stress = self.model.metrics(drawn.scaled(factor), efficiency=False)[self.metric]
        except (DesignError, ConvergenceError) as exc:
            if drawn.rings.size == 1:
                why = ""
                if isinstance(exc, ConvergenceError):
                    k = int(drawn.rings[0])
                    why = f"scale factor {factor[0]:.6g}: " + (
                        _unprefixed(str(exc), k, self.model.spec.seed) or "did not converge"
                    )
                return np.array([True]), [why]
            parts = [self._exceeds(drawn.take([i]), factor[i : i + 1]) for i in range(factor.size)]
            return np.concatenate([p[0] for p in parts]), [w for p in parts for w in p[1]]
        return stress > self.allowable_contact_stress_mpa, [""] * drawn.rings.size

    def _block(self, first: int, last: int) -> dict[str, NDArray[Any]]:
        drawn = self.model.draw(np.arange(first, last))
        n = drawn.rings.size
        lower = np.zeros(n)
        upper = np.full(n, np.inf)
        active = np.ones(n, dtype=bool)  # not yet seen exceeding
        reason = [""] * n  # the first failed solve of a ring that the allocation needed
        at = np.full(n, np.nan)  # and its scale factor

        def note(needed: NDArray[np.bool_], why: list[str], factor: NDArray[np.float64]) -> None:
            for i in np.flatnonzero(needed):
                if why[i] and not reason[i]:
                    reason[i], at[i] = why[i], factor[i]

        for f in self.factors:
            if not active.any():
                break
            exceeded, why = self._exceeds(drawn, np.full(n, f))
            note(active, why, np.full(n, f))
            upper[active & exceeded] = f
            lower[active & ~exceeded] = f
            active &= ~exceeded
        bracketed = np.isfinite(upper)
        for _ in range(self.bisections):
            if not bracketed.any():
                break
            mid = np.where(bracketed, 0.5 * (lower + upper), 0.0)
            exceeded, why = self._exceeds(drawn, mid)
            note(bracketed, why, mid)
            upper = np.where(bracketed & exceeded, mid, upper)
            lower = np.where(bracketed & ~exceeded, mid, lower)
        stated = ring_outcomes(self.model, drawn)
        note(
            stated["unsolved"],
            [f"scale factor 1: {w}" if w else "" for w in stated["unsolved_reason"]],
            np.ones(n),
        )
        return {
            "ring": drawn.rings,
            "critical_factor_lower": lower,
            "critical_factor_upper": upper,
            **{name: stated[name] for name in STATED_METRICS if name in stated},
            "jammed": stated["jammed"],
            "unsolved": np.array([bool(r) for r in reason], dtype=bool),
            "unsolved_reason": np.asarray(reason, dtype=str),
            "unsolved_factor": at,
        }

    def __call__(self, start: int, stop: int) -> dict[str, NDArray[Any]]:
        return _by_blocks(start, stop, self._block, self.model.block_rings)
