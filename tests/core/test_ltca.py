"""Loaded tooth contact analysis through a revolution (Li et al., Machines 2022, Sections 2-5)."""

import numpy as np
import pytest

from cyclomesh import (
    TABLE1,
    ConvergenceError,
    DesignError,
    Modification,
    PinErrors,
    analyse,
    summarize,
)
from cyclomesh.core.loadsharing import TORQUE_TOLERANCE
from cyclomesh.core.ltca import solve_ltca

TPM = Modification(pin_radius=8e-6)
STEP = np.deg2rad(0.5)
REV = np.arange(0, 2 * np.pi - STEP / 2, STEP)


def random_errors(seed, rings=(), radial_um=(-4.0, 4.0)):
    rng = np.random.default_rng(seed)
    shape = (*rings, TABLE1.pins)
    return PinErrors(
        radial=rng.uniform(*radial_um, shape) * 1e-6, angular=rng.uniform(-5e-5, 5e-5, shape)
    )


@pytest.mark.parametrize("mod", [None, TPM])
@pytest.mark.parametrize("groove", [False, True])
def test_moments_of_pin_loads_balance_the_torque(mod, groove):
    # without TPM there is no clearance: only outward radial errors let the pins fit
    errors = random_errors(1, radial_um=(0.0, 4.0) if mod is None else (-4.0, 4.0))
    res = solve_ltca(TABLE1, mod, errors, 250.0, REV, groove)
    total = np.sum(res.pin_load * res.moment_arm, axis=-1)
    np.testing.assert_allclose(total, 250.0, rtol=10 * TORQUE_TOLERANCE)
    assert np.all(np.isfinite(res.pin_load)) and np.all(res.pin_load >= 0)


def test_unmodified_pair_loads_about_half_the_pins():
    res = solve_ltca(TABLE1, None, None, 250.0, REV, True)
    assert res.contacts.min() >= 18 and res.contacts.max() <= 21
    np.testing.assert_array_less(res.rest_rotation, 1e-9)  # every loaded pin touches at once
    np.testing.assert_array_less(-1e-9, res.rest_rotation)


def test_tpm_opens_backlash_and_cuts_the_loaded_pins():
    ideal = solve_ltca(TABLE1, None, None, 250.0, REV, True)
    tpm = solve_ltca(TABLE1, TPM, None, 250.0, REV, True)
    assert tpm.contacts.max() < ideal.contacts.min() / 1.5
    assert tpm.pin_load.max() > 1.3 * ideal.pin_load.max()
    assert tpm.contact_stress.max() > ideal.contact_stress.max()
    assert np.all(tpm.transmission_error < ideal.transmission_error)  # more lag


def test_loaded_pins_at_zero_degrees():
    res = solve_ltca(TABLE1, TPM, None, 250.0, [0.0], True)
    loaded = np.flatnonzero(res.pin_load[0] > 0) + 1
    assert loaded.min() >= 2 and loaded.max() <= 21


def test_error_free_pair_repeats_with_the_mesh_period():
    """TE and the contact pattern repeat every 360°/n1 of crank angle, pin k → k + 1."""
    psi = 2 * np.pi / TABLE1.pins
    phi = np.deg2rad(np.array([0.0, 1.3, 4.1, 7.7]))
    a = solve_ltca(TABLE1, TPM, None, 250.0, phi, True)
    b = solve_ltca(TABLE1, TPM, None, 250.0, phi + psi, True)
    np.testing.assert_allclose(b.transmission_error, a.transmission_error, rtol=0, atol=1e-13)
    np.testing.assert_allclose(b.pin_load, np.roll(a.pin_load, 1, axis=-1), rtol=1e-9, atol=1e-7)
    np.testing.assert_array_equal(b.contacts, a.contacts)


def test_more_torque_never_fewer_contacts_nor_smaller_te():
    errors = random_errors(2)
    previous = None
    for torque in (50.0, 150.0, 250.0, 500.0, 1000.0):
        res = solve_ltca(TABLE1, TPM, errors, torque, REV[::4], True)
        if previous is not None:
            assert np.all(res.contacts >= previous.contacts)
            assert np.all(np.abs(res.transmission_error) >= np.abs(previous.transmission_error))
        previous = res


def test_groove_deformation_softens_the_mesh():
    """Improved model: more compliance, so more lag and no higher peak load (Table 2)."""
    current = solve_ltca(TABLE1, TPM, None, 250.0, REV, False)
    improved = solve_ltca(TABLE1, TPM, None, 250.0, REV, True)
    assert np.all(improved.transmission_error < current.transmission_error)
    assert improved.pin_load.max() < current.pin_load.max()
    assert np.all(improved.contacts >= current.contacts)


def test_explicit_zero_errors_give_exactly_the_error_free_result():
    z = np.zeros(TABLE1.pins)
    a = solve_ltca(TABLE1, TPM, None, 250.0, REV[:40], True)
    b = solve_ltca(TABLE1, TPM, PinErrors(z, z, z, 0.0), 250.0, REV[:40], True)
    for name in ("pin_load", "transmission_error", "backlash", "contact_stress", "gear_ratio"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_rings_solved_together_equal_rings_solved_alone():
    """Bit for bit: a ring's result does not depend on the rings batched with it."""
    errors = random_errors(4, (5,))
    together = solve_ltca(TABLE1, TPM, errors, 250.0, REV[::6], True)
    for k in range(5):
        alone = solve_ltca(
            TABLE1,
            TPM,
            PinErrors(radial=errors.radial[k], angular=errors.angular[k]),
            250.0,
            REV[::6],
            True,
        )
        np.testing.assert_array_equal(together.pin_load[k], alone.pin_load)
        np.testing.assert_array_equal(together.transmission_error[k], alone.transmission_error)


def test_results_converge_as_the_crank_step_shrinks():
    """Peak stress and TE peak-to-peak over a mesh cycle converge as the step halves."""
    period = 2 * np.pi / TABLE1.pins
    errors = random_errors(8)
    peaks, pps = [], []
    for n in (20, 40, 80, 160, 320):
        phi = np.linspace(0, period, n, endpoint=False)
        res = solve_ltca(TABLE1, TPM, errors, 250.0, phi, True)
        peaks.append(res.contact_stress.max())
        pps.append(np.ptp(res.transmission_error))
    d_peak = np.abs(np.diff(peaks))
    d_pp = np.abs(np.diff(pps))
    assert d_peak[-1] < 0.01 * peaks[-1] and d_peak[-1] <= d_peak[0]
    assert d_pp[-1] < 0.01 * pps[-1] and d_pp[-1] <= d_pp[0]


def test_gear_ratio_converges_as_the_crank_step_shrinks():
    """Central-difference ratio at an angle clear of contact changes: second order in h."""
    target = np.deg2rad(5.5)  # 9 pins in contact throughout the stencils below
    values = []
    for h in np.deg2rad([0.4, 0.2, 0.1, 0.05, 0.025]):
        phi = target + h * np.arange(-2, 3)
        res = solve_ltca(TABLE1, TPM, None, 250.0, phi, True)
        assert np.all(res.contacts == res.contacts[0])
        values.append(res.gear_ratio[2])
    diffs = np.abs(np.diff(values))
    np.testing.assert_array_less(3.0, diffs[:-1] / diffs[1:])  # about 4 = 2²
    assert values[-1] == pytest.approx(TABLE1.teeth, rel=5e-3)


def test_rotation_modification_shifts_te_and_keeps_loads():
    delta = 20e-6
    a = solve_ltca(TABLE1, TPM, None, 250.0, REV[:30], True)
    b = solve_ltca(
        TABLE1, Modification(pin_radius=8e-6, rotation=delta), None, 250.0, REV[:30], True
    )
    np.testing.assert_allclose(
        b.transmission_error, a.transmission_error - delta, rtol=0, atol=1e-15
    )
    np.testing.assert_allclose(b.pin_load, a.pin_load, rtol=1e-12, atol=1e-9)


def test_unloaded_side_overlap_is_detected():
    """A pin displaced beyond the clearance interferes with the unloaded flank."""
    found = []
    for sign in (+1, -1):
        angular = np.zeros(TABLE1.pins)
        angular[30] = sign * 4e-4
        res = solve_ltca(TABLE1, TPM, PinErrors(angular=angular), 250.0, REV, True)
        found.append(res.overlap.max(axis=0))
    free = solve_ltca(TABLE1, TPM, None, 250.0, REV, True)
    assert free.overlap.max() == 0.0
    hit = np.maximum(*found)
    assert hit[30] > 0 and np.all(np.delete(hit, 30) == 0)


def test_solver_failure_names_the_crank_angle():
    with pytest.raises(ConvergenceError, match="crank angle"):
        solve_ltca(TABLE1, TPM, None, 1e12, REV[:3], True)


@pytest.mark.parametrize("torque", [0.0, -5.0, float("nan")])
def test_bad_torque(torque):
    with pytest.raises(DesignError, match="torque"):
        solve_ltca(TABLE1, TPM, None, torque, REV[:3], True)


def test_pin_overlapping_the_tooth_space_bottom_is_refused():
    radial = np.zeros(TABLE1.pins)
    radial[5] = -30e-6
    with pytest.raises(DesignError, match="pin 6 overlaps"):
        solve_ltca(TABLE1, TPM, PinErrors(radial=radial), 250.0, REV, True)


def test_dataset_units_and_summary():
    ds = analyse(TABLE1, TPM, crank_angles=REV[::10])
    expected = {
        "pin_load": "N",
        "groove_load": "N",
        "contact_stress": "MPa",
        "groove_stress": "MPa",
        "backlash": "arcsec",
        "transmission_error": "arcsec",
        "gear_ratio": "1",
        "contacts": "1",
    }
    for name, unit in expected.items():
        assert ds[name].attrs["units"] == unit
    assert ds["pin_load"].dims == ("crank_angle", "pin")
    assert list(ds["pin"].values) == list(range(1, 41))
    assert ds["crank_angle"].values[1] == pytest.approx(5.0)
    s = summarize(ds)
    assert float(s["max_contact_stress_mpa"]) == pytest.approx(float(ds["contact_stress"].max()))
    assert float(s["te_mean_arcsec"]) < 0  # a lagging disc
    rings = analyse(TABLE1, TPM, random_errors(0, (2,)), crank_angles=REV[::10])
    assert rings["pin_load"].dims == ("ring", "crank_angle", "pin")
    assert summarize(rings)["max_pin_load_n"].dims == ("ring",)


def test_pin_larger_than_its_groove_is_refused():
    radius = np.zeros(TABLE1.pins)
    radius[12] = 6e-6  # 3.506 mm in a 3.505 mm groove
    with pytest.raises(DesignError, match="pin 13"):
        solve_ltca(TABLE1, TPM, PinErrors(pin_radius=radius), 250.0, REV[:4], True)


def test_degrees_label_the_dataset_exactly():
    ds = analyse(TABLE1, TPM, crank_angles_deg=np.arange(0, 360, 15.0))
    assert float(ds["pin_load"].sel(crank_angle=60.0).sum()) > 0
    np.testing.assert_array_equal(ds["crank_angle"].values, np.arange(0, 360, 15.0))
