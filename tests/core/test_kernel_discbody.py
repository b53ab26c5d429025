"""The compiled coupled load sharing of the compliant disc (numba) against the NumPy
reference (issue 27).

Both solve the same equations with the same start, Newton steps, line search and
convergence test; the kernel's logarithms and exponentials are the C library's and its
force inversions start from each pin's last one, so the results agree to round-off:
the per-pin fields to 1e-13 of their largest value, the rotations and the transmission
error to 1e-13 elementwise (as ``tests/core/test_kernel.py``).
"""

import warnings

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification
from cyclomesh.core import kernel, kernel_discbody
from cyclomesh.core.contact import unloaded_contact
from cyclomesh.core.discbody import DiscBody, share_load_coupled, tooth_index
from cyclomesh.core.loadsharing import share_load
from cyclomesh.core.ltca import pin_compliance, rest_position, solve_ltca
from cyclomesh.core.pair import PinErrors
from cyclomesh.drive.solve import solve_drive
from cyclomesh.exceptions import ConvergenceError
from tests.core.test_kernel import _agree  # the kernels' one agreement rule

pytest.importorskip("numba")

MOD = Modification(pin_radius=8e-6)
PHI = np.deg2rad(np.arange(0.0, 360.0, 2.5))
RNG = np.random.default_rng(28)
ERRORS = PinErrors(
    radial=RNG.uniform(-4e-6, 4e-6, (2, 40)), angular=RNG.uniform(-5e-5, 5e-5, (2, 40))
)


def _body(period: int = 1, far: float = 0.0) -> DiscBody:
    """A reciprocal, positive-definite table (web torsion plus a local term decaying with
    the tooth offset), its local term varying with the tooth after which the support
    repeats (``period``); ``far``: a coefficient on the teeth 5 apart [m/N] (negative:
    pins outside the first candidate set that a load elsewhere could bring to touch)."""
    n2 = TABLE1.teeth
    u = np.linspace(-np.pi, 0.0, 13)
    arm = 0.05 * np.abs(np.sin(u)) + 0.01
    d = np.arange(n2)
    dist = np.minimum(d, n2 - d)
    local = 3e-10 * np.exp(-dist)[:, None, None] * np.exp(-((u[:, None] - u[None, :]) ** 2))
    web = 1e-7 * arm[:, None] * arm[None, :]
    table = np.stack([(1.0 + 0.2 * k) * local + web[None] for k in range(period)])
    table[:, 5] += far
    table[:, n2 - 5] += far
    return DiscBody(u, table, n2)


def _both(monkeypatch, solve):
    """The solution on each kernel; the numba kernel must not need the reference."""
    import cyclomesh.core.discbody as cdb

    out = {}
    real = cdb._solve_set_numpy
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        calls = []

        def spy(*args, calls=calls):
            calls.append(1)
            return real(*args)

        monkeypatch.setattr(cdb, "_solve_set_numpy", spy)
        out[name] = solve()
        assert bool(calls) == (name == "numpy"), name
    return out["numpy"], out["numba"]


@pytest.mark.parametrize("period", [1, 3])
def test_compliant_disc_agrees(monkeypatch, period):
    body = _body(period)
    ref, got = _both(
        monkeypatch, lambda: solve_ltca(TABLE1, MOD, ERRORS, 250.0, PHI, True, "half_plane", body)
    )
    _agree(
        ref,
        got,
        ("pin_load", "contact_stress", "groove_stress", "loaded_rotation", "transmission_error"),
    )
    # the kernel's solution is an equilibrium in its own right, and the body yields
    np.testing.assert_allclose(np.sum(got.pin_load * got.moment_arm, axis=-1), 250.0, rtol=1e-12)
    rigid = solve_ltca(TABLE1, MOD, ERRORS, 250.0, PHI, True, "half_plane")
    assert np.all(got.loaded_rotation > rigid.loaded_rotation)


@pytest.mark.parametrize("law", ["half_plane", "paper"])
def test_the_coupled_load_sharing_agrees_on_both_laws(monkeypatch, law):
    """share_load_coupled itself on either law's coefficients (the model pairs the FE
    body with the half-plane law only; the solve takes any α, γ)."""
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")  # the same inputs for both
    geo = unloaded_contact(TABLE1, MOD, ERRORS, PHI)
    backlash = geo.rotation - rest_position(geo.rotation, geo.moment_arm)[..., None]
    alpha, gamma = pin_compliance(geo, TABLE1, True, law)
    tooth = np.broadcast_to(tooth_index(TABLE1.pins, TABLE1.pitch, PHI), backlash.shape)
    problem = (backlash, geo.moment_arm, alpha, gamma, 250.0, _body(), tooth, geo.profile_angle)
    ref = share_load_coupled(*problem)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    got = share_load_coupled(*problem, angle_axis=True)
    np.testing.assert_allclose(got[0], ref[0], rtol=1e-13, atol=0)
    np.testing.assert_allclose(got[1], ref[1], rtol=0, atol=1e-13 * np.max(ref[1]))
    assert np.any(ref[1] != got[1])  # the kernel's own arithmetic, not the reference's


def test_a_compliant_stack_on_both_flanks_agrees(monkeypatch):
    body = _body()
    ref, got = _both(
        monkeypatch,
        lambda: solve_drive(
            TABLE1, MOD, ERRORS, [-250.0, 250.0], PHI[::2], True, 2, "half_plane", body
        ),
    )
    _agree(
        ref, got, ("pin_load", "contact_stress", "transmission_error", "mesh_force", "torque_share")
    )


def test_pins_added_after_the_first_set_agree(monkeypatch):
    """A negative coefficient between teeth 5 apart: pins outside the first candidate set
    are checked, and those that would penetrate added and solved again, on both kernels."""
    body = _body(far=-2e-11)
    ref, got = _both(
        monkeypatch, lambda: solve_ltca(TABLE1, MOD, ERRORS, 250.0, PHI, True, "half_plane", body)
    )
    _agree(ref, got, ("pin_load", "loaded_rotation", "transmission_error"))


def test_failures_are_the_reference_errors(monkeypatch):
    """A case the kernel cannot finish (here a force past the stiffest point of the law)
    goes to the reference, which raises its own error."""
    body = _body()
    messages = []
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        with pytest.raises(ConvergenceError) as info:
            solve_ltca(TABLE1, MOD, None, 5e6, PHI[:4], True, "half_plane", body)
        messages.append(str(info.value))
    assert messages[0] == messages[1] and "torque too large" in messages[0]


def test_the_single_case_and_the_batch_agree(monkeypatch):
    """share_load_coupled on one case (no leading axes) and on a batch, numba kernel."""
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    body = _body()
    bl = np.array([[0.0, 1e-4, 2e-4, np.inf], [0.0, 5e-5, 3e-4, 1e-3]])
    arm = np.full((2, 4), 0.04)
    alpha, gamma = np.full((2, 4), 2e-9), np.full((2, 4), 1e-10)
    tooth, angle = np.array([[0, 1, 2, 3]] * 2), np.full((2, 4), -1.0)
    x, f = share_load_coupled(bl, arm, alpha, gamma, 200.0, body, tooth, angle)
    for k in range(2):
        xk, fk = share_load_coupled(bl[k], arm[k], alpha[k], gamma[k], 200.0, body, tooth[k], -1.0)
        np.testing.assert_array_equal(xk, x[k])
        np.testing.assert_array_equal(fk, f[k])
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    x_ref, f_ref = share_load_coupled(bl, arm, alpha, gamma, 200.0, body, tooth, angle)
    np.testing.assert_allclose(x, x_ref, rtol=1e-13, atol=0)
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-13 * np.max(f_ref))


@pytest.mark.parametrize("name", kernel.KERNELS)
def test_broadcast_inputs_solve_as_full_arrays_without_a_warning(monkeypatch, name):
    """Inputs that differ from the common shape by leading axes of length 1 (as the
    stage's tooth indices, (A, P) beside (1, A, P)) or that really broadcast give the
    full arrays' solution bit for bit, and no NumPy FutureWarning about writeable
    broadcast views reaches the user (numba asks whether its arguments are writeable)."""
    monkeypatch.setenv(kernel.ENV_VAR, name)
    body = _body()
    bl = np.array([[0.0, 1e-4, 2e-4, np.inf], [0.0, 5e-5, 3e-4, 1e-3]])
    arm = np.full((2, 4), 0.04)
    alpha, gamma = np.full((2, 4), 2e-9), np.full((2, 4), 1e-10)
    tooth, angle = np.array([[0, 1, 2, 3]] * 2), np.full((2, 4), -1.0)
    ref = share_load_coupled(bl, arm, alpha, gamma, 200.0, body, tooth, angle)
    real = kernel_discbody.compiled()

    class Asks:  # numba's typeof reads .flags.writeable of every array it types
        def __getattr__(self, attr):
            def call(*args):
                for a in args:
                    if isinstance(a, np.ndarray):
                        assert a.flags.writeable in (True, False)
                return getattr(real, attr)(*args)

            return call

    monkeypatch.setattr(kernel_discbody, "compiled", Asks)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lead = share_load_coupled(
            bl[None], arm[None], alpha[None], gamma[None], 200.0, body, tooth, angle[None]
        )
        spread = share_load_coupled(bl, 0.04, alpha, 1e-10, 200.0, body, tooth[0], -1.0)
    for got in (lead, spread):
        np.testing.assert_array_equal(got[0].reshape(ref[0].shape), ref[0])
        np.testing.assert_array_equal(got[1].reshape(ref[1].shape), ref[1])


def test_the_kernel_keeps_the_reference_constants():
    from cyclomesh.core import hertz

    pair = (kernel_discbody._MAX_NEWTON, kernel_discbody._ROUND_OFF)
    assert pair == (hertz._MAX_NEWTON, hertz._ROUND_OFF)


def test_the_suspect_cases_cover_the_checks_cases():
    """The compiled pass that picks the cases the check after the solve must look at
    flags every case the check's own test flags, and the others only within its
    round-off margin: random solutions, some of their pins outside the candidates just
    below or above the reach of the most negative coefficient, some unusable."""
    rng = np.random.default_rng(5)
    cases, n, lowest = 400, 12, 3e-11
    arm = rng.uniform(0.01, 0.05, (cases, n))
    arm[rng.random((cases, n)) < 0.1] = -0.02
    x = rng.uniform(1e-4, 2e-4, cases)
    full = np.where(rng.random((cases, n)) < 0.5, rng.uniform(0.0, 3e3, (cases, n)), 0.0)
    reach = x[:, None] + lowest * np.sum(full, axis=-1)[:, None] / arm
    bl = reach * (1.0 + rng.choice([-1e-3, -1e-14, 0.0, 1e-14, 1e-3], (cases, n)))
    bl[rng.random((cases, n)) < 0.1] = np.inf
    candidate = rng.random((cases, n)) < 0.7
    usable = np.isfinite(bl) & (arm > 0)
    flagged = np.any(usable & ~candidate & (bl < reach), axis=-1)
    out = np.empty(cases, bool)
    kernel_discbody.compiled().suspects(candidate, bl, arm, x, full, lowest, out)
    assert 0 < np.sum(flagged) < cases
    assert np.all(out[flagged])
    near = np.any(usable & ~candidate & (bl < reach * (1.0 + 1e-11)), axis=-1)
    assert np.all(near[out])  # no case beyond the margin


def test_the_cholesky_solve():
    """The Newton system's Cholesky solve against LAPACK's on positive-definite systems
    of each size, and its refusal of an indefinite one (the kernel then eliminates)."""
    kernel_discbody.compiled()
    rng = np.random.default_rng(3)
    for n in range(1, 13):
        m = rng.normal(size=(n, n))
        a = m @ m.T + n * np.eye(n)
        b = rng.normal(size=(n, 2))
        system, rhs = np.triu(a) + np.tril(np.full((n, n), np.nan), -1), b.copy()
        assert kernel_discbody._cholesky2(n, system, rhs)  # the lower triangle is not read
        np.testing.assert_allclose(rhs, np.linalg.solve(a, b), rtol=1e-12, atol=1e-14)
    indefinite = np.array([[1.0, 2.0], [2.0, 1.0]])
    assert not kernel_discbody._cholesky2(2, indefinite, np.ones((2, 2)))


def test_the_warm_start_order():
    """A pin's loads extrapolated cubically on a smooth run of four loaded cases, linearly
    where it enters contact or its loads' third difference exceeds their second."""
    kernel_discbody.compiled()
    order = kernel_discbody._order
    smooth = [100.0 + 10.0 * t + 0.5 * t * t for t in (3.0, 2.0, 1.0, 0.0)]  # f1 … f4
    assert order(*smooth, 4) == 4
    assert order(*smooth, 9) == 4  # a long streak: still four loads
    assert order(*smooth, 3) == 2 and order(*smooth, 2) == 2 and order(*smooth, 1) == 1
    assert order(30.0, 10.0, 0.0, 0.0, 4) == 2  # entering contact
    assert order(100.0, 100.0, 100.0, 0.0, 4) == 2
    assert order(130.0, 100.0, 100.0, 100.0, 4) == 4  # |Δ³| = |Δ²| = 30: still smooth
    assert order(100.0, 130.0, 100.0, 130.0, 4) == 2  # |Δ³| = 120 > |Δ²| = 60
    ext = kernel_discbody._extrapolate
    assert ext(*smooth, 4) == pytest.approx(100.0 + 40.0 + 8.0, rel=1e-14)  # exact: cubic
    assert ext(*smooth, 2) == pytest.approx(2.0 * smooth[0] - smooth[1], rel=1e-15)


def test_a_case_without_its_start_takes_the_rigid_disc(monkeypatch):
    """The compiled solve of cases whose rigid start is not given (NaN) and that have no
    case before them to start from: the rigid disc is solved for them and they are
    solved as with it given, bit for bit; a ring's later angles start on their own."""
    import cyclomesh.core.discbody as cdb

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    body = _body()
    geo = unloaded_contact(TABLE1, MOD, ERRORS, PHI)
    bl = geo.rotation - rest_position(geo.rotation, geo.moment_arm)[..., None]
    alpha, gamma = pin_compliance(geo, TABLE1, True, "half_plane")
    arm, angle = geo.moment_arm.reshape(-1, 40), geo.profile_angle.reshape(-1, 40)
    bl, alpha, gamma = bl.reshape(-1, 40), alpha.reshape(-1, 40), gamma.reshape(-1, 40)
    tooth = np.broadcast_to(tooth_index(TABLE1.pins, TABLE1.pitch, PHI), (2, PHI.size, 40))
    tooth = np.ascontiguousarray(tooth.reshape(-1, 40))
    own, candidate = cdb._candidates(bl, arm, alpha, gamma, tooth, angle, 250.0, body)
    arrays = (bl, arm, alpha, gamma, tooth, angle, own)
    x0, f0 = kernel.share_load(bl, arm, alpha, gamma, 250.0)  # as the kernel's own call
    given = cdb._solve_set(candidate, arrays, x0.copy(), f0.copy(), 250.0, body, 40)
    nan, zero = np.full(x0.size, np.nan), np.zeros(f0.shape)
    flags, rows = np.empty(x0.size, bool), np.empty(x0.size, bool)
    alone = cdb._solve_set(candidate, arrays, nan, zero, 250.0, body, 40, 1, flags)
    # the check's cases flagged in the solve (here all in its second pass): _suspects'
    kernel_discbody.compiled().suspects(candidate, bl, arm, *alone, body._lowest, rows)
    np.testing.assert_array_equal(flags, rows)
    np.testing.assert_array_equal(alone[0], given[0])
    np.testing.assert_array_equal(alone[1], given[1])
    np.testing.assert_array_equal(nan, x0)  # filled in place where needed: everywhere
    nan, zero = np.full(x0.size, np.nan), np.zeros(f0.shape)
    nan[:: PHI.size], zero[:: PHI.size] = x0[:: PHI.size], f0[:: PHI.size]
    ring = cdb._solve_set(candidate, arrays, nan, zero, 250.0, body, 40, PHI.size, flags)
    kernel_discbody.compiled().suspects(candidate, bl, arm, *ring, body._lowest, rows)
    np.testing.assert_array_equal(flags, rows)
    assert np.sum(np.isnan(nan)) > 0.9 * x0.size  # mostly its own starts (2.5° apart)
    np.testing.assert_allclose(ring[0], given[0], rtol=1e-14, atol=0)
    np.testing.assert_allclose(ring[1], given[1], rtol=0, atol=1e-14 * np.max(given[1]))


def _problem(body=None, law="half_plane"):
    """share_load_coupled's inputs for PHI (one ring, no errors) [rad, m, m/N, m/N]."""
    geo = unloaded_contact(TABLE1, MOD, None, PHI)
    bl = geo.rotation - rest_position(geo.rotation, geo.moment_arm)[..., None]
    alpha, gamma = pin_compliance(geo, TABLE1, True, law)
    tooth = tooth_index(TABLE1.pins, TABLE1.pitch, PHI)
    body = _body() if body is None else body
    return (bl, geo.moment_arm, alpha, gamma, 250.0, body, tooth, geo.profile_angle)


def test_the_reference_runs_to_the_root_at_round_off(monkeypatch):
    """The NumPy reference's Newton goes on from its tolerances to round-off: at its end
    the torque residual is a few units in the last place of T and the compatibility
    l·(Δφc − φbl) − C·F − δ(F) of every loaded pin a few of the largest approach; and
    two starts (the rigid disc's Δφc and one 1e-3 of itself above) end at the same loads
    to round-off, not 1e-12 apart (where the old test stopped)."""
    import cyclomesh.core.discbody as cdb

    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    bl, arm, alpha, gamma, torque, body, tooth, angle = _problem()
    x, f = share_load_coupled(bl, arm, alpha, gamma, torque, body, tooth, angle)
    eps = np.finfo(float).eps
    assert np.all(np.abs(np.sum(f * arm, axis=-1) - torque) <= 16 * eps * torque)
    c = body.reciprocal_matrix(tooth, angle)
    loaded = f > 0
    with np.errstate(invalid="ignore"):
        approach = arm * (x[:, None] - bl) - np.einsum("aij,aj->ai", c, f)
    law = np.where(loaded, f * (alpha - gamma * np.log(np.where(loaded, f, 1.0))), 0.0)
    scale = np.max(np.where(loaded, approach, 0.0), axis=-1, keepdims=True)
    assert np.all(np.abs(np.where(loaded, approach - law, 0.0)) <= 64 * eps * scale)
    # two starts, the same root
    diag, candidate = cdb._candidates(bl, arm, alpha, gamma, tooth, angle, torque, body)
    arrays = (bl, arm, alpha, gamma, tooth, angle, diag)
    x0, f0 = share_load(bl, arm, alpha, gamma, torque)
    a = cdb._solve_set_numpy(candidate, arrays, x0, f0, torque, body, 40)
    b = cdb._solve_set_numpy(candidate, arrays, x0 * (1.0 + 1e-3), f0, torque, body, 40)
    np.testing.assert_allclose(b[0], a[0], rtol=4e-15, atol=0)
    np.testing.assert_allclose(b[1], a[1], rtol=0, atol=4e-15 * np.max(a[1]))
    assert not np.array_equal(a[1], b[1])  # two paths, not one


@pytest.mark.parametrize("law", ["half_plane", "paper"])
def test_the_kernel_lands_on_the_references_root(monkeypatch, law):
    """Both run to the root at round-off, so the kernel's own starts (the roots of the
    crank angles before) end where the reference's rigid start does: within a few units
    in the last place, not the 1e-13 the kernels' agreement allows; the kernel's warm
    candidate sets (the pins its start can reach) are written back for the check."""
    problem = _problem(law=law)
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = share_load_coupled(*problem)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    got = share_load_coupled(*problem, angle_axis=True)
    np.testing.assert_allclose(got[0], ref[0], rtol=4e-15, atol=0)
    np.testing.assert_allclose(got[1], ref[1], rtol=0, atol=1e-14 * np.max(ref[1]))


def test_a_warm_start_candidate_set_and_the_check_after(monkeypatch):
    """The kernel's warm cases choose their own candidates (the pins within reach of the
    start): with a negative coefficient between teeth 5 apart (pins outside them that a
    load elsewhere could bring to touch) the solution is the reference's, at 0.25° and
    at 10° between crank angles (a poor extrapolation)."""
    body = _body(far=-2e-11)
    for phi in (np.deg2rad(np.arange(0.0, 30.0, 0.25)), np.deg2rad(np.arange(0.0, 360.0, 10.0))):
        ref, got = _both(
            monkeypatch,
            lambda phi=phi: solve_ltca(TABLE1, MOD, ERRORS, 250.0, phi, True, "half_plane", body),
        )
        np.testing.assert_allclose(
            got.pin_load, ref.pin_load, rtol=0, atol=1e-14 * np.max(ref.pin_load)
        )


def test_a_rings_first_case_takes_the_pins_its_start_can_reach(monkeypatch):
    """A ring's first crank angle (the rigid disc's start) is solved on the single-pin
    bound's candidates and the pins that start can reach by the table's most negative
    coefficient (as a warm start's): written into the caller's candidates, a superset of
    the bound's, and the check after the solve has no case to look at; the solution is
    the reference's."""
    import cyclomesh.core.discbody as cdb

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    body = _body(far=-1e-9)  # strongly negative: the start reaches past the bound
    bl, arm, alpha, gamma, torque, body, tooth, angle = _problem(body)
    tooth = np.ascontiguousarray(np.broadcast_to(tooth, bl.shape))
    own, bound = cdb._candidates(bl, arm, alpha, gamma, tooth, angle, torque, body)
    arrays = (bl, arm, alpha, gamma, tooth, angle, own)
    x0, f0 = np.full(PHI.size, np.nan), np.zeros(bl.shape)
    cdb._rigid_start(arrays, torque, x0, f0, np.array([0]))
    candidate, flags = bound.copy(), np.empty(PHI.size, bool)
    x, force = cdb._solve_set(candidate, arrays, x0, f0, torque, body, 40, PHI.size, flags)
    usable = np.isfinite(bl[0]) & (arm[0] > 0)
    reach = x0[0] * 1.05 + 1.05 * body._lowest * np.sum(f0[0]) / np.where(usable, arm[0], 1.0)
    assert np.all(candidate[0] >= bound[0])
    np.testing.assert_array_equal(candidate[0], bound[0] | (usable & (bl[0] < reach)))
    assert np.sum(candidate[0]) > np.sum(bound[0])  # here the start reaches more pins
    assert not np.any(flags)
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = share_load_coupled(*_problem(body))
    np.testing.assert_allclose(x, ref[0], rtol=1e-14, atol=0)
    np.testing.assert_allclose(force, ref[1], rtol=0, atol=1e-14 * np.max(ref[1]))


def test_the_tooth_index_on_both_kernels(monkeypatch):
    """tooth_index compiled is NumPy's, integer for integer (halves to even, negative
    crank angles, any leading shape)."""
    rng = np.random.default_rng(7)
    angles = (
        np.deg2rad(np.arange(3600) * 0.1),
        rng.uniform(-100.0, 100.0, (5, 36)),
        np.arange(-2000, 2000) * np.pi / TABLE1.teeth,
        np.float64(0.3),
    )
    for phi in angles:
        out = {}
        for name in kernel.KERNELS:
            monkeypatch.setenv(kernel.ENV_VAR, name)
            out[name] = tooth_index(TABLE1.pins, TABLE1.pitch, phi)
        assert out["numba"].dtype == out["numpy"].dtype == np.int64
        np.testing.assert_array_equal(out["numba"], out["numpy"])


def test_a_ring_goes_on_warm_after_a_case_given_up(monkeypatch):
    """A case the kernel gives up in the middle of a ring (here one no pin can touch:
    status 2, the rigid disc's start asked for) does not end the ring's warm starts: the
    cases after it start from the last one solved, and every case solved is the
    reference's root; the case given up has its single-pin bound candidates and own
    coefficients back (for the caller's rigid start)."""
    import cyclomesh.core.discbody as cdb

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    bl, arm, alpha, gamma, torque, body, tooth, angle = _problem()
    hole = bl.copy()
    hole[10] = np.inf  # no pin can touch at the eleventh crank angle
    n = bl.shape[-1]
    own, candidate = np.empty(bl.shape), np.empty(bl.shape, bool)
    u = body.profile_angles
    grid = np.array([u[0], u[-1], u[1] - u[0], u.size], float)
    passes = kernel_discbody.compiled()
    block = bl.shape[0]
    passes.candidates(hole, arm, alpha, gamma, tooth, angle, body.diagonal, grid, torque,
                      block, own, candidate)  # fmt: skip
    x0, f0 = np.full(block, np.nan), np.zeros(bl.shape)
    x0[0], f0[0] = share_load(bl[0], arm[0], alpha[0], gamma[0], torque)
    rotation, force, status = np.empty(block), np.zeros(bl.shape), np.zeros(block, np.int8)
    suspect = np.empty(block, bool)
    failed = passes.solve_sets(
        candidate, hole, arm, alpha, gamma, tooth, angle, own, x0, f0, body._padded.ravel(),
        body.diagonal, grid, body.teeth, body.period, n, torque, cdb.TORQUE_TOLERANCE,
        cdb.COMPATIBILITY_TOLERANCE, cdb.ROUND_OFF, 100, body._lowest, block, rotation,
        force, status, suspect
    )  # fmt: skip
    assert failed == 1 and status[10] == 2 and not np.any(candidate[10])
    solved = status == 0
    # the flags taken in the solve: _suspects' on the cases solved, True on the other
    rows = np.empty(block, bool)
    passes.suspects(candidate, hole, arm, rotation, force, body._lowest, rows)
    np.testing.assert_array_equal(suspect[solved], rows[solved])
    assert suspect[10]
    assert np.sum(solved) == block - 1
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref_x, ref_f = share_load_coupled(bl, arm, alpha, gamma, torque, body, tooth, angle)
    np.testing.assert_allclose(rotation[solved], ref_x[solved], rtol=4e-15, atol=0)
    np.testing.assert_allclose(force[solved], ref_f[solved], rtol=0, atol=1e-14 * np.max(ref_f))
    ref_own = cdb._candidates(bl, arm, alpha, gamma, tooth, angle, torque, body)[0]
    np.testing.assert_allclose(own[10], ref_own[10], rtol=1e-14, atol=0)
