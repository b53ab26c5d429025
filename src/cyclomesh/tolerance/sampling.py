"""Monte Carlo sampling of pin-ring errors, reproducible ring by ring.

Ring k's errors depend only on (seed, k): each error kind of ring k draws from its own
stream ``numpy.random.Generator(PCG64(SeedSequence([seed, k, kind])))``. The results
are therefore bit-for-bit identical however rings are split into chunks and wherever
the chunks run, and changing the distribution of one kind leaves the draws of the
others unchanged.

Every distribution is a fixed standard draw times a scale (uniform: U(−1, 1) times the
half range; normal: N(0, 1) times sigma; true position: a point of the unit disc
times the zone radius), so scaling all tolerances by a factor scales the same
underlying draws: common random numbers for :mod:`cyclomesh.tolerance.allocation`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray


class Distribution(Protocol):
    """One error distribution of the ``[tolerance]`` section: ``distribution`` is
    ``"uniform"`` (with ``half_range``) or ``"normal"`` (with ``sigma``), in the unit of
    its key (:class:`cyclomesh.studyfile.schema.Uniform`, ``Normal`` are such objects)."""

    distribution: str


class ToleranceSpec(Protocol):
    """What the sampling reads of the ``[tolerance]`` section: ``seed`` and the optional
    distributions ``radial_um``, ``angular_urad``, ``tangential_um``, ``pin_radius_um``,
    ``eccentricity_um`` and ``position`` (a true-position zone with ``zone_diameter_um``).
    :class:`cyclomesh.studyfile.schema.ToleranceSection` is one; the numerics here do
    not depend on the study-file schema."""

    seed: int


__all__ = ["RingErrors", "draw_ring_errors", "unit_disc"]

# stream ids of the error kinds (part of the reproducibility contract: never renumber)
_RADIAL, _ANGULAR, _PIN_RADIUS, _ECCENTRICITY, _POSITION, _TANGENTIAL = 1, 2, 3, 4, 5, 6
_HOLE_RADIAL, _HOLE_TANGENTIAL = 7, 8


@dataclass(frozen=True)
class RingErrors:
    """Errors of a batch of rings in study-file units, leading axis = ring.

    Study-file units (not SI) so that a ring written to a study file as decimal
    numbers reads back bit for bit (see :mod:`cyclomesh.tolerance.worst`).

    Attributes
    ----------
    rings : ndarray, shape (R,)
        Ring indices k.
    radial_um : ndarray, shape (R, n1)
        εa,i, radial pin position error [µm], positive outwards.
    angular_urad : ndarray, shape (R, n1)
        εψ,i, angular pin position error [µrad].
    pin_radius_um : ndarray, shape (R, n1)
        ερ,i, pin radius error [µm].
    eccentricity_um : ndarray, shape (R,)
        εe, eccentricity error [µm].
    hole_radial_um, hole_tangential_um : ndarray, shape (R, D, N), or None
        Crank hole position errors of the RV stage [µm] (disc frame, radial outwards and
        counter-clockwise), drawn per disc and crank; None without a stage.
    """

    rings: NDArray[np.int64]
    radial_um: NDArray[np.float64]
    angular_urad: NDArray[np.float64]
    pin_radius_um: NDArray[np.float64]
    eccentricity_um: NDArray[np.float64]
    hole_radial_um: NDArray[np.float64] | None = None
    hole_tangential_um: NDArray[np.float64] | None = None

    def scaled(self, factor: ArrayLike) -> RingErrors:
        """The same draws times ``factor`` (scalar, or one value per ring) [-]."""
        f = np.asarray(factor, dtype=float)
        fp = f[..., None] if f.ndim else f
        fh = f[..., None, None] if f.ndim else f
        return RingErrors(
            self.rings,
            self.radial_um * fp,
            self.angular_urad * fp,
            self.pin_radius_um * fp,
            self.eccentricity_um * f,
            None if self.hole_radial_um is None else self.hole_radial_um * fh,
            None if self.hole_tangential_um is None else self.hole_tangential_um * fh,
        )

    def take(self, index: ArrayLike) -> RingErrors:
        """The rings at positions ``index`` of this batch."""
        i = np.asarray(index)
        return RingErrors(
            self.rings[i],
            self.radial_um[i],
            self.angular_urad[i],
            self.pin_radius_um[i],
            self.eccentricity_um[i],
            None if self.hole_radial_um is None else self.hole_radial_um[i],
            None if self.hole_tangential_um is None else self.hole_tangential_um[i],
        )


def _stream(seed: int, ring: int, kind: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, ring, kind])))


def unit_disc(rng: np.random.Generator, size: int) -> tuple[NDArray[np.float64], ...]:
    """Points uniform in area over the unit disc: r = sqrt(U1), θ = 2π·U2.

    Returns
    -------
    x, y : ndarray
        Cartesian coordinates [-] (x radial, y tangential for a pin).
    """
    u = rng.random((2, size))
    r = np.sqrt(u[0])
    theta = 2.0 * np.pi * u[1]
    return r * np.cos(theta), r * np.sin(theta)


def _standard(dist: Any, rng: np.random.Generator, size: int) -> NDArray[np.float64]:
    if dist.distribution == "uniform":
        return rng.uniform(-1.0, 1.0, size) * dist.half_range
    if dist.distribution == "normal":
        return rng.standard_normal(size) * dist.sigma
    raise ValueError(f"unknown distribution {dist.distribution!r}")


def draw_ring_errors(
    spec: ToleranceSpec | Any,
    pins: int,
    pin_circle_radius: float,
    rings: Sequence[int] | NDArray[np.integer],
    holes: tuple[int, int] | None = None,
) -> RingErrors:
    """Draw the errors of the given rings at the stated tolerances (scale factor 1).

    Parameters
    ----------
    spec : ToleranceSpec
        Distributions and seed (the ``[tolerance]`` section).
    pins : int
        Number of pins n1 [-].
    pin_circle_radius : float
        Pin-circle radius a [m], to turn a tangential error (``tangential_um`` or the
        true-position zone's) into the angular error εψ,i = tangential / a.
    rings : sequence of int
        Ring indices k ≥ 0.
    holes : (D, N), optional
        Discs and crank holes of an RV stage: the crank hole errors ``hole_radial_um`` and
        ``hole_tangential_um`` of the spec are drawn per disc and crank (streams of their
        own, same distributions as the pin errors); None: no hole errors.

    Returns
    -------
    RingErrors
        In µm and µrad.
    """
    ks = np.asarray(rings, dtype=np.int64).reshape(-1)
    n = ks.size
    radial = np.zeros((n, pins))
    angular = np.zeros((n, pins))
    pin_radius = np.zeros((n, pins))
    eccentricity = np.zeros(n)
    seed = spec.seed
    for j, k in enumerate(ks.tolist()):
        if spec.radial_um is not None:
            radial[j] = _standard(spec.radial_um, _stream(seed, k, _RADIAL), pins)
        if spec.angular_urad is not None:
            angular[j] = _standard(spec.angular_urad, _stream(seed, k, _ANGULAR), pins)
        if spec.tangential_um is not None:  # µm / m = µrad
            tangential = _standard(spec.tangential_um, _stream(seed, k, _TANGENTIAL), pins)
            angular[j] = tangential / pin_circle_radius
        if spec.position is not None:
            x, y = unit_disc(_stream(seed, k, _POSITION), pins)
            radius_um = 0.5 * spec.position.zone_diameter_um
            radial[j] = radius_um * x
            angular[j] = radius_um * y / pin_circle_radius  # µm / m = µrad
        if spec.pin_radius_um is not None:
            pin_radius[j] = _standard(spec.pin_radius_um, _stream(seed, k, _PIN_RADIUS), pins)
        if spec.eccentricity_um is not None:
            eccentricity[j] = _standard(spec.eccentricity_um, _stream(seed, k, _ECCENTRICITY), 1)[0]
    if holes is None:
        return RingErrors(ks, radial, angular, pin_radius, eccentricity)
    hole = {}
    for name, kind in (("hole_radial_um", _HOLE_RADIAL), ("hole_tangential_um", _HOLE_TANGENTIAL)):
        hole[name] = np.zeros((n, *holes))
        dist = getattr(spec, name, None)
        if dist is not None:
            for j, k in enumerate(ks.tolist()):
                size = holes[0] * holes[1]
                hole[name][j] = _standard(dist, _stream(seed, k, kind), size).reshape(holes)
    return RingErrors(ks, radial, angular, pin_radius, eccentricity, **hole)
