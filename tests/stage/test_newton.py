"""The stage's Newton iteration (cyclomesh.stage.newton, equilibrium._solve): the pins near
contact, the step cap and the one-pass bearing law give the whole problem's answer at the
hard points (±3 % of the rated torque with pin and hole errors: discs that carry nothing,
crank bearings at zero load), to the solver's tolerance."""

import dataclasses

import numpy as np
import pytest

import cyclomesh.stage.equilibrium as eq
import cyclomesh.stage.newton as nt
from cyclomesh.core.kernel import ENV_VAR
from cyclomesh.core.pair import CrankHoles, Modification, PinErrors
from cyclomesh.stage import RollerSet, StageDesign, solve_stage
from cyclomesh.stage.bearing import radial_energy, radial_force, radial_law, radial_stiffness
from cyclomesh.stage.carrier import Carrier
from cyclomesh.stage.crankshaft import Crankshaft
from tests.stage.rv40 import HOLES, RV40

BEARING = RollerSet(14, 4e-3, 9e-3, 5e-6, 22e-3)
MOD = Modification(pin_radius=3e-6)
PHI = np.radians(np.arange(0.0, 360.0, 3.0))
LIGHT = 12.36  # 3 % of the RV-40E's rated 412 N·m


def _hard_stage(seed: int = 0):
    """The tolerance study's stage (examples/rv_stage.toml: crankshafts and carrier from
    geometry) with one ring's pin errors and crank hole errors beyond the clearance."""
    rng = np.random.default_rng(seed)
    errors = PinErrors(radial=rng.uniform(-2e-6, 2e-6, 40), angular=rng.uniform(-2e-5, 2e-5, 40))
    stage = StageDesign(
        HOLES,
        BEARING,
        hole_error_radial=rng.uniform(-3e-6, 3e-6, (2, 3)),
        hole_error_tangential=rng.normal(0.0, 2e-6, (2, 3)),
        crankshaft=Crankshaft(
            support_span=40e-3, disc_pitch=11e-3, pin_diameter=18e-3, support_stiffness=400e6
        ),
        carrier=Carrier(
            pillars=3, pillar_diameter=14e-3, pillar_length=24e-3, pillar_circle_radius=36e-3
        ),
    )
    return errors, stage


def _solve(errors, stage, torques):
    return solve_stage(RV40, stage, MOD, errors, torques, PHI, discs=2)


def _agree(a, b, torques):
    """Two converged solutions: residuals within the tolerance, twists and loads alike."""
    tol = nt.FORCE_TOLERANCE * np.abs(np.asarray(torques))[:, None] / HOLES.circle_radius
    assert np.all(a.residual <= tol) and np.all(b.residual <= tol)
    twist = np.max(np.abs(b.twist))
    assert np.max(np.abs(a.twist - b.twist)) <= 1e-11 * twist
    load = np.max(b.bearing_load)
    assert np.max(np.abs(a.bearing_load - b.bearing_load)) <= 1e-10 * load
    pins = np.max(b.pin_load)
    assert np.max(np.abs(a.pin_load - b.pin_load)) <= 1e-10 * pins


def test_radial_law_is_the_three_functions_bit_for_bit(monkeypatch):
    """The NumPy roller law (the reference) is its three functions bit for bit; pinned
    to the NumPy kernel, which it tests (with numba radial_law takes the compiled law,
    equal to round-off: tests/stage/test_kernel_stage.py)."""
    monkeypatch.setenv(ENV_VAR, "numpy")
    s = np.concatenate([np.linspace(0.0, 3e-6, 50), np.geomspace(2.5e-6, 5e-5, 50)])
    s = s.reshape(10, 10)
    force, stiff, energy = radial_law(BEARING, s)
    assert np.array_equal(force, radial_force(BEARING, s))
    assert np.array_equal(stiff, radial_stiffness(BEARING, s))
    assert np.array_equal(energy, radial_energy(BEARING, s))
    assert radial_law(BEARING, s, stiffness=False)[1] is None
    assert np.all(force[s <= 2.5e-6] == 0.0) and np.all(force[s > 2.6e-6] > 0.0)


def test_gradient_is_the_derivative_of_the_potential_with_crankshafts_and_carrier(monkeypatch):
    """The bearings' ∂d/∂x formed once per solve (bearing_jacobian) is the derivative of
    the hole displacements: the gradient matches central differences of the potential."""
    monkeypatch.setenv(ENV_VAR, "numpy")  # the NumPy Newton (eq.newton) it tests
    errors, stage = _hard_stage()
    seen = []
    newton = eq.newton

    def capture(p, evaluate, law, x, discs, rigid, phi):
        if not rigid:
            seen.append((p, law, x.copy()))
        return newton(p, evaluate, law, x, discs, rigid, phi)

    monkeypatch.setattr(eq, "newton", capture)
    _solve(errors, stage, [412.0])
    p, law, x = seen[0]
    assert p.jacobian is not None and x.shape[1] == 1 + 6 + 12 + 1
    rows = np.arange(0, x.shape[0], 7)
    sub, x = p.take(rows), x[rows]
    _, g, _, _ = eq._evaluate(sub, law, x, 2, False)
    rot = [0, 1, 4, x.shape[1] - 1]  # c, θ_1, θ_2, β: the gradient is per r_c·rad
    for j in range(x.shape[1]):
        h = 1e-10 / (p.scale if j in rot else 1.0)
        up, down = x.copy(), x.copy()
        up[:, j] += h
        down[:, j] -= h
        e_up = eq._evaluate(sub, law, up, 2, False, gradient=False)[0]
        e_down = eq._evaluate(sub, law, down, 2, False, gradient=False)[0]
        fd = (e_up - e_down) / (2 * h) / (p.scale if j in rot else 1.0)
        scale = np.max(np.abs(g), axis=-1)
        np.testing.assert_allclose(fd, g[:, j], rtol=0, atol=1e-5 * scale.max())


@pytest.mark.parametrize("seed", [0, 3])
def test_near_pins_give_the_whole_problems_answer_at_the_hard_points(monkeypatch, seed):
    """±3 % of the rated torque with pin and hole errors: some disc carries no pin at some
    crank angle and some crank bearing sits at zero load. Newton on the pins near contact
    reaches the answer of Newton on all pins (the previous iteration) to the tolerance."""
    errors, stage = _hard_stage(seed)
    torques = [-LIGHT, LIGHT, 412.0]
    fast = _solve(errors, stage, torques)
    monkeypatch.setattr(eq, "_NEAR", np.inf)
    whole = _solve(errors, stage, torques)
    _agree(fast, whole, torques)
    light = whole.bearing_load[:2]
    assert np.any(np.all(whole.pin_load[:2] == 0.0, axis=-1)), "a disc carries nothing"
    assert np.any(light < 1e-3 * np.max(light)), "a crank bearing at zero load"


def test_a_left_out_pin_that_closes_is_taken_back(monkeypatch):
    """With no margin only the pins closed at the start are iterated on; the pins that
    close on the way are found after, and their crank angles solved again with all pins
    (at +3 % the near pins alone do not even converge: solved whole from the start):
    the answer is the whole problem's."""
    monkeypatch.setenv(ENV_VAR, "numpy")  # the NumPy Newton (eq.newton) it tests
    errors, stage = _hard_stage()
    torques = [-LIGHT, LIGHT, 412.0]
    whole = _solve(errors, stage, torques)
    calls = []
    newton = eq.newton

    def counted(p, *args):
        calls.append(p.bl.shape)
        return newton(p, *args)

    monkeypatch.setattr(eq, "newton", counted)
    monkeypatch.setattr(eq, "_NEAR", 0.0)
    narrow = _solve(errors, stage, torques)
    assert len(calls) > 6  # 3 torques × (rigid + stage): some solved again
    _agree(narrow, whole, torques)


def test_step_cap_keeps_the_answer_and_saves_evaluations(monkeypatch):
    """A disc floating in its clearance makes the Newton step huge; shortened to the cap
    it needs fewer line-search trials, and the equilibrium is the same (each crank angle
    from its own start: from the one before, the steps are short anyway)."""
    monkeypatch.setenv(ENV_VAR, "numpy")  # the NumPy Newton (eq.newton) it tests
    errors, stage = _hard_stage()
    torques = [-LIGHT]
    calls = []
    evaluate = eq._evaluate

    def counted(*args, **kwargs):
        calls.append(1)
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(eq, "_evaluate", counted)
    monkeypatch.setattr(nt, "WARM_RUN", 1)  # every crank angle from its own start
    results, count = [], []
    for cap in (nt._STEP_CAP, np.inf):
        monkeypatch.setattr(nt, "_STEP_CAP", cap)
        calls.clear()
        results.append(_solve(errors, stage, torques))
        count.append(len(calls))
    assert count[0] < count[1]
    _agree(*results, torques)


# ring 1255 of bench_stage's stage tolerance study (seed 1: ±2 µm / ±20 µrad pins, ±3 µm /
# σ 2 µm crank holes), exactly as drawn: at +3 % and crank angle 332° one disc's crank
# bearings end at zero load and the potential (9.4e-8 J) is the small difference of the
# torque's work T·c and the springs' energy (6.0e-4 J each)
RING_1255_UM = {
    "radial": [-1.127459209137791, 0.9004837692527032, -1.8406075106630175,
               -0.43818451957896176, -0.9517809563364552, -1.1144179229440012,
               -1.3359912998841468, -1.620245261267343, -0.587519609417015,
               -1.1209226164721229, 0.21341331426292998, 1.8296500712634773,
               -0.05962067786483738, -1.5652886300582542, -1.3271281190168036,
               -1.503808531437556, 1.465495857807039, -0.4583156503314316,
               -0.6865905104530841, -0.30660424561797317, -0.7288456888748938,
               -1.6082773167183526, -1.357468870492093, -1.5224240267255174,
               1.6229372759181242, 0.09798046199136357, 1.8841684531820544,
               1.6931562442623465, -0.4160829571798623, 0.4973476244442283,
               -1.945678491188298, 0.31164233381710726, 0.03740659535417068,
               -0.8864702042824968, 0.436966698081902, -1.3644798570590368,
               1.7663468035594194, 1.3974867448954456, 1.6609461628064253,
               1.649518567841631],
    "angular": [-11.488769716755712, 5.315835330662404, -8.93886314084459,
                11.251893048118898, 16.753004756995278, 10.945596263296412,
                5.647013918693946, 3.2701221111606094, -5.2709038968975985,
                -15.383025642659396, -14.83434592554666, -2.247379673125307,
                -3.120213675254382, 16.14497291553443, -7.82226769859748,
                0.4988684086853823, 10.70487486932976, -2.9159487356666025,
                -11.23241560465766, -4.745289824005403, 5.172729464927772,
                -15.301403160585272, 3.022587049599803, -1.67652894969331,
                4.586071796159734, 10.447950710940678, 4.333520566623341,
                5.978470352893175, 9.329918385602722, -8.173098836983051,
                2.0336058920090183, -19.018836258219388, 3.2177282094838677,
                -6.903627173362561, 6.351293701284129, -5.550602892342136,
                -6.720346886279631, 19.601344488704765, -7.40882997443137,
                19.031771563275612],
    "hole_radial": [[-2.308811567382039, -2.665875642174547, 2.5239519224855935],
                    [-2.4982039175670328, 1.6836995463533122, 0.43903346415171063]],
    "hole_tangential": [[1.6875520115660487, -3.0784380198076247, -2.9635630506581],
                        [2.9100477158583993, -0.5739377261952014, -0.23419094606028493]],
}  # fmt: skip


def ring_1255():
    """The ring's stage and pin errors, in the units and conversions of the study (mm and
    µm read from examples/rv_stage.toml, × 1e-3 and × 1e-6)."""
    um = {key: np.asarray(value) * 1e-6 for key, value in RING_1255_UM.items()}
    mm = 1e-3
    stage = StageDesign(
        CrankHoles(count=3, circle_radius=36 * mm, radius=13 * mm),
        RollerSet(14, 4 * mm, 9 * mm, 5 * 1e-6, 0.022000000000000002),  # as the study reads it
        hole_error_radial=um["hole_radial"],
        hole_error_tangential=um["hole_tangential"],
        crankshaft=Crankshaft(
            support_span=40 * mm, disc_pitch=11 * mm, pin_diameter=18 * mm, support_stiffness=400e6
        ),
        carrier=Carrier(
            pillars=3, pillar_diameter=14 * mm, pillar_length=24 * mm, pillar_circle_radius=36 * mm
        ),
    )
    design = dataclasses.replace(RV40, eccentricity=1.3 * mm)
    return design, PinErrors(radial=um["radial"], angular=um["angular"]), stage


def test_newton_judges_by_the_residual_where_the_potential_has_no_digits(monkeypatch):
    """Ring 1255 at +3 % and 332° (NumPy reference): Newton's predicted decrease of the
    potential (~1e-20 J) falls below the round-off of its terms (eps·6e-4 J) while the
    residual is still 3,000 times the tolerance; the sufficient-decrease test on the
    potential then accepts only steps of ~1e-8 (where the potential is unchanged) and the
    iteration stalled for 200 steps (ConvergenceError). Judged by the residual's norm
    there, it converges in a few steps, to the tolerance, with one disc's crank bearings
    at zero load."""
    from cyclomesh.core import kernel

    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    design, errors, stage = ring_1255()
    calls = []
    evaluate = eq._evaluate

    def counted(*args, **kwargs):
        calls.append(1)
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(eq, "_evaluate", counted)
    res = solve_stage(design, stage, MOD, errors, [LIGHT], np.radians([332.0]), discs=2)
    assert np.all(res.residual <= nt.FORCE_TOLERANCE * LIGHT / HOLES.circle_radius)
    assert len(calls) < 200  # not the stall's hundreds of evaluations
    load = res.bearing_load[0, 0]  # (D, N)
    assert np.sum(load[1] < 1e-6 * np.max(load)) >= 2, "disc 2's bearings at zero load"


def test_any_start_gives_the_same_root_to_round_off(monkeypatch):
    """Newton goes on from near the root (FORCE_TOLERANCE) to round-off, so the answer does
    not depend on its path: the bearing phase started off its start by 1e-3 (relative, every
    unknown) gives the same twists to 1e-14 and the same loads to 1e-13 of their largest,
    at the hard points (discs that float, bearings at zero load). The former test (stop
    anywhere below 1e-12·T/r_c) left loads ~1e-12 apart."""
    errors, stage = _hard_stage(0)
    torques = [412.0, -LIGHT, LIGHT]
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    ref = _solve(errors, stage, torques)
    solve = eq._solve

    def moved(p, law, x, discs, rigid, phi, state=None):
        if not rigid:
            x = x * (1.0 + 1e-3)
        return solve(p, law, x, discs, rigid, phi, state)

    monkeypatch.setattr(eq, "_solve", moved)
    got = _solve(errors, stage, torques)
    tol = nt.FORCE_TOLERANCE * np.abs(np.asarray(torques))[:, None] / HOLES.circle_radius
    assert np.all(got.residual <= tol)
    assert np.max(np.abs(got.twist - ref.twist)) <= 1e-14 * np.max(np.abs(ref.twist))
    for name in ("bearing_load", "pin_load", "torque_share"):
        a, b = getattr(ref, name), getattr(got, name)
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a)), name


def test_newton_with_failed_flags_instead_of_raising():
    """A crank angle that cannot converge is flagged, not raised, and left at its last
    iterate; without ``failed`` the same raises ConvergenceError."""
    from types import SimpleNamespace

    from cyclomesh.exceptions import ConvergenceError

    class Problem(SimpleNamespace):
        def take(self, idx):
            return self

    def evaluate(sub, law, x, discs, rigid, hessian=True, gradient=True):
        # a saddle: Π = −x₀² (no minimum), gradient −2x₀, Hessian −2
        n, m = x.shape
        g = np.zeros((n, m))
        g[:, 0] = -2.0 * x[:, 0]
        H = np.zeros((n, m, m))
        H[:, 0, 0] = -2.0
        for i in range(1, m):
            H[:, i, i] = 1.0
        return -(x[:, 0] ** 2), g, H, {"bad": np.zeros(n, bool)}

    p = Problem(torque=1.0, scale=1.0, supports=None, body=None)
    x = np.full((2, 4), 1e-3)
    with pytest.raises(ConvergenceError):
        nt.newton(p, evaluate, None, x.copy(), 1, False, np.zeros(2))
    failed = np.zeros(2, bool)
    out = nt.newton(p, evaluate, None, x.copy(), 1, False, np.zeros(2), failed)
    assert failed.all() and np.all(np.isfinite(out))


def test_residual_newton_goes_on_to_round_off_with_round_off():
    """residual_newton(round_off=True) (the compliant disc's _stationary): past the
    1e-12·T/r_c test it goes on while the largest residual falls, to a few ulp of T/r_c;
    without it, it stops at the test (the arithmetic before unchanged)."""
    from types import SimpleNamespace

    class Problem(SimpleNamespace):
        def take(self, idx):
            return Problem(**{**vars(self), "c": self.c[idx]})

    def residual(sub, x, jacobian):
        # r = x + x³/10 − c per component: a smooth root, Newton quadratic
        r = x + 0.1 * x**3 - sub.c
        J = None
        if jacobian:
            J = np.zeros((*x.shape, x.shape[1]))
            i = np.arange(x.shape[1])
            J[:, i, i] = 1.0 + 0.3 * x**2
        return r, J, {"bad": np.zeros(x.shape[0], bool)}

    c = np.array([[1.0, -0.7, 0.3], [2.0, 0.5, -1.5]])
    p = Problem(torque=1.0, scale=1.0, c=c)
    phi = np.zeros(2)
    plain = nt.residual_newton(p, residual, np.zeros((2, 3)), phi, [], "test")
    tight = nt.residual_newton(p, residual, np.zeros((2, 3)), phi, [], "test", round_off=True)
    left = np.abs(residual(p, tight, False)[0])
    assert np.max(left) <= 4.0 * nt.ROUND_OFF_FORCE
    assert np.max(np.abs(residual(p, plain, False)[0])) <= nt.FORCE_TOLERANCE
    np.testing.assert_allclose(tight, plain, rtol=0, atol=2e-12)
