"""Influence coefficients of the disc body by FE, condensed on the loaded flanks.

The disc (2-D plane strain, linear elastic, P1 triangles, the whole modified profile) is
held as in the real part:

* ``support="bore"``: the bore of radius ``bore_radius`` tied to a rigid centre that is
  held (its translation by the crank bearing, its rotation is the disc rotation Δφc of
  the LTCA, which the coefficients are measured from): every bore node fixed;
* ``support="crank_holes"``: N crank holes (:class:`~cyclomesh.core.pair.CrankHoles`),
  the edge of each tied rigidly to its centre, the centre held and free to turn (the
  crank bearing rolls): u = θ_h × (x − c_h) on the hole's nodes, θ_h one unknown per hole,
  eliminated by a transformation of the stiffness matrix.

The stiffness matrix is factorised once (``scipy.sparse.linalg.splu``). A unit normal
load (per unit face width, into the disc) is applied at m evenly spaced generating
angles u of the forward flank of tooth 0 as a Hertzian pressure of half-width
``load_half_width`` (consistent nodal forces g), and the normal displacement at the same
m points of every tooth is read with the same weights (gᵀu), so the discrete table is
exactly reciprocal: C = Gᵀ K⁻¹ G. Cyclic symmetry (the bore support; the crank holes
repeat every n2/gcd(n2, N) teeth) gives every pair from the loads of one tooth (or of
one period). The near field that the contact law already carries is subtracted on the
diagonal: the half-plane approach to the disc centre (Johnson, eq. 5.41, the tooth term
of ``contact_law="half_plane"``) at the same half-width, in the same pressure-weighted
mean (the centre's approach less c/(2π) per unit load), so nothing is counted twice;
what is left is the body's compliance beyond a half-plane: the web's torsion, the
tooth's bending and shear, and the coupling between contacts. Divided by the face width
B the coefficients are in m/N.

The result, a :class:`~cyclomesh.core.discbody.DiscBody`, is cached in a file keyed by a hash
of every input (:func:`influence`): the first call computes it (tens of seconds), later
calls, in any process, load it in milliseconds.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.linalg import splu

from cyclomesh.core.discbody import FREE_HELD, DiscBody, FreeDiscBody
from cyclomesh.core.pair import CrankHoles, Modification, PairDesign
from cyclomesh.exceptions import DesignError
from cyclomesh.fe.mesh import Refinement, mesh_profile_disc
from cyclomesh.fe.solve import Body, boundary_chain
from cyclomesh.fe.tooth import disc_outline, profile_point

__all__ = [
    "influence",
    "compute_influence",
    "influence_key",
    "default_cache_dir",
    "load_coefficients",
    "INFLUENCE_VERSION",
    "MESH_DEFAULTS",
    "compute_free_influence",
    "free_influence",
    "cache_file",
    "GeometryBody",
    "SECONDS_PER_BODY",
]

FloatArray = NDArray[np.float64]
INFLUENCE_VERSION = 1
"""Bumped whenever the FE model behind the coefficients changes (invalidates caches)."""


MESH_DEFAULTS = {
    "bore_radius": 30e-3,
    "points": 31,
    "load_half_width": None,
    "far_size": 1.5e-3,
    "flank_size": 0.5e-3,
    "elements_per_half_width": 5.0,
}
"""Defaults of the FE model of :func:`compute_influence` (SI)."""


def default_cache_dir() -> Path:
    """The cache folder: ``$CYCLOMESH_CACHE_DIR`` (set by the CLI's ``--cache-dir``), else
    the per-user ``$XDG_CACHE_HOME/cyclomesh`` or ``~/.cache/cyclomesh``."""
    if os.environ.get("CYCLOMESH_CACHE_DIR"):
        return Path(os.environ["CYCLOMESH_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "cyclomesh"


def _plain(obj):
    if dataclasses.is_dataclass(obj):
        return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, np.ndarray | np.generic):
        return np.asarray(obj).tolist()
    if isinstance(obj, list | tuple):
        return [_plain(x) for x in obj]
    return obj


def influence_key(
    design: PairDesign,
    modification: Modification | None,
    holes: CrankHoles | None,
    **mesh: float,
) -> str:
    """SHA-256 of every input of the coefficients (geometry, modification, materials,
    supports, mesh and model version), the cache key."""
    doc = {
        "version": INFLUENCE_VERSION,
        "design": _plain(design),
        "modification": _plain(modification or Modification()),
        "holes": _plain(holes),
        "mesh": {k: float(v) for k, v in sorted(mesh.items())},
    }
    text = json.dumps(doc, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _arc_weights(body: Body, point: FloatArray, half_width: float, h: float):
    """Consistent nodal weights (sum 1) of a Hertzian pressure of half-width b about
    ``point`` on the boundary of ``body`` (arc coordinate along the boundary chain)."""
    chain = boundary_chain(body, tuple(point), half_width + 3.0 * h)
    xy = body.mesh.p[:, chain]
    seg = np.diff(xy, axis=1)
    length = np.hypot(*seg)
    s_node = np.concatenate([[0.0], np.cumsum(length)])
    # foot of the point on the chain
    rel = point[:, None] - xy[:, :-1]
    t = np.clip(np.sum(rel * seg, axis=0) / length**2, 0.0, 1.0)
    foot = xy[:, :-1] + t * seg
    k = int(np.argmin(np.hypot(*(foot - point[:, None]))))
    s0 = s_node[k] + t[k] * length[k]
    # pressure sampled finely (Gauss–Chebyshev of the second kind: exact for the
    # sqrt(1 − x²) weight times a piecewise-linear shape function up to the kinks)
    n = 400
    theta = np.pi * (np.arange(n) + 0.5) / n
    xs = np.cos(theta)
    wq = np.sin(theta) ** 2
    s = s0 + half_width * xs
    if s.min() < 0 or s.max() > s_node[-1]:
        raise ValueError("load spreads beyond the boundary chain")
    j = np.clip(np.searchsorted(s_node, s, side="right") - 1, 0, length.size - 1)
    loc = (s - s_node[j]) / length[j]
    weights = np.zeros(chain.size)
    np.add.at(weights, j, wq * (1.0 - loc))
    np.add.at(weights, j + 1, wq * loc)
    return chain, weights / weights.sum()


def _disc_model(
    design: PairDesign,
    modification: Modification,
    holes: CrankHoles | None,
    bore_radius: float,
    points: int,
    load_half_width: float,
    far_size: float,
    flank_size: float,
    elements_per_half_width: float,
):
    """The meshed disc of :func:`compute_influence` and its grid of contact points:
    (u, period, points (n2·m, 2), outward normals, the fine (loaded) points, their element
    size, the :class:`~cyclomesh.fe.solve.Body`, meshing time [s])."""
    b = load_half_width
    n2 = design.teeth
    u = np.linspace(-np.pi, 0.0, points)
    period = 1 if holes is None else n2 // math.gcd(n2, holes.count)
    loaded = [k for k in range(period)]
    # geometry of every grid point on every tooth
    phi1 = (2.0 * np.pi * np.arange(n2)[:, None] + u[None, :]).ravel()
    pts, normals = [], []
    for p in phi1:
        xy, n = profile_point(design, modification, float(p))
        pts.append(xy)
        normals.append(n)
    pts, normals = np.array(pts), np.array(normals)  # (n2·m, 2)
    h_fine = b / elements_per_half_width
    fine = [k * points + a for k in loaded for a in range(points)]
    refine_pts = [tuple(pts[i]) for i in range(pts.shape[0])]
    sizes = [flank_size] * len(refine_pts)
    radii = [2.0 * flank_size] * len(refine_pts)
    for i in fine:
        sizes[i] = h_fine
        radii[i] = 2.0 * b
    refine = Refinement(refine_pts, sizes, radii, far_size, 4e-3)
    contacts = phi1[np.asarray(fine)]
    outline, breaks = disc_outline(design, modification, contacts)
    hole_list = [] if holes is None else [(x, y, holes.radius) for x, y in holes.centres]
    mesh_t = time.perf_counter()
    disc = Body(
        *mesh_profile_disc(outline, bore_radius, refine, breaks, hole_list),
        design.disc_material.youngs_modulus,
        design.disc_material.poisson_ratio,
    )
    mesh_t = time.perf_counter() - mesh_t
    return u, period, pts, normals, fine, h_fine, disc, mesh_t


def _load_vectors(disc, pts, normals, fine, b, h_fine, flank_size):
    """Unit Hertzian line loads of half-width b into the disc at every grid point,
    (ndof, n2·m); the same weights read the normal approach δ = gᵀu."""
    # load vectors: unit line load into the disc, Hertzian over b, at every grid point
    g_rows, g_cols, g_vals = [], [], []
    fine_set = set(fine)
    for i in range(pts.shape[0]):
        h_here = h_fine if i in fine_set else flank_size
        chain, w = _arc_weights(disc, pts[i], b, h_here)
        g_rows += [disc.dof(chain, 0), disc.dof(chain, 1)]
        g_vals += [-normals[i, 0] * w, -normals[i, 1] * w]
        g_cols += [np.full(2 * chain.size, i)]
    # (ndof, n2·m): the unit loads; the same weights read the approach δ = gᵀu
    g_full = sp.csc_matrix(
        (np.concatenate(g_vals), (np.concatenate(g_rows), np.concatenate(g_cols))),
        shape=(2 * disc.n_nodes, pts.shape[0]),
    )
    return g_full


def _mesh_args(
    design: PairDesign,
    bore_radius: float,
    points: int,
    load_half_width: float | None,
    far_size: float,
    flank_size: float,
    elements_per_half_width: float,
) -> tuple[float, dict]:
    """The half-width b of the unit loads [m] (default ρp/16) and the mesh's arguments of
    :func:`_disc_model`, which are also the cache key's."""
    b = design.pin_radius / 16.0 if load_half_width is None else float(load_half_width)
    return b, dict(
        bore_radius=bore_radius,
        points=points,
        load_half_width=b,
        far_size=far_size,
        flank_size=flank_size,
        elements_per_half_width=elements_per_half_width,
    )


def _hole_edges(p: FloatArray, holes: CrankHoles) -> list[tuple[NDArray, FloatArray]]:
    """The mesh nodes on every crank hole's edge with the hole's centre [m]."""
    edges = []
    for cx, cy in holes.centres:
        on = np.flatnonzero(np.abs(np.hypot(p[0] - cx, p[1] - cy) - holes.radius) < 1e-6)
        edges.append((on, np.array([cx, cy])))
    return edges


def _tooth_table(
    design: PairDesign, resp: FloatArray, pts: FloatArray, points: int, period: int, b: float
) -> tuple[FloatArray, FloatArray]:
    """The influence table (period, n2, m, m) from the responses at every grid point to the
    loads on the ``period`` loaded teeth, and its diagonal less the near field of the
    half-plane law at the same half-width (pressure-weighted mean) [m/(N/m)], per unit
    width not yet divided."""
    n2 = design.teeth
    resp = np.asarray(resp).reshape(n2, points, period, points)
    table = np.empty((period, n2, points, points))
    for k0 in range(period):
        order = np.mod(k0 + np.arange(n2), n2)
        # table[k0, d, a, b] = response at tooth k0 + d, point b, to load k0, point a
        table[k0] = np.transpose(resp[order, :, k0, :], (0, 2, 1))
    c = design.disc_material.compliance
    nu = design.disc_material.poisson_ratio
    d = np.hypot(*pts[:points].T)
    near = 2.0 / np.pi * c * (np.log(2.0 * d / b) - nu / (2.0 * (1.0 - nu))) - c / (2.0 * np.pi)
    diagonal = np.stack([np.diagonal(table[k0, 0]) - near for k0 in range(period)])
    return table, diagonal


def compute_influence(
    design: PairDesign,
    modification: Modification | None = None,
    holes: CrankHoles | None = None,
    bore_radius: float = 30e-3,
    points: int = 31,
    load_half_width: float | None = None,
    far_size: float = 1.5e-3,
    flank_size: float = 0.5e-3,
    elements_per_half_width: float = 5.0,
) -> DiscBody:
    """Compute the influence coefficients of the disc body (see the module docstring).

    Parameters
    ----------
    design, modification
        The pair; the profile is that of tooth space 0 on every tooth.
    holes : CrankHoles, optional
        Support on N crank holes; None: the bore tied to a held rigid centre.
    bore_radius : float
        Bore radius [m] (free with crank holes).
    points : int
        Evenly spaced generating angles u of the forward flank, from −π to 0.
    load_half_width : float, optional
        Half-width b of the Hertzian unit loads [m]; default ρp/16.
    far_size, flank_size : float
        Element size far from the flanks and along every loaded flank [m].
    elements_per_half_width : float
        Element size b/this at the load points of the loaded tooth (or teeth).

    Returns
    -------
    DiscBody
        With ``key`` the cache key and ``info`` the model's size and timing.
    """
    start = time.perf_counter()
    modification = modification or Modification()
    n2 = design.teeth
    b, mesh_args = _mesh_args(
        design, bore_radius, points, load_half_width, far_size, flank_size, elements_per_half_width
    )
    key = influence_key(design, modification, holes, **mesh_args)
    u, period, pts, normals, fine, h_fine, disc, mesh_t = _disc_model(
        design, modification, holes, **mesh_args
    )
    k_full = disc.stiffness().tocsc()
    ndof = k_full.shape[0]
    p = disc.mesh.p
    # supports as a transformation u = T·v
    if holes is None:
        fixed = np.flatnonzero(np.abs(np.hypot(*p) - bore_radius) < 1e-6 * bore_radius)
        tied: list[tuple[NDArray, FloatArray]] = []
    else:
        fixed = np.empty(0, np.int64)
        tied = _hole_edges(p, holes)
    dead = np.zeros(ndof, bool)
    dead[disc.dof(fixed, 0)] = dead[disc.dof(fixed, 1)] = True
    for on, _ in tied:
        dead[disc.dof(on, 0)] = dead[disc.dof(on, 1)] = True
    free = np.flatnonzero(~dead)
    rows, cols, vals = list(free), list(range(free.size)), [1.0] * free.size
    for h, (on, c) in enumerate(tied):
        col = free.size + h
        rx, ry = p[0, on] - c[0], p[1, on] - c[1]
        rows += list(disc.dof(on, 0)) + list(disc.dof(on, 1))
        cols += [col] * (2 * on.size)
        vals += list(-ry) + list(rx)
    t_mat = sp.csc_matrix((vals, (rows, cols)), shape=(ndof, free.size + len(tied)))
    k_red = (t_mat.T @ k_full @ t_mat).tocsc()
    g_full = _load_vectors(disc, pts, normals, fine, b, h_fine, flank_size)
    g_red = (t_mat.T @ g_full).tocsc()
    fact_t = time.perf_counter()
    lu = splu(k_red, permc_spec="MMD_AT_PLUS_A")
    disp = lu.solve(np.ascontiguousarray(g_red[:, fine].toarray()))
    fact_t = time.perf_counter() - fact_t
    resp = np.asarray(g_red.T @ disp)  # (n2·m, period·m): response at all points to each load
    width = design.width
    table, diagonal = _tooth_table(design, resp, pts, points, period, b)
    table = table / width
    diagonal = diagonal / width
    info = {
        "support": "bore" if holes is None else f"{holes.count} crank holes",
        "nodes": int(disc.n_nodes),
        "points": int(points),
        "load_half_width_m": b,
        "mesh_s": mesh_t,
        "solve_s": fact_t,
        "total_s": time.perf_counter() - start,
        **{k: float(v) for k, v in mesh_args.items()},
    }
    return DiscBody(u, table, n2, key=key, info=info, diagonal=diagonal)


def _cache_file(cache_dir: Path, key: str) -> Path:
    return Path(cache_dir) / f"influence-{key}.npz"


def _cache_args(design: PairDesign, holes: CrankHoles | None, mesh: dict, name: str) -> dict:
    """The FE model's arguments of :func:`influence` and :func:`free_influence` (and of
    their cache key): :data:`MESH_DEFAULTS` with the bore of :func:`bore_radius_for`,
    overridden by ``mesh``; the load half-width ρp/16 unless given [SI]."""
    unknown = set(mesh) - set(MESH_DEFAULTS)
    if unknown:
        raise TypeError(f"{name}: unknown mesh settings {sorted(unknown)}")
    args = {**MESH_DEFAULTS, "bore_radius": bore_radius_for(holes), **mesh}
    if args["load_half_width"] is None:
        args["load_half_width"] = design.pin_radius / 16.0
    return args


def cache_file(
    design: PairDesign,
    modification: Modification | None = None,
    holes: CrankHoles | None = None,
    cache_dir: str | Path | None = None,
    free: bool = False,
    **mesh: float,
) -> Path:
    """The cache file of :func:`influence` (``free``: of :func:`free_influence`) for these
    inputs; it exists once the body was built (nothing is computed here)."""
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    modification = modification or Modification()
    args = _cache_args(design, holes, mesh, "free_influence" if free else "influence")
    extra = {"free_holes": 1.0} if free else {}
    return _cache_file(folder, influence_key(design, modification, holes, **extra, **args))


def load_coefficients(path: str | Path) -> DiscBody:
    """A :class:`DiscBody` from a cache file written by :func:`influence`."""
    with np.load(path, allow_pickle=False) as z:
        info = json.loads(str(z["info"]))
        return DiscBody(
            z["profile_angles"],
            z["table"],
            int(z["teeth"]),
            key=str(z["key"]),
            info=info,
            diagonal=z["diagonal"],
        )


def influence(
    design: PairDesign,
    modification: Modification | None = None,
    holes: CrankHoles | None = None,
    cache_dir: str | Path | None = None,
    **mesh: float,
) -> DiscBody:
    """The disc body's coefficients from the cache, computed and stored on a miss.

    ``cache_dir`` defaults to :func:`default_cache_dir`; the file name carries the
    hash of every input (:func:`influence_key`), so a changed design, material,
    support or mesh never reads a stale table. The file is written atomically
    (a temporary file renamed), so parallel workers share it safely.
    """
    modification = modification or Modification()
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    args = _cache_args(design, holes, mesh, "influence")
    path = _cache_file(folder, influence_key(design, modification, holes, **args))
    if path.exists():
        return load_coefficients(path)
    body = compute_influence(design, modification, holes, **args)
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".npz.tmp")
    os.close(fd)
    try:
        with open(tmp, "wb") as fh:
            np.savez(
                fh,
                profile_angles=body.profile_angles,
                table=body.table,
                diagonal=body.diagonal,
                teeth=body.teeth,
                key=body.key,
                info=json.dumps(body.info),
            )
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return load_coefficients(path)


def compute_free_influence(
    design: PairDesign,
    modification: Modification | None = None,
    holes: CrankHoles | None = None,
    bore_radius: float = 30e-3,
    points: int = 31,
    load_half_width: float | None = None,
    far_size: float = 1.5e-3,
    flank_size: float = 0.5e-3,
    elements_per_half_width: float = 5.0,
) -> FreeDiscBody:
    """The disc body condensed on its contact points *and* its crank-hole centres.

    The FE model is :func:`compute_influence`'s (same mesh, loads and near field), but each
    crank hole's edge is tied to a master point whose translation is free as well as its
    rotation: u = c_h + θ_h × (x − x_h) on the hole's nodes, c_h = r_h·e_r + t_h·e_t in the
    hole's radial and tangential directions. Three master components (:data:`FREE_HELD`)
    remove the rigid modes; the flexibility C of the remaining points (K⁻¹ by the same
    sparse LU) is then moved to the frame of the hole centres' least-squares rigid motion,

        C' = P·C·Pᵀ,   P = I − R·Hᵀ,

    R (points × 3) the rigid motions' displacements at every point and Hᵀ the least-squares
    fit of a rigid motion to the hole centres (HᵀR = I). C' does not depend on which
    components were held (for loads in equilibrium it is the body's unique deformation,
    measured from the holes' mean motion), so it keeps the cyclic symmetry of the
    holes and its pin block is a :class:`DiscBody` table of period n2/gcd(n2, N); the
    hole rows are read at every tooth's grid points. In the RV stage
    (:mod:`cyclomesh.stage.equilibrium`) the loads on a disc (pins and crank bearings) are
    in equilibrium, and the disc's rigid motion is the stage's own unknown.

    Parameters and mesh as :func:`compute_influence` (``holes`` required).

    References
    ----------
    The hybrid FE/analytical contact model of issue 17 (:mod:`cyclomesh.core.discbody`);
    condensation on master points: the superelement (static condensation) of linear FE.
    """
    if holes is None:
        raise ValueError("compute_free_influence: the free disc needs its crank holes")
    if bore_radius >= holes.circle_radius - holes.radius:
        raise ValueError("compute_free_influence: the bore cuts the crank holes")
    start = time.perf_counter()
    modification = modification or Modification()
    n2 = design.teeth
    b, mesh_args = _mesh_args(
        design, bore_radius, points, load_half_width, far_size, flank_size, elements_per_half_width
    )
    key = influence_key(design, modification, holes, free_holes=1.0, **mesh_args)
    u, period, pts, normals, fine, h_fine, disc, mesh_t = _disc_model(
        design, modification, holes, **mesh_args
    )
    k_full = disc.stiffness().tocsc()
    ndof = k_full.shape[0]
    p = disc.mesh.p
    N = holes.count
    ang = holes.angles
    dead = np.zeros(ndof, bool)
    tied = _hole_edges(p, holes)
    for on, _ in tied:
        dead[disc.dof(on, 0)] = dead[disc.dof(on, 1)] = True
    free = np.flatnonzero(~dead)
    rows, cols, vals = list(free), list(range(free.size)), [1.0] * free.size
    master = {}  # (hole, component 0 r / 1 t / 2 θ) → column
    col = free.size
    for h, (on, c) in enumerate(tied):
        er = np.array([np.cos(ang[h]), np.sin(ang[h])])
        et = np.array([-np.sin(ang[h]), np.cos(ang[h])])
        rx, ry = p[0, on] - c[0], p[1, on] - c[1]
        shapes = (
            (np.full(on.size, er[0]), np.full(on.size, er[1])),
            (np.full(on.size, et[0]), np.full(on.size, et[1])),
            (-ry, rx),
        )
        for comp, (sx, sy) in enumerate(shapes):
            if (h, comp) in FREE_HELD:
                continue
            master[(h, comp)] = col
            rows += list(disc.dof(on, 0)) + list(disc.dof(on, 1))
            cols += [col] * (2 * on.size)
            vals += list(sx) + list(sy)
            col += 1
    t_mat = sp.csc_matrix((vals, (rows, cols)), shape=(ndof, col))
    k_red = (t_mat.T @ k_full @ t_mat).tocsc()
    g_full = _load_vectors(disc, pts, normals, fine, b, h_fine, flank_size)
    g_red = (t_mat.T @ g_full).tocsc()
    # the hole components (r, t of each hole) as unit vectors of the reduced system
    npts = pts.shape[0]
    hole_cols = np.zeros((col, 2 * N))
    for h in range(N):
        for comp in range(2):
            if (h, comp) in master:
                hole_cols[master[(h, comp)], 2 * h + comp] = 1.0
    fact_t = time.perf_counter()
    lu = splu(k_red, permc_spec="MMD_AT_PLUS_A")
    rhs = np.concatenate([g_red[:, fine].toarray(), hole_cols], axis=1)
    disp = lu.solve(np.ascontiguousarray(rhs))
    fact_t = time.perf_counter() - fact_t
    # X = C[rows, cols]: rows every grid point and hole component, cols fine points + holes
    x_mat = np.concatenate([np.asarray(g_red.T @ disp), hole_cols.T @ disp], axis=0)
    # rigid motions (tx, ty, ω about the disc centre): into-disc normal displacement of
    # every grid point, radial and tangential displacement of every hole centre
    rig = np.zeros((npts + 2 * N, 3))
    rig[:npts, 0] = -normals[:, 0]
    rig[:npts, 1] = -normals[:, 1]
    rig[:npts, 2] = -(pts[:, 0] * normals[:, 1] - pts[:, 1] * normals[:, 0])
    r_c = holes.circle_radius
    rig[npts::2, 0], rig[npts::2, 1] = np.cos(ang), np.sin(ang)
    rig[npts + 1 :: 2, 0], rig[npts + 1 :: 2, 1] = -np.sin(ang), np.cos(ang)
    rig[npts + 1 :: 2, 2] = r_c
    # least-squares rigid fit of the hole centres: Hᵀ (3, 2N) acting on (r, t) per hole
    fit = np.zeros((3, 2 * N))
    fit[0, 0::2], fit[0, 1::2] = np.cos(ang) / N, -np.sin(ang) / N
    fit[1, 0::2], fit[1, 1::2] = np.sin(ang) / N, np.cos(ang) / N
    fit[2, 1::2] = 1.0 / (N * r_c)
    col_rig = np.concatenate([rig[np.asarray(fine)], rig[npts:]], axis=0)  # R at the cols
    c_holes = x_mat[:, len(fine) :]  # C[:, hole comps]
    y_mat = x_mat - (c_holes @ fit.T) @ col_rig.T  # C·Pᵀ
    c_prime = y_mat - rig @ (fit @ y_mat[npts:])  # P·C·Pᵀ
    table, diagonal = _tooth_table(design, c_prime[:npts, : len(fine)], pts, points, period, b)
    width = design.width
    hole_pin = c_prime[:npts, len(fine) :].reshape(n2, points, N, 2) / width
    hole_hole = c_prime[npts:, len(fine) :].reshape(N, 2, N, 2) / width
    # reciprocity of the FE (the pin loads' hole responses against the hole loads' pin
    # responses, on the loaded teeth): a check of the condensation, kept in the info
    pin_rows = c_prime[npts:, : len(fine)].T.reshape(period, points, N, 2) / width
    mismatch = float(np.max(np.abs(pin_rows - hole_pin[:period])) / np.max(np.abs(hole_pin)))
    info = {
        "support": f"{N} crank holes, centres free",
        "nodes": int(disc.n_nodes),
        "points": int(points),
        "load_half_width_m": b,
        "mesh_s": mesh_t,
        "solve_s": fact_t,
        "total_s": time.perf_counter() - start,
        "reciprocity": mismatch,
        **{k: float(v) for k, v in mesh_args.items()},
    }
    pins = DiscBody(u, table / width, n2, key=key, info=info, diagonal=diagonal / width)
    return FreeDiscBody(pins, hole_pin, hole_hole, holes.count)


def bore_radius_for(holes: CrankHoles | None) -> float:
    """The central bore of a disc with crank holes [m]: the default 30 mm
    (:data:`MESH_DEFAULTS`) if it clears the holes (r_c − r_h), else half that ligament
    (an assumption: the study files give no bore, and a bore cutting the holes cannot be
    meshed; the RV example's 23 mm ligament gets 11.5 mm)."""
    bore = MESH_DEFAULTS["bore_radius"]
    if holes is None or bore < holes.circle_radius - holes.radius:
        return bore
    return 0.5 * (holes.circle_radius - holes.radius)


def free_influence(
    design: PairDesign,
    modification: Modification | None = None,
    holes: CrankHoles | None = None,
    cache_dir: str | Path | None = None,
    **mesh: float,
) -> FreeDiscBody:
    """:func:`compute_free_influence` from the cache, computed and stored on a miss (the
    same cache folder and atomic write as :func:`influence`)."""
    modification = modification or Modification()
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    args = _cache_args(design, holes, mesh, "free_influence")
    path = _cache_file(folder, influence_key(design, modification, holes, free_holes=1.0, **args))
    if not path.exists():
        body = compute_free_influence(design, modification, holes, **args)
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".npz.tmp")
        os.close(fd)
        try:
            with open(tmp, "wb") as fh:
                np.savez(
                    fh,
                    profile_angles=body.pins.profile_angles,
                    table=body.pins.table,
                    diagonal=body.pins.diagonal,
                    teeth=body.pins.teeth,
                    key=body.pins.key,
                    info=json.dumps(body.pins.info),
                    hole_pin=body.hole_pin,
                    hole_hole=body.hole_hole,
                )
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    with np.load(path, allow_pickle=False) as z:
        pins = DiscBody(
            z["profile_angles"],
            z["table"],
            int(z["teeth"]),
            key=str(z["key"]),
            info=json.loads(str(z["info"])),
            diagonal=z["diagonal"],
        )
        return FreeDiscBody(pins, z["hole_pin"], z["hole_hole"], int(z["hole_pin"].shape[2]))


SECONDS_PER_BODY = {"held": 20.0, "free": 80.0}
"""Rough wall time of one FE disc body at :data:`MESH_DEFAULTS` [s], for the notice of a
design map: measured on a 2-core machine shared with other jobs (load 2.5), gmsh's
start included: the Table 1 pair held at its bore 16 s, the RV-40E-size disc of
``examples/rv_stage.toml`` held at its crank holes 22 s and with its hole centres free
(the stage's body) 77 s."""


@dataclass(frozen=True)
class GeometryBody:
    """The compliant disc body of whatever geometry it is given: a design map over the
    geometry builds each candidate's own body with it (``disc_body = "fe"``), in the
    map's worker processes, through the cache of :func:`influence`.

    Picklable (it travels with the map's task to local or Dask workers); the FE model's
    settings are fixed when it is made, so every worker builds with the parent's.

    Parameters
    ----------
    holes : CrankHoles or None
        Where the disc is held (:func:`influence`); None: at its bore.
    free : bool
        The free body of the RV stage (:func:`free_influence`, the hole centres free).
    cache_dir : str, optional
        The cache folder (default: :func:`default_cache_dir` of the worker).
    mesh : tuple of (name, value)
        Settings of :data:`MESH_DEFAULTS` (SI); those not given take the defaults, the
        bore :func:`bore_radius_for` the holes, the load half-width ρp/16 of each design.
    """

    holes: CrankHoles | None = None
    free: bool = False
    cache_dir: str | None = None
    mesh: tuple[tuple[str, float | None], ...] = ()

    @classmethod
    def with_defaults(
        cls, holes: CrankHoles | None, free: bool = False, cache_dir: str | Path | None = None
    ) -> GeometryBody:
        """A builder with today's :data:`MESH_DEFAULTS` (less the bore, which the holes
        fix) and the cache folder resolved now, as ``cyclomesh run`` would build."""
        folder = str(Path(cache_dir) if cache_dir is not None else default_cache_dir())
        mesh = tuple((k, v) for k, v in MESH_DEFAULTS.items() if k != "bore_radius")
        return cls(holes, free, folder, mesh)

    def path(self, design: PairDesign, modification: Modification | None = None) -> Path:
        """The cache file of this geometry's body (it exists once built)."""
        return cache_file(
            design, modification, self.holes, self.cache_dir, self.free, **dict(self.mesh)
        )

    def __call__(
        self, design: PairDesign, modification: Modification | None = None
    ) -> DiscBody | FreeDiscBody:
        """The body of ``design`` (from the cache, else built and stored).

        Raises
        ------
        DesignError
            Holes or a bore that do not fit the geometry, or an FE model that cannot be
            built (the reason in one line): the candidate is infeasible with it.
        """
        from cyclomesh.core.pair import check_bore

        mesh = dict(self.mesh)
        if self.holes is not None:
            self.holes.check_fits(design)
        check_bore(design, self.holes, float(mesh.get("bore_radius", bore_radius_for(self.holes))))
        build = free_influence if self.free else influence
        try:
            return build(design, modification, self.holes, self.cache_dir, **mesh)
        except Exception as exc:  # noqa: BLE001 (gmsh raises a bare Exception)
            reason = " ".join(str(exc).split()) or type(exc).__name__
            raise DesignError(f'disc_body = "fe": no FE body of this geometry: {reason}') from None
