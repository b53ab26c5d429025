"""Triangle meshes of pins, flats, seats and the cycloid disc with gmsh (PyPI wheel).

Every function returns ``(points, triangles)``: node coordinates of shape (2, N) [m]
and node indices of shape (3, M), the linear triangles of scikit-fem's ``MeshTri``.
Geometry is built with gmsh's OpenCASCADE kernel in millimetres (gmsh's tolerances are
absolute) and scaled to metres on return. The element size is ``h_fine`` within
``fine_radius`` of each refinement point (the potential contacts) and grows linearly to
``h_far`` at ``grow_radius`` from it.
"""

from __future__ import annotations

import ctypes
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import gmsh
import numpy as np
from numpy.typing import NDArray

from cyclomesh.units import M_PER_MM

__all__ = ["Refinement", "mesh_disk", "mesh_half_disk", "mesh_block", "mesh_profile_disc"]

FloatArray = NDArray[np.float64]
MM = M_PER_MM  # mm -> m (units.py): gmsh works in mm


@dataclass(frozen=True)
class Refinement:
    """Element sizes around the potential contacts [m].

    Attributes
    ----------
    points : sequence of (x, y)
        Centres of refinement [m].
    h_fine : float or sequence of float
        Element size near the points (one for all or one per point) [m].
    fine_radius : float or sequence of float
        Radius of the uniformly fine zone (one for all or one per point) [m].
    h_far : float
        Element size far from the points [m].
    grow_radius : float
        Distance at which the size reaches ``h_far`` [m].
    """

    points: Sequence[tuple[float, float]]
    h_fine: float | Sequence[float]
    fine_radius: float | Sequence[float]
    h_far: float
    grow_radius: float


def _ignore_sigpipe() -> None:
    """Set SIGPIPE back to ignored, as Python starts (a write to a closed pipe raises
    BrokenPipeError): ``gmsh.initialize`` resets it to the default action, which
    terminates the process. Without this, a process that has meshed once dies (exit
    141) when it writes to the pipe of a worker that died, instead of rebuilding its
    pool (:class:`cyclomesh.execution.backends.ProcessBackend`)."""
    if not hasattr(signal, "SIGPIPE"):  # Windows
        return
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    else:  # signal.signal is the main thread's only: the C call, process-wide as well
        libc = ctypes.CDLL(None)
        libc.signal.restype = ctypes.c_void_p
        libc.signal.argtypes = (ctypes.c_int, ctypes.c_void_p)
        libc.signal(int(signal.SIGPIPE), 1)  # SIG_IGN


@contextmanager
def _session() -> Iterator[None]:
    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
        _ignore_sigpipe()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.model.add("cyclomesh")
    try:
        yield
    finally:
        gmsh.model.remove()
        if not initialised:
            gmsh.finalize()


def _mesh(build: Callable[[], int], refine: Refinement) -> tuple[FloatArray, NDArray]:
    """Mesh the surface made by ``build`` (OCC, mm) with the size field of ``refine``."""
    with _session():
        surface = build()
        occ = gmsh.model.occ
        fields = []
        n_pts = len(refine.points)
        h_fine = np.broadcast_to(np.asarray(refine.h_fine, float), (n_pts,))
        fine_radius = np.broadcast_to(np.asarray(refine.fine_radius, float), (n_pts,))
        # one Distance/Threshold pair per distinct (size, radius): the minimum of the
        # thresholds of points sharing them is the threshold of their nearest distance
        groups: dict[tuple[float, float], list[tuple[float, float]]] = {}
        for xy, h_i, r_i in zip(refine.points, h_fine, fine_radius, strict=True):
            groups.setdefault((float(h_i), float(r_i)), []).append(xy)
        for (h_i, r_i), pts in groups.items():
            occ.synchronize()
            tags = [occ.addPoint(x / MM, y / MM, 0.0) for x, y in pts]
            occ.synchronize()
            dist = gmsh.model.mesh.field.add("Distance")
            gmsh.model.mesh.field.setNumbers(dist, "PointsList", tags)
            thr = gmsh.model.mesh.field.add("Threshold")
            gmsh.model.mesh.field.setNumber(thr, "InField", dist)
            gmsh.model.mesh.field.setNumber(thr, "SizeMin", h_i / MM)
            gmsh.model.mesh.field.setNumber(thr, "SizeMax", refine.h_far / MM)
            gmsh.model.mesh.field.setNumber(thr, "DistMin", r_i / MM)
            gmsh.model.mesh.field.setNumber(thr, "DistMax", refine.grow_radius / MM)
            fields.append(thr)
        occ.synchronize()
        if fields:
            field = gmsh.model.mesh.field.add("Min")
            gmsh.model.mesh.field.setNumbers(field, "FieldsList", fields)
            gmsh.model.mesh.field.setAsBackgroundMesh(field)
        gmsh.option.setNumber("Mesh.MeshSizeMax", refine.h_far / MM)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, conn = gmsh.model.mesh.getElements(2, surface)
        tri = np.asarray(conn[list(types).index(2)], dtype=np.int64).reshape(-1, 3)
    xy = coords.reshape(-1, 3)[:, :2] * MM
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(tags.size)
    tri = index[tri]
    used = np.unique(tri)
    renumber = np.full(tags.size, -1, dtype=np.int64)
    renumber[used] = np.arange(used.size)
    return np.ascontiguousarray(xy[used].T), np.ascontiguousarray(renumber[tri].T)


def mesh_disk(
    center: tuple[float, float],
    radius: float,
    refine: Refinement,
    embed: Sequence[tuple[float, float]] = (),
) -> tuple[FloatArray, NDArray]:
    """A full disk (a pin) [m]; ``embed`` points (e.g. its centre) become nodes."""

    def build() -> int:
        occ = gmsh.model.occ
        surf = occ.addDisk(center[0] / MM, center[1] / MM, 0.0, radius / MM, radius / MM)
        pts = [occ.addPoint(x / MM, y / MM, 0.0) for x, y in embed]
        occ.synchronize()
        if pts:
            gmsh.model.mesh.embed(0, pts, 2, surf)
        return surf

    return _mesh(build, refine)


def mesh_half_disk(radius: float, refine: Refinement) -> tuple[FloatArray, NDArray]:
    """The right half (x ≥ 0) of a disk of centre (0, radius): a pin resting on y = 0 [m]."""

    def build() -> int:
        occ = gmsh.model.occ
        r = radius / MM
        c = occ.addPoint(0.0, r, 0.0)
        bottom = occ.addPoint(0.0, 0.0, 0.0)
        top = occ.addPoint(0.0, 2 * r, 0.0)
        side = occ.addPoint(r, r, 0.0)
        arcs = [occ.addCircleArc(bottom, c, side), occ.addCircleArc(side, c, top)]
        axis = occ.addLine(top, bottom)
        loop = occ.addCurveLoop([*arcs, axis])
        return occ.addPlaneSurface([loop])

    return _mesh(build, refine)


def mesh_block(
    half_width: float,
    depth: float,
    refine: Refinement,
    seat_radius: float | None = None,
) -> tuple[FloatArray, NDArray]:
    """Right half (x ≥ 0) of a block with its top at y = 0 [m].

    With ``seat_radius`` the top carries a concave circular seat of that radius whose
    bottom is at the origin (centre (0, seat_radius)); the block then reaches up to
    y = seat_radius·0.9 so the seat is a deep groove.
    """

    def build() -> int:
        occ = gmsh.model.occ
        w, d = half_width / MM, depth / MM
        if seat_radius is None:
            return occ.addRectangle(0.0, -d, 0.0, w, d)
        rg = seat_radius / MM
        top = 0.9 * rg
        rect = occ.addRectangle(0.0, -d, 0.0, w, d + top)
        hole = occ.addDisk(0.0, rg, 0.0, rg, rg)
        out, _ = occ.cut([(2, rect)], [(2, hole)])
        return out[0][1]

    return _mesh(build, refine)


def mesh_profile_disc(
    outline: FloatArray,
    bore_radius: float,
    refine: Refinement,
    breaks: Sequence[int] = (),
    holes: Sequence[tuple[float, float, float]] = (),
) -> tuple[FloatArray, NDArray]:
    """The cycloid disc: a closed outline (2, K) [m] interpolated by splines, minus a bore.

    ``breaks`` are indices of outline points that become geometric vertices (and so mesh
    nodes), e.g. the contact points; the outline is split into one spline between each
    pair of consecutive breaks. ``holes`` are further circular holes (x, y, radius) [m],
    e.g. the crank holes.
    """

    def build() -> int:
        occ = gmsh.model.occ
        k = outline.shape[1]
        tags = [occ.addPoint(x / MM, y / MM, 0.0) for x, y in outline.T]
        cuts = sorted({0, *(int(b) % k for b in breaks)})
        curves = []
        for i, start in enumerate(cuts):
            stop = cuts[i + 1] if i + 1 < len(cuts) else k
            chain = [tags[j % k] for j in range(start, stop + 1)]
            curves.append(occ.addSpline(chain))
        loop = occ.addCurveLoop(curves)
        bore = occ.addCircle(0.0, 0.0, 0.0, bore_radius / MM)
        inner = [occ.addCurveLoop([bore])]
        for x, y, r in holes:
            inner.append(occ.addCurveLoop([occ.addCircle(x / MM, y / MM, 0.0, r / MM)]))
        return occ.addPlaneSurface([loop, *inner])

    return _mesh(build, refine)
