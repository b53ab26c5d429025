"""Labelled results: run :func:`cyclomesh.ltca.solve_ltca` and return an xarray Dataset.

This is the notebook entry point. The numbers come from the SI core; here they are
converted to the units a gear engineer reads (N, MPa, arcsec, degrees, mm), labelled
with ``crank_angle`` (degrees) and ``pin`` (1 … n1), and the inputs recorded as
attributes. :func:`summarize` reduces a result to the headline numbers of a study.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from cyclomesh.design import Modification, PairDesign, PinErrors
from cyclomesh.ltca import LTCA, solve_ltca

__all__ = ["analyse", "to_dataset", "summarize", "ARCSEC"]

ARCSEC = np.pi / (180.0 * 3600.0)
"""One second of arc [rad]."""

# name (an LTCA field): (scale from SI, units, long name)
_PER_PIN = {
    "pin_load": (1.0, "N", "pin-tooth contact force Fc"),
    "groove_load": (1.0, "N", "pin-groove contact force Fp"),
    "contact_stress": (1e-6, "MPa", "max. Hertzian pressure, pin-tooth"),
    "groove_stress": (1e-6, "MPa", "max. Hertzian pressure, pin-groove"),
    "backlash": (1.0 / ARCSEC, "arcsec", "unloaded backlash φbl (inf: unreachable)"),
    "overlap": (1.0 / ARCSEC, "arcsec", "interference with the unloaded flank"),
    "profile_angle": (180.0 / np.pi, "deg", "generating angle φ1 of contact"),
    "contact_radius": (1e3, "mm", "radius of the contact point on the disc"),
    "moment_arm": (1e3, "mm", "moment arm of the line of action"),
    "curvature_radius": (1e3, "mm", "signed profile curvature radius ρc"),
}
_PER_ANGLE = {
    "transmission_error": (1.0 / ARCSEC, "arcsec", "loaded TE"),
    "gear_ratio": (1.0, "1", "instantaneous gear ratio"),
    "contacts": (1, "1", "number of pins in contact"),
    "loaded_rotation": (1.0 / ARCSEC, "arcsec", "disc rotation under load Δφc"),
    "rest_rotation": (1.0 / ARCSEC, "arcsec", "unloaded rest position φc − φt"),
}


def _version() -> str:
    try:
        return version("cyclomesh")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def to_dataset(
    result: LTCA,
    design: PairDesign,
    modification: Modification,
    torque: float,
    groove_deformation: bool,
) -> xr.Dataset:
    """Label an :class:`~cyclomesh.ltca.LTCA` result (SI) as a Dataset in engineering units."""
    ring_dims = ("ring",) if result.transmission_error.ndim == 2 else ()
    if result.transmission_error.ndim > 2:
        raise ValueError("to_dataset supports at most one ring axis")
    dims_pin = (*ring_dims, "crank_angle", "pin")
    dims_angle = (*ring_dims, "crank_angle")
    data = {}
    for dims, table in ((dims_pin, _PER_PIN), (dims_angle, _PER_ANGLE)):
        for name, (scale, units, long_name) in table.items():
            attrs = {"units": units, "long_name": long_name}
            data[name] = (dims, getattr(result, name) * scale, attrs)
    coords = {
        "crank_angle": ("crank_angle", np.degrees(result.crank_angle), {"units": "deg"}),
        "pin": ("pin", np.arange(1, design.pins + 1), {"units": "1"}),
    }
    if ring_dims:
        coords["ring"] = ("ring", np.arange(result.transmission_error.shape[0]))
    step = np.degrees(np.diff(result.crank_angle))
    attrs = {
        "title": "cyclomesh loaded tooth contact analysis",
        "source": "Li, Tang, He, Sun, Machines 2022, 10, 672, doi:10.3390/machines10080672",
        "cyclomesh_version": _version(),
        "pins": design.pins,
        "teeth": design.teeth,
        "pin_circle_radius_mm": design.pin_circle_radius * 1e3,
        "pin_radius_mm": design.pin_radius * 1e3,
        "groove_radius_mm": design.groove_radius * 1e3,
        "eccentricity_mm": design.eccentricity * 1e3,
        "width_mm": design.width * 1e3,
        "pin_youngs_modulus_gpa": design.pin_material.youngs_modulus * 1e-9,
        "pin_poisson_ratio": design.pin_material.poisson_ratio,
        "disc_youngs_modulus_gpa": design.disc_material.youngs_modulus * 1e-9,
        "disc_poisson_ratio": design.disc_material.poisson_ratio,
        "ring_youngs_modulus_gpa": design.ring_material.youngs_modulus * 1e-9,
        "ring_poisson_ratio": design.ring_material.poisson_ratio,
        "modification_pin_circle_radius_um": modification.pin_circle_radius * 1e6,
        "modification_pin_radius_um": modification.pin_radius * 1e6,
        "modification_rotation_urad": modification.rotation * 1e6,
        "torque_nm": float(torque),
        "groove_deformation": int(bool(groove_deformation)),
        "gear_ratio_step_deg": float(step[0]) if step.size else 0.0,
        "sign_convention": (
            "crank counter-clockwise; disc turns by -phi/n2; TE positive in the disc's "
            "direction of motion (a lagging disc has negative TE)"
        ),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def analyse(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: float = 250.0,
    crank_angles: ArrayLike | None = None,
    groove_deformation: bool = True,
    *,
    crank_angles_deg: ArrayLike | None = None,
    contact_law: str = "paper",
) -> xr.Dataset:
    """Loaded tooth contact analysis of a cycloid-pin pair as a labelled Dataset.

    Parameters
    ----------
    design : PairDesign
        Geometry and materials (SI).
    modification : Modification, optional
        Tooth profile modification (Eq. 3 of [1]).
    errors : PinErrors, optional
        Pin ring errors (Eq. 5 of [1]); one leading axis gives a ``ring`` dimension.
    torque : float
        Torque on the disc [N·m].
    crank_angles : array_like, optional
        Crank angles [rad]; default a revolution at 1°.
    groove_deformation : bool
        "Improved model" (True) or "current model" (False).
    crank_angles_deg : array_like, optional
        Crank angles [deg], instead of ``crank_angles``; they become the ``crank_angle``
        coordinate exactly as given, so ``ds.sel(crank_angle=60.0)`` finds them.
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (see :mod:`cyclomesh.hertz`); recorded in the
        ``contact_law`` attribute.

    Returns
    -------
    xarray.Dataset
        Dimensions ``crank_angle`` [deg] and ``pin`` (1 … n1), plus ``ring`` for several
        rings; variables carry a ``units`` attribute (see :mod:`cyclomesh.analysis`).

    References
    ----------
    [1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672.
    """
    modification = modification or Modification()
    if crank_angles_deg is not None:
        if crank_angles is not None:
            raise TypeError("give crank_angles [rad] or crank_angles_deg, not both")
        degrees = np.atleast_1d(np.asarray(crank_angles_deg, float))
        crank_angles = np.deg2rad(degrees)
    elif crank_angles is None:
        degrees = np.arange(360.0)
        crank_angles = np.deg2rad(degrees)
    else:
        degrees = None
    result = solve_ltca(
        design, modification, errors, torque, crank_angles, groove_deformation, contact_law
    )
    ds = to_dataset(result, design, modification, torque, groove_deformation)
    ds.attrs["contact_law"] = contact_law
    if degrees is not None:
        ds = ds.assign_coords(crank_angle=("crank_angle", degrees, {"units": "deg"}))
    return ds


def summarize(ds: xr.Dataset) -> xr.Dataset:
    """Headline numbers of a result, reduced over crank angle and pin (ring kept).

    Returns a Dataset with ``te_mean_arcsec``, ``te_pp_arcsec``, ``max_pin_load_n``,
    ``max_groove_load_n``, ``max_contact_stress_mpa``, ``max_groove_stress_mpa``,
    ``contacts_min``, ``contacts_max``, ``gear_ratio_ripple_pct`` (peak-to-peak of the
    instantaneous ratio in % of n2, over the step ``gear_ratio_step_deg``),
    ``max_overlap_arcsec`` and ``overlap`` (any interference with an unloaded flank).
    """
    both = ("crank_angle", "pin")
    te = ds["transmission_error"]
    ratio = ds["gear_ratio"]
    teeth = ds.attrs["teeth"]
    out = {
        "te_mean_arcsec": te.mean("crank_angle"),
        "te_pp_arcsec": te.max("crank_angle") - te.min("crank_angle"),
        "max_pin_load_n": ds["pin_load"].max(both),
        "max_groove_load_n": ds["groove_load"].max(both),
        "max_contact_stress_mpa": ds["contact_stress"].max(both),
        "max_groove_stress_mpa": ds["groove_stress"].max(both),
        "contacts_min": ds["contacts"].min("crank_angle"),
        "contacts_max": ds["contacts"].max("crank_angle"),
        "gear_ratio_ripple_pct": (ratio.max("crank_angle") - ratio.min("crank_angle"))
        / teeth
        * 100.0,
        "max_overlap_arcsec": ds["overlap"].max(both),
    }
    summary = xr.Dataset(out)
    summary["overlap"] = summary["max_overlap_arcsec"] > 0
    units = {
        "te_mean_arcsec": "arcsec",
        "te_pp_arcsec": "arcsec",
        "max_pin_load_n": "N",
        "max_groove_load_n": "N",
        "max_contact_stress_mpa": "MPa",
        "max_groove_stress_mpa": "MPa",
        "contacts_min": "1",
        "contacts_max": "1",
        "gear_ratio_ripple_pct": "%",
        "max_overlap_arcsec": "arcsec",
    }
    for name, unit in units.items():
        summary[name].attrs = {"units": unit}
    summary.attrs["gear_ratio_step_deg"] = ds.attrs.get("gear_ratio_step_deg", 0.0)
    return summary
