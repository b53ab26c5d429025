"""Unloaded tooth contact analysis (Eqs. 5-14 of Li et al., Machines 2022)."""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from cyclomesh import TABLE1, Modification, PinErrors
from cyclomesh.core.contact import CONTACT_TOLERANCE, unloaded_contact
from cyclomesh.core.profile import modified_profile

PSI = 2 * np.pi / TABLE1.pins
TPM = Modification(pin_radius=8e-6)


def random_errors(seed, rings=()):
    rng = np.random.default_rng(seed)
    shape = (*rings, TABLE1.pins)
    return PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, shape),
        angular=rng.uniform(-5e-5, 5e-5, shape),
        pin_radius=rng.uniform(-2e-6, 2e-6, shape),
        eccentricity=rng.uniform(-2e-6, 2e-6, rings),
    )


def test_unmodified_pair_has_zero_backlash_on_the_loaded_side():
    """No TPM, no errors: every loaded-side pin touches at once (Section 5 of the spec)."""
    phi = np.deg2rad(np.arange(0.0, 9.0, 0.37))
    geo = unloaded_contact(TABLE1, None, None, phi)
    backlash = geo.rotation - geo.rotation.min(axis=-1, keepdims=True)
    # tooth phase of each pin, n2·(i·ψ + φ/n2) wrapped to (−π, π]; loaded flank (−π, 0)
    phase = np.angle(np.exp(1j * (TABLE1.teeth * np.arange(40) * PSI + phi[:, None])))
    loaded_side = (phase < -0.05) & (phase > -np.pi + 0.05)
    # pins at the bottom or tip of a space (arm ~ 0) are excluded: there the contact
    # rotation is ill-conditioned (the gap does not change to first order)
    assert np.all(np.abs(backlash[loaded_side]) < 1e-12)
    assert np.all(np.abs(geo.rotation[loaded_side]) < 1e-12)  # and at the theoretical angle
    count = loaded_side.sum(axis=-1)
    assert np.all((count >= 18) & (count <= 20))  # about half of 40


def test_loaded_pins_at_zero_are_2_to_20():
    """Convention of the issue: at 0° the loaded pins are numbers 2 to about 20."""
    geo = unloaded_contact(TABLE1, None, None, [0.0])
    arm = geo.moment_arm[0]
    assert np.all(arm[1:20] > 1e-3)
    assert arm[0] == pytest.approx(0.0, abs=1e-7)  # pin 1 sits in a tooth-space bottom


@pytest.mark.parametrize("mod", [TPM, Modification(pin_circle_radius=-5e-6, pin_radius=3e-6)])
def test_contact_condition_is_met_to_round_off(mod):
    geo = unloaded_contact(TABLE1, mod, random_errors(3, (2,)), np.deg2rad(np.arange(0, 360, 7.3)))
    reachable = np.isfinite(geo.rotation)
    assert np.all(geo.residual[reachable] <= CONTACT_TOLERANCE)
    assert reachable.mean() > 0.9


def test_contact_against_brute_force_distance_to_the_profile():
    """At the computed rotation the pin circle touches the modified profile (Eq. 10).

    Independent check: the distance from the pin centre to the profile (found by
    minimising over the profile parameter) equals the pin radius, and the pin does not
    cut the profile.
    """
    errors = random_errors(11)
    phi = np.deg2rad(23.0)
    geo = unloaded_contact(TABLE1, TPM, errors, [phi])
    n2 = TABLE1.teeth
    for i in (3, 7, 12, 17):
        rot = -phi / n2 + geo.rotation[0, i]
        ang = i * PSI + errors.angular[i]
        r = TABLE1.pin_circle_radius + errors.radial[i]
        ecc = TABLE1.eccentricity + float(errors.eccentricity)
        cx = r * np.cos(ang) - ecc * np.cos(phi)
        cy = r * np.sin(ang) - ecc * np.sin(phi)
        qx = np.cos(rot) * cx + np.sin(rot) * cy
        qy = -np.sin(rot) * cx + np.cos(rot) * cy
        grid = n2 * np.arctan2(qy, qx) + np.linspace(-np.pi, np.pi, 20001)
        gx, gy = modified_profile(TABLE1, TPM, grid)
        start = grid[np.argmin(np.hypot(gx - qx, gy - qy))]

        def dist(p1, qx=qx, qy=qy):
            x, y = modified_profile(TABLE1, TPM, p1)
            return float(np.hypot(x - qx, y - qy))

        best = minimize_scalar(
            dist, bounds=(start - 1e-3, start + 1e-3), method="bounded", options={"xatol": 1e-12}
        )
        r_pin = TABLE1.pin_radius + errors.pin_radius[i]
        assert best.fun == pytest.approx(r_pin, abs=1e-11)  # 1e-8 mm


def test_explicit_zero_errors_equal_no_errors():
    phi = np.deg2rad(np.arange(0, 20, 1.0))
    a = unloaded_contact(TABLE1, TPM, None, phi)
    z = np.zeros(TABLE1.pins)
    b = unloaded_contact(TABLE1, TPM, PinErrors(z, z, z, 0.0), phi)
    for name in ("rotation", "moment_arm", "cos_beta", "curvature_radius", "profile_angle"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_moment_arm_is_the_derivative_of_the_contact_rotation():
    """Virtual work: moving pin i radially inward by dr turns its contact by dr·(n·r̂)/l."""
    phi = [np.deg2rad(4.0)]
    base = unloaded_contact(TABLE1, TPM, None, phi)
    i = 8
    dr = np.zeros(TABLE1.pins)
    dr[i] = -1e-8
    moved = unloaded_contact(TABLE1, TPM, PinErrors(radial=dr), phi)
    d_rot = moved.rotation[0, i] - base.rotation[0, i]
    # the pin moves by dr along its radial line; the gap closes by |dr|·cos β
    expected = -abs(dr[i]) * base.cos_beta[0, i] / base.moment_arm[0, i]
    assert d_rot == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize("eccentricity_mm", [26.0, 26.5, 27.0])
def test_two_teeth_the_unloaded_flank_is_at_most_a_pitch_behind(eccentricity_mm):
    # 3 pins, 2 teeth (pitch half a turn), K1 up to 0.99: a pin at a tooth tip has its
    # two flanks half a turn apart; the plain wrap to (−π, π] read that as an
    # interference of 180° (issue 15). The gap lies within [0, pitch]: the unmodified
    # pair has no interference at all.
    from cyclomesh import PairDesign

    design = PairDesign(
        pins=3,
        pin_circle_radius=82e-3,
        pin_radius=3.5e-3,
        groove_radius=3.505e-3,
        eccentricity=eccentricity_mm * 1e-3,
        width=12e-3,
    )
    phi = np.deg2rad(np.arange(0.0, 360.0, 0.1))
    geo = unloaded_contact(design, Modification(), None, phi)
    ok = np.isfinite(geo.rotation) & np.isfinite(geo.reverse_rotation)
    gap = (geo.rotation - geo.reverse_rotation)[ok]
    pitch = 2.0 * np.pi / design.teeth
    assert np.all(gap > -1e-9) and np.all(gap <= pitch + 1e-9)


def test_the_contact_normal_is_a_unit_vector_whose_line_through_the_pin_gives_the_moment_arm():
    """The line of action (through the pin centre C_i along n, Eq. 10 of [1]) passes at the
    moment arm l_i of Eq. 17 from the disc centre, with errors and a stack of two discs."""
    from cyclomesh.core.contact import contact_normal, contact_tangent

    errors = random_errors(3)
    phi = np.deg2rad(np.arange(0.0, 30.0, 2.9))
    crank = phi[:, None] + np.array([0.0, np.pi])[None, :]  # two discs, (A, 2)
    geo = unloaded_contact(TABLE1, TPM, errors, crank.ravel())
    shape = (phi.size, 2, TABLE1.pins)
    u, r_pin = geo.profile_angle.reshape(shape), geo.pin_radius.reshape(shape)
    nx, ny = contact_normal(TABLE1, TPM, errors, crank, u, r_pin)
    np.testing.assert_allclose(np.hypot(nx, ny), 1.0, rtol=0, atol=1e-15)
    tx, ty = contact_tangent(nx, ny)
    np.testing.assert_allclose(nx * tx + ny * ty, 0.0, atol=1e-15)
    ang = np.arange(TABLE1.pins) * PSI + errors.angular
    r = TABLE1.pin_circle_radius + errors.radial
    ecc = TABLE1.eccentricity + errors.eccentricity
    wx = r * np.cos(ang) - ecc * np.cos(crank)[..., None]
    wy = r * np.sin(ang) - ecc * np.sin(crank)[..., None]
    arm = geo.moment_arm.reshape(shape)
    reach = np.isfinite(geo.rotation.reshape(shape))
    np.testing.assert_allclose(np.abs(wx * ny - wy * nx)[reach], arm[reach], rtol=0, atol=1e-12)


@pytest.mark.parametrize("rings", [(), (3,), (2, 2)])
def test_normals_at_a_few_contacts_are_the_references_bit_for_bit(monkeypatch, rings):
    """normals_at (the normals of some contacts only, for the mesh force of the loaded
    pins) gives the NumPy reference's normals of unloaded_contact at those contacts, bit
    for bit, with and without ring axes and with eccentricity and pin radius errors."""
    from cyclomesh.core.contact import normals_at

    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    rng = np.random.default_rng(3)
    shape = (*rings, TABLE1.pins)
    errors = PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, shape),
        angular=rng.uniform(-5e-5, 5e-5, shape),
        pin_radius=rng.uniform(-1e-6, 1e-6, shape),
        eccentricity=rng.uniform(-2e-6, 2e-6, rings),
    )
    modification = Modification(pin_radius=8e-6, pin_circle_radius=-3e-6)
    phi = np.deg2rad(np.arange(0.0, 360.0, 7.0))
    geo = unloaded_contact(TABLE1, modification, errors, phi, normals=True)
    at = rng.choice(geo.rotation.size, 500, replace=False)
    where = np.unravel_index(at, geo.rotation.shape)
    ring = np.ravel_multi_index(where[:-2], rings) if rings else np.zeros_like(at)
    nx, ny = normals_at(
        TABLE1,
        modification,
        errors,
        phi,
        ring,
        where[-2],
        where[-1],
        geo.profile_angle[where],
        geo.pin_radius[where],
    )
    np.testing.assert_array_equal(nx, geo.normal_x[where], strict=True)
    np.testing.assert_array_equal(ny, geo.normal_y[where], strict=True)
