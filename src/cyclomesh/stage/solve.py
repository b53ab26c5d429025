"""Equilibrium of the RV cycloid stage: discs held by crank bearings, pressed by the pins.

Model
-----
D identical discs (disc d's eccentric at φ + d·2π/D, d = 0 … D − 1) share one pin ring and
N crankshafts. Crankshaft k runs through crank hole k of every disc, centred at
h_k = r_c·(cos(2πk/N + φt), sin(2πk/N + φt)) from the disc centre (φt = −φ/n2, the
disc's theoretical rotation; the holes are :class:`~cyclomesh.core.pair.CrankHoles`). The
crankshafts sit in the carrier (the output), which carries the torque T. The input (and
with it the crank angle φ) is held, as in a torsional-rigidity test of a reducer.

Each disc is a rigid body with a rotation θ_d (from the stack's rest position on the
loaded flanks, counter-clockwise) and an in-plane translation u_d; the carrier turns by c.
Small displacements (µm against mm) are superposed on the nominal position:

* pin i of disc d closes by δ_i = l_i·(θ_d − φbl,i) + n_i·u_d (moment arm l_i, unloaded
  backlash φbl,i, outward flank normal n_i, all from the mesh core,
  :class:`~cyclomesh.drive.solve.StackMesh`) and carries F_i = F(δ_i⁺) (Eqs. 15–23 of [1]);
* the opposite flank of every tooth space is a second contact of its pin, closing by
  −l'_i·(θ_d − φ'bl,i) + n'_i·u_d (geometry and compliance of the loaded flank of the
  mirror problem, φ'bl,i its unloaded contact rotation from the rest): a translation
  may close it;
* hole k of disc d moves against its crank pin by
  d_dk = u_d + (θ_d − c)·ẑ×h_k + ε_dk (ε_dk the position error of the hole), and its
  roller set (:mod:`cyclomesh.stage.bearing`, Harris & Kotzalas [2]) pushes the crank
  pin with B(|d_dk|)·d_dk/|d_dk| and the disc with the opposite force; an optional
  radial spring k_s of the crankshaft acts in series with it;
* the carrier turns by c + T/k_c with an optional torsional spring k_c.

Equilibrium of every disc (two forces, one moment) and of the carrier (Σ moments of the
bearing forces = T) is the stationarity of the convex potential

    Π = Σ_pins ∫F dδ + Σ_bearings ∫B ds − T·c,

solved at every crank angle by Newton's method on the 1 + 3D unknowns with a
backtracking line search on Π, vectorised over the crank angles, to a force residual of
1e-12·T/r_c (round-off). With rigid bearings without clearance (``bearing=None``) the
discs cannot move against the carrier (u_d = 0, θ_d = c): the pins are then the mesh
problem of :func:`~cyclomesh.drive.solve.solve_drive` (reproduced to round-off while the
opposite flanks stay open, which the mesh alone does not model; tested), and
the statically indeterminate bearing loads are those of the stiff limit of identical
roller sets without clearance (their homogeneous law Q ∝ δ^(10/9) fixes the split).

The reverse flanks (negative torque) are solved through the exact mirror of
:mod:`cyclomesh.drive.solve` (crank hole k ↔ (N − k) mod N, the tangential hole error and
y-components negated).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.hertz import force_from_approach
from cyclomesh.core.ltca import (
    check_contact_law,
    check_crank_angles,
    check_pair,
    contact_stresses,
    count_contacts,
)
from cyclomesh.core.pair import CrankHoles, Modification, PairDesign, PinErrors
from cyclomesh.core.transmission import transmission_error
from cyclomesh.drive.solve import (
    StackMesh,
    check_discs,
    check_torques,
    mirror_index,
    stack_meshes,
    torsion_metrics,
    torsion_torques,
    unmirror,
)
from cyclomesh.exceptions import ConvergenceError, DesignError
from cyclomesh.stage.bearing import (
    LOAD_EXPONENT,
    RollerSet,
    deflection_for_force,
    equivalent_load,
    life_hours,
    radial_energy,
    radial_force,
    radial_stiffness,
    rating_life,
    roller_loads,
)
from cyclomesh.stage.carrier import Carrier
from cyclomesh.stage.crankshaft import Crankshaft
from cyclomesh.stage.duty import DutyCycle

__all__ = [
    "StageDesign",
    "Stage",
    "StageTorsion",
    "solve_stage",
    "stage_torsion_curve",
    "bearing_life",
    "FORCE_TOLERANCE",
]

FloatArray = NDArray[np.float64]

FORCE_TOLERANCE = 1e-12
"""Accepted residual of every equilibrium equation, relative to T/r_c (moments /r_c)."""
_MAX_ITERATIONS = 200
_MAX_HALVINGS = 60


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
        er, et = self.hole_errors(discs)  # (D, N)
        if not (np.any(er) or np.any(et)):
            return
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
        residual = ((M @ pose).T - rhs).reshape(discs, 2, n)  # (D, x/y, N)
        misfit = np.sqrt(np.sum(residual**2, axis=(-2, -1)) / n)
        # displacement of one bearing at its dynamic load rating
        limit = float(deflection_for_force(self.bearing, self.bearing.rating()))
        if np.max(misfit) > limit:
            d = int(np.argmax(misfit))
            raise DesignError(
                f"stage.hole_error_radial_um / hole_error_tangential_um: the crank hole errors "
                f"of disc {d + 1} leave {np.max(misfit) * 1e6:.4g} µm (rms over its holes) "
                "that no position of the disc takes up, more than a crank bearing's "
                f"displacement at its dynamic load rating ({limit * 1e6:.4g} µm with "
                f"{self.bearing.clearance * 1e6:.4g} µm clearance): the holes jam the stage"
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


@dataclass(frozen=True)
class Stage:
    """Result of :func:`solve_stage`, SI units; Q torques, A crank angles, D discs, N cranks.

    Attributes
    ----------
    crank_angle : ndarray
        φ [rad], (A,).
    torque : ndarray
        Output torque on the carrier [N·m], (Q,); negative: reverse flanks.
    pin_load, contact_stress : ndarray
        Pin–tooth force on the loaded flank [N] and its Hertzian pressure [Pa],
        (Q, A, D, n1).
    opposite_pin_load : ndarray
        Force of each pin on the opposite flank of its tooth space [N] (0 unless a
        translation of the disc closes it), (Q, A, D, n1).
    contacts : ndarray
        Loaded pins per disc, (Q, A, D).
    torque_share : ndarray
        Σ F·l of the pins of each disc [N·m], (Q, A, D).
    mesh_force, mesh_force_angle : ndarray
        Resultant of the pin forces on each disc [N] and its direction [rad], (Q, A, D).
    bearing_load, bearing_load_angle : ndarray
        Force of each disc on each crank pin through its bearing [N] and its direction
        [rad, counter-clockwise from x, fixed frame], (Q, A, D, N).
    bearing_deflection : ndarray
        |d_dk|, displacement of the hole against its crank pin [m] (clearance included).
    max_roller_load : ndarray
        Load of the most loaded roller [N], (Q, A, D, N).
    disc_translation_x, disc_translation_y : ndarray
        u_d [m], fixed frame, (Q, A, D).
    disc_rotation : ndarray
        TE of each disc against the pins (Eq. 25 sign: negative when it lags) [rad].
    transmission_error : ndarray
        TE of the output (carrier, with its spring) [rad], (Q, A).
    mesh_transmission_error : ndarray
        TE of the mesh alone (rigid bearings) at the same torque [rad], (Q, A).
    residual : ndarray
        Largest equilibrium residual of each solve [N] (moments over r_c), (Q, A).
    groove_load, groove_stress : ndarray
        Groove force Fc·cos β [N] and its Hertzian pressure [Pa] of the loaded-flank pins
        (Eq. 24), (Q, A, D, n1).
    work : dict of ndarray
        Work of every part of the stage on its own deformation [J], (Q, A) each, keys
        :data:`WORK_PARTS`: they add up to T·twist to round-off (virtual work).
    twist : ndarray
        Rotation of the output under T from the rest position (first pin touching, no
        load) [rad], counter-clockwise in the loaded direction's frame: positive with a
        positive torque, (Q, A).
    """

    crank_angle: FloatArray
    torque: FloatArray
    pin_load: FloatArray
    opposite_pin_load: FloatArray
    contact_stress: FloatArray
    contacts: NDArray[np.int64]
    torque_share: FloatArray
    mesh_force: FloatArray
    mesh_force_angle: FloatArray
    bearing_load: FloatArray
    bearing_load_angle: FloatArray
    bearing_deflection: FloatArray
    max_roller_load: FloatArray
    disc_translation_x: FloatArray
    disc_translation_y: FloatArray
    disc_rotation: FloatArray
    transmission_error: FloatArray
    mesh_transmission_error: FloatArray
    residual: FloatArray
    groove_load: FloatArray
    groove_stress: FloatArray
    work: dict[str, FloatArray] | None = None
    twist: FloatArray | None = None


# --- the bearing law with its optional series spring ---------------------------------


class _Law:
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

    def evaluate(self, s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(B, dB/ds, U, s_b) at the displacements s [m]."""
        sb = self._split(s)
        force = radial_force(self.rs, sb)
        stiff = radial_stiffness(self.rs, sb)
        energy = radial_energy(self.rs, sb)
        if self.k is not None:
            stiff = stiff / (1.0 + stiff / self.k)
            energy = energy + 0.5 * force * force / self.k
        return force, stiff, energy, sb


class _Power:
    """The stiff limit of a roller set without clearance: B = s^(10/9) (any scale)."""

    def evaluate(self, s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        p = LOAD_EXPONENT
        return s**p, p * s ** (p - 1.0), s ** (p + 1.0) / (p + 1.0), s


# --- the crankshafts and the carrier from their geometry ----------------------------


@dataclass(frozen=True)
class _Supports:
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


def _supports(stage: StageDesign, discs: int, order: NDArray[np.int64]) -> _Supports | None:
    """The supports of ``stage`` for the discs in ``order`` (the mirror's disc order)."""
    if stage.crankshaft is None:
        return None
    shaft = stage.crankshaft
    flexibility = shaft.compliance(discs)[np.ix_(order, order)]
    fraction = (shaft.positions(discs) / shaft.support_span)[order]
    return _Supports(
        stiffness=np.linalg.inv(flexibility),
        fraction=fraction,
        carrier=None if stage.carrier is None else stage.carrier.torsional_stiffness(),
    )


# --- the per-direction problem -------------------------------------------------------


@dataclass
class _Problem:
    """Arrays of one direction at one torque, leading axis the crank angles (A, ...)."""

    bl: FloatArray  # (A, D, n1)
    arm: FloatArray
    nx: FloatArray
    ny: FloatArray
    alpha: FloatArray
    gamma: FloatArray
    dmax: FloatArray  # largest approach of the contact law, (A, D, n1)
    hx: FloatArray  # (A, N) hole centres from the disc centre, fixed frame
    hy: FloatArray
    ex: FloatArray  # (A, D, N) hole errors, fixed frame
    ey: FloatArray
    torque: float
    scale: float  # r_c
    supports: _Supports | None = None

    def take(self, idx: NDArray[np.int64]) -> _Problem:
        kw = {
            name: (
                getattr(self, name)[idx]
                if isinstance(getattr(self, name), np.ndarray)
                else getattr(self, name)
            )
            for name in self.__dataclass_fields__
        }
        return _Problem(**kw)


def _pins(p: _Problem, theta: FloatArray, ux: FloatArray, uy: FloatArray):
    """Pin approach, force, stiffness, energy; None where an approach leaves the law."""
    usable = np.isfinite(p.bl)
    delta = np.where(
        usable,
        p.arm * (theta[..., None] - np.where(usable, p.bl, 0.0))
        + p.nx * ux[..., None]
        + p.ny * uy[..., None],
        -1.0,
    )
    delta = np.maximum(delta, 0.0)
    bad = np.any(delta >= p.dmax, axis=(-2, -1))
    safe = np.where(delta < p.dmax, delta, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        force = force_from_approach(safe, p.alpha, p.gamma)
        logf = np.log(np.where(force > 0, force, 1.0))
        dd = p.alpha - p.gamma * (1.0 + logf)
        stiff = np.where(force > 0, 1.0 / dd, 0.0)
        energy = np.where(
            force > 0, 0.5 * force * force * (p.alpha - 0.5 * p.gamma - p.gamma * logf), 0.0
        )
    return force, stiff, energy, bad


def _unpack(x: FloatArray, discs: int):
    c = x[:, 0]
    rest = x[:, 1 : 1 + 3 * discs].reshape(-1, discs, 3)
    return c, rest[..., 0], rest[..., 1], rest[..., 2]


def _evaluate(p: _Problem, law, x: FloatArray, discs: int, rigid: bool, hessian: bool = True):
    """Potential, gradient, Hessian (scaled: rotations × r_c) and the parts of the state."""
    c, theta, ux, uy = _unpack(x, discs)
    n, m = x.shape
    F, k, U, bad = _pins(p, theta, ux, uy)
    energy = np.sum(U, axis=(-2, -1)) - p.torque * c
    L = p.scale
    g = np.zeros((n, m))
    H = np.zeros((n, m, m)) if hessian else None
    # pins: a = (θ_d: l/L, ux: nx, uy: ny) in scaled unknowns
    cols = [p.arm / L, p.nx, p.ny]
    for d in range(discs):
        base = 1 + 3 * d
        for a_i, col in enumerate(cols):
            g[:, base + a_i] += np.sum(F[:, d] * col[:, d], axis=-1)
            if hessian:
                for b_i in range(a_i, 3):
                    v = np.sum(k[:, d] * col[:, d] * cols[b_i][:, d], axis=-1)
                    H[:, base + a_i, base + b_i] += v
                    if b_i != a_i:
                        H[:, base + b_i, base + a_i] += v
    g[:, 0] -= p.torque / L
    state = {"pin_force": F, "bad": bad}
    if rigid:
        return energy, g, H, state
    if p.supports is not None:
        return _evaluate_supported(p, law, x, discs, hessian, energy, g, H, state)
    # bearings: d = u + (θ − c)·Jh + ε, Jh = (−hy, hx)
    jx, jy = -p.hy[:, None, :], p.hx[:, None, :]  # (n, 1, N)
    rot = (theta - c[:, None])[..., None]
    dx = ux[..., None] + rot * jx + p.ex
    dy = uy[..., None] + rot * jy + p.ey
    s = np.hypot(dx, dy)
    B, kb, Ub, sb = law.evaluate(s)
    energy = energy + np.sum(Ub, axis=(-2, -1))
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = np.where(s > 0, dx / s, 1.0)
        cy = np.where(s > 0, dy / s, 0.0)
        secant = np.where(s > 0, B / s, kb)
    fx, fy = B * cx, B * cy  # force of the disc on the crank pin
    # columns of ∂d/∂(c, θ_d, ux_d, uy_d), scaled (c, θ by L)
    gc = [(-jx / L, -jy / L), (jx / L, jy / L), (1.0, 0.0), (0.0, 1.0)]
    kxx = kb * cx * cx + secant * cy * cy
    kyy = kb * cy * cy + secant * cx * cx
    kxy = (kb - secant) * cx * cy
    for d in range(discs):
        idx = [0, 1 + 3 * d, 2 + 3 * d, 3 + 3 * d]
        vec = [
            (np.broadcast_to(a, s.shape)[:, d], np.broadcast_to(b, s.shape)[:, d]) for a, b in gc
        ]
        for ia, (ax, ay) in zip(idx, vec, strict=True):
            g[:, ia] += np.sum(fx[:, d] * ax + fy[:, d] * ay, axis=-1)
            if hessian:
                kax = kxx[:, d] * ax + kxy[:, d] * ay
                kay = kxy[:, d] * ax + kyy[:, d] * ay
                for ib, (bx, by) in zip(idx, vec, strict=True):
                    H[:, ia, ib] += np.sum(kax * bx + kay * by, axis=-1)
    state.update(bearing_fx=fx, bearing_fy=fy, deflection=s, bearing_part=sb)
    return energy, g, H, state


def _evaluate_supported(p: _Problem, law, x, discs, hessian, energy, g, H, state):
    """Bearings, crankshafts and end plate of :func:`_evaluate` with :class:`_Supports`.

    d_dk = u_d + (θ_d − c)·Jh_k + ε_dk − w'_dk − (x_d/S)·β·Jh_k (hole against crank pin);
    the gradient and Hessian are assembled from ∂d/∂x (n, D, N, 2, m) in one contraction.
    """
    sup = p.supports
    c, theta, ux, uy = _unpack(x, discs)
    n, m = x.shape
    N = p.hx.shape[-1]
    L = p.scale
    jx, jy = -p.hy[:, None, :], p.hx[:, None, :]  # (n, 1, N)
    base = 1 + 3 * discs
    nw = 2 * discs * N if sup.stiffness is not None else 0
    w = x[:, base : base + nw].reshape(n, discs, N, 2) if nw else np.zeros((n, discs, N, 2))
    beta = x[:, base + nw] if sup.carrier is not None else np.zeros(n)
    a = sup.fraction[None, :, None]  # (1, D, 1)
    rot = (theta - c[:, None])[..., None] - a * beta[:, None, None]
    dx = ux[..., None] + rot * jx + p.ex - w[..., 0]
    dy = uy[..., None] + rot * jy + p.ey - w[..., 1]
    s = np.hypot(dx, dy)
    B, kb, Ub, sb = law.evaluate(s)
    energy = energy + np.sum(Ub, axis=(-2, -1))
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = np.where(s > 0, dx / s, 1.0)
        cy = np.where(s > 0, dy / s, 0.0)
        secant = np.where(s > 0, B / s, kb)
    fx, fy = B * cx, B * cy
    # ∂d/∂x, scaled unknowns (rotations × L)
    G = np.zeros((n, discs, N, 2, m))
    jxb = np.broadcast_to(jx, (n, discs, N)) / L
    jyb = np.broadcast_to(jy, (n, discs, N)) / L
    G[..., 0, 0], G[..., 1, 0] = -jxb, -jyb
    for d in range(discs):
        G[:, d, :, 0, 1 + 3 * d], G[:, d, :, 1, 1 + 3 * d] = jxb[:, d], jyb[:, d]
        G[:, d, :, 0, 2 + 3 * d] = 1.0
        G[:, d, :, 1, 3 + 3 * d] = 1.0
    if nw:
        idx = base + np.arange(nw).reshape(discs, N, 2)
        for d in range(discs):
            for k in range(N):
                G[:, d, k, 0, idx[d, k, 0]] = -1.0
                G[:, d, k, 1, idx[d, k, 1]] = -1.0
    if sup.carrier is not None:
        G[..., 0, base + nw] = -a * jxb
        G[..., 1, base + nw] = -a * jyb
    f = np.stack([fx, fy], axis=-1)
    g = g + np.einsum("ndkc,ndkcm->nm", f, G)
    if nw:
        Kw = np.einsum("de,nekc->ndkc", sup.stiffness, w)
        energy = energy + 0.5 * np.sum(w * Kw, axis=(1, 2, 3))
        g[:, base : base + nw] += Kw.reshape(n, nw)
    if sup.carrier is not None:
        energy = energy + 0.5 * sup.carrier * beta * beta
        g[:, base + nw] += sup.carrier * beta / L
    if hessian:
        kxx = kb * cx * cx + secant * cy * cy
        kyy = kb * cy * cy + secant * cx * cx
        kxy = (kb - secant) * cx * cy
        kmat = np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2)
        H = H + np.einsum("ndkcm,ndkce,ndkep->nmp", G, kmat, G, optimize=True)
        if nw:
            H[:, base : base + nw, base : base + nw] += np.kron(sup.stiffness, np.eye(2 * N))
        if sup.carrier is not None:
            H[:, base + nw, base + nw] += sup.carrier / (L * L)
    state.update(
        bearing_fx=fx,
        bearing_fy=fy,
        deflection=s,
        bearing_part=sb,
        shaft_deflection=w,
        end_plate=beta,
    )
    return energy, g, H, state


def _rotation_index(m: int, discs: int, supports: _Supports | None) -> list[int]:
    """Unknowns that are rotations (scaled by r_c in the Newton step)."""
    idx = [0, *range(1, 1 + 3 * discs, 3)]
    if supports is not None and supports.carrier is not None:
        idx.append(m - 1)
    return idx


def _newton(
    p: _Problem, law, x: FloatArray, discs: int, rigid: bool, phi: FloatArray
) -> FloatArray:
    """Newton's method with a backtracking line search on the potential, per crank angle."""
    tol = FORCE_TOLERANCE * abs(p.torque) / p.scale
    reduce = np.zeros((1 + 3 * discs, 1))
    reduce[[0, *range(1, 1 + 3 * discs, 3)], 0] = 1.0  # rigid: θ_d = c, u = 0
    active = np.arange(x.shape[0])
    for _ in range(_MAX_ITERATIONS):
        sub = p.take(active)
        xa = x[active]
        energy, g, H, _state = _evaluate(sub, law, xa, discs, rigid)
        if rigid:
            g = g @ reduce
            H = np.einsum("im,nij,jk->nmk", reduce, H, reduce)
        # converged: every residual below tol, or at the round-off of the unknowns
        # themselves (stiff bearings: a residual of H·ulp(x) cannot be resolved)
        rot_idx = _rotation_index(xa.shape[1], discs, None if rigid else p.supports)
        xs = np.abs(_scale(xa, 1.0 / p.scale, rot_idx))
        if rigid:
            xs = xs @ reduce
        noise = 16.0 * np.finfo(float).eps * np.einsum("nij,nj->ni", np.abs(H), xs)
        done = np.all(np.abs(g) <= np.maximum(tol, noise), axis=-1)
        keep = ~done
        active = active[keep]
        if active.size == 0:
            return x
        xa, g, H, energy = xa[keep], g[keep], H[keep], energy[keep]
        sub = sub.take(np.flatnonzero(keep))
        diag = np.maximum(np.max(np.abs(np.diagonal(H, axis1=1, axis2=2)), axis=-1), 1e-300)
        eye = np.eye(H.shape[-1])
        step = np.linalg.solve(H + 1e-14 * diag[:, None, None] * eye, -g[..., None])[..., 0]
        slope = np.sum(g * step, axis=-1)
        # not a descent direction (flat directions): steepest descent, scaled
        flip = ~(slope < 0)
        step[flip] = -g[flip] / diag[flip, None]
        slope = np.sum(g * step, axis=-1)
        t = np.ones(xa.shape[0])
        todo = np.arange(xa.shape[0])
        new = xa.copy()
        tiny = -slope <= 1e-13 * np.maximum(np.abs(energy), 1e-300)
        for _h in range(_MAX_HALVINGS):
            full = _expand(step[todo] * t[todo, None], reduce if rigid else None)
            trial = xa[todo] + _scale(full, p.scale, rot_idx)
            e_t, _g, _H, st = _evaluate(sub.take(todo), law, trial, discs, rigid, hessian=False)
            ok = ~st["bad"] & ((e_t <= energy[todo] + 1e-4 * t[todo] * slope[todo]) | tiny[todo])
            new[todo[ok]] = trial[ok]
            todo = todo[~ok]
            if todo.size == 0:
                break
            t[todo] *= 0.5
        else:
            raise ConvergenceError(
                f"stage: no descent at crank angle {np.degrees(phi[active[todo[0]]]):.6g}° "
                f"(line search failed after {_MAX_HALVINGS} halvings)"
            )
        x[active] = new
    raise ConvergenceError(
        f"stage equilibrium did not converge at crank angle {np.degrees(phi[active[0]]):.6g}°: "
        f"residual above {FORCE_TOLERANCE:.0e}·T/r_c after {_MAX_ITERATIONS} Newton steps"
    )


def _expand(step: FloatArray, reduce: FloatArray | None) -> FloatArray:
    return step if reduce is None else step @ reduce.T


def _scale(step: FloatArray, L: float, rot_idx: list[int]) -> FloatArray:
    """Scaled step (rotations × L) → unknowns (rad, m)."""
    out = step.copy()
    out[:, rot_idx] /= L
    return out


def _distribution(p: _Problem, mesh_fx: FloatArray, mesh_fy: FloatArray, moment: FloatArray):
    """Stiff-limit split of each disc's load over its bearings (power law, no clearance).

    Finds per disc (u, ω) with Σ_k B(d_k)·d̂_k = (mesh_fx, mesh_fy) (the pins' resultant,
    passed to the crank pins) and Σ_k h_k × B_k = moment, d_k = u + ω·Jh_k, B = s^(10/9),
    by Newton's method on the convex potential. Returns the forces on the crank pins,
    (A, D, N) each.
    """
    law = _Power()
    A, D = mesh_fx.shape
    N = p.hx.shape[-1]
    L = p.scale
    jx = np.broadcast_to(-p.hy[:, None, :], (A, D, N))
    jy = np.broadcast_to(p.hx[:, None, :], (A, D, N))
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
    for _ in range(_MAX_ITERATIONS):
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


def _mirrored(arr: FloatArray) -> FloatArray:
    """(A, D, n1) of the mirror problem → this problem's frame (angles, discs, pins)."""
    out = np.flip(arr, axis=0)
    out = np.take(out, mirror_index(out.shape[1]), axis=1)
    return out[..., mirror_index(out.shape[-1])]


def _problem(
    mesh: StackMesh,
    other: StackMesh,
    holes: CrankHoles,
    errs: tuple[FloatArray, FloatArray],
    torque: float,
) -> _Problem:
    """The arrays of one direction: pins (A, D, 2·n1), holes (A, N), hole errors (A, D, N).

    Pins 0 … n1 − 1 are the loaded flanks (arm l > 0, backlash φbl from the stack's rest);
    pins n1 … 2n1 − 1 the opposite flanks of the same tooth spaces, which a translation of
    the disc may close: their geometry and compliance are those of the forward flanks of
    the mirror problem ``other`` (pin (n1 − i) mod n1 at −φ, y reflected), their contact
    rotation the unloaded opposite-flank rotation of this mesh, and a counter-clockwise
    rotation opens them (signed arm −l').
    """
    design, geo = mesh.design, mesh.geo
    A, D, n1 = geo.rotation.shape
    phi_t = -mesh.phi / design.teeth
    ang = holes.angles[None, :] + phi_t[:, None]  # (A, N)
    hx, hy = holes.circle_radius * np.cos(ang), holes.circle_radius * np.sin(ang)
    # hole errors (radial, tangential) of the disc frame → fixed frame
    cr, sr = np.cos(ang)[:, None, :], np.sin(ang)[:, None, :]
    ex = errs[0][None] * cr - errs[1][None] * sr
    ey = errs[0][None] * sr + errs[1][None] * cr
    alpha = mesh.alpha.reshape(A, D, n1)
    gamma = mesh.gamma.reshape(A, D, n1)
    # the opposite flanks
    arm_o = _mirrored(other.geo.moment_arm)
    alpha_o = _mirrored(other.alpha.reshape(A, D, n1))
    gamma_o = _mirrored(other.gamma.reshape(A, D, n1))
    with np.errstate(invalid="ignore"):
        bl_o = geo.reverse_rotation - mesh.rest[:, None, None]
    usable_o = (
        np.isfinite(bl_o)
        & np.isfinite(arm_o)
        & (arm_o >= 0)
        & np.isfinite(alpha_o)
        & np.isfinite(gamma_o)
    )
    bl = np.concatenate([mesh.backlash.reshape(A, D, n1), np.where(usable_o, bl_o, np.inf)], -1)
    alpha = np.concatenate([alpha, np.where(usable_o, alpha_o, 1.0)], -1)
    gamma = np.concatenate([gamma, np.where(usable_o, gamma_o, 0.0)], -1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        dmax = np.where(gamma > 0, gamma * np.exp(alpha / gamma - 1.0), np.inf)
    return _Problem(
        bl=bl,
        arm=np.concatenate([geo.moment_arm, -np.where(usable_o, arm_o, 0.0)], -1),
        nx=np.concatenate([mesh.normal_x, np.where(usable_o, _mirrored(other.normal_x), 0)], -1),
        ny=np.concatenate([mesh.normal_y, np.where(usable_o, -_mirrored(other.normal_y), 0)], -1),
        alpha=alpha,
        gamma=gamma,
        dmax=np.where(np.isfinite(dmax), dmax * (1.0 - 1e-9), np.inf),
        hx=hx,
        hy=hy,
        ex=ex,
        ey=ey,
        torque=torque,
        scale=holes.circle_radius,
    )


def _solve_direction(
    mesh: StackMesh,
    other: StackMesh,
    stage: StageDesign,
    errs: tuple[FloatArray, FloatArray],
    torque: float,
    supports: _Supports | None = None,
) -> dict[str, FloatArray]:
    """Stage under a positive torque in the mesh's frame (``other``: the mirror problem)."""
    D, n1 = mesh.geo.rotation.shape[-2:]
    prob = _problem(mesh, other, stage.holes, errs, torque)
    A = prob.bl.shape[0]
    m = 1 + 3 * D
    # rigid stage (θ_d = c, u = 0) from the rotation at which the stiffest pin alone
    # would carry T (an upper bound of the root, as in cyclomesh.loadsharing)
    x = np.zeros((A, m))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ok = np.isfinite(prob.bl) & (prob.arm > 0)
        f1 = np.where(ok, torque / np.where(ok, prob.arm, 1.0), 1.0)
        log1 = np.log(f1)
        # on the stiffening branch of the law only (as cyclomesh.core.loadsharing)
        ok &= (prob.gamma == 0) | (log1 < prob.alpha / prob.gamma - 1.0)
        d1 = f1 * (prob.alpha - prob.gamma * log1)
        single = np.where(ok, prob.bl + d1 / np.where(ok, prob.arm, 1.0), np.inf)
    x[:, 0] = np.min(single.reshape(A, -1), axis=-1)
    if not np.all(np.isfinite(x[:, 0])):
        bad = int(np.argmin(np.isfinite(x[:, 0])))
        raise ConvergenceError(
            f"crank angle {np.degrees(mesh.phi[bad]):.6g}°: no pin can carry the torque "
            "alone within the line-contact law (Eq. 20)"
        )
    x[:, 1::3] = x[:, [0]]
    x = _newton(prob, None, x, D, True, mesh.phi)
    _, _, _, st = _evaluate(prob, None, x, D, True, hessian=False)
    F = st["pin_force"]
    mesh_te = transmission_error(mesh.rest, x[:, 0])
    mfx = -np.sum(F * prob.nx, axis=-1)  # pins on disc
    mfy = -np.sum(F * prob.ny, axis=-1)
    share = np.sum(F * prob.arm, axis=-1)
    # bearings carry the pins' resultant to the crank pins and the moment Σ F·l
    bfx, bfy = _distribution(prob, mfx, mfy, -share)
    if stage.bearing is not None:
        law = _Law(stage.bearing, stage.crankshaft_stiffness)
        B = np.hypot(bfx, bfy)
        s = _deflection(law, B)
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = np.where(B > 0, bfx / B * s, 0.0) - prob.ex
            dy = np.where(B > 0, bfy / B * s, 0.0) - prob.ey
        N = stage.holes.count
        L = prob.scale
        jx, jy = -prob.hy[:, None, :], prob.hx[:, None, :]
        omega = np.sum(dx * jx + dy * jy, -1) / (N * L * L)  # (A, D)
        ux, uy = dx.mean(-1), dy.mean(-1)
        # turn each disc so that its pins keep (in the least-squares sense, weighted by
        # their stiffness) the approach of the rigid solution despite the translation
        _, k_pin, _, _ = _pins(prob, x[:, 1::3], np.zeros_like(ux), np.zeros_like(uy))
        shift = prob.nx * ux[..., None] + prob.ny * uy[..., None]
        weight = np.sum(k_pin * prob.arm * prob.arm, -1)
        turn = -np.sum(k_pin * prob.arm * shift, -1) / np.where(weight > 0, weight, np.inf)
        theta = x[:, 1::3] + turn
        x[:, 0] = np.mean(theta - omega, -1)
        x[:, 1::3] = x[:, [0]] + omega
        x[:, 2::3] = ux
        x[:, 3::3] = uy
        if supports is not None:
            prob = dataclasses.replace(prob, supports=supports)
            x = np.concatenate([x, np.zeros((A, supports.extra(D, N)))], axis=-1)
        x = _newton(prob, law, x, D, False, mesh.phi)
        energy, g, _, st = _evaluate(prob, law, x, D, False, hessian=False)
        F = st["pin_force"]
        bfx, bfy = st["bearing_fx"], st["bearing_fy"]
        deflection = st["deflection"]
        sb = st["bearing_part"]
        residual = np.max(np.abs(g), axis=-1)
        work = _work(prob, stage, x, D, st)
    else:
        deflection = np.zeros_like(bfx)
        sb = deflection
        work = _work(prob, stage, x, D, {"pin_force": F})
        residual = np.max(
            np.abs(_evaluate(prob, None, x, D, True, hessian=False)[1] @ _reducer(D)), -1
        )
    c, theta, ux, uy = _unpack(x, D)
    groove, stress, groove_stress = contact_stresses(mesh.geo, mesh.design, F[..., :n1])
    mfx = -np.sum(F * prob.nx, axis=-1)
    mfy = -np.sum(F * prob.ny, axis=-1)
    rollers = (
        np.max(roller_loads(stage.bearing, sb), axis=-1)
        if stage.bearing is not None
        else np.full(deflection.shape, np.nan)
    )
    return {
        "pin_load": F[..., :n1],
        "opposite_pin_load": F[..., n1:],
        "contact_stress": stress,
        "groove_load": groove,
        "groove_stress": groove_stress,
        "contacts": count_contacts(F[..., :n1], axes=2),  # per disc, against the stack
        "torque_share": np.sum(F * prob.arm, axis=-1),
        "mesh_fx": mfx,
        "mesh_fy": mfy,
        "bearing_fx": bfx,
        "bearing_fy": bfy,
        "bearing_deflection": deflection,
        "max_roller_load": rollers,
        "disc_translation_x": ux,
        "disc_translation_y": uy,
        "disc_te": transmission_error(mesh.rest[:, None], theta),
        "carrier_te": transmission_error(mesh.rest, c),
        "twist": c,
        "mesh_te": mesh_te,
        "residual": residual,
        **work,
    }


WORK_PARTS = ("mesh", "crank_bearings", "crankshafts", "carrier", "hole_errors")
"""Parts of the output twist (:func:`_work`; the carrier's override spring adds T²/k_c)."""


def _work(p: _Problem, stage: StageDesign, x: FloatArray, discs: int, st: dict):
    """Work of every part on its own deformation at equilibrium [J], (A,) each.

    Virtual work (Clapeyron's identity for an affine compatibility, exact for any
    constitutive law): at the stationary point of Π, x·∇Π = 0, i.e.

        T·c = Σ_pins F·(δ − δ(0)) + Σ_bearings f·(d − ε) + Σ w'ᵀKw' + K_β·β²,

    so the output twist splits into the mesh (pin approaches and the closing of the
    modification gaps), the crank bearings (their clearance included; a series spring
    ``crankshaft_stiffness`` is counted with the crankshafts, B²/k), the crankshafts'
    bending and supports, the carrier's pillars, and the hole errors' share (−Σ f·ε).
    """
    c, theta, ux, uy = _unpack(x, discs)
    F = st["pin_force"]
    usable = np.isfinite(p.bl)
    lin = np.where(
        usable,
        p.arm * (theta[..., None] - np.where(usable, p.bl, 0.0))
        + p.nx * ux[..., None]
        + p.ny * uy[..., None],
        0.0,
    )
    lin0 = np.where(usable, -p.arm * np.where(usable, p.bl, 0.0), 0.0)
    zero = np.zeros_like(c)
    out = {
        "work_mesh": np.sum(F * (lin - lin0), axis=(-2, -1)),
        "work_crank_bearings": zero,
        "work_crankshafts": zero,
        "work_carrier": zero,
        "work_hole_errors": zero,
    }
    if "bearing_fx" not in st:
        return out
    fx, fy = st["bearing_fx"], st["bearing_fy"]
    B = np.hypot(fx, fy)
    fd = B * st["deflection"]  # f·d, d along f
    shafts = np.zeros_like(c)
    if stage.crankshaft_stiffness is not None:
        shafts = np.sum(B * B, axis=(-2, -1)) / stage.crankshaft_stiffness
    if "shaft_deflection" in st:
        w = st["shaft_deflection"]
        shafts = shafts + np.sum(fx * w[..., 0] + fy * w[..., 1], axis=(-2, -1))
        if p.supports.carrier is not None:
            out["work_carrier"] = p.supports.carrier * st["end_plate"] ** 2
    out["work_crankshafts"] = shafts
    out["work_crank_bearings"] = np.sum(fd, axis=(-2, -1)) - np.where(
        stage.crankshaft_stiffness is not None, shafts, 0.0
    )
    out["work_hole_errors"] = -np.sum(fx * p.ex + fy * p.ey, axis=(-2, -1))
    return out


def _ring_mesh(mesh: StackMesh, ring: tuple[int, ...]) -> StackMesh:
    """The unloaded mesh of one ring of a many-ring :class:`StackMesh`."""
    if not ring:
        return mesh
    geo = type(mesh.geo)(
        **{name: getattr(mesh.geo, name)[ring] for name in mesh.geo.__dataclass_fields__}
    )
    fields = {name: getattr(mesh, name) for name in mesh.__dataclass_fields__}
    for name in ("rest", "reverse_rest", "backlash", "alpha", "gamma", "normal_x", "normal_y"):
        fields[name] = fields[name][ring]
    return StackMesh(**{**fields, "geo": geo, "ring_shape": ()})


def _reducer(D: int) -> FloatArray:
    reduce = np.zeros((1 + 3 * D, 1))
    reduce[[0, *range(1, 1 + 3 * D, 3)], 0] = 1.0
    return reduce


def _deflection(law: _Law, force: FloatArray) -> FloatArray:
    """Total displacement s at which the bearing (+ spring) carries ``force`` [m]."""
    rs = law.rs
    s = 0.5 * rs.clearance + (np.maximum(force, 0.0) / rs.constant) ** (1.0 / LOAD_EXPONENT)
    for _ in range(100):
        resid = radial_force(rs, s) - force
        if np.all(np.abs(resid) <= 1e-12 * np.maximum(force, 1e-300)):
            break
        k = radial_stiffness(rs, s)
        s = np.where(force > 0, s - resid / np.where(k > 0, k, np.inf), 0.5 * rs.clearance)
    if law.k is not None:
        s = s + force / law.k
    return s


# fields: (angle axis, disc axis, crank/pin axis) for the mirror
_PER_PIN = {"pin_load", "opposite_pin_load", "contact_stress", "groove_load", "groove_stress"}
_PER_CRANK = {"bearing_fx", "bearing_fy", "bearing_deflection", "max_roller_load"}
_PER_DISC = {
    "contacts",
    "torque_share",
    "mesh_fx",
    "mesh_fy",
    "disc_translation_x",
    "disc_translation_y",
    "disc_te",
}
_ODD = {
    "twist",
    "mesh_fy",
    "bearing_fy",
    "disc_translation_y",
    "disc_te",
    "carrier_te",
    "mesh_te",
    "torque_share",
}


def _reverse(fields: dict[str, FloatArray]) -> dict[str, FloatArray]:
    out = {}
    for name, value in fields.items():
        if name in _PER_PIN:
            arr = unmirror(value, 0, 1, True)
        elif name in _PER_CRANK:
            arr = unmirror(value, 0, 1, False)
            arr = arr[..., mirror_index(arr.shape[-1])]
        elif name in _PER_DISC:
            arr = unmirror(value, 0, 1, False)
        else:
            arr = unmirror(value, 0, None, False)
        out[name] = -arr if name in _ODD else arr
    return out


def solve_stage(
    design: PairDesign,
    stage: StageDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: ArrayLike = 250.0,
    crank_angles: ArrayLike = (0.0,),
    groove_deformation: bool = True,
    discs: int = 1,
    contact_law: str = "half_plane",
) -> Stage:
    """Equilibrium of the RV stage at every crank angle and torque (see the module doc).

    Parameters
    ----------
    design, modification, errors, groove_deformation, discs, contact_law
        As in :func:`~cyclomesh.drive.solve.solve_drive`; errors with ring axes give
        results with the same leading axes (the rings are solved one after the other).
    stage : StageDesign
    torque : float or array_like
        Output torque on the carrier [N·m], not 0; negative loads the reverse flanks.
    crank_angles : array_like
        φ [rad], increasing.

    Returns
    -------
    Stage

    Raises
    ------
    DesignError
        For bad input (as :func:`~cyclomesh.drive.solve.solve_drive`).
    ConvergenceError
        If the equilibrium cannot be solved to round-off; names the crank angle.
    """
    modification = modification or Modification()
    errors = errors or PinErrors()
    torques = check_torques(torque)
    discs = check_discs(discs)
    phi = check_crank_angles(crank_angles)
    check_contact_law(contact_law)
    ring_shape = check_pair(design, modification, errors)
    rad, tan = stage.hole_errors(discs)
    fwd, rev = stack_meshes(
        design,
        modification,
        errors,
        phi,
        discs,
        groove_deformation,
        True,  # both: the opposite flanks of one direction are the mirror's loaded flanks
        True,
        contact_law,
    )
    N = stage.holes.count
    mirror_errs = (
        rad[mirror_index(discs)][:, mirror_index(N)],
        -tan[mirror_index(discs)][:, mirror_index(N)],
    )
    supports = _supports(stage, discs, np.arange(discs))
    mirror_supports = _supports(stage, discs, mirror_index(discs))
    per_ring = []
    for ring in np.ndindex(ring_shape):  # rings one after the other (one ring: ())
        results = []
        f_ring, r_ring = _ring_mesh(fwd, ring), _ring_mesh(rev, ring)
        where = f"ring {np.ravel_multi_index(ring, ring_shape)}, " if ring_shape else ""
        for value in torques:
            try:
                if value > 0:
                    fields = _solve_direction(
                        f_ring, r_ring, stage, (rad, tan), float(value), supports
                    )
                else:
                    fields = _reverse(
                        _solve_direction(
                            r_ring, f_ring, stage, mirror_errs, float(-value), mirror_supports
                        )
                    )
            except ConvergenceError as exc:
                raise ConvergenceError(f"{where}torque {value:g} N·m: {exc}") from None
            results.append(fields)
        per_ring.append({name: np.stack([r[name] for r in results]) for name in results[0]})
    out = {
        name: np.stack([r[name] for r in per_ring]).reshape(*ring_shape, *per_ring[0][name].shape)
        for name in per_ring[0]
    }
    te = out.pop("carrier_te")
    work = {name: out.pop(f"work_{name}") for name in WORK_PARTS}
    twist = out.pop("twist")
    if stage.carrier_stiffness is not None:
        te = te - torques[:, None] / stage.carrier_stiffness
        twist = twist + torques[:, None] / stage.carrier_stiffness
        work["carrier"] = work["carrier"] + (torques**2 / stage.carrier_stiffness)[:, None]
    bfx, bfy = out.pop("bearing_fx"), out.pop("bearing_fy")
    mfx, mfy = out.pop("mesh_fx"), out.pop("mesh_fy")
    return Stage(
        crank_angle=phi,
        torque=torques,
        pin_load=out["pin_load"],
        opposite_pin_load=out["opposite_pin_load"],
        contact_stress=out["contact_stress"],
        contacts=out["contacts"],
        torque_share=out["torque_share"],
        mesh_force=np.hypot(mfx, mfy),
        mesh_force_angle=np.arctan2(mfy, mfx),
        bearing_load=np.hypot(bfx, bfy),
        bearing_load_angle=np.arctan2(bfy, bfx),
        bearing_deflection=out["bearing_deflection"],
        max_roller_load=out["max_roller_load"],
        disc_translation_x=out["disc_translation_x"],
        disc_translation_y=out["disc_translation_y"],
        disc_rotation=out["disc_te"],
        transmission_error=te,
        mesh_transmission_error=out["mesh_te"],
        residual=out["residual"],
        groove_load=out["groove_load"],
        groove_stress=out["groove_stress"],
        work=work,
        twist=twist,
    )


def bearing_life(
    stage_result: Stage, stage: StageDesign, pins: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Equivalent load [N], L10 [million revolutions] and L10h [h] of every crank bearing.

    The equivalent dynamic load is the p-mean (p = 10/3) of the bearing load over the
    crank angles of the result (ISO 281:2007, variable load; the angles should span a
    revolution or whole mesh cycles, evenly spaced). The crank pin turns against its
    hole n1 times per output revolution (the hole turns with the output, the eccentric
    n2 times the other way), so L10h = 10⁶·L10/(60·n1·n_out).

    Returns
    -------
    equivalent, l10, hours : ndarray
        Shape (..., Q, D, N) (ring axes first).
    """
    if stage.bearing is None:
        raise DesignError("stage: the life needs a crank bearing ([stage.crank_bearing])")
    p = equivalent_load(stage_result.bearing_load, axis=-3)
    life = rating_life(stage.bearing.rating(), p)
    return p, life, life_hours(life, pins * stage.output_speed)


@dataclass(frozen=True)
class StageTorsion:
    """Result of :func:`stage_torsion_curve`; rotation (Q, A) [rad], metrics (A,)."""

    torque: FloatArray
    rated_torque: float
    rotation: FloatArray
    mesh_rotation: FloatArray
    lost_motion: FloatArray
    torsional_rigidity: FloatArray
    mesh_lost_motion: FloatArray
    mesh_torsional_rigidity: FloatArray
    stage: Stage


def stage_torsion_curve(
    design: PairDesign,
    stage: StageDesign,
    modification: Modification | None,
    errors: PinErrors | None,
    rated_torque: float,
    crank_angles: ArrayLike,
    groove_deformation: bool = True,
    discs: int = 1,
    points: int = 41,
    contact_law: str = "half_plane",
) -> StageTorsion:
    """Torsion curve of the whole stage (mesh, crank bearings, springs in one solve).

    Torques and the definitions of lost motion (±3 %) and rigidity (secant 50–100 %) as
    :func:`~cyclomesh.drive.solve.torsion_curve`; the output rotation is the carrier's TE from
    :func:`solve_stage`, beside the mesh alone (rigid bearings) at the same torques.
    """
    torques = torsion_torques(rated_torque, points)
    result = solve_stage(
        design,
        stage,
        modification,
        errors,
        torques,
        crank_angles,
        groove_deformation,
        discs,
        contact_law,
    )
    lost, rigidity = torsion_metrics(result.transmission_error, torques, rated_torque)
    mesh_lost, mesh_rigidity = torsion_metrics(
        result.mesh_transmission_error, torques, rated_torque
    )
    return StageTorsion(
        torque=torques,
        rated_torque=float(rated_torque),
        rotation=result.transmission_error,
        mesh_rotation=result.mesh_transmission_error,
        lost_motion=lost,
        torsional_rigidity=rigidity,
        mesh_lost_motion=mesh_lost,
        mesh_torsional_rigidity=mesh_rigidity,
        stage=result,
    )
