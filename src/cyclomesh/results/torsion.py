"""Torsion curve of a cycloid stage as a labelled Dataset: the catalogue characteristics.

:func:`stiffness` runs :func:`cyclomesh.drive.solve.torsion_curve` (the rotation of the disc, or
the stack of discs, against the torque, both directions, at every crank angle) and labels
it in the units of an RV catalogue: rotation in arcsec, play and lost motion in arcmin,
torsional rigidity in N·m/arcmin. :func:`summarize_stiffness` reduces it to the headline
numbers. The definitions are in ``docs/drive.md``:

* play(φ) = TE of the reverse rest position − TE of the forward one (zero load);
* lost motion(φ) = TE(−0.03·T_r, φ) − TE(+0.03·T_r, φ);
* torsional rigidity(φ) = mean over the two directions of 0.5·T_r/|TE(±T_r, φ) − TE(±0.5·T_r, φ)|.

These are the characteristics of the cycloid-pin mesh alone. A whole reducer is much
softer (crank bearings, crankshafts and the first stage are in series with the mesh);
``series_stiffness_nm_per_arcmin`` adds that compliance as a linear spring and the
Dataset then carries the whole-drive curve beside the mesh curve.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from cyclomesh.core.case import Case, Model
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.drive.solve import TorsionCurve, torsion
from cyclomesh.exceptions import DesignError
from cyclomesh.quantities import QUANTITIES
from cyclomesh.results.dataset import resolve_crank_angles, resolve_disc_body, result_attrs
from cyclomesh.units import RAD_PER_ARCMIN, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["stiffness", "summarize_stiffness", "torsion_dataset"]

"""One minute of arc [rad]."""


def stiffness(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    rated_torque: float = 250.0,
    points: int = 41,
    crank_angles: ArrayLike | None = None,
    groove_deformation: bool = True,
    *,
    crank_angles_deg: ArrayLike | None = None,
    discs: int = 1,
    series_stiffness_nm_per_arcmin: float | None = None,
    contact_law: str = "half_plane",
    disc_body: Any = "rigid",
    crank_holes: Any = None,
    cache_dir: Any = None,
    friction: Any = None,
) -> xr.Dataset:
    """Torsion curve, play, lost motion and torsional rigidity of the mesh (Eqs. 5–26 of [1]).

    Parameters
    ----------
    design, modification, errors
        As in :func:`cyclomesh.analyse` (SI); one leading ring axis of the errors gives a
        ``ring`` dimension.
    rated_torque : float
        Rated torque T_r of the disc stack [N·m], > 0.
    points : int
        Evenly spaced torques from −T_r to +T_r (0 left out; ±3 %, ±50 %, ±100 % of T_r
        always added), see :func:`cyclomesh.drive.solve.torsion_torques`.
    crank_angles : array_like, optional
        Crank angles [rad]; default a revolution at 1°.
    groove_deformation : bool
        The "improved model" (Eq. 19 of [1]) or the "current model".
    crank_angles_deg : array_like, optional
        Crank angles [deg] instead of ``crank_angles``, kept exactly as the coordinate.
    discs : int
        Number of discs of the stack (see :func:`cyclomesh.drive.solve.solve_drive`).
    series_stiffness_nm_per_arcmin : float, optional
        Torsional stiffness of the rest of the drive in series with the mesh
        [N·m/arcmin]; adds ``drive_rotation``, ``drive_lost_motion`` and
        ``drive_torsional_rigidity``.
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (:func:`cyclomesh.core.ltca.solve_ltca`).
    friction : Friction, optional
        Friction at the pins (:func:`cyclomesh.drive.solve.torsion_curve`): adds the loop's
        ``rotation_ascending``, ``rotation_descending`` [arcsec] and ``hysteresis``
        [arcmin]; ``rotation`` is then the loop's mid curve.

    Returns
    -------
    xarray.Dataset
        Dimensions ``torque`` [N·m] and ``crank_angle`` [deg] (plus ``disc`` for a stack,
        ``ring`` for several rings). Variables: ``rotation`` [arcsec] (disc rotation from
        its theoretical position, TE sign: negative for a positive torque), ``contacts``,
        ``max_contact_stress`` [MPa], ``torque_share`` [N·m] (stacks), and per crank angle
        ``play`` and ``lost_motion`` [arcmin] and ``torsional_rigidity`` [N·m/arcmin].

    References
    ----------
    [1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672.
    """
    modification = modification or Modification()
    phi, degrees = resolve_crank_angles(crank_angles, crank_angles_deg)
    if degrees is None:
        degrees = np.degrees(phi)
    series = None
    if series_stiffness_nm_per_arcmin is not None:
        k = series_stiffness_nm_per_arcmin
        if isinstance(k, bool) or not isinstance(k, int | float) or not np.isfinite(k) or k <= 0:
            raise DesignError(
                f"series_stiffness_nm_per_arcmin must be a positive number, got {k!r}"
            )
        series = float(k) / RAD_PER_ARCMIN
    body = resolve_disc_body(disc_body, design, modification, crank_holes, cache_dir)
    case = Case(design, modification, errors, rated_torque, phi)
    model = Model(contact_law, groove_deformation, body, discs, friction=friction)
    curve = torsion(case, model, points, series)
    return torsion_dataset(curve, case, model, points, degrees, series_stiffness_nm_per_arcmin)


def torsion_dataset(
    curve: TorsionCurve,
    case: Case,
    model: Model,
    points: int,
    degrees: ArrayLike | None = None,
    series_stiffness_nm_per_arcmin: float | None = None,
) -> xr.Dataset:
    """The Dataset of :func:`stiffness` from a :class:`~cyclomesh.drive.solve.TorsionCurve`
    of ``case`` (``torque``: the rated torque) and ``model`` (its disc body resolved)."""
    design = case.design
    modification = case.modification or Modification()
    phi = np.asarray(case.crank_angles, float)
    degrees = np.degrees(phi) if degrees is None else degrees
    rated_torque, groove_deformation = case.torque, model.groove_deformation
    contact_law, disc_body = model.contact_law, model.disc_body
    series = curve.series_stiffness
    lead = curve.play.ndim - 1
    if lead > 1:
        raise ValueError("stiffness supports at most one ring axis")
    ring = ("ring",) * lead
    n_discs = curve.contacts.shape[-1]
    stack = ("disc",) if n_discs > 1 else ()

    def per_disc(value: np.ndarray) -> np.ndarray:
        return value if stack else value[..., 0]

    curve_dims = (*ring, "torque", "crank_angle")
    angle_dims = (*ring, "crank_angle")
    data = {
        "rotation": (
            curve_dims,
            curve.rotation / RAD_PER_ARCSEC,
            _attrs("rotation"),
        ),
        "contacts": (
            (*curve_dims, *stack),
            per_disc(curve.contacts),
            _attrs("contacts"),
        ),
        "max_contact_stress": (
            (*curve_dims, *stack),
            per_disc(curve.max_contact_stress) * 1e-6,
            _attrs("max_contact_stress"),
        ),
        "play": (
            angle_dims,
            curve.play / RAD_PER_ARCMIN,
            # the run's ``play`` is in arcsec: here arcmin, as the torsion curve's metrics
            {"units": "arcmin", "long_name": "angular play between the flanks at zero load"},
        ),
        "lost_motion": (
            angle_dims,
            curve.lost_motion / RAD_PER_ARCMIN,
            _attrs("lost_motion"),
        ),
        "torsional_rigidity": (
            angle_dims,
            curve.torsional_rigidity * RAD_PER_ARCMIN,
            _attrs("torsional_rigidity"),
        ),
    }
    if curve.hysteresis is not None:
        for name in ("rotation_ascending", "rotation_descending"):
            data[name] = (curve_dims, getattr(curve, name) / RAD_PER_ARCSEC, _attrs(name))
        data["hysteresis"] = (
            angle_dims,
            curve.hysteresis / RAD_PER_ARCMIN,
            _attrs("hysteresis"),
        )
    if stack:
        data["torque_share"] = (
            (*curve_dims, "disc"),
            curve.torque_share,
            _attrs("torque_share"),
        )
    if series is not None:
        data["drive_rotation"] = (
            curve_dims,
            curve.drive_rotation / RAD_PER_ARCSEC,
            _attrs("drive_rotation"),
        )
        data["drive_lost_motion"] = (
            angle_dims,
            curve.drive_lost_motion / RAD_PER_ARCMIN,
            _attrs("drive_lost_motion"),
        )
        data["drive_torsional_rigidity"] = (
            angle_dims,
            curve.drive_torsional_rigidity * RAD_PER_ARCMIN,
            _attrs("drive_torsional_rigidity"),
        )
    coords = {
        "torque": ("torque", curve.torque, {"units": "N·m", "long_name": "torque"}),
        "crank_angle": ("crank_angle", degrees, {"units": "deg"}),
    }
    if stack:
        coords["disc"] = ("disc", np.arange(1, n_discs + 1), {"units": "1"})
    if ring:
        coords["ring"] = ("ring", np.arange(curve.play.shape[0]))
    attrs = result_attrs(phi, design, modification, None, groove_deformation)
    attrs["contact_law"] = contact_law
    attrs["disc_body"] = disc_body if isinstance(disc_body, str) else "fe"
    attrs.update(
        title="cyclomesh torsion curve of the cycloid-pin mesh",
        discs=int(n_discs),
        rated_torque_nm=float(rated_torque),
        points=int(points),
        scope=(
            "cycloid-pin mesh only; crank bearings, crankshafts and the first stage add "
            "compliance in series (see series_stiffness_nm_per_arcmin)"
        ),
    )
    if series is not None:
        attrs["series_stiffness_nm_per_arcmin"] = float(series_stiffness_nm_per_arcmin)
    import xarray as xr

    return xr.Dataset(data, coords=coords, attrs=attrs)


_SUMMARY = {
    "play_arcmin_mean": ("play", "mean"),
    "play_arcmin_max": ("play", "max"),
    "lost_motion_arcmin_mean": ("lost_motion", "mean"),
    "lost_motion_arcmin_max": ("lost_motion", "max"),
    "torsional_rigidity_nm_per_arcmin_mean": ("torsional_rigidity", "mean"),
    "torsional_rigidity_nm_per_arcmin_min": ("torsional_rigidity", "min"),
    "hysteresis_arcmin_mean": ("hysteresis", "mean"),
    "hysteresis_arcmin_max": ("hysteresis", "max"),
}


def _attrs(name: str) -> dict[str, str]:
    """``units`` and ``long_name`` of a variable, from :data:`cyclomesh.quantities.QUANTITIES`."""
    return {"units": QUANTITIES[name].unit, "long_name": QUANTITIES[name].long_name}


def summarize_stiffness(ds: xr.Dataset) -> xr.Dataset:
    """Headline numbers of a torsion curve, reduced over crank angle (ring kept).

    ``play_arcmin_mean``, ``play_arcmin_max``, ``lost_motion_arcmin_mean``,
    ``lost_motion_arcmin_max``, ``torsional_rigidity_nm_per_arcmin_mean``,
    ``torsional_rigidity_nm_per_arcmin_min``; with a series stiffness also the
    ``drive_lost_motion_*`` and ``drive_torsional_rigidity_*`` numbers of the whole drive.
    """
    out = {}
    for prefix in ("", "drive_"):
        for key, (name, how) in _SUMMARY.items():
            if name == "play" and prefix:
                continue
            if prefix + name not in ds:
                continue
            value = getattr(ds[prefix + name], how)("crank_angle")
            out[prefix + key] = value.assign_attrs(units=QUANTITIES[prefix + key].unit)
    import xarray as xr

    summary = xr.Dataset(out)
    summary.attrs["rated_torque_nm"] = ds.attrs["rated_torque_nm"]
    return summary
