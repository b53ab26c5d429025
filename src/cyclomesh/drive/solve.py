"""Drive characteristics: both flanks, torque sweeps, play, mesh force, disc stacks.

The core of :mod:`cyclomesh.core.ltca` loads one disc, with a positive torque, on the flank a
counter-clockwise turn of the disc presses onto the pins (the disc lags: TE < 0). This
module builds the characteristics of a whole cycloid stage on top of it, exactly
(the same equations, Eqs. 5–26 of [1], solved to round-off).

Both flanks (the mirror)
------------------------
A negative torque pushes the disc ahead of its theoretical position onto the other flank
of every tooth space (TE > 0). That state is the mirror image, about the x-axis of the
fixed frame, of a forward state: the disc profile is symmetric about a tooth-space bottom
(Δa, Δρ and the rotation modification δ act alike on both flanks), pin i at angle
iψ + εψ,i maps to pin (n1 − i) mod n1 at angle −(iψ + εψ,i) (so with angular error
−εψ,i; radial and radius errors are carried along), a disc centre at crank angle φ maps
to −φ, its theoretical rotation −φ/n2 to +φ/n2 = −(−φ)/n2, and a clockwise (negative)
torque to a counter-clockwise one. Hence, exactly,

    reverse(φ, errors, −T) = mirror of forward(−φ, mirror(errors), T),

with rotations and TE negated, generating angles negated, per-pin arrays re-indexed by
i → (n1 − i) mod n1 and force vectors reflected (y → −y). :func:`mirror_errors` is the one
place that maps a ring to its mirror image.

Play
----
At zero load the disc can sit anywhere between the rest position on the forward flanks
(the first pin a counter-clockwise turn reaches, :func:`~cyclomesh.core.ltca.rest_position`)
and the rest position on the reverse flanks (the first pin a clockwise turn reaches). The
play is TE of the reverse rest position minus TE of the forward one, ≥ 0 [rad]. Both rest
positions follow from one unloaded contact analysis (the forward and the reverse contact
rotation of every pin, :class:`~cyclomesh.core.contact.UnloadedContact`).

Disc stacks
-----------
N identical discs on one pin ring, disc k's eccentric at φ + (k − 1)·2π/N, all turning
by one rotation (they drive one output). Each disc is measured from its own theoretical
position, so one rotation of the stack from theoretical puts every pin of every disc at
its own backlash: the N·n1 pin contacts form one load-sharing problem (Eqs. 15–18), with
the backlash measured from the stack's rest position (the first contact over all discs),
solved exactly by :func:`~cyclomesh.core.loadsharing.share_load`. The torque of disc k is the
sum of its pins' moments, so the total torque splits by the stiffness of the discs.

Mesh force
----------
The pin i presses on the disc along the common normal of pin and flank, through the pin
centre C_i. With w = C_i − O2 (disc centre O2), the outward flank normal n makes the angle
θ = arg n − arg P_s with w (both taken in the tooth frame of the contact, see
:mod:`cyclomesh.core.contact`), so the force on the disc is −F_i·(cos(arg w + θ),
sin(arg w + θ)). The mesh force is the resultant over the pins of a disc, the load its
crank bearing carries; its moment about O2 balances the torque.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.case import (
    Case,
    Model,
    check,
    check_crank_angles,
    check_discs,
    check_pair,
    check_torques,
)
from cyclomesh.core.discbody import DiscBody
from cyclomesh.core.friction import Friction
from cyclomesh.core.kernel import kernel_name
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.core.transmission import gear_ratio, transmission_error
from cyclomesh.drive.friction import FRICTION_FIELDS, FrictionCoupling
from cyclomesh.drive.mesh import (
    FRICTION_PIN,
    OPTIONAL,
    PER_DISC,
    PER_PIN,
    StackMesh,
    load_stack,
    rest_positions,
    reverse_fields,
    stack_meshes,
    stacked_contact,
)
from cyclomesh.drive.mirror import mirror_errors, mirror_index, mirror_problem, unmirror
from cyclomesh.drive.torsion import (
    LOST_MOTION_FRACTION,
    RIGIDITY_FRACTIONS,
    TorsionCurve,
    torsion,
    torsion_curve,
    torsion_metrics,
    torsion_torques,
)

__all__ = [
    "Drive",
    "TorsionCurve",
    "mirror_errors",
    "mirror_index",
    "mirror_problem",
    "play",
    "solve_drive",
    "drive",
    "torsion",
    "StackMesh",
    "stack_meshes",
    "unmirror",
    "check_discs",
    "check_torques",
    "torsion_torques",
    "torsion_curve",
    "torsion_metrics",
    "LOST_MOTION_FRACTION",
    "RIGIDITY_FRACTIONS",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Drive:
    """Result of :func:`solve_drive`, SI units.

    ``...`` are the ring axes of the errors; Q torques, A crank angles, N discs, n1 pins.

    Attributes
    ----------
    crank_angle : ndarray
        φin [rad], (A,); disc k's eccentric is at φin + (k − 1)·2π/N.
    torque : ndarray
        Total torque on the stack [N·m], (Q,); negative loads the reverse flanks.
    pin_load, groove_load, contact_stress, groove_stress : ndarray
        As in :class:`~cyclomesh.core.ltca.LTCA`, on the flank the torque loads, (..., Q, A, N, n1)
        [N, N, Pa, Pa].
    backlash : ndarray
        Unloaded angular distance of each pin from the stack's rest position on the loaded
        flanks (Eq. 11) [rad], ≥ 0; +inf where unreachable.
    overlap : ndarray
        Interference with the opposite (unloaded) flank [rad], 0 if none (None when
        :func:`solve_drive` was asked to leave it out, ``without``).
    profile_angle : ndarray
        Generating angle φ1 of the contact [rad]: in [−π, 0] on the forward flank, in
        [0, π] on the reverse flank.
    contact_radius, moment_arm, curvature_radius : ndarray
        Contact geometry [m].
    force_angle : ndarray
        Direction of the force of each pin on its disc [rad, counter-clockwise from x,
        fixed frame] (along the common normal, from the pin into the disc); None when
        left out (``without``), as ``mesh_force_angle``.
    torque_share : ndarray
        Torque carried by each disc, Σ F·l (Eqs. 16, 18), signed like the torque, (..., Q, A, N)
        [N·m].
    contacts : ndarray
        Pins in contact of each disc, (..., Q, A, N): load above
        :data:`~cyclomesh.core.ltca.CONTACT_LOAD_FRACTION` of the stack's largest pin load.
    mesh_force, mesh_force_angle : ndarray
        Magnitude [N] and direction [rad, counter-clockwise from x, fixed frame] of the
        resultant of the pin forces on each disc, (..., Q, A, N).
    rest_rotation : ndarray
        φc − φt of the stack at rest on the loaded flanks [rad], (..., Q, A).
    loaded_rotation : ndarray
        Further rotation under the torque [rad] (counter-clockwise positive).
    transmission_error : ndarray
        TE of the stack (Eq. 25) [rad]: negative for a positive torque.
    gear_ratio : ndarray
        Instantaneous ratio of the stack (Eq. 26) [-].
    play : ndarray
        TE of the reverse rest position minus TE of the forward one [rad], ≥ 0, (..., A).
    friction : dict or None
        With friction (:mod:`cyclomesh.drive.friction`): ``friction_force``,
        ``sliding_velocity_tooth``, ``sliding_velocity_groove``, ``power_loss_tooth``,
        ``power_loss_groove``, ``friction_coefficient`` per pin (..., Q, A, N, n1) [N, m/s,
        m/s, W, W, -], ``input_torque`` [N·m] and ``power_loss_bearing`` [W] per disc
        (..., Q, A, N); None without.
    """

    crank_angle: FloatArray
    torque: FloatArray
    pin_load: FloatArray
    groove_load: FloatArray
    contact_stress: FloatArray
    groove_stress: FloatArray
    backlash: FloatArray
    overlap: FloatArray | None
    profile_angle: FloatArray
    contact_radius: FloatArray
    moment_arm: FloatArray
    curvature_radius: FloatArray
    force_angle: FloatArray | None
    torque_share: FloatArray
    contacts: NDArray[np.int64]
    mesh_force: FloatArray
    mesh_force_angle: FloatArray | None
    rest_rotation: FloatArray
    loaded_rotation: FloatArray
    transmission_error: FloatArray
    gear_ratio: FloatArray
    play: FloatArray
    friction: dict[str, FloatArray] | None = None


def play(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    crank_angles: ArrayLike = (0.0,),
    discs: int = 1,
) -> FloatArray:
    """Unloaded play of a stack at each crank angle (Eq. 11 of [1] on both flanks) [rad].

    play = TE(reverse-flank rest) − TE(forward-flank rest) = φc,fwd − φc,rev, the same
    number :func:`solve_drive` reports, without solving any load. Error-free, for Δa and
    Δρ it is 2[Δρ − Δa·√(1 − K1²)]/(e·n2) to first order; a rotation δ adds exactly 2δ.

    Parameters
    ----------
    crank_angles : array_like
        Crank angles φin [rad] of disc 1, one-dimensional and increasing.
    discs : int
        Number N of discs sharing the ring.

    Returns
    -------
    ndarray
        Shape ``(..., A)`` (ring axes of the errors first) [rad]; negative where the disc
        interferes with the pins.
    """
    modification = modification or Modification()
    errors = errors or PinErrors()
    phi = check_crank_angles(crank_angles)
    discs = check_discs(discs)
    check_pair(design, modification, errors)
    rest, reverse_rest = rest_positions(
        stacked_contact(design, modification, errors, phi, discs), design.pins, discs
    )
    return rest - reverse_rest


def solve_drive(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: ArrayLike = 250.0,
    crank_angles: ArrayLike = (0.0,),
    groove_deformation: bool = True,
    discs: int = 1,
    contact_law: str = "half_plane",
    disc_body: str | DiscBody = "rigid",
    friction: Friction | None = None,
    backdrive: bool = False,
    without: Collection[str] = (),
) -> Drive:
    """Loaded contact of a stack of discs on both flanks over a list of torques.

    Solves Eqs. 5–26 of [1] for every torque (positive: forward flanks, as in
    :func:`~cyclomesh.core.ltca.solve_ltca`; negative: reverse flanks, through the exact mirror
    described in :mod:`cyclomesh.drive.solve`), for ``discs`` identical discs sharing the ring
    and one rotation. With one disc and a positive torque the result is bit for bit that
    of :func:`~cyclomesh.core.ltca.solve_ltca`.

    Parameters
    ----------
    design : PairDesign
    modification : Modification, optional
        Tooth profile modification (Eq. 3).
    errors : PinErrors, optional
        Pin ring errors (Eq. 5), shared by all discs; leading axes are rings.
    torque : float or array_like
        Total torque on the stack [N·m], one value or a list; not 0.
    crank_angles : array_like
        Crank angles φin [rad] of disc 1, one-dimensional and increasing.
    groove_deformation : bool
        The "improved model" (Eq. 19) or the "current model".
    discs : int
        Number N of discs; disc k's eccentric is at φin + (k − 1)·2π/N.
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (:func:`~cyclomesh.core.ltca.solve_ltca`).
    disc_body : "rigid" or DiscBody
        Rigid disc, or the compliant disc body (:func:`~cyclomesh.core.ltca.solve_ltca`);
        the discs of a stack share no body.
    friction : Friction, optional
        Friction at the pin contacts (:mod:`cyclomesh.core.friction`), in the torque
        balance; None (or all coefficients 0): the paper's frictionless model, bit for bit.
    backdrive : bool
        The sense of the motion with friction: False, the crank drives every torque (it
        turns counter-clockwise, φ increasing, against a positive torque and clockwise
        against a negative one); True, every torque drives the crank back (the motion
        reversed, the same flanks loaded).
    without : collection of str
        Fields the caller does not read, None in the result: ``force_angle`` (with
        ``mesh_force_angle``) and ``overlap`` (:data:`cyclomesh.drive.mesh.OPTIONAL`), for
        callers that reduce a few metrics (a design map's candidates, a tolerance study's
        rings); every other field is the same, bit for bit.

    Returns
    -------
    Drive

    Raises
    ------
    DesignError
        For a torque of 0, bad crank angles, a bad number of discs, an undercut profile
        or interfering pins.
    ConvergenceError
        If a solver fails; the message names the torque and crank angle.
    """
    return drive(
        Case(design, modification, errors, torque, crank_angles),
        Model(contact_law, groove_deformation, disc_body, discs, friction=friction),
        backdrive,
        without,
    )


def drive(
    case: Case,
    model: Model,
    backdrive: bool = False,
    without: Collection[str] = (),
    meshes: tuple[StackMesh | None, StackMesh | None] | None = None,
) -> Drive:
    """:func:`solve_drive` of a :class:`~cyclomesh.core.case.Case` and a
    :class:`~cyclomesh.core.case.Model` (the mesh alone: ``model.stage`` is not read);
    ``backdrive``: the sense of the motion with ``model.friction``; ``without``: fields
    left out (:func:`solve_drive`). ``meshes``: the unloaded forward and mirror meshes of
    the case and model (:func:`~cyclomesh.drive.mesh.stack_meshes`, with the flank normals
    of every contact; the directions its torques load), formed by the caller (a tolerance
    study with the RV stage shares them with the stage's solves); None: formed here."""
    without = frozenset(without)
    if not without <= OPTIONAL:
        raise ValueError(
            f"solve_drive without {sorted(without - OPTIONAL)}: only {sorted(OPTIONAL)} "
            "may be left out"
        )
    c = check(case, model)
    design, phi, torques = c.design, c.phi, c.torques
    fwd, rev = (
        meshes
        if meshes is not None
        else stack_meshes(
            design,
            c.modification,
            c.errors,
            phi,
            c.discs,
            c.groove_deformation,
            bool(np.any(torques > 0)),
            bool(np.any(torques < 0)),
            c.contact_law,
            c.body,
            "force_angle" not in without,
            # the NumPy reference's normals cost a tenth of its contact: without the force
            # angles (and friction, which reads every pin's) only the loaded pins' are taken
            not (
                "force_angle" in without
                and c.friction is None
                and c.modification.profile is None
                and kernel_name() == "numpy"
            ),
        )
    )
    if fwd is not None:
        play = fwd.rest - fwd.reverse_rest
    else:
        play = unmirror(rev.rest - rev.reverse_rest, -1, None, False)

    per_torque = []
    friction = c.friction
    sense = -1.0 if backdrive else 1.0
    for value in torques:
        mesh = fwd if value > 0 else rev
        coupling = None
        if friction is not None:  # a negative torque: the crank turns clockwise, which
            coupling = FrictionCoupling(mesh, friction, sense)  # the mirror turns over
        fields = load_stack(mesh, abs(float(value)), coupling, without)
        geo = mesh.geo
        fields.update(
            backlash=mesh.backlash.reshape(geo.rotation.shape),
            profile_angle=geo.profile_angle,
            contact_radius=geo.contact_radius,
            moment_arm=geo.moment_arm,
            curvature_radius=geo.curvature_radius,
            rest_rotation=mesh.rest,
        )
        if value < 0:
            fields = reverse_fields(fields)
        per_torque.append(fields)

    def stacked(name: str) -> FloatArray:
        axis = -4 if PER_PIN.get(name, name in FRICTION_PIN) else -3 if name in PER_DISC else -2
        if len(per_torque) == 1:  # one torque: its axis as a view, no copy
            return np.expand_dims(per_torque[0][name], axis)
        return np.stack([fields[name] for fields in per_torque], axis=axis)

    out = {name: None if name in without else stacked(name) for name in PER_PIN}
    if friction is not None:
        out["friction"] = {name: stacked(name) for name in FRICTION_FIELDS}
    te = transmission_error(out["rest_rotation"], out["loaded_rotation"])
    fx, fy = out.pop("mesh_force_x"), out.pop("mesh_force_y")
    return Drive(
        crank_angle=phi,
        torque=torques,
        mesh_force=np.hypot(fx, fy),
        mesh_force_angle=None if "force_angle" in without else np.arctan2(fy, fx),
        transmission_error=te,
        gear_ratio=gear_ratio(te, phi, design.teeth),
        play=play,
        **out,
    )
