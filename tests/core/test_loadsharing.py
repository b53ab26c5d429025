"""Load sharing: compatibility and equilibrium (Eqs. 15-18 of Li et al., Machines 2022)."""

import numpy as np
import pytest

from cyclomesh import ConvergenceError
from cyclomesh.core.loadsharing import ROUND_OFF_TORQUE, TORQUE_TOLERANCE, column_sum, share_load

ARMS = np.array([0.0, 30e-3, 48e-3, 55e-3, 58e-3, 57e-3, 50e-3, 40e-3, 25e-3, 10e-3])


def test_constant_stiffness_zero_backlash_loads_proportional_to_arms():
    """Classical result: with equal linear springs and no backlash, F_i = T·l_i/Σl²."""
    k_inv = 2e-9  # m/N
    torque = 250.0
    rot, force = share_load(np.zeros(10), ARMS, k_inv, 0.0, torque)
    np.testing.assert_allclose(force, torque * ARMS / np.sum(ARMS**2), rtol=1e-12, atol=1e-12)
    assert rot == pytest.approx(torque * k_inv / np.sum(ARMS**2), rel=1e-12)


def test_constant_stiffness_with_backlash_closed_form():
    """Linear springs with backlash: Δφ = (T/k + Σ l²·φbl)/Σ l² over the engaged set."""
    k_inv = 2e-9
    backlash = np.array([np.inf, 3e-6, 0.0, 1e-6, 4e-6, 2e-5, 9e-5, 1e-3, np.inf, 0.0])
    torque = 250.0
    rot, force = share_load(backlash, ARMS, k_inv, 0.0, torque)
    engaged = force > 0
    arms = ARMS[engaged]
    expected = (torque * k_inv + np.sum(arms**2 * backlash[engaged])) / np.sum(arms**2)
    assert rot == pytest.approx(expected, rel=1e-12)
    assert np.all(backlash[~engaged & np.isfinite(backlash) & (ARMS > 0)] >= rot)
    np.testing.assert_allclose(force[engaged], (rot - backlash[engaged]) * arms / k_inv, rtol=1e-10)


def test_nonlinear_equilibrium_to_tolerance_vectorised():
    rng = np.random.default_rng(5)
    backlash = rng.uniform(0, 2e-5, (7, 3, 10))
    backlash[..., 2] = 0.0
    # the range of the Table 1 design (compliance_coefficients gives α/γ of 12 to 17)
    alpha = rng.uniform(5.2e-9, 6.6e-9, (7, 3, 10))
    gamma = rng.uniform(3.4e-10, 4.0e-10, (7, 3, 10))
    for torque in (1.0, 250.0, 2000.0):
        rot, force = share_load(backlash, ARMS, alpha, gamma, torque)
        assert rot.shape == (7, 3)
        total = np.sum(force * ARMS, axis=-1)
        np.testing.assert_allclose(total, torque, rtol=10 * TORQUE_TOLERANCE)
        # compatibility: engaged pins deform by l(Δφ − φbl), the others are free
        delta = np.maximum(rot[..., None] - backlash, 0) * ARMS
        log_f = np.log(np.where(force > 0, force, 1))
        np.testing.assert_allclose(
            force * (alpha - gamma * log_f), np.where(force > 0, delta, 0), rtol=1e-10, atol=1e-18
        )


def test_no_pin_can_carry_the_torque():
    with pytest.raises(ConvergenceError, match="no pin"):
        share_load(np.full(3, np.inf), np.ones(3), 1e-9, 0.0, 1.0)


def test_torque_beyond_the_contact_law_is_refused():
    with pytest.raises(ConvergenceError, match="torque too large"):
        share_load(np.zeros(3), np.full(3, 1e-3), 5e-9, 4e-10, 1e12)


def test_the_root_is_reached_at_round_off_whatever_the_start():
    """Newton runs past 1e-12·T to the root: the torque residual is at round-off, and a
    start left or right of the root (a neighbouring crank angle's) gives the same root to
    a few units in the last place, not merely another point within 1e-12·T."""
    rng = np.random.default_rng(11)
    backlash = rng.uniform(0, 2e-5, (40, 10))
    backlash[:, 2] = 0.0
    alpha = rng.uniform(5.2e-9, 6.6e-9, (40, 10))
    gamma = rng.uniform(3.4e-10, 4.0e-10, (40, 10))
    for torque in (1.0, 250.0, 2000.0):
        rot, force = share_load(backlash, ARMS, alpha, gamma, torque)
        total = column_sum(force * ARMS)
        # each case's last step did not reduce a residual already at the sum's round-off
        assert np.all(np.abs(total - torque) <= 8 * ROUND_OFF_TORQUE * torque)
        for factor in (0.7, 0.999, 1.001, 1.3):
            again, moved = share_load(backlash, ARMS, alpha, gamma, torque, start=factor * rot)
            np.testing.assert_allclose(again, rot, rtol=1e-14, atol=0)
            np.testing.assert_allclose(moved, force, rtol=0, atol=1e-14 * np.max(force))
