"""Equilibrium of the RV stage (cyclomesh.stage.solve): limits, balance, symmetry, clearance."""

import numpy as np
import pytest

from cyclomesh.core.pair import Modification, PinErrors
from cyclomesh.drive.solve import solve_drive, torsion_curve
from cyclomesh.exceptions import DesignError
from cyclomesh.stage import RollerSet, StageDesign, bearing_life, solve_stage, stage_torsion_curve
from tests.stage.rv40 import HOLES, RV40

MOD = Modification(pin_radius=8e-6)
PHI = np.radians(np.arange(0.0, 360.0, 9.0))


def _bearing(clearance=0.0, length=9e-3):
    return RollerSet(14, 4e-3, length, clearance, 22e-3)


def test_rigid_bearings_reproduce_the_mesh():
    errors = PinErrors(radial=np.linspace(-3e-6, 3e-6, 40) ** 2 * 1e5)
    for discs in (1, 2):
        stage = solve_stage(
            RV40, StageDesign(HOLES), MOD, errors, [-300.0, 300.0], PHI, discs=discs
        )
        drive = solve_drive(RV40, MOD, errors, [-300.0, 300.0], PHI, discs=discs)
        np.testing.assert_allclose(
            stage.pin_load, drive.pin_load, rtol=0, atol=1e-11 * drive.pin_load.max()
        )
        np.testing.assert_allclose(
            stage.transmission_error, drive.transmission_error, rtol=0, atol=1e-15
        )
        np.testing.assert_allclose(stage.disc_translation_x, 0.0, atol=0)
        np.testing.assert_allclose(stage.mesh_force, drive.mesh_force, rtol=1e-10)


def _balance(design, stage_design, result, discs, mod=MOD):
    """Largest relative imbalance of forces and moments on every disc and on the carrier."""
    drive = solve_drive(design, mod, None, result.torque, result.crank_angle, discs=discs)
    # the opposite flanks: the loaded flanks of the other direction (geometry only)
    other = solve_drive(design, mod, None, -result.torque, result.crank_angle, discs=discs)
    fa, fo = drive.force_angle, other.force_angle  # pins on disc
    load, opposite = result.pin_load, result.opposite_pin_load
    px = np.sum(load * np.cos(fa), -1) + np.sum(opposite * np.cos(fo), -1)
    py = np.sum(load * np.sin(fa), -1) + np.sum(opposite * np.sin(fo), -1)
    # the pins drive the disc against the load: their moment is −T's sign times Σ F·l;
    # the opposite flanks push the other way
    sign = np.sign(result.torque)[:, None, None]
    pm = -sign * (np.sum(load * drive.moment_arm, -1) - np.sum(opposite * other.moment_arm, -1))
    holes = stage_design.holes
    ang = holes.angles[None, :] - result.crank_angle[:, None] / design.teeth  # (A, N)
    hx, hy = holes.circle_radius * np.cos(ang), holes.circle_radius * np.sin(ang)
    bx = result.bearing_load * np.cos(result.bearing_load_angle)  # on the crank pins
    by = result.bearing_load * np.sin(result.bearing_load_angle)
    bm = np.sum(hx[None, :, None] * by - hy[None, :, None] * bx, -1)
    scale = np.max(result.bearing_load)
    force = max(np.max(np.abs(px - bx.sum(-1))), np.max(np.abs(py - by.sum(-1)))) / scale
    moment = np.max(np.abs(pm - bm)) / (scale * holes.circle_radius)
    carrier = np.max(np.abs(bm.sum(-1) + result.torque[:, None])) / np.abs(result.torque).max()
    return force, moment, carrier


@pytest.mark.parametrize("clearance", [0.0, 10e-6])
def test_every_disc_balances_to_round_off(clearance):
    sd = StageDesign(HOLES, _bearing(clearance), crankshaft_stiffness=2e8)
    result = solve_stage(RV40, sd, MOD, None, [-412.0, 412.0], PHI, discs=2)
    force, moment, carrier = _balance(RV40, sd, result, 2)
    assert force < 1e-10 and moment < 1e-10 and carrier < 1e-10
    assert np.all(result.disc_translation_x != 0)
    # the rigid stiff-limit split balances too
    rigid = StageDesign(HOLES)
    assert max(_balance(RV40, rigid, solve_stage(RV40, rigid, MOD, None, 412.0, PHI), 1)) < 1e-10


def test_translation_closes_the_opposite_flanks_without_play():
    # no modification: no play, so the disc's translation within the bearing clearance
    # presses pins on the opposite flanks of their tooth spaces too
    mod = Modification()
    sd = StageDesign(HOLES, _bearing(10e-6))
    result = solve_stage(RV40, sd, mod, None, [-412.0, 412.0], PHI, discs=2)
    assert np.all(result.opposite_pin_load.max(axis=(2, 3)) > 0)
    assert max(_balance(RV40, sd, result, 2, mod)) < 1e-10
    # with the play of Δρ = 3 µm they stay open (the mesh-alone results hold)
    open_ = solve_stage(RV40, sd, Modification(pin_radius=3e-6), None, 412.0, PHI, discs=2)
    assert np.all(open_.opposite_pin_load == 0)


def test_identical_cranks_share_by_symmetry():
    # turning the whole stage by 13 pin pitches (117°) maps crank k onto crank k + 1
    # (n2 = 39 = 3·13) and crank angle φ onto φ + 117°: the loads must follow exactly
    phi = np.radians(np.arange(0.0, 360.0, 3.0))
    sd = StageDesign(HOLES, _bearing(6e-6))
    result = solve_stage(RV40, sd, MOD, None, [-412.0, 412.0], phi, discs=2)
    shift = 117 // 3
    load = result.bearing_load
    moved = np.roll(np.roll(load, -shift, axis=1), -1, axis=-1)
    np.testing.assert_allclose(moved[:, : 120 - shift], load[:, : 120 - shift], rtol=1e-9)
    turned = np.roll(np.roll(result.bearing_load_angle, -shift, axis=1), -1, axis=-1)
    diff = np.angle(np.exp(1j * (turned - result.bearing_load_angle - np.radians(117.0))))
    assert np.max(np.abs(diff[:, : 120 - shift])) < 1e-9
    # whole-revolution means: the cranks share the load equally within the slow advance of
    # the holes (360°/n2 per crank revolution)
    mean = load.mean(axis=1)
    assert np.ptp(mean, axis=-1).max() < 0.05 * mean.max()


def test_uniform_tangential_hole_error_only_turns_the_output():
    eps = 5e-6
    base = solve_stage(RV40, StageDesign(HOLES, _bearing(4e-6)), MOD, None, 412.0, PHI, discs=2)
    moved = solve_stage(
        RV40,
        StageDesign(HOLES, _bearing(4e-6), hole_error_tangential=eps),
        MOD,
        None,
        412.0,
        PHI,
        discs=2,
    )
    np.testing.assert_allclose(moved.bearing_load, base.bearing_load, rtol=1e-8)
    np.testing.assert_allclose(
        moved.transmission_error - base.transmission_error, -eps / HOLES.circle_radius, atol=1e-14
    )
    # one hole out of place changes the split (and the mirror keeps the reverse direction)
    odd = StageDesign(HOLES, _bearing(4e-6), hole_error_radial=[[10e-6, 0, 0], [0, 0, 0]])
    res = solve_stage(RV40, odd, MOD, None, [-412.0, 412.0], PHI, discs=2)
    assert not np.allclose(res.bearing_load[1], base.bearing_load[0], rtol=1e-3)
    assert max(_balance(RV40, odd, res, 2)) < 1e-10


def test_stiff_bearings_tend_to_the_rigid_stage():
    rigid = solve_stage(RV40, StageDesign(HOLES), MOD, None, 412.0, PHI, discs=2)
    gaps = []
    for length in (9e-3, 9.0, 9e3):  # K_n ∝ l^(8/9): a thousandfold stiffer each time
        res = solve_stage(
            RV40, StageDesign(HOLES, _bearing(0.0, length)), MOD, None, 412.0, PHI, discs=2
        )
        gaps.append(
            np.max(np.abs(res.bearing_load - rigid.bearing_load)) / rigid.bearing_load.max()
        )
    assert gaps[0] > gaps[1] > gaps[2]
    assert gaps[2] < 1e-4


def test_lost_motion_grows_with_clearance_as_geometry_says():
    phi = np.radians(np.arange(0.0, 9.0, 3.0))
    lost = []
    clearances = np.array([0.0, 10e-6, 20e-6, 40e-6])
    for c in clearances:
        tc = stage_torsion_curve(
            RV40, StageDesign(HOLES, _bearing(c)), MOD, None, 412.0, phi, discs=2, points=5
        )
        lost.append(tc.lost_motion.mean())
    mesh = torsion_curve(RV40, MOD, None, 412.0, phi, discs=2, points=5)
    np.testing.assert_allclose(tc.mesh_lost_motion, mesh.lost_motion, rtol=1e-12)
    growth = np.array(lost) - lost[0]
    free_travel = clearances / HOLES.circle_radius  # zero-load free rotation of the bearings
    assert lost[0] > mesh.lost_motion.mean()
    # at least the bearings' free travel, plus a nearly constant elastic extra (at ±3 % of the
    # rated torque a bearing with clearance loads fewer rollers, and the disc translates);
    # from one clearance to the next the lost motion grows by the free travel itself
    ratio = growth[1:] / free_travel[1:]
    assert np.all(ratio >= 1.0) and np.all(ratio < 1.2)
    step = np.diff(lost)[1:] / np.diff(free_travel)[1:]
    assert np.all(step >= 0.99) and np.all(step <= 1.05)


def test_life_and_reverse_mirror():
    sd = StageDesign(HOLES, _bearing(6e-6), output_speed=15.0)
    res = solve_stage(RV40, sd, MOD, None, [-412.0, 412.0], PHI, discs=2)
    p, l10, hours = bearing_life(res, sd, RV40.pins)
    assert p.shape == (2, 2, 3)
    np.testing.assert_allclose(hours, l10 * 1e6 / (60 * 40 * 15.0))
    # the reverse direction of an error-free stage is the mirror: same load statistics
    np.testing.assert_allclose(np.sort(p[0].ravel()), np.sort(p[1].ravel()), rtol=0.05)
    np.testing.assert_allclose(
        np.abs(res.transmission_error[0]).mean(),
        np.abs(res.transmission_error[1]).mean(),
        rtol=0.02,
    )


def test_stage_input_errors():
    with pytest.raises(DesignError, match="need a compliant crank bearing"):
        StageDesign(HOLES, None, hole_error_radial=1e-6)
    with pytest.raises(DesignError, match="pitch diameter"):
        StageDesign(HOLES, RollerSet(14, 4e-3, 9e-3, 0.0, 20e-3))
    with pytest.raises(DesignError, match="one per disc and crank"):
        solve_stage(
            RV40,
            StageDesign(HOLES, _bearing(), hole_error_radial=[1e-6, 0.0]),
            MOD,
            None,
            412.0,
            PHI,
            discs=2,
        )


def test_rings_are_solved_one_by_one_with_the_same_result():
    rng = np.random.default_rng(3)
    radial = rng.uniform(-3e-6, 3e-6, (2, 40))
    sd = StageDesign(HOLES, _bearing(4e-6))
    phi = PHI[:6]
    both = solve_stage(RV40, sd, MOD, PinErrors(radial=radial), [-412.0, 412.0], phi, discs=2)
    assert both.bearing_load.shape == (2, 2, 6, 2, 3)
    for ring in range(2):
        one = solve_stage(
            RV40, sd, MOD, PinErrors(radial=radial[ring]), [-412.0, 412.0], phi, discs=2
        )
        np.testing.assert_array_equal(both.bearing_load[ring], one.bearing_load)
        np.testing.assert_array_equal(both.transmission_error[ring], one.transmission_error)
    _, _, hours = bearing_life(both, sd, RV40.pins)
    assert hours.shape == (2, 2, 2, 3)


@pytest.mark.parametrize("bearing", [None, 5e-6])
def test_a_disc_the_pin_errors_unload_gets_no_bearing_load(bearing):
    """Issue 23: with pin errors one disc of a stack can be out of contact at some crank
    angles (the other carries the whole torque); its stiff-limit bearing split is B = 0
    exactly, not a singular Newton system. The ring is examples/rv_stage.toml's with
    [errors.random] seed = 1, radial_um = 3, whose disc 1 is unloaded near 138°."""
    radial = np.random.default_rng(1).uniform(-3.0, 3.0, 40) * 1e-6
    sd = StageDesign(HOLES, None if bearing is None else _bearing(bearing))
    mod = Modification(pin_radius=3e-6)
    phi = np.radians([41.0, 42.0, 138.0, 139.0, 221.0, 222.0, 318.0, 319.0])
    # 3 % of the rated torque: the lost-motion point of the stage's torsion curve
    res = solve_stage(RV40, sd, mod, PinErrors(radial=radial), [-12.36, 12.36], phi, discs=2)
    total = np.sum(res.pin_load, -1) + np.sum(res.opposite_pin_load, -1)  # (T, A, D)
    unloaded = total == 0
    # the case the issue met: a disc without a loaded pin in the rigid stage (which also
    # starts the solve with compliant bearings, where the disc then translates into contact)
    assert unloaded.any() or bearing is not None
    assert np.all(np.isfinite(res.bearing_load)) and np.all(np.isfinite(res.pin_load))
    # the carrier balances the torque through the cranks of the loaded disc alone
    ang = HOLES.angles[None, :] - res.crank_angle[:, None] / RV40.teeth  # (A, N)
    hx, hy = HOLES.circle_radius * np.cos(ang), HOLES.circle_radius * np.sin(ang)
    bx = res.bearing_load * np.cos(res.bearing_load_angle)
    by = res.bearing_load * np.sin(res.bearing_load_angle)
    moment = np.sum(hx[None, :, None] * by - hy[None, :, None] * bx, -1)  # (T, A, D)
    carrier = np.abs(moment.sum(-1) + res.torque[:, None]) / np.abs(res.torque).max()
    assert carrier.max() < 1e-10
    if bearing is None:  # rigid bearings: an unloaded disc passes nothing to its cranks
        assert np.all(res.bearing_load[unloaded] == 0.0)


def test_light_torque_with_pin_errors_solves():
    """A wild first Newton step at −3 % of the rated torque with pin errors once pushed a
    trial past the contact law's stiffest point (its inversion failed, the solve with it);
    the line search now halves such a step. The stage balances to round-off."""
    rng = np.random.default_rng(1)
    errors = PinErrors(
        radial=rng.uniform(-2e-6, 2e-6, (3, 40))[1],
        angular=rng.uniform(-2e-5, 2e-5, (3, 40))[1],
    )
    sd = StageDesign(HOLES, _bearing(5e-6), crankshaft_stiffness=200e6, carrier_stiffness=3e6)
    phi = np.radians(np.arange(0.0, 360.0, 2.0))
    mod = Modification(pin_radius=3e-6)
    result = solve_stage(RV40, sd, mod, errors, [-12.36], phi, discs=2)
    assert np.all(np.isfinite(result.twist)) and np.all(result.twist < 0)
    assert np.max(result.residual) <= 1e-11 * 12.36 / HOLES.circle_radius


def test_stretched_newton_step_keeps_the_answer_and_saves_steps(monkeypatch):
    """At −3 % of the rated torque with pin and hole errors a disc carries almost nothing:
    its crank bearings' equilibrium compression is ~0, where Q ∝ δ^(10/9) makes Newton
    linear. The step stretched by 10/9 (the modified Newton step of that root) must reach
    the same equilibrium (to round-off) with fewer potential evaluations."""
    import cyclomesh.stage.equilibrium as eq
    import cyclomesh.stage.newton as nt
    from cyclomesh.core.kernel import ENV_VAR

    monkeypatch.setenv(ENV_VAR, "numpy")  # the NumPy Newton's evaluations it counts
    rng = np.random.default_rng(0)
    errors = PinErrors(radial=rng.uniform(-2e-6, 2e-6, 40), angular=rng.uniform(-2e-5, 2e-5, 40))
    sd = StageDesign(
        HOLES,
        _bearing(5e-6),
        hole_error_radial=rng.uniform(-3e-6, 3e-6, (2, 3)),
        hole_error_tangential=rng.normal(0.0, 2e-6, (2, 3)),
    )
    phi = np.radians(np.arange(0.0, 360.0, 3.0))
    mod = Modification(pin_radius=3e-6)
    calls = []
    evaluate = eq._evaluate

    def counted(*args, **kwargs):
        calls.append(args[2].shape[0])
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(eq, "_evaluate", counted)
    results, rows = [], []
    for linear in (nt._LINEAR, (1.0, 1.0)):  # (1, 1): never stretched
        monkeypatch.setattr(nt, "_LINEAR", linear)
        calls.clear()
        results.append(solve_stage(RV40, sd, mod, errors, [-12.36], phi, discs=2))
        rows.append(sum(calls))
    fast, plain = results
    tol = 1e-12 * 12.36 / HOLES.circle_radius
    assert np.max(fast.residual) <= tol and np.max(plain.residual) <= tol
    assert rows[0] < rows[1]
    scale = np.max(np.abs(plain.twist))
    assert np.max(np.abs(fast.twist - plain.twist)) <= 1e-9 * scale
    load = np.max(plain.bearing_load)
    assert np.max(np.abs(fast.bearing_load - plain.bearing_load)) <= 1e-6 * load
