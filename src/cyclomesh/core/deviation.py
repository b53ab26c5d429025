"""Tabulated profile deviation of the cycloid disc (measured or designed), SI units.

A :class:`ProfileDeviation` is a normal deviation d(φ1) of the disc profile, material
removed along the outward profile normal (positive = relief), as a function of the
generating angle φ1 of Eq. 1 in [1] within a tooth space (φ1 = 0 the tooth-space bottom,
±π the tips on either side; the flank loaded by cyclomesh's torque convention is
φ1 ∈ [−π, 0], the other one [0, π]). It adds to the modifications Δa, Δρ, δ of
:class:`~cyclomesh.core.pair.Modification`: the disc profile becomes

    X(φ1) = P − (ρ' + d(φ1))·n

with P the pin-centre locus and n its outward normal (see :mod:`cyclomesh.core.profile`).

Tables
------
Each row of ``angle``/``deviation`` is one tooth space, given either

* on φ1 ∈ [−π, 0]: the deviation is the same on both flanks (symmetric about the
  tooth-space bottom), or
* on φ1 ∈ [−π, π]: both flanks, e.g. a measured (CMM) disc with pitch errors.

One row applies to every tooth space; n2 rows give one per tooth space, row j (0-based)
being the tooth space whose bottom lies on the disc-frame ray at angle 2πj/n2
(counter-clockwise), i.e. ``tooth = j + 1`` in a study's CSV file.

Each row is interpolated by a C² cubic spline (:class:`scipy.interpolate.CubicSpline`)
clamped to zero slope at the tips (and, for a symmetric row, mirrored about the bottom,
so its slope is zero there too): d, d' and d'' are continuous, as the curvature radius
that enters Eq. 20 of [1] needs. A table is refused if an angle step exceeds
:data:`MAX_ANGLE_STEP` (too coarse to resolve the contact path: fewer than 18 points a
flank), if the angles do not increase, or if it does not span the flank(s).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import DesignError

if TYPE_CHECKING:  # scipy.interpolate is imported when a table is read (0.3 s)
    from scipy.interpolate import CubicSpline, PPoly

__all__ = ["ProfileDeviation", "MAX_ANGLE_STEP"]

FloatArray = NDArray[np.float64]

MAX_ANGLE_STEP = math.radians(10.0)
"""Largest step between consecutive angles of a deviation table [rad] (10° of φ1)."""

_SPAN_TOLERANCE = 1e-9  # [rad], how close the first/last angle must be to −π, 0 or π


@dataclass(frozen=True, eq=False)
class ProfileDeviation:
    """Normal deviation of the disc profile by tooth space, tabulated (see module doc).

    Parameters
    ----------
    angle : array_like
        Generating angle φ1 within the tooth space [rad], shape ``(m,)`` or
        ``(rows, m)``; strictly increasing from −π to 0 (symmetric) or to π (both flanks).
    deviation : array_like
        Material removed along the profile normal [m] (positive = relief), same shape.
    rows : array_like of int, optional
        Line numbers of the table's points in their source file, same shape; only used
        to name the offending line in error messages.

    Raises
    ------
    DesignError
        Non-finite values, shapes that disagree, angles that do not increase, do not
        span the flank(s), or step by more than :data:`MAX_ANGLE_STEP`.
    """

    angle: FloatArray
    deviation: FloatArray
    rows: NDArray[np.int64] | None = None
    _spline: PPoly = field(init=False, repr=False)
    _symmetric: bool = field(init=False, repr=False)

    def __post_init__(self) -> None:
        angle = np.atleast_2d(np.asarray(self.angle, dtype=float))
        dev = np.atleast_2d(np.asarray(self.deviation, dtype=float))
        if angle.shape != dev.shape or angle.ndim != 2:
            raise DesignError(
                f"profile deviation: angle {np.shape(self.angle)} and deviation "
                f"{np.shape(self.deviation)} must have the same shape, (m,) or (rows, m)"
            )
        rows = None if self.rows is None else np.atleast_2d(np.asarray(self.rows, dtype=int))
        if rows is not None and rows.shape != angle.shape:
            raise DesignError("profile deviation: rows must have the shape of angle")
        object.__setattr__(self, "angle", angle)
        object.__setattr__(self, "deviation", dev)
        object.__setattr__(self, "rows", rows)
        if angle.shape[1] < 2:
            raise DesignError("profile deviation: a table needs at least two angles per tooth")
        spans = set()
        for j in range(angle.shape[0]):
            spans.add(self._check_row(j))
        if len(spans) > 1:
            raise DesignError(
                "profile deviation: every tooth must span the same flanks "
                "(all -180..0 deg or all -180..180 deg)"
            )
        symmetric = spans.pop() == 0.0
        object.__setattr__(self, "_symmetric", symmetric)
        object.__setattr__(self, "_spline", self._build_spline())

    def _where(self, j: int, k: int) -> str:
        if self.rows is not None:
            return f"line {int(self.rows[j, k])}"
        tooth = f" of tooth {j + 1}" if self.angle.shape[0] > 1 else ""
        return f"point {k + 1}{tooth}"

    def _check_row(self, j: int) -> float:
        phi, dev = self.angle[j], self.deviation[j]
        for values, name in ((phi, "profile angle"), (dev, "normal deviation")):
            bad = ~np.isfinite(values)
            if np.any(bad):
                raise DesignError(
                    f"profile deviation: {self._where(j, int(np.argmax(bad)))}: "
                    f"{name} must be a finite number"
                )
        step = np.diff(phi)
        if np.any(step <= 0):
            k = int(np.argmax(step <= 0)) + 1
            raise DesignError(
                f"profile deviation: {self._where(j, k)}: profile_angle_deg "
                f"{math.degrees(phi[k]):.6g} does not increase (angles must be monotone)"
            )
        if abs(phi[0] + math.pi) > _SPAN_TOLERANCE:
            raise DesignError(
                f"profile deviation: {self._where(j, 0)}: the table must start at "
                f"profile_angle_deg = -180 (the tip), not {math.degrees(phi[0]):.6g}"
            )
        end = min((0.0, math.pi), key=lambda x: abs(phi[-1] - x))
        if abs(phi[-1] - end) > _SPAN_TOLERANCE:
            raise DesignError(
                f"profile deviation: {self._where(j, len(phi) - 1)}: the table must end at "
                f"profile_angle_deg = 0 (one flank, symmetric) or 180 (both flanks), not "
                f"{math.degrees(phi[-1]):.6g}"
            )
        if np.any(step > MAX_ANGLE_STEP * (1 + 1e-12)):
            k = int(np.argmax(step > MAX_ANGLE_STEP * (1 + 1e-12))) + 1
            raise DesignError(
                f"profile deviation: {self._where(j, k)}: step of "
                f"{math.degrees(step[k - 1]):.4g} deg in profile_angle_deg is too coarse "
                f"(at most {math.degrees(MAX_ANGLE_STEP):.4g} deg)"
            )
        return end

    def _row_spline(self, j: int) -> CubicSpline:
        from scipy.interpolate import CubicSpline

        phi, dev = self.angle[j], self.deviation[j]
        if self._symmetric:  # mirror about the tooth-space bottom φ1 = 0
            phi = np.concatenate([phi, -phi[-2::-1]])
            dev = np.concatenate([dev, dev[-2::-1]])
        phi = phi.copy()
        phi[0], phi[-1] = -math.pi, math.pi  # exact tips
        return CubicSpline(phi, dev, bc_type=((1, 0.0), (1, 0.0)))

    def _build_spline(self) -> PPoly:
        from scipy.interpolate import PPoly

        xs, cs = [], []
        for j in range(self.angle.shape[0]):
            sp = self._row_spline(j)
            xs.append(sp.x[:-1] + 2.0 * math.pi * j)
            cs.append(sp.c)
        x = np.concatenate([*xs, [math.pi + 2.0 * math.pi * (self.angle.shape[0] - 1)]])
        return PPoly(np.concatenate(cs, axis=1), x, extrapolate=True)

    @property
    def teeth(self) -> int:
        """Number of tooth spaces tabulated: 1 (the same on every one) or n2."""
        return int(self.angle.shape[0])

    @property
    def symmetric(self) -> bool:
        """True if every tooth space has the same deviation on both of its flanks."""
        return self._symmetric

    @property
    def per_tooth(self) -> bool:
        """True for one table per tooth space."""
        return self.teeth > 1

    def evaluate(self, phase: ArrayLike, space: ArrayLike = 0, derivative: int = 0) -> FloatArray:
        """Deviation d or its derivative with respect to φ1 [m/rad^k].

        Parameters
        ----------
        phase : array_like
            φ1 within the tooth space, in [−π, π] [rad].
        space : array_like of int
            Tooth-space index 0 … n2 − 1 (ignored for a single table), broadcast with phase.
        derivative : int
            0, 1 or 2.
        """
        phase = np.asarray(phase, dtype=float)
        if self.teeth > 1:
            # φ1 = π is the last point of its own tooth space, not the next one's first
            phase = np.minimum(phase, math.pi - 1e-12)
            phase = phase + 2.0 * math.pi * (np.asarray(space) % self.teeth)
        return self._spline(phase, derivative)

    def mirrored(self) -> ProfileDeviation:
        """This deviation seen in the disc mirrored about its x-axis [m].

        Mirroring maps φ1 → −φ1 (the two flanks swap) and tooth space j → −j mod n2.
        Used to solve the reverse flank as the forward flank of the mirrored system.
        """
        if self.symmetric and self.teeth == 1:
            return self
        order = (-np.arange(self.teeth)) % self.teeth
        if self.symmetric:
            angle, dev = self.angle[order], self.deviation[order]
            rows = None if self.rows is None else self.rows[order]
        else:
            angle = -self.angle[order, ::-1]
            dev = self.deviation[order, ::-1]
            rows = None if self.rows is None else self.rows[order, ::-1]
        squeeze = self.teeth == 1
        return ProfileDeviation(
            angle[0] if squeeze else angle,
            dev[0] if squeeze else dev,
            None if rows is None else (rows[0] if squeeze else rows),
        )

    def row_near(self, space: int, phase: float) -> str:
        """How messages name the table point nearest to φ1 = ``phase`` of a tooth space."""
        j = space % self.teeth
        phi = self.angle[j]
        k = int(np.argmin(np.abs(phi - (-abs(phase) if self.symmetric else phase))))
        return self._where(j, k)
