"""The compliant disc's own starts (equilibrium._body_starts' ``own``) reuse what the
solve has formed: the problem taken at the crank angles asked for once (for the bearing
start and for the loads there) and the rotation bound of every crank angle (the lazy
compliant solve forms it for the coupling's reach) instead of forming each again for the
rows asked for. Both give the same bits: ``solve_direction``'s ``start`` with the taken
problem as without it, and the compiled single-pin bound of any rows the rows of the
whole's.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from cyclomesh.stage.kernel import single_rotation  # noqa: E402


def test_the_rotation_bound_is_row_by_row():
    """single_rotation of some crank angles is the whole's at them, bit for bit (pins
    without a law, with a negative arm, and crank angles no pin can carry included)."""
    rng = np.random.default_rng(46)
    A, D, P, n1 = 40, 2, 16, 8
    bl = rng.uniform(-1e-3, 1e-3, (A, D, P))
    bl[rng.random((A, D, P)) < 0.2] = np.inf
    arm = rng.uniform(-0.02, 0.06, (A, D, P))
    alpha = rng.uniform(1e-9, 3e-9, (A, D, P))
    gamma = rng.uniform(1e-11, 1e-10, (A, D, P))
    bl[7] = np.inf  # a crank angle no pin can carry: inf
    whole = single_rotation(bl, arm, alpha, gamma, 412.0, n1)
    assert np.isinf(whole[7]) and np.all(np.isfinite(np.delete(whole, 7)))
    for idx in (np.array([3]), np.array([0, 7, 8, 9, 31]), np.arange(1, A, 3)):
        part = single_rotation(*(np.ascontiguousarray(v[idx]) for v in (bl, arm, alpha, gamma)),
                               412.0, n1)  # fmt: skip
        np.testing.assert_array_equal(part, whole[idx])


def test_the_start_of_a_taken_problem_is_the_same(example, request, monkeypatch):
    """Every start the compiled Newton asks for (±412 N·m, numba) is the same, bit for
    bit, given the problem taken at its crank angles (the own starts' call) or not; and
    the solve asks for some."""
    from tests.stage.fe_cases import require_fe

    require_fe()  # (before the coarse disc's FE)
    coarse = request.getfixturevalue("coarse")
    import cyclomesh.stage.equilibrium as eq
    from cyclomesh.stage.solve import solve

    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    checked: list[int] = []
    body_starts = eq._body_starts

    def wrapped(mesh, prob, body, reach, law, start, memo=None):
        def compared(idx, taken=None):
            got = start(idx, taken)
            np.testing.assert_array_equal(got, start(idx))
            np.testing.assert_array_equal(got, start(idx, prob.take(idx)))
            checked.append(idx.size)
            return got

        return body_starts(mesh, prob, body, reach, law, compared, memo)

    monkeypatch.setattr(eq, "_body_starts", wrapped)
    phi = np.radians(np.arange(0.0, 360.0, 4.0))
    case = example.case().replace(torque=[-412.0, 412.0], crank_angles=phi)
    solve(case, example.model().replace(disc_body=coarse))
    assert checked and sum(checked) >= 2
