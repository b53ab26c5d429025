"""Duty-cycle life (ISO 281 variable load) and the output ripple by orders."""

from pathlib import Path

import numpy as np
import pytest

from cyclomesh.exceptions import DesignError
from cyclomesh.results.datasheet import order_spectrum, top_orders
from cyclomesh.stage.bearing import LIFE_EXPONENT, life_hours, rating_life
from cyclomesh.stage.duty import DutyCycle, cycle_life

EXAMPLES = Path(__file__).parents[2] / "examples"


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


def _study_with_cycle(tmp_path, steps: str, csv: str | None = None):
    from cyclomesh.studyfile import load_study

    text = (EXAMPLES / "rv_stage.toml").read_text()
    start = text.index("[stage.duty_cycle]")
    end = text.index("\n[", start) + 1
    (tmp_path / "s.toml").write_text(
        text[:start] + "[stage.duty_cycle]\n" + steps + "\n" + text[end:]
    )
    if csv is not None:
        (tmp_path / "duty.csv").write_text(csv)
    return load_study(tmp_path / "s.toml")


def test_a_duty_cycle_from_a_csv_file_is_the_same_cycle(tmp_path):
    lists = _study_with_cycle(
        tmp_path,
        "torque_nm = [412.0, -150.0]\noutput_speed_rpm = [10.0, 15.0]\ntime_share = [0.2, 0.8]",
    )
    csv = "# steps\ntorque_nm,output_speed_rpm,time_share\n412,10,0.2\n-150.0,15,0.8\n"
    sub = tmp_path / "sub"
    sub.mkdir()
    filed = _study_with_cycle(sub, 'file = "duty.csv"', csv)
    a, b = (s.inputs[0].stage.duty_cycle for s in (lists, filed))
    assert a == b == DutyCycle((412.0, -150.0), (10.0, 15.0), (0.2, 0.8))


@pytest.mark.parametrize(
    ("steps", "csv", "match"),
    [
        ('file = "duty.csv"', "torque_nm,output_speed_rpm,time_share\n1,10,-1\n", "time_share"),
        ('file = "duty.csv"', "torque_nm,speed_rpm,time_share\n1,10,1\n", "columns must be"),
        ('file = "duty.csv"', "torque_nm,output_speed_rpm,time_share\n", "at least one step"),
        ('file = "duty.csv"', "torque_nm,output_speed_rpm,time_share\n1_0,10,1\n", "line 2"),
        ('file = "missing.csv"', None, "not found"),
        ('file = "duty.csv"\ntorque_nm = [1.0]', "", "not both"),
        ("torque_nm = [1.0]", None, "or file"),
    ],
)
def test_a_bad_duty_cycle_file_is_refused_in_one_line(tmp_path, steps, csv, match):
    from cyclomesh.exceptions import StudyError

    with pytest.raises(StudyError, match=match) as info:
        _ = _study_with_cycle(tmp_path, steps, csv).inputs
    assert "\n" not in str(info.value) and "stage.duty_cycle" in str(info.value)
