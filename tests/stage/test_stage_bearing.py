"""The crank bearing's roller set against Harris & Kotzalas and ISO 281."""

import numpy as np
import pytest

from cyclomesh.exceptions import DesignError
from cyclomesh.stage.bearing import (
    LIFE_EXPONENT,
    RollerSet,
    deflection_for_force,
    dynamic_load_rating,
    equivalent_load,
    fc_table,
    life_hours,
    radial_energy,
    radial_force,
    radial_stiffness,
    rating_life,
    roller_loads,
)

# Harris & Kotzalas, Rolling Bearing Analysis, Table 7.1 (Sjövall's radial load distribution
# integral J_r(ε), line contact): ε → J_r
HARRIS_JR_LINE = {0.1: 0.1268, 0.2: 0.1737, 0.3: 0.2055, 0.4: 0.2286, 0.5: 0.2453,
                  0.6: 0.2568, 0.7: 0.2636, 0.8: 0.2658, 0.9: 0.2628, 1.0: 0.2523}  # fmt: skip


def _set(rollers=14, clearance=0.0, diameter=4e-3, length=9e-3, pitch=22e-3):
    return RollerSet(rollers, diameter, length, clearance, pitch)


@pytest.mark.parametrize("eps", [e for e in sorted(HARRIS_JR_LINE) if e <= 0.5])
def test_load_distribution_matches_harris_table(eps):
    # a radial shift δr with clearance P_d loads the arc where δr·cos ψ > P_d/2; Harris:
    # ε = (1 − P_d/(2δr))/2 and F_r = Z·Q_max·J_r(ε) (ε > 0.5 needs preload: not modelled)
    clearance = 20e-6 if eps < 0.5 else 0.0
    rs = _set(rollers=720, clearance=clearance, pitch=1.0)
    s = 0.5 * clearance / (1.0 - 2.0 * eps) if eps < 0.5 else 5e-6
    q = roller_loads(rs, s)
    jr = radial_force(rs, s) / (rs.rollers * q.max())
    assert jr == pytest.approx(HARRIS_JR_LINE[eps], rel=0.02)


def test_stribeck_max_roller_load_zero_clearance():
    # Harris & Kotzalas (Stribeck, line contact, zero clearance): Q_max = 4.08·F_r/Z
    rs = _set(rollers=14)
    force = 5000.0
    s = deflection_for_force(rs, force)
    assert radial_force(rs, s) == pytest.approx(force, rel=1e-12)
    assert roller_loads(rs, s).max() == pytest.approx(4.08 * force / 14, rel=0.02)


def test_palmgren_line_contact_deflection():
    # Palmgren: δ = 3.84e-5·Q^0.9/l^0.8 (mm, N) per contact; two contacts per roller
    rs = _set(rollers=14, length=9e-3)
    force = 5000.0
    s = deflection_for_force(rs, force)  # zero clearance: the roller on the line is δ_max = s
    q_max = roller_loads(rs, s).max()
    hand_mm = 2 * 3.84e-5 * q_max**0.9 / 9.0**0.8
    assert s * 1e3 == pytest.approx(hand_mm, rel=1e-12)
    # and the classic zero-clearance estimate with Q_max = 4.08 F/Z within 2 %
    assert s * 1e3 == pytest.approx(2 * 3.84e-5 * (4.08 * force / 14) ** 0.9 / 9.0**0.8, rel=0.02)


def test_clearance_is_free_travel_and_stiffness_is_derivative():
    rs = _set(clearance=12e-6)
    assert radial_force(rs, 6e-6) == 0.0
    assert radial_force(rs, 6.001e-6) > 0.0
    s = np.array([7e-6, 10e-6, 20e-6])
    h = 1e-12
    numeric = (radial_force(rs, s + h) - radial_force(rs, s - h)) / (2 * h)
    np.testing.assert_allclose(radial_stiffness(rs, s), numeric, rtol=1e-6)
    numeric_e = (radial_energy(rs, s + h) - radial_energy(rs, s - h)) / (2 * h)
    np.testing.assert_allclose(numeric_e, radial_force(rs, s), rtol=1e-6)


def test_fc_table_agrees_with_iso_tr_1281_closed_form():
    g, fc = fc_table()
    formula = (
        207.9 * 0.83 * g ** (2 / 9) * (1 - g) ** (29 / 27) * (1 + g) ** (-1 / 4)
        * (1 + (1.04 * ((1 - g) / (1 + g)) ** (143 / 108)) ** 4.5) ** (-2 / 9)
    )  # fmt: skip
    assert np.max(np.abs(formula - fc)) <= 0.055


def test_l10_matches_hand_iso281():
    # Z = 14 needles of 4 × 9 mm on a pitch diameter of 20 mm: D_we/D_pw = 0.20, f_c = 88.7
    rs = RollerSet(14, 4e-3, 9e-3, 0.0, 20e-3)
    c_hand = 1.1 * 88.7 * 9.0 ** (7 / 9) * 14**0.75 * 4.0 ** (29 / 27)
    assert rs.rating() == pytest.approx(c_hand, rel=1e-12)
    loads = np.array([2000.0, 3000.0, 2500.0, 1000.0])
    p_hand = (np.mean(loads ** (10 / 3))) ** 0.3
    assert equivalent_load(loads) == pytest.approx(p_hand, rel=1e-12)
    l10_hand = (c_hand / p_hand) ** (10 / 3)
    hours_hand = l10_hand * 1e6 / (60 * 600.0)
    assert life_hours(rating_life(rs.rating(), equivalent_load(loads)), 600.0) == pytest.approx(
        hours_hand, rel=1e-3
    )
    assert LIFE_EXPONENT == 10 / 3
    # interpolation between table rows is linear (ISO 281)
    between = dynamic_load_rating(14, 4e-3, 9e-3, 4e-3 / 0.105)
    c_mid = 1.1 * 0.5 * (84.2 + 85.4) * 9.0 ** (7 / 9) * 14**0.75 * 4.0 ** (29 / 27)
    assert between == pytest.approx(c_mid, rel=1e-9)
    assert RollerSet(14, 4e-3, 9e-3, 0.0, 20e-3, dynamic_load_rating=30e3).rating() == 30e3


def test_roller_set_refuses_bad_geometry():
    with pytest.raises(DesignError, match="do not fit"):
        RollerSet(20, 4e-3, 9e-3, 0.0, 20e-3)
    with pytest.raises(DesignError, match="radial_clearance"):
        RollerSet(14, 4e-3, 9e-3, -1e-6, 20e-3)
    with pytest.raises(DesignError, match="outside the ISO 281"):
        dynamic_load_rating(14, 4e-3, 9e-3, 8e-3)
