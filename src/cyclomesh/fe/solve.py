"""Plane-strain elastic bodies in frictionless unilateral contact, with scikit-fem.

Small deformation, linear elasticity, linear triangles (scikit-fem's ``ElementTriP1``
in ``ElementVector``), per unit thickness: forces are in N/m, pressures in Pa.

Contact is node-to-segment: every slave node (on the pin) is projected, in the
undeformed configuration, onto the nearest segment of the master boundary (the other
body), giving one linearised gap per slave node

    g_i(u) = g0_i + n_i·(u_s − (1 − t_i)·u_m1 − t_i·u_m2) ≥ 0,   λ_i ≥ 0,   λ_i·g_i = 0,

λ_i the contact force on the slave node [N/m]. Equalities (supports, symmetry, ties to
a rigid centre) are Lagrange multipliers too.

The problem is condensed on the contact forces. The zero-energy modes R that the
equalities leave (a floating body pressed by a load, a rigid centre free to rotate under
a torque) are found from the bodies' rigid motions (``free_modes``) and grounded at one
dof each; with A the grounded system, u = A⁻¹(f + Gᵀλ) + R·a and the gaps are

    g = q + Wλ + Ha,   W = G A⁻¹ Gᵀ (symmetric positive definite),   H = G R,

with the modes' equilibrium Hᵀλ = −Rᵀf (for a rigid centre: the torque balance). The
contact conditions are then the KKT conditions of the convex quadratic programme
min ½λᵀWλ + qᵀλ subject to λ ≥ 0, Hᵀλ = −Rᵀf, solved by the method of multipliers on a
with every subproblem solved exactly and finitely by non-negative least squares
(Lawson–Hanson on a Cholesky factor of W + ρHHᵀ: no cycling), and the KKT system of
its active set solved exactly and accepted when it satisfies every condition to
round-off (``contact_qp``). The projection is then recomputed in the deformed
configuration and the programme solved again until no force and no gap changes by more
than a tolerance (a geometrically consistent small-sliding contact). The final solution
is checked: no penetration and closed gaps closed to 1e-8 of the closure, compressive
forces, the modes in equilibrium to 1e-8; otherwise :class:`ConvergenceError`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu
from skfem import Basis, ElementTriP1, ElementVector, MeshTri, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

from cyclomesh.exceptions import ConvergenceError
from cyclomesh.fe.contact_qp import (
    check_solution,
    contact_qp,
    free_modes,
    grounding_dofs,
    linearised_gaps,
    nodal,
)

__all__ = ["Body", "ContactPair", "Solution", "solve_contact", "boundary_chain"]

FloatArray = NDArray[np.float64]


@dataclass
class Body:
    """One elastic body: a mesh and a material (plane strain).

    Attributes
    ----------
    points : ndarray
        Node coordinates (2, N) [m].
    triangles : ndarray
        Node indices (3, M).
    youngs_modulus : float
        E [Pa].
    poisson_ratio : float
        ν [-].
    """

    points: FloatArray
    triangles: NDArray
    youngs_modulus: float
    poisson_ratio: float
    mesh: MeshTri = field(init=False, repr=False)
    basis: Basis = field(init=False, repr=False)
    _stiffness: sp.csr_matrix | None = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        self.mesh = MeshTri(np.asarray(self.points, float), np.asarray(self.triangles))
        self.basis = Basis(self.mesh, ElementVector(ElementTriP1()))

    @property
    def n_nodes(self) -> int:
        return self.mesh.p.shape[1]

    def stiffness(self) -> sp.csr_matrix:
        """Plane-strain stiffness per unit thickness [N/m²]; dofs interleaved (x0, y0, x1, ...)."""
        if self._stiffness is None:
            lam, mu = lame_parameters(self.youngs_modulus, self.poisson_ratio)
            self._stiffness = asm(linear_elasticity(lam, mu), self.basis).tocsr()
        return self._stiffness

    def dof(self, node: ArrayLike2, component: int) -> NDArray:
        """Global-in-body dof index of ``component`` (0 = x, 1 = y) of nodes."""
        return self.basis.nodal_dofs[component][np.asarray(node)]

    def nearest_node(self, xy: tuple[float, float]) -> int:
        d = np.hypot(self.mesh.p[0] - xy[0], self.mesh.p[1] - xy[1])
        return int(np.argmin(d))


ArrayLike2 = NDArray | int


def boundary_chain(
    body: Body,
    center: tuple[float, float],
    radius: float,
    where: Callable[[FloatArray], NDArray] | None = None,
) -> NDArray:
    """Boundary nodes of ``body`` within ``radius`` of ``center``, ordered along the boundary.

    Boundary facets whose midpoints lie within ``radius`` of ``center`` (and satisfy
    ``where(midpoints)``, e.g. off a symmetry axis) are chained with the body on their
    left; the chain through the facet nearest to ``center`` is returned (node indices).
    """
    m = body.mesh
    bf = m.boundary_facets()
    facets = m.facets[:, bf]
    mid = m.p[:, facets].mean(axis=1)
    near = np.hypot(mid[0] - center[0], mid[1] - center[1]) <= radius
    if where is not None:
        near &= np.asarray(where(mid), bool)
    if not near.any():
        raise ValueError("no boundary within the contact search radius")
    segs, tris = facets[:, near], m.f2t[0, bf[near]]
    c = m.p[:, m.t[:, tris]].mean(axis=1)
    pa, pb = m.p[:, segs[0]], m.p[:, segs[1]]
    cross = (pb[0] - pa[0]) * (c[1] - pa[1]) - (pb[1] - pa[1]) * (c[0] - pa[0])
    a = np.where(cross > 0, segs[0], segs[1])
    b = np.where(cross > 0, segs[1], segs[0])
    nxt = dict(zip(a.tolist(), b.tolist(), strict=True))
    prv = dict(zip(b.tolist(), a.tolist(), strict=True))
    dist = np.hypot(mid[0, near] - center[0], mid[1, near] - center[1])
    node = int(a[np.argmin(dist)])
    first = node
    while node in prv and prv[node] != first:
        node = prv[node]
    chain = [node]
    while chain[-1] in nxt and nxt[chain[-1]] != chain[0]:
        chain.append(nxt[chain[-1]])
    return np.asarray(chain)


@dataclass
class ContactPair:
    """A slave chain of nodes on one body against a master chain on another.

    Attributes
    ----------
    slave_body, master_body : int
        Indices of the bodies in the list given to :func:`solve_contact`.
    slave_nodes : ndarray
        Slave node indices (in the slave body), ordered along its boundary.
    master_nodes : ndarray
        Master node indices, ordered along the master boundary with the body on the
        left (so the outward normal of segment (m1, m2) is the tangent turned clockwise).
    """

    slave_body: int
    master_body: int
    slave_nodes: NDArray
    master_nodes: NDArray


@dataclass
class Solution:
    """Result of :func:`solve_contact`.

    Attributes
    ----------
    displacements : list of ndarray
        Per body, nodal displacements (2, N) [m].
    extra : ndarray
        Values of the extra (rigid-body) unknowns.
    contact_force : list of ndarray
        Per pair, λ at each slave node [N/m] (0 where open).
    gap : list of ndarray
        Per pair, the gap at each slave node [m] (0 where closed).
    normal : list of ndarray
        Per pair, the master normal (2, n) at each slave node.
    master_point : list of tuple
        Per pair, (segment index, t) of each slave node's projection.
    reactions : ndarray
        Lagrange multipliers of the equality constraints.
    iterations : int
        Non-negative least-squares subproblems solved, in total.
    active : list of ndarray
        Per pair, the closed nodes (bool per slave node).
    projections : int
        Projections of the gaps (the last one unchanged within the tolerance).
    """

    displacements: list[FloatArray]
    extra: FloatArray
    contact_force: list[FloatArray]
    gap: list[FloatArray]
    normal: list[FloatArray]
    master_point: list[tuple[NDArray, FloatArray]]
    reactions: FloatArray
    iterations: int
    active: list[NDArray]
    projections: int = 1


def solve_contact(
    bodies: list[Body],
    pairs: list[ContactPair],
    equalities: list[tuple[list[tuple[int, NDArray, float]], float]] = (),
    forces: list[tuple[int, NDArray, float]] = (),
    n_extra: int = 0,
    extra_forces: FloatArray | None = None,
    extra_stiffness: FloatArray | None = None,
    stiffness_update: Callable[[list[FloatArray]], FloatArray] | None = None,
    max_projection: int = 50,
    projection_tolerance: float = 1e-7,
) -> Solution:
    """Solve frictionless contact of plane-strain elastic bodies (see the module docstring).

    Parameters
    ----------
    bodies : list of Body
    pairs : list of ContactPair
    equalities : list
        Linear constraints Σ coeff·u[dof] = value, each given as
        ``([(body, dof, coeff), ...], value)``; ``body = -1`` addresses the extra
        unknowns (e.g. the rotation of a rigid centre) [m, rad].
    forces : list of (body, dof, value)
        Nodal forces [N/m] on body dofs.
    n_extra : int
        Number of extra unknowns.
    extra_forces : ndarray, optional
        Generalised forces on the extra unknowns (e.g. a torque per unit thickness [N]).
    extra_stiffness : ndarray, optional
        Stiffness of each extra unknown to ground (e.g. a support spring) [N/m²]; an extra
        unknown without stiffness is free (held by the constraints or the contacts).
    stiffness_update : callable, optional
        ``stiffness_update(contact_force) -> extra_stiffness``: new stiffness of the
        extra unknowns from the contact forces of each pair (e.g. a secant stiffness
        that depends on the load), updated with the projections until both settle; only
        the extra unknowns with a stiffness > 0 in ``extra_stiffness`` may change.
    max_projection : int
        Re-projections of the node-to-segment gaps (and stiffness updates) at most.
    projection_tolerance : float
        The re-projection stops when no contact force changes by more than this
        fraction of the largest, and no gap by more than this fraction of the closure.

    Raises
    ------
    ConvergenceError
        If the contact problem has no solution (a load pulls a floating body away), the
        condensed programme does not converge, or the projections do not settle.
    """
    sizes = [2 * b.n_nodes for b in bodies]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    n_b = int(offsets[-1])
    n_u = n_b + n_extra
    blocks = [b.stiffness() for b in bodies]
    k_extra = np.zeros(n_extra) if extra_stiffness is None else np.asarray(extra_stiffness, float)
    if n_extra:
        blocks.append(sp.diags(k_extra, format="csr"))
    k_mat = sp.block_diag(blocks, format="csr")
    f = np.zeros(n_u)
    for body, dof, value in forces:
        f[offsets[body] + np.asarray(dof)] += value
    if extra_forces is not None:
        f[n_b:] += extra_forces

    def gdof(body: int, dof: NDArray | int) -> NDArray:
        return (n_b if body == -1 else offsets[body]) + np.asarray(dof)

    rows, cols, vals, rhs_c = [], [], [], []
    for r, (terms, value) in enumerate(equalities):
        for body, dof, coeff in terms:
            dofs = np.atleast_1d(gdof(body, dof))
            rows.extend([r] * dofs.size)
            cols.extend(dofs.tolist())
            vals.extend(np.broadcast_to(coeff, dofs.shape).tolist())
        rhs_c.append(value)
    n_c = len(rhs_c)
    c_mat = sp.csr_matrix((vals, (rows, cols)), shape=(n_c, n_u))
    rhs_c = np.asarray(rhs_c, float)

    # zero-energy modes left by the constraints (floating bodies, free rigid centres):
    # grounded at a few dofs for the factorisation, their amplitudes solved for exactly
    modes = free_modes(bodies, offsets, c_mat, k_extra)
    grounded = grounding_dofs(modes)
    e_mat = sp.csr_matrix(
        (np.ones(grounded.size), (np.arange(grounded.size), grounded)), shape=(grounded.size, n_u)
    )
    # constraint rows scaled to the stiffness (else the saddle-point system is badly
    # scaled, E against 1, and its solution loses digits); multipliers scaled back below
    diag = np.abs(k_mat.diagonal())
    alpha = float(diag[diag > 0].mean()) if (diag > 0).any() else 1.0
    a_mat = sp.bmat(
        [
            [k_mat, -alpha * c_mat.T, -alpha * e_mat.T],
            [-alpha * c_mat, None, None],
            [-alpha * e_mat, None, None],
        ],
        format="csc",
    )
    # the grounded system falls apart into independent blocks (bodies that touch only
    # through the contacts): factorised and solved block by block
    n_blocks, label = connected_components(a_mat, directed=False)
    parts = []
    for i in range(n_blocks):
        idx = np.flatnonzero(label == i)
        try:
            parts.append((idx, splu(a_mat[idx][:, idx].tocsc(), permc_spec="COLAMD")))
        except RuntimeError as exc:
            raise ConvergenceError(f"FE contact: singular system ({exc})") from None

    def solve(rhs_u: FloatArray, rhs_cons: FloatArray | None = None) -> FloatArray:
        rhs = np.zeros((a_mat.shape[0],) + rhs_u.shape[1:])
        rhs[:n_u] = rhs_u
        if rhs_cons is not None:
            rhs[n_u : n_u + n_c] = alpha * rhs_cons
        x = np.zeros_like(rhs)
        for idx, lu in parts:
            r = rhs[idx]
            if r.ndim == 2:  # only the columns loaded in this block
                cols = np.flatnonzero(np.any(r != 0, axis=0))
                if cols.size:
                    x[np.ix_(idx, cols)] = lu.solve(np.asfortranarray(r[:, cols]))
            elif np.any(r != 0):
                x[idx] = lu.solve(r)
        if not np.all(np.isfinite(x)):
            raise ConvergenceError("FE contact: singular system; a body is unsupported")
        return x

    x0 = solve(f, -rhs_c)
    u0 = x0[:n_u]
    modal_force = modes.T @ f  # the contact forces must balance it: Hᵀλ = −Rᵀf

    # compliance of the grounded system on the contact dofs D and the spring dofs S
    # (whose stiffness the update may change: a low-rank, Woodbury, correction)
    contact_dofs = np.unique(
        np.concatenate(
            [
                np.concatenate(
                    [
                        gdof(p.slave_body, bodies[p.slave_body].dof(p.slave_nodes, c)),
                        gdof(p.master_body, bodies[p.master_body].dof(p.master_nodes, c)),
                    ]
                )
                for p in pairs
                for c in (0, 1)
            ]
        )
    )
    springs = n_b + np.flatnonzero(k_extra > 0) if stiffness_update else np.zeros(0, int)
    dofs = np.concatenate([contact_dofs, springs])
    n_d = contact_dofs.size
    phi = np.empty((dofs.size, dofs.size))
    spring_cols = np.empty((n_u, springs.size))
    for start in range(0, dofs.size, 128):
        block = dofs[start : start + 128]
        rhs = np.zeros((n_u, block.size))
        rhs[block, np.arange(block.size)] = 1.0
        x = solve(rhs)[:n_u]
        phi[:, start : start + block.size] = x[dofs]
        inside = (start + np.arange(block.size)) >= n_d
        spring_cols[:, start + np.flatnonzero(inside) - n_d] = x[:, inside]
    phi = 0.5 * (phi + phi.T)
    modes_d = modes[dofs]

    u = u0.copy()
    lam = lam_relaxed = res_prev = None
    omega = 1.0
    k_now = k_extra[springs - n_b]
    amp = np.zeros(modes.shape[1])
    total_iter = 0
    projection = 0
    geom = None
    change = np.inf
    while projection < max_projection:
        projection += 1
        # the compliance and the load response with the current spring stiffness
        delta = k_now - k_extra[springs - n_b]
        if springs.size and np.any(delta != 0):
            corr = np.linalg.solve(
                np.eye(springs.size) + phi[n_d:, n_d:] * delta[None, :],
                np.concatenate([phi[n_d:, :], u0[springs][:, None]], axis=1),
            )
            comp = phi - (phi[:, n_d:] * delta[None, :]) @ corr[:, :-1]
            load_resp = u0[dofs] - (phi[:, n_d:] * delta[None, :]) @ corr[:, -1]
        else:
            comp, load_resp, corr = phi, u0[dofs], None
        g_mat, g_const, geom = linearised_gaps(bodies, pairs, offsets, gdof, u, n_u, geom)
        g_d = g_mat[:, contact_dofs].toarray()
        gc = g_d @ comp[:n_d]  # (n_s, |dofs|): response at the dofs to unit contact force
        w = 0.5 * ((gc[:, :n_d] @ g_d.T) + (gc[:, :n_d] @ g_d.T).T)
        q = g_const + g_d @ load_resp[:n_d]
        h = g_d @ modes[contact_dofs]
        new_lam, amp, iters = contact_qp(w, q, h, -modal_force, amp)
        total_iter += iters
        u_new = u.copy()
        u_new[dofs] = load_resp + gc.T @ new_lam + modes_d @ amp
        gap_now = g_const + g_mat @ u_new
        closure = max(float(np.abs(g_mat @ u_new).max()), 1e-300)
        scale = max(float(new_lam.max()), 1e-300)
        if lam is not None:
            change = max(
                float(np.abs(new_lam - lam).max()) / scale,
                float(np.abs(g_mat @ (u_new - u)).max()) / closure,
            )
        # the next configuration, relaxed (Aitken's Δ²: the iteration oscillates where a
        # conforming contact, near an inflection point, is sensitive to its normal)
        res = u_new[dofs] - u[dofs]
        if res_prev is not None:
            d_res = res - res_prev
            den = float(d_res @ d_res)
            if den > 0:
                omega = float(np.clip(-omega * float(res_prev @ d_res) / den, 0.05, 1.0))
        res_prev = res
        lam_relaxed = new_lam if lam is None else lam_relaxed + omega * (new_lam - lam_relaxed)
        lam = new_lam
        u = u.copy()
        u[dofs] += omega * res
        k_prev = k_now
        if stiffness_update is not None and springs.size:
            counts = np.cumsum([p.slave_nodes.size for p in pairs])[:-1]
            k_now = np.asarray(stiffness_update(np.split(lam_relaxed, counts)), float)
            k_now = k_now[springs - n_b]
            change = max(change, float(np.abs(k_now / k_prev - 1).max()))
        if change <= projection_tolerance:
            k_now = k_prev  # the solution is that of the stiffness it was solved with
            break
    if change > projection_tolerance:
        raise ConvergenceError(
            f"FE contact: projections did not settle in {max_projection} steps "
            f"(last change {change:.2g})"
        )
    check_solution(lam, gap_now, closure, h, modal_force)
    # the whole displacement field, with the stiffness of the last solution
    x = solve(f + g_mat.T @ lam, -rhs_c)
    if corr is not None:
        delta = k_now - k_extra[springs - n_b]
        m_mat = np.eye(springs.size) + phi[n_d:, n_d:] * delta[None, :]
        x[:n_u] -= spring_cols @ (delta * np.linalg.solve(m_mat, x[springs]))
    x[:n_u] += modes @ amp
    u = x[:n_u]
    act = lam > 0
    counts = [p.slave_nodes.size for p in pairs]
    split = np.cumsum(counts)[:-1]
    return Solution(
        displacements=[nodal(u, offsets, i, b) for i, b in enumerate(bodies)],
        extra=u[n_b:].copy(),
        contact_force=np.split(lam, split),
        gap=np.split(np.where(act, 0.0, gap_now), split),
        normal=[g[2] for g in geom],
        master_point=[(g[0], g[1]) for g in geom],
        reactions=alpha * x[n_u : n_u + n_c],
        iterations=total_iter,
        active=np.split(act, split),
        projections=projection,
    )


@dataclass(frozen=True)
class ContactSummary:
    """Resultant of the contact forces on a slave chain (per unit thickness).

    Attributes
    ----------
    load : float
        Σλ [N/m].
    centre : ndarray
        Load-weighted centre of the contact (2,) [m].
    half_width : float
        b = 2·sqrt(Σ s²λ / Σ λ), s the arc length from the centre [m] (exact for a
        Hertzian distribution, whose ∫s²p ds / ∫p ds is b²/4).
    peak_pressure : float
        Peak of a least-squares parabola through the nodal pressures within b/2 of the
        centre [Pa]: a local recovery that averages out the node-to-segment oscillation;
        NaN when fewer than three closed nodes lie within b/2 (a light touch the mesh
        cannot resolve; :func:`cyclomesh.fe.disc.solve_disc_fe` then reports the Hertz
        pressure of the FE load instead, and says so).
    pressure : ndarray
        Nodal pressures λ_i / (tributary length) [Pa].
    arc : ndarray
        s at each node [m].
    """

    load: float
    centre: FloatArray
    half_width: float
    peak_pressure: float
    pressure: FloatArray
    arc: FloatArray


def summarize_contact(points: FloatArray, force: FloatArray) -> ContactSummary:
    """Load, centre, half-width and peak pressure of nodal contact forces on a chain.

    Parameters
    ----------
    points : ndarray
        Slave node coordinates (2, n), ordered along the boundary [m].
    force : ndarray
        Contact forces λ_i at the nodes [N/m].
    """
    seg = np.hypot(*np.diff(points, axis=1))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    trib = np.zeros(s.size)
    trib[:-1] += seg / 2
    trib[1:] += seg / 2
    load = float(force.sum())
    if load <= 0:
        return ContactSummary(0.0, points[:, 0] * np.nan, 0.0, 0.0, force * 0, s)
    s_c = float(np.sum(s * force) / load)
    arc = s - s_c
    b = float(2.0 * np.sqrt(np.sum(arc**2 * force) / load))
    p = force / trib
    near = np.abs(arc) <= 0.5 * b
    if (force > 0).sum() < 3 or (near & (force > 0)).sum() < 3:
        peak = np.nan  # a light touch on one or two elements: the mesh does not resolve it
    else:
        c2, c1, c0 = np.polyfit(arc[near], p[near], 2)
        peak = float(c0 - c1**2 / (4 * c2)) if c2 < 0 else float(p[near].max())
    k = int(np.searchsorted(s, s_c).clip(1, s.size - 1))
    w = (s_c - s[k - 1]) / (s[k] - s[k - 1])
    centre = (1 - w) * points[:, k - 1] + w * points[:, k]
    return ContactSummary(load, centre, b, peak, p, arc)
