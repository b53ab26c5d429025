"""Post-contact fields: what follows from the pin loads once the load sharing is solved.

Every solver (the one-disc chain :func:`cyclomesh.core.ltca.solve_ltca`, the stacks of
:mod:`cyclomesh.drive.solve`, the RV stage of :mod:`cyclomesh.stage.solve`) solves for the
pin loads F_i and the disc rotation, and then asks :func:`contact_fields` for the fields
it reports: the Hertzian pressures of tooth and groove (Eq. 24 of [1]), the groove load
F_i·cos β_i (Eq. 18), the interference with the unloaded flank, the torque share Σ F·l
(Eqs. 16, 18), the resultant mesh force, the direction of each pin force and the pins in
contact. A new per-contact quantity (a friction force) is one more entry here, computed
from the contact kinematics of :mod:`cyclomesh.core.contact`.

NumPy (or the compiled pass of the numba kernel), SI units, no I/O.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.contact import UnloadedContact
from cyclomesh.core.hertz import (
    effective_modulus,
    max_pressure,
    pin_groove_radius,
    pin_tooth_radius,
)
from cyclomesh.core.kernel import kernel_name
from cyclomesh.core.kernel_contact import stack_fields, stress_arrays
from cyclomesh.core.pair import PairDesign

__all__ = [
    "CONTACT_FIELDS",
    "PIN_FIELDS",
    "CONTACT_LOAD_FRACTION",
    "contact_fields",
    "contact_stresses",
    "count_contacts",
    "overlap",
]

FloatArray = NDArray[np.float64]

CONTACT_LOAD_FRACTION = 1e-3
"""A pin is counted in contact when its load exceeds this fraction of the largest pin load
at the same crank angle (over all discs of a stack). Pins at a tip or a tooth-space bottom
(moment arm ≈ 0) touch the disc but carry about 1e-8 of the peak load; 0.1 % leaves them
out and no pin that carries load (the lightest loaded pins of the examples carry 0.3 % to
5 % of the peak)."""

CONTACT_FIELDS = (
    "groove_load",
    "contact_stress",
    "groove_stress",
    "overlap",
    "force_angle",
    "torque_share",
    "mesh_force",
    "contacts",
)
"""The fields :func:`contact_fields` computes (``mesh_force`` gives ``mesh_force_x`` and
``mesh_force_y``)."""

PIN_FIELDS = frozenset({"groove_load", "contact_stress", "groove_stress", "overlap", "force_angle"})
"""The fields of :data:`CONTACT_FIELDS` with one value per pin, (..., n1); the others have
one per disc (``torque_share``, ``mesh_force_x``/``_y``, ``contacts``)."""


def contact_stresses(
    geo: UnloadedContact, design: PairDesign, force: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Groove force Fc·cos β [N] and the Hertzian pressures of tooth and groove [Pa].

    Eqs. 18 and 24 of [1]: p = sqrt(F·E*/(π·b·ρ)) with the pin–tooth radius of the
    contact and the pin–groove radius (with the numba kernel, :mod:`cyclomesh.core.kernel`,
    the same formulas in one compiled pass).
    """
    if kernel_name() == "numba":
        shape = np.shape(force)
        # a stack's (..., A, N, n1) as (..., A·N, n1): its pin radii, the same at every
        # crank angle and disc (a broadcast view), are then read one row per ring instead
        # of copied for every crank angle (kernel_contact's pin rows), as pin_compliance
        rows = shape if len(shape) <= 3 else (-1, shape[-3] * shape[-2], shape[-1])
        out = stress_arrays(
            *(
                np.broadcast_to(v, shape).reshape(rows)
                for v in (geo.pin_radius, geo.curvature_radius, geo.cos_beta, force)
            ),
            design,
        )
        return tuple(v.reshape(shape) for v in out)
    pin_c = design.pin_material.compliance
    groove_force = force * geo.cos_beta
    tooth_modulus = effective_modulus(pin_c, design.disc_material.compliance)
    groove_modulus = effective_modulus(pin_c, design.ring_material.compliance)
    with np.errstate(invalid="ignore"):  # unreachable pins have ρc = inf and no load
        rho_pc = np.where(force > 0, pin_tooth_radius(geo.pin_radius, geo.curvature_radius), 1.0)
    rho_pg = pin_groove_radius(geo.pin_radius, design.groove_radius)
    contact_stress = max_pressure(force, rho_pc, tooth_modulus, design.width)
    groove_stress = max_pressure(groove_force, rho_pg, groove_modulus, design.width)
    return groove_force, contact_stress, groove_stress


def count_contacts(force: FloatArray, axes: int = 1) -> NDArray[np.int64]:
    """Pins in contact: load above :data:`CONTACT_LOAD_FRACTION` of the largest pin load.

    Parameters
    ----------
    force : ndarray
        Pin loads [N], the last ``axes`` axes are the pins of one crank angle (``axes=2``
        for the discs × pins of a stack: the reference is the stack's largest pin load).
    axes : int
        Trailing axes that make up the reference set; the count is per last axis
        (per disc).

    Returns
    -------
    ndarray
        Counts, ``force.shape[:-1]``.
    """
    reference = np.max(force, axis=tuple(range(-axes, 0)), keepdims=True)
    return np.sum(force > CONTACT_LOAD_FRACTION * reference, axis=-1)


def overlap(reverse_rotation: FloatArray, rotation: FloatArray) -> FloatArray:
    """Interference of the loaded disc with the unloaded flank of every pin [rad], 0 if none.

    The unloaded flank of pin i touches at the disc rotation φ'c,i (its reverse contact
    rotation, Eq. 11 of [1] on the other flank); a disc that sits clockwise of it, at
    ``rotation`` = φc − φt + Δφc < φ'c,i − φt, overlaps the pin by the difference.

    Parameters
    ----------
    reverse_rotation : ndarray
        φ'c,i − φt of :class:`~cyclomesh.core.contact.UnloadedContact` [rad].
    rotation : ndarray
        Loaded disc rotation from its theoretical position [rad], broadcast against it.
    """
    return np.maximum(reverse_rotation - rotation, 0.0)


def contact_fields(
    what: Iterable[str],
    design: PairDesign,
    geo: UnloadedContact,
    force: FloatArray,
    *,
    rotation: FloatArray | None = None,
    normal: tuple[FloatArray, FloatArray] | None = None,
    moment_arm: FloatArray | None = None,
    stack_axes: int = 1,
) -> dict[str, FloatArray]:
    """The post-contact fields a solver asks for, from the pin loads (SI).

    Parameters
    ----------
    what : iterable of str
        Names from :data:`CONTACT_FIELDS`.
    design : PairDesign
    geo : UnloadedContact
        Contact geometry, shape of ``force`` (..., n1).
    force : ndarray
        Pin loads F_i on the loaded flanks [N].
    rotation : ndarray, optional
        Loaded disc rotation φc − φt + Δφc [rad], broadcast against ``force``; needed for
        ``overlap``.
    normal : (ndarray, ndarray), optional
        Outward flank normal (:func:`~cyclomesh.core.contact.contact_normal`); needed for
        ``force_angle`` and ``mesh_force``.
    moment_arm : ndarray, optional
        Moment arms of the torque share [m] (default ``geo.moment_arm``); with ``force``
        and ``normal`` they may carry more contacts than ``geo`` (the opposite flanks of
        the stage), which the stresses do not read.
    stack_axes : int
        Trailing axes of ``force`` that form the reference of :func:`count_contacts`
        (2 for the discs × pins of a stack).

    Returns
    -------
    dict
        ``groove_load`` [N], ``contact_stress`` and ``groove_stress`` [Pa] (Eq. 24),
        ``overlap`` [rad], ``force_angle`` [rad] (direction of the force of each pin on
        its disc, fixed frame), ``torque_share`` [N·m] (per disc, Σ F·l),
        ``mesh_force_x`` and ``mesh_force_y`` [N] (resultant of the pin forces on each
        disc), ``contacts`` (per disc).
    """
    what = set(what)
    unknown = what - set(CONTACT_FIELDS)
    if unknown:
        raise ValueError(f"contact_fields: unknown fields {sorted(unknown)}")
    out: dict[str, FloatArray] = {}
    if what & {"groove_load", "contact_stress", "groove_stress"}:
        groove, stress, groove_stress = contact_stresses(geo, design, force)
        out.update(groove_load=groove, contact_stress=stress, groove_stress=groove_stress)
    if kernel_name() == "numba":  # the per-disc sums, counts and overlaps in one pass
        out.update(_compiled_fields(what, geo, force, rotation, normal, moment_arm, stack_axes))
    if "overlap" in what and "overlap" not in out:
        out["overlap"] = overlap(geo.reverse_rotation, rotation)
    if "force_angle" in what:
        out["force_angle"] = np.arctan2(-normal[1], -normal[0])
    if "torque_share" in what and "torque_share" not in out:
        arm = geo.moment_arm if moment_arm is None else moment_arm
        out["torque_share"] = np.sum(force * arm, axis=-1)
    if "contacts" in what and "contacts" not in out:
        out["contacts"] = count_contacts(force, axes=stack_axes)
    if "mesh_force" in what and "mesh_force_x" not in out:
        out["mesh_force_x"] = -np.sum(force * normal[0], axis=-1)
        out["mesh_force_y"] = -np.sum(force * normal[1], axis=-1)
    return {name: out[name] for name in out if name in what or name.startswith("mesh_force")}


def _compiled_fields(
    what: set[str],
    geo: UnloadedContact,
    force: FloatArray,
    rotation: FloatArray | None,
    normal: tuple[FloatArray, FloatArray] | None,
    moment_arm: FloatArray | None,
    stack_axes: int,
) -> dict[str, FloatArray]:
    """``overlap``, ``contacts``, ``torque_share`` and ``mesh_force_x``/``_y`` of
    :func:`contact_fields` in one compiled pass
    (:func:`cyclomesh.core.kernel_contact.stack_fields`, NumPy's sums in NumPy's order:
    the same bits), where every array it reads has ``force``'s shape and ``rotation``
    one value per row of the stack; else nothing (NumPy computes them)."""
    shape = np.shape(force)
    if stack_axes not in (1, 2) or not what & {"overlap", "contacts", "torque_share", "mesh_force"}:
        return {}

    def same(x: object) -> bool:
        return np.shape(x) == shape

    reverse = None
    if "overlap" in what:
        rows = (*shape[:-stack_axes], *(1,) * stack_axes)
        if not same(geo.reverse_rotation) or np.broadcast_shapes(np.shape(rotation), rows) != rows:
            return {}
        reverse = geo.reverse_rotation
    arm = None
    if "torque_share" in what:
        arm = geo.moment_arm if moment_arm is None else moment_arm
        if not same(arm):
            return {}
    if "mesh_force" in what and not (same(normal[0]) and same(normal[1])):
        return {}
    out = stack_fields(
        force,
        stack_axes,
        CONTACT_LOAD_FRACTION,
        arm,
        normal if "mesh_force" in what else None,
        reverse,
        rotation,
    )
    if out is None:
        return {}
    if "contacts" not in what:
        del out["contacts"]
    return out
