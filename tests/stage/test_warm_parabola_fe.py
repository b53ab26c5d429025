"""The compliant kernel's warm start chosen by the crank angles before (task i46a,
stage.kernel_compliant._WARM) on the example's stage with the coarse FE disc, pin and
crank-hole errors: the same root as with the line through two (``_WARM`` False, the
kernel before), at the rated torque and a light one, on fewer evaluations; K's iteration
(``_ACTIVE`` 0) keeps the line, so it is the same bit for bit with or without."""

from __future__ import annotations

import pytest

pytest.importorskip("numba")
from tests.stage.fe_cases import require_fe

require_fe()

from tests.stage.test_active_rows import _close_all, _equal_all, solve_counted  # noqa: E402


def _run(example, coarse, monkeypatch, chosen, active=1):
    """The numba path's results at both torques and the kernel's evaluations summed."""
    out, sums = solve_counted(
        example, coarse, monkeypatch, lambda st: st["counts"][:, 0].sum(), _WARM=chosen,
        _ACTIVE=active,
    )  # fmt: skip
    return out, int(sum(sums))


def test_the_chosen_start_finds_the_lines_root(example, coarse, monkeypatch):
    """Every output within 1e-13 of its largest of the line's (as test_active_rows
    compares), in fewer evaluations."""
    line, n_line = _run(example, coarse, monkeypatch, False)
    bend, n_bend = _run(example, coarse, monkeypatch, True)
    for ref, res in zip(line, bend, strict=True):
        _close_all(ref, res)
    assert n_bend < n_line


def test_ks_iteration_keeps_the_line(example, coarse, monkeypatch):
    """``_ACTIVE`` 0 (every crank angle on K): no chosen start, bit for bit."""
    line, n_line = _run(example, coarse, monkeypatch, False, active=0)
    bend, n_bend = _run(example, coarse, monkeypatch, True, active=0)
    assert n_bend == n_line
    for ref, res in zip(line, bend, strict=True):
        _equal_all(ref, res)
