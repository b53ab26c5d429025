"""Loaded tooth contact analysis through a crank revolution (Sections 2–3 of [1]).

:func:`solve_ltca` chains the model: unloaded contact of every pin (Eqs. 5–11),
Hertzian stiffness with or without the pin–groove deformation (Eqs. 19–23), load
sharing (Eqs. 15–18), contact stresses (Eq. 24), transmission error and gear ratio
(Eqs. 25, 26). It is vectorised over rings (leading axes of the errors), crank angles
and pins, works in SI units, and does no I/O.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.case import (
    Case,
    Model,
    check,
    check_contact_law,
    check_crank_angles,
    check_disc_body,
    check_pair,
)
from cyclomesh.core.contact import UnloadedContact, unloaded_contact
from cyclomesh.core.discbody import DiscBody, share_load_coupled, tooth_index
from cyclomesh.core.fields import (
    CONTACT_LOAD_FRACTION,
    contact_fields,
    contact_stresses,
    count_contacts,
)
from cyclomesh.core.hertz import CONTACT_LAWS, compliance_coefficients
from cyclomesh.core.kernel import kernel_name, share_load
from cyclomesh.core.kernel_contact import compliance_arrays, rest_and_backlash, rest_arrays
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.core.transmission import gear_ratio, transmission_error
from cyclomesh.exceptions import ConvergenceError, DesignError

__all__ = [
    "LTCA",
    "solve_ltca",
    "ltca",
    "rest_position",
    "check_disc_body",
    "check_contact_law",
    "check_crank_angles",
    "check_pair",
    "pin_compliance",
    "locate_failure",
    # re-exported from cyclomesh.core.case and cyclomesh.core.fields (issue 24)
    "count_contacts",
    "contact_stresses",
    "CONTACT_LOAD_FRACTION",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class LTCA:
    """Result of :func:`solve_ltca`, SI units.

    Per-pin arrays have shape ``(..., n_angles, n1)``, per-angle arrays ``(..., n_angles)``.

    Attributes
    ----------
    crank_angle : ndarray
        φin [rad].
    pin_load, groove_load : ndarray
        Fc,i and Fp,i = Fc,i·cos βi [N].
    contact_stress, groove_stress : ndarray
        Maximum Hertzian pressure on tooth and groove (Eq. 24) [Pa].
    backlash : ndarray
        φbl,i (Eq. 11) [rad]; +inf if the pin cannot reach the loaded flank.
    overlap : ndarray
        Interference of the loaded disc with the unloaded flank at pin i [rad], 0 if none.
    profile_angle, contact_radius, moment_arm, curvature_radius : ndarray
        Contact geometry on the loaded flank [rad, m, m, m].
    rest_rotation : ndarray
        φc − φt, rest position of the unloaded disc from its theoretical one [rad].
    loaded_rotation : ndarray
        Δφc [rad].
    transmission_error : ndarray
        TE (Eq. 25) [rad], negative when the disc lags.
    gear_ratio : ndarray
        Instantaneous ratio (Eq. 26) [-].
    contacts : ndarray
        Number of pins in contact [-]: pins carrying more than
        :data:`CONTACT_LOAD_FRACTION` of the largest pin load at that crank angle
        (:func:`count_contacts`).
    """

    crank_angle: FloatArray
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
    rest_rotation: FloatArray
    loaded_rotation: FloatArray
    transmission_error: FloatArray
    gear_ratio: FloatArray
    contacts: NDArray[np.int64]


CONDITIONED_ARM = 1e-4
"""Smallest moment arm [m] of a pin that can set the rest position of the disc."""


def rest_position(rotation: FloatArray, moment_arm: FloatArray) -> FloatArray:
    """Rest position φc − φt of the unloaded disc: the first pin it touches (Eq. 11 of [1]).

    φc is the extreme (here the smallest counter-clockwise) contact rotation over the
    pins. A pin right at a tip or a tooth-space bottom (moment arm below
    :data:`CONDITIONED_ARM`) is left out: its gap does not change to first order with
    the disc rotation, so it cannot stop the disc, and its contact rotation is
    ill-conditioned (set only to about 1e-9 rad by round-off). With the numba kernel
    (:mod:`cyclomesh.core.kernel`) the same minimum in one compiled pass, bit for bit.

    Parameters
    ----------
    rotation : ndarray
        Contact rotations φc,i − φt, shape (..., n1) [rad].
    moment_arm : ndarray
        Moment arms l_i [m].

    Returns
    -------
    ndarray
        Shape (...) [rad].
    """
    if kernel_name() == "numba":  # the same min and comparisons in one compiled pass
        return rest_arrays(rotation, None, moment_arm, CONDITIONED_ARM)[0]
    conditioned = np.where(moment_arm >= CONDITIONED_ARM, rotation, np.inf)
    rest = np.min(conditioned, axis=-1)
    return np.where(np.isfinite(rest), rest, np.min(rotation, axis=-1))


def solve_ltca(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: float = 250.0,
    crank_angles: ArrayLike = (0.0,),
    groove_deformation: bool = True,
    contact_law: str = "half_plane",
    disc_body: str | DiscBody = "rigid",
) -> LTCA:
    """Loaded tooth contact analysis of a cycloid-pin pair (Eqs. 1–26 of [1]).

    Parameters
    ----------
    design : PairDesign
        Nominal geometry and materials.
    modification : Modification, optional
        Tooth profile modification (Eq. 3).
    errors : PinErrors, optional
        Pin ring errors (Eq. 5); leading axes are independent rings.
    torque : float
        Torque on the disc T [N·m], > 0.
    crank_angles : array_like
        Crank angles φin [rad], one-dimensional and increasing.
    groove_deformation : bool
        True for the "improved model" (pin–groove deformation, Eq. 19), False for the
        "current model".
    contact_law : {"paper", "half_plane"}
        The tooth's term of the contact law: the approach of a half-plane to the disc
        centre (Johnson, eq. 5.41; the default), finite at the profile's inflection points
        and converged in the crank step, or Eq. 20 of [1] as published (``"paper"``, to
        reproduce the paper; its ratio ripple and TE peak-to-peak grow without bound as
        the crank step shrinks); see :mod:`cyclomesh.core.hertz` and ``docs/contact-law.md``.
    disc_body : "rigid" or DiscBody
        The disc body: rigid apart from the contact law ([1], the default, solved by
        :func:`~cyclomesh.core.loadsharing.share_load` exactly as before), or elastic with
        the influence coefficients of a :class:`~cyclomesh.core.discbody.DiscBody`
        (:func:`cyclomesh.fe.influence.influence`; needs ``contact_law="half_plane"``,
        whose near field the coefficients leave out).

    Returns
    -------
    LTCA

    Raises
    ------
    DesignError
        For an invalid torque, crank angles, undercut profile or interfering pins.
    ConvergenceError
        If a solver fails; the message names the crank angle (and ring).
    """
    return ltca(
        Case(design, modification, errors, torque, crank_angles),
        Model(contact_law, groove_deformation, disc_body),
    )


def ltca(case: Case, model: Model) -> LTCA:
    """:func:`solve_ltca` of a :class:`~cyclomesh.core.case.Case` and a
    :class:`~cyclomesh.core.case.Model` (one disc, one positive torque, no stage)."""
    if model.discs != 1 or model.stage is not None:
        raise DesignError(
            "ltca: one disc and no stage (a stack or a stage: cyclomesh.results.chain.run)"
        )
    c = check(case, model, torque="positive")
    if c.friction is not None:
        raise DesignError(
            "ltca: the one-disc fast path is frictionless; friction is solved by the stack "
            "(cyclomesh.drive.solve.drive, cyclomesh.analyse)"
        )
    design, modification, errors, phi = c.design, c.modification, c.errors, c.phi
    body, ring_shape, torque = c.body, c.ring_shape, case.torque
    geo = unloaded_contact(design, modification, errors, phi)
    if kernel_name() == "numba":  # both in one compiled pass, the same bits
        rest, backlash = rest_and_backlash(geo.rotation, geo.moment_arm, CONDITIONED_ARM)
    else:
        rest = rest_position(geo.rotation, geo.moment_arm)
        backlash = geo.rotation - rest[..., None]
    alpha, gamma = pin_compliance(geo, design, c.groove_deformation, c.contact_law)
    try:
        if body is None:
            loaded, force = share_load(
                backlash, geo.moment_arm, alpha, gamma, torque, angle_axis=True
            )
        else:
            tooth = tooth_index(design.pins, design.pitch, phi)
            loaded, force = share_load_coupled(
                backlash,
                geo.moment_arm,
                alpha,
                gamma,
                torque,
                body,
                tooth,
                geo.profile_angle,
                angle_axis=True,
            )
    except ConvergenceError as exc:
        raise locate_failure(exc, (*ring_shape, phi.size), phi) from None
    fields = contact_fields(
        ("groove_load", "contact_stress", "groove_stress", "overlap", "contacts"),
        design,
        geo,
        force,
        rotation=(rest + loaded)[..., None],
    )
    te = transmission_error(rest, loaded)
    return LTCA(
        crank_angle=phi,
        pin_load=force,
        groove_load=fields["groove_load"],
        contact_stress=fields["contact_stress"],
        groove_stress=fields["groove_stress"],
        backlash=backlash,
        overlap=fields["overlap"],
        profile_angle=geo.profile_angle,
        contact_radius=geo.contact_radius,
        moment_arm=geo.moment_arm,
        curvature_radius=geo.curvature_radius,
        rest_rotation=rest,
        loaded_rotation=loaded,
        transmission_error=te,
        gear_ratio=gear_ratio(te, phi, design.teeth),
        contacts=fields["contacts"],
    )


def pin_compliance(
    geo: UnloadedContact,
    design: PairDesign,
    groove_deformation: bool,
    contact_law: str = "half_plane",
) -> tuple[FloatArray, FloatArray]:
    """Coefficients (α, γ) of δ = F(α − γ ln F) of every pin contact [m/N].

    Eqs. 19–23 of [1] with the tooth term of ``contact_law`` (Eq. 20, or the half-plane
    law of :mod:`cyclomesh.core.hertz`, Johnson eq. 5.41); with the numba kernel
    (:mod:`cyclomesh.core.kernel`) the same formulas in one compiled pass
    (:func:`cyclomesh.core.kernel_contact.compliance_arrays`).
    """
    if contact_law in CONTACT_LAWS and kernel_name() == "numba":
        shape = np.shape(geo.curvature_radius)
        # a stack's (..., A, N, n1) as (..., A·N, n1): its pin radii, the same at every
        # crank angle and disc (a broadcast view), are then read one row per ring
        # instead of copied for every crank angle (kernel_contact's pin rows)
        rows = shape if len(shape) <= 3 else (-1, shape[-3] * shape[-2], shape[-1])
        alpha, gamma = compliance_arrays(
            *(
                np.broadcast_to(v, shape).reshape(rows)
                for v in (geo.pin_radius, geo.curvature_radius, geo.cos_beta, geo.contact_radius)
            ),
            design,
            groove_deformation,
            contact_law,
        )
        return alpha.reshape(shape), gamma.reshape(shape)
    with np.errstate(divide="ignore", invalid="ignore"):  # unreachable pins: never loaded
        return compliance_coefficients(
            geo.pin_radius,
            geo.curvature_radius,
            design.groove_radius,
            geo.cos_beta,
            design.width,
            design.pin_material.compliance,
            design.disc_material.compliance,
            design.ring_material.compliance,
            groove_deformation,
            contact_law,
            geo.contact_radius,
            design.disc_material.poisson_ratio,
        )


def locate_failure(exc: ConvergenceError, shape: tuple, phi: FloatArray) -> ConvergenceError:
    """The load-sharing error ``exc`` with the ring and crank angle of its case named."""
    index = getattr(exc, "case_index", None)
    if index is None:
        return exc
    where = np.unravel_index(index, shape)
    ring = f"ring {where[0]}, " if len(where) > 1 else ""
    return ConvergenceError(f"{ring}crank angle {np.degrees(phi[where[-1]]):.6g}°: {exc}")
