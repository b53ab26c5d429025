"""The carrier of an RV stage: output flange and end plate joined by pillars.

The crankshafts' support bearings sit in the output flange (the output) and in the end
plate; the end plate is held to the output flange only by P pillars (the "shafts" of the
carrier that pass through the discs' pillar holes), of diameter d and free length l on
the radius R. A rotation β of the end plate against the output flange, both flanges taken
rigid and parallel, bends and shears every pillar as a beam clamped at both ends with a
relative end translation R·β (fixed-guided Timoshenko beam, lateral stiffness
k = 1/(l³/(12EI) + l/(κGA)), Timoshenko & Gere, *Mechanics of Materials*; κ of a solid
circle after Cowper 1966) and twists it by β (GJ/l). The torsional stiffness of the
pillars between the flanges is

    K_β = P·(k·R² + G·J/l),    J = πd⁴/32.

In the stage (:mod:`cyclomesh.stage.solve`) β is an unknown of the equilibrium: the end
plate's support of every crankshaft moves by β·ẑ×h_k, and since a crankshaft on two
supports is statically determinate, a disc at the axial place x_d sees its crank pin
moved by (x_d/S)·β·ẑ×h_k; the pillars' energy ½K_β·β² closes the end plate's
equilibrium (its torque is the moment of the support reactions it carries).

SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cyclomesh.exceptions import DesignError
from cyclomesh.stage.crankshaft import shear_coefficient

__all__ = ["Carrier", "pillar_stiffness"]


def pillar_stiffness(
    diameter: float, length: float, youngs_modulus: float = 206e9, poisson_ratio: float = 0.3
) -> float:
    """Lateral stiffness of a solid round pillar clamped at both ends, ends kept parallel
    (fixed-guided Timoshenko beam): k = 1/(l³/(12EI) + l/(κGA)) [N/m]."""
    area = math.pi * diameter**2 / 4.0
    inertia = math.pi * diameter**4 / 64.0
    shear_modulus = youngs_modulus / (2.0 * (1.0 + poisson_ratio))
    bending = length**3 / (12.0 * youngs_modulus * inertia)
    shear = length / (shear_coefficient(poisson_ratio) * shear_modulus * area)
    return 1.0 / (bending + shear)


@dataclass(frozen=True)
class Carrier:
    """Pillars between the output flange and the end plate, SI units.

    Parameters
    ----------
    pillars : int
        Number of pillars P.
    pillar_diameter, pillar_length, pillar_circle_radius : float
        d, free length l between the flanges, and the radius R of their circle [m].
    youngs_modulus, poisson_ratio : float
        Steel by default (206 GPa, 0.3).
    """

    pillars: int
    pillar_diameter: float
    pillar_length: float
    pillar_circle_radius: float
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3

    def __post_init__(self) -> None:
        if isinstance(self.pillars, bool) or not isinstance(self.pillars, int) or self.pillars < 2:
            raise DesignError(f"stage.carrier: pillars must be 2 or more, got {self.pillars!r}")
        for name in ("pillar_diameter", "pillar_length", "pillar_circle_radius"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise DesignError(f"stage.carrier: {name}_mm must be positive, got {value!r}")

    def torsional_stiffness(self) -> float:
        """K_β of the pillars between the flanges [N·m/rad] (module doc)."""
        d, length = self.pillar_diameter, self.pillar_length
        k = pillar_stiffness(d, length, self.youngs_modulus, self.poisson_ratio)
        shear_modulus = self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
        twist = shear_modulus * math.pi * d**4 / 32.0 / length
        return self.pillars * (k * self.pillar_circle_radius**2 + twist)
