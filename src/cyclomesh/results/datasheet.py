"""The RV reducer's data sheet by the catalogue's definitions, its compliance budget, and
measured hysteresis loops read back by the same definitions.

Catalogue definitions
---------------------
A torsional-rigidity test of an RV reducer locks the input (and the case), loads the
output flange from 0 to +T_r, back through 0 to −T_r and back to 0, and records the
twist of the output against the torque: the hysteresis loop. The RV catalogue (Nabtesco
RV-E/RV-N series, "torsional rigidity, lost motion, backlash", with its hysteresis-curve
figure; GB/T 37718-2019 for robot RV reducers uses the same quantities) defines, as we
read them (treat the reading as approximate; the catalogue sheet itself was not at hand):

* **torsional rigidity** b/a: the torque step b from 50 % to 100 % of the rated torque
  over the twist a between those two points of the loop, averaged over the positive and
  negative halves (the mid-curve of the loop where it has a width);
* **lost motion**: the twist between the mid-points of the loop's width at +3 % and at
  −3 % of the rated torque;
* **backlash**: the width of the loop at zero torque (the twist between the descending
  branch from +T_r and the ascending branch from −T_r where they cross T = 0).

Without friction the model's loop is one curve: its lost motion is TE(−3 %) − TE(+3 %)
and its backlash the play, the width of its curve as the torque goes to zero, evaluated
at ±:data:`BACKLASH_FRACTION` of T_r (the contact laws are not inverted reliably at
smaller loads; the width there still holds the elastic deflection at 0.1 % of T_r: in
the RV-40E example it falls by 6 % from ±1 % to ±0.1 %, so the extrapolated play is lower
by well under 1 %).

Compliance budget
-----------------
At the rated torque the output twist from the unloaded rest splits exactly into the work
of every part on its own deformation (virtual work, :func:`cyclomesh.stage.solve` —
``Stage.work``): :func:`compliance_share` gives each part's share of T·twist over the
crank angles; the shares add up to 1 to the equilibrium's round-off. The first (spur)
stage is not in the model; docs/stage.md estimates its share from ISO 6336-1.

SI units inside; the functions taking a loop use N·m and rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import DesignError

__all__ = [
    "BACKLASH_FRACTION",
    "LOST_MOTION_FRACTION",
    "RIGIDITY_FRACTIONS",
    "SHARE_PARTS",
    "compliance_share",
    "LoopMetrics",
    "branch_twist",
    "loop_metrics",
    "reconcile",
]

FloatArray = NDArray[np.float64]

BACKLASH_FRACTION = 1e-3
"""The model's backlash: width of its torsion curve at ±0.1 % of the rated torque."""
LOST_MOTION_FRACTION = 0.03
RIGIDITY_FRACTIONS = (0.5, 1.0)

SHARE_PARTS = ("mesh", "disc_body", "crank_bearings", "crankshafts", "carrier", "hole_errors")
"""Parts of the compliance budget (``compliance_share`` of ``summary.json``)."""


def compliance_share(work: dict[str, FloatArray], torque: float, twist: FloatArray) -> dict:
    """Share of every part in the output twist at one torque, over the crank angles.

    Parameters
    ----------
    work : dict of ndarray
        ``Stage.work`` at that torque: the work of each part on its deformation [J], (A,).
    torque : float
        T [N·m].
    twist : ndarray
        ``Stage.twist`` at that torque [rad], (A,).

    Returns
    -------
    dict
        Part → Σ_A work / Σ_A T·twist, keys :data:`SHARE_PARTS` (``disc_body`` 0 with the
        rigid disc). Their sum is 1 to the equilibrium's round-off.
    """
    total = float(np.sum(torque * np.asarray(twist)))
    if not total > 0:
        raise DesignError("compliance budget: the output did not turn under the torque")
    out = {part: 0.0 for part in SHARE_PARTS}
    for part, value in work.items():
        out[part] = float(np.sum(value)) / total
    return out


@dataclass(frozen=True)
class LoopMetrics:
    """Catalogue quantities of a hysteresis loop, SI: rigidity [N·m/rad], twists [rad]."""

    torsional_rigidity: float
    lost_motion: float
    backlash: float


def branch_twist(torque: ArrayLike, twist: ArrayLike, level: float, rising: bool) -> float:
    """Twist of the loop's rising (or falling) branches at the torque ``level``.

    Every segment between consecutive samples whose torque rises (falls) and spans
    ``level`` is interpolated linearly; the mean over the segments (one per cycle) is
    returned. NaN if no such segment.
    """
    t = np.asarray(torque, float)
    w = np.asarray(twist, float)
    t0, t1, w0, w1 = t[:-1], t[1:], w[:-1], w[1:]
    going = t1 > t0 if rising else t1 < t0
    lo, hi = np.minimum(t0, t1), np.maximum(t0, t1)
    hit = going & (lo <= level) & (level <= hi)
    if not np.any(hit):
        return float("nan")
    frac = (level - t0[hit]) / (t1[hit] - t0[hit])
    return float(np.mean(w0[hit] + frac * (w1[hit] - w0[hit])))


def loop_metrics(torque: ArrayLike, twist: ArrayLike, rated_torque: float) -> LoopMetrics:
    """Rigidity, lost motion and backlash of a measured loop by the catalogue definitions.

    Parameters
    ----------
    torque : array_like
        Output torque [N·m] in the order measured: one or more cycles through ±T_r.
    twist : array_like
        Output twist [rad], growing with the torque.
    rated_torque : float
        T_r [N·m].

    Raises
    ------
    DesignError
        If a branch does not pass a torque the definitions need (±3 %, ±50 %, ±100 % of
        T_r, 0), naming it.
    """

    def at(fraction: float, rising: bool) -> float:
        value = branch_twist(torque, twist, fraction * rated_torque, rising)
        if not np.isfinite(value):
            raise DesignError(
                f"measured loop: no {'rising' if rising else 'falling'} branch passes "
                f"{fraction * 100:+g} % of the rated torque ({fraction * rated_torque:g} N·m); "
                "the loop must run from -T_r to +T_r and back"
            )
        return value

    def mid(fraction: float) -> float:
        return 0.5 * (at(fraction, True) + at(fraction, False))

    half, full = RIGIDITY_FRACTIONS
    rigidity = 0.0
    for sign in (-1.0, 1.0):
        step = abs(mid(sign * full) - mid(sign * half))  # at ±T_r the branches meet
        if not step > 0:
            raise DesignError("measured loop: no twist between 50 % and 100 % of rated torque")
        rigidity += 0.5 * (full - half) * rated_torque / step
    lost = mid(LOST_MOTION_FRACTION) - mid(-LOST_MOTION_FRACTION)
    backlash = at(0.0, False) - at(0.0, True)
    return LoopMetrics(float(rigidity), float(lost), float(backlash))


def reconcile(measured: LoopMetrics, model_rigidity: float, model_lost_motion: float) -> dict:
    """The series compliance that would take the model's rigidity to the measured one.

    Returns ``{"compliance": 1/K_measured − 1/K_model [rad/(N·m)], "stiffness": its
    inverse [N·m/rad] or None if the model is the softer, "lost_motion": measured −
    model [rad]}``. Reported only: nothing is applied to the model.
    """
    compliance = 1.0 / measured.torsional_rigidity - 1.0 / model_rigidity
    return {
        "compliance": compliance,
        "stiffness": 1.0 / compliance if compliance > 0 else None,
        "lost_motion": measured.lost_motion - model_lost_motion,
    }


def measured_loop_variables(
    torque: ArrayLike,
    twist_arcmin: ArrayLike,
    rated_torque: float,
    model_rigidity_nm_per_arcmin: float,
    model_lost_motion_arcmin: float,
) -> tuple[dict, dict]:
    """Dataset variables and summary keys of a measured loop beside the model.

    Variables ``measured_torque`` [N m] and ``measured_twist`` [arcmin] (dim ``sample``);
    summary ``measured_torsional_rigidity_nm_per_arcmin``, ``measured_lost_motion_arcmin``,
    ``measured_backlash_arcmin`` (:func:`loop_metrics`) and the reconciling series
    compliance ``reconciling_compliance_arcmin_per_knm`` (with its stiffness
    ``reconciling_stiffness_nm_per_arcmin`` when positive) and
    ``lost_motion_difference_arcmin`` (measured − model): reported, never applied.
    """
    arcmin = np.radians(1.0 / 60.0)
    torque = np.asarray(torque, float)
    twist = np.asarray(twist_arcmin, float)
    metrics = loop_metrics(torque, twist * arcmin, rated_torque)
    rec = reconcile(
        metrics, model_rigidity_nm_per_arcmin / arcmin, model_lost_motion_arcmin * arcmin
    )
    data = {
        "measured_torque": (("sample",), torque, {"units": "N m", "long_name": "measured torque"}),
        "measured_twist": (
            ("sample",),
            twist,
            {"units": "arcmin", "long_name": "measured twist of the output"},
        ),
    }
    summary = {
        "measured_torsional_rigidity_nm_per_arcmin": metrics.torsional_rigidity * arcmin,
        "measured_lost_motion_arcmin": metrics.lost_motion / arcmin,
        "measured_backlash_arcmin": metrics.backlash / arcmin,
        "reconciling_compliance_arcmin_per_knm": rec["compliance"] / arcmin * 1e3,
        "reconciling_stiffness_nm_per_arcmin": (
            None if rec["stiffness"] is None else rec["stiffness"] * arcmin
        ),
        "lost_motion_difference_arcmin": rec["lost_motion"] / arcmin,
    }
    return data, summary


def order_spectrum(values: ArrayLike, axis: int = 0, orders: int | None = None) -> FloatArray:
    """Amplitude of each order of a signal sampled evenly over one revolution.

    Order k: k periods per revolution; amplitude 2·|X_k|/A (the mean at k = 0), X the
    discrete Fourier transform over the A samples on ``axis``, which moves to the front.
    ``orders``: keep orders 0 … orders (default A//2).
    """
    x = np.moveaxis(np.asarray(values, float), axis, 0)
    count = x.shape[0]
    spectrum = np.abs(np.fft.rfft(x, axis=0)) / count
    spectrum[1:] *= 2.0
    if count % 2 == 0:
        spectrum[-1] /= 2.0  # the Nyquist order is not doubled
    return spectrum[: (orders + 1) if orders is not None else None]


def top_orders(amplitude: FloatArray, count: int, scale: int) -> list[list[float]]:
    """The ``count`` largest orders ≥ 1 as [crank order, output order, amplitude]."""
    order = np.argsort(amplitude[1:])[::-1][:count] + 1
    return [[int(k), int(k * scale), float(amplitude[k])] for k in order]
