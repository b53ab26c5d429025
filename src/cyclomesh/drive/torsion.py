"""The torsion curve of the cycloid-pin mesh: rotation against torque, both directions.

Torques from :func:`torsion_torques` (±3 %, ±50 %, ±100 % of the rated torque always
included), lost motion and torsional rigidity from :func:`torsion_metrics`, the curve of a
:class:`~cyclomesh.core.case.Case` and a :class:`~cyclomesh.core.case.Model` from
:func:`torsion` (:func:`torsion_curve` its public wrapper), every point solved with
Eqs. 5–26 of [1] on both flanks (:mod:`cyclomesh.drive.mesh`, docs/drive.md).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.case import Case, Model, check, check_discs
from cyclomesh.core.discbody import DiscBody
from cyclomesh.core.friction import Friction
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.core.transmission import transmission_error
from cyclomesh.drive.friction import FrictionCoupling
from cyclomesh.drive.mesh import load_stack, reverse_fields, stack_meshes
from cyclomesh.exceptions import DesignError

__all__ = [
    "TorsionCurve",
    "torsion_curve",
    "torsion",
    "torsion_torques",
    "torsion_metrics",
    "LOST_MOTION_FRACTION",
    "RIGIDITY_FRACTIONS",
]

FloatArray = NDArray[np.float64]


LOST_MOTION_FRACTION = 0.03
"""Lost motion is measured at ±3 % of the rated torque."""
RIGIDITY_FRACTIONS = (0.5, 1.0)
"""Torsional rigidity is the secant between 50 % and 100 % of the rated torque."""


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

    Raises
    ------
    DesignError
        If the TE at 50 % and 100 % of ``rated_torque`` is the same double (a rated torque
        so small, e.g. 1e-300 N·m, that the rigidity would be infinite).
    """

    def te(fraction: float) -> FloatArray:
        return rotation[..., _at(torques, fraction * rated_torque), :]

    lost = te(-LOST_MOTION_FRACTION) - te(LOST_MOTION_FRACTION)
    half, full = RIGIDITY_FRACTIONS
    rigidity = 0.0
    for sign in (-1.0, 1.0):
        turn = np.abs(te(sign * full) - te(sign * half))
        if not np.all(turn > 0):  # 0 (or NaN): the torque moves the TE by less than 1 ulp
            raise DesignError(
                f"rated torque {rated_torque:g} N·m: the TE does not change between "
                f"{half:.0%} and {full:.0%} of it (the mesh deflection is below the "
                "resolution of a double), so the torsional rigidity is undefined; raise "
                "the rated torque (stiffness.rated_torque_nm)"
            )
        rigidity = rigidity + 0.5 * ((full - half) * rated_torque / turn)
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
    rotation_ascending, rotation_descending : ndarray or None
        With friction: TE on the branch of rising torque (the disc turning
        counter-clockwise, friction resisting it) and of falling torque [rad], (..., Q, A);
        ``rotation`` is then their mean (the mid curve).
    hysteresis : ndarray or None
        With friction: the loop's largest width over the torques, ascending − descending
        branch [rad] (≥ 0: on the rising branch friction helps the pins hold the disc, so it
        turns less), (..., A).
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
    rotation_ascending: FloatArray | None = None
    rotation_descending: FloatArray | None = None
    hysteresis: FloatArray | None = None


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
    friction: Friction | None = None,
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
    friction : Friction, optional
        Friction at the pin contacts (:mod:`cyclomesh.core.friction`): the crank held, the
        disc turning about its centre, each torque solved on the rising branch (friction
        against a counter-clockwise turn) and on the falling one: the curve becomes a
        loop. None or all coefficients 0: the frictionless curve, bit for bit.

    Returns
    -------
    TorsionCurve
    """
    return torsion(
        Case(design, modification, errors, rated_torque, crank_angles),
        Model(contact_law, groove_deformation, disc_body, discs, friction=friction),
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
    branches = {}
    if c.friction is not None:
        for name, sense in (("rotation_ascending", 1.0), ("rotation_descending", -1.0)):
            te = []
            for value in torques:
                mesh = fwd if value > 0 else rev  # the mirror turns the disc's sense over
                coupling = FrictionCoupling(mesh, c.friction, 0.0, sense if value > 0 else -sense)
                fields = load_stack(mesh, abs(float(value)), coupling)
                fields = {"rest_rotation": mesh.rest, "loaded_rotation": fields["loaded_rotation"]}
                if value < 0:
                    fields = reverse_fields(fields)
                te.append(transmission_error(fields["rest_rotation"], fields["loaded_rotation"]))
            branches[name] = np.stack(te, axis=-2)
    rotation, contacts, stress, share = [], [], [], []
    for value in torques:
        fields = load_stack(fwd if value > 0 else rev, abs(float(value)))
        fields["rest_rotation"] = (fwd if value > 0 else rev).rest
        fields["max_contact_stress"] = np.max(fields["contact_stress"], axis=-1)
        keep = ("torque_share", "contacts", "rest_rotation", "loaded_rotation")
        fields = {name: fields[name] for name in (*keep, "max_contact_stress")}
        if value < 0:
            fields = reverse_fields(fields)
        rotation.append(transmission_error(fields["rest_rotation"], fields["loaded_rotation"]))
        contacts.append(fields["contacts"])
        stress.append(fields["max_contact_stress"])
        share.append(fields["torque_share"])
    rotation = np.stack(rotation, axis=-2)
    if branches:  # the mid curve of the loop; contacts and stresses of the frictionless one
        rotation = 0.5 * (branches["rotation_ascending"] + branches["rotation_descending"])
        width = branches["rotation_ascending"] - branches["rotation_descending"]
        branches["hysteresis"] = np.max(width, axis=-2)
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
        **branches,
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
