"""The loads of the compliant disc's own starts (:func:`cyclomesh.stage.assembly.loads`):
the pins' and the crank bearings' forces of :func:`~cyclomesh.stage.assembly.evaluate`'s
state, bit for bit, without its potential (with and without :class:`Supports`, a
compliant body, a series spring; both kernels)."""

from __future__ import annotations

import numpy as np
import pytest

from cyclomesh.stage.assembly import Body, Problem, evaluate, loads
from cyclomesh.stage.bearing import RollerSet
from cyclomesh.stage.supports import BearingLaw, Supports

SUPPORTS = Supports(
    stiffness=np.array([[3e8, -1e8], [-1e8, 3e8]]), fraction=np.array([0.3, 0.6]), carrier=2e5
)


def _case(supports, body: bool, seed: int = 0):
    """A problem of 9 crank angles, 2 discs, 3 holes, 12 flanks with closed and open pins
    and a state x near contact (the bearings deflected by a few µm)."""
    rng = np.random.default_rng(seed)
    A, D, N, P = 9, 2, 3, 12
    bl = rng.uniform(-2e-5, 2e-5, (A, D, P))
    bl[rng.random((A, D, P)) < 0.2] = np.inf  # pins without a law
    arm = rng.uniform(0.01, 0.06, (A, D, P))
    ang = rng.uniform(0, 2 * np.pi, (A, D, P))
    nx, ny = np.cos(ang), np.sin(ang)
    alpha = rng.uniform(1e-9, 2e-9, (A, D, P))
    gamma = rng.uniform(1e-11, 5e-11, (A, D, P))
    dmax = np.full((A, D, P), 1e-3)
    hang = rng.random(A)[:, None] + 2 * np.pi * np.arange(N) / N
    hx, hy = 0.036 * np.cos(hang), 0.036 * np.sin(hang)
    ex, ey = (2e-6 * rng.standard_normal((A, D, N)) for _ in range(2))
    p = Problem(bl, arm, nx, ny, alpha, gamma, dmax, hx, hy, ex, ey, 412.0, 0.036, supports)
    m = 1 + 3 * D + (0 if supports is None else supports.extra(D, N))
    x = np.zeros((A, m))
    x[:, 0] = rng.uniform(0, 1e-5, A)
    x[:, 1 : 1 + 3 * D : 3] = x[:, [0]] + rng.uniform(-1e-6, 1e-6, (A, D))
    x[:, 2 : 2 + 3 * D : 3] = rng.uniform(-4e-6, 4e-6, (A, D))
    x[:, 3 : 3 + 3 * D : 3] = rng.uniform(-4e-6, 4e-6, (A, D))
    x[:, 1 + 3 * D :] = rng.uniform(-1e-7, 1e-7, (A, m - 1 - 3 * D))
    if body:
        lam = 7
        pin_w = 1e-3 * rng.standard_normal((A, D, 2 * P, lam))  # (the whole: of_dense)
        pin_w = pin_w[:, :, :P]
        hole_w = 1e-3 * rng.standard_normal((A, D, N, 2, lam))
        energy = rng.standard_normal((A, D, lam, lam))
        p.body = Body.of_dense(pin_w, hole_w, energy)
        x = np.concatenate([x, 1e-9 * rng.standard_normal((A, D * lam))], axis=-1)
    return p, x


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
@pytest.mark.parametrize("supports", [SUPPORTS, Supports(None, SUPPORTS.fraction, None), None])
@pytest.mark.parametrize("body", [False, True])
@pytest.mark.parametrize("spring", [None, 4e8])
def test_the_loads_are_evaluates(kernel, supports, body, spring, monkeypatch):
    if kernel == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", kernel)
    law = BearingLaw(RollerSet(14, 4e-3, 9e-3, 5e-6, 22e-3), spring)
    for seed in range(3):
        p, x = _case(supports, body, seed)
        st = evaluate(p, law, x, 2, False, gradient=False)[3]
        got = loads(p, law, x, 2)
        assert set(got) == {"pin_force", "bearing_fx", "bearing_fy"}
        assert np.any(got["pin_force"] > 0) and np.any(got["bearing_fx"] != 0)
        for name, value in got.items():
            np.testing.assert_array_equal(value, st[name], err_msg=name)
