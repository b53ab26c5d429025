"""Hertzian line contact with pin-groove deformation (Eqs. 19-24 of Li et al., Machines 2022)."""

import numpy as np
import pytest

from cyclomesh import STEEL
from cyclomesh.core.hertz import (
    approach,
    compliance_coefficients,
    effective_modulus,
    force_from_approach,
    force_from_approach_w,
    half_width,
    max_pressure,
    pin_groove_radius,
    pin_tooth_radius,
)

C = STEEL.compliance
B = 12e-3
RP, RG = 3.5e-3, 3.505e-3


@pytest.mark.parametrize("rho_c", [4.3e-3, -3.7e-3, 20e-3])
@pytest.mark.parametrize("cos_beta", [1.0, 0.6, 0.05])
def test_coefficients_reproduce_eq19_to_eq21(rho_c, cos_beta):
    """δ = δc(F) + cos β·δp(F cos β) written as F(α − γ ln F) is the same function."""
    force = np.geomspace(1e-2, 5e3, 40)
    delta_c = approach(force, rho_c, RP, C, C, pin_tooth_radius(RP, rho_c), B)
    delta_p = approach(force * cos_beta, RG, RP, C, C, pin_groove_radius(RP, RG), B)
    alpha, gamma = compliance_coefficients(RP, rho_c, RG, cos_beta, B, C, C, C, True)
    np.testing.assert_allclose(
        force * (alpha - gamma * np.log(force)), delta_c + cos_beta * delta_p, rtol=1e-12
    )
    alpha0, gamma0 = compliance_coefficients(RP, rho_c, RG, cos_beta, B, C, C, C, False)
    np.testing.assert_allclose(force * (alpha0 - gamma0 * np.log(force)), delta_c, rtol=1e-12)


def test_force_from_approach_inverts_to_round_off():
    alpha, gamma = compliance_coefficients(RP, 4.3e-3, RG, 0.8, B, C, C, C, True)
    force = np.geomspace(1e-6, 1e5, 200)
    delta = force * (alpha - gamma * np.log(force))
    np.testing.assert_allclose(force_from_approach(delta, alpha, gamma), force, rtol=1e-13)
    # the closed form through Lambert W agrees
    np.testing.assert_allclose(force_from_approach_w(delta, alpha, gamma), force, rtol=1e-13)
    assert force_from_approach(0.0, alpha, gamma) == 0.0


def test_linear_spring_limit():
    assert force_from_approach(2e-6, 1e-9, 0.0) == pytest.approx(2000.0, rel=1e-15)


def test_approach_is_monotone_and_stiffening():
    """Contact stiffness F/δ grows with the load (the nonlinearity of Section 4)."""
    alpha, gamma = compliance_coefficients(RP, 4.3e-3, RG, 0.8, B, C, C, C, True)
    force = np.geomspace(1.0, 1e4, 100)
    delta = force * (alpha - gamma * np.log(force))
    assert np.all(np.diff(delta) > 0)
    assert np.all(np.diff(force / delta) > 0)


def test_max_pressure_is_eq24():
    e_star = effective_modulus(C, C)
    rho = pin_tooth_radius(RP, 4.3e-3)
    b = half_width(700.0, rho, e_star, B)
    assert max_pressure(700.0, rho, e_star, B) == pytest.approx(
        2 * 700.0 / (np.pi * b * B), rel=1e-14
    )


def test_concave_contact_is_conforming():
    """Signed ρc: a concave flank gives a larger equivalent radius than a convex one."""
    assert pin_tooth_radius(RP, -3.7e-3) > 10 * pin_tooth_radius(RP, 3.7e-3)
    assert pin_groove_radius(RP, RG) == pytest.approx(RP * RG / 5e-6)


def test_inversion_of_a_tiny_approach_converges_to_round_off():
    """Issue 23: the RV-40E-size stage with ±2 µm / ±50 µrad pin errors met an approach of
    2e-23 m at 3 % of the rated torque, where |ln F| ≈ 35: 2e-15·δ lies below what one
    unit in the last place of ln F resolves, so Newton stalled at 2.4e-15·δ and the whole
    stage failed ("inversion of the contact law (Eq. 20) did not converge"). The
    inversion now accepts a residual at the resolution of its unknown."""
    import numpy as np

    from cyclomesh.core.hertz import force_from_approach

    d, a, g = 1.9852334701272664e-23, 7.455829532665755e-09, 4.54654566497379e-10
    f = float(force_from_approach(d, a, g))
    assert f > 0
    assert abs(f * (a - g * np.log(f)) - d) <= 1e-14 * d
    # the same element in a batch with ordinary ones: the others' bits are unchanged
    batch = force_from_approach([d, 1e-6, 2e-6], a, g)
    np.testing.assert_array_equal(batch[1:], force_from_approach([1e-6, 2e-6], a, g))
