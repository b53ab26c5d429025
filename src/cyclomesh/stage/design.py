"""The RV stage around the cycloid-pin mesh: crank holes, crank bearings, springs.

:class:`StageDesign` is what :class:`~cyclomesh.core.case.Model` carries as its ``stage``
(:mod:`cyclomesh.stage.solve` for the model, docs/stage.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.pair import CrankHoles, PairDesign
from cyclomesh.exceptions import DesignError
from cyclomesh.stage.bearing import (
    RollerSet,
    deflection_for_force,
)
from cyclomesh.stage.carrier import Carrier
from cyclomesh.stage.crankshaft import Crankshaft
from cyclomesh.stage.duty import DutyCycle

__all__ = ["StageDesign"]

FloatArray = NDArray[np.float64]


@lru_cache(maxsize=32)
def _rating_deflection(bearing: RollerSet) -> float:
    """The displacement [m] at which one crank bearing carries its dynamic load rating C
    (:meth:`StageDesign.check_fits`' limit): the bearing's alone, so a study's rings,
    each its own hole errors on the same bearing, form it once (the same number)."""
    return float(deflection_for_force(bearing, bearing.rating()))


@dataclass(frozen=True)
class StageDesign:
    """The RV stage around the cycloid-pin mesh, SI units.

    Parameters
    ----------
    holes : CrankHoles
        Crank holes = crankshafts: count N (2 or 3 in RV reducers), crank circle radius
        r_c and hole radius (the outer raceway of the crank bearing).
    bearing : RollerSet or None
        The crank bearing of every hole; None: rigid bearings without clearance.
    crankshaft_stiffness : float, optional
        Radial stiffness of a crank pin against the carrier [N/m], in series with its
        bearing (bending of the crankshaft, its support bearings).
    carrier_stiffness : float, optional
        Torsional stiffness of the carrier (output) [N·m/rad], in series with the stage.
    hole_error_radial, hole_error_tangential : array_like
        Position errors of the crank holes in the disc frame [m], broadcastable to (D, N):
        radial (outwards) and tangential (counter-clockwise). Need a bearing.
    output_speed : float
        Output speed [rev/min] for the life in hours.
    crankshaft : Crankshaft, optional
        The crankshafts from their geometry (:mod:`cyclomesh.stage.crankshaft`): a beam on
        two support bearings coupling the discs of the stack; excludes
        ``crankshaft_stiffness``.
    carrier : Carrier, optional
        The carrier's pillars (:mod:`cyclomesh.stage.carrier`): the end plate turns against
        the output flange; needs ``crankshaft`` (the axial places); excludes
        ``carrier_stiffness``.
    duty_cycle : DutyCycle, optional
        A load spectrum for the life over a cycle (:mod:`cyclomesh.stage.duty`).
    """

    holes: CrankHoles
    bearing: RollerSet | None = None
    crankshaft_stiffness: float | None = None
    carrier_stiffness: float | None = None
    hole_error_radial: ArrayLike = 0.0
    hole_error_tangential: ArrayLike = 0.0
    output_speed: float = 15.0
    crankshaft: Crankshaft | None = None
    carrier: Carrier | None = None
    duty_cycle: DutyCycle | None = None

    def __post_init__(self) -> None:
        if self.duty_cycle is not None and self.bearing is None:
            raise DesignError(
                "stage.duty_cycle: the life needs a crank bearing ([stage.crank_bearing])"
            )
        if self.crankshaft is not None and self.crankshaft_stiffness is not None:
            raise DesignError(
                "stage: give the crankshaft either by its geometry ([stage.crankshaft]) or by "
                "crankshaft_stiffness_n_per_um, not both"
            )
        if self.carrier is not None and self.carrier_stiffness is not None:
            raise DesignError(
                "stage: give the carrier either by its geometry ([stage.carrier]) or by "
                "carrier_stiffness_nm_per_arcmin, not both"
            )
        if self.carrier is not None and self.crankshaft is None:
            raise DesignError(
                "stage.carrier: needs [stage.crankshaft] support_span_mm and disc_pitch_mm "
                "(where the discs load the crankshafts between the flanges)"
            )
        for name in ("crankshaft_stiffness", "carrier_stiffness"):
            value = getattr(self, name)
            if value is not None and not (
                isinstance(value, int | float) and math.isfinite(value) and value > 0
            ):
                raise DesignError(f"stage.{name} must be a positive number, got {value!r}")
        if not (
            isinstance(self.output_speed, int | float)
            and math.isfinite(self.output_speed)
            and self.output_speed > 0
        ):
            raise DesignError(f"stage.output_speed_rpm must be positive, got {self.output_speed!r}")
        errs = [np.asarray(v, float) for v in (self.hole_error_radial, self.hole_error_tangential)]
        if not all(np.all(np.isfinite(v)) for v in errs):
            raise DesignError("stage: crank hole errors must be finite numbers")
        if self.bearing is None and (
            any(np.any(v != 0) for v in errs)
            or self.crankshaft_stiffness is not None
            or self.crankshaft is not None
        ):
            raise DesignError(
                "stage: crank hole errors and compliant crankshafts need a compliant crank "
                "bearing ([stage.crank_bearing]); rigid bearings cannot take them"
            )
        if self.bearing is not None:
            diameter = 2.0 * self.holes.radius
            if abs(self.bearing.pitch_diameter - (diameter - self.bearing.diameter)) > 1e-12:
                raise DesignError(
                    "stage.crank_bearing: pitch diameter must be the hole diameter minus the "
                    "roller diameter"
                )

    def check_fits(self, design: PairDesign, discs: int) -> None:
        """Refuse a stage that cannot be built or turned.

        * The rollers must fit the disc width (``roller_length`` ≤ B); their pitch circle
          and count around it are checked by :class:`RollerSet`.
        * Crank hole errors beyond what the bearings can take: per disc, the hole errors
          that no rigid motion of the disc (translation u, rotation ω) takes up, rms over
          its N holes, r = min_(u, ω) √(Σ_k |ε_k + u + ω·J·h_k|² / N) (least squares,
          J·h = (−h_y, h_x)), bound the largest bearing displacement from below for
          every position of the disc (max ≥ rms). If r exceeds the displacement at which
          one bearing carries its dynamic load rating C (ISO 281: a life of 10⁶
          revolutions), the hole errors alone overload a bearing at zero torque: the
          holes jam the stage.

        Raises
        ------
        DesignError
            One line naming the key and the limit.
        """
        if self.bearing is None:
            return
        if self.bearing.length > design.width * (1.0 + 1e-12):
            raise DesignError(
                f"stage.crank_bearing.roller_length_mm = {self.bearing.length * 1e3:.6g}: the "
                f"rollers must fit the disc width, design.width_mm = {design.width * 1e3:.6g}"
            )
        residual = self.hole_misfit(discs)
        if residual is None:
            return
        n = self.holes.count
        misfit = np.sqrt(np.sum(residual**2, axis=(-2, -1)) / n)
        # displacement of one bearing at its dynamic load rating
        limit = _rating_deflection(self.bearing)
        if np.max(misfit) > limit:
            d = int(np.argmax(misfit))
            raise DesignError(
                f"stage.hole_error_radial_um / hole_error_tangential_um: the crank hole errors "
                f"of disc {d + 1} leave {np.max(misfit) * 1e6:.4g} µm (rms over its holes) "
                "that no position of the disc takes up, more than a crank bearing's "
                f"displacement at its dynamic load rating ({limit * 1e6:.4g} µm with "
                f"{self.bearing.clearance * 1e6:.4g} µm clearance): the holes jam the stage"
            )

    def hole_misfit(self, discs: int) -> FloatArray | None:
        """The hole errors that no rigid motion of a disc takes up [m], (D, 2, N) (x, y).

        Per disc, the residual ε_k + u + ω·J·h_k of the least-squares pose (u, ω) over its
        N holes (J·h = (−h_y, h_x)); None without hole errors.
        """
        er, et = self.hole_errors(discs)  # (D, N)
        if not (np.any(er) or np.any(et)):
            return None
        a = self.holes.angles
        hx, hy = self.holes.circle_radius * np.cos(a), self.holes.circle_radius * np.sin(a)
        ex = er * np.cos(a) - et * np.sin(a)
        ey = er * np.sin(a) + et * np.cos(a)
        n = a.size
        # columns (ux, uy, ω) of the 2N equations ε + u + ω·J·h = 0
        M = np.zeros((2 * n, 3))
        M[:n, 0], M[n:, 1] = 1.0, 1.0
        M[:n, 2], M[n:, 2] = -hy, hx
        rhs = -np.concatenate([ex, ey], axis=-1)  # (D, 2N)
        pose, *_ = np.linalg.lstsq(M, rhs.T, rcond=None)
        return ((M @ pose).T - rhs).reshape(discs, 2, n)  # (D, x/y, N)

    def preload_warning(self, discs: int) -> str | None:
        """A warning when crank hole errors exceed the bearing clearance (accepted, unlike
        those :meth:`check_fits` refuses), None otherwise.

        A hole whose misfit (:meth:`hole_misfit`, the least-squares position of its disc)
        is larger than the bearing's free radial travel P_d/2 presses its rollers at zero
        torque: the bearing is preloaded, which moves the lost motion and the life.
        """
        if self.bearing is None:
            return None
        residual = self.hole_misfit(discs)
        if residual is None:
            return None
        size = np.hypot(residual[:, 0], residual[:, 1])  # (D, N)
        free = 0.5 * self.bearing.clearance
        if np.max(size) <= free * (1.0 + 1e-9):
            return None
        d, k = np.unravel_index(int(np.argmax(size)), size.shape)
        return (
            f"stage.hole_error_radial_um / hole_error_tangential_um: crank hole {k + 1} of "
            f"disc {d + 1} is {np.max(size) * 1e6:.3g} µm off where no position of the disc "
            f"takes it up, more than the bearing's free radial travel "
            f"({free * 1e6:.3g} µm, half the {self.bearing.clearance * 1e6:.3g} µm clearance): "
            "the crank bearings are preloaded at zero torque (the lost motion and the life "
            "change; accepted below the jam limit of docs/stage.md)"
        )

    def hole_errors(self, discs: int) -> tuple[FloatArray, FloatArray]:
        """Radial and tangential hole errors as (D, N) arrays [m]."""
        shape = (discs, self.holes.count)
        try:
            return tuple(
                np.broadcast_to(np.asarray(v, float), shape).copy()
                for v in (self.hole_error_radial, self.hole_error_tangential)
            )
        except ValueError:
            raise DesignError(
                f"stage: crank hole errors must be one number, or one per crank ({shape[1]}), "
                f"or one per disc and crank {shape}"
            ) from None
