"""stage.kernel_compliant (the compliant disc's Newton compiled per crank angle) against
the NumPy reference: its evaluation against stage.assembly.evaluate, its block-arrow
solve against LAPACK, its warm start's carried unknowns against equilibrium._body_carried,
and the solves (coarse FE disc, the example's three-crankshaft case) against the NumPy
path, with the crank angles it gives up handed to that path."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")
from tests.stage.fe_cases import require_fe

require_fe()

import cyclomesh.stage.equilibrium as eq  # noqa: E402
import cyclomesh.stage.newton as nt  # noqa: E402
from cyclomesh.stage import kernel_compliant as kc  # noqa: E402
from cyclomesh.stage.solve import solve  # noqa: E402

PHI = np.radians(np.arange(0.0, 360.0, 15.0))
FIELDS = ("twist", "bearing_load", "pin_load", "torque_share")


def _solve(example, body, torque, phi=PHI):
    case = example.case().replace(torque=torque, crank_angles=phi)
    return solve(case, example.model().replace(disc_body=body))


def _close(a, b, rtol, name):
    assert np.max(np.abs(a - b)) <= rtol * np.max(np.abs(a)), (name, np.max(np.abs(a - b)))


@pytest.fixture(scope="module")
def problems(example, coarse):
    """The compliant problems the numba path hands the kernel (±412 and ±12.36 N·m), with
    their starts and the kernel's solutions."""
    mp = pytest.MonkeyPatch()
    mp.setenv("CYCLOMESH_KERNEL", "numba")
    found = []
    compiled = eq._body_kernel

    def kept(p, law, x, discs, phi, state=None, start=None):
        first = x.copy() if start is None else start(np.arange(p.bl.shape[0]))
        out = compiled(p, law, x, discs, phi, state, start)
        found.append((p, law, first, out.copy(), discs))
        return out

    mp.setattr(eq, "_body_kernel", kept)
    try:
        _solve(example, coarse, [-412.0, 412.0])
        _solve(example, coarse, [-12.36, 12.36])
    finally:
        mp.undo()
    assert len(found) == 4
    return found


def test_the_compiled_evaluation_is_the_references(problems, monkeypatch):
    """Potential, gradient and Hessian of every crank angle at its start and at the
    solution: 1e-13 of each one's largest entry (the gradient's: or of T/r_c)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    for p, law, start, sol, D in problems:
        for x in (start, sol):
            e, g, H, status = kc.evaluate(p, law, x, D)
            e0, g0, H0, st = eq._evaluate(p, law, x, D, False)
            np.testing.assert_array_equal(status != 0, st["bad"])
            _close(e0, e, 1e-13, "energy")
            # (at the solution the gradient is its round-off: measured against T/r_c, the
            # size of its terms)
            scale = max(np.max(np.abs(g0)), abs(p.torque) / p.scale)
            assert np.max(np.abs(g - g0)) <= 1e-13 * scale
            _close(H0, H, 1e-13, "hessian")


def test_the_kernel_finishes_at_the_references_residual(problems, monkeypatch):
    """At the kernel's solution every residual is within the reference's test (its largest
    below 1e-12·T/r_c: the iteration ran to round-off)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    for p, law, _start, sol, D in problems:
        _, g, _, _ = eq._evaluate(p, law, sol, D, False)
        assert np.max(np.abs(g)) <= nt.FORCE_TOLERANCE * abs(p.torque) / p.scale


def _count_given_up(monkeypatch) -> list[int]:
    """The crank angles the compiled Newton hands to the NumPy path, one count per call
    (equilibrium's kernel_compliant wrapped for the test)."""
    handed: list[int] = []
    compiled = eq.kernel_compliant

    def counted(*args, **kw):
        failed = compiled(*args, **kw)
        handed.append(int(failed.sum()))
        return failed

    monkeypatch.setattr(eq, "kernel_compliant", counted)
    return handed


@pytest.mark.parametrize("torque", [[-412.0, 412.0], [-12.36, 12.36]])
def test_the_compiled_newton_reaches_the_numpy_root(example, coarse, monkeypatch, torque):
    """The whole solve, numba (the kernel) against NumPy: 1e-13 of each field's largest
    (measured 1e-15 to 5e-15), and the kernel finished every crank angle here."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    ref = _solve(example, coarse, torque)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    handed = _count_given_up(monkeypatch)
    got = _solve(example, coarse, torque)
    assert len(handed) == 2 and sum(handed) == 0
    for name in FIELDS:
        _close(getattr(ref, name), getattr(got, name), 1e-13, name)


def test_angles_the_kernel_gives_up_go_to_the_numpy_path(example, coarse, monkeypatch):
    """A stall declared after 0 steps: the kernel gives up every crank angle not near the
    root at its start, the NumPy path (its Newton, then the residual Newton) solves them
    from their own start, to the same root."""
    torque = [-412.0, 412.0]
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    ref = _solve(example, coarse, torque)
    handed = _count_given_up(monkeypatch)
    monkeypatch.setattr(nt, "_STALL_ITERATIONS", 0)
    got = _solve(example, coarse, torque)
    assert sum(handed) == 2 * PHI.size
    for name in FIELDS:
        _close(getattr(ref, name), getattr(got, name), 1e-13, name)


def test_friction_keeps_the_numpy_path(monkeypatch):
    """The kernel is asked only without friction (p.slip None) and a series spring."""
    called = []
    monkeypatch.setattr(eq, "_body_kernel", lambda *a: called.append(1))
    monkeypatch.setattr(eq, "_solve_near", lambda p, law, x, *a: x)
    monkeypatch.setattr(eq, "_body_warm", lambda p, law, x, *a: x)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    body = type("B", (), {"pins": np.zeros((1, 1, 1), np.int64)})()
    law = type("L", (), {"k": None})()
    p = type("P", (), {"slip": np.zeros(1), "body": body, "frozen": None})()
    x = np.zeros((1, 3))
    eq._solve(p, law, x, 1, False, np.zeros(1))
    assert not called
    p.slip = None
    law.k = 1e9
    eq._solve(p, law, x, 1, False, np.zeros(1))
    assert not called


def _arrow(rng, nr, D, lam, zero_pivot=False):
    """A block-arrow matrix: R (nr) coupled to all, each Z_d (lam) to R's columns of its
    own and to itself."""
    m = nr + D * lam
    H = np.zeros((m, m))
    H[:nr, :nr] = rng.standard_normal((nr, nr)) + nr * np.eye(nr)
    for d in range(D):
        z = slice(nr + d * lam, nr + (d + 1) * lam)
        own = rng.choice(nr, size=nr // 2, replace=False)
        H[z, z] = rng.standard_normal((lam, lam)) + 3 * np.eye(lam)
        H[z, own] = rng.standard_normal((lam, own.size))
        H[own, z] = rng.standard_normal((own.size, lam))
        if zero_pivot:
            H[z, z][:, 0] = 0.0
    return H, rng.standard_normal(m)


@pytest.mark.parametrize("zero_pivot", [False, True])
def test_the_block_arrow_solve_is_lapacks(zero_pivot):
    """The LU of the body blocks on a symmetric block-arrow H (a Hessian: _coupled reads
    its upper triangle only, task i40k)."""
    kc._kernels()
    rng = np.random.default_rng(3)
    nr, D, lam = 9, 2, 7
    H, g = _arrow(rng, nr, D, lam)
    H = 0.5 * (H + H.T)
    if zero_pivot:  # the first body block's first row and column 0: singular
        H[nr, nr : nr + lam] = H[nr : nr + lam, nr] = 0.0
    step = np.zeros(g.size)
    ok = kc._solve_body(
        H.copy(), g, step, nr, D, lam, np.zeros((nr, nr)), np.zeros((D, lam, nr + 1)),
        np.zeros(nr), np.zeros(nr), np.zeros((D, nr + 1), np.int64), np.zeros((nr + 1, nr + 1)),
    )  # fmt: skip
    if zero_pivot:  # a body block singular: the caller solves the whole H
        assert not ok
        return
    assert ok
    ref = np.linalg.solve(H, -g)
    _close(ref, step, 1e-12, "step")


def test_a_warm_start_carries_each_pins_unknown_as_the_reference():
    """The kernel's carried start (by pin) is equilibrium._body_carried's, bit for bit."""
    kc._kernels()
    lam = 5
    pins = np.array([[[4, 5, 6]], [[5, 6, -1]], [[6, 7, 8]], [[8, 6, 9]]])  # (A, D, P)
    body = eq._Body.of_dense(
        pin_w=np.zeros((4, 1, 10, lam)),
        hole_w=np.zeros((4, 1, 3, 2, lam)),
        energy=np.zeros((4, 1, lam, lam)),
        pins=pins,
    )
    p = type("P", (), {"body": body})()
    rng = np.random.default_rng(4)
    x = rng.standard_normal((4, 9))
    for i in (1, 2, 3):
        for back in (1, 2) if i >= 2 else (1,):
            own = rng.standard_normal(9)
            ref = eq._body_carried(p, x, np.array([i]), back, own[None, :])[0]
            got = np.zeros(9)
            kc._carry(got, x, own, pins, i, back, 4, lam)
            np.testing.assert_array_equal(got, ref)


def test_the_kernels_state_is_the_references_at_its_solution(problems, monkeypatch):
    """The state the kernel hands the caller (so that it need not evaluate the solution
    again) against stage.assembly.evaluate's there: 1e-13 of each one's largest (the
    gradient: of T/r_c)."""
    import cyclomesh.stage.newton as reference

    settings = reference.kernel_settings(10**6, compliant=True)
    for p, law, start, _sol, D in problems:
        x = start.copy()
        state: dict = {}
        failed = kc.newton(p, law, x, D, p.jacobian, settings, state=state)
        assert not np.any(failed) and state
        monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
        _, g, _, st = eq._evaluate(p, law, x, D, False, hessian=False)
        monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
        for name in ("pin_force", "pin_shift", "bearing_fx", "bearing_fy", "deflection"):
            ref = st[name]
            got = state[name]
            if name == "pin_shift":  # (only the pins with a law enter anything)
                usable = np.isfinite(p.bl)
                ref, got = np.where(usable, ref, 0.0), np.where(usable, got, 0.0)
            _close(ref, got, 1e-13, name)
        scale = max(np.max(np.abs(g)), abs(p.torque) / p.scale)
        assert np.max(np.abs(state["gradient"] - g)) <= 1e-13 * scale


def _symmetric_arrow(rng, nr, D, lam):
    """A symmetric block-arrow matrix with indefinite body blocks (as the body's energy)."""
    H, g = _arrow(rng, nr, D, lam)
    H = 0.5 * (H + H.T)
    for d in range(D):
        z = slice(nr + d * lam, nr + (d + 1) * lam)
        H[z, z] -= 1.5 * np.eye(lam)  # (some eigenvalues below 0)
    return H, g


def _spd_solve(H, g, nr, D, lam):
    step = np.zeros(g.size)
    H0 = H.copy()
    ok = kc._solve_ldl(
        H, g, step, nr, D, lam, np.zeros((nr, nr)), np.zeros((D, lam, nr + 1)),
        np.zeros(nr), np.zeros(nr), np.zeros((D, nr + 1), np.int64), np.zeros((nr + 1, nr + 1)),
        np.zeros((D, lam)), np.zeros((D, lam, lam)), np.zeros(nr, np.int64), np.zeros((D, lam)),
        np.zeros((D, lam, nr)), np.zeros(nr),
    )  # fmt: skip
    return ok, step, H0


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_the_symmetric_block_solve_is_lapacks(seed):
    """The LΔLᵀ elimination of the body blocks (symmetric, indefinite) against LAPACK's
    solve; H is left as it was (the LU fallback needs it)."""
    kc._kernels()
    rng = np.random.default_rng(seed)
    nr, D, lam = 9, 2, 7
    H, g = _symmetric_arrow(rng, nr, D, lam)
    assert np.min(np.linalg.eigvalsh(H[nr : nr + lam, nr : nr + lam])) < 0.0
    ok, step, H0 = _spd_solve(H, g, nr, D, lam)
    assert ok
    np.testing.assert_array_equal(H, H0)
    _close(np.linalg.solve(H0, -g), step, 1e-12, "step")


@pytest.mark.parametrize("case", ["zero pivot", "growth", "singular"])
def test_the_symmetric_block_solve_falls_back_to_the_lu(case):
    """A body block whose first pivot is 0 or whose L would grow beyond _GROWTH goes to
    the LU with partial pivoting (_solve_body), whose result is LAPACK's; a singular body
    block: False (the caller solves the whole H)."""
    kc._kernels()
    rng = np.random.default_rng(8)
    nr, D, lam = 9, 2, 7
    H, g = _symmetric_arrow(rng, nr, D, lam)
    z = nr + lam  # the second disc's block
    if case == "zero pivot":
        H[z, z] = 0.0
    elif case == "growth":
        H[z, z] = 1e-6 * abs(H[z + 1, z])
    else:
        H[z : z + lam, z] = 0.0
        H[z, z : z + lam] = 0.0
    ok, step, H0 = _spd_solve(H, g, nr, D, lam)
    if case == "singular":
        assert not ok
        return
    assert ok
    _close(np.linalg.solve(H0, -g), step, 1e-10, "step")


# --- chord (modified Newton) steps and the Hessian's upper triangle (task i40k) ---


def _ldl_work(nr, D, lam):
    return (
        np.zeros((nr, nr)), np.zeros((D, lam, nr + 1)), np.zeros(nr), np.zeros(nr),
        np.zeros((D, nr + 1), np.int64), np.zeros((nr + 1, nr + 1)), np.zeros((D, lam)),
        np.zeros((D, lam, lam)), np.zeros(nr, np.int64), np.zeros((D, lam)),
        np.zeros((D, lam, nr)), np.zeros(nr),
    )  # fmt: skip


def _upper_only(H):
    """H with its strict lower triangle spoiled (what the compiled Newton's H holds there)."""
    spoiled = H.copy()
    low = np.tril_indices(H.shape[0], -1)
    spoiled[low] = np.nan
    return spoiled


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_a_chord_step_reuses_the_factors(seed):
    """_resolve with the factors _solve_ldl kept: the factored gradient's step bit for bit,
    another gradient's step LAPACK's (1e-12); only H's upper triangle is read."""
    kc._kernels()
    rng = np.random.default_rng(seed)
    nr, D, lam = 9, 2, 7
    H, g = _symmetric_arrow(rng, nr, D, lam)
    S, Y, rhs, sc, cl, T, dg, Lb, piv, v, Wd, ds = _ldl_work(nr, D, lam)
    step = np.zeros(g.size)
    code = kc._solve_ldl(
        _upper_only(H), g, step, nr, D, lam, S, Y, rhs, sc, cl, T, dg, Lb, piv, v, Wd, ds
    )
    assert code == 1
    _close(np.linalg.solve(H, -g), step, 1e-12, "step")
    again = np.zeros(g.size)
    kc._resolve(g, again, nr, D, lam, S, Y, rhs, sc, cl, dg, Lb, piv, v, Wd, ds)
    np.testing.assert_array_equal(again, step)
    g2 = rng.standard_normal(g.size)
    kc._resolve(g2, again, nr, D, lam, S, Y, rhs, sc, cl, dg, Lb, piv, v, Wd, ds)
    _close(np.linalg.solve(H, -g2), again, 1e-12, "chord step")


def test_a_chord_step_after_the_schur_complements_lu():
    """A Schur complement S whose L·Δ·Lᵀ would grow (its first pivot ~1e-9 of its row):
    _solve_ldl still keeps the factors (1), S's by _lu (piv[0] ≥ 0), and _resolve solves
    with those: the factored gradient's step bit for bit, another's LAPACK's (task i43c)."""
    kc._kernels()
    rng = np.random.default_rng(12)
    nr, D, lam = 9, 2, 7
    H, g = _symmetric_arrow(rng, nr, D, lam)
    Z = slice(nr, None)
    S = H[:nr, :nr] - H[:nr, Z] @ np.linalg.solve(H[Z, Z], H[Z, :nr])
    H[0, 0] += 1e-9 * np.max(np.abs(S[0])) - S[0, 0]  # (S_00 ~1e-9 of S's first row)
    S, Y, rhs, sc, cl, T, dg, Lb, piv, v, Wd, ds = _ldl_work(nr, D, lam)
    step = np.zeros(g.size)
    code = kc._solve_ldl(
        _upper_only(H), g, step, nr, D, lam, S, Y, rhs, sc, cl, T, dg, Lb, piv, v, Wd, ds
    )
    assert code == 1 and piv[0] >= 0
    _close(np.linalg.solve(H, -g), step, 1e-9, "step")
    again = np.zeros(g.size)
    kc._resolve(g, again, nr, D, lam, S, Y, rhs, sc, cl, dg, Lb, piv, v, Wd, ds)
    np.testing.assert_array_equal(again, step)
    g2 = rng.standard_normal(g.size)
    kc._resolve(g2, again, nr, D, lam, S, Y, rhs, sc, cl, dg, Lb, piv, v, Wd, ds)
    _close(np.linalg.solve(H, -g2), again, 1e-9, "chord step")


def test_the_lu_with_its_swaps_is_solve_in_place():
    """_lu: kernel_newton._solve_in_place's step bit for bit, its LU and row swaps kept
    for _lu_solve (another right-hand side: LAPACK's)."""
    from cyclomesh.stage import kernel_newton as kn

    kc._kernels()
    rng = np.random.default_rng(11)
    n = 12
    A = rng.standard_normal((n, n))
    b = rng.standard_normal(n)
    ref = np.zeros(n)
    assert kn._solve_in_place(A.copy(), b, ref)
    S, got, piv = A.copy(), np.zeros(n), np.zeros(n, np.int64)
    assert kc._lu(S, b, got, piv)
    np.testing.assert_array_equal(got, ref)
    b2 = rng.standard_normal(n)
    kc._lu_solve(S, b2, got, piv)
    _close(np.linalg.solve(A, -b2), got, 1e-12, "lu solve")
    singular = A.copy()
    singular[:, 3] = 0.0
    assert not kc._lu(singular, b, got, piv)


@pytest.mark.parametrize("case", ["zero pivot", "growth"])
def test_the_lu_fallback_mirrors_the_upper_triangle(case):
    """_solve_ldl's LU fallback (2: no factors kept) from H's upper triangle only."""
    kc._kernels()
    rng = np.random.default_rng(8)
    nr, D, lam = 9, 2, 7
    H, g = _symmetric_arrow(rng, nr, D, lam)
    z = nr + lam
    H[z, z] = 0.0 if case == "zero pivot" else 1e-6 * abs(H[z + 1, z])
    step = np.zeros(g.size)
    code = kc._solve_ldl(_upper_only(H), g, step, nr, D, lam, *_ldl_work(nr, D, lam))
    assert code == 2
    _close(np.linalg.solve(H, -g), step, 1e-10, "step")


def test_the_upper_triangle_evaluation_is_the_whole_ones(problems):
    """_evaluate_one with want 3 (the compiled Newton's): the energy, gradient and the
    Hessian's upper triangle of want 2 bit for bit."""
    kc._kernels()
    p, law, start, _sol, D = problems[0]
    A, m = start.shape
    G, cols, _, _, hole, const, nw, carrier, pin_w, energy, _, block = kc._prepare(
        p, law, start, D, p.jacobian
    )
    sup = p.supports
    P = block.shape[3]
    upper = np.triu_indices(m)
    for i in (0, A // 3, A - 1):
        out = []
        for want in (2, 3):
            memo, pf = np.zeros((3, D, P)), np.zeros((2, A, D, P))
            bf, wrow = np.zeros((A, D, hole.shape[3], 3)), np.zeros((D, P), np.int64)
            g, H = np.zeros(m), np.full((m, m), np.nan)
            kc._rows(wrow, pin_w, i)
            e, st = kc._evaluate_one(
                i, i, start[i].copy(), block, pin_w, energy, hole, G, cols, const, nw,
                float(sup.carrier) if carrier else 0.0, carrier, 0.5 * law.rs.clearance,
                law.rs.constant, float(p.torque), float(p.scale), want, g, H, memo, pf, bf,
                wrow, np.zeros((3, max(m, D * pin_w[0].shape[2], energy.shape[3], 9))),
                np.zeros((D, energy.shape[3], energy.shape[3])),
            )  # fmt: skip
            out.append((e, st, g, H))
        (e2, s2, g2, H2), (e3, s3, g3, H3) = out
        assert e2 == e3 and s2 == s3
        np.testing.assert_array_equal(g2, g3)
        np.testing.assert_array_equal(H2[upper], H3[upper])
        np.testing.assert_array_equal(H2, H2.T)


def test_chord_steps_reach_the_newton_steps_root(problems):
    """The kernel with chord steps (newton._CHORD) against every step Newton's (_CHORD =
    0): the same root, the state at it within 1e-13 of each one's largest; fewer
    Hessians at the rated torque; with _CHORD = 0 every evaluation has its Hessian."""
    import cyclomesh.stage.newton as reference

    settings = reference.kernel_settings(10**6, compliant=True)
    assert settings[-2] == reference._CHORD > 0.0
    newton_only = (*settings[:-2], 0.0, settings[-1])
    for p, law, start, _sol, D in problems:
        out = []
        for s in (settings, newton_only):
            x, state, stats = start.copy(), {}, {}
            failed = kc.newton(p, law, x, D, p.jacobian, s, stats=stats, state=state)
            assert not np.any(failed) and state
            out.append((state, stats["counts"]))
        (chord, c1), (newton, c0) = out
        for name in ("pin_force", "bearing_fx", "bearing_fy"):
            _close(newton[name], chord[name], 1e-13, name)
        np.testing.assert_array_equal(c0[:, 3], c0[:, 0])  # (every evaluation's Hessian)
        if abs(p.torque) > 100.0:
            assert c1[:, 3].sum() < c0[:, 3].sum()
