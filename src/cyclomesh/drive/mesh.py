"""The unloaded and the loaded state of a stack of discs on one flank (Eqs. 5–24 of [1]).

:func:`stack_meshes` builds the unloaded state of every disc of a stack on the forward
flanks and on the mirror problem (:class:`StackMesh`: contact geometry, rest positions,
backlash, compliance, contact normals), shared by :func:`cyclomesh.drive.solve.solve_drive`,
the torsion curve (:mod:`cyclomesh.drive.torsion`) and the RV stage
(:mod:`cyclomesh.stage.solve`); :func:`load_stack` solves the load sharing of one torque
and asks :func:`cyclomesh.core.fields.contact_fields` for the post-contact fields;
:func:`reverse_fields` maps the fields of the mirror problem back onto the reverse flanks.
See :mod:`cyclomesh.drive.solve` for the model (stacks, mesh force).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.contact import (
    UnloadedContact,
    normals_at,
    unloaded_contact,
    unloaded_contact_stack,
)
from cyclomesh.core.discbody import DiscBody, share_load_coupled, tooth_index
from cyclomesh.core.fields import CONTACT_FIELDS, PIN_FIELDS, contact_fields
from cyclomesh.core.kernel import kernel_name, share_load
from cyclomesh.core.kernel_contact import rest_arrays
from cyclomesh.core.ltca import (
    CONDITIONED_ARM,
    locate_failure,
    pin_compliance,
    rest_position,
)
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.drive.friction import FRICTION_FIELDS, FrictionCoupling
from cyclomesh.drive.mirror import mirror_problem, unmirror
from cyclomesh.exceptions import ConvergenceError
from cyclomesh.quantities import QUANTITIES

__all__ = [
    "StackMesh",
    "stack_meshes",
    "stacked_contact",
    "rest_positions",
    "disc_angles",
    "load_stack",
    "loaded_normals",
    "reverse_fields",
    "PER_PIN",
    "PER_DISC",
    "FRICTION_PIN",
    "ODD",
    "OPTIONAL",
]

FloatArray = NDArray[np.float64]


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
    n·u); ``ring_shape``; ``phi`` (crank angles of disc 1 in this frame [rad]);
    ``eccentricity`` (e + εe of every ring [m], (..., 1, 1, 1), for the contact kinematics of
    friction, :mod:`cyclomesh.drive.friction`); ``force_angle`` (direction of each pin's
    force on its disc, fixed frame [rad], (..., A, N, n1): geometry alone, so computed once
    here and not again for every torque of a torsion curve)."""

    design: PairDesign
    geo: UnloadedContact  # arrays (..., A, N, n1)
    rest: FloatArray | None  # (..., A); None: not formed (_mesh's rests)
    reverse_rest: FloatArray | None  # (..., A), rest on the opposite flanks
    backlash: FloatArray | None  # (..., A, N·n1)
    alpha: FloatArray
    gamma: FloatArray
    normal_x: FloatArray  # (..., A, N, n1): outward normal of the contact, fixed frame
    normal_y: FloatArray
    ring_shape: tuple
    phi: FloatArray
    body: DiscBody | None = None
    tooth: NDArray | None = None  # (A, N·n1): tooth space of every contact (compliant disc)
    eccentricity: FloatArray | None = None  # (..., 1, 1, 1): e + εe of every ring [m]
    force_angle: FloatArray | None = None  # (..., A, N, n1): arg(−n) [rad]
    modification: Modification | None = None  # of this frame (mirrored for the reverse)
    errors: PinErrors | None = None  # of this frame: for normals=False, loaded_normals


def disc_angles(phi: FloatArray, discs: int) -> FloatArray:
    """Eccentric angles of the discs, shape (N·A,), disc after disc [rad]."""
    offsets = 2.0 * np.pi * np.arange(discs) / discs
    return (offsets[:, None] + phi[None, :]).ravel()


def _stack(arr: FloatArray, discs: int, n_angles: int) -> FloatArray:
    """(..., N·A, n1) → (..., A, N, n1)."""
    shaped = arr.reshape(*arr.shape[:-2], discs, n_angles, arr.shape[-1])
    return shaped.swapaxes(-3, -2)  # np.moveaxis's view, without its axis checks


def stacked_contact(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors,
    phi: FloatArray,
    discs: int,
    normals: bool = True,
) -> UnloadedContact:
    """Unloaded contact of every disc of a stack, arrays (..., A, N, n1) (Eqs. 5–11), with
    the outward flank normals in the fixed frame (computed once, with the contact; None
    without ``normals``).

    With numba (an undeviated profile: the compiled contact passes, each contact computed
    alone) the eccentric angles go crank angle after crank angle, φ_a + 2πd/N in (A, N)
    order (the same sums, so the same angles), and the arrays are (..., A, N, n1)
    C-contiguous: the compliance, the rests, the stage's problem and the stresses read
    them without the strided copies of the stacked views (the same numbers)."""
    if kernel_name() == "numba" and (modification is None or modification.profile is None):
        offsets = 2.0 * np.pi * np.arange(discs) / discs
        angles = (phi[:, None] + offsets[None, :]).ravel()  # disc_angles' sums, (A, N)
        raw = unloaded_contact(design, modification, errors, angles, normals=normals)
        return UnloadedContact(
            **{
                name: None
                if value is None
                else value.reshape(*value.shape[:-2], phi.size, discs, value.shape[-1])
                for name in UnloadedContact.__dataclass_fields__
                for value in (getattr(raw, name),)
            }
        )
    raw = unloaded_contact(design, modification, errors, disc_angles(phi, discs), normals=normals)
    return UnloadedContact(
        **{
            name: None if value is None else _stack(value, discs, phi.size)
            for name in UnloadedContact.__dataclass_fields__
            for value in (getattr(raw, name),)
        }
    )


def _stacked_pair(
    design: PairDesign,
    modification: Modification,
    problems: list[tuple[PinErrors, FloatArray]],
    discs: int,
    normals: bool,
) -> UnloadedContact | None:
    """:func:`stacked_contact` of problems ``(errors, phi)`` that share the design and the
    modification in one pass of the compiled contact
    (:func:`~cyclomesh.core.contact.unloaded_contact_stack`): arrays (P, ..., A, N, n1),
    problem p's at [p], each :func:`stacked_contact`'s bit for bit (the eccentric angles
    as its compiled path takes them); None where that pass does not apply."""
    offsets = 2.0 * np.pi * np.arange(discs) / discs
    raw = unloaded_contact_stack(
        design,
        modification,
        [(errors, (phi[:, None] + offsets[None, :]).ravel()) for errors, phi in problems],
        normals,
    )
    if raw is None:
        return None
    n_angles = problems[0][1].size
    return UnloadedContact(
        **{
            name: None
            if value is None
            else value.reshape(*value.shape[:-2], n_angles, discs, value.shape[-1])
            for name in UnloadedContact.__dataclass_fields__
            for value in (getattr(raw, name),)
        }
    )


def _part(geo: UnloadedContact, p: int) -> UnloadedContact:
    """Problem ``p`` of a stack of problems' contact (:func:`_stacked_pair`), views."""
    return UnloadedContact(
        **{
            name: None if value is None else value[p]
            for name in UnloadedContact.__dataclass_fields__
            for value in (getattr(geo, name),)
        }
    )


def loaded_normals(mesh: StackMesh, force: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The outward flank normals (..., A, N, n1) of a mesh built without them, at the
    pins that carry load (F ≠ 0) only, 0 elsewhere: those pins' normals bit for bit
    (:func:`~cyclomesh.core.contact.normals_at`). Enough for the mesh force, −Σ F·n, whose
    terms at the other pins are ±0 whatever n: its sums are the same bits wherever some
    pin carries load."""
    nx, ny = np.zeros(force.shape), np.zeros(force.shape)
    at = np.flatnonzero(force.reshape(-1) != 0.0)
    if not at.size:
        return nx, ny
    where = np.unravel_index(at, force.shape)
    n_angles, discs = force.shape[-3:-1]
    ring = (
        np.ravel_multi_index(where[:-3], force.shape[:-3]) if force.ndim > 3 else np.zeros_like(at)
    )
    geo = mesh.geo
    sub = normals_at(
        mesh.design,
        mesh.modification,
        mesh.errors,
        disc_angles(mesh.phi, discs),
        ring,
        where[-2] * n_angles + where[-3],  # disc after disc, as unloaded_contact's angles
        where[-1],
        geo.profile_angle[where],
        geo.pin_radius[where],
    )
    np.put(nx, at, sub[0])
    np.put(ny, at, sub[1])
    return nx, ny


def rest_positions(geo: UnloadedContact, pins: int, discs: int) -> tuple[FloatArray, FloatArray]:
    """Rest positions of a stack on the forward and on the opposite flanks [rad], (..., A).

    Forward: the smallest conditioned contact rotation (:func:`~cyclomesh.core.ltca.rest_position`,
    Eq. 11); opposite: the largest conditioned reverse-flank contact rotation.
    """
    flat = (*geo.rotation.shape[:-2], discs * pins)
    arm = geo.moment_arm.reshape(flat)
    if kernel_name() == "numba":  # the same min and comparisons in one compiled pass
        return rest_arrays(
            geo.rotation.reshape(flat), geo.reverse_rotation.reshape(flat), arm, CONDITIONED_ARM
        )
    rest = rest_position(geo.rotation.reshape(flat), arm)
    reverse_rest = -rest_position(-geo.reverse_rotation.reshape(flat), arm)
    return rest, reverse_rest


def _mesh(
    design: PairDesign,
    modification: Modification,
    errors: PinErrors,
    phi: FloatArray,
    discs: int,
    groove_deformation: bool,
    contact_law: str = "half_plane",
    body: DiscBody | None = None,
    force_angle: bool = True,
    normals: bool = True,
    rests: bool = True,
    formed: tuple[UnloadedContact, FloatArray, FloatArray] | None = None,
) -> StackMesh:
    """Unloaded contact, rest positions and compliance of a stack (forward flanks);
    ``force_angle``: also the direction of every pin's force (else None); ``normals``:
    the flank normals of every contact (else None: :func:`load_stack` takes those of the
    loaded pins, :func:`loaded_normals`; no force angle then); ``rests``: the rest
    positions and the backlash (else None: a mesh only the flanks' geometry and
    compliance of which are read); ``formed``: the contact and the compliance (α, γ)
    already formed (:func:`stack_meshes`' two problems in one pass), else formed here."""
    ring_shape = errors.ring_shape(design.pins)
    if formed is None:
        geo = stacked_contact(design, modification, errors, phi, discs, normals)
        alpha, gamma = pin_compliance(geo, design, groove_deformation, contact_law)
    else:
        geo, alpha, gamma = formed
    flat = (*geo.rotation.shape[:-2], discs * design.pins)
    rest = reverse_rest = backlash = None
    if rests:
        rest, reverse_rest = rest_positions(geo, design.pins, discs)
        backlash = geo.rotation.reshape(flat) - rest[..., None]
    return StackMesh(
        design=design,
        geo=geo,
        rest=rest,
        reverse_rest=reverse_rest,
        backlash=backlash,
        alpha=alpha.reshape(flat),
        gamma=gamma.reshape(flat),
        normal_x=geo.normal_x,
        normal_y=geo.normal_y,
        force_angle=contact_fields(
            ("force_angle",), design, geo, geo.rotation, normal=(geo.normal_x, geo.normal_y)
        )["force_angle"]
        if force_angle and normals
        else None,
        modification=modification,
        errors=errors,
        ring_shape=ring_shape,
        phi=phi,
        body=body,
        eccentricity=design.eccentricity
        + np.broadcast_to(np.asarray(errors.eccentricity, float), ring_shape)[
            ..., None, None, None
        ],
        tooth=None
        if body is None
        else tooth_index(design.pins, design.pitch, disc_angles(phi, discs))
        .reshape(discs, phi.size, design.pins)
        .transpose(1, 0, 2)
        .reshape(phi.size, discs * design.pins),
    )


def load_stack(
    mesh: StackMesh,
    torque: float,
    friction: FrictionCoupling | None = None,
    without: frozenset[str] = frozenset(),
) -> dict[str, FloatArray]:
    """Loaded state of a stack under a positive torque, in the mesh's frame; with
    ``friction`` (:mod:`cyclomesh.drive.friction`) the friction forces enter the torque
    balance and the friction fields (:data:`~cyclomesh.drive.friction.FRICTION_FIELDS`)
    are added. ``without``: contact fields (:data:`OPTIONAL`) left out; ``force_angle``
    is the mesh's (left out where the mesh has none)."""
    geo = mesh.geo
    flat_arm = mesh.backlash.shape
    try:
        if friction is not None:
            loaded, force, state = friction.share(torque)
        elif mesh.body is None:
            loaded, force = share_load(  # (..., A, N·n1): a ring's crank angles in order
                mesh.backlash,
                geo.moment_arm.reshape(flat_arm),
                mesh.alpha,
                mesh.gamma,
                torque,
                angle_axis=True,
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
                angle_axis=True,
            )
    except ConvergenceError as exc:
        err = locate_failure(exc, (*mesh.ring_shape, mesh.phi.size), mesh.phi)
        raise ConvergenceError(f"torque {torque:g} N·m: {err}") from None
    force = force.reshape(geo.rotation.shape)
    extra = {} if friction is None else friction.fields(force, state)
    normal = (mesh.normal_x, mesh.normal_y)
    if mesh.normal_x is None:  # a mesh built without them: the loaded pins' (bit for bit)
        normal = loaded_normals(mesh, force)
    fields = contact_fields(
        [name for name in _PER_TORQUE if name not in without],
        mesh.design,
        geo,
        force,
        rotation=(mesh.rest + loaded)[..., None, None],
        normal=normal,
        stack_axes=2,
    )
    if mesh.force_angle is not None and "force_angle" not in without:
        fields["force_angle"] = mesh.force_angle
    return extra | {"pin_load": force, **fields, "loaded_rotation": loaded}


_PER_TORQUE = tuple(name for name in CONTACT_FIELDS if name != "force_angle")
"""The contact fields that change with the torque (the force angle is the mesh's)."""
OPTIONAL = frozenset({"force_angle", "overlap"})
"""Per-pin fields a caller that reduces a few metrics may leave out (:func:`load_stack`,
:func:`cyclomesh.drive.solve.solve_drive` ``without``): each is a full pass over the
contacts (an arctangent of every normal, a difference with the reverse rotations) that
no other field reads."""


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
    force_angle: bool = True,
    normals: bool = True,
    reverse_rests: bool = True,
) -> tuple[StackMesh | None, StackMesh | None]:
    """The unloaded meshes of the forward flanks and of the mirror problem (reverse flanks),
    as needed; the mirror problem is solved on the crank angles −φ reversed, and
    :func:`unmirror` maps its arrays back (Eqs. 5–23 of [1]).

    The mirrored problem uses the same body coefficients: the disc (profile, bore and
    the crank holes at 2πk/N) is symmetric about its x-axis. ``force_angle``: the meshes
    carry the direction of every pin's force (else None); ``normals``: the flank normals
    of every contact (else only the loaded pins' are taken, by :func:`load_stack`).
    ``reverse_rests``: the mirror problem's rest positions and backlash (else None in its
    mesh: the RV stage under positive torques reads only its flanks' geometry and
    compliance, as the opposite flanks of the forward problem).

    With numba (an undeviated profile) both problems' contact is one compiled pass and
    their compliance one call (:func:`_formed_pair`: the two problems as two rows of the
    kernel's ring axis, each with its pins and crank angles), each mesh's arrays views of
    the pair's, C-contiguous: each contact is computed alone, so the meshes are those of
    the problems formed one after the other, bit for bit.
    """
    fwd = rev = None
    args = (discs, groove_deformation, contact_law, body, force_angle, normals)
    formed = (None, None)
    if reverse:
        mod_m, errors_m = mirror_problem(modification, errors, design.pins)
        # the mirror of crank angle φ is −φ; solve increasing angles and flip back below
        phi_m = -phi[::-1]
        if forward and mod_m is modification:  # both problems' contact in one pass
            formed = _formed_pair(
                design, modification, [(errors, phi), (errors_m, phi_m)], *args[:3], normals
            )
    if forward:
        fwd = _mesh(design, modification, errors, phi, *args, formed=formed[0])
    if reverse:
        rev = _mesh(design, mod_m, errors_m, phi_m, *args, reverse_rests, formed=formed[1])
    return fwd, rev


def _formed_pair(
    design: PairDesign,
    modification: Modification,
    problems: list[tuple[PinErrors, FloatArray]],
    discs: int,
    groove_deformation: bool,
    contact_law: str,
    normals: bool,
) -> tuple:
    """The contact and the compliance (α, γ) of problems that share the design and the
    modification (:func:`stack_meshes`' forward and mirror problems) in one compiled pass
    each, then taken apart: each problem's the same bits as its own
    (:func:`_stacked_pair`; the compliance is per contact); (None, …) where the compiled
    contact does not apply (each problem then formed alone)."""
    geo = _stacked_pair(design, modification, problems, discs, normals)
    if geo is None:
        return (None,) * len(problems)
    alpha, gamma = pin_compliance(geo, design, groove_deformation, contact_law)
    flat = (*alpha.shape[:-2], discs * design.pins)
    alpha, gamma = alpha.reshape(flat), gamma.reshape(flat)
    return tuple((_part(geo, p), alpha[p], gamma[p]) for p in range(len(problems)))


_CONTACT = [
    part
    for name in CONTACT_FIELDS
    for part in ((f"{name}_x", f"{name}_y") if name == "mesh_force" else (name,))
]
PER_PIN = {
    "pin_load": True,
    **{name: name in PIN_FIELDS for name in _CONTACT},
    "backlash": True,
    "profile_angle": True,
    "contact_radius": True,
    "moment_arm": True,
    "curvature_radius": True,
    "rest_rotation": False,
    "loaded_rotation": False,
}
"""Every field of a stack (:func:`load_stack` and the unloaded mesh) → whether it has one
value per pin (else per disc or per crank angle); the contact fields' from
:data:`cyclomesh.core.fields.PIN_FIELDS`."""
ODD = {name for name in PER_PIN if name in QUANTITIES and QUANTITIES[name].parity < 0} | {
    "mesh_force_y"
}
"""Fields that change sign in the mirror image: the registry's parity
(:data:`cyclomesh.quantities.QUANTITIES`), and the y component of the mesh force."""
PER_DISC = {"torque_share", "contacts", "mesh_force_x", "mesh_force_y", "max_contact_stress"}
FRICTION_PIN = {name for name, pin in FRICTION_FIELDS.items() if pin}
"""The per-pin friction fields (:mod:`cyclomesh.drive.friction`); the others are per disc."""
PER_DISC |= {name for name, pin in FRICTION_FIELDS.items() if not pin}
ODD |= {name for name in FRICTION_FIELDS if QUANTITIES[name].parity < 0}


def reverse_fields(fields: dict[str, FloatArray]) -> dict[str, FloatArray]:
    """Fields of the mirrored forward problem mapped back onto the reverse flanks."""
    out = {}
    for name, value in fields.items():
        if PER_PIN.get(name, name in FRICTION_PIN):
            arr = unmirror(value, -3, -2, True)
        elif name in PER_DISC:
            arr = unmirror(value, -2, -1, False)
        else:
            arr = unmirror(value, -1, None, False)
        if name in ODD:
            arr = -arr
        out[name] = arr
    return out
