"""The compiled stage Newton's last step (cyclomesh.stage.kernel_newton.LAST_PREDICTED):
where Newton's quadratic convergence predicts a residual far below the round-off floor,
the last step is taken without evaluating its end, the state there moved to first order
(the bearing phase's pins' forces and bearings' loads; the rigid phase's pins' forces and
stiffnesses), unless a pin or a roller changes its state of the law on the way. Checked
here: the moved state against an evaluation at the end, the refusals, and whole solves
at 1° (the benchmark's crank step, where the rule fires on most crank angles) against
the NumPy reference to 1e-13 of each field's largest value."""

import numpy as np
import pytest

from cyclomesh.core import kernel
from cyclomesh.stage import StageDesign, solve_stage

pytest.importorskip("numba")

import cyclomesh.stage.kernel_newton as kn  # noqa: E402
from tests.stage.test_kernel_stage import _agree, _both  # noqa: E402
from tests.stage.test_newton import BEARING, HOLES, LIGHT, MOD, RV40, _hard_stage  # noqa: E402

FINE = np.radians(np.arange(0.0, 90.0, 1.0))


def _captured(monkeypatch, stage, errors=None, torque=412.0):
    """The arguments of the compiled bearing phase's last call (by name) and of the rigid
    phase's, from a solve over FINE with the numba kernel."""
    calls = {}
    newton, rigid = kn._kernels_newton, kn._kernels_rigid

    def keep(name, make):
        def compiled():
            run = make()

            def wrapped(*args):
                out = run(*args)
                calls[name] = (
                    run.py_func,
                    [a.copy() if isinstance(a, np.ndarray) else a for a in args],
                )
                return out

            return wrapped

        return compiled

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    monkeypatch.setattr(kn, "_kernels_newton", keep("newton", newton))
    monkeypatch.setattr(kn, "_kernels_rigid", keep("rigid", rigid))
    solve_stage(RV40, stage, MOD, errors, [torque], FINE, discs=2)
    monkeypatch.setattr(kn, "_kernels_newton", newton)
    monkeypatch.setattr(kn, "_kernels_rigid", rigid)
    out = {}
    for name, (py, args) in calls.items():
        names = py.__code__.co_varnames[: py.__code__.co_argcount]
        out[name] = dict(zip(names, args, strict=True))
    return out


def _evaluate(a, i, x, memo=None):
    """kn._evaluate_one at crank angle i and x with its state (pf, bf (A, D, N, 6), kp)."""
    m = x.size
    D, P = a["pin"].shape[2:]
    N = a["hole"].shape[3]
    A = a["pin"].shape[1]
    pf, bf, kp = np.zeros((A, D, P)), np.zeros((A, D, N, 6)), np.zeros((2, D, P))
    g, H = np.zeros(m), np.zeros((m, m))
    memo = np.zeros((3, D, P)) if memo is None else memo
    _, status = kn._evaluate_one(
        i, x, a["pin"], a["hole"], a["G"], a["cols"], a["const"], a["nw"], a["kcarrier"],
        a["carrier"], a["half"], a["kn"], a["torque"], a["L"], True, g, H, memo, pf, bf, kp,
    )  # fmt: skip
    assert status == 0
    return pf, bf, kp, g


@pytest.mark.parametrize("crankshafts", [False, True])
def test_the_moved_state_is_the_evaluation_at_the_end(monkeypatch, crankshafts):
    """A step of the size the rule takes (~10⁻¹³ m): the state moved by _last_state is the
    evaluation's there to 1e-13 of the largest force; a step that opens a pin, or that
    moves a crank bearing's roller across its clearance, is refused and nothing moves."""
    errors, stage = _hard_stage(0) if crankshafts else (None, StageDesign(HOLES, BEARING))
    a = _captured(monkeypatch, stage, errors)["newton"]
    kn._kernels_newton()  # compiles the pieces
    x = a["x"]
    rot = np.zeros(x.shape[1], bool)
    rot[[0, 1, 4]] = True
    if a["carrier"]:
        rot[-1] = True
    rng = np.random.default_rng(1)
    for i in (0, 17, 45, 89):
        pf, bf, kp, _ = _evaluate(a, i, x[i].copy())
        move = rng.normal(size=x.shape[1]) * 1e-13
        move[rot] /= a["L"]
        end = x[i] + move
        want_pf, want_bf, _, _ = _evaluate(a, i, end.copy())
        ok = kn._last_state(
            i, x[i], end, a["pin"], a["hole"], a["const"], a["nw"], a["carrier"], a["half"],
            pf, bf, kp,
        )  # fmt: skip
        assert ok
        assert np.max(np.abs(pf[i] - want_pf[i])) <= 1e-13 * np.max(want_pf[i])
        assert np.max(np.abs(bf[i, ..., :3] - want_bf[i, ..., :3])) <= 1e-13 * np.max(
            np.abs(want_bf[i, ..., :2])
        )
        # a disc turned back until its most loaded pin's approach is gone: refused
        before = (pf.copy(), bf.copy())
        far = x[i].copy()
        far[1] -= 2.0 * np.max(np.abs(x[i, 1:4])) + 1e-3
        ok = kn._last_state(
            i, x[i], far, a["pin"], a["hole"], a["const"], a["nw"], a["carrier"], a["half"],
            pf, bf, kp,
        )  # fmt: skip
        assert not ok
        assert np.array_equal(pf, before[0]) and np.array_equal(bf, before[1])


def test_a_roller_crossing_its_clearance_is_refused(monkeypatch):
    """A crank pin deflected (the crankshafts' unknowns: no pin's approach moves) along its
    bearing's offset by a step that unloads the bearing's outermost loaded roller:
    refused, the state untouched; half of that step, within the same rollers, taken."""
    errors, stage = _hard_stage(0)
    a = _captured(monkeypatch, stage, errors)["newton"]
    kn._kernels_newton()
    assert a["nw"] > 0
    x = a["x"]
    D, N = a["hole"].shape[2:]
    R = a["const"].size - D - D * D
    cos = a["const"][:R]
    base = 1 + 3 * D
    for i in (3, 30, 60):
        pf, bf, kp, _ = _evaluate(a, i, x[i].copy())
        d, k = np.unravel_index(np.argmax(bf[i, ..., 2]), bf.shape[1:3])
        s = bf[i, d, k, 2]
        loaded = cos[s * cos - a["half"] > 0.0]
        assert loaded.size
        dx, dy = kn._hole_offset(i, x[i], d, k, a["hole"], a["const"], R, a["nw"], a["carrier"])
        w = base + 2 * (d * N + k)
        for fraction, taken in ((1.01, False), (0.5, True)):
            shrink = (s - a["half"] / loaded.min()) * fraction  # s − the unloading deflection
            end = x[i].copy()
            end[w] += shrink * dx / s  # dx = … − wx: the offset shortens along itself
            end[w + 1] += shrink * dy / s
            before = (pf.copy(), bf.copy())
            ok = kn._last_state(
                i, x[i], end, a["pin"], a["hole"], a["const"], a["nw"], a["carrier"],
                a["half"], pf, bf, kp,
            )  # fmt: skip
            assert ok == taken
            if not taken:
                assert np.array_equal(pf, before[0]) and np.array_equal(bf, before[1])
            else:
                assert np.array_equal(pf, before[0])  # no pin moved
                assert abs(bf[i, d, k, 2] - (s - shrink)) <= 1e-12 * s


def test_the_rigid_phase_refuses_a_pin_that_closes(monkeypatch):
    """_rigid_same: a tiny turn keeps every pin's state; a turn that carries an open
    pin's approach past 0 (or a closed one's back) does not."""
    a = _captured(monkeypatch, StageDesign(HOLES, BEARING))["rigid"]
    kn._kernels_rigid()
    x, pin = a["x"], a["pin"]
    opens = np.full(pin.shape[2], np.inf)
    for i in (0, 40, 80):
        end = x[i].copy()
        end[[0, 1, 4]] += 1e-15
        assert kn._rigid_same(i, x[i], end, pin, opens)
        # the smallest turn that closes an open loaded-flank pin of disc 0
        bl, arm = pin[0, i, 0], pin[1, i, 0]
        th = x[i, 1]
        fin = np.isfinite(bl)
        closed = fin & (arm * (th - np.where(fin, bl, 0.0)) > 0)
        opening = fin & ~closed & (arm > 0)
        gap = np.min(bl[opening] - th)
        end = x[i].copy()
        end[[0, 1, 4]] += gap * 1.001
        assert not kn._rigid_same(i, x[i], end, pin, opens)


@pytest.mark.parametrize("torque", [412.0, -LIGHT, LIGHT])
def test_fine_crank_steps_agree_with_the_reference(monkeypatch, torque):
    """At 1° (the benchmark's step: the last step taken on most crank angles of both
    phases) the stage with clearance bearings, and the tolerance ring with crankshafts,
    carrier and errors, agree with the NumPy reference to 1e-13 of each field's
    largest value."""
    for errors, stage in ((None, StageDesign(HOLES, BEARING)), _hard_stage(1)):
        ref, got = _both(
            monkeypatch,
            lambda s=stage, e=errors: solve_stage(RV40, s, MOD, e, [torque], FINE, discs=2),
        )
        _agree(ref, got)
        assert np.all(got.residual <= 1e-12 * abs(torque) / HOLES.circle_radius)


def test_the_rollers_curvature_is_the_derivative_of_their_stiffness():
    """_rollers_curved: B, dB/ds and the energy bit for bit _rollers' (the same
    operations), d²B/ds² the central difference of dB/ds to 1e-6, across the clearance
    (no roller loaded, one, several)."""
    kn._kernels_newton()
    const = np.concatenate([np.cos(BEARING.angles), np.zeros(2 + 4)])
    R, half, k = BEARING.angles.size, 0.5 * BEARING.clearance, BEARING.constant
    for s in (1e-6, 2.4e-6, 2.6e-6, 3e-6, 8e-6, 4e-5):
        got = kn._rollers_curved(s, const, R, half, k)
        assert got[:3] == kn._rollers(s, const, R, half, k)
        h = 1e-5 * s
        lo = kn._rollers(s - h, const, R, half, k)[1]
        hi = kn._rollers(s + h, const, R, half, k)[1]
        fd = (hi - lo) / (2.0 * h)
        assert abs(got[3] - fd) <= 1e-6 * max(abs(fd), 1e-300) or (s < half and got[3] == 0.0)


@pytest.mark.parametrize("crankshafts", [False, True])
def test_the_third_derivative_is_the_change_of_the_hessian(monkeypatch, crankshafts):
    """_curvature's T[s, s] (the pins' stiffening and the crank bearings' curvature, which
    Chebyshev's step takes) against the central difference of the Hessian along s, H(x ±
    εs)·s/(2ε), to 1e-5 of its largest component, at the start of a crank angle (the
    parabola through three solutions) along its Newton step."""
    errors, stage = _hard_stage(0) if crankshafts else (None, StageDesign(HOLES, BEARING))
    a = _captured(monkeypatch, stage, errors)["newton"]
    kn._kernels_newton()
    x = a["x"]
    m = x.shape[1]
    rot = np.zeros(m, bool)
    rot[[0, 1, 4]] = True
    if a["carrier"]:
        rot[-1] = True

    def hessian(i, xx):
        A, D, P = a["pin"].shape[1:]
        N = a["hole"].shape[3]
        pf, bf, kp = np.zeros((A, D, P)), np.zeros((A, D, N, 6)), np.zeros((2, D, P))
        g, H = np.zeros(m), np.zeros((m, m))
        kn._evaluate_one(
            i, xx, a["pin"], a["hole"], a["G"], a["cols"], a["const"], a["nw"], a["kcarrier"],
            a["carrier"], a["half"], a["kn"], a["torque"], a["L"], True, g, H,
            np.zeros((3, D, P)), pf, bf, kp,
        )  # fmt: skip
        return g, H, pf, bf, kp

    for i in (5, 33, 71):
        x0 = 3.0 * x[i - 1] - 3.0 * x[i - 2] + x[i - 3]
        g, H, pf, bf, kp = hessian(i, x0.copy())
        s = np.linalg.solve(H, -g)
        out = np.zeros(m)
        half = kn._curvature(
            i, x0, s, a["pin"], a["hole"], a["G"], a["cols"], a["const"], a["nw"],
            a["carrier"], a["L"], pf, bf, kp, out,
        )  # fmt: skip
        assert half == 0.5 * np.max(np.abs(out))
        eps = 1e-3
        hp = hessian(i, x0 + eps * np.where(rot, s / a["L"], s))[1]
        hm = hessian(i, x0 - eps * np.where(rot, s / a["L"], s))[1]
        fd = (hp - hm) @ s / (2.0 * eps)
        assert np.max(np.abs(out - fd)) <= 1e-5 * np.max(np.abs(fd))
