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

import math
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
from cyclomesh.core.contact import UnloadedContact, contact_normal, unloaded_contact
from cyclomesh.core.discbody import DiscBody, share_load_coupled, tooth_index
from cyclomesh.core.fields import CONTACT_FIELDS, contact_fields
from cyclomesh.core.loadsharing import share_load
from cyclomesh.core.ltca import (
    locate_failure,
    pin_compliance,
    rest_position,
)
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.core.transmission import gear_ratio, transmission_error
from cyclomesh.exceptions import ConvergenceError, DesignError
from cyclomesh.quantities import QUANTITIES

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

LOST_MOTION_FRACTION = 0.03
"""Lost motion is measured at ±3 % of the rated torque."""
RIGIDITY_FRACTIONS = (0.5, 1.0)
"""Torsional rigidity is the secant between 50 % and 100 % of the rated torque."""


def mirror_index(pins: int) -> NDArray[np.int64]:
    """Index of the mirror image of every pin: pin i ↔ pin (n1 − i) mod n1 (0-based)."""
    return (-np.arange(pins)) % pins


def mirror_errors(errors: PinErrors, pins: int) -> PinErrors:
    """The pin ring reflected about the x-axis of the fixed frame.

    Pin i at angle iψ + εψ,i becomes pin (n1 − i) mod n1 at angle −iψ − εψ,i, i.e. with
    angular error −εψ,i; its radial and radius errors go with it; the eccentricity error
    is unchanged. The mapping is an involution.

    Parameters
    ----------
    errors : PinErrors
        Errors of the ring (SI), leading axes are rings.
    pins : int
        n1.
    """
    shape = (*errors.ring_shape(pins), pins)
    index = mirror_index(pins)

    def per_pin(value: ArrayLike) -> FloatArray:
        return np.broadcast_to(np.asarray(value, float), shape)[..., index]

    return PinErrors(
        radial=per_pin(errors.radial),
        angular=-per_pin(errors.angular),
        pin_radius=per_pin(errors.pin_radius),
        eccentricity=errors.eccentricity,
    )


def mirror_problem(
    modification: Modification, errors: PinErrors, pins: int
) -> tuple[Modification, PinErrors]:
    """The gear pair reflected about the x-axis: the one place that maps a problem to its
    mirror image (used for the reverse flanks).

    Δa, Δρ and the rotation modification δ are symmetric about a tooth-space bottom, so a
    modification made of them is its own mirror image; a modification that is not (a
    tabulated profile deviation, per tooth or not) must provide ``mirrored()``, which
    is used when present. The ring goes through :func:`mirror_errors`.
    """
    mirrored = getattr(modification, "mirrored", None)
    return (mirrored() if callable(mirrored) else modification), mirror_errors(errors, pins)


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
        Interference with the opposite (unloaded) flank [rad], 0 if none.
    profile_angle : ndarray
        Generating angle φ1 of the contact [rad]: in [−π, 0] on the forward flank, in
        [0, π] on the reverse flank.
    contact_radius, moment_arm, curvature_radius : ndarray
        Contact geometry [m].
    force_angle : ndarray
        Direction of the force of each pin on its disc [rad, counter-clockwise from x,
        fixed frame] (along the common normal, from the pin into the disc).
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
    """

    crank_angle: FloatArray
    torque: FloatArray
    pin_load: FloatArray
    groove_load: FloatArray
    contact_stress: FloatArray
    groove_stress: FloatArray
    backlash: FloatArray
    overlap: FloatArray
    profile_angle: FloatArray
    contact_radius: FloatArray
    moment_arm: FloatArray
    curvature_radius: FloatArray
    force_angle: FloatArray
    torque_share: FloatArray
    contacts: NDArray[np.int64]
    mesh_force: FloatArray
    mesh_force_angle: FloatArray
    rest_rotation: FloatArray
    loaded_rotation: FloatArray
    transmission_error: FloatArray
    gear_ratio: FloatArray
    play: FloatArray


@dataclass(frozen=True)
class StackMesh:
    """Unloaded state of a stack on its forward flanks, in the (possibly mirrored) frame: the
    steps of :func:`solve_drive` before the load sharing. Fields: ``design``; ``geo``
    (:class:`~cyclomesh.core.contact.UnloadedContact`, arrays (..., A, N, n1)); ``rest`` and
    ``reverse_rest`` (rest rotation on the loaded and the opposite flanks [rad], (..., A));
    ``backlash`` (φbl from the stack's rest [rad], (..., A, N·n1)); ``alpha``, ``gamma``
    (compliance of δ = F(α − γ ln F) [m/N], (..., A, N·n1)); ``normal_x``, ``normal_y``
    (outward flank normal, fixed frame, (..., A, N, n1): the force of pin i on its disc is
    −F_i·n, a counter-clockwise disc rotation θ closes the gap by l_i·θ, a translation u by
    n·u); ``ring_shape``; ``phi`` (crank angles of disc 1 in this frame [rad])."""

    design: PairDesign
    geo: UnloadedContact  # arrays (..., A, N, n1)
    rest: FloatArray  # (..., A)
    reverse_rest: FloatArray  # (..., A), rest on the opposite flanks
    backlash: FloatArray  # (..., A, N·n1)
    alpha: FloatArray
    gamma: FloatArray
    normal_x: FloatArray  # (..., A, N, n1): outward normal of the contact, fixed frame
    normal_y: FloatArray
    ring_shape: tuple
    phi: FloatArray
    body: DiscBody | None = None
    tooth: NDArray | None = None  # (A, N·n1): tooth space of every contact (compliant disc)


def _disc_angles(phi: FloatArray, discs: int) -> FloatArray:
    """Eccentric angles of the discs, shape (N·A,), disc after disc [rad]."""
    offsets = 2.0 * np.pi * np.arange(discs) / discs
    return (offsets[:, None] + phi[None, :]).ravel()


def _stack(arr: FloatArray, discs: int, n_angles: int) -> FloatArray:
    """(..., N·A, n1) → (..., A, N, n1)."""
    shaped = arr.reshape(*arr.shape[:-2], discs, n_angles, arr.shape[-1])
    return np.moveaxis(shaped, -3, -2)


def _stacked_contact(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors,
    phi: FloatArray,
    discs: int,
) -> UnloadedContact:
    """Unloaded contact of every disc of a stack, arrays (..., A, N, n1) (Eqs. 5–11)."""
    raw = unloaded_contact(design, modification, errors, _disc_angles(phi, discs))
    return UnloadedContact(
        **{
            name: _stack(getattr(raw, name), discs, phi.size)
            for name in UnloadedContact.__dataclass_fields__
        }
    )


def _rests(geo: UnloadedContact, pins: int, discs: int) -> tuple[FloatArray, FloatArray]:
    """Rest positions of a stack on the forward and on the opposite flanks [rad], (..., A).

    Forward: the smallest conditioned contact rotation (:func:`~cyclomesh.core.ltca.rest_position`,
    Eq. 11); opposite: the largest conditioned reverse-flank contact rotation.
    """
    flat = (*geo.rotation.shape[:-2], discs * pins)
    arm = geo.moment_arm.reshape(flat)
    rest = rest_position(geo.rotation.reshape(flat), arm)
    reverse_rest = -rest_position(-geo.reverse_rotation.reshape(flat), arm)
    return rest, reverse_rest


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
    rest, reverse_rest = _rests(
        _stacked_contact(design, modification, errors, phi, discs), design.pins, discs
    )
    return rest - reverse_rest


def _mesh(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors,
    phi: FloatArray,
    discs: int,
    groove_deformation: bool,
    contact_law: str = "half_plane",
    body: DiscBody | None = None,
) -> StackMesh:
    """Unloaded contact, rest positions and compliance of a stack (forward flanks)."""
    ring_shape = errors.ring_shape(design.pins)
    geo = _stacked_contact(design, modification, errors, phi, discs)
    flat = (*geo.rotation.shape[:-2], discs * design.pins)
    rest, reverse_rest = _rests(geo, design.pins, discs)
    alpha, gamma = pin_compliance(geo, design, groove_deformation, contact_law)
    offsets = 2.0 * np.pi * np.arange(discs) / discs
    nx, ny = contact_normal(
        design,
        modification,
        errors,
        phi[:, None] + offsets[None, :],
        geo.profile_angle,
        geo.pin_radius,
    )
    return StackMesh(
        design=design,
        geo=geo,
        rest=rest,
        reverse_rest=reverse_rest,
        backlash=geo.rotation.reshape(flat) - rest[..., None],
        alpha=alpha.reshape(flat),
        gamma=gamma.reshape(flat),
        normal_x=nx,
        normal_y=ny,
        ring_shape=ring_shape,
        phi=phi,
        body=body,
        tooth=None
        if body is None
        else tooth_index(design.pins, design.pitch, _disc_angles(phi, discs))
        .reshape(discs, phi.size, design.pins)
        .transpose(1, 0, 2)
        .reshape(phi.size, discs * design.pins),
    )


def _load(mesh: StackMesh, torque: float) -> dict[str, FloatArray]:
    """Loaded state of a stack under a positive torque, in the mesh's frame."""
    geo = mesh.geo
    flat_arm = mesh.backlash.shape
    try:
        if mesh.body is None:
            loaded, force = share_load(
                mesh.backlash, geo.moment_arm.reshape(flat_arm), mesh.alpha, mesh.gamma, torque
            )
        else:
            loaded, force = share_load_coupled(
                mesh.backlash,
                geo.moment_arm.reshape(flat_arm),
                mesh.alpha,
                mesh.gamma,
                torque,
                mesh.body,
                mesh.tooth,
                geo.profile_angle.reshape(flat_arm),
                groups=geo.rotation.shape[-2],
            )
    except ConvergenceError as exc:
        err = locate_failure(exc, (*mesh.ring_shape, mesh.phi.size), mesh.phi)
        raise ConvergenceError(f"torque {torque:g} N·m: {err}") from None
    force = force.reshape(geo.rotation.shape)
    fields = contact_fields(
        CONTACT_FIELDS,
        mesh.design,
        geo,
        force,
        rotation=(mesh.rest + loaded)[..., None, None],
        normal=(mesh.normal_x, mesh.normal_y),
        stack_axes=2,
    )
    return {"pin_load": force, **fields, "loaded_rotation": loaded}


def stack_meshes(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors,
    phi: FloatArray,
    discs: int,
    groove_deformation: bool,
    forward: bool,
    reverse: bool,
    contact_law: str = "half_plane",
    body: DiscBody | None = None,
) -> tuple[StackMesh | None, StackMesh | None]:
    """The unloaded meshes of the forward flanks and of the mirror problem (reverse flanks),
    as needed; the mirror problem is solved on the crank angles −φ reversed, and
    :func:`unmirror` maps its arrays back (Eqs. 5–23 of [1]).

    The mirrored problem uses the same body coefficients: the disc (profile, bore and
    the crank holes at 2πk/N) is symmetric about its x-axis.
    """
    fwd = rev = None
    args = (discs, groove_deformation, contact_law, body)
    if forward:
        fwd = _mesh(design, modification, errors, phi, *args)
    if reverse:
        mod_m, errors_m = mirror_problem(modification, errors, design.pins)
        # the mirror of crank angle φ is −φ; solve increasing angles and flip back below
        rev = _mesh(design, mod_m, errors_m, -phi[::-1], *args)
    return fwd, rev


def unmirror(arr: FloatArray, angle_axis: int, disc_axis: int | None, pins: bool) -> FloatArray:
    """Map an array of the mirrored problem back onto the reverse flanks.

    Crank angle −φ → φ (the mirrored problem is solved on the reversed angles), disc k at
    −φ − (k − 1)·2π/N is disc (1 − k) mod N + 1 of the mirrored stack, pin i is pin
    (n1 − i) mod n1.
    """
    out = np.flip(arr, axis=angle_axis)
    if disc_axis is not None:
        out = np.take(out, mirror_index(out.shape[disc_axis]), axis=disc_axis)
    if pins:
        out = out[..., mirror_index(out.shape[-1])]
    return out


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
        Model(contact_law, groove_deformation, disc_body, discs),
    )


def drive(case: Case, model: Model) -> Drive:
    """:func:`solve_drive` of a :class:`~cyclomesh.core.case.Case` and a
    :class:`~cyclomesh.core.case.Model` (the mesh alone: ``model.stage`` is not read)."""
    c = check(case, model)
    design, phi, torques = c.design, c.phi, c.torques
    fwd, rev = stack_meshes(
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
    )
    if fwd is not None:
        play = fwd.rest - fwd.reverse_rest
    else:
        play = unmirror(rev.rest - rev.reverse_rest, -1, None, False)

    per_torque = []
    for value in torques:
        mesh = fwd if value > 0 else rev
        fields = _load(mesh, abs(float(value)))
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
            fields = _reverse(fields)
        per_torque.append(fields)

    def stacked(name: str) -> FloatArray:
        axis = -4 if _PIN[name] else -3 if name in _PER_DISC else -2
        return np.stack([fields[name] for fields in per_torque], axis=axis)

    out = {name: stacked(name) for name in _PIN}
    te = transmission_error(out["rest_rotation"], out["loaded_rotation"])
    fx, fy = out.pop("mesh_force_x"), out.pop("mesh_force_y")
    return Drive(
        crank_angle=phi,
        torque=torques,
        mesh_force=np.hypot(fx, fy),
        mesh_force_angle=np.arctan2(fy, fx),
        transmission_error=te,
        gear_ratio=gear_ratio(te, phi, design.teeth),
        play=play,
        **out,
    )


# field: per pin (True: (..., A, N, n1)) or per disc/angle (False: (..., A, N) or (..., A))
_PIN = {
    "pin_load": True,
    "groove_load": True,
    "contact_stress": True,
    "groove_stress": True,
    "backlash": True,
    "overlap": True,
    "profile_angle": True,
    "contact_radius": True,
    "moment_arm": True,
    "curvature_radius": True,
    "force_angle": True,
    "torque_share": False,
    "contacts": False,
    "mesh_force_x": False,
    "mesh_force_y": False,
    "rest_rotation": False,
    "loaded_rotation": False,
}
_ODD = {name for name in _PIN if name in QUANTITIES and QUANTITIES[name].parity < 0} | {
    "mesh_force_y"
}
"""Fields that change sign in the mirror image: the registry's parity
(:data:`cyclomesh.quantities.QUANTITIES`), and the y component of the mesh force."""
_PER_DISC = {"torque_share", "contacts", "mesh_force_x", "mesh_force_y", "max_contact_stress"}


def _reverse(fields: dict[str, FloatArray]) -> dict[str, FloatArray]:
    """Fields of the mirrored forward problem mapped back onto the reverse flanks."""
    out = {}
    for name, value in fields.items():
        if _PIN.get(name, False):
            arr = unmirror(value, -3, -2, True)
        elif name in _PER_DISC:
            arr = unmirror(value, -2, -1, False)
        else:
            arr = unmirror(value, -1, None, False)
        if name in _ODD:
            arr = -arr
        out[name] = arr
    return out


# --- torsion curve -------------------------------------------------------------------


def torsion_torques(rated_torque: float, points: int = 41) -> FloatArray:
    """Torques of a torsion curve, symmetric from −T_r to +T_r [N·m].

    ``points`` torques evenly spaced from −T_r to +T_r, 0 left out, with ±3 %, ±50 % and
    ±100 % of T_r always included exactly (an evenly spaced torque within 1e-9·T_r of one
    of them is replaced by it), sorted.

    Raises
    ------
    DesignError
        For a rated torque that is not a positive number, or fewer than 2 points.
    """
    if not (isinstance(rated_torque, int | float) and math.isfinite(rated_torque)) or (
        rated_torque <= 0
    ):
        raise DesignError(f"rated_torque_nm must be a positive number, got {rated_torque!r}")
    if isinstance(points, bool) or not isinstance(points, int | np.integer) or points < 2:
        raise DesignError(f"points must be a whole number of at least 2, got {points!r}")
    fractions = (LOST_MOTION_FRACTION, *RIGIDITY_FRACTIONS)
    required = np.array([sign * f * rated_torque for f in fractions for sign in (-1.0, 1.0)])
    even = np.linspace(-rated_torque, rated_torque, int(points))
    near = np.min(np.abs(even[:, None] - required[None, :]), axis=1) <= 1e-9 * rated_torque
    keep = even[~near & (np.abs(even) > 1e-9 * rated_torque)]
    return np.sort(np.concatenate([keep, required]))


def _at(torques: FloatArray, value: float) -> int:
    hit = np.flatnonzero(torques == value)
    if hit.size == 0:
        raise DesignError(f"the torsion curve needs the torque {value:g} N·m")
    return int(hit[0])


def torsion_metrics(
    rotation: FloatArray, torques: FloatArray, rated_torque: float
) -> tuple[FloatArray, FloatArray]:
    """Lost motion and torsional rigidity from a torsion curve.

    lost motion(φ) = TE(−0.03·T_r, φ) − TE(+0.03·T_r, φ);
    torsional rigidity(φ) = mean over the two directions of 0.5·T_r/|TE(±T_r, φ) − TE(±0.5·T_r, φ)|.

    Parameters
    ----------
    rotation : ndarray
        TE (disc rotation from its theoretical position) [rad], torque on axis −2.
    torques : ndarray
        The torques [N·m], containing ±0.03, ±0.5, ±1 times ``rated_torque`` exactly.
    rated_torque : float
        T_r [N·m].

    Returns
    -------
    lost_motion : ndarray
        [rad], shape of ``rotation`` without the torque axis.
    rigidity : ndarray
        [N·m/rad], same shape.
    """

    def te(fraction: float) -> FloatArray:
        return rotation[..., _at(torques, fraction * rated_torque), :]

    lost = te(-LOST_MOTION_FRACTION) - te(LOST_MOTION_FRACTION)
    half, full = RIGIDITY_FRACTIONS
    rigidity = 0.0
    for sign in (-1.0, 1.0):
        rigidity = rigidity + 0.5 * (
            (full - half) * rated_torque / np.abs(te(sign * full) - te(sign * half))
        )
    return lost, rigidity


@dataclass(frozen=True)
class TorsionCurve:
    """Result of :func:`torsion_curve`, SI units; ``...`` ring axes, Q torques, A angles.

    Attributes
    ----------
    crank_angle : ndarray
        φin [rad], (A,).
    torque : ndarray
        Torque on the stack [N·m], (Q,).
    rated_torque : float
        T_r [N·m].
    rotation : ndarray
        TE of the stack (rotation from its theoretical position) [rad], (..., Q, A).
    contacts : ndarray
        Loaded pins per disc, (..., Q, A, N).
    max_contact_stress : ndarray
        Largest pin-tooth pressure per disc [Pa], (..., Q, A, N).
    torque_share : ndarray
        Torque per disc [N·m], (..., Q, A, N).
    play, lost_motion : ndarray
        [rad], (..., A).
    torsional_rigidity : ndarray
        [N·m/rad], (..., A).
    series_stiffness : float or None
        Stiffness of the rest of the drive in series [N·m/rad].
    drive_rotation, drive_lost_motion, drive_torsional_rigidity : ndarray or None
        The same for the whole drive (mesh in series with ``series_stiffness``).
    """

    crank_angle: FloatArray
    torque: FloatArray
    rated_torque: float
    rotation: FloatArray
    contacts: NDArray[np.int64]
    max_contact_stress: FloatArray
    torque_share: FloatArray
    play: FloatArray
    lost_motion: FloatArray
    torsional_rigidity: FloatArray
    series_stiffness: float | None = None
    drive_rotation: FloatArray | None = None
    drive_lost_motion: FloatArray | None = None
    drive_torsional_rigidity: FloatArray | None = None


def torsion_curve(
    design: PairDesign,
    modification: Modification | None,
    errors: PinErrors | None,
    rated_torque: float,
    crank_angles: ArrayLike,
    groove_deformation: bool = True,
    discs: int = 1,
    points: int = 41,
    series_stiffness: float | None = None,
    contact_law: str = "half_plane",
    disc_body: str | DiscBody = "rigid",
) -> TorsionCurve:
    """Torsion curve of the cycloid-pin mesh: rotation against torque, both directions.

    Torques from :func:`torsion_torques`; lost motion and rigidity from
    :func:`torsion_metrics`; the play as in :func:`solve_drive`. Everything is solved
    with Eqs. 5–26 of [1] on both flanks (see :mod:`cyclomesh.drive.solve`). This is the mesh
    alone; ``series_stiffness`` adds the rest of the drive (crank bearings, crankshafts,
    first stage) as a linear torsional spring in series: whole-drive rotation =
    mesh rotation − T/k_series.

    Parameters
    ----------
    design, modification, errors
        As in :func:`solve_drive`.
    rated_torque : float
        T_r [N·m] of the stack.
    crank_angles : array_like
        φin [rad], increasing.
    groove_deformation : bool
    discs : int
    points : int
        Evenly spaced torques from −T_r to +T_r (see :func:`torsion_torques`).
    series_stiffness : float, optional
        k_series [N·m/rad], > 0.
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (:func:`~cyclomesh.core.ltca.solve_ltca`).
    disc_body : "rigid" or DiscBody
        Rigid or compliant disc body (:func:`solve_drive`).

    Returns
    -------
    TorsionCurve
    """
    return torsion(
        Case(design, modification, errors, rated_torque, crank_angles),
        Model(contact_law, groove_deformation, disc_body, discs),
        points,
        series_stiffness,
    )


def torsion(
    case: Case, model: Model, points: int = 41, series_stiffness: float | None = None
) -> TorsionCurve:
    """:func:`torsion_curve` of a :class:`~cyclomesh.core.case.Case` (``torque``: the rated
    torque T_r) and a :class:`~cyclomesh.core.case.Model` (the mesh alone)."""
    rated_torque = case.torque
    torques = torsion_torques(rated_torque, points)
    check_discs(model.discs)
    if series_stiffness is not None and not (
        isinstance(series_stiffness, int | float)
        and math.isfinite(series_stiffness)
        and series_stiffness > 0
    ):
        raise DesignError(f"series_stiffness must be a positive number, got {series_stiffness!r}")
    c = check(case, model, torque="rated")
    phi = c.phi
    fwd, rev = stack_meshes(
        c.design,
        c.modification,
        c.errors,
        phi,
        c.discs,
        c.groove_deformation,
        True,
        True,
        c.contact_law,
        c.body,
    )
    rotation, contacts, stress, share = [], [], [], []
    for value in torques:
        fields = _load(fwd if value > 0 else rev, abs(float(value)))
        fields["rest_rotation"] = (fwd if value > 0 else rev).rest
        fields["max_contact_stress"] = np.max(fields["contact_stress"], axis=-1)
        keep = ("torque_share", "contacts", "rest_rotation", "loaded_rotation")
        fields = {name: fields[name] for name in (*keep, "max_contact_stress")}
        if value < 0:
            fields = _reverse(fields)
        rotation.append(transmission_error(fields["rest_rotation"], fields["loaded_rotation"]))
        contacts.append(fields["contacts"])
        stress.append(fields["max_contact_stress"])
        share.append(fields["torque_share"])
    rotation = np.stack(rotation, axis=-2)
    lost, rigidity = torsion_metrics(rotation, torques, rated_torque)
    result = {
        "crank_angle": phi,
        "torque": torques,
        "rated_torque": float(rated_torque),
        "rotation": rotation,
        "contacts": np.stack(contacts, axis=-3),
        "max_contact_stress": np.stack(stress, axis=-3),
        "torque_share": np.stack(share, axis=-3),
        "play": fwd.rest - fwd.reverse_rest,
        "lost_motion": lost,
        "torsional_rigidity": rigidity,
    }
    if series_stiffness is not None:
        drive = rotation - torques[:, None] / series_stiffness
        drive_lost, drive_rigidity = torsion_metrics(drive, torques, rated_torque)
        result.update(
            series_stiffness=float(series_stiffness),
            drive_rotation=drive,
            drive_lost_motion=drive_lost,
            drive_torsional_rigidity=drive_rigidity,
        )
    return TorsionCurve(**result)
