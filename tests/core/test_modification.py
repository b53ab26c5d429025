"""Rotation modification and tabulated profile deviations (issue 9)."""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from cyclomesh import TABLE1, DesignError, Modification, PinErrors
from cyclomesh.core.contact import CONTACT_TOLERANCE, unloaded_contact
from cyclomesh.core.deviation import MAX_ANGLE_STEP, ProfileDeviation
from cyclomesh.core.ltca import CONDITIONED_ARM, solve_ltca
from cyclomesh.core.profile import check_profile, deviated_geometry, modified_profile
from cyclomesh.drive.solve import mirror_errors, play

N1, N2 = TABLE1.pins, TABLE1.teeth
A, E = TABLE1.pin_circle_radius, TABLE1.eccentricity
MESH = np.deg2rad(np.arange(0.0, 9.0, 0.25))  # one mesh cycle
GEOMETRY = ("rotation", "reverse_rotation", "moment_arm", "cos_beta", "profile_angle")


def flank(step_deg=5.0, stop=0.0):
    return np.deg2rad(np.linspace(-180.0, stop, int(round((stop + 180.0) / step_deg)) + 1))


def ring_errors(seed, rings=()):
    rng = np.random.default_rng(seed)
    shape = (*rings, N1)
    return PinErrors(
        radial=rng.uniform(-3e-6, 3e-6, shape),
        angular=rng.uniform(-3e-5, 3e-5, shape),
        pin_radius=rng.uniform(-1e-6, 1e-6, shape),
        eccentricity=rng.uniform(-1e-6, 1e-6, rings),
    )


def rotation_relief(u, delta):
    """Normal relief of a flank turned by δ about the disc centre: δ times the moment arm."""
    d = np.sqrt(A * A + E * E * N1 * N1 - 2 * A * E * N1 * np.cos(u))
    return delta * A * E * N2 * np.abs(np.sin(u)) / d


# ---------------------------------------------------------------- rotation modification


def test_rotation_alone_keeps_the_conjugate_shape():
    delta = 15e-6
    ideal = solve_ltca(TABLE1, None, None, 250.0, MESH)
    turned = solve_ltca(TABLE1, Modification(rotation=delta), None, 250.0, MESH)
    # every loaded pin touches at once: zero backlash wherever a pin is loaded (pins at a
    # tip or bottom, moment arm < CONDITIONED_ARM, are set only to ~1e-9 by round-off)
    settled = (turned.pin_load > 0) & (turned.moment_arm >= CONDITIONED_ARM)
    np.testing.assert_array_less(np.abs(turned.backlash[settled]), 1e-12)
    np.testing.assert_array_equal(turned.contacts, ideal.contacts)
    np.testing.assert_allclose(
        turned.transmission_error, ideal.transmission_error - delta, rtol=0, atol=1e-15
    )
    np.testing.assert_allclose(turned.pin_load, ideal.pin_load, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("base", [Modification(pin_radius=4e-6), Modification(-3e-6, 5e-6)])
def test_rotation_grows_the_play_by_exactly_twice_delta(base):
    delta = 12e-6
    errors = ring_errors(3)
    before = play(TABLE1, base, errors, MESH)
    after = play(TABLE1, Modification(base.pin_circle_radius, base.pin_radius, delta), errors, MESH)
    np.testing.assert_allclose(after - before, 2 * delta, rtol=0, atol=1e-15)


def test_unmodified_play_is_zero_and_tpm_play_matches_the_closed_form():
    np.testing.assert_allclose(play(TABLE1, None, None, MESH), 0.0, atol=1e-12)
    k1 = TABLE1.short_amplitude_coefficient
    for da, dr in ((0.0, 8e-6), (-5e-6, 2e-6), (-4e-6, 0.0)):
        closed = 2 * (dr - da * np.sqrt(1 - k1 * k1)) / (E * N2)
        got = play(TABLE1, Modification(da, dr), None, MESH)
        np.testing.assert_allclose(got, closed, rtol=5e-3)  # first order in e/a


# ---------------------------------------------------------------- tabulated deviations


def test_constant_table_equals_equidistant_modification():
    c = 6e-6
    phi1 = flank(10.0)
    table = Modification(-2e-6, 0.0, profile=ProfileDeviation(phi1, np.full_like(phi1, c)))
    plain = Modification(-2e-6, c)
    errors = ring_errors(5, (3,))
    geo_t = unloaded_contact(TABLE1, table, errors, MESH)
    geo_p = unloaded_contact(TABLE1, plain, errors, MESH)
    for name in GEOMETRY:
        a, b = getattr(geo_t, name), getattr(geo_p, name)
        np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b))
        finite = np.isfinite(a)
        np.testing.assert_allclose(a[finite], b[finite], rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(geo_t.curvature_radius, geo_p.curvature_radius, rtol=1e-9)
    res_t = solve_ltca(TABLE1, table, errors, 250.0, MESH)
    res_p = solve_ltca(TABLE1, plain, errors, 250.0, MESH)
    np.testing.assert_allclose(res_t.transmission_error, res_p.transmission_error, atol=1e-14)
    np.testing.assert_allclose(res_t.contact_stress, res_p.contact_stress, rtol=1e-9, atol=1e-3)
    np.testing.assert_array_equal(res_t.contacts, res_p.contacts)


def test_table_of_a_rotation_reproduces_the_rotation_modification():
    delta = 20e-6
    phi1 = flank(5.0)
    table = Modification(
        pin_radius=8e-6, profile=ProfileDeviation(phi1, rotation_relief(phi1, delta))
    )
    turned = Modification(pin_radius=8e-6, rotation=delta)
    res_t = solve_ltca(TABLE1, table, None, 250.0, MESH)
    res_r = solve_ltca(TABLE1, turned, None, 250.0, MESH)
    # interpolation error: the relief δ·l(φ1) has kinks at tip and bottom a spline rounds
    np.testing.assert_allclose(
        res_t.transmission_error, res_r.transmission_error, rtol=0, atol=1e-3 * delta
    )
    np.testing.assert_allclose(
        res_t.pin_load, res_r.pin_load, rtol=0, atol=2e-3 * res_r.pin_load.max()
    )
    np.testing.assert_allclose(
        play(TABLE1, table, None, MESH), play(TABLE1, turned, None, MESH), atol=1e-3 * delta
    )


def wavy(step_deg=2.0, amplitude=3e-6):
    phi1 = flank(step_deg)
    return ProfileDeviation(phi1, amplitude * (1 + np.cos(3 * phi1)) + 4e-6)


def test_curvature_radius_with_a_deviation_matches_finite_differences():
    mod = Modification(pin_radius=2e-6, profile=wavy())
    phi1 = np.deg2rad(np.linspace(-170, -10, 33))
    h = 1e-4
    x, y = (
        np.stack(p)
        for p in zip(
            *(modified_profile(TABLE1, mod, phi1 + k * h) for k in (-1, 0, 1)), strict=True
        )
    )
    dx, dy = (x[2] - x[0]) / (2 * h), (y[2] - y[0]) / (2 * h)
    ddx, ddy = (x[2] - 2 * x[1] + x[0]) / h**2, (y[2] - 2 * y[1] + y[0]) / h**2
    fd = (dx * dx + dy * dy) ** 1.5 / (dx * ddy - dy * ddx)
    geo = deviated_geometry(phi1, TABLE1, mod, TABLE1.pin_radius)
    moderate = np.abs(fd) < 0.5  # away from the inflection point (|ρc| → ∞)
    np.testing.assert_allclose(geo.curvature_radius[moderate], fd[moderate], rtol=2e-5)
    # and the deviation really changes it (the check is not vacuous)
    plain = deviated_geometry(
        phi1,
        TABLE1,
        Modification(pin_radius=2e-6, profile=ProfileDeviation(flank(10), np.full(19, 7e-6))),
        TABLE1.pin_radius,
    )
    assert np.max(np.abs(plain.curvature_radius / geo.curvature_radius - 1)[moderate]) > 1e-3


def per_tooth_table():
    """Both flanks of every tooth space, each different: pitch-like and profile errors."""
    phi1 = flank(4.0, stop=180.0)
    j = np.arange(N2)[:, None]
    dev = (
        5e-6
        + 1.5e-6 * np.sin(2 * np.pi * j / N2) * np.sin(phi1 / 2)
        + 1e-6 * np.cos(2 * phi1 + j) * np.sin(phi1) ** 2
    )
    return ProfileDeviation(np.broadcast_to(phi1, dev.shape), dev)


def test_per_tooth_contact_is_exact_against_brute_force_distance():
    mod = Modification(profile=per_tooth_table())
    errors = ring_errors(7)
    phi = np.deg2rad(31.0)
    geo = unloaded_contact(TABLE1, mod, errors, [phi])
    assert geo.residual.max() <= CONTACT_TOLERANCE
    for i in (2, 9, 14, 33):
        ang = i * 2 * np.pi / N1 + errors.angular[i]
        r = A + errors.radial[i]
        ecc = E + float(errors.eccentricity)
        cx, cy = r * np.cos(ang) - ecc * np.cos(phi), r * np.sin(ang) - ecc * np.sin(phi)
        r_pin = TABLE1.pin_radius + errors.pin_radius[i]
        for rot in (geo.rotation[0, i], geo.reverse_rotation[0, i]):
            turn = -phi / N2 + rot
            qx = np.cos(turn) * cx + np.sin(turn) * cy
            qy = -np.sin(turn) * cx + np.cos(turn) * cy
            grid = N2 * np.arctan2(qy, qx) + np.linspace(-np.pi, np.pi, 20001)
            gx, gy = modified_profile(TABLE1, mod, grid)
            start = grid[np.argmin(np.hypot(gx - qx, gy - qy))]

            def dist(p1, qx=qx, qy=qy):
                px, py = modified_profile(TABLE1, mod, p1)
                return float(np.hypot(px - qx, py - qy))

            best = minimize_scalar(
                dist,
                bounds=(start - 1e-3, start + 1e-3),
                method="bounded",
                options={"xatol": 1e-12},
            )
            assert best.fun == pytest.approx(r_pin, abs=1e-11)


def test_identical_per_tooth_tables_equal_one_table():
    phi1 = flank(5.0)
    dev = 5e-6 + 2e-6 * np.cos(phi1)
    one = Modification(profile=ProfileDeviation(phi1, dev))
    every = Modification(profile=ProfileDeviation(np.tile(phi1, (N2, 1)), np.tile(dev, (N2, 1))))
    a = unloaded_contact(TABLE1, one, None, MESH)
    b = unloaded_contact(TABLE1, every, None, MESH)
    for name in GEOMETRY:
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-13)


def test_mirrored_table_swaps_flanks_and_teeth():
    table = per_tooth_table()
    mirror = table.mirrored()
    u = np.linspace(-np.pi, np.pi, 101)
    for j in (0, 1, 5, 38):
        for k in range(3):
            np.testing.assert_allclose(
                mirror.evaluate(-u, (-j) % N2, k), (-1) ** k * table.evaluate(u, j, k), atol=1e-15
            )
    np.testing.assert_array_equal(mirror.mirrored().deviation, table.deviation)
    symmetric = wavy()
    assert symmetric.mirrored() is symmetric


def test_mirrored_modification_gives_the_mirrored_contact():
    """Reverse flank of the system = forward flank of its mirror image (x-axis)."""
    mod = Modification(pin_radius=3e-6, profile=per_tooth_table())
    errors = ring_errors(9)
    geo = unloaded_contact(TABLE1, mod, errors, MESH)
    mirror = unloaded_contact(TABLE1, mod.mirrored(), mirror_errors(errors, N1), -MESH)
    order = (-np.arange(N1)) % N1
    np.testing.assert_allclose(-mirror.rotation[:, order], geo.reverse_rotation, atol=1e-13)


@pytest.mark.parametrize(
    ("angle", "deviation", "message"),
    [
        (flank(15.0), None, "too coarse"),
        (np.r_[flank(10.0)[:5], flank(10.0)[3], flank(10.0)[6:]], None, "does not increase"),
        (flank(10.0, stop=0.0)[1:], None, "must start at"),
        (np.r_[flank(10.0), 0.1], None, "must end at"),
    ],
)
def test_bad_tables_are_refused_naming_the_row(angle, deviation, message):
    deviation = np.zeros_like(angle) if deviation is None else deviation
    rows = np.arange(2, angle.size + 2)
    with pytest.raises(DesignError, match=message) as info:
        ProfileDeviation(angle, deviation, rows)
    assert "line " in str(info.value) and "\n" not in str(info.value)


def test_coarseness_limit_is_the_documented_step():
    ok = np.linspace(-np.pi, 0.0, int(np.ceil(np.pi / MAX_ANGLE_STEP)) + 1)
    ProfileDeviation(ok, np.zeros_like(ok))


def test_a_table_that_loops_the_profile_is_refused():
    phi1 = flank(2.0)
    bump = -60e-6 * np.exp(-(((phi1 + np.pi / 3) / np.deg2rad(4.0)) ** 2))  # sharp added material
    mod = Modification(
        pin_radius=8e-6, profile=ProfileDeviation(phi1, bump, np.arange(phi1.size) + 2)
    )
    with pytest.raises(DesignError, match=r"line \d+: .* (loop|tighter)"):
        check_profile(TABLE1, mod)


def test_per_tooth_table_needs_every_tooth():
    phi1 = flank(10.0)
    table = ProfileDeviation(np.tile(phi1, (5, 1)), np.zeros((5, phi1.size)))
    with pytest.raises(DesignError, match="5 teeth tabulated"):
        check_profile(TABLE1, Modification(profile=table))


def test_profile_figure_shows_the_rotation_and_a_table():
    from cyclomesh.figures import plot_profile
    from cyclomesh.results.profile import profile_curves

    delta = 20e-6
    phi1 = flank(5.0)
    mods = {
        "rotation": Modification(rotation=delta),
        "table": Modification(profile=ProfileDeviation(phi1, np.full_like(phi1, 3e-6))),
    }
    fig = plot_profile(profile_curves(TABLE1, mods, samples=721))
    lines = fig.axes[1].get_lines()
    x, rot = lines[0].get_data()
    _, tab = lines[1].get_data()
    inner = np.abs(x) < 170  # away from the tips, where the turned flanks meet
    expected = rotation_relief(np.deg2rad(x), delta) * 1e6
    np.testing.assert_allclose(rot[inner], expected[inner], atol=0.02 * expected.max())
    np.testing.assert_allclose(tab, 3.0, atol=0.05)
