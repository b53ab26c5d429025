"""Unloaded tooth contact analysis with pin position deviations (Eqs. 5–14 of [1]).

Conventions (fixed frame Sf = pin wheel, angles counter-clockwise positive):

* pin k (k = 1 … n1, index i = k − 1) has its centre at radius a + εa,i and angle
  i·ψ + εψ,i, and radius ρp + ερ,i (Eq. 5);
* at crank angle φ the disc centre is at (e + εe)·(cos φ, sin φ) (Eqs. 7–9);
* the disc's theoretical rotation is φt = −φ/n2; the torque resists the disc's
  (clockwise) motion, so the disc lags: the loaded flank is the one that a
  counter-clockwise turn of the disc presses onto the pins. In the tooth phase
  φ1 mod 2π this is the flank (−π, 0) between a tip (−π) and the tooth-space
  bottom (0).

Eq. 10 (coincident points, collinear normals) is solved exactly by a reduction to one
scalar equation. In the disc frame the pin centre is q = R(−φc)·w with w = C_i − O2, so
|q| = |w| whatever the disc rotation φc. The pin touches the profile when q lies on the
offset P_s = P + s·n of the locus by s = r_pin − ρ' along the outward normal n. Writing
P(t) = e^{it}·(a' − e·e^{iu}) with the tooth phase u = n2·t, every quantity of the contact
is a function of c = cos u alone:

    |P_s|² = a'² + e² − 2a'e·c + 2s·G(c)/D(c) + s²,
    G = a'² + e²n1 − a'e(n1 + 1)c,   D = |P'| = sqrt(a'² + e²n1² − 2a'e·n1·c),

so the contact condition |P_s(c)| = |w| is one smooth, monotone equation in c ∈ [−1, 1]
whose s = 0 root is closed-form (c = (a'² + e² − |w|²)/(2a'e)). Newton's method from there
converges to round-off in two or three steps. The same c serves both flanks of the
pin's tooth space (u = ∓arccos c; the profile is symmetric about the tooth-space
bottom), and the disc rotation at contact is φc = arg w − arg P_s. The moment arm of the
line of action about the disc centre is l = a'e·n2·|sin u|/D (Eq. 17 restated). This
replaces the fsolve of Eqs. 12–14 of [1].

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NoReturn

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.kernel import kernel_name
from cyclomesh.core.kernel_contact import contact_arrays
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.core.profile import curvature_radius, deviated_geometry, generating_radii
from cyclomesh.exceptions import ConvergenceError, DesignError

__all__ = [
    "UnloadedContact",
    "unloaded_contact",
    "unloaded_contact_stack",
    "contact_phase",
    "contact_normal",
    "normals_at",
    "contact_tangent",
]

FloatArray = NDArray[np.float64]

CONTACT_TOLERANCE = 1e-13
"""Required residual of the contact condition, as a distance [m] (1e-10 mm)."""
_MAX_ITERATIONS = 40
_MAX_BRACKETED_ITERATIONS = 120


@dataclass(frozen=True)
class UnloadedContact:
    """Unloaded contact of every pin with the loaded flank of its tooth space.

    Arrays have shape ``(..., n_angles, n1)``; ``...`` are the ring axes of the errors.
    All angles [rad], lengths [m].

    Attributes
    ----------
    rotation : ndarray
        φc,i − φt: disc rotation from its theoretical position at which pin i just
        touches the loaded flank (counter-clockwise positive; +inf if the pin lies
        outside the tip circle of the modified profile and cannot be reached).
    reverse_rotation : ndarray
        The same for the unloaded flank of the pin's tooth space (the flank a
        clockwise turn presses on); −inf where unreachable.
    moment_arm : ndarray
        l_i, distance from the disc centre to the line of action at the loaded-flank
        contact (Eq. 17, from the contact geometry) [m].
    cos_beta : ndarray
        cos β_i, β the angle between the line of action and the pin's radial line.
    profile_angle : ndarray
        Generating angle φ1 of the contact within its tooth, in [−π, 0] [rad].
    contact_radius : ndarray
        Radius of the contact point on the disc [m].
    curvature_radius : ndarray
        Signed profile curvature radius ρc at the contact (Eq. 4; concave < 0) [m].
    pin_radius : ndarray
        Actual pin radius ρp + ερ,i [m].
    residual : ndarray
        Residual of the contact condition, as a distance [m].
    normal_x, normal_y : ndarray or None
        Outward flank normal n at the contact, fixed frame (unit vector, as
        :func:`contact_normal` gives it, bit for bit; with the numba kernel,
        :mod:`cyclomesh.core.kernel_contact`, from the contact's own angles, to round-off,
        1e-14; at a tooth tip, φ1 = −π, the reference's own), when asked for
        (``unloaded_contact(..., normals=True)``), else None: computed once here, for
        the mesh force and the friction of a stack.
    """

    rotation: FloatArray
    reverse_rotation: FloatArray
    moment_arm: FloatArray
    cos_beta: FloatArray
    profile_angle: FloatArray
    contact_radius: FloatArray
    curvature_radius: FloatArray
    pin_radius: FloatArray
    residual: FloatArray
    normal_x: FloatArray | None = None
    normal_y: FloatArray | None = None


def contact_phase(
    w2: FloatArray, a: float, e: float, n1: int, s: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Solve |P_s(c)| = |w| for c = cos u, the tooth phase of the contact (Eq. 10 of [1]).

    Parameters
    ----------
    w2 : ndarray
        |w|², squared distance from the disc centre to the pin centre [m²].
    a, e, n1
        Generating pin-circle radius a' [m], eccentricity [m], number of pins.
    s : ndarray
        Offset r_pin − ρ' of the pin centre from the locus [m].

    Returns
    -------
    c : ndarray
        cos u at contact, in [−1, 1].
    residual : ndarray
        | |P_s| − |w| | at the solution [m] (0 for unreachable pins).
    reachable : ndarray of bool
        False where the pin lies outside the tip circle of the modified profile.

    A pin inside the root circle of the offset locus (|w| < a' − e + s) overlaps the
    tooth-space bottom whatever the disc rotation; the caller checks for it.
    """
    w = np.sqrt(w2)
    reachable = w <= a + e + s
    k0 = a * a + e * e + s * s - w2
    g0, g1 = a * a + e * e * n1, a * e * (n1 + 1)
    d0, d1 = a * a + e * e * n1 * n1, 2.0 * a * e * n1
    c = np.clip(k0 / (2.0 * a * e), -1.0, 1.0)
    for _ in range(_MAX_ITERATIONS):
        d = np.sqrt(d0 - d1 * c)
        g = g0 - g1 * c
        h = k0 - 2.0 * a * e * c + 2.0 * s * g / d
        residual = np.where(reachable, np.abs(h) / (2.0 * w), 0.0)
        done = residual <= CONTACT_TOLERANCE
        if np.all(done):
            break
        # dh/dc; D' = −d1/(2D). A converged element stays put, so that its result does
        # not depend on the other elements of the batch (extra steps move the last bit).
        dh = -2.0 * a * e + 2.0 * s * (-g1 * d + g * d1 / (2.0 * d)) / (d * d)
        c = np.where(done, c, np.clip(c - h / dh, -1.0, 1.0))
    return c, residual, reachable


def unloaded_contact(
    design: PairDesign,
    modification: Modification | None,
    errors: PinErrors | None,
    crank_angles: ArrayLike,
    normals: bool = False,
) -> UnloadedContact:
    """Unloaded contact of every pin at every crank angle (Eqs. 5–11 of [1]).

    Parameters
    ----------
    design : PairDesign
    modification : Modification or None
        Tooth profile modification (Eq. 3).
    errors : PinErrors or None
        Pin position, pin radius and eccentricity errors (Eq. 5); leading axes are rings.
    crank_angles : array_like
        Crank angles φ [rad], shape (n_angles,).
    normals : bool
        Also the outward flank normals in the fixed frame (``normal_x``, ``normal_y``,
        equal bit for bit to :func:`contact_normal`'s, which they spare recomputing).

    Returns
    -------
    UnloadedContact
        Arrays of shape ``(..., n_angles, n1)``.

    Raises
    ------
    ConvergenceError
        If the contact condition cannot be met to 1e-10 mm at some pin and angle.
    DesignError
        If a pin overlaps the disc whatever its rotation.
    """
    modification = modification or Modification()
    errors = errors or PinErrors()
    n1, n2 = design.pins, design.teeth
    a, rho_gen = generating_radii(design, modification)
    e = design.eccentricity
    ring_shape = errors.ring_shape(n1)
    phi = np.asarray(crank_angles, dtype=float)[:, None]  # (A, 1)
    pin_angle, pin_r, r_pin, ecc = _ring(design, errors, ring_shape)

    phi_t = -phi / n2
    # nominal tooth phase n2·(i·ψ + φ/n2) of the pin, and its nearest tooth-space bottom
    # (the compiled passes take the bottom themselves, from n2·i·ψ and φ)
    pin_phase = n2 * np.arange(n1) * design.pitch
    if modification.profile is None and kernel_name() == "numba":
        # the compiled passes (cyclomesh.core.kernel_contact); None: the reference refuses
        shape = (*ring_shape, phi.size, n1)
        got = _compiled_contact(
            design, modification, pin_r, pin_angle, ecc, phi, r_pin, shape, normals
        )
        if got is not None:
            return got
    u_nominal = pin_phase + phi
    t_root = 2.0 * np.pi * np.round(u_nominal / (2.0 * np.pi)) / n2

    wx = pin_r * np.cos(pin_angle) - ecc * np.cos(phi)
    wy = pin_r * np.sin(pin_angle) - ecc * np.sin(phi)
    w2 = wx * wx + wy * wy
    s = np.broadcast_to(r_pin - rho_gen, w2.shape)

    if modification.profile is not None:
        return _deviated_contact(
            design, modification, w2, wx, wy, r_pin, phi, phi_t, t_root, pin_angle, normals
        )
    if np.any(np.sqrt(w2) < a - e + s - CONTACT_TOLERANCE):
        _refuse_overlap(
            a - e + s - np.sqrt(w2),
            phi,
            "its radius or negative radial error exceeds the clearance of the modification; "
            "raise modification.pin_radius_um (Δρ) by at least {depth:.3g} µm or reduce the "
            "pin's radius or negative radial error",
        )
    c, residual, reach = contact_phase(w2, a, e, n1, s)
    _require_converged(residual, phi)
    # loaded flank: u = −arccos c ∈ [−π, 0], sin u ≤ 0
    u = -np.arccos(c)
    sin_u = -np.sqrt(1.0 - c * c)
    d = np.sqrt(a * a + e * e * n1 * n1 - 2.0 * a * e * n1 * c)
    nx, ny = (a - e * n1 * c) / d, -e * n1 * sin_u / d  # normal in the frame turned by t
    zx, zy = a - e * c + s * nx, -e * sin_u + s * ny  # pin centre P_s, same frame
    arg_w = np.arctan2(wy, wx)
    arg_z = np.arctan2(zy, zx)
    t = t_root + u / n2
    rotation = _wrap(arg_w - t - arg_z - phi_t)
    # angle of the line of action in the fixed frame minus the pin's radial angle (a
    # rotation modification turns flank and disc alike, so it does not enter here)
    lateral = phi_t + rotation + t + np.arctan2(ny, nx) - pin_angle
    rotation = rotation + modification.rotation
    # unloaded flank: the mirror image about the tooth-space bottom
    reverse = _behind(
        rotation, _wrap(arg_w - (t_root - u / n2) + arg_z - phi_t) - modification.rotation, n2
    )

    moment_arm = -a * e * n2 * sin_u / d
    rho_x, rho_y = a - e * c - rho_gen * nx, -e * sin_u - rho_gen * ny
    profile_angle = np.where(reach, u, -np.pi)
    pin_radius = np.broadcast_to(r_pin, w2.shape)
    normal = (None, None)
    if normals:
        normal = _fixed_normal(arg_w, profile_angle, pin_radius, a, e, n1, rho_gen)
    return UnloadedContact(
        rotation=np.where(reach, rotation, np.inf),
        reverse_rotation=np.where(reach, reverse, -np.inf),
        moment_arm=np.where(reach, moment_arm, 0.0),
        cos_beta=np.where(reach, np.abs(np.cos(lateral)), 1.0),
        profile_angle=profile_angle,
        contact_radius=np.where(reach, np.hypot(rho_x, rho_y), a + e - rho_gen),
        curvature_radius=np.where(reach, curvature_radius(t, design, modification), np.inf),
        pin_radius=pin_radius,
        residual=residual,
        normal_x=normal[0],
        normal_y=normal[1],
    )


def _ring(
    design: PairDesign, errors: PinErrors, ring_shape: tuple[int, ...]
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Pin angles, pin-circle radii and pin radii (..., 1, n1) and the eccentricity
    (..., 1, 1) of a ring of pins with ``errors`` (Eq. 5) [rad, m]."""
    n1 = design.pins

    def per_pin(x: ArrayLike) -> FloatArray:  # (..., 1, n1)
        return np.broadcast_to(np.asarray(x, float), (*ring_shape, n1))[..., None, :]

    pin_angle = np.arange(n1) * design.pitch + per_pin(errors.angular)
    pin_r = design.pin_circle_radius + per_pin(errors.radial)
    r_pin = design.pin_radius + per_pin(errors.pin_radius)
    ecc = design.eccentricity + np.broadcast_to(errors.eccentricity, ring_shape)[..., None, None]
    return pin_angle, pin_r, r_pin, ecc


def _compiled_contact(
    design: PairDesign,
    modification: Modification,
    pin_r: FloatArray,
    pin_angle: FloatArray,
    ecc: FloatArray,
    phi: FloatArray,
    r_pin: FloatArray,
    shape: tuple[int, ...],
    normals: bool,
) -> UnloadedContact | None:
    """:func:`unloaded_contact`'s arrays of ``shape`` (..., A, n1) by the compiled passes
    (undeviated profile; :func:`cyclomesh.core.kernel_contact.contact_arrays`, whose
    inputs these are), or None for a case the reference must refuse."""
    n1, n2 = design.pins, design.teeth
    a, rho_gen = generating_radii(design, modification)
    e = design.eccentricity
    pin_phase = n2 * np.arange(n1) * design.pitch
    got = contact_arrays(
        pin_r, pin_angle, ecc, phi, r_pin - rho_gen, pin_phase, a, e, n1, n2, rho_gen,
        modification.rotation, shape, normals,
    )  # fmt: skip
    if got is None:
        return None
    arg_w = got.pop("arg_w")
    if normals:  # at a tip, or unreachable (φ1 = −π), the reference's normal: along
        # w but for the last bits of sin(−π) (the kernel's sin φ1 = −√(1 − c²) is
        # 0), which decide the side of ±π of its force angle when w lies on the
        # x-axis; a few % of the contacts, taken by their flat indices (C order)
        tip = np.flatnonzero(got["profile_angle"].reshape(-1) == -np.pi)
        if tip.size:
            radius = r_pin.reshape(-1)[tip // (shape[-2] * n1) * n1 + tip % n1]
            angle = got["profile_angle"].reshape(-1)[tip]
            nx, ny = _fixed_normal(arg_w.reshape(-1)[tip], angle, radius, a, e, n1, rho_gen)
            np.put(got["normal_x"], tip, nx)
            np.put(got["normal_y"], tip, ny)
    return UnloadedContact(**got, pin_radius=np.broadcast_to(r_pin, shape))


def unloaded_contact_stack(
    design: PairDesign,
    modification: Modification | None,
    problems: list[tuple[PinErrors | None, ArrayLike]],
    normals: bool = False,
) -> UnloadedContact | None:
    """:func:`unloaded_contact` of several problems that share the design and the
    modification, each ``(errors, crank_angles)`` (the same ring shape and number of
    crank angles), in one pass of the compiled kernel: arrays (P, ..., A, n1), problem p's
    at [p], each of them :func:`unloaded_contact`'s bit for bit (each contact is
    computed alone; the problems are rows of the kernel's ring axis, each with its crank
    angles). For a drive's forward and mirror problems (:func:`cyclomesh.drive.mesh.stack_meshes`),
    which would otherwise go through the kernel's per-call work twice.

    None where the compiled passes do not apply (the NumPy kernel, a profile deviation,
    problems of other ring shapes or numbers of crank angles) or refuse a case (a jammed
    or unconverged contact: :func:`unloaded_contact` of each problem then raises).
    """
    modification = modification or Modification()
    if modification.profile is not None or kernel_name() != "numba":
        return None
    n1 = design.pins
    problems = [(errors or PinErrors(), np.asarray(phi, dtype=float)) for errors, phi in problems]
    ring_shape = problems[0][0].ring_shape(n1)
    n_angles = problems[0][1].size
    if any(
        errors.ring_shape(n1) != ring_shape or phi.shape != (n_angles,) for errors, phi in problems
    ):
        return None
    rings = [_ring(design, errors, ring_shape) for errors, _ in problems]
    pin_angle, pin_r, r_pin, ecc = (np.stack(parts) for parts in zip(*rings, strict=True))
    lead = (len(problems),) + (1,) * len(ring_shape)
    phi = np.stack([phi for _, phi in problems]).reshape(*lead, n_angles, 1)
    shape = (len(problems), *ring_shape, n_angles, n1)
    return _compiled_contact(
        design, modification, pin_r, pin_angle, ecc, phi, r_pin, shape, normals
    )


def _fixed_normal(
    arg_w: FloatArray,
    profile_angle: FloatArray,
    pin_radius: FloatArray,
    a: float,
    e: float,
    n1: int,
    rho_gen: float,
) -> tuple[FloatArray, FloatArray]:
    """Outward flank normal in the fixed frame from arg w and the contact's φ1 (module doc;
    :func:`contact_normal`): n = (cos, sin)(arg w + arg n − arg P_s), n and P_s in the
    tooth frame of the contact."""
    u = profile_angle
    c, sin_u = np.cos(u), np.sin(u)
    d = np.sqrt(a * a + e * e * n1 * n1 - 2.0 * a * e * n1 * c)
    nx, ny = (a - e * n1 * c) / d, -e * n1 * sin_u / d
    s = pin_radius - rho_gen
    zx, zy = a - e * c + s * nx, -e * sin_u + s * ny
    angle = arg_w + np.arctan2(ny, nx) - np.arctan2(zy, zx)
    return np.cos(angle), np.sin(angle)


def contact_normal(
    design: PairDesign,
    modification: Modification | None,
    errors: PinErrors | None,
    crank_angles: ArrayLike,
    profile_angle: FloatArray,
    pin_radius: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Outward flank normal n at every contact, in the fixed frame (unit vector).

    The pin presses on the disc along −n (the common normal through the pin centre C_i,
    Eq. 10 of [1]); a counter-clockwise disc rotation θ closes the gap by l_i·θ (the
    moment arm of :class:`UnloadedContact`), a disc translation u by n·u. With w = C_i − O2
    the normal makes the angle θ_n = arg n − arg P_s with w, both taken in the tooth frame
    of the contact (module doc), so n = (cos(arg w + θ_n), sin(arg w + θ_n)).

    The normal is that of the undeviated cycloid at the contact's generating angle
    (Eqs. 1–2 of [1]); a tabulated profile deviation (:mod:`cyclomesh.core.profile`) moves
    the contact point, and through it φ1, but its own slope does not enter here.

    Parameters
    ----------
    design : PairDesign
    modification : Modification or None
        Δa and Δρ (Eq. 3) set the generating radii.
    errors : PinErrors or None
        Pin position and eccentricity errors (Eq. 5); leading axes are rings.
    crank_angles : array_like
        Eccentric angle of the disc at every contact [rad], shape ``(A,)`` or ``(A, N)``
        (N discs of a stack, each at its own eccentric angle).
    profile_angle, pin_radius : ndarray
        φ1 [rad] and the actual pin radius [m] of :class:`UnloadedContact`, shape
        ``(..., A, n1)`` or ``(..., A, N, n1)``.

    Returns
    -------
    nx, ny : ndarray
        Components of the unit normal, shape of ``profile_angle``.
    """
    modification = modification or Modification()
    errors = errors or PinErrors()
    n1 = design.pins
    ring_shape = errors.ring_shape(n1)
    a, rho_gen = generating_radii(design, modification)
    e = design.eccentricity
    crank = np.asarray(crank_angles, dtype=float)[..., None]  # (A, [N,] 1)
    lead = (1,) * (crank.ndim - 1)

    def per_pin(x: ArrayLike) -> FloatArray:  # (..., 1, [1,] n1)
        return np.broadcast_to(np.asarray(x, float), (*ring_shape, n1)).reshape(
            *ring_shape, *lead, n1
        )

    pin_angle = np.arange(n1) * design.pitch + per_pin(errors.angular)
    pin_r = design.pin_circle_radius + per_pin(errors.radial)
    ecc = e + np.broadcast_to(errors.eccentricity, ring_shape).reshape(*ring_shape, *lead, 1)
    arg_w = np.arctan2(
        pin_r * np.sin(pin_angle) - ecc * np.sin(crank),
        pin_r * np.cos(pin_angle) - ecc * np.cos(crank),
    )
    # tooth frame of the contact: normal n and pin centre P_s (module doc)
    return _fixed_normal(arg_w, profile_angle, pin_radius, a, e, n1, rho_gen)


def normals_at(
    design: PairDesign,
    modification: Modification | None,
    errors: PinErrors | None,
    crank_angles: ArrayLike,
    ring: NDArray[np.intp],
    angle: NDArray[np.intp],
    pin: NDArray[np.intp],
    profile_angle: FloatArray,
    pin_radius: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """The outward flank normals of some contacts only: those of :func:`unloaded_contact`
    (``normals=True``, NumPy reference) at ring ``ring`` (flat index over the errors' ring
    axes), crank angle ``angle`` (index into ``crank_angles``) and pin ``pin``, bit for
    bit: the pin and disc-centre terms of w = C_i − O2 are the reference's products, taken
    elementwise, and :func:`_fixed_normal` is elementwise. For callers that read the
    normals at a few contacts (the mesh force reads the loaded pins only).

    Parameters
    ----------
    ring, angle, pin : ndarray of int
        Indices of the contacts, shape (M,).
    profile_angle, pin_radius : ndarray
        φ1 [rad] and the actual pin radius [m] of those contacts, shape (M,).

    Returns
    -------
    nx, ny : ndarray
        Components of the unit normals, shape (M,).
    """
    modification = modification or Modification()
    errors = errors or PinErrors()
    n1 = design.pins
    ring_shape = errors.ring_shape(n1)
    a, rho_gen = generating_radii(design, modification)
    e = design.eccentricity

    def per_pin(x: ArrayLike) -> FloatArray:  # (R, n1)
        return np.broadcast_to(np.asarray(x, float), (*ring_shape, n1)).reshape(-1, n1)

    pin_angle = np.arange(n1) * design.pitch + per_pin(errors.angular)
    pin_r = design.pin_circle_radius + per_pin(errors.radial)
    ecc = e + np.broadcast_to(errors.eccentricity, ring_shape).reshape(-1)
    phi = np.asarray(crank_angles, dtype=float)
    wx = (pin_r * np.cos(pin_angle))[ring, pin] - ecc[ring] * np.cos(phi)[angle]
    wy = (pin_r * np.sin(pin_angle))[ring, pin] - ecc[ring] * np.sin(phi)[angle]
    return _fixed_normal(np.arctan2(wy, wx), profile_angle, pin_radius, a, e, n1, rho_gen)


def contact_tangent(normal_x: FloatArray, normal_y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit tangent t = ẑ × n of the flank at the contact, fixed frame.

    With the outward normal n of :func:`contact_normal`, t points along the flank in the
    counter-clockwise sense about the disc centre for a loaded-flank contact; a sliding
    (friction) force on the disc is ±F_t·t.
    """
    return -normal_y, normal_x


def _refuse_overlap(overlap: FloatArray, phi: FloatArray, cause: str) -> NoReturn:
    """Raise the one-line error of a pin ring that jams the disc, naming the deepest
    overlap (``overlap`` [m], (..., A, n1), positive where a pin overlaps the disc at its
    tooth-space bottom): its pin, crank angle ``phi`` (A, 1) [rad] and depth; ``cause``
    may format ``{depth}`` [µm]."""
    where = np.unravel_index(np.argmax(overlap), overlap.shape)
    depth = float(overlap[where]) * 1e6
    raise DesignError(
        f"pin {where[-1] + 1} overlaps the disc at its tooth-space bottom by {depth:.3g} µm "
        f"at crank angle {np.degrees(phi[where[-2], 0]):.6g}° whatever the disc rotation: "
        + cause.format(depth=depth)
    )


def _require_converged(residual: FloatArray, phi: FloatArray) -> None:
    """Raise :class:`ConvergenceError` naming the worst contact where the unloaded contact
    condition's ``residual`` [m] (..., A, n1) exceeds :data:`CONTACT_TOLERANCE`."""
    if np.all(residual <= CONTACT_TOLERANCE):
        return
    flat = np.unravel_index(np.argmax(residual), residual.shape)
    raise ConvergenceError(
        f"unloaded contact did not converge at crank angle "
        f"{np.degrees(phi[flat[-2], 0]):.6g}°, pin {flat[-1] + 1}: residual "
        f"{residual[flat] * 1e3:.3g} mm (limit {CONTACT_TOLERANCE * 1e3:.0e} mm)"
    )


def _flank_phase(
    design: PairDesign,
    modification: Modification,
    w2: FloatArray,
    r_pin: FloatArray,
    space: NDArray[np.int64],
    sign: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Tooth phase u of contact on one flank with a tabulated deviation (Eq. 10 of [1]).

    Solves |Q(u)| = |w| for c = cos u, u = sign·arccos c, by Newton's method safeguarded
    by bisection: |Q| decreases monotonically from the tip (c = −1) to the tooth-space
    bottom (c = 1). Returns (u, residual [m], reachable, jammed, c).
    """
    a, rho_gen = generating_radii(design, modification)
    e, n1 = design.eccentricity, design.pins
    w = np.sqrt(w2)

    def q2(cos_u: FloatArray) -> tuple[FloatArray, FloatArray]:
        u = sign * np.arccos(cos_u)
        geo = deviated_geometry(u, design, modification, r_pin, space)
        h = geo.qx * geo.qx + geo.qy * geo.qy - w2
        dh_du = 2.0 * (geo.qx * geo.dq_du_x + geo.qy * geo.dq_du_y)
        with np.errstate(divide="ignore", invalid="ignore"):
            dh_dc = dh_du / (-np.sin(u))
        return h, dh_dc

    ones = np.ones_like(w2)
    h_tip, _ = q2(-ones)
    h_root, _ = q2(ones)
    reachable = h_tip >= 0.0
    jammed = h_root > 2.0 * w * CONTACT_TOLERANCE
    # start: the constant-offset solution with the deviation at its phase
    s = r_pin - rho_gen
    c, _, _ = contact_phase(w2, a, e, n1, s)
    d0 = modification.profile.evaluate(sign * np.arccos(c), space)
    c, _, _ = contact_phase(w2, a, e, n1, s - d0)
    lo, hi = -ones, ones.copy()
    for _ in range(_MAX_BRACKETED_ITERATIONS):
        h, dh = q2(c)
        residual = np.where(reachable & ~jammed, np.abs(h) / (2.0 * w), 0.0)
        if np.all(residual <= CONTACT_TOLERANCE):
            break
        lo = np.where(h > 0, c, lo)
        hi = np.where(h > 0, hi, c)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = c - h / dh
        ok = np.isfinite(step) & (step > lo) & (step < hi)
        c = np.where(residual <= CONTACT_TOLERANCE, c, np.where(ok, step, 0.5 * (lo + hi)))
    return sign * np.arccos(c), residual, reachable, jammed, c


def _deviated_contact(
    design: PairDesign,
    modification: Modification,
    w2: FloatArray,
    wx: FloatArray,
    wy: FloatArray,
    r_pin: FloatArray,
    phi: FloatArray,
    phi_t: FloatArray,
    t_root: FloatArray,
    pin_angle: FloatArray,
    normals: bool = False,
) -> UnloadedContact:
    """:func:`unloaded_contact` with a tabulated profile deviation: each flank solved."""
    n2 = design.teeth
    r_pin = np.broadcast_to(r_pin, w2.shape)
    space = np.broadcast_to(np.round(t_root * n2 / (2.0 * np.pi)).astype(np.int64) % n2, w2.shape)
    u, residual, reach, jammed, _ = _flank_phase(design, modification, w2, r_pin, space, -1.0)
    if np.any(jammed):  # |Q| at the tooth-space bottom against |w|
        root = deviated_geometry(np.zeros(w2.shape), design, modification, r_pin, space)
        _refuse_overlap(
            np.where(jammed, np.hypot(root.qx, root.qy) - np.sqrt(w2), -np.inf),
            phi,
            "its radius, a negative radial error or the profile deviation exceeds the "
            "clearance; raise modification.pin_radius_um (Δρ) or reduce the pin's radius, "
            "its negative radial error or the profile deviation",
        )
    _require_converged(residual, phi)
    geo = deviated_geometry(u, design, modification, r_pin, space)
    arg_w = np.arctan2(wy, wx)
    t = t_root + u / n2
    rotation = _wrap(arg_w - t - np.arctan2(geo.qy, geo.qx) - phi_t)
    lateral = phi_t + rotation + t + np.arctan2(geo.ny, geo.nx) - pin_angle
    rotation = rotation + modification.rotation
    if modification.profile.symmetric:
        u_rev, rev_reach = -u, reach
    else:
        u_rev, res_rev, rev_reach, _, _ = _flank_phase(design, modification, w2, r_pin, space, 1.0)
        if not np.all(res_rev <= CONTACT_TOLERANCE):
            flat = np.unravel_index(np.argmax(res_rev), res_rev.shape)
            raise ConvergenceError(
                f"unloaded contact (unloaded flank) did not converge at crank angle "
                f"{np.degrees(phi[flat[-2], 0]):.6g}°, pin {flat[-1] + 1}"
            )
    rev = deviated_geometry(u_rev, design, modification, r_pin, space)
    reverse = _behind(
        rotation,
        _wrap(arg_w - (t_root + u_rev / n2) - np.arctan2(rev.qy, rev.qx) - phi_t)
        - modification.rotation,
        n2,
    )
    # moment arm of the line of action (through Q along N) about the disc centre
    moment_arm = geo.qx * geo.ny - geo.qy * geo.nx
    profile_angle = np.where(reach, u, -np.pi)
    normal = (None, None)
    if normals:  # of the undeviated cycloid at the contact's φ1, as contact_normal
        a, rho_gen = generating_radii(design, modification)
        normal = _fixed_normal(
            arg_w, profile_angle, r_pin, a, design.eccentricity, design.pins, rho_gen
        )
    return UnloadedContact(
        rotation=np.where(reach, rotation, np.inf),
        reverse_rotation=np.where(rev_reach, reverse, -np.inf),
        moment_arm=np.where(reach, moment_arm, 0.0),
        cos_beta=np.where(reach, np.abs(np.cos(lateral)), 1.0),
        profile_angle=profile_angle,
        contact_radius=np.where(
            reach, np.hypot(geo.x, geo.y), _tip_radius(design, modification, space)
        ),
        curvature_radius=np.where(reach, geo.curvature_radius, np.inf),
        pin_radius=r_pin,
        residual=residual,
        normal_x=normal[0],
        normal_y=normal[1],
    )


def _tip_radius(design: PairDesign, modification: Modification, space: FloatArray) -> FloatArray:
    """Radius of the tip of the deviated profile (where unreachable pins are reported) [m]."""
    a, rho_gen = generating_radii(design, modification)
    return a + design.eccentricity - rho_gen - modification.profile.evaluate(-np.pi, space)


def _behind(rotation: FloatArray, reverse: FloatArray, teeth: int) -> FloatArray:
    """The unloaded-flank rotation ``reverse`` [rad] taken a whole turn up or down so that
    its gap to the loaded flank, ``rotation − reverse``, lies in (p/2 − π, p/2 + π], p =
    2π/n2 the tooth pitch (Eq. 11 of [1]).

    The flanks of one tooth space are at most a pitch apart (the gap is a pitch at the
    tooth tip, near 0 at the bottom, slightly negative where a pin interferes). Each
    rotation alone is wrapped to (−π, π]; for many teeth the gap is far from ±π and this
    changes nothing, but with n2 = 2 a pin at a tooth tip has a gap of half a turn,
    which the plain wrap could read as −π: a spurious interference of 180°.
    """
    gap = rotation - reverse
    centre = np.pi / teeth
    turns = np.floor((centre + np.pi - gap) / (2.0 * np.pi))
    return np.where(turns != 0.0, reverse - 2.0 * np.pi * turns, reverse)


def _wrap(angle: FloatArray) -> FloatArray:
    """Wrap angles to (−π, π] [rad]."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)
