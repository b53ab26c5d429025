"""The compliant kernel's stretched step after one residual ratio in the active set's
iteration (task i47a, stage.kernel_compliant._ONCE) on the example's stage with the coarse
FE disc, pin and crank-hole errors: the same root as with the stretch after two ratios
(``_ONCE`` False, the kernel before), at the rated torque and a light one, on another
path at the light torque (a crank bearing's roller tail); K's iteration (``_ACTIVE``
0) keeps two, so it is the same bit for bit with or without."""

from __future__ import annotations

import pytest

pytest.importorskip("numba")
from tests.stage.fe_cases import require_fe

require_fe()

from tests.stage.test_active_rows import _close_all, _equal_all, solve_counted  # noqa: E402


def _run(example, coarse, monkeypatch, once, active=1):
    """The numba path's results at both torques and the kernel's Hessians a torque."""
    out, sums = solve_counted(
        example, coarse, monkeypatch, lambda st: st["counts"][:, 3].sum(), _ONCE=once,
        _ACTIVE=active,
    )  # fmt: skip
    return out, [int(n) for n in sums]


def test_one_ratio_finds_the_same_root(example, coarse, monkeypatch):
    """Every output within 1e-13 of its largest of the stretch after two ratios (as
    test_active_rows compares); the light torque's iteration another (the stretch taken:
    on this coarse case 960 Hessians against 954, on a stage tolerance ring's −10 %)."""
    two, n_two = _run(example, coarse, monkeypatch, False)
    one, n_one = _run(example, coarse, monkeypatch, True)
    for ref, res in zip(two, one, strict=True):
        _close_all(ref, res)
    assert n_one[1] != n_two[1]


def test_ks_iteration_keeps_two(example, coarse, monkeypatch):
    """``_ACTIVE`` 0 (every crank angle on K): the stretch after two ratios, bit for bit."""
    two, n_two = _run(example, coarse, monkeypatch, False, active=0)
    one, n_one = _run(example, coarse, monkeypatch, True, active=0)
    assert n_one == n_two
    for ref, res in zip(two, one, strict=True):
        _equal_all(ref, res)
