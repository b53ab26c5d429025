"""The crankshaft of an RV stage as a Timoshenko beam on two support bearings.

Each crankshaft runs through one crank hole of every disc of the stack and sits in the
carrier on two support bearings (tapered rollers in the output flange and in the end
plate), ``support_span`` apart. The discs' bearing forces act on it at their mid-planes,
``disc_pitch`` apart and centred in the span (disc 0 nearest the output-flange support).
In each transverse direction the crankshaft is a uniform Timoshenko beam (bending and
shear, Timoshenko & Gere, *Mechanics of Materials*; shear coefficient of a solid circle
κ = 6(1 + ν)/(7 + 6ν), Cowper, J. Appl. Mech. 33 (1966) 335), simply supported on two
radial springs (the support bearings, ``support_stiffness`` each, given or the tangent
stiffness of a preloaded tapered roller bearing from its geometry,
:class:`~cyclomesh.stage.bearing.TaperedRollerBearing`; None: rigid). Its
round section makes it isotropic: x and y bend alike and independently.

:func:`beam_compliance` assembles exact two-node Timoshenko elements (nodes at the supports
and at the load points; the element stiffness with Φ = 12EI/(κGAl²) is exact for nodal
loads, Przemieniecki, *Theory of Matrix Structural Analysis*, 1968, §5.6) and returns the
flexibility matrix at the load points, C[d, e] = deflection at disc d per unit force at
disc e [m/N]: the discs of a stack are coupled through their shared crankshaft.

The crank pin's diameter is the crank hole's less two roller diameters (the needles run
on the pin); the model takes the whole span at that diameter (journals and webs of the
real shaft differ: an assumption, stated where it is used).

SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import DesignError

if TYPE_CHECKING:
    from cyclomesh.stage.bearing import TaperedRollerBearing

__all__ = [
    "Crankshaft",
    "shear_coefficient",
    "beam_compliance",
    "disc_positions",
]

FloatArray = NDArray[np.float64]


def shear_coefficient(poisson_ratio: float) -> float:
    """Timoshenko shear coefficient of a solid circular section, κ = 6(1 + ν)/(7 + 6ν)
    (Cowper, J. Appl. Mech. 33 (1966) 335, Table 1)."""
    return 6.0 * (1.0 + poisson_ratio) / (7.0 + 6.0 * poisson_ratio)


def _positive(name: str, value: float | None, optional: bool = False) -> None:
    if value is None and optional:
        return
    if not (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value > 0
    ):
        raise DesignError(f"stage.crankshaft: {name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class Crankshaft:
    """Geometry of every crankshaft of the stage, SI units.

    Parameters
    ----------
    support_span : float
        Distance between the two support bearings (output flange, end plate) [m].
    disc_pitch : float
        Axial distance between neighbouring discs' mid-planes [m].
    pin_diameter : float
        Crank pin diameter [m] (crank hole diameter less two roller diameters).
    support_stiffness : float or None
        Radial stiffness of each support bearing [N/m]; None: rigid supports (or, with
        ``support_bearing``, its tangent stiffness).
    support_bearing : TaperedRollerBearing or None
        The support bearings' geometry and preload; gives ``support_stiffness``
        (:meth:`~cyclomesh.stage.bearing.TaperedRollerBearing.radial_stiffness`), which
        must then be omitted.
    youngs_modulus, poisson_ratio : float
        Steel by default (206 GPa, 0.3).
    """

    support_span: float
    disc_pitch: float
    pin_diameter: float
    support_stiffness: float | None = None
    support_bearing: TaperedRollerBearing | None = None
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3

    def __post_init__(self) -> None:
        if self.support_bearing is not None:
            if self.support_stiffness is not None:
                raise DesignError(
                    "stage.crankshaft: give support_bearing_stiffness_n_per_um or "
                    "[stage.crankshaft.support_bearing], not both"
                )
            object.__setattr__(self, "support_stiffness", self.support_bearing.radial_stiffness())
        _positive("support_span_mm", self.support_span)
        _positive("disc_pitch_mm", self.disc_pitch)
        _positive("crank pin diameter (crank hole less two rollers)", self.pin_diameter)
        _positive("support_bearing_stiffness_n_per_um", self.support_stiffness, optional=True)
        _positive("youngs_modulus", self.youngs_modulus)
        if not (0.0 <= self.poisson_ratio < 0.5):
            raise DesignError("stage.crankshaft: poisson_ratio must lie in [0, 0.5)")

    def positions(self, discs: int) -> FloatArray:
        """Axial places of the discs' mid-planes from the output-flange support [m]."""
        return disc_positions(self.support_span, self.disc_pitch, discs)

    def support_loads(self, force: FloatArray) -> FloatArray:
        """Radial loads of the two support bearings [N], (..., 2): output flange, end plate.

        ``force`` (..., D, 2): the discs' forces on the crank pin [N] (x, y), disc d at
        :meth:`positions`. A beam simply supported on two springs is statically
        determinate: R_0 = |Σ_d F_d·(1 − x_d/L)|, R_1 = |Σ_d F_d·x_d/L|.
        """
        force = np.asarray(force, float)
        x = self.positions(force.shape[-2]) / self.support_span
        far = np.einsum("...dk,d->...k", force, x)
        near = np.sum(force, axis=-2) - far
        return np.stack(
            [np.hypot(near[..., 0], near[..., 1]), np.hypot(far[..., 0], far[..., 1])], -1
        )

    def compliance(self, discs: int) -> FloatArray:
        """Flexibility matrix at the discs' mid-planes [m/N], (D, D)."""
        area = math.pi * self.pin_diameter**2 / 4.0
        inertia = math.pi * self.pin_diameter**4 / 64.0
        shear_modulus = self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
        return beam_compliance(
            self.support_span,
            self.positions(discs),
            self.youngs_modulus * inertia,
            shear_coefficient(self.poisson_ratio) * shear_modulus * area,
            self.support_stiffness,
        )


def disc_positions(span: float, pitch: float, discs: int) -> FloatArray:
    """Mid-planes of ``discs`` discs ``pitch`` apart, centred in ``span`` [m].

    Raises
    ------
    DesignError
        If the stack does not fit strictly between the supports.
    """
    x = 0.5 * span + (np.arange(discs) - 0.5 * (discs - 1)) * pitch
    if discs > 1 and (discs - 1) * pitch >= span:
        raise DesignError(
            f"stage.crankshaft: {discs} discs {pitch * 1e3:g} mm apart do not fit between "
            f"supports {span * 1e3:g} mm apart; make support_span_mm larger than "
            f"{(discs - 1) * pitch * 1e3:g} mm"
        )
    return x


def beam_compliance(
    span: float,
    loads: ArrayLike,
    bending_stiffness: float,
    shear_stiffness: float,
    support_stiffness: float | None = None,
) -> FloatArray:
    """Flexibility of a simply supported Timoshenko beam at its load points [m/N].

    Parameters
    ----------
    span : float
        Distance between the two supports [m] (at x = 0 and x = span).
    loads : array_like
        Load points x strictly between the supports [m], (P,), distinct.
    bending_stiffness : float
        EI [N·m²].
    shear_stiffness : float
        κGA [N].
    support_stiffness : float or None
        Radial spring of each support [N/m]; None: rigid.

    Returns
    -------
    ndarray
        C (P, P): deflection at point i per unit transverse force at point j (symmetric,
        positive definite). Exact for point loads (the element stiffness of the Timoshenko
        beam reproduces its nodal solution, Przemieniecki 1968, §5.6).
    """
    x = np.asarray(loads, float).ravel()
    nodes = np.concatenate([[0.0], x, [span]])
    order = np.argsort(nodes, kind="stable")
    nodes = nodes[order]
    if np.any(np.diff(nodes) <= 0):
        raise DesignError("beam: load points must be distinct and strictly between the supports")
    n = nodes.size
    K = np.zeros((2 * n, 2 * n))
    for i, length in enumerate(np.diff(nodes)):
        phi = 12.0 * bending_stiffness / (shear_stiffness * length**2)
        c = bending_stiffness / ((1.0 + phi) * length**3)
        ke = c * np.array(
            [
                [12.0, 6.0 * length, -12.0, 6.0 * length],
                [6.0 * length, (4.0 + phi) * length**2, -6.0 * length, (2.0 - phi) * length**2],
                [-12.0, -6.0 * length, 12.0, -6.0 * length],
                [6.0 * length, (2.0 - phi) * length**2, -6.0 * length, (4.0 + phi) * length**2],
            ]
        )
        dofs = [2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3]
        K[np.ix_(dofs, dofs)] += ke
    ends = [int(np.flatnonzero(order == 0)[0]), int(np.flatnonzero(order == n - 1)[0])]
    free = np.ones(2 * n, bool)
    for node in ends:
        if support_stiffness is None:
            free[2 * node] = False
        else:
            K[2 * node, 2 * node] += support_stiffness
    # unit loads at the load points (nodes 1 … P in the input order)
    where = np.argsort(order)[1 : x.size + 1]  # node of each load point
    rhs = np.zeros((2 * n, x.size))
    rhs[2 * where, np.arange(x.size)] = 1.0
    u = np.zeros_like(rhs)
    u[free] = np.linalg.solve(K[np.ix_(free, free)], rhs[free])
    C = u[2 * where]
    return 0.5 * (C + C.T)
