"""The one table of result metrics: the headline numbers of a loaded tooth contact analysis.

:data:`METRICS` names every metric once, with its unit and long name; summaries
(:func:`cyclomesh.summarize`), ``summary.json``, the tolerance study's per-ring
outputs and statistics, CSV and Parquet headers and the CLI tables all read it. A
kind of study that adds a metric adds it here.

:func:`summary_metrics` reduces per-angle and per-pin arrays (engineering units, as in
the Dataset of :func:`cyclomesh.analyse`) over the crank angle and the pins, leaving
any leading ring axes. It is plain NumPy, so the tolerance study's workers reduce
thousands of rings without building Datasets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Metric",
    "METRICS",
    "DRIVE_METRICS",
    "STIFFNESS_METRICS",
    "FE_METRICS",
    "STRESS_METRIC",
    "summary_metrics",
    "metric_label",
]


@dataclass(frozen=True)
class Metric:
    """A result metric: file name (with its unit suffix), unit, long name, short label."""

    name: str
    unit: str
    long_name: str
    label: str


METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        Metric("te_mean_arcsec", "arcsec", "mean loaded transmission error (Eq. 25)", "TE mean"),
        Metric("te_pp_arcsec", "arcsec", "peak-to-peak loaded transmission error", "TE p-p"),
        Metric("max_pin_load_n", "N", "largest pin load Fc", "max pin load"),
        Metric("max_groove_load_n", "N", "largest groove load Fp", "max groove load"),
        Metric(
            "max_contact_stress_mpa",
            "MPa",
            "peak contact stress, pin-tooth (Eq. 24)",
            "max σH tooth",
        ),
        Metric(
            "max_groove_stress_mpa",
            "MPa",
            "peak contact stress, pin-groove (Eq. 24)",
            "max σH groove",
        ),
        Metric("contacts_min", "1", "fewest pins in contact", "min pins in contact"),
        Metric("contacts_max", "1", "most pins in contact", "max pins in contact"),
        Metric(
            "gear_ratio_ripple_pct",
            "%",
            "gear-ratio ripple, peak-to-peak in % of n2 (Eq. 26)",
            "ratio ripple",
        ),
        Metric(
            "max_overlap_arcsec",
            "arcsec",
            "largest interference with an unloaded-side pin",
            "max overlap",
        ),
        Metric("overlap", "1", "any interference with an unloaded-side pin (0/1)", "overlap"),
    )
}
"""Every headline metric, in the order of tables and files."""

DRIVE_METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        Metric("play_arcsec_mean", "arcsec", "mean play between the flanks at zero load", "play"),
        Metric("play_arcsec_max", "arcsec", "largest play between the flanks", "max play"),
        Metric(
            "max_mesh_force_n",
            "N",
            "largest mesh force on a disc (crank bearing load)",
            "max mesh force",
        ),
        Metric(
            "torque_share_min_nm", "N m", "smallest torque carried by one disc", "min disc torque"
        ),
        Metric(
            "torque_share_max_nm", "N m", "largest torque carried by one disc", "max disc torque"
        ),
    )
}
"""Drive characteristics of a run (:func:`cyclomesh.analyse`; docs/drive.md). Not in
:data:`METRICS`: the tolerance study's workers reduce core results without them."""

STIFFNESS_METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        Metric("play_arcmin_mean", "arcmin", "mean play at zero load", "play"),
        Metric("play_arcmin_max", "arcmin", "largest play at zero load", "max play"),
        Metric(
            "lost_motion_arcmin_mean",
            "arcmin",
            "mean lost motion, TE(-3 %) - TE(+3 %) of rated",
            "lost motion",
        ),
        Metric("lost_motion_arcmin_max", "arcmin", "largest lost motion", "max lost motion"),
        Metric(
            "torsional_rigidity_nm_per_arcmin_mean",
            "N m/arcmin",
            "mean torsional rigidity of the mesh, secant 50-100 % of rated",
            "mesh rigidity",
        ),
        Metric(
            "torsional_rigidity_nm_per_arcmin_min",
            "N m/arcmin",
            "smallest torsional rigidity of the mesh",
            "min mesh rigidity",
        ),
        Metric(
            "drive_lost_motion_arcmin_mean",
            "arcmin",
            "mean lost motion of the whole drive (mesh + series stiffness)",
            "drive lost motion",
        ),
        Metric(
            "drive_lost_motion_arcmin_max",
            "arcmin",
            "largest lost motion of the whole drive",
            "max drive lost motion",
        ),
        Metric(
            "drive_torsional_rigidity_nm_per_arcmin_mean",
            "N m/arcmin",
            "mean torsional rigidity of the whole drive (mesh + series stiffness)",
            "drive rigidity",
        ),
        Metric(
            "drive_torsional_rigidity_nm_per_arcmin_min",
            "N m/arcmin",
            "smallest torsional rigidity of the whole drive",
            "min drive rigidity",
        ),
        Metric(
            "hysteresis_arcmin_mean",
            "arcmin",
            "mean width of the friction loop (with [friction])",
            "hysteresis",
        ),
        Metric(
            "hysteresis_arcmin_max",
            "arcmin",
            "largest width of the friction loop",
            "max hysteresis",
        ),
    )
}
"""Headline numbers of a torsion curve (``cyclomesh stiffness``; docs/drive.md)."""


def _fe_metrics() -> dict[str, Metric]:
    out = [
        Metric("fe_max_pin_load_n", "N", "largest pin load, FE", "FE max pin load"),
        Metric(
            "fe_max_contact_stress_mpa", "MPa", "peak contact stress, pin-tooth, FE", "FE max σH"
        ),
        Metric(
            "fe_rotation_arcsec_mean",
            "arcsec",
            "mean loaded disc position, FE (TE convention, Eq. 25)",
            "FE rotation",
        ),
    ]
    for law in ("paper", "half_plane"):
        out += [
            Metric(f"ltca_{law}_max_pin_load_n", "N", f"largest pin load, LTCA ({law} law)", law),
            Metric(
                f"ltca_{law}_pin_load_rms_pct",
                "%",
                f"RMS of LTCA ({law} law) minus FE pin loads, % of the FE peak",
                f"{law} RMS dev.",
            ),
            Metric(
                f"ltca_{law}_rotation_arcsec_mean",
                "arcsec",
                f"mean loaded disc position, LTCA ({law} law)",
                f"{law} rotation",
            ),
        ]
    out += [
        Metric(
            "ltca_max_pin_load_n",
            "N",
            "largest pin load, LTCA of the study ([analysis]: contact law, disc body)",
            "LTCA",
        ),
        Metric(
            "ltca_pin_load_rms_pct",
            "%",
            "RMS of LTCA of the study minus FE pin loads, % of the FE peak",
            "LTCA RMS dev.",
        ),
        Metric(
            "ltca_rotation_arcsec_mean",
            "arcsec",
            "mean loaded disc position, LTCA of the study",
            "LTCA rotation",
        ),
    ]
    return {m.name: m for m in out}


FE_METRICS: dict[str, Metric] = _fe_metrics()
"""Headline numbers of an FE check (``cyclomesh fe``; docs/contact-law.md)."""

STRESS_METRIC = "max_contact_stress_mpa"
"""The metric compared with the allowable contact stress (tolerance studies)."""


def metric_label(name: str) -> str:
    """``long name [unit]`` for axes and tables (no unit for dimensionless metrics)."""
    m = (
        METRICS.get(name)
        or DRIVE_METRICS.get(name)
        or STIFFNESS_METRICS.get(name)
        or FE_METRICS[name]
    )
    return m.long_name if m.unit == "1" else f"{m.long_name} [{m.unit}]"


def summary_metrics(
    transmission_error: NDArray[np.float64],
    gear_ratio: NDArray[np.float64],
    contacts: NDArray[np.integer],
    pin_load: NDArray[np.float64],
    groove_load: NDArray[np.float64],
    contact_stress: NDArray[np.float64],
    groove_stress: NDArray[np.float64],
    overlap: NDArray[np.float64],
    teeth: int,
) -> dict[str, NDArray]:
    """The metrics of :data:`METRICS`, reduced over crank angle (and pin).

    Parameters
    ----------
    transmission_error, gear_ratio, contacts : ndarray, shape (..., angles)
        Loaded TE [arcsec] (Eq. 25), instantaneous gear ratio [-] (Eq. 26), pins in
        contact [-].
    pin_load, groove_load : ndarray, shape (..., angles, n1)
        Fc, Fp [N].
    contact_stress, groove_stress : ndarray, shape (..., angles, n1)
        Maximum Hertzian pressure on tooth and groove [MPa] (Eq. 24).
    overlap : ndarray, shape (..., angles, n1)
        Interference with the unloaded flank [arcsec].
    teeth : int
        Number of disc teeth n2 (the ideal ratio) [-].

    Returns
    -------
    dict of ndarray
        One array per metric, shape ``(...)`` (the leading ring axes).
    """
    both = (-2, -1)
    ratio = np.asarray(gear_ratio)
    te = np.asarray(transmission_error)
    max_overlap = np.max(overlap, axis=both)
    return {
        "te_mean_arcsec": np.mean(te, axis=-1),
        "te_pp_arcsec": np.max(te, axis=-1) - np.min(te, axis=-1),
        "max_pin_load_n": np.max(pin_load, axis=both),
        "max_groove_load_n": np.max(groove_load, axis=both),
        "max_contact_stress_mpa": np.max(contact_stress, axis=both),
        "max_groove_stress_mpa": np.max(groove_stress, axis=both),
        "contacts_min": np.min(contacts, axis=-1),
        "contacts_max": np.max(contacts, axis=-1),
        "gear_ratio_ripple_pct": (np.max(ratio, axis=-1) - np.min(ratio, axis=-1)) / teeth * 100.0,
        "max_overlap_arcsec": max_overlap,
        "overlap": max_overlap > 0,
    }
