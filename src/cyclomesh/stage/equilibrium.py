"""Equilibrium of one direction of the RV stage at one torque (the model of
:mod:`cyclomesh.stage.solve`): the problem of every crank angle (pins on both flanks,
crank holes, hole errors), Newton's method with a backtracking line search on the
potential, and the stiff-limit split of the bearing loads.

:func:`solve_direction` solves the stage under a positive torque in the frame of a
:class:`~cyclomesh.drive.mesh.StackMesh` (the reverse flanks go through the mirror);
:func:`ring_mesh` takes one ring of a many-ring mesh. With the crankshafts and carrier
from their geometry (:class:`Supports`, :func:`stage_supports`, with the bearing law in
:mod:`cyclomesh.stage.supports`; docs/stage.md) the beam
deflections of the crank pins at the discs and the end plate's rotation are extra
unknowns of the same potential; the output twist is split by virtual work into the
work of every part on its own deformation (:data:`WORK_PARTS`).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.discbody import FREE_HELD, FreeDiscBody
from cyclomesh.core.fields import contact_fields
from cyclomesh.core.hertz import force_from_approach
from cyclomesh.core.pair import CrankHoles
from cyclomesh.core.transmission import transmission_error
from cyclomesh.drive.solve import (
    StackMesh,
    mirror_index,
)
from cyclomesh.exceptions import ConvergenceError
from cyclomesh.stage import newton as reference
from cyclomesh.stage.bearing import roller_loads
from cyclomesh.stage.design import StageDesign
from cyclomesh.stage.kernel import compiled, pin_law
from cyclomesh.stage.kernel import newton as kernel_newton
from cyclomesh.stage.kernel import rigid_newton as kernel_rigid_newton
from cyclomesh.stage.newton import FORCE_TOLERANCE, newton, reducer
from cyclomesh.stage.supports import (
    BearingLaw,
    Supports,
    bearing_deflection,
    stage_supports,
    stiff_limit_split,
)

__all__ = [
    "solve_direction",
    "ring_mesh",
    "FORCE_TOLERANCE",
    "Supports",
    "stage_supports",
    "WORK_PARTS",
]

FloatArray = NDArray[np.float64]

_BODY_REACH = 10.0
"""Pins with an unloaded backlash below this many times the single-pin bound of the
rotation get the compliant disc's unknowns (:func:`body_coupling`): the disc turns by
about the output's twist, a few times that bound in the examples (the far side of the
disc, whose forward flanks face away, is 5–500 times it)."""
_REACH = 0.5
"""Largest pin approach a line-search trial may reach, as a fraction of the stiffest point
of the contact law γ·exp(α/γ − 1) (about 0.8 mm here, against µm under load): a longer
trial step is halved. Near the stiffest point dδ/dF → 0 and the law's inversion
(:func:`~cyclomesh.core.hertz.force_from_approach`) converges too slowly; a wild first
step at a light torque with pin errors reached it and failed the solve."""


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
    dmax: FloatArray  # largest approach a trial may reach (_REACH of the law's), (A, D, n1)
    hx: FloatArray  # (A, N) hole centres from the disc centre, fixed frame
    hy: FloatArray
    ex: FloatArray  # (A, D, N) hole errors, fixed frame
    ey: FloatArray
    torque: float
    scale: float  # r_c
    supports: Supports | None = None
    jacobian: FloatArray | None = None  # bearing_jacobian, (A, D, N, 2, m), or None
    body: _Body | None = None  # the compliant disc (FE), unknowns after the supports'

    def take(self, idx: NDArray[np.int64]) -> _Problem:
        """The problem at the crank angles ``idx`` (increasing); itself when it is all."""
        if idx.size == self.bl.shape[0] and np.array_equal(idx, np.arange(idx.size)):
            return self
        kw = {
            name: (
                getattr(self, name)[idx]
                if isinstance(getattr(self, name), np.ndarray | _Body)
                else getattr(self, name)
            )
            for name in self.__dataclass_fields__
        }
        return _Problem(**kw)


@dataclass
class _Body:
    """The compliant disc in the equilibrium (:func:`body_coupling`), leading axis the
    crank angles (A, ...), Λ body unknowns per disc.

    The unknowns z (m) are the forces on each disc scaled by a typical compliance c0,
    λ = z/c0: the loads of its candidate pins (into the disc) and of its hole centres
    (radial and tangential, less the three components that fix the rigid motion). The body's
    displacement is C'·λ (:class:`~cyclomesh.core.discbody.FreeDiscBody`), its energy
    ½·λᵀC'λ = ½·zᵀEz; at the stationary point λ is the load on the disc.
    """

    pin_w: FloatArray  # (A, D, 2·n1, Λ): into-disc displacement of every pin per unit z
    hole_w: FloatArray  # (A, D, N, 2, Λ): hole centre displacement (fixed frame, x y)
    energy: FloatArray  # (A, D, Λ, Λ): E = C'/c0² on the free components

    def __getitem__(self, idx: NDArray[np.int64]) -> _Body:
        return _Body(self.pin_w[idx], self.hole_w[idx], self.energy[idx])

    @property
    def size(self) -> int:
        return self.energy.shape[1] * self.energy.shape[2]


def _pins(
    p: _Problem,
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


def _unpack(x: FloatArray, discs: int):
    c = x[:, 0]
    rest = x[:, 1 : 1 + 3 * discs].reshape(-1, discs, 3)
    return c, rest[..., 0], rest[..., 1], rest[..., 2]


def _evaluate(
    p: _Problem,
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
    c, theta, ux, uy = _unpack(x, discs)
    n, m = x.shape
    shift = None
    if p.body is not None and not rigid:  # the body's displacement at the pins
        z = x[:, m - p.body.size :].reshape(n, discs, -1)
        shift = np.matmul(p.body.pin_w, z[..., None])[..., 0]
    # rigid: u = 0 exactly, and only the rotations' rows of g and H enter the reduced
    # problem (the others are multiplied by 0 there), so they are left 0
    F, k, U, bad = _pins(p, theta, None if rigid else ux, None if rigid else uy, shift)
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
    state = {"pin_force": F, "bad": bad}
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
    s = np.hypot(dx, dy)
    B, kb, Ub, sb = law.evaluate(s, stiffness=hessian)
    energy = energy + np.sum(Ub, axis=(-2, -1))
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = np.where(s > 0, dx / s, 1.0)
        cy = np.where(s > 0, dy / s, 0.0)
        if hessian:
            secant = np.where(s > 0, B / s, kb)
    fx, fy = B * cx, B * cy  # force of the disc on the crank pin
    # columns of ∂d/∂(c, θ_d, ux_d, uy_d), scaled (c, θ by L)
    gc = [(-jx / L, -jy / L), (jx / L, jy / L), (1.0, 0.0), (0.0, 1.0)]
    if hessian:
        kxx = kb * cx * cx + secant * cy * cy
        kyy = kb * cy * cy + secant * cx * cx
        kxy = (kb - secant) * cx * cy
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


def _body_pins(p: _Problem, x, discs, cols, F, k, energy, g, H):
    """The compliant disc at the pins and its own energy (:class:`_Body`).

    δ_i −= (C'·λ)_i, so ∂δ/∂z = −pin_w; the body's energy ½·zᵀEz = ½·λᵀC'λ (issue 17's
    coefficients, :class:`~cyclomesh.core.discbody.FreeDiscBody`). Gradient and Hessian
    of the scaled unknowns as :func:`_evaluate` (``cols``: ∂δ/∂(θ·r_c, u) of every pin).
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
    for d in range(discs):
        zi = slice(z0 + d * lam, z0 + (d + 1) * lam)
        w = b.pin_w[:, d]  # (n, 2·n1, Λ)
        g[:, zi] += ez[:, d] - np.matmul(F[:, d, None, :], w)[:, 0]
        if H is not None:
            kw = k[:, d, :, None] * w
            H[:, zi, zi] += np.matmul(np.swapaxes(w, 1, 2), kw) + b.energy[:, d]
            base = 1 + 3 * d
            v = -np.matmul(cols[:, d], kw)  # (n, 3, Λ): cols (n, D, 3, pins)
            H[:, base : base + cols.shape[-2], zi] += v
            H[:, zi, base : base + cols.shape[-2]] += np.swapaxes(v, 1, 2)
    return energy, g, H


def body_coupling(
    mesh: StackMesh, prob: _Problem, body: FreeDiscBody, reach: FloatArray, start: dict
) -> tuple[_Body, FloatArray]:
    """The compliant disc of one direction: :class:`_Body` from the free disc's
    influence coefficients (:class:`~cyclomesh.core.discbody.FreeDiscBody`, issue 17's FE
    with the crank-hole centres free).

    Every loaded-flank pin that can close (positive moment arm, unloaded backlash below
    ``reach`` (A,) [rad], :data:`_BODY_REACH` times the rotation at which one pin alone
    would carry the torque) gets a body unknown (its load), and so do the hole centres
    except :data:`~cyclomesh.core.discbody.FREE_HELD`, which fix the disc's rigid motion
    (the stage's θ_d, u_d: the hole centres' least-squares motion). The opposite flanks
    and the other pins keep the rigid disc (they carry no load in the examples; with a
    compliant disc their gaps would move by the body's deformation too, which is not
    modelled). Hole components are turned from the disc's radial/tangential directions to
    the fixed frame at every crank angle.

    The pins' coefficients have the near field of the contact law taken out (issue 17), so
    C' alone is not positive definite (a pin's own coefficient may be negative; only the
    law's compliance plus C' is): the stationary point in the body unknowns is then a
    saddle of the potential, not a minimum. Newton's method finds it from the rigid disc's
    loads (λ = the loads on the disc there, ``start``); the convergence test is the
    residual of every equation, as without the body (tested on every crank angle of the
    examples; a shift of C''s negative part into the laws, which would restore a minimum,
    took a quarter of the law's α and left the stiffened law no range).
    """
    A, D, n1 = mesh.geo.rotation.shape
    N = prob.hx.shape[-1]
    tooth = np.asarray(mesh.tooth).reshape(A, D, n1)
    angle = mesh.geo.profile_angle.reshape(A, D, n1)
    bl = prob.bl[..., :n1]
    cand = np.isfinite(bl) & (prob.arm[..., :n1] > 0) & (bl < reach[:, None, None])
    P = max(int(np.max(np.sum(cand, axis=-1))), 1)
    order = np.argsort(~cand, axis=-1, kind="stable")[..., :P]
    ok = np.take_along_axis(cand, order, -1)
    cmat = body.matrix(
        np.take_along_axis(tooth, order, -1),
        np.where(ok, np.take_along_axis(angle, order, -1), 0.0),
    )
    rows = np.concatenate([ok, np.ones((A, D, 2 * N), bool)], -1)
    cmat = np.where(rows[..., :, None] & rows[..., None, :], cmat, 0.0)
    held = [2 * h + c for h, c in FREE_HELD]
    free = np.array([*range(P), *(P + j for j in range(2 * N) if j not in held)])
    c0 = float(np.mean(np.abs(np.diagonal(cmat[..., :P, :P], axis1=-2, axis2=-1)[ok])))
    pad = np.flatnonzero(~ok.reshape(-1, P))
    if pad.size:  # padding: an unknown of its own, 0 at the solution
        flat = cmat.reshape(-1, P + 2 * N, P + 2 * N)
        j = pad % P
        flat[pad // P, j, j] = c0
    scaled = cmat[..., free] / c0  # (A, D, P + 2N, Λ)
    lam = free.size
    pin_w = np.zeros((A, D, 2 * n1, lam))
    np.put_along_axis(pin_w, order[..., None], scaled[..., :P, :], axis=2)
    holes = scaled[..., P:, :].reshape(A, D, N, 2, lam)  # radial, tangential
    L = prob.scale
    erx, ery = prob.hx[:, None, :, None] / L, prob.hy[:, None, :, None] / L  # (A, 1, N, 1)
    hole_w = np.stack(
        [
            holes[..., 0, :] * erx - holes[..., 1, :] * ery,
            holes[..., 0, :] * ery + holes[..., 1, :] * erx,
        ],
        axis=-2,
    )
    energy = cmat[..., free[:, None], free[None, :]] / (c0 * c0)
    # the start: λ the loads on the disc in the state ``start`` (the rigid disc's), the
    # pins' and the crank bearings' reactions (radial and tangential at each hole)
    lam = np.zeros((A, D, P + 2 * N))
    lam[..., :P] = np.where(ok, np.take_along_axis(start["pin_force"], order, -1), 0.0)
    fx, fy = -start["bearing_fx"], -start["bearing_fy"]  # (A, D, N), on the disc
    lam[..., P::2] = fx * erx[..., 0] + fy * ery[..., 0]
    lam[..., P + 1 :: 2] = -fx * ery[..., 0] + fy * erx[..., 0]
    z = c0 * lam[..., free]
    return _Body(pin_w=pin_w, hole_w=hole_w, energy=energy), z.reshape(A, -1)


def _evaluate_supported(p: _Problem, law, x, discs, hessian, energy, g, H, state):
    """Bearings, crankshafts and end plate of :func:`_evaluate` with :class:`Supports`.

    d_dk = u_d + (θ_d − c)·Jh_k + ε_dk − w'_dk − (x_d/S)·β·Jh_k (hole against crank pin);
    the gradient and Hessian are assembled from ∂d/∂x (n, D, N, 2, m) in one contraction.
    With the compliant disc (``p.body``) the hole centre moves by the body's displacement
    too: d_dk += (C'·λ)_k (:class:`_Body`). Either of ``p.supports`` and ``p.body`` may be
    None.
    """
    sup = p.supports
    c, theta, ux, uy = _unpack(x, discs)
    n, m = x.shape
    N = p.hx.shape[-1]
    L = p.scale
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
    s = np.hypot(dx, dy)
    B, kb, Ub, sb = law.evaluate(s, stiffness=hessian)
    energy = energy + np.sum(Ub, axis=(-2, -1))
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = np.where(s > 0, dx / s, 1.0)
        cy = np.where(s > 0, dy / s, 0.0)
        if hessian:
            secant = np.where(s > 0, B / s, kb)
    fx, fy = B * cx, B * cy
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
    if hessian:
        kxx = kb * cx * cx + secant * cy * cy
        kyy = kb * cy * cy + secant * cx * cx
        kxy = (kb - secant) * cx * cy
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


def bearing_jacobian(p: _Problem, discs: int, m: int) -> FloatArray:
    """∂d/∂x of every hole against its crank pin with :class:`Supports` or the compliant
    disc, (n, D, N, 2, m).

    Scaled unknowns (rotations × r_c); d is affine in x, so this depends on the crank
    angle only (:func:`solve_direction` forms it once, :attr:`_Problem.jacobian`).
    """
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
    if p.body is not None:  # the hole centres' displacement by the compliant disc
        lam = p.body.energy.shape[-1]
        for d in range(discs):
            z0 = m - p.body.size + d * lam
            G[:, d, :, :, z0 : z0 + lam] = p.body.hole_w[:, d]
    return G


_NEAR = 10e-6
"""Pins farther than this from contact at the start of a solve [m] are left out of its
Newton iteration (:func:`_solve`); a left-out pin that closes all the same is taken back
and its crank angle solved again with every pin, so this sets the speed, not the answer."""
_PIN_FIELDS = ("bl", "arm", "nx", "ny", "alpha", "gamma", "dmax")


def _approach(p: _Problem, x: FloatArray, discs: int, rigid: bool) -> FloatArray:
    """Pin approaches δ (A, D, pins) of :func:`_pins` at x; −inf where a pin has no law."""
    _, theta, ux, uy = _unpack(x, discs)
    usable = np.isfinite(p.bl)
    delta = p.arm * (theta[..., None] - np.where(usable, p.bl, 0.0))
    if not rigid:
        delta = delta + p.nx * ux[..., None] + p.ny * uy[..., None]
    if not rigid and p.body is not None:  # less the compliant disc's displacement
        z = x[:, x.shape[1] - p.body.size :].reshape(x.shape[0], discs, -1)
        delta = delta - np.matmul(p.body.pin_w, z[..., None])[..., 0]
    return np.where(usable, delta, -np.inf)


def _near(p: _Problem, x: FloatArray, discs: int, rigid: bool) -> _Problem:
    """The problem on the pins within :data:`_NEAR` of contact at x (the others are open
    and add exactly nothing to the potential while they stay open), padded per crank
    angle and disc with pins without a law (φbl = inf)."""
    near = _approach(p, x, discs, rigid) > -_NEAR
    count = int(max(1, np.max(np.sum(near, axis=-1))))
    order = np.argsort(~near, axis=-1, kind="stable")[..., :count]
    kept = np.take_along_axis(near, order, axis=-1)
    fields = {f: np.take_along_axis(getattr(p, f), order, axis=-1) for f in _PIN_FIELDS}
    fields["bl"] = np.where(kept, fields["bl"], np.inf)
    if p.body is not None:  # the same pins of the compliant disc's coefficients
        pin_w = np.take_along_axis(p.body.pin_w, order[..., None], axis=2)
        fields["body"] = dataclasses.replace(p.body, pin_w=pin_w)
    return dataclasses.replace(p, **fields)


def _solve(p: _Problem, law, x: FloatArray, discs: int, rigid: bool, phi: FloatArray):
    """:func:`~cyclomesh.stage.newton.newton` on the pins near contact (:func:`_near`),
    then every pin checked: the crank angles where a left-out pin closed are solved
    again from there with all pins (the answer is the whole problem's either way). If
    the near pins alone do not converge (a left-out pin that would have held a disc),
    the whole problem is solved from the start, so this fails only where it fails. The
    compliant disc's problem goes through :func:`_body_newton`."""
    if (rigid or (p.body is None and law.k is None)) and compiled():
        # CYCLOMESH_KERNEL=numba: every pin in the compiled pass (an open pin costs it a
        # comparison, less than picking the near ones), so there is no check after
        return _kernel_newton(p, _evaluate, law, x, discs, rigid, phi)
    solver = newton if rigid or p.body is None else _body_newton
    q = _near(p, x, discs, rigid)
    start = x.copy()
    try:
        x = solver(q, _evaluate, law, x, discs, rigid, phi)
    except ConvergenceError:
        return solver(p, _evaluate, law, start, discs, rigid, phi)
    closed = np.sum(_approach(p, x, discs, rigid) > 0.0, axis=-1)
    counted = np.sum(_approach(q, x, discs, rigid) > 0.0, axis=-1)  # the same arithmetic
    again = np.flatnonzero(np.any(closed != counted, axis=-1))
    if again.size:
        x[again] = solver(p.take(again), _evaluate, law, x[again], discs, rigid, phi[again])
    return x


def _kernel_newton(p: _Problem, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi):
    """:func:`~cyclomesh.stage.newton.newton` compiled (:func:`cyclomesh.stage.kernel.newton`,
    :func:`~cyclomesh.stage.kernel.rigid_newton` for the rigid phase: each crank angle's
    iteration in one pass); the crank angles it cannot finish are
    solved by the reference from their start, which raises its own error if it fails."""
    start = x.copy()
    settings = (
        reference.FORCE_TOLERANCE,
        reference._MAX_ITERATIONS,
        reference._MAX_HALVINGS,
        reference._STEP_CAP,
        *reference._LINEAR,
    )
    if rigid:
        failed = kernel_rigid_newton(p, x, discs, settings)
    else:
        jacobian = p.jacobian if p.jacobian is not None else bearing_jacobian(p, discs, x.shape[1])
        failed = kernel_newton(p, law, x, discs, jacobian, settings)
    if np.any(failed):
        idx = np.flatnonzero(failed)
        x[idx] = newton(p.take(idx), evaluate, law, start[idx], discs, rigid, phi[idx])
    return x


def _body_newton(p: _Problem, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi):
    """The compliant disc's equilibrium: :func:`~cyclomesh.stage.newton.newton` (its line
    search on the potential), and where that fails, :func:`_stationary` from the same
    start (the stationary point is a saddle in the body's unknowns, :func:`body_coupling`,
    so a descent on the potential can run away along them)."""
    start = x.copy()
    try:
        return newton(p, evaluate, law, x, discs, rigid, phi)
    except ConvergenceError:
        return _stationary(p, evaluate, law, start, discs, phi)


def _stationary(p: _Problem, evaluate, law, x: FloatArray, discs: int, phi: FloatArray):
    """Newton's method on ∇Π = 0 with a backtracking line search on the residual ‖∇Π‖
    (scaled unknowns as :func:`~cyclomesh.stage.newton.newton`, the same convergence test:
    every residual below 1e-12·T/r_c or the round-off of the unknowns)."""
    tol = FORCE_TOLERANCE * abs(p.torque) / p.scale
    L, m = p.scale, x.shape[1]
    rot = [0, *range(1, 1 + 3 * discs, 3)]
    if p.supports is not None and p.supports.carrier is not None:
        rot.append(m - 1 - p.body.size)
    active = np.arange(x.shape[0])
    for _ in range(200):
        sub = p.take(active)
        xa = x[active]
        _, g, H, _st = evaluate(sub, law, xa, discs, False)
        xs = np.abs(xa)
        xs[:, rot] *= L
        noise = 16.0 * np.finfo(float).eps * np.einsum("nij,nj->ni", np.abs(H), xs)
        keep = ~np.all(np.abs(g) <= np.maximum(tol, noise), axis=-1)
        active = active[keep]
        if active.size == 0:
            return x
        xa, g, H, sub = xa[keep], g[keep], H[keep], sub.take(np.flatnonzero(keep))
        diag = np.maximum(np.max(np.abs(np.diagonal(H, axis1=1, axis2=2)), axis=-1), 1e-300)
        step = np.linalg.solve(H + 1e-14 * diag[:, None, None] * np.eye(m), -g[..., None])[..., 0]
        step[:, rot] /= L
        merit = np.linalg.norm(g, axis=-1)
        t = np.ones(xa.shape[0])
        todo = np.arange(xa.shape[0])
        new = xa.copy()
        for _h in range(60):
            trial = xa[todo] + t[todo, None] * step[todo]
            _e, g_t, _H, st = evaluate(sub.take(todo), law, trial, discs, False, hessian=False)
            ok = ~st["bad"] & (np.linalg.norm(g_t, axis=-1) <= (1.0 - 1e-4 * t[todo]) * merit[todo])
            new[todo[ok]] = trial[ok]
            todo = todo[~ok]
            if todo.size == 0:
                break
            t[todo] *= 0.5
        else:
            raise ConvergenceError(
                f"stage (compliant disc): no decrease of the residual at crank angle "
                f"{np.degrees(phi[active[todo[0]]]):.6g}°"
            )
        x[active] = new
    raise ConvergenceError(
        f"stage (compliant disc) did not converge at crank angle "
        f"{np.degrees(phi[active[0]]):.6g}°: residual above {FORCE_TOLERANCE:.0e}·T/r_c"
    )


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
        dmax=np.where(np.isfinite(dmax), dmax * _REACH, np.inf),
        hx=hx,
        hy=hy,
        ex=ex,
        ey=ey,
        torque=torque,
        scale=holes.circle_radius,
    )


def solve_direction(
    mesh: StackMesh,
    other: StackMesh,
    stage: StageDesign,
    errs: tuple[FloatArray, FloatArray],
    torque: float,
    supports: Supports | None = None,
    body: FreeDiscBody | None = None,
) -> dict[str, FloatArray]:
    """Stage under a positive torque in the mesh's frame (``other``: the mirror problem).

    ``supports``: the crankshafts and carrier from their geometry (:func:`stage_supports`
    in this direction's disc order), None: rigid (or the override springs of ``stage``).
    ``body``: the compliant disc (:class:`~cyclomesh.core.discbody.FreeDiscBody`; ``mesh``
    then carries the tooth of every pin), None: rigid discs. It needs a crank bearing.
    """
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
    bound = x[:, 0].copy()  # one pin alone: an upper bound of the rigid mesh's rotation
    x = _solve(prob, None, x, D, True, mesh.phi)
    _, _, _, st = _evaluate(prob, None, x, D, True, hessian=False)
    F = st["pin_force"]
    mesh_te = transmission_error(mesh.rest, x[:, 0])
    rigid = _disc_loads(mesh, prob, F)  # pins on disc
    # bearings carry the pins' resultant to the crank pins and the moment Σ F·l
    bfx, bfy = stiff_limit_split(
        prob.hx,
        prob.hy,
        prob.scale,
        rigid["mesh_force_x"],
        rigid["mesh_force_y"],
        -rigid["torque_share"],
    )
    if stage.bearing is not None:
        law = BearingLaw(stage.bearing, stage.crankshaft_stiffness)
        B = np.hypot(bfx, bfy)
        s = bearing_deflection(law, B)
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
        _, k_pin, _, _ = _pins(prob, x[:, 1::3], None, None)
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
        if body is not None:  # the compliant disc, from the rigid disc's loads
            _, _, _, start = _evaluate(prob, law, x, D, False, hessian=False)
            coupling, z = body_coupling(mesh, prob, body, _BODY_REACH * bound, start)
            prob = dataclasses.replace(prob, body=coupling)
            x = np.concatenate([x, z], axis=-1)
        if supports is not None or body is not None:
            prob.jacobian = bearing_jacobian(prob, D, x.shape[1])
        x = _solve(prob, law, x, D, False, mesh.phi)
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
            np.abs(_evaluate(prob, None, x, D, True, hessian=False)[1] @ reducer(D)), -1
        )
    c, theta, ux, uy = _unpack(x, D)
    loaded = contact_fields(
        ("groove_load", "contact_stress", "groove_stress", "contacts"),
        mesh.design,
        mesh.geo,
        F[..., :n1],
        stack_axes=2,  # per disc, against the stack
    )
    disc = _disc_loads(mesh, prob, F)
    rollers = (
        np.max(roller_loads(stage.bearing, sb), axis=-1)
        if stage.bearing is not None
        else np.full(deflection.shape, np.nan)
    )
    return {
        "pin_load": F[..., :n1],
        "opposite_pin_load": F[..., n1:],
        "groove_load": loaded["groove_load"],
        "contact_stress": loaded["contact_stress"],
        "groove_stress": loaded["groove_stress"],
        "contacts": loaded["contacts"],
        "torque_share": disc["torque_share"],
        "mesh_fx": disc["mesh_force_x"],
        "mesh_fy": disc["mesh_force_y"],
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


WORK_PARTS = ("mesh", "disc_body", "crank_bearings", "crankshafts", "carrier", "hole_errors")
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
    if st.get("pin_shift") is not None:  # the compliant disc: δ includes −(C'λ)_pin
        lin = lin - st["pin_shift"]
    out = {
        "work_mesh": np.sum(F * (lin - lin0), axis=(-2, -1)),
        "work_disc_body": zero,
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
        if p.supports is not None and p.supports.carrier is not None:
            out["work_carrier"] = p.supports.carrier * st["end_plate"] ** 2
    out["work_crankshafts"] = shafts
    out["work_crank_bearings"] = np.sum(fd, axis=(-2, -1)) - np.where(
        stage.crankshaft_stiffness is not None, shafts, 0.0
    )
    out["work_hole_errors"] = -np.sum(fx * p.ex + fy * p.ey, axis=(-2, -1))
    if p.body is not None:  # λᵀC'λ = zᵀEz, the body's work on its own deformation
        z = x[:, x.shape[1] - p.body.size :].reshape(x.shape[0], discs, -1)
        out["work_disc_body"] = np.einsum("ndl,ndlk,ndk->n", z, p.body.energy, z)
    return out


def _disc_loads(mesh: StackMesh, prob: _Problem, force: FloatArray) -> dict[str, FloatArray]:
    """Torque share and mesh force of every disc from the forces on both flanks (A, D, 2·n1)."""
    return contact_fields(
        ("torque_share", "mesh_force"),
        mesh.design,
        mesh.geo,
        force,
        normal=(prob.nx, prob.ny),
        moment_arm=prob.arm,
    )


def ring_mesh(mesh: StackMesh, ring: tuple[int, ...]) -> StackMesh:
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
