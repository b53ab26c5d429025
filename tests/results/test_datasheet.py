"""The catalogue definitions, the compliance budget and measured loops read back."""

import numpy as np
import pytest

from cyclomesh.exceptions import DesignError
from cyclomesh.results.datasheet import compliance_share, loop_metrics, reconcile

ARCMIN = np.radians(1 / 60)


def _loop(rigidity, width, play, rated, cycles=2, points=400, smooth=0.005):
    """A loop from a known rigidity [N·m/rad], friction width at zero torque [rad] and
    play [rad]: mid-curve T/K + play/2·tanh(T/(smooth·T_r)), branches ± the width
    shrinking to 0 at the tips as 1 − (T/T_r)²."""
    s = np.linspace(0.0, 1.0, points, endpoint=False)
    path = np.concatenate([s, 1 - s, -s, -1 + s] * cycles + [[0.0]]) * rated
    dT = np.diff(path, prepend=path[0] - 1e-9 * rated)
    rising = np.sign(dT)
    mid = path / rigidity + 0.5 * play * np.tanh(path / (smooth * rated))
    half = 0.5 * width * (1.0 - (path / rated) ** 2)
    return path, mid - rising * half


def test_loop_read_back_within_one_percent():
    K, width, play, rated = 108.0 / ARCMIN, 0.4 * ARCMIN, 0.6 * ARCMIN, 412.0
    torque, twist = _loop(K, width, play, rated)
    got = loop_metrics(torque, twist, rated)
    lost = 0.06 * rated / K + play * np.tanh(0.03 / 0.005)
    assert got.torsional_rigidity == pytest.approx(K, rel=0.01)
    assert got.lost_motion == pytest.approx(lost, rel=0.01)
    assert got.backlash == pytest.approx(width, rel=0.01)
    # the reconciling series compliance takes a stiffer model to the measurement
    rec = reconcile(got, 2 * K, 0.0)
    assert 1 / (1 / (2 * K) + rec["compliance"]) == pytest.approx(got.torsional_rigidity)
    assert rec["stiffness"] > 0


def test_loop_must_reach_the_rated_torque():
    torque, twist = _loop(1e6, 1e-5, 0.0, 100.0)
    with pytest.raises(DesignError, match="rated torque"):
        loop_metrics(0.5 * torque, twist, 100.0)


def test_shares_need_a_turning_output():
    with pytest.raises(DesignError):
        compliance_share({"mesh": np.zeros(3)}, 1.0, np.zeros(3))
