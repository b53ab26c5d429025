"""The metric tables: the headline numbers of a loaded tooth contact analysis.

Every metric is a row of :data:`cyclomesh.quantities.QUANTITIES` (name, unit, long name,
label, and how it reduces a run's variable); the tables here are the selections each
kind of study reports. :data:`METRICS` lists the metrics of a run; summaries
(:func:`cyclomesh.summarize`), ``summary.json``, the tolerance study's per-ring
outputs and statistics, CSV and Parquet headers and the CLI tables all read it. A
kind of study that adds a metric adds it here.

:func:`summary_metrics` reduces per-angle and per-pin arrays (engineering units, as in
the Dataset of :func:`cyclomesh.analyse`) over the crank angle and the pins, leaving
any leading ring axes. It is plain NumPy, so the tolerance study's workers reduce
thousands of rings without building Datasets.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from cyclomesh.quantities import PIN, QUANTITIES, Quantity, label, select

__all__ = [
    "Metric",
    "METRICS",
    "DRIVE_METRICS",
    "STAGE_RING_METRICS",
    "STAGE_METRICS",
    "STIFFNESS_METRICS",
    "FE_METRICS",
    "STRESS_METRIC",
    "summary_metrics",
    "metric_label",
]


Metric = Quantity
"""A result metric: a row of :data:`cyclomesh.quantities.QUANTITIES` (name with its unit
suffix, unit, long name, label)."""

METRICS: dict[str, Metric] = select(
    "te_mean_arcsec",
    "te_pp_arcsec",
    "max_pin_load_n",
    "max_groove_load_n",
    "max_contact_stress_mpa",
    "max_groove_stress_mpa",
    "min_contacts",
    "max_contacts",
    "gear_ratio_ripple_pct",
    "max_overlap_arcsec",
    "any_overlap",
)
"""Every headline metric, in the order of tables and files; each reduces a run's variable
(its ``reduce``, :func:`summary_metrics`)."""

DRIVE_METRICS: dict[str, Metric] = select(
    "play_arcsec_mean",
    "play_arcsec_max",
    "max_mesh_force_n",
    "min_torque_share_nm",
    "max_torque_share_nm",
)
"""Drive characteristics of a run (:func:`cyclomesh.analyse`; docs/drive.md). Not in
:data:`METRICS`: the tolerance study's workers reduce core results without them."""

STAGE_RING_METRICS: dict[str, Metric] = select(
    "stage_l10_h_min",
    "stage_lost_motion_arcmin_max",
    "stage_max_crank_bearing_load_n",
    "stage_max_contact_stress_mpa",
)
"""The RV stage's metrics of a ring of a tolerance study with ``[stage]``
(:meth:`cyclomesh.tolerance.tasks.RingModel.stage_metrics`)."""

STAGE_METRICS: dict[str, Metric] = select(
    "stage_rated_torque_nm",
    "stage_output_speed_rpm",
    "stage_l10_h_min",
    "stage_equivalent_load_n_max",
    "stage_dynamic_load_rating_kn",
    "stage_torsional_rigidity_nm_per_arcmin",
    "mesh_torsional_rigidity_nm_per_arcmin",
    "stage_lost_motion_arcmin",
    "mesh_lost_motion_arcmin",
    "stage_backlash_arcmin",
    "mesh_backlash_arcmin",
    "stage_duty_equivalent_torque_nm",
    "stage_duty_equivalent_speed_rpm",
    "stage_duty_l10_h_min",
    "stage_l10_h_at_equivalent_torque",
    "stage_lost_motion_arcmin_max",
    "stage_torsional_rigidity_nm_per_arcmin_min",
    "stage_max_contact_stress_mpa",
    "stage_max_crank_bearing_load_n",
    "stage_max_roller_load_n",
    "stage_max_support_bearing_load_n",
    "stage_support_bearing_stiffness_n_per_um",
    "stage_support_bearing_linear_limit_n",
)
"""The catalogue data sheet of a case with ``[stage]`` (:func:`cyclomesh.results.stage.data_sheet`),
in ``summary.json`` and the report; here, not in :mod:`cyclomesh.results.stage`, so that a
run without a stage does not import the stage's solver."""

STIFFNESS_METRICS: dict[str, Metric] = select(
    "play_arcmin_mean",
    "play_arcmin_max",
    "lost_motion_arcmin_mean",
    "lost_motion_arcmin_max",
    "torsional_rigidity_nm_per_arcmin_mean",
    "torsional_rigidity_nm_per_arcmin_min",
    "drive_lost_motion_arcmin_mean",
    "drive_lost_motion_arcmin_max",
    "drive_torsional_rigidity_nm_per_arcmin_mean",
    "drive_torsional_rigidity_nm_per_arcmin_min",
    "hysteresis_arcmin_mean",
    "hysteresis_arcmin_max",
)
"""Headline numbers of a torsion curve (``cyclomesh stiffness``; docs/drive.md)."""

FE_METRICS: dict[str, Metric] = select(
    "fe_max_pin_load_n",
    "fe_max_contact_stress_mpa",
    "fe_rotation_arcsec_mean",
    *(
        f"ltca_{law}_{what}"
        for law in ("paper", "half_plane")
        for what in ("max_pin_load_n", "pin_load_rms_pct", "rotation_arcsec_mean")
    ),
    "ltca_max_pin_load_n",
    "ltca_pin_load_rms_pct",
    "ltca_rotation_arcsec_mean",
)
"""Headline numbers of an FE check (``cyclomesh fe``; docs/contact-law.md)."""

STRESS_METRIC = "max_contact_stress_mpa"
"""The metric compared with the allowable contact stress (tolerance studies)."""


def metric_label(name: str) -> str:
    """``long name [unit]`` for axes and tables (no unit for dimensionless metrics)."""
    return label(name)


def summary_metrics(
    fields: Mapping[str, NDArray], teeth: int, metrics: Mapping[str, Metric] | None = None
) -> dict[str, NDArray]:
    """The metrics of :data:`METRICS` (or ``metrics``), each reduced from its source as its
    registry row says (``reduce``: :data:`cyclomesh.quantities.REDUCTIONS`).

    Parameters
    ----------
    fields : mapping of str to ndarray
        The sources in engineering units (as in the Dataset of :func:`cyclomesh.analyse`):
        per-angle ones shape (..., angles) (``transmission_error`` [arcsec],
        ``gear_ratio`` [-], ``contacts`` [-]), per-pin ones shape (..., angles, n1)
        (``pin_load``, ``groove_load`` [N], ``contact_stress``, ``groove_stress`` [MPa],
        ``overlap`` [arcsec]).
    teeth : int
        Number of disc teeth n2 (the ideal ratio) [-].

    Returns
    -------
    dict of ndarray
        One array per metric, shape ``(...)`` (the leading ring axes).
    """
    out = {}
    for name, metric in (METRICS if metrics is None else metrics).items():
        source, how = metric.reduce
        value = np.asarray(fields[source])
        axes = (-2, -1) if QUANTITIES[source].dims == PIN else -1
        if how == "max":
            out[name] = np.max(value, axis=axes)
        elif how == "min":
            out[name] = np.min(value, axis=axes)
        elif how == "mean":
            out[name] = np.mean(value, axis=axes)
        elif how == "peak_to_peak":
            out[name] = np.max(value, axis=axes) - np.min(value, axis=axes)
        elif how == "ripple_pct":
            out[name] = (np.max(value, axis=axes) - np.min(value, axis=axes)) / teeth * 100.0
        elif how == "positive":
            out[name] = np.max(value, axis=axes) > 0
        else:  # pragma: no cover - the registry's rows are checked by tests
            raise ValueError(f"{name}: unknown reduction {how!r}")
    return out
