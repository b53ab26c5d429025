"""The springs of the RV stage's equilibrium (:mod:`cyclomesh.stage.equilibrium`): the
crank bearing's law with its optional series spring (:class:`BearingLaw`), its stiff
limit (:class:`PowerLaw`), the displacement that carries a load
(:func:`bearing_deflection`), and the crankshafts and carrier from their geometry
(:class:`Supports`, :func:`stage_supports`; docs/stage.md).

References
----------
[1] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from cyclomesh.exceptions import ConvergenceError
from cyclomesh.stage.bearing import (
    LOAD_EXPONENT,
    RollerSet,
    radial_force,
    radial_law,
    radial_stiffness,
)
from cyclomesh.stage.design import StageDesign
from cyclomesh.stage.kernel import compiled, deflection, split

__all__ = [
    "BearingLaw",
    "PowerLaw",
    "bearing_deflection",
    "stiff_limit_split",
    "Supports",
    "stage_supports",
]

FloatArray = NDArray[np.float64]

SPLIT_ITERATIONS = 200
"""Newton steps of :func:`stiff_limit_split` before it gives up (as the stage's own; the
compiled bearing start of :mod:`cyclomesh.stage.kernel` takes it too)."""


# --- the bearing law with its optional series spring ---------------------------------


class BearingLaw:
    """Isotropic force B(s), stiffness B'(s), energy U(s) of a crank bearing (+ spring)."""

    def __init__(self, bearing: RollerSet, spring: float | None):
        self.rs, self.k = bearing, spring

    def _split(self, s: FloatArray) -> FloatArray:
        """Bearing part s_b of the displacement s = s_b + B(s_b)/k (Newton, monotone)."""
        if self.k is None:
            return s
        sb = s.copy()
        for _ in range(100):
            f = radial_force(self.rs, sb)
            resid = sb + f / self.k - s
            if np.all(np.abs(resid) <= 1e-14 * np.maximum(s, 1e-300)):
                return sb
            sb = sb - resid / (1.0 + radial_stiffness(self.rs, sb) / self.k)
        raise ConvergenceError("stage: the crank bearing and crankshaft spring split failed")

    def evaluate(
        self, s: FloatArray, stiffness: bool = True
    ) -> tuple[FloatArray, FloatArray | None, FloatArray, FloatArray]:
        """(B, dB/ds, U, s_b) at the displacements s [m]; dB/ds None if not ``stiffness``."""
        sb = self._split(s)
        force, stiff, energy = radial_law(self.rs, sb, stiffness)
        if self.k is not None:
            if stiffness:
                stiff = stiff / (1.0 + stiff / self.k)
            energy = energy + 0.5 * force * force / self.k
        return force, stiff, energy, sb


class PowerLaw:
    """The stiff limit of a roller set without clearance: B = s^(10/9) (any scale)."""

    def evaluate(
        self, s: FloatArray, stiffness: bool = True
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        p = LOAD_EXPONENT
        return s**p, p * s ** (p - 1.0), s ** (p + 1.0) / (p + 1.0), s


# --- the crankshafts and the carrier from their geometry ----------------------------


@dataclass(frozen=True)
class Supports:
    """Elastic crankshafts and end plate in the equilibrium (extra unknowns after 1 + 3D).

    ``stiffness``: inverse of the crankshaft's flexibility at the discs' planes (D, D) or
    None (rigid crankshaft): unknowns w'_dk (x, y), the beam's own deflection of crank pin k
    at disc d, energy ½·Σ_k w'_kᵀ·K·w'_k per direction. ``fraction``: x_d/S of every disc
    (D,); ``carrier``: K_β [N·m/rad] or None: unknown β, the end plate's rotation against
    the output flange, moving the crank pin at disc d by x_d/S·β·ẑ×h_k, energy ½K_β·β².
    """

    stiffness: FloatArray | None
    fraction: FloatArray
    carrier: float | None

    def extra(self, discs: int, cranks: int) -> int:
        return (2 * discs * cranks if self.stiffness is not None else 0) + (
            1 if self.carrier is not None else 0
        )


def stage_supports(stage: StageDesign, discs: int, order: NDArray[np.int64]) -> Supports | None:
    """The supports of ``stage`` for the discs in ``order`` (the mirror's disc order).

    They depend on the crankshaft and the carrier only, not on the hole errors: a study of
    many rings (each its own hole errors) forms them once (:func:`_supports`, cached; the
    same arithmetic; nothing writes to its arrays)."""
    if stage.crankshaft is None:
        return None
    return _supports(stage.crankshaft, stage.carrier, discs, tuple(int(i) for i in order))


@lru_cache(maxsize=32)
def _supports(shaft, carrier, discs: int, order: tuple[int, ...]) -> Supports:
    idx = np.asarray(order, dtype=np.int64)
    flexibility = shaft.compliance(discs)[np.ix_(idx, idx)]
    fraction = (shaft.positions(discs) / shaft.support_span)[idx]
    return Supports(
        stiffness=np.linalg.inv(flexibility),
        fraction=fraction,
        carrier=None if carrier is None else carrier.torsional_stiffness(),
    )


def bearing_deflection(law: BearingLaw, force: FloatArray) -> FloatArray:
    """Total displacement s at which the bearing (+ spring) carries ``force`` [m]."""
    rs = law.rs
    if compiled():  # CYCLOMESH_KERNEL=numba: the same iteration in one compiled pass
        s = deflection(
            np.cos(rs.angles), 0.5 * rs.clearance, rs.constant, LOAD_EXPONENT, force, 100
        )
        return s + force / law.k if law.k is not None else s
    s = 0.5 * rs.clearance + (np.maximum(force, 0.0) / rs.constant) ** (1.0 / LOAD_EXPONENT)
    for _ in range(100):
        value, k, _ = radial_law(rs, s)
        resid = value - force
        if np.all(np.abs(resid) <= 1e-12 * np.maximum(force, 1e-300)):
            break
        s = np.where(force > 0, s - resid / np.where(k > 0, k, np.inf), 0.5 * rs.clearance)
    if law.k is not None:
        s = s + force / law.k
    return s


def stiff_limit_split(
    hx: FloatArray,
    hy: FloatArray,
    L: float,
    mesh_fx: FloatArray,
    mesh_fy: FloatArray,
    moment: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Stiff-limit split of each disc's load over its bearings (power law, no clearance).

    Finds per disc (u, ω) with Σ_k B(d_k)·d̂_k = (mesh_fx, mesh_fy) (the pins' resultant,
    passed to the crank pins) and Σ_k h_k × B_k = moment, d_k = u + ω·Jh_k, B = s^(10/9),
    by Newton's method on the convex potential. ``hx``, ``hy``: crank-hole centres [m],
    (A, N); ``L``: their length scale [m]; forces [N], moment [N·m]. Returns the forces on
    the crank pins [N], (A, D, N) each (Harris & Kotzalas's roller law, B = s^(10/9)).
    """
    if compiled():  # CYCLOMESH_KERNEL=numba: each (crank angle, disc) in one compiled pass
        out = split(hx, hy, L, mesh_fx, mesh_fy, moment, LOAD_EXPONENT, SPLIT_ITERATIONS)
        if out is None:
            raise ConvergenceError("stage: the stiff-limit bearing load split did not converge")
        return out
    law = PowerLaw()
    A, D = mesh_fx.shape
    N = hx.shape[-1]
    jx = np.broadcast_to(-hy[:, None, :], (A, D, N))
    jy = np.broadcast_to(hx[:, None, :], (A, D, N))
    target = np.stack([moment / L, mesh_fx, mesh_fy], axis=-1)  # (A, D, 3)
    # start: the linear (least-norm) split, its magnitude through the power law
    lin_x = mesh_fx[..., None] / N + moment[..., None] * jx / (N * L * L)
    lin_y = mesh_fy[..., None] / N + moment[..., None] * jy / (N * L * L)
    mag = np.hypot(lin_x, lin_y)
    with np.errstate(divide="ignore", invalid="ignore"):
        s0 = mag ** (1.0 / LOAD_EXPONENT)
        dx0 = np.where(mag > 0, lin_x / mag * s0, 0.0)
        dy0 = np.where(mag > 0, lin_y / mag * s0, 0.0)
    y = np.stack(
        [np.sum(dx0 * jx + dy0 * jy, -1) / (N * L), dx0.mean(-1), dy0.mean(-1)], axis=-1
    )  # (ω·L, ux, uy)
    scale = np.maximum(np.max(np.abs(target), axis=-1, keepdims=True), 1e-300)
    cols = [(jx / L, jy / L), (1.0, 0.0), (0.0, 1.0)]
    fx, fy = np.zeros((A, D, N)), np.zeros((A, D, N))
    # a disc that carries nothing (all its pins out of contact: pin errors, the other disc
    # takes the torque) has the exact split B = 0 (y = 0, where the Hessian of the
    # s^(19/9) potential vanishes, so Newton is not applied to it)
    active = np.argwhere(np.any(target != 0.0, axis=-1))  # (k, 2) of (angle, disc)
    ia, idisc = active[:, 0], active[:, 1]
    for _ in range(SPLIT_ITERATIONS):
        if ia.size == 0:
            return fx, fy
        yk, tk = y[ia, idisc], target[ia, idisc]
        jxk, jyk = jx[ia, idisc], jy[ia, idisc]
        dx = yk[:, 1, None] + yk[:, 0, None] * jxk / L
        dy = yk[:, 2, None] + yk[:, 0, None] * jyk / L
        s = np.hypot(dx, dy)
        B, kb, _U, _ = law.evaluate(s)
        with np.errstate(divide="ignore", invalid="ignore"):
            cx, cy = np.where(s > 0, dx / s, 1.0), np.where(s > 0, dy / s, 0.0)
            sec = np.where(s > 0, B / s, 0.0)
        fx[ia, idisc], fy[ia, idisc] = B * cx, B * cy
        vec = [
            (np.broadcast_to(a, s.shape), np.broadcast_to(b, s.shape))
            for a, b in ((jxk / L, jyk / L), *cols[1:])
        ]
        g = np.stack([np.sum(B * cx * a + B * cy * b, -1) for a, b in vec], -1) - tk
        keep = ~np.all(np.abs(g) <= 1e-13 * scale[ia, idisc], axis=-1)
        kxx, kyy = kb * cx * cx + sec * cy * cy, kb * cy * cy + sec * cx * cx
        kxy = (kb - sec) * cx * cy
        H = np.empty((ia.size, 3, 3))
        for i, (ax, ay) in enumerate(vec):
            for j, (bx, by) in enumerate(vec):
                H[:, i, j] = np.sum((kxx * ax + kxy * ay) * bx + (kxy * ax + kyy * ay) * by, -1)
        ia, idisc, g, H = ia[keep], idisc[keep], g[keep], H[keep]
        y[ia, idisc] = y[ia, idisc] - np.linalg.solve(H, g[..., None])[..., 0]
    raise ConvergenceError("stage: the stiff-limit bearing load split did not converge")
