"""Equilibrium of the RV cycloid stage: discs held by crank bearings, pressed by the pins.

Model
-----
D identical discs (disc d's eccentric at φ + d·2π/D, d = 0 … D − 1) share one pin ring and
N crankshafts. Crankshaft k runs through crank hole k of every disc, centred at
h_k = r_c·(cos(2πk/N + φt), sin(2πk/N + φt)) from the disc centre (φt = −φ/n2, the
disc's theoretical rotation; the holes are :class:`~cyclomesh.core.pair.CrankHoles`). The
crankshafts sit in the carrier (the output), which carries the torque T. The input (and
with it the crank angle φ) is held, as in a torsional-rigidity test of a reducer.

Each disc is a rigid body with a rotation θ_d (from the stack's rest position on the
loaded flanks, counter-clockwise) and an in-plane translation u_d; the carrier turns by c.
Small displacements (µm against mm) are superposed on the nominal position:

* pin i of disc d closes by δ_i = l_i·(θ_d − φbl,i) + n_i·u_d (moment arm l_i, unloaded
  backlash φbl,i, outward flank normal n_i, all from the mesh core,
  :class:`~cyclomesh.drive.solve.StackMesh`) and carries F_i = F(δ_i⁺) (Eqs. 15–23 of [1]);
* the opposite flank of every tooth space is a second contact of its pin, closing by
  −l'_i·(θ_d − φ'bl,i) + n'_i·u_d (geometry and compliance of the loaded flank of the
  mirror problem, φ'bl,i its unloaded contact rotation from the rest): a translation
  may close it;
* hole k of disc d moves against its crank pin by
  d_dk = u_d + (θ_d − c)·ẑ×h_k + ε_dk (ε_dk the position error of the hole), and its
  roller set (:mod:`cyclomesh.stage.bearing`, Harris & Kotzalas [2]) pushes the crank
  pin with B(|d_dk|)·d_dk/|d_dk| and the disc with the opposite force; an optional
  radial spring k_s of the crankshaft acts in series with it;
* the carrier turns by c + T/k_c with an optional torsional spring k_c.

Equilibrium of every disc (two forces, one moment) and of the carrier (Σ moments of the
bearing forces = T) is the stationarity of the convex potential

    Π = Σ_pins ∫F dδ + Σ_bearings ∫B ds − T·c,

solved at every crank angle by Newton's method on the 1 + 3D unknowns with a
backtracking line search on Π, vectorised over the crank angles, to the root at
round-off (below 1e-12·T/r_c, on while Newton's steps reduce the residual, to 4 ulp of
T/r_c; :func:`~cyclomesh.stage.newton.newton`). With rigid bearings without clearance
(``bearing=None``) the discs cannot move against the carrier (u_d = 0, θ_d = c): the
pins are then the mesh problem of :func:`~cyclomesh.drive.solve.solve_drive`
(reproduced to round-off while the opposite flanks stay open, which the mesh alone does
not model; tested), and the statically indeterminate bearing loads are those of the
stiff limit of identical roller sets without clearance (their homogeneous law
Q ∝ δ^(10/9) fixes the split).

The reverse flanks (negative torque) are solved through the exact mirror of
:mod:`cyclomesh.drive.solve` (crank hole k ↔ (N − k) mod N, the tangential hole error and
y-components negated).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.case import Case, Model, check
from cyclomesh.core.discbody import FreeDiscBody
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.drive.mesh import StackMesh
from cyclomesh.drive.solve import (
    mirror_index,
    stack_meshes,
    torsion_metrics,
    torsion_torques,
    unmirror,
)
from cyclomesh.exceptions import ConvergenceError, DesignError
from cyclomesh.stage.assembly import SupportedJacobians
from cyclomesh.stage.bearing import (
    equivalent_load,
    life_hours,
    rating_life,
)
from cyclomesh.stage.design import StageDesign
from cyclomesh.stage.equilibrium import (
    FORCE_TOLERANCE,
    FRICTION_FIELDS,
    WORK_PARTS,
    ring_mesh,
    solve_direction,
    stage_supports,
)
from cyclomesh.stage.friction import check_stage_friction

__all__ = [
    "StageDesign",
    "Stage",
    "StageTorsion",
    "solve_stage",
    "solve",
    "stage_torsion",
    "stage_torsion_curve",
    "bearing_life",
    "FORCE_TOLERANCE",
    "WORK_PARTS",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Stage:
    """Result of :func:`solve_stage`, SI units; Q torques, A crank angles, D discs, N cranks.

    Attributes
    ----------
    crank_angle : ndarray
        φ [rad], (A,).
    torque : ndarray
        Output torque on the carrier [N·m], (Q,); negative: reverse flanks.
    pin_load, contact_stress : ndarray
        Pin–tooth force on the loaded flank [N] and its Hertzian pressure [Pa],
        (Q, A, D, n1).
    groove_load, groove_stress : ndarray
        Load Fc·cos β of each pin's loaded-flank contact on its groove [N] and its
        Hertzian pressure (Eq. 24 of [1]) [Pa], (Q, A, D, n1); the opposite-flank force,
        0 unless a translation closes it, is not added.
    opposite_pin_load : ndarray
        Force of each pin on the opposite flank of its tooth space [N] (0 unless a
        translation of the disc closes it), (Q, A, D, n1).
    contacts : ndarray
        Loaded pins per disc, (Q, A, D).
    torque_share : ndarray
        Σ F·l of the pins of each disc [N·m], (Q, A, D).
    mesh_force, mesh_force_angle : ndarray
        Resultant of the pin forces on each disc [N] and its direction [rad], (Q, A, D).
    bearing_load, bearing_load_angle : ndarray
        Force of each disc on each crank pin through its bearing [N] and its direction
        [rad, counter-clockwise from x, fixed frame], (Q, A, D, N).
    bearing_deflection : ndarray
        |d_dk|, displacement of the hole against its crank pin [m] (clearance included).
    max_roller_load : ndarray
        Load of the most loaded roller [N], (Q, A, D, N).
    disc_translation_x, disc_translation_y : ndarray
        u_d [m], fixed frame, (Q, A, D).
    disc_rotation : ndarray
        TE of each disc against the pins (Eq. 25 sign: negative when it lags) [rad].
    transmission_error : ndarray
        TE of the output (carrier, with its spring) [rad], (Q, A).
    mesh_transmission_error : ndarray
        TE of the mesh alone (rigid bearings) at the same torque [rad], (Q, A).
    residual : ndarray
        Largest equilibrium residual of each solve [N] (moments over r_c), (Q, A).
    work : dict of ndarray
        Work of every part of the stage on its own deformation [J], (Q, A) each, keys
        :data:`WORK_PARTS`: they add up to T·twist to round-off (virtual work).
    twist : ndarray
        Rotation of the output under T from the rest position (first pin touching, no
        load) [rad], counter-clockwise in the loaded direction's frame: positive with a
        positive torque, (Q, A).
    friction : dict of ndarray or None
        A drive with friction (:mod:`cyclomesh.stage.friction`): per pin, both flanks
        together, (Q, A, D, n1): ``friction_force`` [N], ``power_loss_tooth``,
        ``power_loss_groove`` [W], ``sliding_velocity_tooth``, ``sliding_velocity_groove``
        [m/s] (loaded flank), ``friction_coefficient`` [-], ``film_parameter`` λ [-] of
        the sliding interface (0 without a lubricant or load); ``power_loss_bearing`` [W]
        (Q, A, D, N); ``input_power`` [W] (from the crank pins' forces) and
        ``approach_power`` [W] (a non-conjugate profile's Σ F·v·n), (Q, A). With friction
        ``work`` has a ``friction`` entry (−x·Q, so that the parts add up to T·twist).
    """

    crank_angle: FloatArray
    torque: FloatArray
    pin_load: FloatArray
    opposite_pin_load: FloatArray
    contact_stress: FloatArray
    contacts: NDArray[np.int64]
    torque_share: FloatArray
    mesh_force: FloatArray
    mesh_force_angle: FloatArray
    bearing_load: FloatArray
    bearing_load_angle: FloatArray
    bearing_deflection: FloatArray
    max_roller_load: FloatArray
    disc_translation_x: FloatArray
    disc_translation_y: FloatArray
    disc_rotation: FloatArray
    transmission_error: FloatArray
    mesh_transmission_error: FloatArray
    residual: FloatArray
    groove_load: FloatArray | None = None
    groove_stress: FloatArray | None = None
    work: dict[str, FloatArray] | None = None
    twist: FloatArray | None = None
    friction: dict[str, FloatArray] | None = None


_PER_PIN = {
    "pin_load",
    "opposite_pin_load",
    "groove_load",
    "contact_stress",
    "groove_stress",
    *FRICTION_FIELDS[:7],
}
_PER_CRANK = {
    "bearing_fx",
    "bearing_fy",
    "bearing_deflection",
    "max_roller_load",
    "power_loss_bearing",
}
_PER_DISC = {
    "contacts",
    "torque_share",
    "mesh_fx",
    "mesh_fy",
    "disc_translation_x",
    "disc_translation_y",
    "disc_te",
}
_ODD = {
    "twist",
    "mesh_fy",
    "bearing_fy",
    "disc_translation_y",
    "disc_te",
    "carrier_te",
    "mesh_te",
    "torque_share",
}


OUTPUTS = (
    "pin_load",
    "opposite_pin_load",
    "contact_stress",
    "contacts",
    "torque_share",
    "mesh_force",
    "mesh_force_angle",
    "bearing_load",
    "bearing_load_angle",
    "bearing_deflection",
    "max_roller_load",
    "disc_translation_x",
    "disc_translation_y",
    "disc_rotation",
    "transmission_error",
    "mesh_transmission_error",
    "residual",
    "groove_load",
    "groove_stress",
    "work",
    "twist",
    "friction",
)
"""The results of a :class:`Stage` that :func:`solve` may be asked for (``outputs``)."""
_SOURCES = {
    "mesh_force": ("mesh_fx", "mesh_fy"),
    "mesh_force_angle": ("mesh_fx", "mesh_fy"),
    "bearing_load": ("bearing_fx", "bearing_fy"),
    "bearing_load_angle": ("bearing_fx", "bearing_fy"),
    "disc_rotation": ("disc_te",),
    "transmission_error": ("carrier_te",),
    "mesh_transmission_error": ("mesh_te",),
    "work": (*(f"work_{name}" for name in WORK_PARTS), "work_friction"),
    "friction": FRICTION_FIELDS,
}
"""The fields of :func:`~cyclomesh.stage.equilibrium.solve_direction` each output is made
of (the others: a field of its own name)."""


def _fields(outputs) -> frozenset[str] | None:
    """The fields of :func:`~cyclomesh.stage.equilibrium.solve_direction` behind
    ``outputs`` (None: all)."""
    if outputs is None:
        return None
    unknown = set(outputs) - set(OUTPUTS)
    if unknown:
        raise ValueError(f"stage solve: unknown outputs {sorted(unknown)}; choose from {OUTPUTS}")
    return frozenset(field for name in outputs for field in _SOURCES.get(name, (name,)))


def _reverse(fields: dict[str, FloatArray]) -> dict[str, FloatArray]:
    out = {}
    for name, value in fields.items():
        if name in _PER_PIN:
            arr = unmirror(value, 0, 1, True)
        elif name in _PER_CRANK:
            arr = unmirror(value, 0, 1, False)
            arr = arr[..., mirror_index(arr.shape[-1])]
        elif name in _PER_DISC:
            arr = unmirror(value, 0, 1, False)
        else:
            arr = unmirror(value, 0, None, False)
        out[name] = -arr if name in _ODD else arr
    return out


def solve_stage(
    design: PairDesign,
    stage: StageDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: ArrayLike = 250.0,
    crank_angles: ArrayLike = (0.0,),
    groove_deformation: bool = True,
    discs: int = 1,
    contact_law: str = "half_plane",
) -> Stage:
    """Equilibrium of the RV stage at every crank angle and torque (see the module doc).

    Parameters
    ----------
    design, modification, errors, groove_deformation, discs, contact_law
        As in :func:`~cyclomesh.drive.solve.solve_drive`; errors with ring axes give
        results with the same leading axes (the rings are solved one after the other).
    stage : StageDesign
    torque : float or array_like
        Output torque on the carrier [N·m], not 0; negative loads the reverse flanks.
    crank_angles : array_like
        φ [rad], increasing.

    Returns
    -------
    Stage

    Raises
    ------
    DesignError
        For bad input (as :func:`~cyclomesh.drive.solve.solve_drive`).
    ConvergenceError
        If the equilibrium cannot be solved to round-off; names the crank angle.
    """
    return solve(
        Case(design, modification, errors, torque, crank_angles),
        Model(contact_law, groove_deformation, "rigid", discs, stage),
    )


def solve(
    case: Case,
    model: Model,
    motion: float = 1.0,
    loading: float = 0.0,
    positions: bool = True,
    outputs: Collection[str] | None = None,
    meshes: tuple[StackMesh, StackMesh] | None = None,
    only_at: Mapping[str, Collection[int]] | None = None,
    keep: SupportedJacobians | None = None,
) -> Stage:
    """:func:`solve_stage` of a :class:`~cyclomesh.core.case.Case` and a
    :class:`~cyclomesh.core.case.Model` whose ``stage`` is a :class:`StageDesign`.

    The compliant disc: ``model.disc_body`` a
    :class:`~cyclomesh.core.discbody.FreeDiscBody` (the FE disc condensed on its contacts
    and its crank-hole centres, :func:`cyclomesh.fe.influence.free_influence`), so that the
    crank bearings' and the pins' forces deform one elastic disc
    (:func:`~cyclomesh.stage.equilibrium.body_coupling`); it needs
    ``[stage.crank_bearing]``. A :class:`~cyclomesh.core.discbody.DiscBody` (held holes)
    is refused in one line.

    Friction (``model.friction``, Coulomb coefficients or a lubricant's μ(F) in a drive,
    :mod:`cyclomesh.stage.friction`): ``motion`` +1 the crank drives every torque, −1
    every torque drives the crank back; ``motion = 0`` a torsion test with ``loading`` ±1,
    the output turning with (+1) or against the torque's sense (the branch of rising or
    falling |T|).

    A disc that carries nothing (it floats in its crank bearings' clearance at a light
    torque) has no position determined by equilibrium: it is reported at the point of its
    free set nearest to it centred on its crank pins (:mod:`cyclomesh.stage.floating`),
    whatever the solver's path; ``positions=False`` leaves it where the solve stopped
    (its loads, the twist and every other output are the same; for a caller that reports
    no disc positions, such as the tolerance study).

    ``outputs``: the results wanted (names from :data:`OUTPUTS`), the others None in the
    :class:`Stage`; None: all. Each is the same, bit for bit, whatever else is asked
    (a tolerance ring reads only the output twist, the crank bearings' loads and the
    contact stress: the work split, the groove and disc fields, the rollers and the disc
    positions are then not computed). ``meshes``: the unloaded forward and mirror meshes
    of ``case`` (:func:`~cyclomesh.drive.mesh.stack_meshes` with both directions and, with
    the compliant disc, the tooth of every pin), formed by the caller (a tolerance study
    forms them once a ring, for its mesh-alone solve too); None: formed
    here. ``only_at``: outputs (of ``outputs``, float ones) wanted at some torques only,
    name → indices into the torques; NaN at the others (a tolerance ring reads the contact
    stress at the torque, not at ∓3 % of it). ``keep``: a store kept by a caller that
    solves many rings of one stage design at the same crank angles (a tolerance study:
    :class:`~cyclomesh.stage.assembly.SupportedJacobians`): the compliant disc's supported
    bearing Jacobian, the same for every ring, formed once (the same numbers).
    """
    stage = model.stage
    if not isinstance(stage, StageDesign):
        raise DesignError("stage: the model has no StageDesign (Model(stage=...))")
    fields = _fields(outputs)
    at = {} if only_at is None else {name: set(only_at[name]) for name in only_at}
    if set(at) - (set(OUTPUTS) if outputs is None else set(outputs)):
        raise ValueError(f"stage solve: only_at names outputs not asked for: {sorted(at)}")

    def fields_at(q: int) -> frozenset[str] | None:
        """The fields of torque q."""
        if not at:
            return fields
        left = OUTPUTS if outputs is None else outputs
        return _fields([name for name in left if q in at.get(name, (q,))])

    c = check(case, model)
    body = c.body
    if body is not None and not isinstance(body, FreeDiscBody):
        raise DesignError(
            "stage: the compliant disc needs the crank-hole centres free (the FreeDiscBody of "
            'cyclomesh.fe.influence.free_influence, which disc_body = "fe" resolves to)'
        )
    if body is not None and stage.bearing is None:
        raise DesignError(
            'stage: disc_body = "fe" needs crank bearings ([stage.crank_bearing]): rigid '
            'bearings without clearance hold the hole centres; set disc_body = "rigid"'
        )
    if body is not None and body.count != stage.holes.count:
        raise DesignError(
            f"stage: disc body coefficients for {body.count} crank holes, the design has "
            f"{stage.holes.count}"
        )
    friction = c.friction
    if friction is not None:
        check_stage_friction(friction, stage.bearing)
        if c.ring_shape:
            raise DesignError(
                "friction with [stage] solves one ring at a time: pass pin errors without ring axes"
            )
    torques, discs, phi, ring_shape = c.torques, c.discs, c.phi, c.ring_shape
    rad, tan = stage.hole_errors(discs)
    if meshes is None:
        meshes = stack_meshes(
            c.design,
            c.modification,
            c.errors,
            phi,
            discs,
            c.groove_deformation,
            True,  # both: the opposite flanks of one direction are the mirror's loaded flanks
            True,
            c.contact_law,
            None if body is None else body.pins,  # the tooth of every pin
            False,  # no force angle: the stage's are those of its solved loads
            # the mirror's rests only for a negative torque (its flanks loaded): else only
            # its flanks' geometry and compliance are read, as the opposite flanks
            reverse_rests=bool(np.any(torques < 0)),
        )
    fwd, rev = meshes
    N = stage.holes.count
    mirror_errs = (
        rad[mirror_index(discs)][:, mirror_index(N)],
        -tan[mirror_index(discs)][:, mirror_index(N)],
    )
    supports = stage_supports(stage, discs, np.arange(discs))
    mirror_supports = stage_supports(stage, discs, mirror_index(discs))
    per_ring = []
    for ring in np.ndindex(ring_shape):  # rings one after the other (one ring: ())
        results = []
        f_ring, r_ring = ring_mesh(fwd, ring), ring_mesh(rev, ring)
        caches: tuple[dict, dict] = ({}, {})  # each direction's torque-free arrays
        where = f"ring {np.ravel_multi_index(ring, ring_shape)}, " if ring_shape else ""
        for q, value in enumerate(torques):
            try:
                if value > 0:
                    out = solve_direction(
                        f_ring,
                        r_ring,
                        stage,
                        (rad, tan),
                        float(value),
                        supports,
                        body,
                        friction,
                        motion,
                        loading,
                        positions,
                        caches[0],
                        fields_at(q),
                        keep,
                    )
                else:
                    out = _reverse(
                        solve_direction(
                            r_ring,
                            f_ring,
                            stage,
                            mirror_errs,
                            float(-value),
                            mirror_supports,
                            body,
                            friction,
                            motion,
                            -loading,
                            positions,
                            caches[1],
                            fields_at(q),
                            keep,
                        )
                    )
            except ConvergenceError as exc:
                raise ConvergenceError(
                    f"{where}torque {value:g} N·m: {exc}{_hint(stage)}"
                ) from None
            results.append(out)
        per_ring.append(_by_torque(results))
    if ring_shape:
        out = {
            name: np.stack([r[name] for r in per_ring]).reshape(
                *ring_shape, *per_ring[0][name].shape
            )
            for name in per_ring[0]
        }
    else:  # one ring: its arrays as they are (a stack of one is a copy)
        out = per_ring[0]
    result = _stage(out, phi, torques, stage)
    if outputs is None:
        return result
    return dataclasses.replace(result, **{name: None for name in OUTPUTS if name not in outputs})


def _by_torque(results: list[dict[str, FloatArray]]) -> dict[str, FloatArray]:
    """The fields of every torque stacked (a leading torque axis); NaN at the torques
    where a field was not asked for (``only_at``). One torque: each field's own array
    with the axis added (no copy where it is C-contiguous; the same values)."""
    if len(results) == 1:
        return {name: np.ascontiguousarray(value)[None] for name, value in results[0].items()}
    out = {}
    for name in dict.fromkeys(name for r in results for name in r):
        like = next(r[name] for r in results if name in r)
        out[name] = np.stack(
            [r[name] if name in r else np.full(like.shape, np.nan) for r in results]
        )
    return out


def _stage(
    out: dict[str, FloatArray], phi: FloatArray, torques: FloatArray, stage: StageDesign
) -> Stage:
    """The :class:`Stage` of the fields of :func:`solve` (per torque stacked), None where a
    field was not asked for."""
    te = out.pop("carrier_te", None)
    twist = out.pop("twist", None)
    work = {name: out.pop(f"work_{name}") for name in WORK_PARTS if f"work_{name}" in out}
    if "work_friction" in out:
        work["friction"] = out.pop("work_friction")
    frictional = {name: out.pop(name) for name in FRICTION_FIELDS if name in out}
    if stage.carrier_stiffness is not None:
        if te is not None:
            te = te - torques[:, None] / stage.carrier_stiffness
        if twist is not None:
            twist = twist + torques[:, None] / stage.carrier_stiffness
        if "carrier" in work:
            work["carrier"] = work["carrier"] + (torques**2 / stage.carrier_stiffness)[:, None]
    bfx, bfy = out.pop("bearing_fx", None), out.pop("bearing_fy", None)
    mfx, mfy = out.pop("mesh_fx", None), out.pop("mesh_fy", None)
    bearing = bfx is not None
    mesh = mfx is not None
    return Stage(
        crank_angle=phi,
        torque=torques,
        pin_load=out.get("pin_load"),
        opposite_pin_load=out.get("opposite_pin_load"),
        contact_stress=out.get("contact_stress"),
        groove_load=out.get("groove_load"),
        groove_stress=out.get("groove_stress"),
        contacts=out.get("contacts"),
        torque_share=out.get("torque_share"),
        mesh_force=np.hypot(mfx, mfy) if mesh else None,
        mesh_force_angle=np.arctan2(mfy, mfx) if mesh else None,
        bearing_load=np.hypot(bfx, bfy) if bearing else None,
        bearing_load_angle=np.arctan2(bfy, bfx) if bearing else None,
        bearing_deflection=out.get("bearing_deflection"),
        max_roller_load=out.get("max_roller_load"),
        disc_translation_x=out.get("disc_translation_x"),
        disc_translation_y=out.get("disc_translation_y"),
        disc_rotation=out.get("disc_te"),
        transmission_error=te,
        mesh_transmission_error=out.get("mesh_te"),
        residual=out.get("residual"),
        work=work or None,
        twist=twist,
        friction=frictional or None,
    )


def bearing_life(
    stage_result: Stage, stage: StageDesign, pins: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Equivalent load [N], L10 [million revolutions] and L10h [h] of every crank bearing.

    The equivalent dynamic load is the p-mean (p = 10/3) of the bearing load over the
    crank angles of the result (ISO 281:2007, variable load; the angles should span a
    revolution or whole mesh cycles, evenly spaced). The crank pin turns against its
    hole n1 times per output revolution (the hole turns with the output, the eccentric
    n2 times the other way), so L10h = 10⁶·L10/(60·n1·n_out).

    Returns
    -------
    equivalent, l10, hours : ndarray
        Shape (..., Q, D, N) (ring axes first).
    """
    if stage.bearing is None:
        raise DesignError("stage: the life needs a crank bearing ([stage.crank_bearing])")
    p = equivalent_load(stage_result.bearing_load, axis=-3)
    life = rating_life(stage.bearing.rating(), p)
    return p, life, life_hours(life, pins * stage.output_speed)


@dataclass(frozen=True)
class StageTorsion:
    """Result of :func:`stage_torsion_curve`; rotation (Q, A) [rad], metrics (A,).

    With friction: ``rotation_ascending`` and ``rotation_descending`` the output's TE on the
    branches of rising and falling torque (Q, A) [rad], ``rotation`` (and ``mesh_rotation``)
    their mid curve, ``hysteresis`` the loop's largest width over the torques, ascending −
    descending (A,) [rad], ``stage`` the rising branch's solve (loads at +T_r as loaded)."""

    torque: FloatArray
    rated_torque: float
    rotation: FloatArray
    mesh_rotation: FloatArray
    lost_motion: FloatArray
    torsional_rigidity: FloatArray
    mesh_lost_motion: FloatArray
    mesh_torsional_rigidity: FloatArray
    stage: Stage
    rotation_ascending: FloatArray | None = None
    rotation_descending: FloatArray | None = None
    hysteresis: FloatArray | None = None


def stage_torsion_curve(
    design: PairDesign,
    stage: StageDesign,
    modification: Modification | None,
    errors: PinErrors | None,
    rated_torque: float,
    crank_angles: ArrayLike,
    groove_deformation: bool = True,
    discs: int = 1,
    points: int = 41,
    contact_law: str = "half_plane",
) -> StageTorsion:
    """Torsion curve of the whole stage (mesh, crank bearings, springs in one solve).

    Torques and the definitions of lost motion (±3 %) and rigidity (secant 50–100 %) as
    :func:`~cyclomesh.drive.solve.torsion_curve`; the output rotation is the carrier's TE from
    :func:`solve_stage`, beside the mesh alone (rigid bearings) at the same torques.
    """
    return stage_torsion(
        Case(design, modification, errors, rated_torque, crank_angles),
        Model(contact_law, groove_deformation, "rigid", discs, stage),
        points,
    )


def _hint(stage: StageDesign) -> str:
    """What a failed stage solve asks the user to check: the keys that let the discs float
    (the crank bearings' clearance, the crank-hole errors)."""
    if stage.bearing is None:
        return (
            "; check the crank-hole errors (stage.hole_error_radial_um, hole_error_tangential_um)"
        )
    return (
        "; check stage.crank_bearing.radial_clearance_um (now "
        f"{stage.bearing.clearance * 1e6:.6g} µm; a needle bearing's is a few µm) and the "
        "crank-hole errors"
    )


def stage_torsion(case: Case, model: Model, points: int = 41) -> StageTorsion:
    """:func:`stage_torsion_curve` of a :class:`~cyclomesh.core.case.Case` (``torque``: the
    rated torque T_r) and a :class:`~cyclomesh.core.case.Model` with a stage."""
    rated_torque = case.torque
    torques = torsion_torques(rated_torque, points)
    friction = model.friction is not None and not model.friction.frictionless
    if not friction:
        result = solve(case.replace(torque=torques), model)
        rotation, mesh_rotation = result.transmission_error, result.mesh_transmission_error
        branches = {}
    else:  # the loop: the output turning with the torque's rise (+1) and fall (−1)
        result = solve(case.replace(torque=torques), model, motion=0.0, loading=1.0)
        falling = solve(case.replace(torque=torques), model, motion=0.0, loading=-1.0)
        up, down = result.transmission_error, falling.transmission_error
        rotation = 0.5 * (up + down)
        mesh_rotation = 0.5 * (result.mesh_transmission_error + falling.mesh_transmission_error)
        branches = {
            "rotation_ascending": up,
            "rotation_descending": down,
            "hysteresis": np.max(up - down, axis=-2),
        }
    lost, rigidity = torsion_metrics(rotation, torques, rated_torque)
    mesh_lost, mesh_rigidity = torsion_metrics(mesh_rotation, torques, rated_torque)
    return StageTorsion(
        torque=torques,
        rated_torque=float(rated_torque),
        rotation=rotation,
        mesh_rotation=mesh_rotation,
        lost_motion=lost,
        torsional_rigidity=rigidity,
        mesh_lost_motion=mesh_lost,
        mesh_torsional_rigidity=mesh_rigidity,
        stage=result,
        **branches,
    )
