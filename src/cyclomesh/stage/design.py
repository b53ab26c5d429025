"""The RV stage around the cycloid-pin mesh: crank holes, crank bearings, springs.

:class:`StageDesign` is what :class:`~cyclomesh.core.case.Model` carries as its ``stage``
(:mod:`cyclomesh.stage.solve` for the model, docs/stage.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.pair import CrankHoles
from cyclomesh.exceptions import DesignError
from cyclomesh.stage.bearing import (
    RollerSet,
)

__all__ = ["StageDesign"]

FloatArray = NDArray[np.float64]


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
    """

    holes: CrankHoles
    bearing: RollerSet | None = None
    crankshaft_stiffness: float | None = None
    carrier_stiffness: float | None = None
    hole_error_radial: ArrayLike = 0.0
    hole_error_tangential: ArrayLike = 0.0
    output_speed: float = 15.0

    def __post_init__(self) -> None:
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
            any(np.any(v != 0) for v in errs) or self.crankshaft_stiffness is not None
        ):
            raise DesignError(
                "stage: crank hole errors and a crankshaft stiffness need a compliant crank "
                "bearing ([stage.crank_bearing]); rigid bearings cannot take them"
            )
        if self.bearing is not None:
            diameter = 2.0 * self.holes.radius
            if abs(self.bearing.pitch_diameter - (diameter - self.bearing.diameter)) > 1e-12:
                raise DesignError(
                    "stage.crank_bearing: pitch diameter must be the hole diameter minus the "
                    "roller diameter"
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
