"""The reported position of a disc that carries nothing: a canonical point of its free set.

At a light torque (the ±3 % of rated torque of the lost motion) a disc of a stack may
carry no load at all: the other disc takes the torque, and this one floats inside its
crank bearings' clearance with every pin open. Equilibrium does not determine where: the
potential of :mod:`cyclomesh.stage.equilibrium` is flat over the disc's *free set*

    Z_d = {(θ_d, u_d): every pin open, δ_i ≤ 0; every crank bearing inside its clearance,
           |d_dk| ≤ P_d/2},

so Newton's method stops at a point of it that depends on its path (its start, step cap
and line search), not on the stage. Every determined output (the output twist, loads,
stresses, lives, the lost motion) is the same at every point of Z_d; only the floating
disc's rotation, translation and its holes' deflections are not. They are reported at a
stated point instead, computed after the solve from the problem alone
(:func:`canonical_positions`), the same on the NumPy and the compiled path:

* the disc's **centred position** z₀: its holes centred on their crank pins in the least
  squares sense, min Σ_k |d_dk|² over (θ_d, u_d), the crankshafts' deflections, the end
  plate and the carrier (determined) held; with equally spaced holes and no hole errors
  or crankshaft deflection, θ_d = c and u_d = 0, the disc turning with the carrier;
* the **point of Z_d nearest to z₀** (rotations measured as r_c·θ): z₀ itself when the
  pins and bearings leave it free, else its projection on Z_d. The projection is the
  minimiser of ½|z − z₀|² + (κ/2)(Σ_i max(0, δ_i)² + Σ_k max(0, |d_dk| − P_d/2)²) with
  κ = :data:`PENALTY` (strictly convex, so unique; it lies within about |z − z₀|/κ, below
  10⁻¹³ m here, of the exact projection), found by Newton's method with a backtracking
  line search from z₀.

A disc counts as floating when every force on it (pins on both flanks, crank bearings) is
at most :data:`FLOATING_LOAD`·T/r_c, a thousand times the equilibrium's tolerance
(FORCE_TOLERANCE·T/r_c, below which a load is not resolved by the solve). Its reported
loads (pins, crank bearings) are 0: the solve's are its round-off (~1e-13 N), which
depends on Newton's path, and a contact stress ∝ √F would magnify it to ~1e-9 of the
largest stress (:func:`cyclomesh.stage.equilibrium.solve_direction`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["FLOATING_LOAD", "PENALTY", "floating_discs", "canonical_positions"]

FloatArray = NDArray[np.float64]

FLOATING_LOAD = 1e-9
"""A disc whose every force is at most this times T/r_c floats (:func:`floating_discs`):
1000 times the equilibrium's tolerance, so that two converged solves agree on which discs
float (a disc held by a load below the tolerance sits anywhere along its contact)."""
PENALTY = 1e8
"""κ of the projection on the free set (dimensionless: metres² against metres²)."""
_ITERATIONS = 60
_ROUNDS = 20


def floating_discs(pin_force: FloatArray, bearing_force: FloatArray, tol: float):
    """(A, D) True where every pin force (A, D, P) and crank bearing force (A, D, N) [N]
    is at most ``tol`` [N]."""
    return (np.max(pin_force, axis=-1, initial=0.0) <= tol) & (
        np.max(bearing_force, axis=-1, initial=0.0) <= tol
    )


def canonical_positions(
    p, x: FloatArray, discs: int, floating: NDArray[np.bool_], half_clearance: float
) -> tuple[FloatArray, FloatArray]:
    """The unknowns ``x`` (A, m) with every floating disc (``floating`` (A, D)) moved to the
    point of its free set nearest to its centred position (module doc), and the crank
    bearings' deflections |d_dk| [m] (A', D', N) there of the moved discs, in the order of
    ``np.argwhere(floating)``.

    ``p``: the problem (:class:`~cyclomesh.stage.assembly.Problem`; with the compliant
    disc its rigid arrays: a disc without load is undeformed, its body unknowns left as
    they are in ``x``),
    ``half_clearance``: P_d/2 [m]. Returns ``(x, deflection)``.
    """
    out = x.copy()
    where = np.argwhere(floating)
    if where.size == 0:
        return out, np.zeros((0, p.hx.shape[-1]))
    ia, d = where[:, 0], where[:, 1]
    n, m = x.shape
    L = p.scale
    N = p.hx.shape[-1]
    sup = p.supports
    base = 1 + 3 * discs
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    beta = x[:, base + nw] if sup is not None and sup.carrier is not None else np.zeros(n)
    frac = sup.fraction[d] if sup is not None else np.zeros(d.size)
    # the disc's rotation is θ_ref + ω: θ_ref = c + (x_d/S)·β (the crank pins' own turn)
    theta_ref = x[ia, 0] + frac * beta[ia]
    jx, jy = -p.hy[ia] / L, p.hx[ia] / L  # (k, N): ∂d/∂(ω·L), unit vectors
    ex, ey = p.ex[ia, d], p.ey[ia, d]  # (k, N)
    if nw:
        w = x[:, base : base + nw].reshape(n, discs, N, 2)[ia, d]
        ex, ey = ex - w[..., 0], ey - w[..., 1]
    # d_k = M_k·z + e_k, z = (ω·L, ux, uy), M_k = [[jx, 1, 0], [jy, 0, 1]]
    Mx = np.stack([jx, np.ones_like(jx), np.zeros_like(jx)], -1)  # (k, N, 3)
    My = np.stack([jy, np.zeros_like(jy), np.ones_like(jy)], -1)
    normal = np.einsum("kni,knj->kij", Mx, Mx) + np.einsum("kni,knj->kij", My, My)
    rhs = -(np.einsum("kni,kn->ki", Mx, ex) + np.einsum("kni,kn->ki", My, ey))
    z0 = np.linalg.solve(normal, rhs[..., None])[..., 0]
    # pins: δ_i = a_i·z + b_i (the usable ones; the others have no law)
    usable = np.isfinite(p.bl[ia, d])
    arm = np.where(usable, p.arm[ia, d], 0.0)
    a = np.stack(
        [arm / L, np.where(usable, p.nx[ia, d], 0.0), np.where(usable, p.ny[ia, d], 0.0)], -1
    )
    b = np.where(usable, arm * (theta_ref[:, None] - np.where(usable, p.bl[ia, d], 0.0)), -np.inf)

    z = _polish(z0, a, b, Mx, My, ex, ey, half_clearance)
    out[ia, 1 + 3 * d] = theta_ref + z[:, 0] / L
    out[ia, 2 + 3 * d] = z[:, 1]
    out[ia, 3 + 3 * d] = z[:, 2]
    _, dx, dy = _constraints(z, a, b, Mx, My, ex, ey)
    return out, np.hypot(dx, dy)


def _polish(z0, a, b, Mx, My, ex, ey, r):
    """The projection of z₀ on the free set by an active-set method (Goldfarb and Idnani's
    order: from z₀ itself, the unconstrained minimum): each round solves the KKT system
    of min ½|z − z₀|² with the active constraints as equalities (pins a·z + b = 0,
    bearings (|d|² − r²)/(2r) = 0) by Newton's method to round-off, then drops the
    constraint of the most negative multiplier, or else adds the most violated one.
    Where that does not settle in :data:`_ROUNDS` rounds, :func:`_penalty`'s point
    (within |z − z₀|/κ of the projection)."""
    k, P = b.shape
    delta, dx, dy = _constraints(z0, a, b, Mx, My, ex, ey)
    out = z0.copy()
    todo = np.flatnonzero(np.any(np.concatenate([delta > 0.0, np.hypot(dx, dy) > r], -1), -1))
    if todo.size == 0:  # z₀ free: itself
        return out
    act = np.zeros((k, delta.shape[-1] + dx.shape[-1]), bool)  # (k, P + N)
    z = out.copy()
    for _round in range(_ROUNDS):
        if todo.size == 0:
            return out
        zz, lam, order = _kkt(z[todo], z0[todo], a[todo], b[todo], Mx[todo], My[todo],
                              ex[todo], ey[todo], r, act[todo])  # fmt: skip
        delta, dx, dy = _constraints(zz, a[todo], b[todo], Mx[todo], My[todo], ex[todo], ey[todo])
        excess = np.concatenate([delta, np.hypot(dx, dy) - r], -1)
        excess = np.where(act[todo], -np.inf, excess)
        worst = np.argmax(excess, -1)
        violated = np.max(excess, -1) > 1e-15
        neg = np.min(lam, -1, initial=0.0) < 0.0
        fine = ~violated & ~neg & np.all(np.isfinite(zz), -1)
        out[todo[fine]] = zz[fine]
        rows = np.arange(todo.size)
        drop = order[rows, np.argmin(lam, -1)]
        change = act[todo]
        change[rows[neg], drop[neg]] = False
        add = ~neg & violated
        change[rows[add], worst[add]] = True
        act[todo] = change
        todo = todo[~fine]
    if todo.size:  # not settled: the penalty's point
        out[todo] = _penalty(z0[todo], a[todo], b[todo], Mx[todo], My[todo], ex[todo], ey[todo], r)
    return out


def _constraints(z, a, b, Mx, My, ex, ey):
    """Pin approaches δ (k, P) and hole-against-crank-pin vectors (dx, dy) (k, N) at z."""
    delta = np.einsum("kpi,ki->kp", a, z) + b
    dx = np.einsum("kni,ki->kn", Mx, z) + ex
    dy = np.einsum("kni,ki->kn", My, z) + ey
    return delta, dx, dy


def _kkt(z, z0, a, b, Mx, My, ex, ey, r, act):
    """Newton's method on the KKT system of the projection of z₀ with the constraints
    ``act`` (k, P + N) as equalities, from z; returns (z, the multipliers (k, J), their
    constraints (k, J))."""
    k, P = b.shape
    rows = np.arange(k)[:, None]
    J = max(1, int(np.max(np.sum(act, -1), initial=0)))
    order = np.argsort(~act, axis=-1, kind="stable")[:, :J]
    on = np.take_along_axis(act, order, -1)
    hole = order >= P
    pin = np.where(hole, 0, order)
    bh = np.where(hole, order - P, 0)
    lam = np.zeros((k, J))
    MtM = np.einsum("kni,knj->knij", Mx, Mx) + np.einsum("kni,knj->knij", My, My)
    eye = np.eye(3)
    zz = z.copy()
    for _ in range(30):
        delta, dx, dy = _constraints(zz, a, b, Mx, My, ex, ey)
        gb = (np.einsum("kni,kn->kni", Mx, dx) + np.einsum("kni,kn->kni", My, dy)) / r
        grad = np.where(hole[..., None], gb[rows, bh], a[rows, pin])
        grad = np.where(on[..., None], grad, 0.0)
        val = np.where(hole, (dx * dx + dy * dy - r * r)[rows, bh] / (2.0 * r), delta[rows, pin])
        val = np.where(on, val, 0.0)
        weight = np.where(on & hole, lam, 0.0)
        kkt = np.zeros((k, 3 + J, 3 + J))
        kkt[:, :3, :3] = eye + np.einsum("kj,kjab->kab", weight, MtM[rows, bh]) / r
        kkt[:, :3, 3:] = np.swapaxes(grad, 1, 2)
        kkt[:, 3:, :3] = grad
        kkt[:, 3 + np.arange(J), 3 + np.arange(J)] = np.where(on, -1e-15, 1.0)
        res = np.concatenate([(zz - z0) + np.einsum("kj,kji->ki", lam, grad), val], -1)
        move = np.linalg.solve(kkt, -res[..., None])[..., 0]
        zz = zz + move[:, :3]
        lam = np.where(on, lam + move[:, 3:], 0.0)
        if np.max(np.abs(move[:, :3]), initial=0.0) <= 1e-20:
            break  # round-off of µm (quadratic convergence; pins alone: one step)
    return zz, np.where(on, lam, 0.0), order


def _penalty(z0, a, b, Mx, My, ex, ey, half_clearance):
    """The minimiser of ½|z − z₀|² + (κ/2)(Σ max(0, δ)² + Σ max(0, |d| − r)²), Newton's
    method with a backtracking line search from z₀ (the fallback of :func:`_polish`)."""

    def parts(z, k):
        delta, dx, dy = _constraints(z, a[k], b[k], Mx[k], My[k], ex[k], ey[k])
        return delta, dx, dy, np.hypot(dx, dy)

    def merit(z, k):
        delta, _, _, s = parts(z, k)
        over = np.maximum(s - half_clearance, 0.0)
        return 0.5 * np.sum((z - z0[k]) ** 2, -1) + 0.5 * PENALTY * (
            np.sum(np.maximum(delta, 0.0) ** 2, -1) + np.sum(over * over, -1)
        )

    z = z0.copy()
    todo = np.arange(z.shape[0])
    for _ in range(_ITERATIONS):
        if todo.size == 0:
            break
        zt = z[todo]
        delta, dx, dy, s = parts(zt, todo)
        pen = np.maximum(delta, 0.0)
        over = np.maximum(s - half_clearance, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            cx = np.where(s > 0, dx / s, 1.0)
            cy = np.where(s > 0, dy / s, 0.0)
            ratio = np.where(s > 0, over / s, 0.0)
        Mt = np.stack([Mx[todo], My[todo]], -2)  # (k, N, 2, 3)
        grad = (zt - z0[todo]) + PENALTY * (
            np.einsum("kp,kpi->ki", pen, a[todo])
            + np.einsum("kn,knri,knr->ki", over, Mt, np.stack([cx, cy], -1))
        )
        closed = (delta > 0.0).astype(float)
        hess = np.eye(3) + PENALTY * np.einsum("kp,kpi,kpj->kij", closed, a[todo], a[todo])
        # |d| − r beyond the clearance: d̂d̂ᵀ along, (|d| − r)/|d| across
        c = np.stack([cx, cy], -1)
        outer = (over > 0.0)[..., None, None] * (
            c[..., :, None] * c[..., None, :]
            + ratio[..., None, None] * (np.eye(2) - c[..., :, None] * c[..., None, :])
        )
        hess = hess + PENALTY * np.einsum("knri,knrs,knsj->kij", Mt, outer, Mt)
        step = -np.linalg.solve(hess, grad[..., None])[..., 0]
        now = merit(zt, todo)
        t = np.ones(todo.size)
        slope = np.sum(grad * step, -1)
        for _h in range(20):
            trial = zt + t[:, None] * step
            ok = merit(trial, todo) <= now + 1e-4 * t * slope
            if np.all(ok):
                break
            t = np.where(ok, t, 0.5 * t)
        z[todo] = zt + t[:, None] * step
        todo = todo[np.max(np.abs(t[:, None] * step), -1) > 1e-13]  # its active set
    return z
