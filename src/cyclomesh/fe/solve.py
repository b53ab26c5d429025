"""Plane-strain elastic bodies in frictionless unilateral contact, with scikit-fem.

Small deformation, linear elasticity, linear triangles (scikit-fem's ``ElementTriP1``
in ``ElementVector``), per unit thickness: forces are in N/m, pressures in Pa.

Contact is node-to-segment: every slave node (on the pin) is projected, in the
undeformed configuration, onto the nearest segment of the master boundary (the other
body), giving one linearised gap per slave node

    g_i(u) = g0_i + n_i·(u_s − (1 − t_i)·u_m1 − t_i·u_m2) ≥ 0,   λ_i ≥ 0,   λ_i·g_i = 0,

λ_i the contact force on the slave node [N/m]. Equalities (supports, symmetry, ties to
a rigid centre) are Lagrange multipliers too. The complementarity problem is solved
exactly by the primal–dual active-set method, started from the active set of the problem
condensed on the contact forces (a non-negative least-squares problem, see
``_schur_start``) (a semismooth Newton method): the KKT
system of the current active set is solved, nodes with a tensile multiplier leave the
set and nodes with a negative gap join it, until the set no longer changes; it then
satisfies every condition to round-off. The projection is recomputed in the deformed
configuration and the problem solved again until the active set and the projections
settle (a geometrically consistent small-sliding contact).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.optimize import nnls
from scipy.sparse.linalg import splu
from skfem import Basis, ElementTriP1, ElementVector, MeshTri, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

from cyclomesh.exceptions import ConvergenceError

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

    def __post_init__(self) -> None:
        self.mesh = MeshTri(np.asarray(self.points, float), np.asarray(self.triangles))
        self.basis = Basis(self.mesh, ElementVector(ElementTriP1()))

    @property
    def n_nodes(self) -> int:
        return self.mesh.p.shape[1]

    def stiffness(self) -> sp.csr_matrix:
        """Plane-strain stiffness per unit thickness [N/m²]; dofs interleaved (x0, y0, x1, ...)."""
        lam, mu = lame_parameters(self.youngs_modulus, self.poisson_ratio)
        return asm(linear_elasticity(lam, mu), self.basis).tocsr()

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
        Active-set iterations in total.
    active : list of ndarray
        Per pair, the final active set (bool per slave node).
    regularised : int
        Times the exact active-set method cycled and the regularised condensed solution
        was taken instead (accepted if no open node penetrates by more than 1e-3 of the
        largest closure).
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
    regularised: int = 0


def _project(xs: FloatArray, xm: FloatArray) -> tuple[NDArray, FloatArray, FloatArray, FloatArray]:
    """Closest segment of the master polyline xm (2, K) to every slave point xs (2, n)."""
    a = xm[:, :-1]
    d = xm[:, 1:] - a
    ll = np.sum(d * d, axis=0)
    rel = xs[:, :, None] - a[:, None, :]
    t = np.clip(np.einsum("inj,ij->nj", rel, d) / ll, 0.0, 1.0)
    foot = a[:, None, :] + t[None] * d[:, None, :]
    dist = np.hypot(*(xs[:, :, None] - foot))
    seg = np.argmin(dist, axis=1)
    n_idx = np.arange(xs.shape[1])
    tt = t[n_idx, seg]
    dd = d[:, seg]
    normal = np.stack([dd[1], -dd[0]]) / np.sqrt(ll[seg])  # tangent turned clockwise
    gap = np.sum((xs - foot[:, n_idx, seg]) * normal, axis=0)
    return seg, tt, normal, gap


def solve_contact(
    bodies: list[Body],
    pairs: list[ContactPair],
    equalities: list[tuple[list[tuple[int, NDArray, float]], float]] = (),
    forces: list[tuple[int, NDArray, float]] = (),
    n_extra: int = 0,
    extra_forces: FloatArray | None = None,
    extra_stiffness: FloatArray | None = None,
    max_active_set: int = 30,
    max_projection: int = 10,
    initial_active: list[NDArray] | None = None,
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
        Number of extra unknowns (no stiffness of their own).
    extra_forces : ndarray, optional
        Generalised forces on the extra unknowns (e.g. a torque per unit thickness [N]).
    extra_stiffness : ndarray, optional
        Stiffness of each extra unknown to ground (e.g. a support spring) [N/m²].
    initial_active : list of ndarray, optional
        Starting active set per pair (e.g. ``Solution.active`` of a similar problem);
        otherwise from the condensed problem.

    Raises
    ------
    ConvergenceError
        If the active set or the projections do not settle.
    """
    sizes = [2 * b.n_nodes for b in bodies]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    n_u = int(offsets[-1]) + n_extra
    blocks = [b.stiffness() for b in bodies]
    if n_extra:
        diag = np.zeros(n_extra) if extra_stiffness is None else np.asarray(extra_stiffness)
        blocks.append(sp.diags(diag, format="csr"))
    k_mat = sp.block_diag(blocks, format="csr")
    f = np.zeros(n_u)
    for body, dof, value in forces:
        f[offsets[body] + np.asarray(dof)] += value
    if extra_forces is not None:
        f[offsets[-1] :] += extra_forces

    def gdof(body: int, dof: NDArray | int) -> NDArray:
        return (offsets[-1] if body == -1 else offsets[body]) + np.asarray(dof)

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

    u = np.zeros(n_u)
    active = list(initial_active) if initial_active is not None else [None] * len(pairs)
    total_iter = 0
    warm = initial_active is not None
    fallbacks = 0
    for _ in range(max_projection):
        g_rows, g0 = [], []
        geom = []
        for p in pairs:
            sb, mb = bodies[p.slave_body], bodies[p.master_body]
            us = _nodal(u, offsets, p.slave_body, sb)
            um = _nodal(u, offsets, p.master_body, mb)
            xs = sb.mesh.p[:, p.slave_nodes] + us[:, p.slave_nodes]
            xm = mb.mesh.p[:, p.master_nodes] + um[:, p.master_nodes]
            seg, t, normal, gap = _project(xs, xm)
            # linearised about the current configuration: g = gap + n·(Δu_s − Δu_m)
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
            g0.append(gap - g_pair @ u)  # so that g(u) = g0 + G u
            geom.append((seg, t, normal))
        g_mat = sp.vstack(g_rows, format="csr")
        g_const = np.concatenate(g0)
        counts = [p.slave_nodes.size for p in pairs]
        if all(a is not None for a in active):
            act = np.concatenate(active)
        else:
            act = _schur_start(k_mat, f, c_mat, rhs_c, g_mat, g_const)
        seen: list[NDArray] = []
        for _ in range(max_active_set):
            total_iter += 1
            u, lam_a, mu = _kkt(k_mat, f, c_mat, rhs_c, g_mat, g_const, act)
            lam = np.zeros(act.size)
            lam[act] = lam_a
            gap_now = g_const + g_mat @ u
            # round-off levels of force and gap (the closure scale is |G u|)
            lam_tol = 1e-10 * max(np.abs(lam).max(), 1e-300)
            gap_tol = 1e-10 * max(np.abs(g_mat @ u).max(), 1e-300)
            new = np.where(act, lam > -lam_tol, gap_now < -gap_tol)
            if np.array_equal(new, act):
                break
            if any(np.array_equal(new, old) for old in seen):  # cycling between sets that
                # differ only by nodes at round-off: accept if no condition is violated
                if lam[act].min() > -1e3 * lam_tol and (
                    act.all() or gap_now[~act].min() > -1e3 * gap_tol
                ):
                    break
            seen.append(act)
            act = new
            if not act.any():
                raise ConvergenceError("FE contact: every contact opened (load pulls apart)")
        else:
            # the exact method cycles between sets that differ at round-off level on
            # ill-conditioned models: take the solution of the condensed, regularised
            # (1e-9 of the diagonal) problem, exact for that problem, and check it
            act, lam, u = _schur_start(k_mat, f, c_mat, rhs_c, g_mat, g_const, True)
            gap_now = g_const + g_mat @ u
            closure = max(np.abs(g_mat @ u).max(), 1e-300)
            worst = -gap_now[~act].min() / closure if (~act).any() else 0.0
            if worst > 1e-3:
                raise ConvergenceError(
                    f"FE contact: active set did not settle in {max_active_set} steps "
                    f"(regularised solution penetrates by {worst:.2g} of the closure)"
                )
            mu = np.zeros(c_mat.shape[0])
            fallbacks += 1
        split = np.cumsum(counts)[:-1]
        new_active = np.split(act, split)
        settled = not warm and all(
            a is not None and np.array_equal(a, b) for a, b in zip(active, new_active, strict=True)
        )
        warm = False
        active = new_active
        if settled:
            break
    else:
        raise ConvergenceError("FE contact: projections did not settle")
    lam_full = lam
    gaps = np.where(act, 0.0, gap_now)
    return Solution(
        displacements=[_nodal(u, offsets, i, b) for i, b in enumerate(bodies)],
        extra=u[offsets[-1] :].copy(),
        contact_force=np.split(lam_full, np.cumsum(counts)[:-1]),
        gap=np.split(gaps, np.cumsum(counts)[:-1]),
        normal=[g[2] for g in geom],
        master_point=[(g[0], g[1]) for g in geom],
        reactions=mu,
        iterations=total_iter,
        active=active,
        regularised=fallbacks,
    )


def _nodal(u: FloatArray, offsets: NDArray, i: int, body: Body) -> FloatArray:
    ub = u[offsets[i] : offsets[i + 1]]
    return np.stack([ub[body.basis.nodal_dofs[0]], ub[body.basis.nodal_dofs[1]]])


def _schur_start(k_mat, f, c_mat, rhs_c, g_mat, g_const, return_solution=False):
    """Starting active set from the contact problem condensed on the contact forces.

    With the stiffness regularised by 1e-9 of its diagonal (so floating bodies and free
    rigid centres are held), the contact problem is the convex quadratic programme
    min ½λᵀWλ + qᵀλ, λ ≥ 0, W = G A⁻¹ Gᵀ, solved by non-negative least squares
    (Lawson–Hanson: finite, no cycling). The exact active-set method then starts from its
    active set and only corrects the effect of the regularisation.
    """
    diag = k_mat.diagonal()
    scale = diag.max()
    reg = np.where(diag > 0, 1e-9 * diag, 1e-9 * scale)
    k_reg = (k_mat + sp.diags(reg)).tocsc()
    n_u, n_c = k_mat.shape[0], c_mat.shape[0]
    a_mat = sp.bmat([[k_reg, -c_mat.T], [-c_mat, None]], format="csc")
    lu = splu(a_mat, permc_spec="COLAMD")
    u0 = lu.solve(np.concatenate([f, -rhs_c]))[:n_u]
    gt = g_mat.T.tocsc()
    n_s = g_mat.shape[0]
    w = np.empty((n_s, n_s))
    for start in range(0, n_s, 64):
        cols = gt[:, start : start + 64].toarray()
        rhs = np.vstack([cols, np.zeros((n_c, cols.shape[1]))])
        w[:, start : start + cols.shape[1]] = g_mat @ lu.solve(rhs)[:n_u]
    w = 0.5 * (w + w.T)
    q = g_const + g_mat @ u0
    unit = np.mean(np.diag(w))
    eig, vec = np.linalg.eigh(w / unit)
    keep = eig > 1e-12 * eig.max()  # W is positive semi-definite up to round-off
    root = np.sqrt(eig[keep])
    lam, _ = nnls(
        root[:, None] * vec[:, keep].T, -(vec[:, keep].T @ (q / unit)) / root, maxiter=50 * n_s
    )
    act = lam > 0
    if not act.any():
        act[np.argmin(q)] = True
    if not return_solution:
        return act
    u = lu.solve(np.concatenate([f + gt @ (lam * unit), -rhs_c]))[:n_u]
    return act, lam * unit, u


def _kkt(k_mat, f, c_mat, rhs_c, g_mat, g_const, act):
    """Solve K u = f + Gaᵀλ + Cᵀμ, C u = rhs_c, Ga u = −g0a; return (u, λ, μ)."""
    ga = g_mat[act]
    n_u, n_c = k_mat.shape[0], c_mat.shape[0]
    kkt = sp.bmat([[k_mat, -c_mat.T, -ga.T], [-c_mat, None, None], [-ga, None, None]], format="csc")
    rhs = np.concatenate([f, -rhs_c, g_const[act]])
    try:
        x = splu(kkt, permc_spec="COLAMD").solve(rhs)
    except RuntimeError as exc:  # singular: a rigid-body mode left free
        raise ConvergenceError(
            f"FE contact: singular system ({exc}); a body is unsupported"
        ) from None
    if not np.all(np.isfinite(x)):
        raise ConvergenceError("FE contact: singular system; a body is unsupported")
    return x[:n_u], x[n_u + n_c :], x[n_u : n_u + n_c]


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
        centre [Pa]: a local recovery that averages out the node-to-segment oscillation.
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
    if near.sum() >= 3:
        c2, c1, c0 = np.polyfit(arc[near], p[near], 2)
        peak = float(c0 - c1**2 / (4 * c2)) if c2 < 0 else float(p[near].max())
    else:
        peak = float(p.max())
    k = int(np.searchsorted(s, s_c).clip(1, s.size - 1))
    w = (s_c - s[k - 1]) / (s[k] - s[k - 1])
    centre = (1 - w) * points[:, k - 1] + w * points[:, k]
    return ContactSummary(load, centre, b, peak, p, arc)
