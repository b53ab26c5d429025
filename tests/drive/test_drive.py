"""Drive characteristics: both flanks, play, mesh force, disc stacks, torsion curve."""

import numpy as np
import pytest

from cyclomesh import TABLE1, DesignError, Modification, PinErrors
from cyclomesh.core.deviation import ProfileDeviation
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.drive.solve import (
    mirror_errors,
    play,
    solve_drive,
    torsion_curve,
    torsion_torques,
)

TPM = Modification(pin_radius=8e-6)
REV = np.deg2rad(np.arange(0.0, 360.0, 2.0))
ARCMIN = np.pi / (180 * 60)


def asymmetric_table():
    """A tabulated deviation over both flanks that differs per tooth space (not symmetric)."""
    angle = np.deg2rad(np.linspace(-180.0, 180.0, 73))
    space = np.arange(TABLE1.teeth)[:, None]
    deviation = 6e-6 + 2e-6 * np.sin(angle + 0.3 * space) + 1e-6 * np.cos(3 * angle)
    return ProfileDeviation(np.broadcast_to(angle, deviation.shape).copy(), deviation)


def ring_errors(seed, rings=()):
    rng = np.random.default_rng(seed)
    shape = (*rings, TABLE1.pins)
    return PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, shape),
        angular=rng.uniform(-2e-5, 2e-5, shape),
        pin_radius=rng.uniform(-2e-6, 2e-6, shape),
        eccentricity=2e-6,
    )


def test_forward_single_disc_is_solve_ltca_bit_for_bit():
    errors = ring_errors(3)
    ref = solve_ltca(TABLE1, TPM, errors, 250.0, REV)
    res = solve_drive(TABLE1, TPM, errors, 250.0, REV)
    np.testing.assert_array_equal(res.pin_load[0, :, 0], ref.pin_load)
    np.testing.assert_array_equal(res.overlap[0, :, 0], ref.overlap)
    np.testing.assert_array_equal(res.transmission_error[0], ref.transmission_error)
    np.testing.assert_array_equal(res.gear_ratio[0], ref.gear_ratio)


def test_mirror_errors_is_an_involution_that_reflects_the_pins():
    errors = ring_errors(4, rings=(2,))
    twice = mirror_errors(mirror_errors(errors, 40), 40)
    for name in ("radial", "angular", "pin_radius"):
        np.testing.assert_array_equal(getattr(twice, name), getattr(errors, name))
    once = mirror_errors(errors, 40)
    angle = np.arange(40) * TABLE1.pitch + errors.angular
    mirrored = np.arange(40) * TABLE1.pitch + once.angular
    # pin (n1 − i) mod n1 of the mirror sits at the reflection of pin i
    j = (-np.arange(40)) % 40
    np.testing.assert_allclose(np.sin(mirrored[..., j]), -np.sin(angle), atol=1e-15)
    np.testing.assert_allclose(np.cos(mirrored[..., j]), np.cos(angle), atol=1e-15)


@pytest.mark.parametrize("groove", [False, True])
def test_reverse_of_error_free_pair_mirrors_forward(groove):
    phi = np.deg2rad(np.arange(0.0, 360.0, 1.5))
    res = solve_drive(TABLE1, TPM, None, [250.0, -250.0], phi, groove)
    neg = (-np.arange(phi.size)) % phi.size  # index of −φ
    pin = (-np.arange(40)) % 40
    fwd, rev = 0, 1
    np.testing.assert_allclose(
        res.transmission_error[rev], -res.transmission_error[fwd][neg], rtol=0, atol=1e-14
    )
    assert np.all(res.transmission_error[rev] > 0) and np.all(res.transmission_error[fwd] < 0)
    load_f = res.pin_load[fwd][neg][..., pin]
    # a barely engaged pin is set by its backlash to round-off: 1e-9 of the largest load
    np.testing.assert_allclose(res.pin_load[rev], load_f, rtol=1e-9, atol=1e-9 * load_f.max())
    np.testing.assert_allclose(
        res.profile_angle[rev], -res.profile_angle[fwd][neg][..., pin], atol=1e-12
    )
    np.testing.assert_array_equal(res.contacts[rev], res.contacts[fwd][neg])
    np.testing.assert_allclose(
        res.mesh_force_angle[rev], -res.mesh_force_angle[fwd][neg], atol=1e-12
    )


@pytest.mark.parametrize(
    "mod",
    [
        TPM,
        Modification(pin_radius=8e-6, rotation=3e-5),
        Modification(-8e-6, 4e-6, 2e-5),
        Modification(pin_radius=2e-6, profile=asymmetric_table()),
    ],
)
def test_reverse_rest_from_mirror_agrees_with_unloaded_flank_contact(mod):
    # the play from the mirrored problem against the reverse contact rotations of the
    # forward geometry (contact.py), with pin errors that break the symmetry
    errors = ring_errors(5, rings=(3,))
    both = solve_drive(TABLE1, mod, errors, [100.0, -100.0], REV)
    rev_only = solve_drive(TABLE1, mod, errors, -100.0, REV)
    np.testing.assert_allclose(rev_only.play, both.play, rtol=0, atol=1e-14)
    # TE of the reverse rest position minus TE of the forward one
    te_rest = -both.rest_rotation
    np.testing.assert_allclose(te_rest[..., 1, :] - te_rest[..., 0, :], both.play, atol=1e-14)
    assert np.all(both.play > 0)
    # the unloaded play alone is the same number
    np.testing.assert_array_equal(play(TABLE1, mod, errors, REV), both.play)
    # with errors, the reverse is not the mirror of the forward
    te = both.transmission_error
    assert np.max(np.abs(te[..., 1, :] + te[..., 0, :])) > 1e-7


@pytest.mark.parametrize(
    "delta_a, delta_rho", [(0.0, 8e-6), (-10e-6, 5e-6), (-6e-6, 0.0), (4e-6, 12e-6)]
)
def test_play_of_modified_pair_matches_closed_form(delta_a, delta_rho):
    mod = Modification(pin_circle_radius=delta_a, pin_radius=delta_rho)
    k1 = TABLE1.short_amplitude_coefficient
    closed = 2 * (delta_rho - delta_a * np.sqrt(1 - k1**2)) / (TABLE1.eccentricity * TABLE1.teeth)
    # one pin pitch of crank angle covers every phase of the mesh
    phi = np.deg2rad(np.arange(0.0, 9.0, 0.05))
    play = solve_drive(TABLE1, mod, None, 1.0, phi).play
    assert np.all(play >= closed * (1 - 1e-3))
    np.testing.assert_allclose(play, closed, rtol=5e-3)
    np.testing.assert_allclose(play.min(), closed, rtol=2e-3)


def test_moments_of_pin_forces_balance_the_torque_on_both_flanks():
    errors = ring_errors(6)
    torques = np.array([-300.0, -20.0, 20.0, 300.0])
    res = solve_drive(TABLE1, TPM, errors, torques, REV, discs=3)
    # pin centre relative to each disc centre, fixed frame
    pin_angle = np.arange(40) * TABLE1.pitch + errors.angular
    pin_r = TABLE1.pin_circle_radius + errors.radial
    ecc = TABLE1.eccentricity + errors.eccentricity
    crank = REV[:, None, None] + np.deg2rad([0.0, 120.0, 240.0])[None, :, None]
    wx = pin_r * np.cos(pin_angle) - ecc * np.cos(crank)
    wy = pin_r * np.sin(pin_angle) - ecc * np.sin(crank)
    fx = res.pin_load * np.cos(res.force_angle)
    fy = res.pin_load * np.sin(res.force_angle)
    moment = np.sum(wx * fy - wy * fx, axis=(-1, -2))  # all pins of both discs
    # the pins drive the disc against the torque: their moment is −T
    np.testing.assert_allclose(moment, -torques[:, None] * np.ones(REV.size), rtol=1e-9)
    np.testing.assert_allclose(
        res.torque_share.sum(-1), np.broadcast_to(torques[:, None], moment.shape), rtol=1e-11
    )
    np.testing.assert_allclose(res.mesh_force, np.hypot(fx.sum(-1), fy.sum(-1)), rtol=1e-12)


def test_mesh_force_of_unmodified_pair_passes_through_the_pitch_point():
    # without modification every line of action passes through the pitch point
    # P = e·n1·(cos φ, sin φ), at e·n2 from the disc centre
    res = solve_drive(TABLE1, None, None, [-250.0, 250.0], REV)
    e, n2 = TABLE1.eccentricity, TABLE1.teeth
    fx = res.mesh_force[..., 0] * np.cos(res.mesh_force_angle[..., 0])
    fy = res.mesh_force[..., 0] * np.sin(res.mesh_force_angle[..., 0])
    moment = e * n2 * (np.cos(REV) * fy - np.sin(REV) * fx)
    np.testing.assert_allclose(moment, [[250.0], [-250.0]] * np.ones(REV.size), rtol=1e-12)


def test_error_free_two_disc_stack_splits_the_torque_equally():
    res = solve_drive(TABLE1, TPM, None, [-250.0, 250.0], REV, discs=2)
    # to round-off: disc 2 at φ is disc 1 at φ + 180° = 20 pin pitches, turned
    np.testing.assert_allclose(
        res.torque_share,
        np.broadcast_to(res.torque[:, None, None] / 2, (2, REV.size, 2)),
        rtol=1e-9,
    )
    single = solve_drive(TABLE1, TPM, None, [-125.0, 125.0], REV)
    np.testing.assert_allclose(res.transmission_error, single.transmission_error, atol=1e-15)
    np.testing.assert_allclose(res.play, single.play, atol=1e-15)
    # disc 2 at φ is disc 1 at φ + 180°
    half = REV.size // 2
    np.testing.assert_allclose(
        res.mesh_force[..., 1], np.roll(res.mesh_force[..., 0], -half, axis=-1), rtol=1e-9
    )


def test_pin_errors_unbalance_a_two_disc_stack():
    errors = ring_errors(7)
    res = solve_drive(TABLE1, TPM, errors, 250.0, REV, discs=2)
    share = res.torque_share[0]
    assert np.max(np.abs(share[:, 0] - 125.0)) > 5.0
    np.testing.assert_allclose(share.sum(-1), 250.0, rtol=1e-11)
    # the stack's rest is the first contact over both discs: each disc alone would rest
    # at or beyond it, and the stack lags no more than its stiffer half alone would
    assert np.all(res.backlash.min(axis=(-1, -2)) <= 1e-15)


def test_zero_torque_and_bad_inputs_are_refused():
    with pytest.raises(DesignError, match="torque 0"):
        solve_drive(TABLE1, TPM, None, [250.0, 0.0], REV)
    with pytest.raises(DesignError, match="differ"):
        solve_drive(TABLE1, TPM, None, [250.0, 250.0], REV)
    with pytest.raises(DesignError, match="discs"):
        solve_drive(TABLE1, TPM, None, 250.0, REV, discs=0)
    with pytest.raises(DesignError, match="rated_torque_nm"):
        torsion_torques(-1.0)


def test_torsion_torques_hold_the_construction_points():
    for points in (2, 5, 41, 100):
        torques = torsion_torques(250.0, points)
        assert 0.0 not in torques and np.all(np.diff(torques) > 0)
        for f in (0.03, 0.5, 1.0):
            assert f * 250.0 in torques and -f * 250.0 in torques
    assert torsion_torques(250.0, 41).size == 42  # 41 even points − 0 + ±3 %


def test_torsion_curve_is_invariant_to_the_number_of_points():
    errors = ring_errors(8)
    a = torsion_curve(TABLE1, TPM, errors, 250.0, REV, points=5)
    b = torsion_curve(TABLE1, TPM, errors, 250.0, REV, points=23)
    np.testing.assert_array_equal(a.lost_motion, b.lost_motion)
    np.testing.assert_array_equal(a.torsional_rigidity, b.torsional_rigidity)
    np.testing.assert_array_equal(a.play, b.play)
    common = np.isin(b.torque, a.torque)
    np.testing.assert_array_equal(b.rotation[common], a.rotation)


def test_lost_motion_tends_to_the_play_at_small_rated_torque():
    gaps = []
    for rated in (100.0, 1.0, 0.01):
        curve = torsion_curve(TABLE1, TPM, None, rated, REV[::10], points=2)
        gaps.append(np.max(np.abs(curve.lost_motion - curve.play)))
        assert np.all(curve.lost_motion > curve.play)
    assert gaps[1] < gaps[0] / 10 and gaps[2] < gaps[1] / 10
    assert gaps[2] < 1e-4 * curve.play.min()


def test_torsion_curve_matches_solve_drive_and_series_stiffness():
    k_series = 100.0 / ARCMIN  # 100 N·m/arcmin
    curve = torsion_curve(TABLE1, TPM, None, 250.0, REV, points=9, series_stiffness=k_series)
    full = solve_drive(TABLE1, TPM, None, curve.torque, REV)
    np.testing.assert_array_equal(curve.rotation, full.transmission_error)
    np.testing.assert_array_equal(curve.torque_share, full.torque_share)
    # rigidity of the mesh: the secant between 50 % and 100 % on each side
    te = full.transmission_error
    i = {t: int(np.flatnonzero(curve.torque == t)[0]) for t in (-250, -125, 125, 250)}
    secant = 0.5 * (125 / np.abs(te[i[250]] - te[i[125]]) + 125 / np.abs(te[i[-250]] - te[i[-125]]))
    np.testing.assert_allclose(curve.torsional_rigidity, secant, rtol=1e-14)
    # springs in series: 1/k = 1/k_mesh + 1/k_series for each secant
    inv = 0.5 * (
        1 / (1 / (125 / np.abs(te[i[250]] - te[i[125]])) + 1 / k_series)
        + 1 / (1 / (125 / np.abs(te[i[-250]] - te[i[-125]])) + 1 / k_series)
    )
    np.testing.assert_allclose(curve.drive_torsional_rigidity, inv, rtol=1e-12)
    assert np.all(curve.drive_lost_motion > curve.lost_motion)


@pytest.mark.parametrize("kernel_name", ["numpy", "numba"])
def test_without_leaves_out_the_force_directions_and_overlap_and_nothing_else(
    monkeypatch, kernel_name
):
    """A metrics-only solve (solve_drive ``without``) reports None for the fields it was
    told to leave out and every other field bit for bit, on both flanks, for a stack
    and with either kernel; an unknown field is refused in one line."""
    if kernel_name == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", kernel_name)
    errors = ring_errors(7, rings=(3,))
    angles = np.deg2rad(np.arange(0.0, 360.0, 10.0))
    args = (TABLE1, TPM, errors, [250.0, -7.5, 7.5], angles, True, 2)
    full = solve_drive(*args)
    lean = solve_drive(*args, without=("force_angle", "overlap"))
    assert lean.force_angle is None and lean.mesh_force_angle is None and lean.overlap is None
    assert full.force_angle is not None and full.overlap is not None
    skipped = {"force_angle", "mesh_force_angle", "overlap"}
    for name, value in vars(full).items():
        if name not in skipped and value is not None and not isinstance(value, dict):
            np.testing.assert_array_equal(getattr(lean, name), value, err_msg=name, strict=True)
    only_angle = solve_drive(*args, without=("force_angle",))
    np.testing.assert_array_equal(only_angle.overlap, full.overlap, strict=True)
    with pytest.raises(ValueError, match=r"only \['force_angle', 'overlap'\] may be left out"):
        solve_drive(*args, without=("pin_load",))


@pytest.mark.parametrize("kernel_name", ["numpy", "numba"])
def test_a_mirror_mesh_without_rests_is_the_same_mesh_otherwise(monkeypatch, kernel_name):
    """stack_meshes(reverse_rests=False): the mirror problem's mesh without its rest
    positions and backlash (None), every other array the same bits; the RV stage under
    positive torques asks for it so (it reads only the mirror's flanks), and its solve is
    the one with the full mirror mesh bit for bit."""
    import dataclasses

    from cyclomesh.core.case import Case, Model
    from cyclomesh.core.kernel import ENV_VAR
    from cyclomesh.core.pair import CrankHoles
    from cyclomesh.drive.mesh import stack_meshes
    from cyclomesh.stage import RollerSet, StageDesign
    from cyclomesh.stage.solve import solve as solve_stage_case

    if kernel_name == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv(ENV_VAR, kernel_name)
    rng = np.random.default_rng(7)
    errors = PinErrors(radial=rng.uniform(-2e-6, 2e-6, TABLE1.pins))
    mod = Modification(pin_radius=8e-6)
    phi = np.radians(np.arange(0.0, 360.0, 10.0))
    args = (TABLE1, mod, errors, phi, 2, True, True, True, "half_plane", None, False)
    full = stack_meshes(*args)
    lean = stack_meshes(*args, reverse_rests=False)
    assert lean[1].rest is None and lean[1].reverse_rest is None and lean[1].backlash is None
    for a, b in ((full[0], lean[0]), (full[1], lean[1])):
        for field in dataclasses.fields(a):
            x, y = getattr(a, field.name), getattr(b, field.name)
            if field.name == "geo":
                for name in x.__dataclass_fields__:
                    np.testing.assert_array_equal(getattr(x, name), getattr(y, name))
            elif isinstance(y, np.ndarray):
                np.testing.assert_array_equal(x, y)
    stage = StageDesign(
        CrankHoles(count=3, circle_radius=36e-3, radius=13e-3),
        RollerSet(14, 4e-3, 9e-3, 5e-6, 22e-3),
    )
    case = Case(TABLE1, mod, errors, 250.0, phi)
    model = Model(discs=2, stage=stage)
    got = solve_stage_case(case, model)  # forms the lean mirror mesh itself
    ref = solve_stage_case(case, model, meshes=full)
    for field in dataclasses.fields(ref):
        x = getattr(ref, field.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(getattr(got, field.name), x, err_msg=field.name)


@pytest.mark.parametrize("errors", [None, "rings"])
def test_stacked_contact_with_numba_is_the_disc_after_disc_contact_contiguous(monkeypatch, errors):
    """With numba the stack's contact is computed crank angle after crank angle (the same
    eccentric angles, φ + 2πd/N), so its (..., A, N, n1) arrays are C-contiguous, and
    equal bit for bit to the contact of the disc-after-disc angles stacked as before
    (each contact computed alone, normals included; with ring axes too)."""
    pytest.importorskip("numba")
    from cyclomesh.core.contact import UnloadedContact, unloaded_contact
    from cyclomesh.drive.mesh import _stack, disc_angles, stacked_contact

    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    errs = ring_errors(4, (2,)) if errors else PinErrors()
    phi = REV[:45]
    got = stacked_contact(TABLE1, TPM, errs, phi, 3)
    raw = unloaded_contact(TABLE1, TPM, errs, disc_angles(phi, 3), normals=True)
    for name in UnloadedContact.__dataclass_fields__:
        value = getattr(got, name)
        want = _stack(getattr(raw, name), 3, phi.size)
        assert value.shape == want.shape
        assert np.array_equal(value, want, equal_nan=True), name
        if name != "pin_radius":  # (a broadcast view of the pins' radii)
            assert value.flags.c_contiguous, name
