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
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.linalg import splu

from cyclomesh.core.discbody import DiscBody
from cyclomesh.core.pair import CrankHoles, Modification, PairDesign
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
    b = design.pin_radius / 16.0 if load_half_width is None else float(load_half_width)
    mesh_args = dict(
        bore_radius=bore_radius,
        points=points,
        load_half_width=b,
        far_size=far_size,
        flank_size=flank_size,
        elements_per_half_width=elements_per_half_width,
    )
    key = influence_key(design, modification, holes, **mesh_args)
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
    k_full = disc.stiffness().tocsc()
    ndof = k_full.shape[0]
    p = disc.mesh.p
    # supports as a transformation u = T·v
    if holes is None:
        fixed = np.flatnonzero(np.abs(np.hypot(*p) - bore_radius) < 1e-6 * bore_radius)
        tied: list[tuple[NDArray, FloatArray]] = []
    else:
        fixed = np.empty(0, np.int64)
        tied = []
        for cx, cy in holes.centres:
            on = np.flatnonzero(np.abs(np.hypot(p[0] - cx, p[1] - cy) - holes.radius) < 1e-6)
            tied.append((on, np.array([cx, cy])))
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
        shape=(ndof, pts.shape[0]),
    )
    g_red = (t_mat.T @ g_full).tocsc()
    fact_t = time.perf_counter()
    lu = splu(k_red, permc_spec="MMD_AT_PLUS_A")
    disp = lu.solve(np.ascontiguousarray(g_red[:, fine].toarray()))
    fact_t = time.perf_counter() - fact_t
    resp = np.asarray(g_red.T @ disp)  # (n2·m, period·m): response at all points to each load
    resp = resp.reshape(n2, points, period, points)
    width = design.width
    table = np.empty((period, n2, points, points))
    for k0 in range(period):
        order = np.mod(k0 + np.arange(n2), n2)
        # table[k0, d, a, b] = response at tooth k0 + d, point b, to load k0, point a
        table[k0] = np.transpose(resp[order, :, k0, :], (0, 2, 1))
    # near field of the half-plane law at the same half-width, pressure-weighted mean
    c = design.disc_material.compliance
    nu = design.disc_material.poisson_ratio
    d = np.hypot(*pts[:points].T)
    near = 2.0 / np.pi * c * (np.log(2.0 * d / b) - nu / (2.0 * (1.0 - nu))) - c / (2.0 * np.pi)
    diagonal = np.stack([np.diagonal(table[k0, 0]) - near for k0 in range(period)])
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
    unknown = set(mesh) - set(MESH_DEFAULTS)
    if unknown:
        raise TypeError(f"influence: unknown mesh settings {sorted(unknown)}")
    args = {**MESH_DEFAULTS, **mesh}
    if args["load_half_width"] is None:
        args["load_half_width"] = design.pin_radius / 16.0
    key = influence_key(design, modification, holes, **args)
    path = _cache_file(folder, key)
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
