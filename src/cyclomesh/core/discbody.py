"""The compliant disc: influence coefficients of the disc body and coupled load sharing.

The rigid-disc model (Eqs. 15–18 of [1]) writes the compatibility of pin i as
l_i·(Δφc − φbl,i) = δ_i(F_i), the Hertzian approach of the contact law alone. The disc
body is elastic too: the web between the crank bearing and the teeth twists, the teeth
bend, and a load on one tooth moves its neighbours. The hybrid method of gear contact
analysis keeps the singular near field of every contact in the analytical law and adds
a linear body compliance, computed once by FE and condensed on the points where contact
can occur (:mod:`cyclomesh.fe.influence`):

    l_i·(Δφc − φbl,i) = δ_i(F_i) + Σ_j C_ij·F_j,     F_i ≥ 0,     Σ_i l_i·F_i = T,

C_ij [m/N] the normal displacement of contact i (into the disc, relative to the
support) under a unit normal load at contact j, less the near field the contact law
already carries (the half-plane approach to the same reference depth, at i = j).

:class:`DiscBody` holds the table of C for a load on one tooth and the responses on all
teeth (cyclic symmetry: C depends on the tooth offset and the two profile positions),
and interpolates it with a local bicubic (Catmull–Rom) in the two profile angles.
:func:`share_load_coupled` solves the coupled system exactly (Newton's method, dense:
the pins in contact), to a torque residual of 1e-12·T and a compatibility residual of
1e-12 of the largest approach and from there on to the root at round-off (so that the
root does not depend on the start), or raises
:class:`~cyclomesh.exceptions.ConvergenceError`.

NumPy, SI units, no I/O; with ``CYCLOMESH_KERNEL=numba``
(:func:`cyclomesh.core.kernel.kernel_name`) the Newton iteration on the candidate pins,
the single-pin bound and the tooth index run compiled
(:mod:`cyclomesh.core.kernel_discbody`; each crank angle of a ring started from the
roots before it), to the same root at round-off, this NumPy reference staying the
fallback.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core import kernel_discbody
from cyclomesh.core.hertz import force_from_approach
from cyclomesh.core.kernel import kernel_name, share_load
from cyclomesh.core.loadsharing import TORQUE_TOLERANCE
from cyclomesh.exceptions import ConvergenceError

__all__ = [
    "DiscBody",
    "DISC_BODIES",
    "FreeDiscBody",
    "FREE_HELD",
    "share_load_coupled",
    "tooth_index",
    "COMPATIBILITY_TOLERANCE",
]

FloatArray = NDArray[np.float64]

DISC_BODIES = ("rigid", "fe")
"""Values of ``disc_body``: the rigid disc of [1], or the FE influence coefficients."""

COMPATIBILITY_TOLERANCE = 1e-12
"""Compatibility residual, relative to the largest approach l·(Δφc − φbl), below which
(with the torque's below 1e-12·T) Newton's steps are near the root: from there they go
on to round-off (:data:`ROUND_OFF`)."""
ROUND_OFF = 4.0 * float(np.finfo(float).eps)
"""Torque residual relative to T and compatibility residual relative to the largest
approach (four units in the last place, about 8.9e-16) at which the coupled solve has
reached the root; near the root a Newton step that does not reduce the scaled residual
ends the iteration as well (the round-off of the sums), so the root does not depend on
the start."""
_MAX_ITERATIONS = 100


@dataclass(frozen=True, eq=False)
class DiscBody:
    """Influence coefficients of the disc body on its loaded flanks [m/N].

    Attributes
    ----------
    profile_angles : ndarray
        Grid of generating angles u of the forward flank [rad], shape (m,), evenly
        spaced and increasing (u ∈ [−π, 0], u = 0 the tooth-space bottom).
    table : ndarray
        Shape (p, n2, m, m): ``table[k0, d, a, b]`` is the normal displacement [m], into
        the disc, of the contact at profile angle b on tooth k0 + d under a unit normal
        load [N] (on the face width) at profile angle a on tooth k0, k0 = 0 … p − 1.
        p = 1 for a cyclically symmetric support (the bore); with N crank holes p is
        the number of teeth after which the holes repeat, n2/gcd(n2, N).
    teeth : int
        n2 [-].
    key : str
        Hash of the inputs the table was computed from (cache key), "" if none.
    info : dict
        Description of the FE model (support, mesh, timing), for reports.
    diagonal : ndarray, optional
        Shape (p, m): the self-compliance of a contact, ``table[k0, 0, a, a]`` less the
        near field of the contact law [m/N]. A contact's own coefficient is
        interpolated from it along u alone (the table's same-tooth block holds the
        whole FE response, singular at the load, and serves only two contacts on one
        tooth). Default: the table's diagonal.
    """

    profile_angles: FloatArray
    table: FloatArray
    teeth: int
    key: str = ""
    info: dict = field(default_factory=dict)
    diagonal: FloatArray | None = None

    def __post_init__(self) -> None:
        u = np.asarray(self.profile_angles, float)
        t = np.asarray(self.table, float)
        if u.ndim != 1 or u.size < 4 or not np.all(np.diff(u) > 0):
            raise ValueError("DiscBody.profile_angles: at least 4 increasing angles")
        if not np.allclose(np.diff(u), u[1] - u[0], rtol=1e-9, atol=0):
            raise ValueError("DiscBody.profile_angles must be evenly spaced")
        if t.ndim != 4 or t.shape[1] != self.teeth or t.shape[2:] != (u.size, u.size):
            raise ValueError("DiscBody.table must have shape (p, teeth, m, m)")
        if self.teeth % t.shape[0]:
            raise ValueError("DiscBody.table: the period p must divide the number of teeth")
        object.__setattr__(self, "profile_angles", u)
        object.__setattr__(self, "table", t)
        if self.diagonal is None:
            diag = np.diagonal(t[:, 0], axis1=-2, axis2=-1).copy()
        else:
            diag = np.asarray(self.diagonal, float)
        if diag.shape != (t.shape[0], u.size):
            raise ValueError("DiscBody.diagonal must have shape (p, m)")
        object.__setattr__(self, "diagonal", diag)

    @property
    def period(self) -> int:
        """p: teeth after which the support repeats (1 for the bore)."""
        return int(self.table.shape[0])

    def _cells(self, angle: FloatArray) -> tuple[NDArray, FloatArray]:
        """Catmull–Rom cell i (..., ) and weights (..., 4) at profile angles [rad]: the
        nodes are i − 1 … i + 2, clamped to the grid.

        Angles outside the grid are clamped to its ends (the contacts there, at a tip or
        a tooth-space bottom, have no moment arm and carry no load).
        """
        u = self.profile_angles
        m = u.size
        h = u[1] - u[0]
        s = (np.clip(np.nan_to_num(angle, nan=u[0]), u[0], u[-1]) - u[0]) / h
        i = np.clip(np.floor(s).astype(np.int64), 0, m - 2)
        t = s - i
        t2, t3 = t * t, t * t * t
        w = np.stack(
            [
                0.5 * (-t3 + 2.0 * t2 - t),
                0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
                0.5 * (-3.0 * t3 + 4.0 * t2 + t),
                0.5 * (t3 - t2),
            ],
            axis=-1,
        )
        return i, w

    def _weights(self, angle: FloatArray) -> tuple[NDArray, FloatArray]:
        """Catmull–Rom nodes (..., 4) and weights (..., 4) at profile angles [rad]."""
        i, w = self._cells(angle)
        nodes = np.clip(i[..., None] + np.arange(-1, 3), 0, self.profile_angles.size - 1)
        return nodes, w

    @cached_property
    def _padded(self) -> FloatArray:
        """The reciprocal table, edge-padded in both profile angles, shape (p, n2, m + 2,
        m + 2): ``0.5·(table[k0, d, a, b] + table[(k0 + d) mod p, −d mod n2, b, a])`` (the
        response of contact i to j averaged with that of j to i: reciprocity, which the
        FE holds to its round-off), padded so that the clamped nodes i − 1 … i + 2 of
        cell i are the padded rows i … i + 3. The compiled load sharing
        (:mod:`cyclomesh.core.kernel_discbody`) reads a pair's 4×4 window from it, four
        rows of four (a table of ~0.3 MB on Table 1, not 16 times that)."""
        t = self.table
        p, n2 = self.period, self.teeth
        k0, d = np.arange(p)[:, None], np.arange(n2)[None, :]
        partner = np.swapaxes(t[np.mod(k0 + d, p), np.mod(-d, n2)], -1, -2)
        sym = 0.5 * (t + partner)
        return np.pad(sym, ((0, 0), (0, 0), (1, 1), (1, 1)), mode="edge")

    @cached_property
    def _lowest(self) -> float:
        """−(the most negative coefficient of the table or its diagonal) [m/N], 0 if none:
        a body displacement is at least −this·ΣF (the check after the coupled solve)."""
        return max(0.0, -float(np.min(self.table)), -float(np.min(self.diagonal)))

    @cached_property
    def _windows(self) -> FloatArray:
        """The reciprocal table in Catmull–Rom windows, shape (16, p·n2·(m − 1)²):
        :attr:`_padded` cut into the 4×4 windows of every (k0, d, cell of the load, cell
        of the response), component-major (one row per window node pair, ``4·a + b``).
        """
        p, n2, m = self.period, self.teeth, self.profile_angles.size
        win = np.lib.stride_tricks.sliding_window_view(self._padded, (4, 4), axis=(2, 3))
        return np.ascontiguousarray(win.reshape(p * n2 * (m - 1) ** 2, 16).T)

    def matrix(self, tooth: ArrayLike, angle: ArrayLike) -> FloatArray:
        """C_ij of contacts at (tooth, profile angle), shape (..., n) → (..., n, n) [m/N].

        ``C[..., i, j]`` is the displacement of contact i under a unit load at contact j
        (``table[k_j mod p, (k_i − k_j) mod n2, u_j, u_i]``, interpolated bicubically).
        """
        k = np.asarray(tooth, np.int64)
        nodes, w = self._weights(np.asarray(angle, float))
        n2, p = self.teeth, self.period
        m = self.profile_angles.size
        ki, kj = k[..., :, None], k[..., None, :]
        # flat index into the table: ((k0·n2 + d)·m + a)·m + b
        small = np.int32 if self.table.size < 2**31 else np.int64
        block = ((np.mod(kj, p) * n2 + np.mod(ki - kj, n2)) * (m * m)).astype(small)
        a = (nodes * m).astype(small)[..., None, :, :, None]  # load j's nodes
        b = nodes.astype(small)[..., :, None, None, :]  # response i's nodes
        vals = np.take(self.table.ravel(), block[..., None, None] + a + b)  # (..., n, n, 4, 4)
        half = np.einsum("...ijab,...ja->...ijb", vals, w)
        out = np.einsum("...ijb,...ib->...ij", half, w)
        own = np.einsum("...ia,...ia->...i", self.diagonal[np.mod(k, p)[..., None], nodes], w)
        n = k.shape[-1]
        out[..., np.arange(n), np.arange(n)] = own
        return out

    def reciprocal_matrix(
        self, tooth: ArrayLike, angle: ArrayLike, own: ArrayLike | None = None
    ) -> FloatArray:
        """½(C + Cᵀ) of :meth:`matrix` (the same to round-off), shape (..., n, n) [m/N].

        The coefficients the load sharing uses, formed once per set of contacts: each
        pair i < j interpolated from the reciprocal table (:attr:`_windows`), its 16
        values gathered as one window. ``own``: the diagonal if already known
        (:meth:`self_compliance` of the same contacts).
        """
        k = np.asarray(tooth, np.int64)
        cell, w = self._cells(np.asarray(angle, float))
        k, cell = np.broadcast_arrays(k, cell)
        n = k.shape[-1]
        lead = k.shape[:-1]
        w = np.broadcast_to(w, (*cell.shape, 4)).reshape(-1, n, 4)
        k, cell = k.reshape(-1, n), cell.reshape(-1, n)
        n2, p = self.teeth, self.period
        cells = self.profile_angles.size - 1
        rows, cols = np.triu_indices(n, 1)  # response i = rows, load j = cols
        # window of the pair: ((k_j mod p)·n2 + (k_i − k_j) mod n2, cell_j, cell_i)
        base = (np.mod(k, p) * n2 * cells + cell) * cells  # the load's part, per pin
        km = np.mod(k, n2)
        offset = np.take(km, rows, axis=1) - np.take(km, cols, axis=1)
        offset += n2 * (offset < 0)
        index = offset * (cells * cells)
        index += np.take(base, cols, axis=1)
        index += np.take(cell, rows, axis=1)
        vals = np.take(self._windows, index.ravel(), axis=1).reshape(4, 4, -1)
        wt = np.moveaxis(w, -1, 0)  # (4, B, n)
        wj = np.take(wt, cols, axis=2).reshape(4, -1)
        wi = np.take(wt, rows, axis=2).reshape(4, -1)
        half = np.einsum("abp,ap->bp", vals, wj)  # the load's nodes first, as matrix()
        pair = np.einsum("bp,bp->p", half, wi).reshape(index.shape)
        if own is None:
            nodes = np.clip(cell[..., None] + np.arange(-1, 3), 0, cells)
            own = np.einsum("...ia,...ia->...i", self.diagonal[np.mod(k, p)[..., None], nodes], w)
        else:
            own = np.broadcast_to(own, (*lead, n)).reshape(-1, n)
        # the matrix from the pairs and the diagonal in one gather
        where = np.empty((n, n), np.int64)
        where[rows, cols] = where[cols, rows] = np.arange(rows.size)
        where[np.arange(n), np.arange(n)] = rows.size + np.arange(n)
        out = np.take(np.concatenate([pair, own], axis=1), where.ravel(), axis=1)
        return out.reshape(*lead, n, n)

    def self_compliance(self, tooth: ArrayLike, angle: ArrayLike) -> FloatArray:
        """The own coefficient C_ii of contacts at (tooth, profile angle) [m/N]."""
        k = np.asarray(tooth, np.int64)
        nodes, w = self._weights(np.asarray(angle, float))
        m = self.profile_angles.size
        index = nodes if self.period == 1 else np.mod(k, self.period)[..., None] * m + nodes
        return np.einsum("...a,...a->...", np.take(self.diagonal, index), w)


def tooth_index(pins: int, pitch: float, crank_angle: ArrayLike) -> NDArray[np.int64]:
    """Tooth space of the disc each pin meets, (..., n1) for crank angles (...) [rad].

    Pin i (nominal angle i·2π/n1) lies in the tooth space whose generating angle
    φ1 = 2πk + u (u ∈ (−π, π]) is nearest: k = round((n2·i·pitch + φin)/2π) mod n2.
    """
    n2 = pins - 1
    if kernel_name() == "numba" and kernel_discbody.compiled() is not None:
        phi = np.asarray(crank_angle, float)
        out = np.empty((phi.size, pins), np.int64)
        kernel_discbody.compiled().teeth(phi.ravel(), n2 * pitch, n2, out)
        return out.reshape(*phi.shape, pins)
    phi = np.asarray(crank_angle, float)[..., None]
    turns = n2 * pitch * np.arange(pins) + phi
    turns /= 2.0 * np.pi
    np.rint(turns, out=turns)  # as np.round: halves to even
    # mod n2 of the integer-valued floats (exact: |turns| ≪ 2⁵³), then one cast
    whole = turns / n2
    np.floor(whole, out=whole)
    whole *= n2
    turns -= whole
    return turns.astype(np.int64)


def share_load_coupled(
    backlash: ArrayLike,
    moment_arm: ArrayLike,
    alpha: ArrayLike,
    gamma: ArrayLike,
    torque: float,
    body: DiscBody,
    tooth: ArrayLike,
    profile_angle: ArrayLike,
    groups: int = 1,
    angle_axis: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """Load sharing with the compliant disc body (Eqs. 15–18 of [1] plus Σ C_ij F_j).

    Solves, for every case along the leading axes,

        l_i·(Δφc − φbl,i) − w_i = δ_i(F_i) (F_i > 0),   w = C·F,   Σ l_i·F_i = T,

    with F_i = F(δ⁺) the exact inverse of the contact law
    (:func:`~cyclomesh.core.hertz.force_from_approach`). The unknowns are Δφc and the body
    displacements w; F is a C¹ function of them (dF/dδ = 0 at δ = 0), so Newton's
    method (dense, on the pins that can engage) solves the system without an active
    set. It starts from the rigid-disc solution, with a backtracking line search on the
    scaled residual, to a torque residual below 1e-12·T and a compatibility residual
    |w − C·F| below 1e-12 of the largest approach, and from there takes full Newton
    steps on to the root at round-off (:data:`ROUND_OFF`, or the first step that does
    not reduce the scaled residual), as the stage's Newton
    (:mod:`cyclomesh.stage.newton`) and the rigid load sharing do.

    Parameters
    ----------
    backlash, moment_arm, alpha, gamma, torque
        As in :func:`cyclomesh.core.loadsharing.share_load` (shape (..., n) [rad, m, m/N,
        m/N]; T [N·m]).
    body : DiscBody
        Influence coefficients.
    tooth : array_like
        Tooth space of each contact (int, (..., n)); ``groups`` discs of n/groups pins
        each (a stack) share no body: C between discs is 0.
    profile_angle : array_like
        Generating angle u of each contact on the forward flank [rad], (..., n).
    groups : int
        Number of discs along the pin axis (the pins of disc g are the g-th block).
    angle_axis : bool
        The last leading axis is one ring's crank angles in order (as
        :func:`cyclomesh.core.kernel.share_load`'s: the compiled kernel solves the rigid
        disc, its start, at each ring's first angle and estimates it at the others from
        the angles before, :mod:`cyclomesh.core.kernel_discbody`; the NumPy kernel
        ignores it).

    Returns
    -------
    rotation : ndarray
        Δφc [rad], shape (...).
    force : ndarray
        F_i [N], shape (..., n).
    """
    inputs = tuple(
        np.asarray(v, dtype)
        for v, dtype in (
            (backlash, float),
            (moment_arm, float),
            (alpha, float),
            (gamma, float),
            (tooth, np.int64),
            (profile_angle, float),
        )
    )
    # not np.broadcast_arrays: its views warn when the compiled passes below ask whether
    # they are writeable (NumPy's FutureWarning). An array that differs from the shape by
    # axes of length 1 only is reshaped (a view, as before); np.broadcast_to (read-only)
    # where it really broadcasts. The values are the same.
    shape = np.broadcast_shapes(*(v.shape for v in inputs))
    size = math.prod(shape)
    bl, arm, alpha, gamma, tooth, angle = (
        v if v.shape == shape else v.reshape(shape) if v.size == size else np.broadcast_to(v, shape)
        for v in inputs
    )
    lead, n = bl.shape[:-1], bl.shape[-1]
    flat = (-1, n)
    bl, arm, alpha, gamma = (x.reshape(flat) for x in (bl, arm, alpha, gamma))
    tooth, angle = tooth.reshape(flat), angle.reshape(flat)
    numba = kernel_name() == "numba"
    # a ring's crank angles in order along the last leading axis: the compiled kernel
    # solves the rigid disc (the start) at each ring's first angle only, and its own
    # start of each angle after it from the ones before (kernel_discbody._solve_sets)
    block = lead[-1] if numba and angle_axis and lead else 1
    if block > 1:
        x0, f0 = np.full(bl.shape[0], np.nan), np.zeros(bl.shape)
        _rigid_start((bl, arm, alpha, gamma), torque, x0, f0, np.arange(0, x0.size, block))
    else:  # the rigid disc: the start
        x0, f0 = share_load(
            *(v.reshape(*lead, n) for v in (bl, arm, alpha, gamma)), torque, angle_axis=angle_axis
        )
        x0, f0 = x0.reshape(-1), f0.reshape(flat)
    if numba:  # the own coefficients and the candidates, compiled
        diag = np.empty(bl.shape)
        candidate = np.empty(bl.shape, bool)
        u = body.profile_angles
        grid = np.array([u[0], u[-1], u[1] - u[0], u.size], float)
        kernel_discbody.compiled().candidates(
            *(np.ascontiguousarray(v) for v in (bl, arm, alpha, gamma, tooth, angle)),
            body.diagonal, grid, float(torque), block, diag, candidate
        )  # fmt: skip
    else:
        diag, candidate = _candidates(bl, arm, alpha, gamma, tooth, angle, torque, body)
    arrays = (bl, arm, alpha, gamma, tooth, angle, diag)
    # with numba, the cases the test below may flag (a superset of them), compiled
    flags = np.empty(x0.size, bool) if numba else None
    x, full = _solve_set(candidate, arrays, x0, f0, torque, body, n // groups, block, flags)
    lowest = body._lowest
    if numba:
        rows = np.flatnonzero(flags)
    else:
        rows = np.arange(x.size)
    for _ in range(n):
        # only the cases re-solved can flag again (the others' solutions are as they were)
        with np.errstate(divide="ignore", invalid="ignore"):
            reach = x[rows, None] + lowest * np.sum(full[rows], axis=-1)[:, None] / arm[rows]
        usable = np.isfinite(bl[rows]) & (arm[rows] > 0)
        risky = usable & ~candidate[rows] & (bl[rows] < reach)
        hit = np.any(risky, axis=-1)
        cases, risky = rows[hit], risky[hit]
        if cases.size == 0:
            break
        rows = cases
        pins = candidate[cases] | risky
        width = int(np.max(np.sum(pins, axis=-1)))
        order = np.argsort(~pins, axis=-1, kind="stable")[:, :width]
        take = np.take_along_axis
        ok = take(pins, order, -1)
        cmat = body.matrix(take(tooth[cases], order, -1), take(angle[cases], order, -1))
        disc = order // (n // groups)
        cmat = np.where(ok[:, None, :] & (disc[:, :, None] == disc[:, None, :]), cmat, 0.0)
        w = np.einsum("bij,bj->bi", cmat, take(full[cases], order, -1))
        # padding entries (cases with fewer pins than the widest) may be pins that cannot
        # touch (φbl = inf, l ≤ 0): masked before the product, as in _solve_set
        c_arm = np.where(ok, take(arm[cases], order, -1), 0.0)
        c_bl = np.where(ok, take(bl[cases], order, -1), 0.0)
        gap = c_arm * (x[cases, None] - c_bl) - w
        scale = np.max(np.where(ok, gap, 0.0), axis=-1, keepdims=True)
        bad = ok & take(risky, order, -1) & (gap > COMPATIBILITY_TOLERANCE * scale)
        if not np.any(bad):
            break
        grow = np.zeros_like(pins)
        np.put_along_axis(grow, order, bad, -1)
        candidate[cases] |= grow
        if numba:  # the kernel took the own coefficients of its candidates only
            diag[cases] = body.self_compliance(tooth[cases], angle[cases])
        sub = tuple(a[cases] for a in arrays)
        try:
            x[cases], full[cases] = _solve_set(
                candidate[cases], sub, x0[cases], f0[cases], torque, body, n // groups
            )
        except ConvergenceError as exc:  # name the case in the whole batch
            exc.case_index = int(cases[getattr(exc, "case_index", 0)])
            raise
    return x.reshape(lead), full.reshape(*lead, n)


def _candidates(bl, arm, alpha, gamma, tooth, angle, torque, body):
    """The own coefficients C_ii (B, n) [m/N] and the pins that can engage below the
    single-pin bound with the body's own compliance (as share_load's start), (B, n) bool."""
    usable = np.isfinite(bl) & (arm > 0)
    diag = body.self_compliance(tooth, angle)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        single = np.where(usable, torque / np.where(usable, arm, 1.0), 0.0)
        log_single = np.log(np.where(usable, single, 1.0))
        hertz = single * (alpha - gamma * log_single)
        # as in share_load: a force past the stiffest point of the law bounds nothing
        valid = usable & ((gamma == 0) | (log_single < alpha / gamma - 1.0))
        alone = bl + (hertz + diag * single) / np.where(valid, arm, 1.0)
        alone = np.where(valid & (alone > bl), alone, np.inf)
    bound = np.min(alone, axis=-1)
    # the pins that can engage below the single-pin bound; the solution is then checked
    # for every other pin that could touch (its body displacement may be negative by at
    # most the table's most negative coefficient times the total load), and re-solved
    # with the pins that would penetrate, so the result is that of all pins
    return diag, usable & (bl < bound[:, None])


def _rigid_start(
    arrays: tuple, torque: float, x0: FloatArray, f0: FloatArray, cases: NDArray
) -> None:
    """The rigid disc's solution of ``cases`` (indices into the (B, n) ``arrays``' rows:
    φbl, l, α, γ first) into ``x0`` (B,) and ``f0`` (B, n), the start of their coupled
    solve. Its error is that of the whole batch (the first case that fails), as where
    the rigid disc is solved for every case."""
    if cases.size == 0:
        return
    try:
        x0[cases], f0[cases] = share_load(*(a[cases] for a in arrays[:4]), torque)
    except ConvergenceError as exc:
        share_load(*arrays[:4], torque)  # raises at the batch's first failing case
        exc.case_index = int(cases[getattr(exc, "case_index", 0)])
        raise


def _solve_set(
    candidate: NDArray,
    arrays: tuple,
    x0: FloatArray,
    f0: FloatArray,
    torque: float,
    body: DiscBody,
    per_disc: int,
    block: int = 1,
    flags: NDArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Newton's method of :func:`share_load_coupled` on the ``candidate`` pins, (B, n), on
    the selected kernel: :func:`_solve_set_numpy` (the reference), or with
    ``CYCLOMESH_KERNEL=numba`` the same iteration compiled, case by case
    (:mod:`cyclomesh.core.kernel_discbody`; ``block``: cases per ring); if it cannot
    finish a case, the reference solves the whole set (and raises its own error where it
    fails too). ``x0``, ``f0``: the rigid disc's solution, the start (NaN in ``x0``: not
    solved, the kernel's own start; filled in place where a case needs it). The compiled
    path chooses the candidates of a case it starts from the cases before (the pins its
    start can reach: ``candidate``'s rows at ring starts only are read, the others
    written, in place), adds to a ring start's the pins its rigid start can reach (in
    place too), and restores the single-pin bound's where it gives a case up.
    ``flags`` (B,) bool, given with the numba kernel only: filled with the cases the
    check after the solve may flag (:func:`kernel_discbody._suspects`' test, taken by
    the compiled solve as it finishes each case)."""
    if kernel_name() == "numba":
        bl, arm, alpha, gamma, tooth, angle, own = (np.ascontiguousarray(a) for a in arrays)
        u = body.profile_angles
        grid = np.array([u[0], u[-1], u[1] - u[0], u.size], float)
        passes = kernel_discbody.compiled()
        settings = (
            body._padded.ravel(), body.diagonal, grid, body.teeth, body.period, per_disc,
            float(torque), TORQUE_TOLERANCE, COMPATIBILITY_TOLERANCE, ROUND_OFF, _MAX_ITERATIONS,
            body._lowest,
        )  # fmt: skip
        rotation = np.empty(bl.shape[0])
        force = np.zeros(bl.shape)
        status = np.zeros(bl.shape[0], np.int8)
        suspect = np.empty(bl.shape[0], bool)
        given = candidate
        candidate = np.ascontiguousarray(candidate)
        failed = passes.solve_sets(
            candidate, bl, arm, alpha, gamma, tooth, angle, own, x0, f0, *settings,
            max(block, 1), rotation, force, status, suspect
        )  # fmt: skip
        start = np.flatnonzero(status == 2)  # no start of the kernel's own: the rigid disc's
        if failed and start.size == failed:
            _rigid_start(arrays, torque, x0, f0, start)
            out = (rotation[start], force[start], status[start], suspect[start])
            chosen = candidate[start]
            failed = passes.solve_sets(
                chosen, *(a[start] for a in (bl, arm, alpha, gamma, tooth, angle, own)),
                x0[start], f0[start], *settings, 1, *out
            )  # fmt: skip
            rotation[start], force[start], suspect[start] = out[0], out[1], out[3]
            candidate[start] = chosen  # the kernel's (its start's reach added)
        if candidate is not given:  # the rows the kernel chose, for the check after
            given[...] = candidate
        if not failed:
            if flags is not None:
                flags[...] = suspect
            return rotation, force
    _rigid_start(arrays, torque, x0, f0, np.flatnonzero(np.isnan(x0)))
    x, full = _solve_set_numpy(candidate, arrays, x0, f0, torque, body, per_disc)
    if flags is not None:  # the compiled test on the reference's solution
        bl, arm = (np.ascontiguousarray(a) for a in arrays[:2])
        kernel_discbody.compiled().suspects(candidate, bl, arm, x, full, body._lowest, flags)
    return x, full


def _solve_set_numpy(
    candidate: NDArray,
    arrays: tuple,
    x0: FloatArray,
    f0: FloatArray,
    torque: float,
    body: DiscBody,
    per_disc: int,
) -> tuple[FloatArray, FloatArray]:
    """Newton's method of :func:`share_load_coupled` on the ``candidate`` pins, (B, n):
    the NumPy reference.

    The Newton step of the unknowns (w, Δφc) solves

        (I + C·D)·Δw − C·D·l·Δx = −r_w,     −(D·l)ᵀ·Δw + lᵀ·D·l·Δx = −r_t,

    D = diag(dF/dδ), nonzero on the engaged pins E only. With ΔF = D·(l·Δx − Δw) this is
    Δw = C·ΔF − r_w and the symmetric system on E

        (D⁻¹ + C)_EE·ΔF_E − l_E·Δx = r_w,E,     l_Eᵀ·ΔF_E = −r_t,

    solved with two right-hand sides (r_w and l) of the one matrix; the same step to
    round-off as the full system, at half the cost. Cases that have converged take no
    further steps (their state is final), so the iterations work on the rest only.
    """
    bl, arm, alpha, gamma, tooth, angle, own = arrays
    width = int(np.max(np.sum(candidate, axis=-1)))
    order = np.argsort(~candidate, axis=-1, kind="stable")[:, :width]
    take = np.take_along_axis
    ok = take(candidate, order, -1)
    c_bl = np.where(ok, take(bl, order, -1), 0.0)  # padding: no arm, no approach
    c_arm = np.where(ok, take(arm, order, -1), 0.0)
    c_alpha, c_gamma = take(alpha, order, -1), take(gamma, order, -1)
    c_alpha = np.where(ok, c_alpha, 1.0)
    c_gamma = np.where(ok, c_gamma, 0.0)
    # reciprocal (C = Cᵀ, as the FE to its round-off), formed once for the candidate set
    cmat = body.reciprocal_matrix(
        take(tooth, order, -1), take(angle, order, -1), take(own, order, -1)
    )
    disc = order // per_disc
    cmat[~(ok[:, :, None] & ok[:, None, :] & (disc[:, :, None] == disc[:, None, :]))] = 0.0

    def evaluate(x, w, case):
        delta = np.maximum(c_arm[case] * (x[:, None] - c_bl[case]) - w, 0.0)
        f = force_from_approach(delta, c_alpha[case], c_gamma[case])
        r_w = w - np.einsum("bij,bj->bi", cmat[case], f)
        r_t = np.sum(f * c_arm[case], axis=-1) - torque
        return delta, f, r_w, r_t

    def merit(delta, r_w, r_t):
        scale = np.maximum(np.max(delta, axis=-1), 1e-300)
        return np.max(np.abs(r_w), axis=-1) / scale + np.abs(r_t) / torque

    everything = slice(None)
    x = x0.copy()
    # the start: the rigid-disc solution itself (w = 0: δ, F and the torque exact, only
    # r_w = −C·F0 open); 1–3 Newton steps fewer than from w = C·F0 at the rigid Δφc
    w = np.zeros_like(c_bl)
    delta, f, r_w, r_t = evaluate(x, w, everything)
    current = merit(delta, r_w, r_t)
    done = np.zeros(x.size, bool)
    previous = np.full(x.size, np.inf)  # the scaled residual before the last step
    active = np.arange(x.size)
    for _ in range(_MAX_ITERATIONS):
        case = everything if active.size == x.size else active
        scale = np.max(c_arm[case] * np.maximum(x[case, None] - c_bl[case], 0.0), axis=-1)
        worst = np.max(np.abs(r_w[case]), axis=-1)
        torque_res = np.abs(r_t[case])
        # near the root (the tolerances), then on to the root at round-off: a residual of
        # a few units in the last place, or the first step that does not reduce it
        near = (torque_res <= TORQUE_TOLERANCE * torque) & (
            worst <= COMPATIBILITY_TOLERANCE * scale
        )
        floor = (torque_res <= ROUND_OFF * torque) & (worst <= ROUND_OFF * scale)
        now = near & (floor | (current[case] >= previous[case]))
        previous[case] = current[case]
        done[active[now]] = True
        if np.all(now):
            break
        polish = near[~now]  # near the root: Newton's full step, no line search
        active = active[~now]
        case = everything if active.size == x.size else active
        f_a, r_w_a, r_t_a, l_a = f[case], r_w[case], r_t[case], c_arm[case]
        engaged = f_a > 0
        with np.errstate(divide="ignore"):
            log_f = np.log(np.where(engaged, f_a, 1.0))
        d = np.where(engaged, 1.0 / (c_alpha[case] - c_gamma[case] * (1.0 + log_f)), 0.0)
        c_a = cmat[case]
        # the engaged pins first: the system is that of the widest engaged set
        wide = int(np.max(np.sum(engaged, axis=-1)))
        if wide < width:
            first = np.argsort(~engaged, axis=-1, kind="stable")[:, :wide]
            flat = (np.arange(first.shape[0]) * (width * width))[:, None, None]
            flat = flat + first[:, :, None] * width + first[:, None, :]
            c_e = np.take(c_a, flat)
            eng, d_e = take(engaged, first, -1), take(d, first, -1)
            r_e, l_e = take(r_w_a, first, -1), take(l_a, first, -1)
        else:
            c_e, eng, d_e, r_e, l_e = c_a, engaged, d, r_w_a, l_a
        system = np.where(eng[:, :, None] & eng[:, None, :], c_e, 0.0)
        diagonal = np.arange(wide)
        system[:, diagonal, diagonal] += np.where(eng, 1.0 / np.where(eng, d_e, 1.0), 1.0)
        l_e = np.where(eng, l_e, 0.0)
        rhs = np.stack([np.where(eng, r_e, 0.0), l_e], axis=-1)
        try:
            sol = np.linalg.solve(system, rhs)
        except np.linalg.LinAlgError:
            sol = None
        if sol is not None:
            den = np.sum(l_e * sol[..., 1], axis=-1)
            singular = ~(np.isfinite(den) & (den != 0.0))
        if sol is None or np.any(singular):
            if sol is None:
                det = np.linalg.det(system)
                singular = ~np.isfinite(det) | (det == 0)
            err = ConvergenceError(
                "coupled load sharing: singular Newton system (the disc body's coefficients "
                "plus the contact law are not positive definite here)"
            )
            err.case_index = int(active[np.argmax(singular)])
            raise err from None
        step_x = -(r_t_a + np.sum(l_e * sol[..., 0], axis=-1)) / den
        step_e = sol[..., 0] + sol[..., 1] * step_x[:, None]
        if wide < width:
            step_f = np.zeros_like(f_a)
            np.put_along_axis(step_f, first, step_e, -1)
        else:
            step_f = step_e
        step_w = np.einsum("bij,bj->bi", c_a, step_f) - r_w_a
        old = current[case]
        x_a, w_a = x[case], w[case]
        lam = np.ones(active.size)
        for _ in range(30):
            xn = x_a + lam * step_x
            wn = w_a + lam[:, None] * step_w
            dn, fn, rwn, rtn = evaluate(xn, wn, case)
            new = merit(dn, rwn, rtn)
            worse = (new > old) & (lam > 1e-6) & ~polish
            if not np.any(worse):
                break
            lam = np.where(worse, 0.5 * lam, lam)
        x[case], w[case], delta[case], f[case], r_w[case], r_t[case] = xn, wn, dn, fn, rwn, rtn
        current[case] = new
    else:
        bad = int(np.flatnonzero(~done)[0])
        err = ConvergenceError(
            f"coupled load sharing did not converge: residual above {TORQUE_TOLERANCE:.0e} "
            f"after {_MAX_ITERATIONS} Newton steps"
        )
        err.case_index = bad
        raise err
    full = np.zeros_like(bl)
    np.put_along_axis(full, order, np.where(ok, f, 0.0), -1)
    return x, full


FREE_HELD = ((0, 0), (0, 1), (1, 1))
"""Hole-centre components (hole, 0 radial / 1 tangential) held in the FE model of the
free disc (:func:`cyclomesh.fe.influence.compute_free_influence`), and left out of the
RV stage's body unknowns: they remove the disc's three rigid modes only (hole 0's
translation, hole 1's tangential motion)."""


@dataclass(frozen=True, eq=False)
class FreeDiscBody:
    """The disc body condensed on its contacts and its crank-hole centres (the RV stage).

    Influence coefficients of the free disc in the frame of its hole centres' mean
    (least-squares rigid) motion, :func:`cyclomesh.fe.influence.compute_free_influence`:
    for loads in equilibrium (the pins' and the crank bearings' on one disc) they give the
    body's deformation at every contact and hole centre; the disc's rigid motion is the
    stage's unknown (:mod:`cyclomesh.stage.equilibrium`).

    Attributes
    ----------
    pins : DiscBody
        Pin on pin (the near field on the diagonal removed as in issue 17's table) [m/N].
    hole_pin : ndarray
        (n2, m, N, 2): radial and tangential displacement [m] of hole centre h (its own
        directions e_r, e_t in the disc frame) under a unit normal load [N] into the disc
        at profile angle a of tooth k; by reciprocity, the into-disc normal displacement
        of that contact under a unit radial (tangential) load at the hole centre.
    hole_hole : ndarray
        (N, 2, N, 2): hole centre on hole centre [m/N].
    count : int
        N, the crank holes.
    """

    pins: DiscBody
    hole_pin: FloatArray
    hole_hole: FloatArray
    count: int

    @property
    def key(self) -> str:
        return self.pins.key

    @property
    def teeth(self) -> int:
        return self.pins.teeth

    def matrix(self, tooth: ArrayLike, angle: ArrayLike) -> FloatArray:
        """C' of contacts (..., P) at (tooth, profile angle) and the 2N hole components,
        (..., P + 2N, P + 2N) [m/N], symmetric: pins first (into-disc normal), then hole
        0 radial, hole 0 tangential, hole 1 radial … (each hole's own directions).

        The pin block is :meth:`DiscBody.reciprocal_matrix`; the pin–hole block the
        Catmull–Rom interpolation of :attr:`hole_pin` along u (as the pin block's).
        """
        k = np.asarray(tooth, np.int64)
        a = np.asarray(angle, float)
        pp = self.pins.reciprocal_matrix(k, a)
        nodes, w = self.pins._weights(a)
        vals = self.hole_pin[np.mod(k, self.teeth)[..., None], nodes]  # (..., P, 4, N, 2)
        ph = np.einsum("...pqhc,...pq->...phc", vals, w).reshape(*k.shape, 2 * self.count)
        hh = self.hole_hole.reshape(2 * self.count, 2 * self.count)
        hh = 0.5 * (hh + hh.T)
        lead = k.shape[:-1]
        top = np.concatenate([pp, ph], axis=-1)
        bottom = np.concatenate(
            [np.swapaxes(ph, -1, -2), np.broadcast_to(hh, (*lead, *hh.shape))], axis=-1
        )
        return np.concatenate([top, bottom], axis=-2)
