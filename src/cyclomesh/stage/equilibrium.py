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

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.contact import UnloadedContact
from cyclomesh.core.discbody import FREE_HELD, FreeDiscBody
from cyclomesh.core.fields import CONTACT_LOAD_FRACTION, contact_fields, contact_stresses
from cyclomesh.core.friction import Friction
from cyclomesh.core.lubrication import Film
from cyclomesh.core.pair import CrankHoles, PairDesign
from cyclomesh.core.transmission import transmission_error
from cyclomesh.drive.solve import (
    StackMesh,
    mirror_index,
)
from cyclomesh.exceptions import ConvergenceError
from cyclomesh.stage import newton as reference
from cyclomesh.stage.assembly import (
    Body,
    Problem,
    SupportedJacobians,
    bearing_jacobian,
    evaluate,
    loads,
    pin_laws,
    unpack,
)
from cyclomesh.stage.bearing import LOAD_EXPONENT, roller_loads
from cyclomesh.stage.coupling import coupling, positions
from cyclomesh.stage.design import StageDesign
from cyclomesh.stage.floating import FLOATING_LOAD, canonical_positions, floating_discs
from cyclomesh.stage.friction import (
    friction_arrays,
    friction_continuation,
    friction_newton,
    friction_picard,
    friction_terms,
    lubricated_state,
    pin_slip,
    power_terms,
)
from cyclomesh.stage.kernel import bearing_start as compiled_start
from cyclomesh.stage.kernel import (
    compiled,
    disc_sums,
    disc_turn,
    dmax_finish,
    flank_block,
    mesh_work,
    single_rotation,
)
from cyclomesh.stage.kernel_compliant import newton as kernel_compliant
from cyclomesh.stage.kernel_newton import PIN_BLOCK, pin_block
from cyclomesh.stage.kernel_newton import newton as kernel_newton
from cyclomesh.stage.kernel_newton import rigid_newton as kernel_rigid_newton
from cyclomesh.stage.kernel_newton import run as kernel_run
from cyclomesh.stage.kernel_outputs import DISC_FIELDS, stage_fields
from cyclomesh.stage.newton import (
    FORCE_TOLERANCE,
    newton,
    reducer,
    residual_newton,
    rotation_index,
)
from cyclomesh.stage.supports import (
    SPLIT_ITERATIONS,
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

# the assembly under the names this module has always used (tests reach _evaluate)
_Problem, _Body, _pins, _unpack, _evaluate = Problem, Body, pin_laws, unpack, evaluate

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


def body_coupling(
    mesh: StackMesh,
    prob: _Problem,
    body: FreeDiscBody,
    reach: FloatArray,
    start: dict,
    memo: dict | None = None,
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

    ``memo``: a dict kept by a caller that couples the same direction at several torques
    (:func:`solve_direction`'s ``cache``): the coefficients of the candidates are formed
    once and taken from there where every crank angle's candidates are among the ones
    formed (a lighter torque's reach is shorter), each coefficient the same number
    (:meth:`~cyclomesh.core.discbody.FreeDiscBody.matrix` interpolates each pair, each
    pin–hole and hole–hole term on its own).
    """
    A, D, n1 = mesh.geo.rotation.shape
    N = prob.hx.shape[-1]
    tooth = np.asarray(mesh.tooth).reshape(A, D, n1)
    angle = mesh.geo.profile_angle.reshape(A, D, n1)
    bl = prob.bl[..., :n1]
    if compiled():  # CYCLOMESH_KERNEL=numba: the same arrays in three compiled passes
        w, hole_w, energy, pins, flank, z = coupling(
            tooth, angle, bl, prob.arm[..., :n1], reach, body, prob.hx, prob.hy, prob.scale,
            start["pin_force"], start["bearing_fx"], start["bearing_fy"],
        )  # fmt: skip
        return _Body(w, hole_w, energy, pins, flank, 2 * n1), z
    cand = np.isfinite(bl) & (prob.arm[..., :n1] > 0) & (bl < reach[:, None, None])
    P = max(int(np.max(np.sum(cand, axis=-1))), 1)
    order = np.argsort(~cand, axis=-1, kind="stable")[..., :P]
    ok = np.take_along_axis(cand, order, -1)
    pins = np.where(ok, order, -1)
    cmat = None if memo is None else _memo_matrix(memo.get("body_matrix"), pins, N)
    if cmat is None:
        cmat = body.matrix(
            np.take_along_axis(tooth, order, -1),
            np.where(ok, np.take_along_axis(angle, order, -1), 0.0),
        )
        if memo is not None:
            memo["body_matrix"] = (pins, cmat.copy())
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
    w = scaled[..., :P, :]  # the pins' rows (Body.pin_w: at the flanks ``order``)
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
    body = _Body(w, hole_w, energy, pins, np.ascontiguousarray(order), 2 * n1)
    return body, z.reshape(A, -1)


def _body_starts(
    mesh: StackMesh,
    prob: _Problem,
    body: FreeDiscBody,
    reach: FloatArray,
    law,
    start,
    memo: dict | None = None,
):
    """The compliant disc's coupling (:func:`body_coupling`) and a function of crank-angle
    indices giving their own starts (the bearing start ``start(idx)`` (len(idx), m) of
    ``prob``'s crank angles ``idx`` with the body's start z = c0·λ from the loads on the
    disc there, :func:`body_coupling`'s), for
    :func:`cyclomesh.stage.kernel_compliant.newton`'s ``start``: the rigid stage, the
    bearing start, the state there (the pins' laws inverted, ~10 µs a crank angle) and z
    formed only for the crank angles the kernel reads. :func:`~cyclomesh.stage.assembly.
    evaluate` and z are crank angle by crank angle; the rigid stage and the bearing
    start's stiff-limit split are not (each crank angle warm from the one before in the
    rows asked for together), so the own starts, and the roots from them, differ from
    those with every crank angle's start formed at round-off (a 4-ring compliant study
    ~7·10⁻¹⁶ of a field's largest). The coupling's own z is formed from unit pin loads:
    its candidates' entries are c0."""
    A, D, n1 = mesh.geo.rotation.shape
    N = prob.hx.shape[-1]
    unit = {
        "pin_force": np.ones((A, D, n1)),
        "bearing_fx": np.zeros((A, D, N)),
        "bearing_fy": np.zeros((A, D, N)),
    }
    coupling, z1 = body_coupling(mesh, prob, body, reach, unit, memo)
    P = coupling.pins.shape[-1]
    ones = z1.reshape(A, D, -1)[..., :P][coupling.pins >= 0]
    c0 = ones[0] if ones.size else np.nan  # (the candidates' c0·1: c0)
    held = [2 * h + c for h, c in FREE_HELD]
    comp = np.array([j for j in range(2 * N) if j not in held], np.int64)
    hole, even = comp // 2, comp % 2 == 0

    def own(idx: NDArray[np.int64]) -> FloatArray:
        """The own starts (len(idx), m) of the crank angles ``idx``."""
        sub = prob.take(idx)  # (one take for the start and the loads there)
        x = start(idx, sub)
        st = loads(sub, law, x, D)  # (evaluate's, without the potential)
        pins = coupling.pins[idx]
        ok = pins >= 0
        load = np.take_along_axis(st["pin_force"], coupling.flank[idx], -1)
        zp = c0 * np.where(ok, load, 0.0)
        fx, fy = -st["bearing_fx"][..., hole], -st["bearing_fy"][..., hole]  # (n, D, F)
        erx = (prob.hx[idx][:, hole] / prob.scale)[:, None, :]
        ery = (prob.hy[idx][:, hole] / prob.scale)[:, None, :]
        value = np.where(even, fx * erx + fy * ery, -fx * ery + fy * erx)
        z = np.concatenate([zp, c0 * value], axis=-1)
        return np.concatenate([x, z.reshape(idx.size, -1)], axis=-1)

    return coupling, own


def _positions(here: NDArray[np.int64], there: NDArray[np.int64]):
    """Where each candidate pin of ``here`` stands among those of ``there`` (pin indices,
    −1 for padding, (..., P) and (..., P')): (found, its position; 0 where not found).
    With numba, :func:`cyclomesh.stage.coupling.positions` (the same integers)."""
    if compiled():
        return positions(here, there)
    match = (here[..., :, None] == there[..., None, :]) & (here[..., :, None] >= 0)
    return np.any(match, axis=-1), np.argmax(match, axis=-1)


def _memo_matrix(kept, pins: NDArray[np.int64], N: int):
    """The coefficients (A, D, P + 2N, P + 2N) of the candidates ``pins`` (−1: padding)
    taken from ``kept`` = (pins, matrix) of an earlier coupling (:func:`body_coupling`'s
    ``memo``), or None where a candidate is not among those (or nothing is kept). The
    rows and columns of padding are arbitrary (the caller sets them)."""
    if kept is None:
        return None
    pins1, cmat1 = kept
    if pins1.shape[:2] != pins.shape[:2]:
        return None
    found, where = _positions(pins, pins1)
    if not np.all(found | (pins < 0)):
        return None
    P1 = pins1.shape[-1]
    idx = np.concatenate(
        [where, np.broadcast_to(P1 + np.arange(2 * N), (*pins.shape[:2], 2 * N))], axis=-1
    )
    rows = np.take_along_axis(cmat1, idx[..., :, None], axis=-2)
    return np.take_along_axis(rows, idx[..., None, :], axis=-1)


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
    names = _PIN_FIELDS if p.slip is None else (*_PIN_FIELDS, "slip", "tangent_arm")
    fields = {f: np.take_along_axis(getattr(p, f), order, axis=-1) for f in names}
    if p.lubrication is not None:
        fields["lubrication"] = {
            key: np.take_along_axis(value, order, axis=-1) for key, value in p.lubrication.items()
        }
    fields["bl"] = np.where(kept, fields["bl"], np.inf)
    if p.body is not None:  # the same pins of the compliant disc's coefficients
        fields["body"] = p.body.near(order)
    return dataclasses.replace(p, **fields)


def _solve(
    p: _Problem,
    law,
    x: FloatArray,
    discs: int,
    rigid: bool,
    phi: FloatArray,
    state: dict | None = None,
):
    """:func:`~cyclomesh.stage.newton.newton` on the pins near contact (:func:`_near`),
    then every pin checked: the crank angles where a left-out pin closed are solved
    again from there with all pins (the answer is the whole problem's either way). If
    the near pins alone do not converge (a left-out pin that would have held a disc),
    the whole problem is solved from the start, so this fails only where it fails. The
    compliant disc's problem goes through :func:`_body_newton` (with numba and without
    friction, each crank angle's Newton compiled, :func:`_body_kernel`). The rigid discs' stage
    without friction (the compiled iteration's problems) starts the crank angles in runs
    from the one before: the NumPy reference in runs of
    :data:`~cyclomesh.stage.newton.WARM_RUN` (:func:`_warm`), the compiled iteration in
    one run over the revolution from the line through the two solutions before
    (:func:`cyclomesh.stage.kernel_newton.run`). ``state``: a dict that the compiled
    iteration fills with the state at the solution (:func:`_kernel_newton`,
    :func:`_body_kernel`), left empty otherwise."""
    if p.slip is None and (rigid or (p.body is None and law.k is None)):
        if compiled():
            # CYCLOMESH_KERNEL=numba: every pin in the compiled pass (an open pin costs it
            # a comparison, less than picking the near ones), so there is no check after
            return _kernel_newton(p, _evaluate, law, x, discs, rigid, phi, state)
        return _warm(p, law, x, discs, rigid, phi)
    if p.slip is None and not rigid and p.body is not None and p.body.pins is not None:
        if compiled() and law is not None and law.k is None and p.frozen is None:
            # CYCLOMESH_KERNEL=numba: each crank angle's Newton compiled, warm from the ones
            # before; the angles it gives up go to the NumPy path from their own start
            return _body_kernel(p, law, x, discs, phi, state)
        return _body_warm(p, law, x, discs, phi)
    return _solve_near(p, law, x, discs, rigid, phi)


def _warm(p: _Problem, law, x: FloatArray, discs: int, rigid: bool, phi: FloatArray):
    """:func:`_solve_near` in :data:`~cyclomesh.stage.newton.WARM_RUN` passes: pass j
    solves the crank angles j, j + WARM_RUN, ..., those of pass j > 0 started from the
    solution of the crank angle before (solved in pass j − 1) where the potential is lower
    there than at their own start and no pin is past its law (the compiled iteration
    warms every crank angle after the first, :func:`cyclomesh.stage.kernel_newton.run`;
    the root is the same to round-off)."""
    A = x.shape[0]
    for j in range(min(reference.WARM_RUN, A)):
        idx = np.arange(j, A, reference.WARM_RUN)
        sub = p.take(idx)
        if j:
            prev = x[idx - 1]
            e0, _, _, s0 = _evaluate(sub, law, x[idx], discs, rigid, gradient=False)
            e1, _, _, s1 = _evaluate(sub, law, prev, discs, rigid, gradient=False)
            use = ~s1["bad"] & (s0["bad"] | (e1 < e0))
            x[idx[use]] = prev[use]
        x[idx] = _solve_near(sub, law, x[idx], discs, rigid, phi[idx])
    return x


BODY_RUN = 4
"""Crank angles of the compliant disc's stage solved in a run from the one before
(:func:`_body_warm`): every BODY_RUN-th crank angle starts from its own start (the rigid
disc's loads, :func:`body_coupling`), each of the next BODY_RUN − 1 from the solution of
the crank angle before it."""


def _body_warm(p: _Problem, law, x: FloatArray, discs: int, phi: FloatArray) -> FloatArray:
    """The compliant disc's equilibrium (:func:`_solve_near` with :func:`_body_newton`) in
    :data:`BODY_RUN` passes, as :func:`_warm`: pass j solves the crank angles j,
    j + BODY_RUN, …, those of pass j > 0 started from the solution of the crank angle
    before (:func:`_body_carried`) where no pin is past its law there. Newton runs to the
    root at round-off, so the root does not depend on the start; a warm start takes
    about half the Newton steps of the own start (a light torque's disc unknowns
    converge linearly from the rigid disc's loads)."""
    A = x.shape[0]
    for j in range(min(BODY_RUN, A)):
        idx = np.arange(j, A, BODY_RUN)
        sub = p.take(idx)
        if j:
            prev = _body_carried(p, x, idx, 1)
            check = np.arange(idx.size)  # the starts whose pins are still to be checked
            if j > 1:  # the line through the two solutions before
                line = 2.0 * prev - _body_carried(p, x, idx, 2, prev)
                _, _, _, s2 = _evaluate(sub, law, line, discs, False, gradient=False)
                x[idx[~s2["bad"]]] = line[~s2["bad"]]
                check = np.flatnonzero(s2["bad"])
            if check.size:  # where no pin is past its law at the solution before
                part = sub.take(check)
                _, _, _, s1 = _evaluate(part, law, prev[check], discs, False, gradient=False)
                use = check[~s1["bad"]]
                x[idx[use]] = prev[use]
        x[idx] = _solve_near(sub, law, x[idx], discs, False, phi[idx])
    return x


def _body_kernel(
    p: _Problem,
    law,
    x: FloatArray | None,
    discs: int,
    phi: FloatArray,
    state: dict | None = None,
    start=None,
) -> FloatArray:
    """The compliant disc's equilibrium compiled (:func:`cyclomesh.stage.kernel_compliant.
    newton`: the reference's Newton with ``failed``, crank angle by crank angle, each warm
    from the ones before, its body unknowns carried by pin as :func:`_body_carried`); the
    crank angles it does not finish are solved by the NumPy path (:func:`_solve_near` with
    :func:`_body_newton`) from their own start. The root is the reference's to round-off.
    ``state``: where the kernel finished every crank angle, the state at the solution
    (:func:`cyclomesh.stage.kernel_compliant.newton`'s), as :func:`_kernel_newton`'s.
    ``start``: None, ``x`` holds every crank angle's own start; else ``x`` is None and
    ``start(idx)`` gives the own starts of the crank angles ``idx``, formed only where the
    kernel reads them (its ``start``; those of the angles it gives up among them)."""
    if start is not None:
        x = np.zeros((p.bl.shape[0], p.jacobian.shape[-1]))
    jacobian = p.jacobian if p.jacobian is not None else bearing_jacobian(p, discs, x.shape[1])
    settings = reference.kernel_settings(kernel_run(x.shape[0]), compliant=True)
    failed = kernel_compliant(p, law, x, discs, jacobian, settings, state=state, start=start)
    if np.any(failed):
        idx = np.flatnonzero(failed)
        x[idx] = _solve_near(p.take(idx), law, x[idx], discs, False, phi[idx])
    return x


def _body_carried(
    p: _Problem, x: FloatArray, idx: NDArray[np.int64], back: int, own: FloatArray | None = None
) -> FloatArray:
    """The start of the crank angles ``idx`` from the solution at ``idx − back``: the
    stage's and the supports' unknowns and the holes' body unknowns as they are there, each
    pin unknown (a pin's load × c0, :func:`body_coupling`) that pin's there, or ``own``'s
    (default: ``x[idx]``, the own start) where that pin was no candidate at ``idx − back``
    (the candidates shift with the crank angle; padding stays 0)."""
    b = p.body
    n, m = idx.size, x.shape[1]
    D, P = b.pins.shape[1:]
    z0 = m - b.size
    out = x[idx - back].copy()
    z_prev = x[idx - back, z0:].reshape(n, D, -1)
    z_own = (x[idx] if own is None else own)[:, z0:].reshape(n, D, -1)
    found, where = _positions(b.pins[idx], b.pins[idx - back])  # (n, D, P)
    carried = np.take_along_axis(z_prev[..., :P], where, axis=-1)
    z = out[:, z0:].reshape(n, D, -1)  # a view of out
    z[..., :P] = np.where(found, carried, z_own[..., :P])
    return out


def _solve_near(p: _Problem, law, x: FloatArray, discs: int, rigid: bool, phi: FloatArray):
    """The NumPy path of :func:`_solve`: the pins near contact, then every pin checked."""
    solver = newton if rigid or p.body is None else _body_newton
    if p.slip is not None:  # friction: the equations are not a potential's gradient
        solver = friction_newton
    q = _near(p, x, discs, rigid)
    start = x.copy()
    whole = solver if p.slip is None else _friction_solve  # on every pin
    try:
        x = solver(q, _evaluate, law, x, discs, rigid, phi)
    except ConvergenceError:
        return whole(p, _evaluate, law, start, discs, rigid, phi)
    closed = np.sum(_approach(p, x, discs, rigid) > 0.0, axis=-1)
    counted = np.sum(_approach(q, x, discs, rigid) > 0.0, axis=-1)  # the same arithmetic
    again = np.flatnonzero(np.any(closed != counted, axis=-1))
    if again.size:
        x[again] = whole(p.take(again), _evaluate, law, x[again], discs, rigid, phi[again])
    return x


def _friction_solve(p: _Problem, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi):
    """:func:`~cyclomesh.stage.friction.friction_newton` from ``x``; the crank angles where
    it cannot decrease its residual are solved again from the same start without friction
    (:func:`_solve`: Newton's method on the convex potential, whose line search converges
    from any start), then with friction by fixed-point iteration on the friction forces
    from that solution (:func:`~cyclomesh.stage.friction.friction_picard`, each step a
    convex minimisation with the friction forces as a dead load), finished and tested by
    :func:`friction_newton`; where that still fails, by continuation in the coefficients
    from the frictionless solution (:func:`~cyclomesh.stage.friction.friction_continuation`,
    which raises where it cannot reach them). The angles the first iteration solves keep
    its arithmetic.

    Why: at a light torque (the data sheet's ±0.1 % of T_r) with crank-hole errors beyond
    the bearings' play, the rigid-stage start is far from the solution (pin and bearing
    loads of 100 N against 10 N at the solution) and passes through states in which a
    disc floats inside its bearings' clearance with its pins open: the Jacobian there is
    singular (no stiffness along the disc's free motion), the Newton step is the
    regularisation's and the residual's norm, unlike the frictionless potential, has no
    descent along it (docs/stage.md, "Friction")."""
    start = x.copy()
    failed = np.zeros(x.shape[0], bool)
    x = friction_newton(p, evaluate, law, x, discs, rigid, phi, failed)
    if np.any(failed):
        idx = np.flatnonzero(failed)
        sub = p.take(idx)
        plain = dataclasses.replace(
            sub, slip=None, tangent_arm=None, drag=0.0, lubrication=None, friction_law=None
        )
        x0 = _solve(plain, law, start[idx], discs, rigid, phi[idx])
        again = np.zeros(idx.size, bool)  # Newton from the frictionless solution
        x1 = friction_newton(sub, evaluate, law, x0.copy(), discs, rigid, phi[idx], again)
        if np.any(again):  # the fixed point on the friction forces, finished by Newton
            j = np.flatnonzero(again)
            part, at = sub.take(j), phi[idx][j]
            minimise = newton if rigid or p.body is None else _body_newton
            xj = friction_picard(part, minimise, evaluate, law, x0[j], discs, rigid, at)
            last = np.zeros(j.size, bool)
            x1[j] = friction_newton(part, evaluate, law, xj, discs, rigid, at, last)
            if np.any(last):  # continuation in μ, the last resort (raises where it fails)
                k = j[last]
                x1[k] = friction_continuation(
                    sub.take(k), evaluate, law, x0[k], discs, rigid, phi[idx][k]
                )
        x[idx] = x1
    return x


def _kernel_newton(
    p: _Problem,
    evaluate,
    law,
    x: FloatArray,
    discs: int,
    rigid: bool,
    phi,
    state: dict | None = None,
    start=None,
    keep: dict | None = None,
):
    """:func:`~cyclomesh.stage.newton.newton` compiled
    (:func:`cyclomesh.stage.kernel_newton.newton`, and
    :func:`~cyclomesh.stage.kernel_newton.rigid_newton` for the rigid phase: each crank
    angle's iteration in one pass, the crank angles in order, each started from the
    solutions of the ones before, :data:`~cyclomesh.stage.kernel_newton.RUN`); the crank
    angles it cannot finish are solved by the reference from their start, which raises
    its own error if it fails. ``state`` receives the state at the solution (the kernels'
    ``state``; a crank angle the reference finished evaluated there). ``start`` (the
    bearing phase only): None, ``x`` holds every crank angle's start; else ``x`` is None
    and ``start(idx)`` gives the starts (len(idx), m) of the crank angles ``idx``, asked
    for where the kernel needs them only (:func:`~cyclomesh.stage.kernel_newton.newton`);
    ``keep``: the kernel's torque-free arrays kept there (its ``keep``)."""
    if start is not None:
        m = p.jacobian.shape[-1] if p.jacobian is not None else 1 + 3 * discs
        x = np.zeros((p.bl.shape[0], m))
    begin = None if x is None else x.copy()
    settings = reference.kernel_settings(kernel_run(x.shape[0]))
    found: dict = {}
    if rigid:
        failed = kernel_rigid_newton(p, x, discs, settings, found)
    else:
        jacobian = p.jacobian if p.jacobian is not None else bearing_jacobian(p, discs, x.shape[1])
        failed, started = kernel_newton(p, law, x, discs, jacobian, settings, found, start, keep)
    if np.any(failed):
        idx = np.flatnonzero(failed)
        if start is None:
            first = begin[idx]
        else:  # the own starts (the kernel leaves them in x where it asked for them)
            first = x[idx]
            ask = ~started[idx]
            if np.any(ask):
                first[ask] = start(idx[ask])
        sub = p.take(idx)
        x[idx] = newton(sub, evaluate, law, first, discs, rigid, phi[idx])
        if state is not None:  # the state of the crank angles the reference finished
            _, g, _, st = evaluate(sub, law, x[idx], discs, rigid, hessian=False)
            for key, value in found.items():
                value[idx] = g if key == "gradient" else st[key]
    if state is not None:  # (each crank angle's state as the kernel or the reference
        state.update(found)  # ended it: the same whichever others failed)
    return x


def _body_newton(p: _Problem, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi):
    """The compliant disc's equilibrium: :func:`~cyclomesh.stage.newton.newton` (its line
    search on the potential), and where that fails, :func:`_stationary` from the same
    start (the stationary point is a saddle in the body's unknowns, :func:`body_coupling`,
    so a descent on the potential can run away along them)."""
    start = x.copy()
    failed = np.zeros(x.shape[0], bool)
    x = newton(p, evaluate, law, x, discs, rigid, phi, failed)
    if np.any(failed):
        idx = np.flatnonzero(failed)
        x[idx] = _stationary(p.take(idx), evaluate, law, start[idx], discs, phi[idx])
    return x


def _stationary(p: _Problem, evaluate, law, x: FloatArray, discs: int, phi: FloatArray):
    """Newton's method on ∇Π = 0 with a backtracking line search on the residual ‖∇Π‖
    (:func:`~cyclomesh.stage.newton.residual_newton`: scaled unknowns and the convergence
    test of :func:`~cyclomesh.stage.newton.newton`, every residual below 1e-12·T/r_c or
    the round-off of the unknowns)."""

    def gradient(sub: _Problem, xa: FloatArray, jacobian: bool):
        _, g, H, st = evaluate(sub, law, xa, discs, False, hessian=jacobian)
        return g, H, st

    rot = rotation_index(x.shape[1], discs, p.supports, p.body.size)
    return residual_newton(p, gradient, x, phi, rot, "stage (compliant disc)", round_off=True)


def _mirrored(arr: FloatArray) -> FloatArray:
    """(A, D, n1) of the mirror problem → this problem's frame (angles, discs, pins)."""
    out = np.flip(arr, axis=0)
    out = np.take(out, mirror_index(out.shape[1]), axis=1)
    return out[..., mirror_index(out.shape[-1])]


def _single_rotation(prob: _Problem, torque: float, n1: int) -> FloatArray:
    """The rotation [rad] (A,) at which the stiffest pin alone would carry ``torque`` (an
    upper bound of the rigid stage's root, as in cyclomesh.loadsharing), inf where none
    can; the loaded flanks (pins 0 … n1 − 1) alone: an opposite flank's arm −l' ≤ 0."""
    A = prob.bl.shape[0]
    bl, arm, alpha, gamma = (v[..., :n1] for v in (prob.bl, prob.arm, prob.alpha, prob.gamma))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ok = np.isfinite(bl) & (arm > 0)
        f1 = np.where(ok, torque / np.where(ok, arm, 1.0), 1.0)
        log1 = np.log(f1)
        # on the stiffening branch of the law only (as cyclomesh.core.loadsharing)
        ok &= (gamma == 0) | (log1 < alpha / gamma - 1.0)
        d1 = f1 * (alpha - gamma * log1)
        single = np.where(ok, bl + d1 / np.where(ok, arm, 1.0), np.inf)
    return np.min(single.reshape(A, -1), axis=-1)


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
    cos, sin = np.cos(ang), np.sin(ang)
    hx, hy = holes.circle_radius * cos, holes.circle_radius * sin
    # hole errors (radial, tangential) of the disc frame → fixed frame
    cr, sr = cos[:, None, :], sin[:, None, :]
    ex = errs[0][None] * cr - errs[1][None] * sr
    ey = errs[0][None] * sr + errs[1][None] * cr

    # the opposite flanks (pins n1 … 2n1 − 1): the mirror problem's forward flanks
    # (_mirrored, as strided copies into the second half of each array)
    # (each array a view of one block, in the order of kernel_newton.PIN_BLOCK: the
    # compiled iteration's one argument for the seven)
    block = np.empty((len(PIN_BLOCK), A, D, 2 * n1))
    if compiled():  # CYCLOMESH_KERNEL=numba: the copies and selects below in one pass
        pins = (mesh.backlash, geo.moment_arm, mesh.normal_x, mesh.normal_y, mesh.alpha, mesh.gamma)
        mirrored = (other.geo.moment_arm, other.normal_x, other.normal_y, other.alpha, other.gamma)
        flank_block(
            block,
            tuple(np.reshape(v, (A, D, n1)) for v in pins),
            tuple(np.reshape(v, (A, D, n1)) for v in mirrored),
            geo.reverse_rotation,
            mesh.rest,
        )
        dmax_finish(block, _REACH)  # dmax as _pin_problem's, the same bits
        return _pin_problem(block, hx, hy, ex, ey, torque, holes.circle_radius, dmax=False)

    def flanks(name: str, this: FloatArray, that: FloatArray | None = None) -> FloatArray:
        out = block[PIN_BLOCK.index(name)]
        out[..., :n1] = this
        if that is not None:
            _mirror_into(out[..., n1:], that)
        return out

    arm = flanks("arm", geo.moment_arm, other.geo.moment_arm)
    alpha = flanks("alpha", mesh.alpha.reshape(A, D, n1), other.alpha.reshape(A, D, n1))
    gamma = flanks("gamma", mesh.gamma.reshape(A, D, n1), other.gamma.reshape(A, D, n1))
    bl = flanks("bl", mesh.backlash.reshape(A, D, n1))
    arm_o, alpha_o, gamma_o, bl_o = (v[..., n1:] for v in (arm, alpha, gamma, bl))
    with np.errstate(invalid="ignore"):
        np.subtract(geo.reverse_rotation, mesh.rest[:, None, None], out=bl_o)
    usable_o = np.isfinite(bl_o)
    usable_o &= np.isfinite(arm_o)
    usable_o &= arm_o >= 0
    usable_o &= np.isfinite(alpha_o)
    usable_o &= np.isfinite(gamma_o)
    unusable = ~usable_o
    np.copyto(bl_o, np.inf, where=unusable)
    np.negative(arm_o, out=arm_o)
    np.copyto(arm_o, -0.0, where=unusable)  # −np.where(usable, l', 0.0)
    np.copyto(alpha_o, 1.0, where=unusable)
    np.copyto(gamma_o, 0.0, where=unusable)
    nx = flanks("nx", mesh.normal_x, other.normal_x)
    np.copyto(nx[..., n1:], 0.0, where=unusable)
    ny = flanks("ny", mesh.normal_y, other.normal_y)
    np.negative(ny[..., n1:], out=ny[..., n1:])
    np.copyto(ny[..., n1:], 0.0, where=unusable)
    return _pin_problem(block, hx, hy, ex, ey, torque, holes.circle_radius)


def _pin_problem(block, hx, hy, ex, ey, torque, scale, dmax: bool = True) -> _Problem:
    """The :class:`_Problem` of the pins' ``block`` (:data:`PIN_BLOCK` order, ``dmax``
    formed here, or by the caller: ``dmax`` False) and the holes."""
    bl, arm, nx, ny, alpha, gamma, reach = (block[PIN_BLOCK.index(name)] for name in PIN_BLOCK)
    if dmax:
        # the largest approach of a trial, _REACH of the law's stiffest point
        # γ·exp(α/γ − 1) (inf without one), in place: the same operations in the same order
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            np.divide(alpha, gamma, out=reach)
            reach -= 1.0
            np.exp(reach, out=reach)
            np.multiply(gamma, reach, out=reach)
            finite = gamma > 0
            finite &= np.isfinite(reach)
            reach *= _REACH
        np.copyto(reach, np.inf, where=~finite)
    return _Problem(
        bl=bl,
        arm=arm,
        nx=nx,
        ny=ny,
        alpha=alpha,
        gamma=gamma,
        dmax=reach,
        hx=hx,
        hy=hy,
        ex=ex,
        ey=ey,
        torque=torque,
        scale=scale,
        pins=block,
    )


def _mirror_into(out: FloatArray, arr: FloatArray) -> None:
    """``out[...] = _mirrored(arr)`` for (A, D, n1) arrays, by strided copies: the crank
    angles reversed, disc d ← disc (−d) mod D, pin 0 ← pin 0 and pin i ← pin n1 − i."""
    rev = arr[::-1]
    D = arr.shape[1]
    for d in range(D):
        src = rev[:, (-d) % D]
        out[:, d, 0] = src[:, 0]
        out[:, d, 1:] = src[:, :0:-1]


def solve_direction(
    mesh: StackMesh,
    other: StackMesh,
    stage: StageDesign,
    errs: tuple[FloatArray, FloatArray],
    torque: float,
    supports: Supports | None = None,
    body: FreeDiscBody | None = None,
    friction: Friction | None = None,
    motion: float = 1.0,
    loading: float = 0.0,
    positions: bool = True,
    cache: dict | None = None,
    fields: frozenset[str] | None = None,
    keep: SupportedJacobians | None = None,
) -> dict[str, FloatArray]:
    """Stage under a positive torque in the mesh's frame (``other``: the mirror problem).

    ``supports``: the crankshafts and carrier from their geometry (:func:`stage_supports`
    in this direction's disc order), None: rigid (or the override springs of ``stage``).
    ``body``: the compliant disc (:class:`~cyclomesh.core.discbody.FreeDiscBody`; ``mesh``
    then carries the tooth of every pin), None: rigid discs. It needs a crank bearing.
    ``friction``: Coulomb friction at the pins and in the crank bearings
    (:mod:`cyclomesh.stage.friction`) in the sense ``motion`` (±1, a drive: the crank turns
    counter-clockwise in this frame with +1) or, with ``motion = 0``, ``loading`` (±1, a
    torsion test: the output turning counter-clockwise with +1); None: frictionless, the
    same arithmetic as without the argument. ``positions``: the discs that carry nothing
    get their canonical position (:mod:`cyclomesh.stage.floating`); False leaves them
    where the solve stopped (a caller that reports no positions saves the work).
    ``cache``: a dict kept by a caller that solves this direction (the same ``mesh``,
    ``other``, ``stage``, ``errs`` and ``supports``) at several torques: the problem's
    arrays and the bearings' Jacobian, which do not depend on the torque, are formed once
    (the same arrays, so the same numbers). ``fields``: the names of the returned dict
    wanted (None: all); the others are not computed, and each of them is the same, bit for
    bit, whatever else is asked (:func:`cyclomesh.stage.solve.solve` ``outputs``).
    ``keep``: with the compliant disc, a study's store of the supported bearing Jacobian
    (:class:`~cyclomesh.stage.assembly.SupportedJacobians`, the same for every ring of
    the study), which then is not formed again for each ring (the same numbers).
    """
    D, n1 = mesh.geo.rotation.shape[-2:]

    def want(name: str) -> bool:
        return fields is None or name in fields

    if cache is not None and "problem" in cache:  # the torque's arrays are the same
        prob = dataclasses.replace(cache["problem"], torque=torque)
    else:
        prob = _problem(mesh, other, stage.holes, errs, torque)
        if cache is not None:
            cache["problem"] = prob
    A = prob.bl.shape[0]
    fr = None
    if friction is not None:

        def flanks(name: str) -> FloatArray:  # (A, D, 2·n1): this flank, then the other's
            this = np.broadcast_to(getattr(mesh.geo, name), mesh.geo.rotation.shape)
            that = np.broadcast_to(getattr(other.geo, name), other.geo.rotation.shape)
            return np.concatenate([this, _mirrored(that)], -1)

        film = None
        if friction.lubricant is not None and motion != 0.0:
            film = Film.of_contacts(mesh.design, flanks("pin_radius"), flanks("curvature_radius"))
        fr = friction_arrays(
            prob, mesh, flanks("contact_radius"), flanks("cos_beta"), friction, motion, loading,
            film,
        )  # fmt: skip
        prob = dataclasses.replace(
            prob,
            slip=fr["slip"],
            tangent_arm=fr["tangent_arm"],
            drag=fr["drag"],
            lubrication=fr.get("lubrication"),
            friction_law=friction if "lubrication" in fr else None,
        )
    m = 1 + 3 * D

    def rotation_bound(sub: _Problem, phi: FloatArray) -> FloatArray:
        """The rotation (A,) at which the stiffest pin alone would carry T at each of
        ``sub``'s crank angles (an upper bound of the rigid mesh's root, as in
        cyclomesh.loadsharing), crank angle by crank angle."""
        # (the loaded flanks: an opposite flank's arm −l' ≤ 0 never carries T alone)
        if compiled():  # CYCLOMESH_KERNEL=numba: in one pass
            bound = single_rotation(sub.bl, sub.arm, sub.alpha, sub.gamma, torque, n1)
        else:
            bound = _single_rotation(sub, torque, n1)
        if not np.all(np.isfinite(bound)):
            bad = int(np.argmin(np.isfinite(bound)))
            raise ConvergenceError(
                f"crank angle {np.degrees(phi[bad]):.6g}°: no pin can carry the torque "
                "alone within the line-contact law (Eq. 20)"
            )
        return bound

    def rigid_stage(sub: _Problem, phi: FloatArray, known: FloatArray | None = None):
        """The rigid stage (θ_d = c, u = 0) of ``sub``'s crank angles from the rotation at
        which the stiffest pin alone would carry T (:func:`rotation_bound`; ``known``: that
        rotation of these crank angles, formed before): x, the pins' forces and
        stiffnesses, that bound."""
        x = np.zeros((sub.bl.shape[0], m))
        x[:, 0] = rotation_bound(sub, phi) if known is None else known
        x[:, 1::3] = x[:, [0]]
        bound = x[:, 0].copy()  # one pin alone: an upper bound of the rigid mesh's rotation
        st: dict = {}  # the compiled iteration's state at the solution, else evaluated here
        x = _solve(sub, None, x, D, True, phi, st)
        if not st:
            _, _, _, st = _evaluate(sub, None, x, D, True, hessian=False)
        return x, st["pin_force"], st["pin_stiffness"], bound

    def bearing_start(sub: _Problem, x: FloatArray, F: FloatArray, k_pin: FloatArray):
        """The start of the bearing phase of ``sub``'s crank angles from their rigid
        solution ``x``: the stiff limit's split of the pins' resultant onto the crank pins,
        the bearings' deflections under it, the discs' turns (x grows by the supports'
        unknowns, 0)."""
        weight = None
        x = x.copy()
        if compiled():  # CYCLOMESH_KERNEL=numba: the sums over the pins in one pass
            share, rfx, rfy, weight = disc_sums(F, sub.arm, sub.nx, sub.ny, k_pin)
            moment = -share
        else:
            rigid = _disc_loads(mesh, sub, F)  # pins on disc
            moment = -rigid["torque_share"]
            rfx, rfy = rigid["mesh_force_x"], rigid["mesh_force_y"]
        if fr is not None:  # the tangential forces T·t on the disc, their moment T·m
            tangential = -pin_slip(sub, F)[0] * F
            rfx = rfx + np.sum(tangential * -sub.ny, -1)
            rfy = rfy + np.sum(tangential * sub.nx, -1)
            moment = moment + np.sum(tangential * sub.tangent_arm, -1)
        # bearings carry the pins' resultant to the crank pins and the moment Σ F·l
        bfx, bfy = stiff_limit_split(sub.hx, sub.hy, sub.scale, rfx, rfy, moment)
        if stage.bearing is None:
            return x, bfx, bfy
        B = np.hypot(bfx, bfy)
        s = bearing_deflection(law, B)
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = np.where(B > 0, bfx / B * s, 0.0) - sub.ex
            dy = np.where(B > 0, bfy / B * s, 0.0) - sub.ey
        N = stage.holes.count
        L = sub.scale
        jx, jy = -sub.hy[:, None, :], sub.hx[:, None, :]
        omega = np.sum(dx * jx + dy * jy, -1) / (N * L * L)  # (A, D)
        ux, uy = dx.mean(-1), dy.mean(-1)
        # turn each disc so that its pins keep (in the least-squares sense, weighted by
        # their stiffness) the approach of the rigid solution despite the translation
        # k_pin: the pins' stiffness at the rigid solution (the rigid evaluate's, u = 0)
        if weight is not None:
            turn = disc_turn(k_pin, sub.arm, sub.nx, sub.ny, ux, uy, weight)
        else:
            shift = sub.nx * ux[..., None] + sub.ny * uy[..., None]
            weight = np.sum(k_pin * sub.arm * sub.arm, -1)
            turn = -np.sum(k_pin * sub.arm * shift, -1) / np.where(weight > 0, weight, np.inf)
        theta = x[:, 1::3] + turn
        x[:, 0] = np.mean(theta - omega, -1)
        x[:, 1::3] = x[:, [0]] + omega
        x[:, 2::3] = ux
        x[:, 3::3] = uy
        if supports is not None:
            x = np.concatenate([x, np.zeros((x.shape[0], supports.extra(D, N)))], axis=-1)
        return x, bfx, bfy

    law = None if stage.bearing is None else BearingLaw(stage.bearing, stage.crankshaft_stiffness)
    # ``fast``: numba, no friction, a bearing law without a series spring: the bearing
    # start in one compiled pass (``start``). ``lazy``: that with the rigid discs, whose
    # compiled iteration asks for the start of the crank angles it cannot start from the
    # ones before (the first, mostly): the others' rigid solutions (unless the mesh's TE
    # is wanted), splits and deflections are not formed
    fast = compiled() and law is not None and law.k is None and fr is None
    lazy = fast and body is None
    # ``lazy_body``: ``fast`` with the compliant disc (whose compiled Newton asks for the
    # own starts it reads, :func:`_body_starts`): the rigid stage and the bearing start
    # formed for those crank angles only (the rotation bound, which the coupling's reach
    # reads, for all)
    lazy_body = fast and body is not None and prob.frozen is None
    if lazy and not want("mesh_te"):
        x, F, k_pin, bound, mesh_te = None, None, None, None, None
    elif lazy_body and not want("mesh_te"):
        x, F, k_pin, mesh_te = None, None, None, None
        bound = rotation_bound(prob, mesh.phi)
    else:
        x, F, k_pin, bound = rigid_stage(prob, mesh.phi)
        mesh_te = transmission_error(mesh.rest, x[:, 0])
    if law is not None:
        unsupported, rigid = prob, (x, F, k_pin)  # the problem before the supports

        def start(idx: NDArray[np.int64], taken: _Problem | None = None) -> FloatArray:
            """The bearing phase's start of the crank angles ``idx``; ``taken``: the
            problem at them (``prob.take(idx)``, supported or not: the same arrays), if
            the caller has it."""
            if lazy and rigid[0] is not None:  # the few arrays of the compiled start alone
                sub, block = unsupported, pin_block(unsupported)[:, idx]  # (the same values)
                holes = tuple(v[idx] for v in (sub.hx, sub.hy, sub.ex, sub.ey))
            elif taken is not None:
                sub = dataclasses.replace(taken, supports=unsupported.supports)
                block, holes = None, None
            else:
                sub, block, holes = unsupported.take(idx), None, None
            if rigid[0] is None:  # (the rotation bound of every crank angle, if formed:
                # each crank angle's on its own, the same numbers)
                known = None if bound is None else bound[idx]
                xr, Fr, kr, _ = rigid_stage(sub, mesh.phi[idx], known)
            else:
                xr, Fr, kr = (v[idx] for v in rigid)
            if fast:  # numba, no friction, no series spring (the rigid discs' lazy start,
                # and the compliant disc's, lazy_body): in one pass, the NumPy start's bits
                if block is None:
                    block, holes = pin_block(sub), (sub.hx, sub.hy, sub.ex, sub.ey)
                got = compiled_start(
                    block, Fr, kr, xr, holes, sub.scale, law.rs, LOAD_EXPONENT, SPLIT_ITERATIONS
                )  # fmt: skip
                if got is not None:  # (else the NumPy start, which raises)
                    if supports is None:
                        return got
                    extra = supports.extra(D, stage.holes.count)
                    return np.concatenate([got, np.zeros((got.shape[0], extra))], axis=-1)
                sub = unsupported.take(idx)
            return bearing_start(sub, xr, Fr, kr)[0]

        x = None if lazy or lazy_body else start(np.arange(A))
        if supports is not None:
            prob = dataclasses.replace(prob, supports=supports)
        m_sup = m + (0 if supports is None else supports.extra(D, stage.holes.count))
        own = None
        if body is not None and lazy_body:
            coupling, own = _body_starts(
                mesh, prob, body, _BODY_REACH * bound, law, start, cache
            )  # fmt: skip
            prob = dataclasses.replace(prob, body=coupling)
        elif body is not None:  # the compliant disc, from the rigid disc's loads
            _, _, _, begin = _evaluate(prob, law, x, D, False, gradient=False)
            coupling, z = body_coupling(mesh, prob, body, _BODY_REACH * bound, begin, cache)
            prob = dataclasses.replace(prob, body=coupling)
            x = np.concatenate([x, z], axis=-1)
        if supports is not None or body is not None:
            if body is not None:  # the body's columns depend on the torque, the others not
                supported = None if cache is None else cache.get("supported")
                if supported is None and (cache is not None or keep is not None):
                    bare = dataclasses.replace(prob, body=None)
                    if keep is not None:  # a study's, kept between its rings
                        supported = keep(bare, D, m_sup)
                    else:
                        supported = bearing_jacobian(bare, D, m_sup)
                    if cache is not None:
                        cache["supported"] = supported
                jacobian = bearing_jacobian(prob, D, m_sup + coupling.size, supported)
            elif cache is None or "jacobian" not in cache:
                jacobian = bearing_jacobian(prob, D, m_sup if x is None else x.shape[1])
                if cache is not None:
                    cache["jacobian"] = jacobian
            else:
                jacobian = cache["jacobian"]
            prob.jacobian = jacobian
        st = {}
        if lazy:
            keep = cache if body is None else None  # this direction's (the same jacobian)
            x = _kernel_newton(prob, _evaluate, law, None, D, False, mesh.phi, st, start, keep)
        elif own is not None:
            x = _body_kernel(prob, law, None, D, mesh.phi, st, own)
        else:
            x = _solve(prob, law, x, D, False, mesh.phi, st)
        if st:  # the compiled iteration's state at the solution (the rigid discs' stage)
            g = st.pop("gradient")
            st["bearing_part"] = st["deflection"]  # no series spring in the kernel
            if prob.supports is not None:  # as _evaluate_supported's
                sup, N = prob.supports, stage.holes.count
                nw = 2 * D * N if sup.stiffness is not None else 0
                base = 1 + 3 * D
                st["shaft_deflection"] = (
                    x[:, base : base + nw].reshape(A, D, N, 2) if nw else np.zeros((A, D, N, 2))
                )
                st["end_plate"] = x[:, base + nw] if sup.carrier is not None else np.zeros(A)
        else:
            _, g, _, st = _evaluate(prob, law, x, D, False, hessian=False)
        F = st["pin_force"]
        bfx, bfy = st["bearing_fx"], st["bearing_fy"]
        deflection = st["deflection"]
        sb = st["bearing_part"]
        if fr is not None:
            q, _ = friction_terms(prob, x, D, False, st, law, False)
            g = g - q
        residual = np.max(np.abs(g), axis=-1) if want("residual") else None
        work = _work(prob, stage, x, D, st) if any(want(n) for n in _WORK) else {}
        if fr is not None and want("work_friction"):
            work["work_friction"] = _friction_work(prob, x, q, D)
        # a disc that carries nothing: no load, its canonical position. The compliant
        # disc's too: without load its body is undeformed (z = 0), so its free set is the
        # rigid disc's, and the rigid problem's pin gaps and holes are its own
        idle = floating_discs(F, np.hypot(bfx, bfy), FLOATING_LOAD * abs(torque) / prob.scale)
        if np.any(idle):  # the solve's loads on it are its round-off: reported as 0
            F = np.where(idle[..., None], 0.0, F)
            bfx = np.where(idle[..., None], 0.0, bfx)
            bfy = np.where(idle[..., None], 0.0, bfy)
        if positions and any(want(name) for name in _POSITIONS):
            x, idle_deflection = canonical_positions(
                prob, x, D, idle, 0.5 * stage.bearing.clearance
            )
            deflection = deflection.copy()
            deflection[idle] = idle_deflection
    else:  # rigid bearings: the stiff limit's split is the bearings' loads
        x, bfx, bfy = bearing_start(prob, x, F, k_pin)
        deflection = np.zeros_like(bfx)
        sb = deflection
        work = _work(prob, stage, x, D, {"pin_force": F})
        g = _evaluate(prob, None, x, D, True, hessian=False)[1]
        if fr is not None:
            q, _ = friction_terms(prob, x, D, True, {"pin_force": F}, None, False)
            g = g - q
            work["work_friction"] = _friction_work(prob, x, q, D)
        residual = np.max(np.abs(g @ reducer(D)), -1)
        st = {"pin_force": F, "bearing_fx": bfx, "bearing_fy": bfy}
    c, theta, ux, uy = _unpack(x, D)
    out: dict[str, FloatArray] = {}
    if fr is not None and motion != 0.0 and any(want(name) for name in FRICTION_FIELDS):
        if prob.lubrication is not None:  # the coefficients of the returned loads
            fr = {**fr, **lubricated_state(prob, F)}
        out.update(_friction_fields(prob, mesh, fr, st, motion, friction.speed, n1))
    loaded = [n for n in ("groove_load", "contact_stress", "groove_stress", "contacts") if want(n)]
    sums = [n for n in DISC_FIELDS if want(n)]
    if compiled() and (sums or len(loaded) > 1 or (loaded and fields is None)):
        # CYCLOMESH_KERNEL=numba: the contact fields and the discs' sums in one pass
        # (the same bits as contact_fields' and disc_sums' below)
        out.update(
            stage_fields(
                F, pin_block(prob), mesh.geo, mesh.design, CONTACT_LOAD_FRACTION, {*loaded, *sums}
            )
        )
        loaded, sums = [], []
    if fields is not None and loaded == ["contact_stress"]:  # the loaded pins' alone
        if cache is None or "geometry" not in cache:  # the stresses' geometry, flat
            geometry = [
                np.ascontiguousarray(np.broadcast_to(getattr(mesh.geo, name), (A, D, n1)))
                for name in ("pin_radius", "curvature_radius", "cos_beta")
            ]
            if cache is not None:
                cache["geometry"] = geometry
        else:
            geometry = cache["geometry"]
        out["contact_stress"] = _contact_stress(mesh.design, geometry, F[..., :n1])
    elif loaded:
        out.update(
            contact_fields(loaded, mesh.design, mesh.geo, F[..., :n1], stack_axes=2)
        )  # per disc, against the stack
    if sums:
        disc = _disc_loads(mesh, prob, F)
        out.update(
            torque_share=disc["torque_share"],
            mesh_fx=disc["mesh_force_x"],
            mesh_fy=disc["mesh_force_y"],
        )
    if want("max_roller_load"):
        out["max_roller_load"] = (
            _max_roller_load(stage.bearing, sb)
            if stage.bearing is not None
            else np.full(deflection.shape, np.nan)
        )
    plain = {
        "pin_load": lambda: F[..., :n1],
        "opposite_pin_load": lambda: F[..., n1:],
        "bearing_fx": lambda: bfx,
        "bearing_fy": lambda: bfy,
        "bearing_deflection": lambda: deflection,
        "disc_translation_x": lambda: ux,
        "disc_translation_y": lambda: uy,
        "disc_te": lambda: transmission_error(mesh.rest[:, None], theta),
        "carrier_te": lambda: transmission_error(mesh.rest, c),
        "twist": lambda: c,
        "mesh_te": lambda: mesh_te,
        "residual": lambda: residual,
    }
    out.update({name: value() for name, value in plain.items() if want(name)})
    out.update({name: value for name, value in work.items() if want(name)})
    return out


def _max_roller_load(rs, s: FloatArray) -> FloatArray:
    """The largest roller load Q_max = K_n·δ_max^(10/9) [N] of each crank bearing at its
    raceway displacement ``s`` ≥ 0 [m] (Harris & Kotzalas, Ch. 7): the largest of
    :func:`~cyclomesh.stage.bearing.roller_loads`; with numba, the roller of the largest
    cos ψ_j alone (s·cos ψ_j − P_d/2, its clipping at 0 and the power are monotone, so
    the same compression; the same power to its last bit, a fourteenth of the work)."""
    if not compiled():
        return np.max(roller_loads(rs, s), axis=-1)
    largest = np.max(np.cos(rs.angles))
    delta = np.maximum(np.asarray(s, float) * largest - 0.5 * rs.clearance, 0.0)
    return rs.constant * delta**LOAD_EXPONENT


_POSITIONS = ("disc_translation_x", "disc_translation_y", "disc_te", "bearing_deflection")
"""The fields that read the positions of the discs (the floating discs' canonical ones)."""
FRICTION_FIELDS = (
    "friction_force",
    "power_loss_tooth",
    "power_loss_groove",
    "sliding_velocity_tooth",
    "sliding_velocity_groove",
    "friction_coefficient",
    "film_parameter",
    "power_loss_bearing",
    "input_power",
    "approach_power",
)
"""The friction fields of a stage (:func:`_friction_fields`,
:attr:`cyclomesh.stage.solve.Stage.friction`)."""


def _contact_stress(
    design: PairDesign, geometry: list[FloatArray], force: FloatArray
) -> FloatArray:
    """The pin–tooth pressure [Pa] (A, D, n1) of the loaded pins (F > 0) of
    :func:`~cyclomesh.core.fields.contact_stresses` (Eq. 24 of [1]), 0 at the others:
    the same formula element by element on the loaded pins alone, so the same bits as
    :func:`~cyclomesh.core.fields.contact_fields` at a third of the pins or less.
    ``geometry``: the contacts' pin radius, curvature radius and cos β, (A, D, n1) each,
    C-contiguous."""
    flat = np.ascontiguousarray(force).reshape(-1)
    stress = np.zeros(flat.shape)
    at = np.flatnonzero(flat > 0.0)
    if at.size:
        rp, rc, cb = (np.take(v.reshape(-1), at) for v in geometry)
        sub = UnloadedContact(
            **{
                **dict.fromkeys(UnloadedContact.__dataclass_fields__),
                "pin_radius": rp,
                "curvature_radius": rc,
                "cos_beta": cb,
            }
        )
        stress[at] = contact_stresses(sub, design, np.take(flat, at))[1]
    return stress.reshape(force.shape)


def _friction_work(p, x: FloatArray, q: FloatArray, discs: int) -> FloatArray:
    """−x·Q [J], (A,): with friction x·∇Π = x·Q at equilibrium, so T·c = Σ parts − x·Q
    (:func:`_work`): the friction's share of the output twist (Q acts on the discs' rows
    only: their rotations, scaled by r_c, and translations)."""
    xs = x[:, : 1 + 3 * discs].copy()
    xs[:, 0] *= p.scale
    xs[:, 1::3] *= p.scale
    return -np.sum(xs * q[:, : 1 + 3 * discs], axis=-1)


def _friction_fields(p, mesh, fr, st, motion, speed, n1) -> dict[str, FloatArray]:
    """The friction results of a drive, per pin both flanks together (A, D, n1)."""
    terms = power_terms(p, mesh, fr, st, motion, speed)

    def fold(value):
        return value[..., :n1] + value[..., n1:]

    loss, groove = terms["power_loss_pin"], fr["groove"]
    sliding = np.abs(fr["velocity"]) * speed
    return {
        "friction_force": fold(fr["mu"] * st["pin_force"]),
        "power_loss_tooth": fold(np.where(groove, 0.0, loss)),
        "power_loss_groove": fold(np.where(groove, loss, 0.0)),
        "sliding_velocity_tooth": np.where(groove, 0.0, sliding)[..., :n1],
        "sliding_velocity_groove": np.where(groove, sliding, 0.0)[..., :n1],
        "friction_coefficient": fr["mu"][..., :n1],
        "film_parameter": fr["film_parameter"][..., :n1],
        "power_loss_bearing": terms["power_loss_bearing"],
        "input_power": terms["input_power"],
        "approach_power": terms["approach_power"],
    }


WORK_PARTS = ("mesh", "disc_body", "crank_bearings", "crankshafts", "carrier", "hole_errors")
"""Parts of the output twist (:func:`_work`; the carrier's override spring adds T²/k_c)."""
_WORK = tuple(f"work_{name}" for name in WORK_PARTS)
"""The fields of :func:`_work`."""


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
    zero = np.zeros_like(c)
    if compiled() and st.get("pin_shift") is None:  # CYCLOMESH_KERNEL=numba: one pass
        work_mesh = mesh_work(pin_block(p), F, x, discs)
    else:
        work_mesh = _mesh_work(p, F, c, theta, ux, uy, st)
    out = {
        "work_mesh": work_mesh,
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


def _mesh_work(p, F, c, theta, ux, uy, st) -> FloatArray:
    """The mesh's part of :func:`_work` [J] (A,) with NumPy (the reference)."""
    usable = np.isfinite(p.bl)
    lin = np.where(
        usable,
        p.arm * (theta[..., None] - np.where(usable, p.bl, 0.0))
        + p.nx * ux[..., None]
        + p.ny * uy[..., None],
        0.0,
    )
    lin0 = np.where(usable, -p.arm * np.where(usable, p.bl, 0.0), 0.0)
    if st.get("pin_shift") is not None:  # the compliant disc: δ includes −(C'λ)_pin
        lin = lin - st["pin_shift"]
    return np.sum(F * (lin - lin0), axis=(-2, -1))


def _disc_loads(mesh: StackMesh, prob: _Problem, force: FloatArray) -> dict[str, FloatArray]:
    """Torque share and mesh force of every disc from the forces on both flanks (A, D, 2·n1)
    (numba: the sums over the pins in one pass, :func:`~cyclomesh.stage.kernel.disc_sums`,
    in order where NumPy's are pairwise: the same to round-off)."""
    if compiled():
        share, fx, fy, _ = disc_sums(force, prob.arm, prob.nx, prob.ny, force)
        return {"torque_share": share, "mesh_force_x": fx, "mesh_force_y": fy}
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
        if fields[name] is not None:  # (a mirror mesh without rests: drive.mesh._mesh)
            fields[name] = fields[name][ring]
    return StackMesh(**{**fields, "geo": geo, "ring_shape": ()})
