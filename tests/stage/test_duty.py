"""Duty-cycle life (ISO 281 variable load) and the output ripple by orders."""

import numpy as np
import pytest

from cyclomesh.exceptions import DesignError
from cyclomesh.results.datasheet import order_spectrum, top_orders
from cyclomesh.stage.bearing import LIFE_EXPONENT, life_hours, rating_life
from cyclomesh.stage.duty import DutyCycle, cycle_life


def test_equivalent_torque_and_speed_by_hand():
    cycle = DutyCycle((400.0, -100.0), (10.0, 20.0), (1.0, 3.0))
    rev = np.array([10.0, 60.0])
    p = 10 / 3
    t_eq = ((rev[0] * 400**p + rev[1] * 100**p) / rev.sum()) ** (1 / p)
    assert cycle.equivalent() == pytest.approx((t_eq, 70.0 / 4.0), rel=1e-14)


def test_one_step_cycle_is_the_rated_point_and_steps_weigh_by_revolutions():
    rng = np.random.default_rng(3)
    loads = 2000 + 500 * rng.random((36, 2, 3))
    C, pins = 17.3e3, 40
    one = DutyCycle((300.0,), (12.0,), (1.0,))
    p_eq, hours = cycle_life(one, [loads], C, pins)
    p_ref = np.mean(loads**LIFE_EXPONENT, axis=0) ** (1 / LIFE_EXPONENT)
    assert np.allclose(p_eq, p_ref, rtol=1e-14)
    assert np.allclose(hours, life_hours(rating_life(C, p_ref), pins * 12.0), rtol=1e-13)
    # Palmgren-Miner: damage per hour adds up by the time shares
    two = DutyCycle((300.0, 100.0), (12.0, 6.0), (0.5, 0.5))
    _, h2 = cycle_life(two, [loads, 0.5 * loads], C, pins)
    h_a = life_hours(rating_life(C, p_ref), pins * 12.0)
    h_b = life_hours(rating_life(C, 0.5 * p_ref), pins * 6.0)
    assert np.allclose(1 / h2, 0.5 / h_a + 0.5 / h_b, rtol=1e-12)


def test_bad_cycles_are_refused():
    with pytest.raises(DesignError, match="same number"):
        DutyCycle((1.0, 2.0), (1.0,), (1.0, 1.0))
    with pytest.raises(DesignError, match="time_share"):
        DutyCycle((1.0,), (1.0,), (0.0,))


def test_order_spectrum_recovers_a_sum_of_orders():
    phi = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    signal = 5.0 + 2.0 * np.sin(3 * phi + 0.4) + 0.5 * np.cos(40 * phi)
    amp = order_spectrum(signal)
    assert amp[0] == pytest.approx(5.0)
    assert amp[3] == pytest.approx(2.0)
    assert amp[40] == pytest.approx(0.5)
    assert np.max(np.delete(amp, [0, 3, 40])) < 1e-12
    assert top_orders(amp, 2, 39) == [[3, 117, pytest.approx(2.0)], [40, 1560, pytest.approx(0.5)]]
