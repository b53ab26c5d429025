"""Assembly of the RV stage's equilibrium problem (:mod:`cyclomesh.stage.equilibrium`):
the arrays of one direction at one torque (:class:`Problem`, with the compliant disc's
:class:`Body`), and the potential Π, its gradient and Hessian in the scaled unknowns
(:func:`evaluate`; the crankshafts, carrier and compliant disc in
:func:`_evaluate_supported` with the affine Jacobian :func:`bearing_jacobian` of the hole
displacements). Moved here from :mod:`cyclomesh.stage.equilibrium` unchanged.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.hertz import force_from_approach
from cyclomesh.stage.kernel import compiled, pin_law
from cyclomesh.stage.kernel_body import bearing_hessian, body_pin_hessian
from cyclomesh.stage.supports import Supports

__all__ = [
    "Problem",
    "Body",
    "pin_laws",
    "unpack",
    "evaluate",
    "bearing_jacobian",
    "SupportedJacobians",
    "loads",
]

FloatArray = NDArray[np.float64]

# --- the per-direction problem -------------------------------------------------------


@dataclass
class Problem:
    """Arrays of one direction at one torque, leading axis the crank angles (A, ...)."""

    bl: FloatArray  # (A, D, n1)
    arm: FloatArray
    nx: FloatArray
    ny: FloatArray
    alpha: FloatArray
    gamma: FloatArray
    dmax: FloatArray  # largest approach a trial may reach (_REACH of the law's), (A, D, n1)
    hx: FloatArray  # (A, N) hole centres from the disc centre, fixed frame
    hy: FloatArray
    ex: FloatArray  # (A, D, N) hole errors, fixed frame
    ey: FloatArray
    torque: float
    scale: float  # r_c
    supports: Supports | None = None
    jacobian: FloatArray | None = None  # bearing_jacobian, (A, D, N, 2, m), or None
    body: Body | None = None  # the compliant disc (FE), unknowns after the supports'
    slip: FloatArray | None = None  # friction: μ·s of every pin (A, D, 2·n1), T = −μ·s·F
    tangent_arm: FloatArray | None = None  # friction: m = r·n of every pin [m] (A, D, 2·n1)
    drag: float = 0.0  # friction: s_b·μ_b·d/2 [m], crank bearing moment per unit load
    # a lubricant: per-pin constants of μ(F) (stage.friction.friction_arrays), (A, D, 2·n1)
    lubrication: dict[str, FloatArray] | None = None
    friction_law: Any = None  # the Friction of ``lubrication``
    # friction: the fraction of the coefficients applied (stage.friction.friction_continuation)
    friction_scale: float = 1.0
    # friction: generalised forces held fixed in a step of stage.friction.friction_picard,
    # (A, m) in the scaled unknowns (added to the potential as the work of a dead load)
    frozen: FloatArray | None = None
    # the block (7, A, D, P) that bl … dmax are views of (equilibrium._problem; the
    # compiled iteration's one argument, stage.kernel_newton.pin_block), or None
    pins: FloatArray | None = None

    def take(self, idx: NDArray[np.int64]) -> Problem:
        """The problem at the crank angles ``idx`` (increasing); itself when it is all."""
        if idx.size == self.bl.shape[0] and np.array_equal(idx, np.arange(idx.size)):
            return self
        kw = {
            name: (
                getattr(self, name)[idx]
                if isinstance(getattr(self, name), np.ndarray | Body)
                else getattr(self, name)
            )
            for name in self.__dataclass_fields__
            if name != "pins"  # the taken arrays are copies, not views of a block
        }
        if self.lubrication is not None:
            kw["lubrication"] = {key: value[idx] for key, value in self.lubrication.items()}
        return Problem(**kw)


@dataclass
class Body:
    """The compliant disc in the equilibrium (:func:`body_coupling`), leading axis the
    crank angles (A, ...), Λ body unknowns per disc.

    The unknowns z (m) are the forces on each disc scaled by a typical compliance c0,
    λ = z/c0: the loads of its candidate pins (into the disc) and of its hole centres
    (radial and tangential, less the three components that fix the rigid motion). The body's
    displacement is C'·λ (:class:`~cyclomesh.core.discbody.FreeDiscBody`), its energy
    ½·λᵀC'λ = ½·zᵀEz; at the stationary point λ is the load on the disc.

    The pins' coefficients are kept compact: ``w`` has a row for each of the P pin
    unknowns only (the candidates and the padding's), ``flank`` the pin (flank index) that
    row moves; every other flank's row of :attr:`pin_w` is 0 (the body moves no other
    pin). :attr:`pin_w` is the whole (A, D, 2·n1, Λ) array, formed from them when read.
    """

    w: FloatArray  # (A, D, P', Λ): into-disc displacement of the pin of each row per unit z
    hole_w: FloatArray  # (A, D, N, 2, Λ): hole centre displacement (fixed frame, x y)
    energy: FloatArray  # (A, D, Λ, Λ): E = C'/c0² on the free components
    # the pin (index into the flanks, 0 … 2·n1 − 1) of each pin unknown, −1 for padding,
    # (A, D, P): a crank angle's unknowns carried to the next one's (a warm start)
    pins: NDArray[np.int64] | None = None
    # the flank (0 … flanks − 1) each row of ``w`` moves, −1: none, (A, D, P'); the rows of
    # the padding's unknowns move the pins after the candidates (body_coupling's order)
    flank: NDArray[np.int64] | None = None
    flanks: int = 0  # the pins of the problem (2·n1)

    @classmethod
    def of_dense(
        cls,
        pin_w: FloatArray,
        hole_w: FloatArray,
        energy: FloatArray,
        pins: NDArray[np.int64] | None = None,
    ) -> Body:
        """The Body of a whole ``pin_w`` (A, D, 2·n1, Λ): every flank a row."""
        A, D, F = pin_w.shape[:3]
        flank = np.ascontiguousarray(np.broadcast_to(np.arange(F), (A, D, F)))
        return cls(pin_w, hole_w, energy, pins, flank, F)

    @cached_property
    def pin_w(self) -> FloatArray:
        """(A, D, 2·n1, Λ): into-disc displacement of every pin per unit z (the rows of
        ``w`` at their flanks, 0 elsewhere)."""
        A, D, _, lam = self.w.shape
        out = np.zeros((A, D, self.flanks, lam))
        a, d, q = np.nonzero(self.flank >= 0)
        out[a, d, self.flank[a, d, q]] = self.w[a, d, q]
        return out

    def __getitem__(self, idx: NDArray[np.int64]) -> Body:
        pins = None if self.pins is None else self.pins[idx]
        return Body(
            self.w[idx], self.hole_w[idx], self.energy[idx], pins, self.flank[idx], self.flanks
        )

    def near(self, order: NDArray[np.int64]) -> Body:
        """The Body of a problem on the flanks ``order`` (A, D, K) of this one's (the
        flank of its pin k is ``order[..., k]``): ``pin_w`` becomes
        ``np.take_along_axis(pin_w, order[..., None], 2)``, the same numbers."""
        hit = (self.flank[..., :, None] == order[..., None, :]) & (self.flank[..., :, None] >= 0)
        flank = np.where(np.any(hit, axis=-1), np.argmax(hit, axis=-1), -1)
        return dataclasses.replace(self, flank=flank, flanks=order.shape[-1])

    @property
    def size(self) -> int:
        return self.energy.shape[1] * self.energy.shape[2]


def pin_laws(
    p: Problem,
    theta: FloatArray,
    ux: FloatArray | None,
    uy: FloatArray | None,
    shift: FloatArray | None = None,
):
    """Pin approach, force, stiffness, energy; None where an approach leaves the law.

    The law is evaluated only where a pin closes (δ > 0; most pins of a crank angle are
    open), each element by the same arithmetic as on the whole array. ``shift``: the disc
    body's displacement into the disc at every pin (compliant disc), subtracted. With
    ``CYCLOMESH_KERNEL=numba``: :func:`cyclomesh.stage.kernel.pin_law` (the same law to
    round-off; the reference where it cannot invert a pin's law).
    """
    if compiled():
        out = pin_law(p.bl, p.arm, p.nx, p.ny, p.alpha, p.gamma, p.dmax, theta, ux, uy, shift)
        if out is not None:
            return out
    usable = np.isfinite(p.bl)
    delta = p.arm * (theta[..., None] - np.where(usable, p.bl, 0.0))
    if ux is not None:  # None: no translation (adding n·0 would change no bit)
        delta = delta + p.nx * ux[..., None] + p.ny * uy[..., None]
    if shift is not None:
        delta = delta - shift
    delta = np.where(usable, delta, -1.0)
    delta = np.maximum(delta, 0.0)
    bad = np.any(delta >= p.dmax, axis=(-2, -1))
    closed = np.flatnonzero((delta > 0.0) & (delta < p.dmax))
    alpha = p.alpha.reshape(-1)[closed]
    gamma = p.gamma.reshape(-1)[closed]
    f = force_from_approach(delta.reshape(-1)[closed], alpha, gamma)
    with np.errstate(divide="ignore", invalid="ignore"):
        logf = np.log(np.where(f > 0, f, 1.0))
        dd = alpha - gamma * (1.0 + logf)
        k = np.where(f > 0, 1.0 / dd, 0.0)
        u = np.where(f > 0, 0.5 * f * f * (alpha - 0.5 * gamma - gamma * logf), 0.0)
    force, stiff, energy = (np.zeros(delta.shape) for _ in range(3))
    force.reshape(-1)[closed] = f
    stiff.reshape(-1)[closed] = k
    energy.reshape(-1)[closed] = u
    return force, stiff, energy, bad


def unpack(x: FloatArray, discs: int):
    c = x[:, 0]
    rest = x[:, 1 : 1 + 3 * discs].reshape(-1, discs, 3)
    return c, rest[..., 0], rest[..., 1], rest[..., 2]


def evaluate(
    p: Problem,
    law,
    x: FloatArray,
    discs: int,
    rigid: bool,
    hessian: bool = True,
    gradient: bool = True,
):
    """Potential, gradient, Hessian (scaled: rotations × r_c) and the parts of the state.

    ``gradient=False`` (the line search's trials): the potential and the state only, g and
    H None (the potential is the same arithmetic either way).
    """
    c, theta, ux, uy = unpack(x, discs)
    n, m = x.shape
    shift = None
    if p.body is not None and not rigid:  # the body's displacement at the pins
        z = x[:, m - p.body.size :].reshape(n, discs, -1)
        shift = np.matmul(p.body.pin_w, z[..., None])[..., 0]
    # rigid: u = 0 exactly, and only the rotations' rows of g and H enter the reduced
    # problem (the others are multiplied by 0 there), so they are left 0
    F, k, U, bad = pin_laws(p, theta, None if rigid else ux, None if rigid else uy, shift)
    energy = np.sum(U, axis=(-2, -1)) - p.torque * c
    L = p.scale
    hessian = hessian and gradient
    g = np.zeros((n, m)) if gradient else None
    H = np.zeros((n, m, m)) if hessian else None
    # pins: a = (θ_d: l/L, ux: nx, uy: ny) in scaled unknowns
    if gradient:
        cols = np.stack([p.arm / L] if rigid else [p.arm / L, p.nx, p.ny], axis=-2)  # (n,D,a,P)
        g_pin = np.matmul(cols, F[..., None])[..., 0]  # Σ F·a, (n, D, a)
        if hessian:
            H_pin = np.matmul(cols * k[..., None, :], np.swapaxes(cols, -1, -2))  # Σ k·a·aᵀ
        for d in range(discs):
            block = slice(1 + 3 * d, 1 + 3 * d + cols.shape[-2])
            g[:, block] += g_pin[:, d]
            if hessian:
                H[:, block, block] += H_pin[:, d]
    if gradient:
        g[:, 0] -= p.torque / L
    state = {"pin_force": F, "pin_stiffness": k, "bad": bad}
    if rigid:
        return energy, g, H, state
    if p.body is not None:
        state["pin_shift"] = shift
        energy, g, H = _body_pins(p, x, discs, cols if gradient else None, F, k, energy, g, H)
    if p.supports is not None or p.body is not None:
        return _evaluate_supported(p, law, x, discs, hessian, energy, g, H, state)
    # bearings: d = u + (θ − c)·Jh + ε, Jh = (−hy, hx)
    jx, jy = -p.hy[:, None, :], p.hx[:, None, :]  # (n, 1, N)
    rot = (theta - c[:, None])[..., None]
    dx = ux[..., None] + rot * jx + p.ex
    dy = uy[..., None] + rot * jy + p.ey
    s, fx, fy, Ub, sb, kmat = _bearings(law, dx, dy, hessian, hessian and g is not None)
    energy = energy + np.sum(Ub, axis=(-2, -1))
    # columns of ∂d/∂(c, θ_d, ux_d, uy_d), scaled (c, θ by L)
    gc = [(-jx / L, -jy / L), (jx / L, jy / L), (1.0, 0.0), (0.0, 1.0)]
    if kmat is not None:
        kxx, kyy, kxy = kmat
    for d in range(discs if g is not None else 0):
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


def _body_pins(p: Problem, x, discs, cols, F, k, energy, g, H):
    """The compliant disc at the pins and its own energy (:class:`Body`).

    δ_i −= (C'·λ)_i, so ∂δ/∂z = −pin_w; the body's energy ½·zᵀEz = ½·λᵀC'λ (issue 17's
    coefficients, :class:`~cyclomesh.core.discbody.FreeDiscBody`). Gradient and Hessian
    of the scaled unknowns as :func:`evaluate` (``cols``: ∂δ/∂(θ·r_c, u) of every pin).
    """
    b = p.body
    n, m = x.shape
    lam = b.energy.shape[-1]
    z0 = m - b.size
    z = x[:, z0:].reshape(n, discs, lam)
    ez = np.matmul(b.energy, z[..., None])[..., 0]
    energy = energy + 0.5 * np.sum(z * ez, axis=(1, 2))
    if g is None:
        return energy, g, H
    fast = H is not None and compiled()  # CYCLOMESH_KERNEL=numba: H on the closed pins
    if fast:
        body_pin_hessian(H, k, b.pin_w, cols, b.energy, z0)
    for d in range(discs):
        zi = slice(z0 + d * lam, z0 + (d + 1) * lam)
        w = b.pin_w[:, d]  # (n, 2·n1, Λ)
        g[:, zi] += ez[:, d] - np.matmul(F[:, d, None, :], w)[:, 0]
        if H is not None and not fast:
            kw = k[:, d, :, None] * w
            H[:, zi, zi] += np.matmul(np.swapaxes(w, 1, 2), kw) + b.energy[:, d]
            base = 1 + 3 * d
            v = -np.matmul(cols[:, d], kw)  # (n, 3, Λ): cols (n, D, 3, pins)
            H[:, base : base + cols.shape[-2], zi] += v
            H[:, zi, base : base + cols.shape[-2]] += np.swapaxes(v, 1, 2)
    return energy, g, H


def _bearings(law, dx, dy, stiffness: bool, matrix: bool):
    """The crank bearings at the hole-against-pin vectors (dx, dy) [m]: the deflection s,
    the force of the disc on the crank pin (fx, fy) [N] along d/s, the energy and the
    bearing law's part split (``law.evaluate``, its stiffness with ``stiffness``) and, with
    ``matrix``, the 2×2 stiffness (kxx, kyy, kxy) [N/m]: the law's dB/ds along d, the
    secant B/s across it."""
    s = np.hypot(dx, dy)
    B, kb, Ub, sb = law.evaluate(s, stiffness=stiffness)
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = np.where(s > 0, dx / s, 1.0)
        cy = np.where(s > 0, dy / s, 0.0)
        if matrix:
            secant = np.where(s > 0, B / s, kb)
    k = None
    if matrix:
        k = (
            kb * cx * cx + secant * cy * cy,
            kb * cy * cy + secant * cx * cx,
            (kb - secant) * cx * cy,
        )
    return s, B * cx, B * cy, Ub, sb, k


def _supported_holes(p: Problem, x: FloatArray, discs: int):
    """Every hole against its crank pin with :class:`Supports` or the compliant disc
    (:func:`_evaluate_supported`'s d_dk, (n, D, N) [m] each), and the crankshafts' w'
    (n, D, N, 2) and the end plate's β (n,) at x."""
    sup = p.supports
    c, theta, ux, uy = unpack(x, discs)
    n, m = x.shape
    N = p.hx.shape[-1]
    jx, jy = -p.hy[:, None, :], p.hx[:, None, :]  # (n, 1, N)
    base = 1 + 3 * discs
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    carrier = None if sup is None else sup.carrier
    w = x[:, base : base + nw].reshape(n, discs, N, 2) if nw else np.zeros((n, discs, N, 2))
    beta = x[:, base + nw] if carrier is not None else np.zeros(n)
    a = sup.fraction[None, :, None] if sup is not None else np.zeros((1, discs, 1))
    rot = (theta - c[:, None])[..., None] - a * beta[:, None, None]
    dx = ux[..., None] + rot * jx + p.ex - w[..., 0]
    dy = uy[..., None] + rot * jy + p.ey - w[..., 1]
    if p.body is not None:
        z = x[:, m - p.body.size :].reshape(n, discs, -1)
        wh = np.matmul(p.body.hole_w, z[:, :, None, :, None])[..., 0]
        dx, dy = dx + wh[..., 0], dy + wh[..., 1]
    return dx, dy, w, beta


def loads(p: Problem, law, x: FloatArray, discs: int) -> dict[str, FloatArray]:
    """The pins' forces ``pin_force`` (n, D, pins) [N] and the crank bearings' forces on
    the crank pins ``bearing_fx``, ``bearing_fy`` (n, D, N) [N] at x: those of
    :func:`evaluate`'s state (``rigid`` False), the same arithmetic, without the
    potential (the compliant disc's own starts read only these). A problem without
    :class:`Supports` and without the body goes through :func:`evaluate` itself."""
    if p.supports is None and p.body is None:
        st = evaluate(p, law, x, discs, False, gradient=False)[3]
        return {k: st[k] for k in ("pin_force", "bearing_fx", "bearing_fy")}
    _, theta, ux, uy = unpack(x, discs)
    shift = None
    if p.body is not None:  # (evaluate's)
        n, m = x.shape
        z = x[:, m - p.body.size :].reshape(n, discs, -1)
        shift = np.matmul(p.body.pin_w, z[..., None])[..., 0]
    F = pin_laws(p, theta, ux, uy, shift)[0]
    dx, dy = _supported_holes(p, x, discs)[:2]
    _, fx, fy, _, _, _ = _bearings(law, dx, dy, False, False)
    return {"pin_force": F, "bearing_fx": fx, "bearing_fy": fy}


def _evaluate_supported(p: Problem, law, x, discs, hessian, energy, g, H, state):
    """Bearings, crankshafts and end plate of :func:`evaluate` with :class:`Supports`.

    d_dk = u_d + (θ_d − c)·Jh_k + ε_dk − w'_dk − (x_d/S)·β·Jh_k (hole against crank pin);
    the gradient and Hessian are assembled from ∂d/∂x (n, D, N, 2, m) in one contraction.
    With the compliant disc (``p.body``) the hole centre moves by the body's displacement
    too: d_dk += (C'·λ)_k (:class:`Body`). Either of ``p.supports`` and ``p.body`` may be
    None.
    """
    sup = p.supports
    n, m = x.shape
    N = p.hx.shape[-1]
    L = p.scale
    base = 1 + 3 * discs
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    carrier = None if sup is None else sup.carrier
    dx, dy, w, beta = _supported_holes(p, x, discs)
    s, fx, fy, Ub, sb, k = _bearings(law, dx, dy, hessian, hessian and g is not None)
    energy = energy + np.sum(Ub, axis=(-2, -1))
    if g is None:  # the potential only (a line-search trial)
        if nw:
            Kw = np.einsum("de,nekc->ndkc", sup.stiffness, w)
            energy = energy + 0.5 * np.sum(w * Kw, axis=(1, 2, 3))
        if carrier is not None:
            energy = energy + 0.5 * carrier * beta * beta
        state.update(bearing_fx=fx, bearing_fy=fy, deflection=s, bearing_part=sb)
        state.update(shaft_deflection=w, end_plate=beta)
        return energy, g, H, state
    G = p.jacobian if p.jacobian is not None else bearing_jacobian(p, discs, m)
    f = np.stack([fx, fy], axis=-1)
    g = g + np.matmul(f.reshape(n, 1, -1), G.reshape(n, -1, m))[:, 0]
    if nw:
        Kw = np.einsum("de,nekc->ndkc", sup.stiffness, w)
        energy = energy + 0.5 * np.sum(w * Kw, axis=(1, 2, 3))
        g[:, base : base + nw] += Kw.reshape(n, nw)
    if carrier is not None:
        energy = energy + 0.5 * carrier * beta * beta
        g[:, base + nw] += carrier * beta / L
    if hessian and p.body is not None and compiled():
        # CYCLOMESH_KERNEL=numba: Gᵀ·K·G on ∂d/∂x's nonzero columns, the shafts' K ⊗ I
        kxx, kyy, kxy = k
        bearing_hessian(H, G, kxx, kyy, kxy, sup.stiffness if nw else None, base)
        if carrier is not None:
            H[:, base + nw, base + nw] += carrier / (L * L)
    elif hessian:
        kxx, kyy, kxy = k
        kmat = np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2)
        rows = G.reshape(n, -1, m)  # Gᵀ·K·G over the holes' (x, y)
        H = H + np.matmul(np.swapaxes(rows, -1, -2), np.matmul(kmat, G).reshape(n, -1, m))
        if nw:
            # the crankshafts' K ⊗ I(2N), added on its nonzero entries only (the others +0)
            rows, cols, vals = _shaft_entries(sup.stiffness, base, 2 * N)
            H[:, rows, cols] += vals
        if carrier is not None:
            H[:, base + nw, base + nw] += carrier / (L * L)
    state.update(
        bearing_fx=fx,
        bearing_fy=fy,
        deflection=s,
        bearing_part=sb,
        shaft_deflection=w,
        end_plate=beta,
    )
    return energy, g, H, state


def _shaft_entries(stiffness: FloatArray, base: int, size: int):
    """Rows, columns and values of the nonzero entries of K ⊗ I(size) placed at ``base``
    (the crankshafts' block of the Hessian, :func:`_evaluate_supported`)."""
    D = stiffness.shape[0]
    d, e, r = np.meshgrid(np.arange(D), np.arange(D), np.arange(size), indexing="ij")
    return base + d * size + r, base + e * size + r, stiffness[d, e]


def bearing_jacobian(
    p: Problem, discs: int, m: int, supported: FloatArray | None = None
) -> FloatArray:
    """∂d/∂x of every hole against its crank pin with :class:`Supports` or the compliant
    disc, (n, D, N, 2, m).

    Scaled unknowns (rotations × r_c); d is affine in x, so this depends on the crank
    angle only (:func:`solve_direction` forms it once, :attr:`Problem.jacobian`).
    ``supported``: this Jacobian without the compliant disc's columns (of the same
    problem without its body, (n, D, N, 2, m − body.size), formed before: the body's
    columns depend on the torque, the others do not); its columns are taken as they are.
    """
    if supported is not None and p.body is not None:
        G = np.zeros((*supported.shape[:-1], m))
        G[..., : supported.shape[-1]] = supported
        _body_columns(p, discs, m, G)
        return G
    sup = p.supports
    n, N, L = p.hx.shape[0], p.hx.shape[-1], p.scale
    base = 1 + 3 * discs
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    carrier = None if sup is None else sup.carrier
    a = sup.fraction[None, :, None] if sup is not None else 0.0  # (1, D, 1)
    G = np.zeros((n, discs, N, 2, m))
    jxb = np.broadcast_to(-p.hy[:, None, :], (n, discs, N)) / L
    jyb = np.broadcast_to(p.hx[:, None, :], (n, discs, N)) / L
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
    if carrier is not None:
        G[..., 0, base + nw] = -a * jxb
        G[..., 1, base + nw] = -a * jyb
    if p.body is not None:
        _body_columns(p, discs, m, G)
    return G


class SupportedJacobians:
    """The supported bearing Jacobians (:func:`bearing_jacobian` of a problem without the
    compliant disc's columns) kept between the rings of a study, the last two formed (a
    ring's two directions).

    That Jacobian depends on the crank angles' hole centres (``hx``, ``hy``, r_c), the
    :class:`Supports` and the unknowns only: not on the pins' or the holes' errors nor on
    the torque, so every ring of a tolerance study has the same one per direction. A
    kept one is handed out where its inputs are those of the problem (the same
    :class:`Supports` object, which :func:`~cyclomesh.stage.supports.stage_supports`
    caches, and equal hole centres), else it is formed: the same arrays, so the same
    numbers. The kept arrays are read-only. Not pickled (a worker starts empty).
    """

    KEEP = 2

    def __init__(self) -> None:
        self._kept: list[tuple[Any, ...]] = []

    def __getstate__(self) -> dict:  # (an empty store: not the arrays)
        return {"_kept": []}

    def __call__(self, p: Problem, discs: int, m: int) -> FloatArray:
        """:func:`bearing_jacobian` ``(p, discs, m)`` of ``p`` without a body (read-only)."""
        if p.body is not None:
            raise ValueError("SupportedJacobians: the problem without its body")
        for hx, hy, scale, sup, d, mm, G in self._kept:
            if (
                sup is p.supports
                and d == discs
                and mm == m
                and scale == p.scale
                and hx.shape == p.hx.shape
                and np.array_equal(hx, p.hx)
                and np.array_equal(hy, p.hy)
            ):
                return G
        G = bearing_jacobian(p, discs, m)
        G.flags.writeable = False
        kept = (p.hx.copy(), p.hy.copy(), p.scale, p.supports, discs, m, G)
        self._kept = [*self._kept[-(self.KEEP - 1) :], kept]
        return G


def _body_columns(p: Problem, discs: int, m: int, G: FloatArray) -> None:
    """The hole centres' displacement by the compliant disc into ``G``'s last
    ``p.body.size`` columns (:func:`bearing_jacobian`)."""
    lam = p.body.energy.shape[-1]
    for d in range(discs):
        z0 = m - p.body.size + d * lam
        G[:, d, :, :, z0 : z0 + lam] = p.body.hole_w[:, d]
