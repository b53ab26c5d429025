"""The compliant kernel's warm start chosen by the crank angles before (task i46a,
stage.kernel_compliant._WARM), its pieces against their definitions: _bend_py (the
parabola through three solutions, each pin unknown carried by its pin, the line or the
solution before where a pin was no candidate), _smooth_py (the same loaded pins and crank
bearings at the three crank angles before, none at the edge) and _still_py (the solution
before where it predicted the crank angle before better than the line). The compiled
solve with it: test_warm_parabola_fe.py."""

from __future__ import annotations

import numpy as np
import pytest

from cyclomesh.stage import kernel_compliant as kc

D, P, LAM, Z0 = 2, 4, 6, 5  # discs, candidate pins, body unknowns a disc (2 holes'), others


def _layout(rng, rows):
    """``rows`` crank angles' unknowns (A, Z0 + D·LAM) and candidate pins (A, D, P),
    every crank angle's pins the same, in the same order."""
    x = rng.standard_normal((rows, Z0 + D * LAM))
    pins = np.tile(np.array([[3, 4, 5, -1], [10, 11, 12, 13]]), (rows, 1, 1))
    return x, pins


def _carried(x, pins, i, back):
    """The solution at i − back with each pin unknown carried by its pin (_carry_py; an
    own start of 0: a pin that was no candidate there, and padding, 0)."""
    out = np.zeros(x.shape[1])
    kc._carry_py(out, x, np.zeros(x.shape[1]), pins, i, back, Z0, LAM)
    return out


def test_the_parabola_of_a_quadratic_run_is_exact():
    """Unknowns quadratic in the crank angle: the parabola through three gives the
    fourth (to round-off), the holes' unknowns and the others too (padding: 0)."""
    rng = np.random.default_rng(1)
    x, pins = _layout(rng, 4)
    a, b, c = (rng.standard_normal(x.shape[1]) for _ in range(3))
    for i in range(4):
        x[i] = a + b * i + c * i * i
    out = np.zeros(x.shape[1])
    kc._bend_py(out, x, _carried(x, pins, 3, 1), pins, 3, Z0, LAM)
    expect = a + 3 * b + 9 * c
    expect[Z0 + 3] = 0.0  # disc 0's padding candidate
    np.testing.assert_allclose(out, expect, rtol=0, atol=1e-12 * np.abs(expect).max())


def test_each_pin_unknown_is_carried_by_its_pin():
    """Candidates in another order at each crank angle: each pin's unknown from its own
    columns at i − 1, i − 2, i − 3 (3·z₋₁ − 3·z₋₂ + z₋₃)."""
    rng = np.random.default_rng(2)
    x, pins = _layout(rng, 4)
    pins[1, 1] = [11, 12, 13, 10]
    pins[2, 1] = [13, 10, 11, 12]
    out = np.zeros(x.shape[1])
    kc._bend_py(out, x, _carried(x, pins, 3, 1), pins, 3, Z0, LAM)
    z = Z0 + LAM  # disc 1's pin unknowns
    for q, pin in enumerate(pins[3, 1]):
        col = [z + int(np.flatnonzero(pins[i, 1] == pin)[0]) for i in range(3)]
        want = 3.0 * (x[2, col[2]] - x[1, col[1]]) + x[0, col[0]]
        assert out[z + q] == want


def test_a_pin_new_at_a_crank_angle_before_takes_the_line_or_the_last():
    """A pin that was no candidate at i − 3: the line through i − 2 and i − 1; none at
    i − 2: the solution before (``prev``, _carry's start); padding (−1) too."""
    rng = np.random.default_rng(3)
    x, pins = _layout(rng, 4)
    pins[0, 0] = [3, 4, 7, -1]  # pin 5 no candidate at i − 3
    pins[1, 0] = [3, 8, 5, -1]  # pin 4 no candidate at i − 2
    prev = _carried(x, pins, 3, 1)
    out = np.zeros(x.shape[1])
    kc._bend_py(out, x, prev, pins, 3, Z0, LAM)
    assert out[Z0 + 2] == 2.0 * prev[Z0 + 2] - x[1, Z0 + 2]  # pin 5: the line
    assert out[Z0 + 1] == prev[Z0 + 1]  # pin 4: the solution before
    assert out[Z0 + 0] == 3.0 * (x[2, Z0] - x[1, Z0]) + x[0, Z0]  # pin 3: the parabola
    assert out[Z0 + 3] == prev[Z0 + 3] == 0.0  # padding


def _states(rows=4):
    """Pins' forces pf (2, A, D, P') and bearings' (A, D, 3, 3), every contact loaded."""
    pf = np.ones((2, rows, D, 20))
    bf = np.ones((rows, D, 3, 3))
    return pf, bf


@pytest.mark.parametrize("back", [1, 2, 3])
def test_smooth_runs_keep_their_loaded_contacts(back):
    """_smooth_py: True where the three crank angles before had the same loaded pins
    and crank bearings; a pin's load set on or off, or a bearing's, at any of them: False.
    The crank angle itself and those further back do not count."""
    pf, bf = _states(6)
    i = 5
    assert kc._smooth_py(pf, bf, i)
    pf[0, i, 1, 7] = 0.0
    pf[0, i - 4, 0, 2] = 0.0
    bf[i - 4, 0, 1, :2] = 0.0
    assert kc._smooth_py(pf, bf, i)
    p2, b2 = pf.copy(), bf.copy()
    p2[0, i - back, 1, 7] = 0.0  # a pin unloaded at one of the three
    assert not kc._smooth_py(p2, bf, i)
    b2[i - back, 1, 2, :2] = 0.0  # a crank bearing unloaded at one of them
    assert not kc._smooth_py(pf, b2, i)
    b2 = bf.copy()
    b2[i - back, 1, 2, 0] = 0.0  # one component 0: still loaded
    assert kc._smooth_py(pf, b2, i)


def test_the_solution_before_is_kept_where_it_predicted_better():
    """_still_py: True where x₋₂ was nearer x₋₁ than the line 2·x₋₂ − x₋₃ (the unknowns
    before the body's, rotations times L); a jump back (the disc in its bearings' play)
    makes the line overshoot; a steady drift favours the line. The body's unknowns do not
    count."""
    rot = np.zeros(Z0 + D * LAM, np.bool_)
    rot[0] = True
    x = np.zeros((4, Z0 + D * LAM))
    x[:, 1] = [0.0, 1.0, 2.0, 0.0]  # a drift: the line predicts x₋₁ exactly
    assert not kc._still_py(x, 3, Z0, rot, 1.0)
    x[:, 1] = [0.0, 1.0, 0.9, 0.0]  # x₋₂ → x₋₁ jumps back: the solution before nearer
    assert kc._still_py(x, 3, Z0, rot, 1.0)
    x[:, 1] = [0.0, 1.0, 2.0, 0.0]
    x[:, 0] = [0.0, 1e-3, 0.9e-3, 0.0]  # a rotation jumping back, weighed by L
    assert not kc._still_py(x, 3, Z0, rot, 1.0)
    assert kc._still_py(x, 3, Z0, rot, 1e4)
    x[:, 0] = 0.0
    x[:, Z0:] = [[0.0], [1.0], [0.0], [0.0]]  # the body's unknowns: not looked at
    assert not kc._still_py(x, 3, Z0, rot, 1.0)


def test_a_contact_at_the_edge_breaks_the_stretch():
    """_smooth_py: a pin or crank bearing loaded at all three crank angles but at one of
    them with at most _EDGE of the largest load of its kind: no smooth stretch."""
    pf, bf = _states(6)
    i = 5
    p2 = pf.copy()
    p2[0, i - 2, 0, 3] = 0.5 * kc._EDGE
    assert not kc._smooth_py(p2, bf, i)
    p2[0, i - 2, 0, 3] = 2.0 * kc._EDGE
    assert kc._smooth_py(p2, bf, i)
    b2 = bf.copy()
    b2[i - 3, 1, 0, :2] = 0.5 * kc._EDGE / np.sqrt(2.0)
    assert not kc._smooth_py(pf, b2, i)
