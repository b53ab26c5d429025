"""Node-to-segment contact of :mod:`cyclomesh.fe.solve`: projection of the slave nodes on
the master polyline, the linearised gaps, the zero-energy modes the equalities leave, and
the contact quadratic programme (the method of multipliers with non-negative least
squares, its active set polished and checked to round-off); see the module doc of
:mod:`cyclomesh.fe.solve` for the formulation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import LinAlgError, cholesky, qr, solve_triangular
from scipy.optimize import nnls

from cyclomesh.exceptions import ConvergenceError

__all__ = [
    "project",
    "nodal",
    "linearised_gaps",
    "free_modes",
    "grounding_dofs",
    "least_squares_factor",
    "contact_qp",
    "polish",
    "check_solution",
]

FloatArray = NDArray[np.float64]


def project(
    xs: FloatArray, xm: FloatArray, previous: NDArray | None = None, hold: float = 1e-3
) -> tuple[NDArray, FloatArray, FloatArray, FloatArray]:
    """Closest segment of the master polyline xm (2, K) to every slave point xs (2, n).

    With ``previous`` segments, a node keeps its segment while its foot stays within
    ``hold`` (of the segment length) of it: a node facing a master node would otherwise
    switch between the two segments there on round-off, and with them the normal.
    """
    a = xm[:, :-1]
    d = xm[:, 1:] - a
    ll = np.sum(d * d, axis=0)
    rel = xs[:, :, None] - a[:, None, :]
    t_free = np.einsum("inj,ij->nj", rel, d) / ll
    t = np.clip(t_free, 0.0, 1.0)
    foot = a[:, None, :] + t[None] * d[:, None, :]
    dist = np.hypot(*(xs[:, :, None] - foot))
    seg = np.argmin(dist, axis=1)
    n_idx = np.arange(xs.shape[1])
    if previous is not None:
        tp = t_free[n_idx, previous]
        keep = (tp >= -hold) & (tp <= 1.0 + hold)
        seg = np.where(keep, previous, seg)
    tt = t[n_idx, seg]
    dd = d[:, seg]
    normal = np.stack([dd[1], -dd[0]]) / np.sqrt(ll[seg])  # tangent turned clockwise
    gap = np.sum((xs - foot[:, n_idx, seg]) * normal, axis=0)
    return seg, tt, normal, gap


def nodal(u: FloatArray, offsets: NDArray, i: int, body: Any) -> FloatArray:
    ub = u[offsets[i] : offsets[i + 1]]
    return np.stack([ub[body.basis.nodal_dofs[0]], ub[body.basis.nodal_dofs[1]]])


def linearised_gaps(bodies, pairs, offsets, gdof, u, n_u, previous=None):
    """Node-to-segment gaps projected in the configuration ``u``, linearised about it.

    Returns (G, g0, geometry) with g(u') = g0 + G u' and geometry the (segment, t,
    normal) of each pair.
    """
    g_rows, g0, geom = [], [], []
    for k, p in enumerate(pairs):
        sb, mb = bodies[p.slave_body], bodies[p.master_body]
        us = nodal(u, offsets, p.slave_body, sb)
        um = nodal(u, offsets, p.master_body, mb)
        xs = sb.mesh.p[:, p.slave_nodes] + us[:, p.slave_nodes]
        xm = mb.mesh.p[:, p.master_nodes] + um[:, p.master_nodes]
        seg, t, normal, gap = project(xs, xm, None if previous is None else previous[k][0])
        n = p.slave_nodes.size
        r = np.repeat(np.arange(n), 6)
        m1, m2 = p.master_nodes[seg], p.master_nodes[seg + 1]
        cc = np.stack(
            [
                gdof(p.slave_body, sb.dof(p.slave_nodes, 0)),
                gdof(p.slave_body, sb.dof(p.slave_nodes, 1)),
                gdof(p.master_body, mb.dof(m1, 0)),
                gdof(p.master_body, mb.dof(m1, 1)),
                gdof(p.master_body, mb.dof(m2, 0)),
                gdof(p.master_body, mb.dof(m2, 1)),
            ],
            axis=1,
        ).ravel()
        vv = np.stack(
            [
                normal[0],
                normal[1],
                -(1 - t) * normal[0],
                -(1 - t) * normal[1],
                -t * normal[0],
                -t * normal[1],
            ],
            axis=1,
        ).ravel()
        g_pair = sp.csr_matrix((vv, (r, cc)), shape=(n, n_u))
        g_rows.append(g_pair)
        g0.append(gap - g_pair @ u)  # so that g(u') = g0 + G u'
        geom.append((seg, t, normal))
    return sp.vstack(g_rows, format="csr"), np.concatenate(g0), geom


def free_modes(bodies, offsets, c_mat, k_extra) -> FloatArray:
    """Zero-energy modes of the constrained structure (n_u, r), columns of unit max.

    They lie in the span of the bodies' rigid motions (two translations and the
    infinitesimal rotation of each) and the extra unknowns without stiffness; the modes
    are the combinations of these that satisfy the homogeneous equalities.
    """
    n_b = int(offsets[-1])
    n_u = n_b + k_extra.size
    cols = []
    for i, b in enumerate(bodies):
        x, y = b.mesh.p
        xc, yc = x.mean(), y.mean()
        dx = offsets[i] + b.basis.nodal_dofs[0]
        dy = offsets[i] + b.basis.nodal_dofs[1]
        for vx, vy in ((np.ones_like(x), 0 * x), (0 * x, np.ones_like(x)), (-(y - yc), x - xc)):
            z = np.zeros(n_u)
            z[dx], z[dy] = vx, vy
            cols.append(z / np.abs(z).max())
    for j in np.flatnonzero(k_extra == 0):
        z = np.zeros(n_u)
        z[n_b + j] = 1.0
        cols.append(z)
    z_mat = np.stack(cols, axis=1)
    if c_mat.shape[0] == 0:
        null = np.eye(z_mat.shape[1])
    else:
        cz = np.asarray(c_mat @ z_mat)
        _, sv, vt = np.linalg.svd(cz)
        sv = np.concatenate([sv, np.zeros(vt.shape[0] - sv.size)])
        null = vt[sv <= 1e-9 * max(sv.max(), 1e-300)].T
    modes = z_mat @ null
    if modes.shape[1]:
        modes /= np.abs(modes).max(axis=0)
    return modes


def grounding_dofs(modes: FloatArray) -> NDArray:
    """Dofs at which the modes are independent (pivoted QR), one per mode."""
    if modes.shape[1] == 0:
        return np.zeros(0, int)
    _, piv = qr(modes.T, mode="r", pivoting=True)
    return np.sort(piv[: modes.shape[1]])


def least_squares_factor(m: FloatArray):
    """F with FᵀF = m and the map p ↦ d with Fᵀd = −p (so ½λᵀmλ + pᵀλ = ½‖Fλ − d‖² + c)."""
    try:
        low = cholesky(m, lower=True)
        return low.T, lambda p: -solve_triangular(low, p, lower=True)
    except LinAlgError:  # semi-definite up to round-off: drop the null directions
        eig, vec = np.linalg.eigh(m)
        keep = eig > 1e-13 * eig.max()
        root = np.sqrt(eig[keep])
        return root[:, None] * vec[:, keep].T, lambda p: -(vec[:, keep].T @ p) / root


def contact_qp(w, q, h, c, amp0, max_iter: int = 200):
    """Solve min ½λᵀWλ + qᵀλ subject to λ ≥ 0, Hᵀλ = c (W symmetric positive definite).

    The KKT conditions are the contact conditions g = Wλ + q + Ha ≥ 0, λ ≥ 0, λ·g = 0
    with the amplitudes a of the free modes and their equilibrium Hᵀλ = c. The
    multipliers a are found by the augmented-Lagrangian (method of multipliers) update,
    each subproblem min over λ ≥ 0 a strictly convex QP solved exactly and finitely by
    non-negative least squares (Lawson–Hanson, no cycling); after each, the KKT system of
    its active set is solved exactly and accepted when it satisfies every condition to
    round-off. Returns (λ, a, subproblems).
    """
    n, r = q.size, h.shape[1]
    s = float(np.mean(np.diag(w)))
    ws, qs, hs, cs = w / s, q / s, h / s, np.asarray(c, float) / s
    h_norm = float(np.linalg.norm(hs, 2)) if r else 0.0
    rho = 1e3 / h_norm**2 if h_norm > 0 else 0.0  # ρ‖H‖² ≫ diag W: fast multipliers
    f_mat, rhs = least_squares_factor(ws + rho * (hs @ hs.T))
    a = np.asarray(amp0, float).copy()
    lam = np.zeros(n)
    for k in range(1, max_iter + 1):
        lam, _ = nnls(f_mat, rhs(qs + hs @ a - rho * (hs @ cs)), maxiter=50 * n)
        ok, lam_p, a_p = polish(ws, qs, hs, cs, lam > 0)
        if ok:
            return lam_p, a_p, k
        if r == 0:
            break
        a = a + rho * (hs.T @ lam - cs)
    if r == 0:  # NNLS is exact for this problem; its solution stands if it satisfies KKT
        g = ws @ lam + qs
        tol = 1e-7 * max(float(np.abs(ws @ lam).max()), 1e-300)
        if g.min() >= -tol and np.abs(g[lam > 0]).max(initial=0.0) <= tol:
            return lam, a, 1
    raise ConvergenceError(
        "FE contact: the condensed contact problem did not converge (no equilibrium with "
        "compressive contact forces: a load pulls a body away?)"
    )


def polish(ws, qs, hs, c, act):
    """Solve the KKT system of the active set exactly; (ok, λ, a)."""
    idx = np.flatnonzero(act)
    n_a, r = idx.size, hs.shape[1]
    if n_a == 0:
        return False, None, None
    kkt = np.zeros((n_a + r, n_a + r))
    kkt[:n_a, :n_a] = ws[np.ix_(idx, idx)]
    kkt[:n_a, n_a:] = hs[idx]
    kkt[n_a:, :n_a] = hs[idx].T
    try:
        x = np.linalg.solve(kkt, np.concatenate([-qs[idx], c]))
    except LinAlgError:
        return False, None, None
    lam = np.zeros(qs.size)
    lam[idx] = x[:n_a]
    a = x[n_a:]
    closure = np.abs(ws @ lam)
    if r:
        closure = np.maximum(closure, np.abs(hs @ a))
    g = ws @ lam + qs + hs @ a
    lam_tol = 1e-9 * max(float(np.abs(lam).max()), 1e-300)
    gap_tol = 1e-9 * max(float(closure.max()), 1e-300)
    ok = lam[idx].min() >= -lam_tol and (act.all() or g[~act].min() >= -gap_tol)
    return ok, np.maximum(lam, 0.0), a


def check_solution(lam, gap, closure, h, modal_force) -> None:
    """Verify the final solution: no penetration, compression only, modal equilibrium."""
    act = lam > 0
    tol = 1e-8 * closure
    if lam.min() < 0 or (~act).any() and gap[~act].min() < -tol:
        raise ConvergenceError(
            f"FE contact: the solution penetrates by {-gap[~act].min() / closure:.2g} "
            "of the closure"
        )
    if act.any() and np.abs(gap[act]).max() > tol:
        raise ConvergenceError("FE contact: closed gaps are not closed (ill-conditioned)")
    if h.shape[1]:
        resid = np.abs(h.T @ lam + modal_force)
        ref = np.abs(h).T @ lam + np.abs(modal_force)
        if np.any(resid > 1e-8 * ref):
            raise ConvergenceError(
                f"FE contact: free modes not in equilibrium ({(resid / ref).max():.2g})"
            )
