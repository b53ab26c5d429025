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

__all__ = ["Metric", "METRICS", "STRESS_METRIC", "summary_metrics", "metric_label"]


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

STRESS_METRIC = "max_contact_stress_mpa"
"""The metric compared with the allowable contact stress (tolerance studies)."""


def metric_label(name: str) -> str:
    """``long name [unit]`` for axes and tables (no unit for dimensionless metrics)."""
    m = METRICS[name]
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
