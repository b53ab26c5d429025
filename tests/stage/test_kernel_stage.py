"""The stage's compiled laws (cyclomesh.stage.kernel, CYCLOMESH_KERNEL=numba) against the
NumPy reference: the roller set and the pins' law element by element, and whole stage
solves (rigid bearings, bearings with clearance, crankshafts and carrier from geometry,
the rated torque and ±3 % of it, pin and crank hole errors) to round-off; failures are
still raised."""

import numpy as np
import pytest

import cyclomesh.stage.equilibrium as eq
from cyclomesh.core import kernel
from cyclomesh.exceptions import ConvergenceError
from cyclomesh.stage import StageDesign, solve_stage
from cyclomesh.stage.bearing import radial_law
from cyclomesh.stage.kernel import pin_law, roller_law

pytest.importorskip("numba")

from tests.stage.test_newton import BEARING, HOLES, LIGHT, MOD, RV40, _hard_stage  # noqa: E402

PHI = np.radians(np.arange(0.0, 360.0, 6.0))
FIELDS = (
    "twist",
    "transmission_error",
    "mesh_transmission_error",
    "pin_load",
    "bearing_load",
    "bearing_deflection",
    "disc_translation_x",
    "disc_translation_y",
    "disc_rotation",
    "contact_stress",
)


def test_roller_law_is_the_reference_to_round_off():
    s = np.concatenate([np.linspace(0.0, 3e-6, 60), np.geomspace(2.5e-6, 5e-5, 60)])
    s = s.reshape(12, 10)
    ref = radial_law(BEARING, s)
    got = roller_law(np.cos(BEARING.angles), 0.5 * BEARING.clearance, BEARING.constant, s, True)
    for a, b in zip(ref, got, strict=True):
        assert b.shape == s.shape
        assert np.all((a == 0.0) == (b == 0.0))  # the same rollers loaded
        assert np.all(np.abs(a - b) <= 1e-14 * np.abs(a))
    assert roller_law(np.cos(BEARING.angles), 2.5e-6, BEARING.constant, s, False)[1] is None


def test_pin_law_is_the_reference_to_round_off():
    rng = np.random.default_rng(3)
    shape = (5, 2, 30)
    alpha = rng.uniform(1.5e-9, 2.5e-9, shape)
    gamma = rng.uniform(0.6e-10, 1e-10, shape)
    gamma[0, 0, :5] = 0.0  # the linear spring
    arm = rng.uniform(-0.06, 0.06, shape)
    nx, ny = rng.uniform(-1, 1, shape), rng.uniform(-1, 1, shape)
    bl = rng.uniform(-2e-5, 2e-5, shape)
    bl[1, 1, ::4] = np.inf  # pins without a law
    with np.errstate(
        divide="ignore", over="ignore", invalid="ignore"
    ):  # half the stiffest point, as _problem
        dmax = np.where(gamma > 0, 0.5 * gamma * np.exp(alpha / gamma - 1.0), np.inf)
    dmax[2, 0, :] = 1e-9  # approaches past it: that crank angle is "bad"
    theta = rng.uniform(-2e-5, 2e-5, shape[:2])
    ux, uy = rng.uniform(-2e-6, 2e-6, shape[:2]), rng.uniform(-2e-6, 2e-6, shape[:2])
    shift = rng.uniform(-1e-7, 1e-7, shape)
    for u, sh in (((None, None), None), ((ux, uy), None), ((ux, uy), shift)):
        p = eq._Problem(bl, arm, nx, ny, alpha, gamma, dmax, *(np.zeros((5, 3)),) * 2,
                        *(np.zeros((5, 2, 3)),) * 2, 1.0, 1.0)  # fmt: skip
        ref = eq._pins(p, theta, *u, sh)
        got = pin_law(bl, arm, nx, ny, alpha, gamma, dmax, theta, *u, sh)
        assert np.array_equal(ref[3], got[3]) and ref[3][2] and not np.all(ref[3])
        for a, b in zip(ref[:3], got[:3], strict=True):
            assert np.all((a == 0.0) == (b == 0.0))  # the same pins closed
            assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a))
        assert np.count_nonzero(ref[0]) > 50


def test_pin_law_hands_an_uninvertible_pin_to_the_reference():
    one = np.ones((1, 1, 1))
    # δ = 1 mm past the stiffest point γ·exp(α/γ − 1) of this law, but below dmax
    got = pin_law(0 * one, one * 1e-2, 0 * one, 0 * one, 2e-9 * one, 2e-10 * one,
                  np.inf * one, np.full((1, 1), 0.1), None, None, None)  # fmt: skip
    assert got is None


def test_stiff_limit_split_is_the_reference_to_round_off(monkeypatch):
    """The start's split of each disc's load over its bearings, compiled and NumPy: the
    same forces to round-off, each disc's resultant and moment carried (Σ B·d̂ = target)."""
    from cyclomesh.stage.supports import stiff_limit_split

    rng = np.random.default_rng(5)
    A, D, N, L = 40, 2, 3, 36e-3
    ang = rng.uniform(0, 2 * np.pi, (A, 1)) + 2 * np.pi * np.arange(N) / N
    hx, hy = L * np.cos(ang), L * np.sin(ang)
    fx, fy = rng.normal(0, 3e3, (A, D)), rng.normal(0, 3e3, (A, D))
    moment = rng.normal(0, 200.0, (A, D))
    fx[3, 1] = fy[3, 1] = moment[3, 1] = 0.0  # a disc that carries nothing
    out = {}
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = stiff_limit_split(hx, hy, L, fx, fy, moment)
    for a, b in zip(out["numpy"], out["numba"], strict=True):
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a))
    bx, by = out["numba"]
    assert np.allclose(bx.sum(-1), fx, rtol=0, atol=1e-9 * 3e3)
    assert np.allclose(by.sum(-1), fy, rtol=0, atol=1e-9 * 3e3)
    assert np.allclose(np.sum(hx[:, None] * by - hy[:, None] * bx, -1), moment, atol=1e-9 * 200)
    assert np.all(bx[3, 1] == 0.0) and np.all(by[3, 1] == 0.0)


@pytest.mark.parametrize("spring", [None, 300e6])
def test_bearing_deflection_is_the_reference_to_round_off(monkeypatch, spring):
    """The start's bearing deflection at a load, compiled and NumPy, with and without a
    series spring: the same s to round-off, and the law gives back the load."""
    from cyclomesh.stage.supports import BearingLaw, bearing_deflection

    law = BearingLaw(BEARING, spring)
    force = np.concatenate([[0.0, 1e-3, 1.0], np.geomspace(10.0, 2e4, 57)]).reshape(6, 10)
    out = {}
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = bearing_deflection(law, force)
    assert np.max(np.abs(out["numpy"] - out["numba"])) <= 1e-14 * np.max(out["numpy"])
    back = law.evaluate(out["numba"])[0]
    assert np.allclose(back, force, rtol=1e-11, atol=1e-12)


def _both(monkeypatch, solve):
    out = {}
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = solve()
    return out["numpy"], out["numba"]


def _agree(ref, got):
    """Every field to 1e-13 of its largest value, the positions of the discs that carry
    nothing (floating in their clearance at ±3 % with errors) included: they are the
    canonical point of their free set (cyclomesh.stage.floating), not the solver's."""
    for name in FIELDS:
        a, b = np.asarray(getattr(ref, name)), np.asarray(getattr(got, name))
        assert a.shape == b.shape, name
        assert np.array_equal(np.isfinite(a), np.isfinite(b)), name
        fin = np.isfinite(a)
        scale = np.max(np.abs(a[fin]))
        assert np.max(np.abs(a[fin] - b[fin])) <= 1e-13 * scale, name


@pytest.mark.parametrize("seed", [0, 1])
def test_the_stage_with_crankshafts_carrier_and_errors_agrees(monkeypatch, seed):
    """The tolerance study's ring: the rated torque and ∓3 % of it, pin errors and crank
    hole errors beyond the clearance (discs that float, bearings at zero load)."""
    errors, stage = _hard_stage(seed)
    torques = [412.0, -LIGHT, LIGHT]
    ref, got = _both(
        monkeypatch, lambda: solve_stage(RV40, stage, MOD, errors, torques, PHI, discs=2)
    )
    _agree(ref, got)


@pytest.mark.parametrize("bearing", [None, BEARING])
def test_rigid_and_clearance_bearings_agree(monkeypatch, bearing):
    stage = StageDesign(HOLES, bearing)
    ref, got = _both(
        monkeypatch,
        lambda: solve_stage(RV40, stage, MOD, None, [412.0, -LIGHT], PHI, discs=2),
    )
    _agree(ref, got)


def test_a_torque_too_large_still_raises(monkeypatch):
    messages = []
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        with pytest.raises(ConvergenceError) as info:
            solve_stage(RV40, StageDesign(HOLES, BEARING), MOD, None, 5e6, PHI[:4], discs=2)
        messages.append(str(info.value))
    assert messages[0] == messages[1]


def test_non_convergence_still_raises(monkeypatch):
    """Newton's iteration cut to one step cannot reach the tolerance: both kernels raise."""
    import cyclomesh.stage.newton as nt

    monkeypatch.setattr(nt, "_MAX_ITERATIONS", 1)
    errors, stage = _hard_stage(0)
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        with pytest.raises(ConvergenceError, match="did not converge"):
            solve_stage(RV40, stage, MOD, errors, [LIGHT], PHI[:4], discs=2)


def test_the_compiled_newton_does_the_work(monkeypatch):
    """With the numba kernel every crank angle of the rigid and the bearing phase is solved
    by the compiled iteration: the reference is not called."""

    def refuse(*args, **kwargs):
        raise AssertionError("fell back to the NumPy Newton")

    errors, stage = _hard_stage(1)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    monkeypatch.setattr(eq, "newton", refuse)
    got = solve_stage(RV40, stage, MOD, errors, [412.0, -LIGHT, LIGHT], PHI, discs=2)
    tol = 1e-12 * np.array([412.0, LIGHT, LIGHT])[:, None] / HOLES.circle_radius
    assert np.all(got.residual <= tol)


def test_the_ring_whose_potential_has_no_digits_agrees(monkeypatch):
    """Ring 1255 of bench_stage's study at +3 %, crank angles 284° and 332°, where one
    disc's crank bearings end at zero load and the potential has no digits left for the
    line search's sufficient-decrease test (test_newton): the compiled iteration solves
    both angles itself, as the reference does, with the same answer to 1e-13 (before
    both judged such steps by the residual, the kernel stalled at 284° and the reference
    at 332°)."""
    from tests.stage.test_newton import ring_1255

    design, errors, stage = ring_1255()
    phi = np.radians([284.0, 332.0])
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = solve_stage(design, stage, MOD, errors, [LIGHT], phi, discs=2)

    def refuse(*args, **kwargs):
        raise AssertionError("fell back to the NumPy Newton")

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    monkeypatch.setattr(eq, "newton", refuse)
    got = solve_stage(design, stage, MOD, errors, [LIGHT], phi, discs=2)
    assert np.all(got.residual <= 1e-12 * LIGHT / HOLES.circle_radius)
    _agree(ref, got)


def test_the_block_solve_is_the_dense_solve():
    """The compiled Newton's step with the crank pins' deflections eliminated first
    (kernel_newton._solve_blocks) is H⁻¹g of the whole matrix to round-off, on the stage's
    structure (c, θ and u of two discs, 2 × 3 pin deflections x, y, β), also where a disc
    has no stiffness but the regularisation's (floating); with a bearing reaching another
    crankshaft's deflection the structure is refused (one pivoted elimination)."""
    import cyclomesh.stage.kernel_newton as kn

    kn._kernels_newton()  # compiles
    D, N = 2, 3
    m = 1 + 3 * D + 2 * D * N + 1
    base = 1 + 3 * D
    nonzero = np.zeros((D, N, m), bool)
    for d in range(D):
        for k in range(N):
            w = base + 2 * (d * N + k)
            nonzero[d, k, [0, 1 + 3 * d, 2 + 3 * d, 3 + 3 * d, w, w + 1, m - 1]] = True
    core, blocks = kn._structure(nonzero, D, N, 2 * D * N, m)
    assert blocks.shape == (N, 2 * D) and core.size == m - 2 * D * N
    rng = np.random.default_rng(5)
    for floating in (False, True):
        H = np.zeros((m, m))
        for d in range(D):
            for k in range(N):
                c = np.flatnonzero(nonzero[d, k])
                if floating and d == 1:
                    c = c[c != 2 + 3 * d]  # no stiffness along the disc's u_x
                a = rng.normal(size=(2, c.size))
                H[np.ix_(c, c)] += 1e8 * a.T @ a
            H[1 + 3 * d : 4 + 3 * d, 1 + 3 * d : 4 + 3 * d] += 0.0 if floating else 1e7
        for k in range(N):  # the crankshaft's beam, coupling its pins at both discs
            for c in range(2):
                idx = [base + 2 * (d * N + k) + c for d in range(D)]
                H[np.ix_(idx, idx)] += np.array([[3e8, -1e8], [-1e8, 3e8]])
        H[m - 1, m - 1] += 1e6
        H[np.diag_indices(m)] += 1e-14 * np.max(np.abs(np.diag(H)))
        g = rng.normal(size=m)
        want = np.linalg.solve(H, -g)
        step = np.zeros(m)
        work = (np.zeros((core.size, core.size)), np.zeros((2 * D, core.size + 1)))
        ok = kn._solve_blocks(
            H.copy(), g, step, core, blocks, *work, np.zeros(core.size), np.zeros(core.size)
        )
        assert ok
        assert np.max(np.abs(step - want)) <= 1e-9 * np.max(np.abs(want)), floating
    nonzero[0, 0, base + 2 * (0 * N + 1)] = True  # a bearing on another crankshaft's pin
    core, blocks = kn._structure(nonzero, D, N, 2 * D * N, m)
    assert blocks.shape[0] == 0 and core.size == m


def test_the_compiled_newton_asks_for_the_starts_it_needs(monkeypatch):
    """The compiled bearing phase forms a crank angle's own start (rigid solution, split,
    deflections) only where it cannot start from the crank angles before: once a solve
    over the revolution (a tolerance ring, whose outputs need no rigid solution elsewhere,
    forms the rigid phase there alone too); with runs of 5 (a warm start refused every 5th
    crank angle) at those angles, and the answers are the same roots to 1e-13 of the NumPy
    reference's."""
    from cyclomesh.core.case import Case, Model
    from cyclomesh.stage.solve import solve
    from cyclomesh.tolerance.tasks import STAGE_OUTPUTS

    errors, stage = _hard_stage(0)
    torques = [412.0, -LIGHT, LIGHT]
    split, rigid = eq.stiff_limit_split, eq._solve
    asked, phases = [], []

    def counted_split(hx, *args):
        asked.append(hx.shape[0])
        return split(hx, *args)

    def counted_solve(p, law, x, *args, **kwargs):
        phases.append((law is None, x.shape[0]))
        return rigid(p, law, x, *args, **kwargs)

    start = eq.compiled_start  # the start in one compiled pass (its split inside)

    def counted_start(block, force, stiffness, x, *args):
        got = start(block, force, stiffness, x, *args)
        if got is not None:  # (else the NumPy start, counted by its split)
            asked.append(x.shape[0])
        return got

    monkeypatch.setattr(eq, "stiff_limit_split", counted_split)
    monkeypatch.setattr(eq, "compiled_start", counted_start)
    monkeypatch.setattr(eq, "_solve", counted_solve)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    ring = solve(
        Case(RV40, MOD, errors, np.array(torques), PHI),
        Model(discs=2, stage=stage),
        positions=False,
        outputs=STAGE_OUTPUTS,
    )
    assert asked == [1, 1, 1]  # the first crank angle of each torque's solve
    assert phases == [(True, 1)] * 3  # the rigid phase of that crank angle alone
    asked.clear()
    monkeypatch.setattr(eq, "kernel_run", lambda angles: 5)
    got = solve_stage(RV40, stage, MOD, errors, torques, PHI, discs=2)
    assert asked == [1] * (3 * PHI.size // 5)  # crank angles 0, 5, 10, … of each torque
    monkeypatch.setattr(eq, "stiff_limit_split", split)
    monkeypatch.setattr(eq, "_solve", rigid)
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = solve_stage(RV40, stage, MOD, errors, torques, PHI, discs=2)
    _agree(ref, got)
    for name in ("transmission_error", "bearing_load", "contact_stress"):
        a, b = getattr(ref, name), getattr(ring, name)
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a)), name


def test_the_pin_block_is_the_problems_arrays(monkeypatch):
    """The compiled iteration's one argument for the seven per-pin arrays: the block that
    the problem's arrays are views of (no copy), else (a problem of some crank angles) a
    stacked copy of the same values."""
    import cyclomesh.stage.kernel_newton as kn

    seen = []
    newton = eq.kernel_newton

    def keep(p, *args, **kwargs):
        seen.append(p)
        return newton(p, *args, **kwargs)

    monkeypatch.setattr(eq, "kernel_newton", keep)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    solve_stage(RV40, StageDesign(HOLES, BEARING), MOD, None, 412.0, PHI[:8], discs=2)
    p = seen[0]
    block = kn.pin_block(p)
    assert block is p.pins and block.shape == (7, *p.bl.shape)
    for q, name in enumerate(kn.PIN_BLOCK):
        assert np.shares_memory(block[q], getattr(p, name))
        assert np.array_equal(block[q], getattr(p, name))
    sub = p.take(np.array([1, 4]))
    copy = kn.pin_block(sub)
    assert sub.pins is None and not np.shares_memory(copy, block)
    assert np.array_equal(copy, block[:, [1, 4]])


OUTPUTS = ("torque_share", "mesh_force", "mesh_force_angle", "max_roller_load", "groove_load")


@pytest.mark.parametrize("seed", [0, 1])
def test_the_outputs_after_the_newton_agree(monkeypatch, seed):
    """What numba forms after the compiled iteration in one pass each (the mesh's work,
    the torque share and mesh force of every disc, the largest roller load): the
    reference's to round-off (1e-14 of each one's largest value), at the rated torque
    and at +3 % with pin and crank hole errors."""
    errors, stage = _hard_stage(seed)
    ref, got = _both(
        monkeypatch, lambda: solve_stage(RV40, stage, MOD, errors, [412.0, LIGHT], PHI, discs=2)
    )
    for name in OUTPUTS:
        a, b = np.asarray(getattr(ref, name)), np.asarray(getattr(got, name))
        assert np.max(np.abs(a - b)) <= 1e-14 * np.max(np.abs(a)), name
    for part, a in ref.work.items():
        scale = max(np.max(np.abs(w)) for w in ref.work.values())
        assert np.max(np.abs(a - got.work[part])) <= 1e-14 * scale, part


def test_the_largest_roller_load_is_the_largest_of_the_rollers(monkeypatch):
    """eq._max_roller_load with numba (the roller of the largest cos ψ alone) is the
    largest of bearing.roller_loads bit for bit: raceway displacements inside the
    clearance (no roller loaded), at its edge and beyond."""
    from cyclomesh.stage.bearing import roller_loads

    s = np.concatenate([[0.0, 0.5 * BEARING.clearance], np.geomspace(1e-9, 5e-5, 97)])
    s = s.reshape(3, 3, 11)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    got = eq._max_roller_load(BEARING, s)
    assert np.array_equal(got, np.max(roller_loads(BEARING, s), axis=-1))
    assert np.any(got == 0.0) and np.any(got > 0.0)


@pytest.mark.parametrize("discs", [1, 2, 3])
def test_the_compiled_problem_is_the_references_bit_for_bit(monkeypatch, discs):
    """eq._problem with numba (stage.kernel.flank_block: the loaded flanks, the mirror's
    opposite flanks and their selects in one pass) gives the NumPy reference's arrays bit
    for bit, signs of zeros included (the unusable opposite flanks' arm −0), with pin
    errors; and the compiled rigid start (single_rotation, its pins passed over where φbl
    is not below the smallest so far) the reference's rotation bit for bit."""
    from cyclomesh.core.pair import PinErrors
    from cyclomesh.drive.mesh import stack_meshes
    from cyclomesh.stage.kernel import single_rotation

    rng = np.random.default_rng(discs)
    errors = PinErrors(radial=rng.uniform(-2e-6, 2e-6, 40), angular=rng.uniform(-2e-5, 2e-5, 40))
    phi = np.radians(np.arange(0.0, 360.0, 2.0))
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    fwd, rev = stack_meshes(
        RV40, MOD, errors, phi, discs, True, True, True, "half_plane", None, False
    )
    stage = StageDesign(HOLES, BEARING)
    errs = stage.hole_errors(discs)
    got = eq._problem(fwd, rev, HOLES, errs, 412.0)
    fast = single_rotation(got.bl, got.arm, got.alpha, got.gamma, 412.0, 40)
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = eq._problem(fwd, rev, HOLES, errs, 412.0)
    for name in ("bl", "arm", "nx", "ny", "alpha", "gamma", "dmax", "hx", "hy", "ex", "ey"):
        a, b = getattr(ref, name), getattr(got, name)
        np.testing.assert_array_equal(b, a, err_msg=name)
        np.testing.assert_array_equal(np.signbit(b), np.signbit(a), err_msg=name)
    assert np.any(np.isinf(ref.bl[..., 40:]))  # some opposite flanks without a law
    assert got.pins is not None and np.shares_memory(got.pins, got.bl)
    np.testing.assert_array_equal(fast, eq._single_rotation(ref, 412.0, 40))


def test_dmax_from_the_flank_pass_is_the_references_at_its_edges():
    """stage.kernel.flank_block's α/γ − 1 and dmax_finish (NumPy's exponential between two
    compiled passes) give _pin_problem's dmax bit for bit where γ is 0, negative, NaN or
    inf, α/γ − 1 overflows the exponential or is 0/0, on both flanks."""
    from cyclomesh.stage.kernel import dmax_finish, flank_block

    rng = np.random.default_rng(7)
    A, D, n1 = 5, 2, 6
    specials = np.array([0.0, -1e-9, np.nan, np.inf, 1e-300, 2e-9])
    alpha = rng.uniform(1e-9, 3e-9, (A, D, n1))
    gamma = rng.choice(specials, (A, D, n1))
    alpha[0, 0, :] = [0.0, 1.0, np.nan, np.inf, 5e-9, 0.0]
    gamma[0, 0, :] = [0.0, 1e-300, 1e-9, 1e-9, 1e-9, 1e-12]
    this = (
        rng.uniform(0, 1e-3, (A, D, n1)),
        rng.uniform(0, 0.06, (A, D, n1)),
        rng.uniform(-1, 1, (A, D, n1)),
        rng.uniform(-1, 1, (A, D, n1)),
        alpha,
        gamma,
    )
    that = (
        rng.uniform(0, 0.06, (A, D, n1)),
        rng.uniform(-1, 1, (A, D, n1)),
        rng.uniform(-1, 1, (A, D, n1)),
        alpha[::-1].copy(),
        gamma[:, ::-1].copy(),
    )
    reverse = rng.uniform(0, 1e-2, (A, D, n1))
    rest = rng.uniform(-1e-3, 0, A)
    block = np.empty((7, A, D, 2 * n1))
    flank_block(block, this, that, reverse, rest)
    ref = block.copy()
    dmax_finish(block, eq._REACH)
    want = eq._pin_problem(ref, None, None, None, None, 1.0, 1.0).dmax
    np.testing.assert_array_equal(block[6], want)
    np.testing.assert_array_equal(block[:6], ref[:6])
    assert np.any(np.isinf(want)) and np.any(np.isfinite(want))


@pytest.mark.parametrize("step", [15.0, 45.0])
def test_the_warm_starts_agree_at_coarse_crank_steps(monkeypatch, step):
    """The bearing phase's warm start (the parabola through the three solutions before,
    else the line through two, else the solution before) at coarse crank steps, where the
    parabola lands far from the root: the compiled iteration finishes every crank angle
    itself, with the reference's answers to 1e-13."""
    errors, stage = _hard_stage(1)
    phi = np.radians(np.arange(0.0, 360.0, step))
    torques = [412.0, -LIGHT, LIGHT]
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = solve_stage(RV40, stage, MOD, errors, torques, phi, discs=2)

    def refuse(*args, **kwargs):
        raise AssertionError("fell back to the NumPy Newton")

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    monkeypatch.setattr(eq, "newton", refuse)
    got = solve_stage(RV40, stage, MOD, errors, torques, phi, discs=2)
    _agree(ref, got)
