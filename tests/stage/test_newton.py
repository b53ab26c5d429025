"""The stage's Newton iteration (cyclomesh.stage.newton, equilibrium._solve): the pins near
contact, the step cap and the one-pass bearing law give the whole problem's answer at the
hard points (±3 % of the rated torque with pin and hole errors: discs that carry nothing,
crank bearings at zero load), to the solver's tolerance."""

import numpy as np
import pytest

import cyclomesh.stage.equilibrium as eq
import cyclomesh.stage.newton as nt
from cyclomesh.core.pair import Modification, PinErrors
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


def test_radial_law_is_the_three_functions_bit_for_bit():
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
    it needs fewer line-search trials, and the equilibrium is the same."""
    errors, stage = _hard_stage()
    torques = [-LIGHT]
    calls = []
    evaluate = eq._evaluate

    def counted(*args, **kwargs):
        calls.append(1)
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(eq, "_evaluate", counted)
    results, count = [], []
    for cap in (nt._STEP_CAP, np.inf):
        monkeypatch.setattr(nt, "_STEP_CAP", cap)
        calls.clear()
        results.append(_solve(errors, stage, torques))
        count.append(len(calls))
    assert count[0] < count[1]
    _agree(*results, torques)
