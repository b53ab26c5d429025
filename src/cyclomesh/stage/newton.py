"""Newton's method of the RV stage's equilibrium (:mod:`cyclomesh.stage.equilibrium`):
a backtracking line search on the convex potential, vectorised over the crank angles,
with the step stretched by the bearing law's exponent where a crank bearing near zero
load makes Newton linear; the converged test: near the root (:data:`FORCE_TOLERANCE`),
then on to round-off (:data:`ROUND_OFF_FORCE`).

The problem's assembly (potential, gradient, Hessian) is the caller's: :func:`newton`
takes it as a function, so the iteration does not depend on what the potential holds.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.exceptions import ConvergenceError
from cyclomesh.stage.bearing import LOAD_EXPONENT
from cyclomesh.stage.kernel import compiled
from cyclomesh.stage.kernel_body import hessian_noise

__all__ = [
    "newton",
    "kernel_settings",
    "residual_newton",
    "rotation_index",
    "FORCE_TOLERANCE",
    "ROUND_OFF_FORCE",
    "WARM_RUN",
    "reducer",
]

FloatArray = NDArray[np.float64]
Evaluate = Callable[..., tuple[Any, Any, Any, dict]]

FORCE_TOLERANCE = 1e-12
"""Residual of every equilibrium equation, relative to T/r_c (moments /r_c), below which
Newton's steps are near the root: from there they go on to round-off
(:data:`ROUND_OFF_FORCE`, or a step that no longer reduces the residual)."""
ROUND_OFF_FORCE = 4.0 * float(np.finfo(float).eps)
"""Largest residual of the equilibrium equations, relative to T/r_c, at which the root is
reached (four units in the last place, about 8.9e-16); a residual within
:data:`FORCE_TOLERANCE`·T/r_c (or the round-off of the unknowns) that a Newton step does
not reduce ends the iteration as well (the round-off of the sums of forces)."""
WARM_RUN = 4
"""Crank angles solved in a run from the one before (a warm start): every WARM_RUN-th
crank angle (0, WARM_RUN, ...) starts from its own start, each of the next WARM_RUN − 1
from the solution of the crank angle before it where the potential is lower there
(:func:`cyclomesh.stage.equilibrium._warm`: the NumPy reference's WARM_RUN vectorised
passes; the compiled iteration warms every crank angle after the first,
:func:`cyclomesh.stage.kernel_newton.run`). The root does not depend on the
start (the iteration runs to round-off)."""
_MAX_ITERATIONS = 200
_MAX_HALVINGS = 60
_STALL_HALVINGS = 30
"""With a ``failed`` array (:func:`residual_newton`), a crank angle whose line search has not
decreased the residual within this many halvings (a step of 10⁻⁹ of Newton's: the
direction is the regularisation's, not the problem's) is given up to its caller."""
_STALL_ITERATIONS = 8
"""With a ``failed`` array (:func:`newton`), a crank angle not near the root whose largest
residual has not fallen below its smallest so far for this many Newton steps is given up
to its caller (the compliant disc's saddle, where the potential's descent runs away)."""
_REUSE_TRIAL = True
"""The compliant disc (:func:`newton` on a problem with a ``body``): the first trial of each
line search evaluates the gradient and Hessian as well, and where it is taken they are
the next step's (the same evaluation at the same point, so the same bits: it saves the
next step's evaluation, the line search takes the full step at almost every step)."""
_LAST_STEP = True
"""The compliant disc (:func:`newton` with :data:`_REUSE_TRIAL`): a crank angle near the root
whose residual fell quadratically (by :data:`_QUADRATIC` at least) to one from which the
next is predicted at the round-off (res³/res_before² ≤ :data:`ROUND_OFF_FORCE`·T/r_c)
takes that Newton step without a line search and ends: the evaluation there and the
round-off polish after it are saved (task i36b)."""
_QUADRATIC = 1e-3
"""Largest ratio of two Newton steps' residuals taken as quadratic convergence
(:data:`_LAST_STEP`; a linear tail falls by 0.03–0.1 a step)."""
_CHORD = 1e-2
"""The compliant disc's compiled iteration (:func:`cyclomesh.stage.kernel_compliant.newton`):
where the last step cut the largest residual to this fraction of the one before or less,
the next step reuses the last Newton step's factorisation of the Hessian (a chord, or
modified Newton, step: Ortega & Rheinboldt §7.1; the Shamanskii iteration), a gradient's
evaluation and a back substitution instead of the Hessian's evaluation and
factorisation; a chord step whose residual falls less, or that the line search refuses,
is followed by (or redone as) Newton's. Every trial evaluates only the gradient (its
Hessian only where the iteration goes on with Newton's step there). The same test ends
the iteration, so the root is the same to round-off; :data:`_LAST_STEP` takes a chord
step untried where its linear rate predicts the next residual at the round-off
(res²/res_before ≤ :data:`ROUND_OFF_FORCE`·T/r_c). 0: every step Newton's, as the
NumPy reference (measured, task i40k: 1e-3 to 3e-2 alike, 0.1 more evaluations)."""
_ROUND_OFF_HALVINGS = 3
"""With ``round_off`` (:func:`residual_newton`), a crank angle near the root whose residual's
norm no trial of this many halvings reduces stays where it is (the round-off)."""
_STEP_CAP = 1e-4
"""Largest move of any unknown in one trial step [m] (rotations × r_c): a longer Newton
step (a nearly flat direction of the potential) is shortened to it before the line
search, instead of being halved down to it one potential evaluation at a time."""
_LINEAR = (0.05, 0.12)
"""Residual ratios of two Newton steps taken as the linear convergence of a crank bearing
near zero load (:func:`newton`; (1 − 9/10)^(10/9) ≈ 0.077 in the middle)."""


def rotation_index(m: int, discs: int, supports, tail: int = 0) -> list[int]:
    """Unknowns that are rotations (scaled by r_c in the Newton step); ``tail``: the
    compliant disc's unknowns after the supports' (:class:`~cyclomesh.stage.equilibrium.
    _Body`)."""
    idx = [0, *range(1, 1 + 3 * discs, 3)]
    if supports is not None and supports.carrier is not None:
        idx.append(m - 1 - tail)
    return idx


def newton(
    p,
    evaluate: Evaluate,
    law,
    x: FloatArray,
    discs: int,
    rigid: bool,
    phi: FloatArray,
    failed: NDArray[np.bool_] | None = None,
) -> FloatArray:
    """Newton's method with a backtracking line search on the potential, per crank angle.

    ``p``: the problem (``torque``, ``scale``, ``supports`` and ``take`` of
    :class:`~cyclomesh.stage.equilibrium._Problem`); ``evaluate``: its potential, gradient
    and Hessian (:func:`~cyclomesh.stage.equilibrium._evaluate`); ``x``: the start (A, m),
    overwritten by the solution. Raises ConvergenceError naming the crank angle ``phi``.

    The line search asks the potential for a sufficient decrease (Armijo) while that
    decrease can be resolved: once the Newton step's first-order change −g·s is below
    1e-13 of the magnitude of the potential's terms (:func:`_magnitude`; the potential
    itself is the small difference of the torque's work and the springs' energy near a
    crank bearing at zero load) a trial is judged by the residual's norm instead,
    ‖g(x + t·s)‖ ≤ (1 − 10⁻⁴t)·‖g(x)‖ (s a descent direction of ‖g‖², Nocedal & Wright
    §11.2), so the iteration does not stall on steps of 10⁻⁸ that leave the potential's
    last digit unchanged.

    ``failed``: as :func:`residual_newton`'s (a boolean array (A,), False on entry): the
    crank angles that are not near the root and whose line search finds no decrease
    within :data:`_STALL_HALVINGS` halvings or whose residual has not fallen for
    :data:`_STALL_ITERATIONS` steps (or that fail as without it) are set True
    there, left at their last iterate and dropped; nothing is raised, and the others are
    solved by the same arithmetic as without it (:func:`~cyclomesh.stage.equilibrium.
    _body_newton`, which hands those angles to a Newton on the residual).
    """
    tol = FORCE_TOLERANCE * abs(p.torque) / p.scale
    floor = ROUND_OFF_FORCE * abs(p.torque) / p.scale
    reduce = np.zeros((1 + 3 * discs, 1))
    reduce[[0, *range(1, 1 + 3 * discs, 3)], 0] = 1.0  # rigid: θ_d = c, u = 0
    active = np.arange(x.shape[0])
    previous = np.full(x.shape[0], np.inf)  # max |g| of the last step, per crank angle
    extended = np.zeros(x.shape[0], bool)  # the last step was a stretched one
    linear = np.zeros(x.shape[0], bool)  # the last residual ratio was in _LINEAR
    best = np.full(x.shape[0], np.inf)  # smallest max |g| so far (with ``failed``)
    since = np.zeros(x.shape[0], np.int64)  # steps since it fell
    sub = p.take(active)  # the problem of the active crank angles, taken as they converge
    # the compliant disc: the first trial of each line search evaluates the gradient and
    # Hessian too, kept for the next step where it is accepted (the same evaluation)
    reuse = _REUSE_TRIAL and not rigid and getattr(p, "body", None) is not None
    carried = None
    for _ in range(_MAX_ITERATIONS):
        xa = x[active]
        if carried is None:
            energy, g, H, _state = evaluate(sub, law, xa, discs, rigid)
        else:
            have, energy, g, H = carried
            carried = None
            rest = np.flatnonzero(~have)
            if rest.size:  # the crank angles whose first trial was not taken
                e_r, g_r, H_r, _ = evaluate(sub.take(rest), law, xa[rest], discs, rigid)
                energy[rest], g[rest], H[rest] = e_r, g_r, H_r
        if rigid:
            g = g @ reduce
            H = np.einsum("im,nij,jk->nmk", reduce, H, reduce)
        # near the root: every residual below tol, or at the round-off of the unknowns
        # themselves (stiff bearings: a residual of H·ulp(x) cannot be resolved); from
        # there Newton goes on to the root at round-off: it stops at a residual of a few
        # ulp of T/r_c or at the first step that does not reduce the largest residual
        body = None if rigid else getattr(p, "body", None)
        tail = 0 if body is None else body.size
        rot_idx = rotation_index(xa.shape[1], discs, None if rigid else p.supports, tail)
        xs = np.abs(_scale(xa, 1.0 / p.scale, rot_idx))
        if rigid:
            xs = xs @ reduce
        if reuse and compiled():  # CYCLOMESH_KERNEL=numba: without the copy |H|
            noise = hessian_noise(H, xs)
        else:
            noise = 16.0 * np.finfo(float).eps * np.matmul(np.abs(H), xs[..., None])[..., 0]
        near = np.all(np.abs(g) <= np.maximum(tol, noise), axis=-1)
        res = np.max(np.abs(g), axis=-1)
        done = near & ((res <= floor) | (res >= previous[active]))
        keep = ~done
        last = None
        if reuse and _LAST_STEP:
            # quadratic convergence near the root: this step's residual predicted at the
            # round-off (res³/res_before² ≤ floor); the step is taken without a trial
            before = previous[active]
            last = keep & near & (res <= _QUADRATIC * before) & (res**3 <= floor * before**2)
            last &= ~linear[active]  # (not after a step of a bearing's linear convergence)
        if failed is not None:
            # a descent along the compliant disc's saddle: the potential falls, the
            # residual does not (it grows ×1.3–2 a step); given up to the caller
            better = res < best[active]
            best[active] = np.where(better, res, best[active])
            since[active] = np.where(better, 0, since[active] + 1)
            stall = keep & ~near & (since[active] >= _STALL_ITERATIONS)
            failed[active[stall]] = True
            keep &= ~stall
        # a crank bearing whose equilibrium compression is ~0 (a disc that carries almost
        # nothing at a light torque) makes Newton linear, δ → δ·(1 − 1/p) with
        # Q ∝ δ^p (residual ×(1 − 1/p)^p ≈ 1/13 a step); the step stretched by p is the
        # modified Newton step of that root: try it first, every other step at most
        ratio = (res > _LINEAR[0] * previous[active]) & (res < _LINEAR[1] * previous[active])
        stretch = (~rigid & ~extended[active] & ratio & linear[active])[keep]
        linear[active] = ratio & ~extended[active]
        previous[active] = res
        active = active[keep]
        if active.size == 0:
            return x
        if not np.all(keep):  # (H is the evaluation's own array either way)
            near = near[keep]
            last = None if last is None else last[keep]
            xa, g, H, energy = xa[keep], g[keep], H[keep], energy[keep]
            sub = sub.take(np.flatnonzero(keep))
        diag = np.maximum(np.max(np.abs(np.diagonal(H, axis1=1, axis2=2)), axis=-1), 1e-300)
        i = np.arange(H.shape[-1])
        H[:, i, i] += 1e-14 * diag[:, None]  # regularised (H is this step's own)
        step = np.linalg.solve(H, -g[..., None])[..., 0]
        slope = np.sum(g * step, axis=-1)
        # not a descent direction (flat directions): steepest descent, scaled
        flip = ~(slope < 0)
        step[flip] = -g[flip] / diag[flip, None]
        slope = np.sum(g * step, axis=-1)
        t = np.where(stretch, LOAD_EXPONENT, 1.0)
        reach = np.max(np.abs(step), axis=-1)  # m (rotations × r_c)
        t = np.where(reach * t > _STEP_CAP, _STEP_CAP / np.where(reach > 0, reach, 1.0), t)
        extended[active] = stretch
        todo = np.arange(xa.shape[0])
        new = xa.copy()
        if last is not None:  # a Newton step (descent, not capped), taken as it is
            last &= ~flip & (t == 1.0)
            if np.any(last):
                li = np.flatnonzero(last)
                new[li] = xa[li] + _scale(step[li], p.scale, rot_idx)
                todo = np.flatnonzero(~last)
            else:
                last = None
        tiny = -slope <= 1e-13 * np.maximum(np.abs(energy), 1e-300)
        # the potential has no digits left for the sufficient-decrease test: its change
        # along the step is below the round-off of its terms (−T·c cancels the springs'
        # energy); judge the step by the residual's norm instead
        flat = ~tiny & (-slope <= 1e-13 * _magnitude(energy, p.torque, xa[:, 0]))
        norm = np.linalg.norm(g, axis=-1)
        for _h in range(_MAX_HALVINGS):
            if todo.size == 0:  # (every crank angle took its last step)
                break
            full = _expand(step[todo] * t[todo, None], reduce if rigid else None)
            trial = xa[todo] + _scale(full, p.scale, rot_idx)
            want = bool(np.any(flat[todo]))  # the gradient only where it is needed
            first = reuse and _h == 0  # (todo: every crank angle but the last steps')
            e_t, g_t, H_t, st = evaluate(
                sub.take(todo), law, trial, discs, rigid, hessian=first, gradient=want or first
            )
            ok = (e_t <= energy[todo] + 1e-4 * t[todo] * slope[todo]) | tiny[todo]
            if want:
                g_t = g_t @ reduce if rigid else g_t
                drop = np.linalg.norm(g_t, axis=-1) <= (1.0 - 1e-4 * t[todo]) * norm[todo]
                ok = np.where(flat[todo], drop, ok)
            ok = ~st["bad"] & ok
            new[todo[ok]] = trial[ok]
            if first and np.any(ok):
                carried = (ok, e_t, g_t, H_t)
            todo = todo[~ok]
            if failed is not None and _h + 1 >= _STALL_HALVINGS:
                # not near the root and no decrease after _STALL_HALVINGS halvings: the
                # direction is the regularisation's (or runs away along a saddle):
                # given up to the caller, left at this iteration's start
                stall = ~near[todo]
                failed[active[todo[stall]]] = True
                todo = todo[~stall]
            if todo.size == 0:
                break
            extended[active[todo]] = False
            t[todo] = np.where(t[todo] > 1.0, 1.0, 0.5 * t[todo])
        else:
            # near the root with no digits left in the potential, a residual that no
            # step reduces is the round-off: the iterate stays, the next test ends it
            if not np.all(near[todo] & flat[todo]):
                if failed is None:
                    raise ConvergenceError(
                        f"stage: no descent at crank angle "
                        f"{np.degrees(phi[active[todo[0]]]):.6g}° "
                        f"(line search failed after {_MAX_HALVINGS} halvings)"
                    )
                failed[active[todo[~(near[todo] & flat[todo])]]] = True
        x[active] = new
        if last is not None:  # done (the first trial's evaluation: the others' alone)
            active = active[~last]
            if active.size == 0:
                return x
            sub = sub.take(np.flatnonzero(~last))
        if failed is not None and np.any(failed[active]):
            keep = ~failed[active]
            active = active[keep]
            if active.size == 0:
                return x
            sub = sub.take(np.flatnonzero(keep))
            if carried is not None:
                carried = tuple(v[keep] for v in carried)
    if failed is not None:
        failed[active] = True
        return x
    raise ConvergenceError(
        f"stage equilibrium did not converge at crank angle {np.degrees(phi[active[0]]):.6g}°: "
        f"residual above {FORCE_TOLERANCE:.0e}·T/r_c or still falling after {_MAX_ITERATIONS} "
        "Newton steps"
    )


def kernel_settings(run: int, compliant: bool = False) -> tuple:
    """The iteration's constants as the compiled Newtons take them, in their order
    (:func:`cyclomesh.stage.kernel_newton.newton`; with ``compliant`` the compliant disc's
    :func:`cyclomesh.stage.kernel_compliant.newton`, which adds the give-ups and the last
    step): :data:`FORCE_TOLERANCE`, the iteration and halving limits, :data:`_STEP_CAP`
    [m], :data:`_LINEAR`, :data:`ROUND_OFF_FORCE`, (compliant: :data:`_STALL_HALVINGS`,
    :data:`_STALL_ITERATIONS`, :data:`_QUADRATIC`, :data:`_LAST_STEP` with
    :data:`_REUSE_TRIAL`, :data:`_CHORD`), then ``run``, the crank angles of a warm run."""
    head = (FORCE_TOLERANCE, _MAX_ITERATIONS, _MAX_HALVINGS, _STEP_CAP, *_LINEAR, ROUND_OFF_FORCE)
    if not compliant:
        return (*head, run)
    last = _REUSE_TRIAL and _LAST_STEP
    return (*head, _STALL_HALVINGS, _STALL_ITERATIONS, _QUADRATIC, last, _CHORD, run)


def residual_newton(
    p,
    residual: Callable[..., tuple[Any, Any, dict]],
    x: FloatArray,
    phi: FloatArray,
    rot: list[int],
    what: str,
    reduce: FloatArray | None = None,
    failed: NDArray[np.bool_] | None = None,
    round_off: bool = False,
) -> FloatArray:
    """Newton's method on r(x) = 0 with a backtracking line search on the residual's norm
    (Nocedal & Wright §11.2), per crank angle: where no potential decreases along the step
    (the compliant disc's saddle, friction's non-symmetric Jacobian).

    ``residual(sub, xa, jacobian)`` → ``(r, J, st)`` (``J`` only with ``jacobian``; ``st``
    with the trial's ``bad`` flags) of the problem ``p`` at the scaled unknowns (rotations
    × r_c at ``rot``); ``reduce``: the reduced problem's unknowns (``r`` and ``J`` given in
    them, the step expanded to ``x``'s). The convergence test of :func:`newton`: every
    residual below :data:`FORCE_TOLERANCE`·T/r_c or the round-off of the unknowns. ``x``:
    the start (A, m), overwritten by the solution. Raises ConvergenceError naming ``what``
    and the crank angle ``phi``; with ``failed`` (a boolean array (A,), False on entry)
    it does not: the crank angles it cannot solve (no decrease within
    :data:`_STALL_HALVINGS` halvings) are set True there and left at their last iterate,
    the others solved by the same arithmetic as without it (a caller that solves those
    angles another way, :func:`~cyclomesh.stage.equilibrium._friction_solve`).
    ``round_off``: near the root, go on as :func:`newton` does, to a largest residual of
    :data:`ROUND_OFF_FORCE`·T/r_c or the first step that does not reduce it (or whose line
    search finds no decrease of the norm), so the root does not depend on the start
    (:func:`~cyclomesh.stage.equilibrium._stationary`).
    """
    tol = FORCE_TOLERANCE * abs(p.torque) / p.scale
    floor = ROUND_OFF_FORCE * abs(p.torque) / p.scale
    L = p.scale
    active = np.arange(x.shape[0])
    previous = np.full(x.shape[0], np.inf)  # max |r| of the last step (round_off)
    for _ in range(_MAX_ITERATIONS):
        sub = p.take(active)
        xa = x[active]
        r, J, _st = residual(sub, xa, True)
        xs = np.abs(xa @ reduce if reduce is not None else xa.copy())
        xs[:, rot] *= L
        noise = 16.0 * np.finfo(float).eps * np.einsum("nij,nj->ni", np.abs(J), xs)
        near = np.all(np.abs(r) <= np.maximum(tol, noise), axis=-1)
        keep = ~near
        if round_off:
            res = np.max(np.abs(r), axis=-1)
            keep = ~(near & ((res <= floor) | (res >= previous[active])))
            previous[active] = res
            near = near[keep]
        active = active[keep]
        if active.size == 0:
            return x
        xa, r, J, sub = xa[keep], r[keep], J[keep], sub.take(np.flatnonzero(keep))
        k = J.shape[-1]
        diag = np.maximum(np.max(np.abs(np.diagonal(J, axis1=1, axis2=2)), axis=-1), 1e-300)
        step = np.linalg.solve(J + 1e-14 * diag[:, None, None] * np.eye(k), -r[..., None])[..., 0]
        step[:, rot] /= L
        if reduce is not None:
            step = step @ reduce.T
        merit = np.linalg.norm(r, axis=-1)
        t = np.ones(xa.shape[0])
        todo = np.arange(xa.shape[0])
        new = xa.copy()
        for _h in range(_MAX_HALVINGS if failed is None else _STALL_HALVINGS):
            trial = xa[todo] + t[todo, None] * step[todo]
            r_t, _J, st = residual(sub.take(todo), trial, False)
            ok = ~st["bad"] & (np.linalg.norm(r_t, axis=-1) <= (1.0 - 1e-4 * t[todo]) * merit[todo])
            new[todo[ok]] = trial[ok]
            todo = todo[~ok]
            if round_off and _h >= _ROUND_OFF_HALVINGS:
                todo = todo[~near[todo]]  # at the root's round-off: stays (the test ends it)
            if todo.size == 0:
                break
            t[todo] *= 0.5
        else:
            if round_off:
                # near the root, a residual that no step reduces is the round-off: the
                # iterate stays, the next test ends it (its residual is not below itself)
                todo = todo[~near[todo]]
                if todo.size == 0:
                    x[active] = new
                    continue
            if failed is None:
                raise ConvergenceError(
                    f"{what}: no decrease of the residual at crank angle "
                    f"{np.degrees(phi[active[todo[0]]]):.6g}°"
                )
            failed[active[todo]] = True  # left at this iteration's start
            x[active] = new
            active = active[~failed[active]]
            if active.size == 0:
                return x
            continue
        x[active] = new
    if failed is not None:
        failed[active] = True
        return x
    raise ConvergenceError(
        f"{what} did not converge at crank angle "
        f"{np.degrees(phi[active[0]]):.6g}°: residual above {FORCE_TOLERANCE:.0e}·T/r_c"
    )


def _magnitude(energy: FloatArray, torque: float, c: FloatArray) -> FloatArray:
    """Sum of the magnitudes of the potential's terms [J]: every term is a spring's energy
    (≥ 0) but the torque's work −T·c, so it is |Π + T·c| + |T·c|; its round-off bounds the
    change of Π that an evaluation can resolve (Π itself may be far smaller)."""
    work = torque * c
    return np.abs(energy + work) + np.abs(work)


def _expand(step: FloatArray, reduce: FloatArray | None) -> FloatArray:
    return step if reduce is None else step @ reduce.T


def _scale(step: FloatArray, L: float, rot_idx: list[int]) -> FloatArray:
    """Scaled step (rotations × L) → unknowns (rad, m)."""
    out = step.copy()
    out[:, rot_idx] /= L
    return out


def reducer(D: int) -> FloatArray:
    """Rigid stage (θ_d = c, u = 0): the unknowns of the full problem from c, (1 + 3D, 1)."""
    reduce = np.zeros((1 + 3 * D, 1))
    reduce[[0, *range(1, 1 + 3 * D, 3)], 0] = 1.0
    return reduce
