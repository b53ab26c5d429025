"""The whole modified disc profile as a closed curve for manufacturing (pure geometry, SI).

The disc profile of Eqs. 1–3 of [1] (with Δa, Δρ and a tabulated deviation, per tooth
space if given, see :mod:`cyclomesh.core.deviation`) is sampled adaptively so that the
polyline through the samples stays within a stated chord tolerance of the exact curve,
and the outward unit normal is given at every sample.

A rotation modification δ > 0 turns the flanks φ1 < 0 of every tooth space by −δ and
the others by +δ (:func:`cyclomesh.core.profile.modified_profile`): the disc is then the
intersection of the disc turned both ways, r(θ) = min(R(θ + δ), R(θ − δ)); the turned
flanks are cut where they meet near the tips, and the tooth-space bottoms are closed by
the turned copies up to where they cross (a ridge of about (rδ)²/(2|ρc|), 0.01 µm at
100 µrad on the Table 1 pair).

Datum: the disc centre at the origin, the disc frame of Eq. 1 (the frame in which the
profile is written): tooth space 1 (the ``tooth = 1`` row of a per-tooth deviation table)
has its bottom on the +x axis, tooth space k at the polar angle 2π(k − 1)/n2,
counter-clockwise. The pins are drawn where they stand at crank angle 0 in this frame:
the pin-centre circle centred at (−e, 0), pin 1 seated in tooth space 1 at (a − e, 0).

Chord tolerance: every segment of the polyline is chosen so that the sagitta bound of a
curve whose curvature never exceeds κ, s²·κ/8 for an arc of length s, stays below the
tolerance (κ the largest curvature of the exact profile over the segment, Eq. 4 of [1]
or its deviated form); the result is then checked at a dense set of points of the exact
curve and any segment that still exceeds the tolerance is split.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.pair import Modification, PairDesign
from cyclomesh.core.profile import check_profile, curvature_radius, deviated_geometry, locus
from cyclomesh.exceptions import DesignError

__all__ = ["Outline", "PinLayout", "profile_frame", "polar_radius", "disc_outline", "pin_layout"]

FloatArray = NDArray[np.float64]

_FINE_PER_TOOTH = 4096
"""Samples of the exact profile per tooth space from which the vertices are chosen."""
_MAX_SEGMENT = 2e-3
"""Longest segment [m], also where the profile is nearly straight (an inflection point)."""


class Outline(NamedTuple):
    """The closed disc profile: vertices in order (counter-clockwise), not repeated.

    Attributes
    ----------
    x, y : ndarray
        Vertices [m], disc frame (see the module doc for the datum).
    nx, ny : ndarray
        Outward unit normal of the exact profile at each vertex (from the disc to the
        pins) [-].
    phase : ndarray
        Generating angle φ1 of each vertex within its tooth space, in [−π, π] [rad]
        (0 = tooth-space bottom, ±π = tips); with a rotation modification, φ1 of the
        unturned point (the vertex is that point turned by −δ or +δ).
    space : ndarray of int
        Tooth space of each vertex, 1 … n2.
    chord_tolerance : float
        The stated largest distance between the polyline and the exact profile [m].
    """

    x: FloatArray
    y: FloatArray
    nx: FloatArray
    ny: FloatArray
    phase: FloatArray
    space: NDArray[np.int64]
    chord_tolerance: float

    @property
    def radius(self) -> FloatArray:
        """Distance of each vertex from the disc centre [m]."""
        return np.hypot(self.x, self.y)


class PinLayout(NamedTuple):
    """The pin ring at crank angle 0 in the disc frame [m]: centres (n1, 2) and radius."""

    centres: FloatArray
    pin_radius: float
    circle_centre: tuple[float, float]
    circle_radius: float


def _check(design: PairDesign, modification: Modification) -> None:
    if modification.rotation < 0:
        raise DesignError(
            "modification.rotation_urad: a negative rotation modification (closing the "
            "clearance: the turned flanks overlap at the tooth-space bottoms and leave gaps "
            "at the tips) cannot be exported; give it as Δa/Δρ or as a profile_file"
        )
    if modification.rotation * design.teeth >= 0.1 * math.pi:
        raise DesignError(
            "modification.rotation_urad: the rotation modification is too large to export "
            "(it must stay well below a tenth of the tooth pitch)"
        )
    check_profile(design, modification)


def check_exportable(design: PairDesign, modification: Modification) -> None:
    """Raise the :class:`DesignError` :func:`disc_outline` would raise for this pair
    (a negative or too large rotation modification δ, an invalid profile), without
    sampling the outline."""
    _check(design, modification)


def _polar(x: FloatArray, y: FloatArray, centre: float) -> FloatArray:
    """Polar angle of (x, y) relative to the ray at ``centre``, in (−π, π] [rad]."""
    return np.angle((x + 1j * y) * np.exp(-1j * centre))


def _phase_at(
    design: PairDesign, base: Modification, space: ArrayLike, angle: ArrayLike
) -> FloatArray:
    """φ1 of the points of tooth spaces ``space`` (unturned) at polar angles ``angle``
    measured from each space's bottom ray (|angle| ≤ π/n2), by bisection [rad].

    The polar angle of the profile grows with φ1 within a tooth space (the profile is a
    function r(θ) of the polar angle).
    """
    space, angle = np.broadcast_arrays(np.asarray(space), np.asarray(angle, dtype=float))
    centre = 2.0 * np.pi * space / design.teeth
    lo = np.full(angle.shape, -np.pi)
    hi = np.full(angle.shape, np.pi)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        x, y, *_ = profile_frame(design, base, mid, space)
        below = _polar(x, y, centre) < angle
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def polar_radius(design: PairDesign, base: Modification, theta: ArrayLike) -> FloatArray:
    """Radius r(θ) of the profile at polar angles ``theta`` (disc frame) [m], with Δa, Δρ
    and a tabulated deviation of ``base`` but no rotation modification (Eqs. 1–3 of [1]).

    The point of each tooth space at the polar angle is found by bisection on φ1 (the
    polar angle of the profile grows with φ1 within a tooth space)."""
    n2 = design.teeth
    theta = np.asarray(theta, dtype=float)
    space = np.round(theta * n2 / (2.0 * np.pi)).astype(int)
    u = _phase_at(design, base, space % n2, theta - 2.0 * np.pi * space / n2)
    x, y, *_ = profile_frame(design, base, u, space % n2)
    return np.hypot(x, y)


def _crossings(
    design: PairDesign, base: Modification, centres: FloatArray, delta: float, tip: bool
) -> FloatArray:
    """Polar angles where the profile turned by −δ meets the one turned by +δ, near the
    tooth-space bottoms (``tip`` False) or the tips at ``centres`` [rad].

    The disc turned both ways (δ > 0) is the intersection of the two turned discs: its
    radius is min(R(θ + δ), R(θ − δ)), R the unturned profile; the two meet once within
    ±δ of a bottom (where R is least) or a tip (where it is largest).
    """
    lo, hi = centres - abs(delta), centres + abs(delta)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        both = polar_radius(design, base, np.concatenate([mid + delta, mid - delta]))
        lower = both[: len(mid)] < both[len(mid) :]
        # before the crossing the copy turned by −δ is the lower one at a bottom, the
        # higher one at a tip (δ > 0; the other way round for δ < 0)
        before = (lower != tip) == (delta > 0)
        lo, hi = np.where(before, mid, lo), np.where(before, hi, mid)
    return 0.5 * (lo + hi)


def profile_frame(
    design: PairDesign, modification: Modification | None, phase: ArrayLike, space: ArrayLike = 0
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Profile point, outward unit normal and signed curvature radius (Eqs. 1–4 of [1]).

    Parameters
    ----------
    design, modification
        Δa, Δρ and a tabulated deviation enter; the rotation modification δ is not
        applied here (:func:`disc_outline` turns the flanks).
    phase : array_like
        φ1 within the tooth space, in [−π, π] [rad].
    space : array_like of int
        Tooth space index j = 0 … n2 − 1 (tooth space j + 1), broadcast with ``phase``.

    Returns
    -------
    x, y, nx, ny, rho_c : ndarray
        Point [m] and outward unit normal [-] in the disc frame, signed curvature radius
        ρc [m] (convex > 0).
    """
    modification = modification or Modification()
    phase = np.asarray(phase, dtype=float)
    space = np.asarray(space)
    t = (phase + 2.0 * np.pi * space) / design.teeth  # locus parameter θc of Eq. 4
    if modification.profile is None:
        a = design.pin_circle_radius + modification.pin_circle_radius
        rho = design.pin_radius + modification.pin_radius
        px, py, dx, dy, _, _ = locus(t, a, design.eccentricity, design.pins)
        speed = np.hypot(dx, dy)
        nx, ny = dy / speed, -dx / speed
        rho_c = curvature_radius(t, design, modification)
        return px - rho * nx, py - rho * ny, nx, ny, np.broadcast_to(rho_c, px.shape)
    geo = deviated_geometry(phase, design, modification, 0.0, space)
    c, s = np.cos(t), np.sin(t)  # the turned frame of deviated_geometry back to the disc
    return (
        c * geo.x - s * geo.y,
        s * geo.x + c * geo.y,
        c * geo.nx - s * geo.ny,
        s * geo.nx + c * geo.ny,
        geo.curvature_radius,
    )


def _chord_errors(
    x: FloatArray, y: FloatArray, keep: NDArray[np.intp]
) -> tuple[FloatArray, NDArray[np.intp]]:
    """Distance of every fine point from the chord of its segment [m], and the segment."""
    seg = np.searchsorted(keep, np.arange(len(x)), side="right") - 1
    seg = np.minimum(seg, len(keep) - 2)
    i, j = keep[seg], keep[seg + 1]
    cx, cy = x[j] - x[i], y[j] - y[i]
    length = np.hypot(cx, cy)
    dist = np.abs(cx * (y - y[i]) - cy * (x - x[i])) / np.where(length > 0, length, 1.0)
    return dist, seg


def _choose(x: FloatArray, y: FloatArray, rho_c: FloatArray, tolerance: float) -> NDArray[np.intp]:
    """Indices of the fine points kept as vertices of one open polyline (ends kept)."""
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    curvature = 1.0 / np.maximum(np.abs(rho_c), 1e-12)
    # an arc of length s on a curve of curvature ≤ κ leaves its chord by ≤ s²κ/8
    allowed = np.minimum(np.sqrt(8.0 * 0.9 * tolerance / curvature), _MAX_SEGMENT)
    keep = [0]
    i, last = 0, len(x) - 1
    while i < last:
        step = allowed[i]
        while True:
            j = int(np.searchsorted(arc, arc[i] + step, side="right")) - 1
            j = min(max(j, i + 1), last)
            smallest = float(allowed[i : j + 1].min())
            if smallest >= step or j == i + 1:
                break
            step = smallest
        keep.append(j)
        i = j
    keep_arr = np.asarray(keep, dtype=np.intp)
    for _ in range(60):  # the safety net: check every fine point, split offending segments
        dist, seg = _chord_errors(x, y, keep_arr)
        bad = np.unique(seg[dist > tolerance])
        if not len(bad):
            return keep_arr
        mids = (keep_arr[bad] + keep_arr[bad + 1]) // 2
        keep_arr = np.unique(np.concatenate([keep_arr, mids]))
    raise DesignError("profile export: the chord tolerance cannot be met (profile too sharp)")


def disc_outline(
    design: PairDesign,
    modification: Modification | None = None,
    chord_tolerance: float = 1e-7,
    samples_per_tooth: int = _FINE_PER_TOOTH,
) -> Outline:
    """The whole modified disc profile, every tooth space, as one closed polyline.

    Parameters
    ----------
    design : PairDesign
    modification : Modification, optional
        Δa, Δρ (Eq. 3 of [1]) and a tabulated deviation (per tooth space if given).
    chord_tolerance : float
        Largest distance between the polyline and the exact profile [m], default
        0.1 µm; at least 1 nm.
    samples_per_tooth : int
        Samples of the exact profile per tooth space from which vertices are chosen
        (and at which the tolerance is checked).

    Returns
    -------
    Outline
        Counter-clockwise from the tip before tooth space 1 (φ1 = −π of space 1).

    Raises
    ------
    DesignError
        An undercut or otherwise invalid profile (:func:`cyclomesh.core.profile.check_profile`),
        a negative (or huge) rotation modification δ, or a tolerance below 1 nm.
    """
    modification = modification or Modification()
    if not (math.isfinite(chord_tolerance) and chord_tolerance >= 1e-9):
        raise DesignError(
            f"chord tolerance {chord_tolerance!r} m: expected at least 1e-9 m (0.001 µm)"
        )
    _check(design, modification)
    if modification.rotation:
        return _turned_outline(design, modification, chord_tolerance, samples_per_tooth)
    n2 = design.teeth
    u = np.linspace(-np.pi, np.pi, samples_per_tooth + 1)
    parts: list[tuple[FloatArray, ...]] = []
    if samples_per_tooth < 64 or samples_per_tooth % 2:
        raise DesignError("samples_per_tooth: expected an even number of at least 64")
    for j in range(n2):  # each tooth space from tip to tip, both tips kept as vertices
        x, y, nx, ny, rho_c = profile_frame(design, modification, u, j)
        half = samples_per_tooth // 2  # the bottom φ1 = 0 is a vertex too (the datum)
        keep = np.concatenate(
            [
                _choose(x[: half + 1], y[: half + 1], rho_c[: half + 1], chord_tolerance),
                half + _choose(x[half:], y[half:], rho_c[half:], chord_tolerance)[1:],
            ]
        )
        parts.append((x[keep], y[keep], nx[keep], ny[keep], u[keep], np.full(len(keep), j + 1)))
    columns = []
    for k in range(6):
        pieces = []
        for j, part in enumerate(parts):
            nxt = parts[(j + 1) % n2]
            # the tip φ1 = π of space j is the tip φ1 = −π of space j + 1: one vertex,
            # unless a per-tooth table puts the two sides apart (then a step joins them)
            same = math.hypot(part[0][-1] - nxt[0][0], part[1][-1] - nxt[1][0])
            pieces.append(part[k][:-1] if same <= 1e-3 * chord_tolerance else part[k])
        columns.append(np.concatenate(pieces))
    x, y, nx, ny, phase, space = columns
    return Outline(x, y, nx, ny, phase, space.astype(np.int64), float(chord_tolerance))


def _turned_outline(
    design: PairDesign, modification: Modification, tolerance: float, samples: int
) -> Outline:
    """The outline with a rotation modification δ: the intersection of the disc turned by
    −δ and by +δ (the loaded flanks φ1 < 0 turned back by δ, the others forward, as in
    :func:`cyclomesh.core.profile.modified_profile`), closed at the tips where the two
    flanks meet and at the tooth-space bottoms where the turned copies cross."""
    from dataclasses import replace

    base = replace(modification, rotation=0.0)
    delta = modification.rotation
    n2 = design.teeth
    half_pitch = np.pi / n2
    parts: list[tuple[FloatArray, ...]] = []
    centres = 2.0 * np.pi * np.arange(n2) / n2
    bottoms = _crossings(design, base, centres, delta, tip=False) - centres
    tips = _crossings(design, base, centres + half_pitch, delta, tip=True) - centres
    for j in range(n2):
        left, bottom, right = tips[j - 1] - 2.0 * half_pitch, bottoms[j], tips[j]
        # polar angle θ of the turned copy comes from θ ∓ δ of the unturned profile
        for turn, start, stop in ((-delta, left, bottom), (delta, bottom, right)):
            u0, u1 = _phase_at(design, base, j, np.array([start - turn, stop - turn]))
            count = max(int(samples * (u1 - u0) / (2.0 * np.pi)), 16)
            u = np.linspace(u0, u1, count + 1)
            cut = [0, count]
            if u0 < 0.0 < u1:  # the tooth-space bottom φ1 = 0 is a vertex (the root radius)
                k = int(np.argmin(np.abs(u)))
                u[k] = 0.0
                cut = [0, k, count]
            x, y, nx, ny, rho_c = profile_frame(design, base, u, j)
            keep = np.unique(
                np.concatenate(
                    [
                        a + _choose(x[a : b + 1], y[a : b + 1], rho_c[a : b + 1], tolerance)
                        for a, b in zip(cut[:-1], cut[1:], strict=True)
                    ]
                )
            )
            c, s = math.cos(turn), math.sin(turn)
            parts.append(
                (
                    c * x[keep] - s * y[keep],
                    s * x[keep] + c * y[keep],
                    c * nx[keep] - s * ny[keep],
                    s * nx[keep] + c * ny[keep],
                    u[keep],
                    np.full(len(keep), j + 1),
                )
            )
    # consecutive pieces share their end points (the crossings): keep one of each
    columns = [np.concatenate([part[k][:-1] for part in parts]) for k in range(6)]
    x, y, nx, ny, phase, space = columns
    return Outline(x, y, nx, ny, phase, space.astype(np.int64), float(tolerance))


def pin_layout(design: PairDesign) -> PinLayout:
    """The nominal pins at crank angle 0 in the disc frame (module doc) [m].

    At crank angle 0 the disc centre is at (e, 0) in the fixed frame and the disc has
    not turned, so pin k (k = 1 … n1) at a·(cos ψk, sin ψk), ψk = 2π(k − 1)/n1, is at
    a·(cos ψk, sin ψk) − (e, 0) in the disc frame.
    """
    psi = 2.0 * np.pi * np.arange(design.pins) / design.pins
    a, e = design.pin_circle_radius, design.eccentricity
    centres = np.stack([a * np.cos(psi) - e, a * np.sin(psi)], axis=-1)
    return PinLayout(centres, design.pin_radius, (-e, 0.0), a)
