"""Friction in the RV stage's equilibrium (:mod:`cyclomesh.stage.equilibrium`): the
Coulomb forces of :mod:`cyclomesh.core.friction` at the pins and the crank bearings'
friction moments, and Newton's method on the equilibrium equations they make
non-conservative.

Forces
------
Pin i of disc d pushes the disc with −F_i·n_i + T_i·t_i, t = ẑ×n, T_i = −μ_eff,i·s_i·F_i
(:func:`cyclomesh.core.friction.torque_arm`, the mesh-level model of docs/efficiency.md):
μ_eff the coefficient of the sliding interface (pin–tooth, or pin–groove for a rolling pin,
:func:`~cyclomesh.core.friction.effective_coefficient`), s_i = sgn(v_d·t) the sliding
direction of the theoretical motion. In a drive (``motion`` ±1) the disc's material
point at the contact moves along t at ω·(e·û(φ_d)·n − m/n2)
(:func:`~cyclomesh.core.friction.tangential_velocity`, φ_d the disc's own eccentric
angle); in a torsion test (the crank held, ``loading`` ±1 the sense of the output's turn)
the disc turns about its centre and v·t = loading·m, m = r·n > 0 the tangential force's
arm about the disc centre. The opposite flank of a tooth space (closed by a translation
only) has its own normal, arm and m, and the same law.

A virtual motion (δθ_d, δu_d) of disc d moves the contact point by δu + δθ·ẑ×r, so the
tangential force does the virtual work T·(m·δθ + t·δu): in the scaled unknowns of
:func:`~cyclomesh.stage.assembly.evaluate` (rotations × r_c) the generalised force
Q = Σ_i T_i·(m_i/r_c, t_x, t_y) on the disc's block. Each crank bearing k of disc d adds the
couple C_dk = s_b·μ_b·d/2·B_dk on the disc (SKF's constant-coefficient model,
:func:`~cyclomesh.core.friction.bearing_moment`, B_dk its load; s_b the sense of the crank
pin's turn against the hole: ``motion`` in a drive, −``loading`` in a torsion test, as
:mod:`cyclomesh.drive.friction`); its reaction goes to the crankshaft, held by the input.

With the compliant disc (:class:`~cyclomesh.stage.assembly.Body`) a pin's approach has
the body's displacement −(C'·λ)_i, so ∂δ_i/∂z = −pin_w enters ∂Q/∂x below; the body is
loaded by the pins' normal forces and the hole centres' forces (issue 17's coefficients),
not by the pins' tangential forces μ·F, whose own deformation of the disc is left out
(the disc's rigid motion and the bearing loads carry them).

The equilibrium is ∇Π(x) − Q(x) = 0 (Π the stage's potential); with Q(x) from the pin
forces F(δ(x)) and the bearing loads B(s(x)) its exact Jacobian ∇²Π − ∂Q/∂x,

    ∂Q/∂x = Σ_i b_i·(−μ_i·s_i·k_i)·a_iᵀ + Σ_dk e_θd·(s_b·μ_b·d/(2·r_c))·k_b,dk·(ĉ_dkᵀ·G_dk),

(a_i = ∂δ_i/∂x and b_i = (m_i/r_c, t_i) on the disc's block, k_i = dF/dδ, k_b = dB/ds, ĉ the
bearing force's direction, G = ∂d/∂x of :func:`~cyclomesh.stage.assembly.bearing_jacobian`),
is not symmetric: :func:`friction_newton` takes full Newton steps with a backtracking line
search on the residual norm, to the convergence test of the frictionless stage.

Power
-----
The virtual power of the theoretical motion, disc by disc and for the carrier with the
crankshafts (ideal support bearings), gives the input power exactly:

    P_in = −Σ_dk f_dk·v_H,dk + ω·s·Σ_d C_d + T·ω·s/n2
         = T·ω·s/n2 + Σ μ·F·|v·t|·ω + Σ_dk μ_b·d/2·B_dk·ω·(1 + 1/n2) + Σ F·(v·n)·ω,

f_dk the force of disc d on crank pin k, v_H its hole centre's velocity, s = ``motion``
(:func:`power_terms`; the last term, the power of a non-conjugate profile's approach,
averages out over a revolution). The crank pin turns against its hole at ω·(1 + 1/n2).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] J. W. Sensinger, J. Mech. Des. 135 (2013) 071006 (friction at the pins).
[3] SKF, Rolling bearings catalogue (2018), "Friction": M = 0.5·μ·P·d.
[4] J. Nocedal, S. J. Wright, Numerical Optimization, 2nd ed., Springer 2006, §11.2
    (Newton's method on nonlinear equations with a line search on the residual).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.friction import (
    Friction,
    coefficients,
    effective_coefficient,
    loaded_film_parameter,
    lubrication_constants,
    normal_moment,
)
from cyclomesh.core.lubrication import Film
from cyclomesh.exceptions import ConvergenceError, DesignError
from cyclomesh.stage.assembly import Problem, bearing_jacobian
from cyclomesh.stage.newton import reducer, residual_newton, rotation_index

__all__ = [
    "friction_arrays",
    "friction_terms",
    "friction_newton",
    "friction_continuation",
    "friction_picard",
    "power_terms",
    "check_stage_friction",
]

FloatArray = NDArray[np.float64]


def check_stage_friction(friction: Friction, bearing: object) -> None:
    """One-line :class:`DesignError` for friction the stage does not model (the rigid and
    the compliant disc both take it: the module doc)."""
    if friction.bearing > 0 and bearing is None:
        raise DesignError(
            "friction.bearing_coefficient with [stage] needs [stage.crank_bearing] (rigid "
            "crank bearings carry a statically indeterminate split); add the crank bearing "
            "or set bearing_coefficient = 0"
        )


def friction_arrays(
    p: Problem,
    mesh,
    contact_radius: FloatArray,
    cos_beta: FloatArray,
    friction: Friction,
    motion: float,
    loading: float,
    film: Film | None = None,
) -> dict:
    """The friction fields of :class:`~cyclomesh.stage.assembly.Problem` for one direction:
    ``slip`` μ_eff·s and ``tangent_arm`` m of every pin (A, D, 2·n1), ``drag`` s_b·μ_b·d/2
    [m], with a lubricant in a drive ``lubrication`` (the load-independent parts of the
    lubricated coefficient of every pin, :func:`~cyclomesh.core.friction.lubrication_constants`,
    with ``cos_beta`` and the sliding sense ``sign``; ``slip`` is then the boundary
    coefficient's, replaced by μ(F) wherever the loads are known: :func:`pin_slip`), and (not
    in the problem) ``velocity`` v·t per unit input speed [m/rad], ``groove`` (the pin–groove
    interface slides), ``mu`` and ``film_parameter`` (0: no lubricant).

    ``contact_radius`` and ``cos_beta``: |r| of every contact from the disc centre [m] and
    cos β, both flanks (A, D, 2·n1); the normals are the problem's. ``film``: the pin
    contacts' radii and moduli (:meth:`~cyclomesh.core.lubrication.Film.of_contacts`), both
    flanks, for the mixed regime of a lubricant (None: Benedict–Kelley's alone, as the mesh
    solver without a film)."""
    A, D, P = p.bl.shape
    usable = np.isfinite(p.bl)
    m = np.where(usable, normal_moment(contact_radius, np.where(usable, p.arm, 0.0)), 0.0)
    if motion == 0.0:  # torsion test: the disc turns about its centre
        velocity = loading * m
    else:
        teeth = mesh.design.teeth
        e = np.asarray(mesh.eccentricity if mesh.eccentricity is not None else 0.0, float)
        if e.size != 1:
            raise DesignError(
                "friction with [stage] solves one ring at a time (no eccentricity errors per ring)"
            )
        e = float(e.reshape(-1)[0]) if mesh.eccentricity is not None else mesh.design.eccentricity
        crank = mesh.phi[:, None] + 2.0 * np.pi * np.arange(D) / D  # (A, D)
        c, s = np.cos(crank)[..., None], np.sin(crank)[..., None]
        velocity = motion * (e * (c * p.nx + s * p.ny) - m / teeth)
    sign = np.sign(velocity)
    mu, groove = effective_coefficient(friction, cos_beta)
    mu = np.broadcast_to(mu, (A, D, P))
    sense = motion if motion != 0.0 else -loading
    out = {
        "slip": np.where(usable, mu * sign, 0.0),
        "tangent_arm": m,
        "drag": sense * 0.5 * friction.bearing * friction.bearing_diameter,
        "velocity": np.where(usable, velocity, 0.0),
        "groove": np.broadcast_to(groove, (A, D, P)),
        "mu": np.where(usable, mu, 0.0),
        "film_parameter": np.zeros((A, D, P)),
    }
    if friction.lubricant is not None and motion != 0.0:
        speed = np.abs(out["velocity"]) * friction.speed
        cb = np.where(usable, cos_beta, 1.0)
        lub = lubrication_constants(friction, cb, speed, mesh.design.width, film)
        lub["cos_beta"] = cb
        lub["sign"] = np.where(usable, sign, 0.0)
        out["lubrication"] = lub
    return out


def pin_slip(p: Problem, force: FloatArray) -> tuple[FloatArray, FloatArray]:
    """μ_eff·s of every pin at the pin loads ``force`` [N] and its derivative
    d(μ_eff·F)/dF·s (the tangential force is T = −μ_eff·s·F): the problem's Coulomb
    ``slip`` twice, or with a lubricant the coefficient of these loads
    (:func:`~cyclomesh.core.friction.coefficients`, Benedict–Kelley's in the mixed regime)
    and μ_eff + F·dμ_eff/dF, its elasticity added (the Jacobian of the lubricated
    tangential forces). A problem's ``friction_scale`` below 1 (a step of
    :func:`friction_continuation`) multiplies both."""
    if p.lubrication is None:
        slip, dslip = p.slip, p.slip
    else:
        lub = p.lubrication
        mu, _, el = coefficients(p.friction_law, lub["cos_beta"], force, constants=lub)
        slip, dslip = mu * lub["sign"], (mu + el) * lub["sign"]
    if p.friction_scale != 1.0:
        return p.friction_scale * slip, p.friction_scale * dslip
    return slip, dslip


def lubricated_state(p: Problem, force: FloatArray) -> dict[str, FloatArray]:
    """``mu`` μ_eff, ``groove`` (the pin–groove interface slides) and ``film_parameter`` λ
    of the sliding interface of every pin at the loads ``force`` [N] of a lubricated
    problem (as :class:`~cyclomesh.drive.friction.DriveFriction` reports them: the
    boundary coefficient and λ = 0 where a pin carries no load)."""
    lub = p.lubrication
    mu, groove, _ = coefficients(p.friction_law, lub["cos_beta"], force, constants=lub)
    return {
        "mu": np.where(lub["sign"] != 0.0, mu, 0.0),
        "groove": groove,
        "film_parameter": loaded_film_parameter(lub, force, groove),
    }


def friction_terms(p: Problem, x: FloatArray, discs: int, rigid: bool, state: dict, law, jac=True):
    """Generalised friction forces Q (n, m) in the scaled unknowns and ∂Q/∂x (n, m, m)
    (module doc); ``state``: :func:`~cyclomesh.stage.assembly.evaluate`'s at x. ``rigid``:
    the rotations' rows only (the reduced problem), no bearing moment."""
    n, m = x.shape
    L = p.scale
    F = state["pin_force"]
    slip, dslip = pin_slip(p, F)
    T = -slip * F  # tangential force on the disc along t, (n, D, P)
    if rigid:
        b = np.stack([p.tangent_arm / L], axis=-2)  # (n, D, 1, P)
        a = np.stack([p.arm / L], axis=-2)
    else:
        b = np.stack([p.tangent_arm / L, -p.ny, p.nx], axis=-2)
        a = np.stack([p.arm / L, p.nx, p.ny], axis=-2)
    Q = np.zeros((n, m))
    dQ = np.zeros((n, m, m)) if jac else None
    q_pin = np.matmul(b, T[..., None])[..., 0]  # (n, D, a)
    if jac:
        dT = -dslip * state["pin_stiffness"]
        dq_pin = np.matmul(b * dT[..., None, :], np.swapaxes(a, -1, -2))  # (n, D, a, a)
    size = b.shape[-2]
    body = None if rigid else p.body
    for d in range(discs):
        block = slice(1 + 3 * d, 1 + 3 * d + size)
        Q[:, block] += q_pin[:, d]
        if jac:
            dQ[:, block, block] += dq_pin[:, d]
        if jac and body is not None:  # ∂δ/∂z = −pin_w: the body's unknowns move the loads
            lam = body.energy.shape[-1]
            zi = slice(m - body.size + d * lam, m - body.size + (d + 1) * lam)
            dQ[:, block, zi] -= np.matmul(b[:, d] * dT[:, d, None, :], body.pin_w[:, d])
    if rigid or p.drag == 0.0:
        return Q, dQ
    drag = p.drag if p.friction_scale == 1.0 else p.friction_scale * p.drag
    fx, fy = state["bearing_fx"], state["bearing_fy"]
    B = np.hypot(fx, fy)
    for d in range(discs):
        Q[:, 1 + 3 * d] += drag * np.sum(B[:, d], axis=-1) / L
    if jac:
        _, kb, _, _ = law.evaluate(state["deflection"], stiffness=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            cx = np.where(B > 0, fx / B, 0.0)
            cy = np.where(B > 0, fy / B, 0.0)
        G = p.jacobian if p.jacobian is not None else bearing_jacobian(p, discs, m)
        ds = cx[..., None] * G[..., 0, :] + cy[..., None] * G[..., 1, :]  # (n, D, N, m)
        for d in range(discs):
            dQ[:, 1 + 3 * d, :] += drag / L * np.sum(kb[:, d, :, None] * ds[:, d], axis=-2)
    return Q, dQ


def friction_newton(
    p: Problem, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi, failed=None
):
    """Newton's method on ∇Π − Q = 0 with the exact Jacobian and a backtracking line search
    on the residual's norm ([4]); scaled unknowns and the convergence test of
    :func:`~cyclomesh.stage.newton.newton` (every residual below 1e-12·T/r_c or the
    round-off of the unknowns). ``rigid``: the reduced problem (θ_d = c, u = 0).
    ``failed``: as :func:`~cyclomesh.stage.newton.residual_newton`'s (the crank angles it
    cannot solve marked there instead of an error)."""
    reduce = reducer(discs) if rigid else None

    def residual(sub: Problem, xa: FloatArray, jac: bool):
        _, g, H, st = evaluate(sub, law, xa, discs, rigid, hessian=jac)
        Q, dQ = friction_terms(sub, xa, discs, rigid, st, law, jac)
        r = g - Q
        J = H - dQ if jac else None
        if rigid:
            r = r @ reduce
            J = np.einsum("im,nij,jk->nmk", reduce, J, reduce) if jac else None
        return r, J, st

    tail = 0 if rigid or p.body is None else p.body.size
    rot = [0] if rigid else rotation_index(x.shape[1], discs, p.supports, tail)
    return residual_newton(p, residual, x, phi, rot, "stage with friction", reduce, failed)


_PICARD_ITERATIONS = 200


def friction_picard(
    p: Problem, minimise, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi
) -> FloatArray:
    """Fixed-point iteration on the friction forces from ``x`` (A, m), the frictionless
    solution: each step holds Q at the last iterate and minimises the convex potential
    Π(x) − Q·x (the friction forces as a dead load, ``frozen``) by ``minimise`` (the
    frictionless stage's Newton method, :func:`~cyclomesh.stage.newton.newton`, whose line
    search on the potential crosses the contact laws' kinks, a pin closing or a bearing
    leaving its clearance, where Newton on the residual can stall). The residual ∇Π − Q
    falls by the ratio of Q's change to the step's (μ times the tangential over the normal
    lever, about 0.05–0.1 here) per step; a crank angle stops at :func:`friction_newton`'s
    tolerance or when its residual no longer falls to 0.9 of its best. Returns ``x``
    (overwritten), for :func:`friction_newton` to finish and test."""
    from cyclomesh.stage.newton import FORCE_TOLERANCE

    tol = FORCE_TOLERANCE * abs(p.torque) / p.scale
    L = p.scale
    tail = 0 if rigid or p.body is None else p.body.size
    rot = (
        [0, *range(1, 1 + 3 * discs, 3)]
        if rigid
        else rotation_index(x.shape[1], discs, p.supports, tail)
    )

    def loaded(sub: Problem, law_, xa, d, r, hessian=True, gradient=True):
        e, g, H, st = evaluate(sub, law_, xa, d, r, hessian=hessian, gradient=gradient)
        xs = xa.copy()
        xs[:, rot] *= L
        e = e - np.sum(sub.frozen * xs, axis=-1)
        return e, (None if g is None else g - sub.frozen), H, st

    plain = dataclasses.replace(p, slip=None, tangent_arm=None, drag=0.0, lubrication=None)
    active = np.arange(x.shape[0])
    best = np.full(x.shape[0], np.inf)
    for _ in range(_PICARD_ITERATIONS):
        if active.size == 0:
            return x
        sub = p.take(active)
        _, g, _, st = evaluate(sub, law, x[active], discs, rigid, hessian=False)
        Q, _ = friction_terms(sub, x[active], discs, rigid, st, law, False)
        r = g - Q
        if rigid:
            r = r @ reducer(discs)
        res = np.max(np.abs(r), axis=-1)
        keep = (res > tol) & (res < 0.9 * best[active])
        best[active] = np.minimum(best[active], res)
        active = active[keep]
        if active.size == 0:
            return x
        step = dataclasses.replace(plain.take(active), frozen=Q[keep])
        try:
            x[active] = minimise(step, loaded, law, x[active], discs, rigid, phi[active])
        except ConvergenceError:  # one angle at a time; an angle that fails stops here
            ok = np.ones(active.size, bool)
            for i in range(active.size):
                try:
                    x[active[i : i + 1]] = minimise(step.take(np.array([i])), loaded, law,
                                                    x[active[i : i + 1]], discs, rigid,
                                                    phi[active[i : i + 1]])  # fmt: skip
                except ConvergenceError:
                    ok[i] = False
            active = active[ok]
    return x


_CONTINUATION_HALVINGS = 12
"""Smallest step of :func:`friction_continuation`: 2⁻¹² of the coefficients."""


def friction_continuation(
    p: Problem, evaluate, law, x: FloatArray, discs: int, rigid: bool, phi
) -> FloatArray:
    """The equilibrium with friction from the frictionless one ``x`` (A, m), by continuation
    in the coefficients: :func:`friction_newton` at a fraction s of every coefficient
    (``friction_scale``), s from 0 to 1, each step from the last solution; a step whose
    Newton iteration fails is halved (down to 2⁻¹² of the coefficients), a step that
    succeeds doubles the next, per crank angle. The first step is the whole of the
    coefficients: friction of 0.05 moves the frictionless solution by a few per cent of
    the loads, well within Newton's reach of it. Returns the solution at s = 1 (``x``
    overwritten), to :func:`friction_newton`'s convergence test; raises ConvergenceError
    naming the crank angle and the fraction reached where even the smallest step fails
    (no sliding solution near the path)."""
    A = x.shape[0]
    level = np.zeros(A)  # the fraction of the coefficients of each angle's x
    step = np.ones(A)
    while True:
        todo = np.flatnonzero(level < 1.0)
        if todo.size == 0:
            return x
        target = np.minimum(level + step, 1.0)
        for value in np.unique(target[todo]):
            idx = todo[target[todo] == value]
            sub = dataclasses.replace(p.take(idx), friction_scale=float(value))
            failed = np.zeros(idx.size, bool)
            trial = friction_newton(sub, evaluate, law, x[idx], discs, rigid, phi[idx], failed)
            ok, bad = idx[~failed], idx[failed]
            x[ok] = trial[~failed]
            level[ok] = value
            step[ok] *= 2.0
            step[bad] *= 0.5
            if np.any(step[bad] < 2.0**-_CONTINUATION_HALVINGS):
                worst = bad[np.argmin(step[bad])]
                raise ConvergenceError(
                    f"stage with friction: no sliding equilibrium at crank angle "
                    f"{np.degrees(phi[worst]):.6g}° beyond {level[worst]:.4g} of the friction "
                    "coefficients (continuation from the frictionless solution)"
                )


def power_terms(
    p: Problem, mesh, fr: dict, state: dict, motion: float, speed: float
) -> dict[str, FloatArray]:
    """Powers of a drive with friction at speed ω [W] (module doc), per crank angle (A,)
    unless said: ``power_loss_pin`` (A, D, 2·n1), ``power_loss_bearing`` (A, D, N),
    ``approach_power`` (the non-conjugate profile's Σ F·(v·n)·ω) and ``input_power`` from the
    crank pins' forces (−Σ f·v_H + s·ω·Σ C + T·ω·s/n2)."""
    teeth = mesh.design.teeth
    A, D, _ = p.bl.shape
    F = state["pin_force"]
    loss = fr["mu"] * F * np.abs(fr["velocity"]) * speed
    fx, fy = state["bearing_fx"], state["bearing_fy"]
    B = np.hypot(fx, fy)
    couple = fr["drag"] * B  # (A, D, N), on the discs
    bearing = np.abs(couple) * speed * (1.0 + 1.0 / teeth)
    e = np.asarray(mesh.eccentricity if mesh.eccentricity is not None else 0.0, float)
    e = float(e.reshape(-1)[0]) if mesh.eccentricity is not None else mesh.design.eccentricity
    crank = mesh.phi[:, None] + 2.0 * np.pi * np.arange(D) / D  # (A, D)
    c, s = np.cos(crank), np.sin(crank)
    # velocity of the theoretical motion per unit ω: at the pins along n, at the holes
    vn = motion * (e * (c[..., None] * p.ny - s[..., None] * p.nx) - p.arm / teeth)
    vn = np.where(np.isfinite(p.bl), vn, 0.0)
    vhx = motion * (-e * s[..., None] + p.hy[:, None, :] / teeth)
    vhy = motion * (e * c[..., None] - p.hx[:, None, :] / teeth)
    p_in = (
        -np.sum(fx * vhx + fy * vhy, axis=(-2, -1))
        + motion * np.sum(couple, axis=(-2, -1))
        + motion * p.torque / teeth
    ) * speed
    return {
        "power_loss_pin": loss,
        "power_loss_bearing": bearing,
        "approach_power": np.sum(F * vn, axis=(-2, -1)) * speed,
        "input_power": p_in,
    }
