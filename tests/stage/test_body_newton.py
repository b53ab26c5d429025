"""The compliant disc's Newton (stage.equilibrium._body_newton): the potential's Newton
(stage.newton.newton) with a ``failed`` array hands only the crank angles it cannot
finish (the descent runs away along the body unknowns' saddle) to the residual Newton
(_stationary); the others keep its arithmetic (coarse FE disc)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

try:  # the fe extra; gmsh's wheel also needs X11/OpenGL client libraries (see .ci/run)
    import gmsh  # noqa: F401
    import skfem  # noqa: F401
except (ImportError, OSError) as exc:  # pragma: no cover
    pytest.skip(f"fe extra not usable here: {exc}", allow_module_level=True)

import cyclomesh.stage.equilibrium as eq
import cyclomesh.stage.newton as nt
from cyclomesh.fe.influence import free_influence
from cyclomesh.stage.solve import solve
from cyclomesh.studyfile.schema import load_study

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage.toml"
COARSE = dict(points=7, far_size=4e-3, flank_size=1.5e-3, elements_per_half_width=2.0)
PHI = np.radians(np.arange(0.0, 360.0, 15.0))
FIELDS = ("twist", "bearing_load", "pin_load", "torque_share")


@pytest.fixture(scope="module")
def example():
    return load_study(EXAMPLE).cases[0].to_core()


@pytest.fixture(scope="module")
def body(example, tmp_path_factory):
    folder = tmp_path_factory.mktemp("cache")
    ex = example
    return free_influence(ex.design, ex.modification, ex.crank_holes, folder, **COARSE)


def _solve(example, body, torque=(-412.0, 412.0)):
    case = example.case().replace(torque=list(torque), crank_angles=PHI)
    return solve(case, example.model().replace(disc_body=body))


def _count(monkeypatch):
    """Crank angles handed to _stationary, counted."""
    handed = []
    stationary = eq._stationary

    def counted(p, evaluate, law, x, discs, phi):
        handed.append(x.shape[0])
        return stationary(p, evaluate, law, x, discs, phi)

    monkeypatch.setattr(eq, "_stationary", counted)
    return handed


def test_failed_newton_keeps_the_arithmetic_where_every_angle_converges(example, body, monkeypatch):
    """Where Newton finishes every crank angle, the ``failed`` array changes no bit."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    handed = _count(monkeypatch)
    ref = _solve(example, body)
    assert sum(handed) == 0
    plain = nt.newton

    def without(p, evaluate, law, x, discs, rigid, phi, failed=None):
        return plain(p, evaluate, law, x, discs, rigid, phi)

    monkeypatch.setattr(eq, "newton", without)
    got = _solve(example, body)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), name)


def test_angles_handed_to_the_residual_newton_reach_the_same_root(example, body, monkeypatch):
    """Every crank angle given up (here: a stall declared after 0 steps) is solved by the
    residual Newton from its start, to the same root: 1e-12 of each field's largest value
    (that Newton stops at 1e-12·T/r_c, not at round-off)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    ref = _solve(example, body)
    handed = _count(monkeypatch)
    monkeypatch.setattr(nt, "_STALL_ITERATIONS", 0)
    got = _solve(example, body)
    assert sum(handed) > 0
    for name in FIELDS:
        a, b = getattr(ref, name), getattr(got, name)
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a)), name


def test_newton_with_failed_flags_instead_of_raising():
    """A crank angle that cannot converge is flagged, not raised, and left at its last
    iterate; without ``failed`` the same raises ConvergenceError."""
    from types import SimpleNamespace

    from cyclomesh.exceptions import ConvergenceError

    class Problem(SimpleNamespace):
        def take(self, idx):
            return self

    def evaluate(sub, law, x, discs, rigid, hessian=True, gradient=True):
        # a saddle: Π = −x₀² (no minimum), gradient −2x₀, Hessian −2
        n, m = x.shape
        g = np.zeros((n, m))
        g[:, 0] = -2.0 * x[:, 0]
        H = np.zeros((n, m, m))
        H[:, 0, 0] = -2.0
        for i in range(1, m):
            H[:, i, i] = 1.0
        return -(x[:, 0] ** 2), g, H, {"bad": np.zeros(n, bool)}

    p = Problem(torque=1.0, scale=1.0, supports=None, body=None)
    x = np.full((2, 4), 1e-3)
    with pytest.raises(ConvergenceError):
        nt.newton(p, evaluate, None, x.copy(), 1, False, np.zeros(2))
    failed = np.zeros(2, bool)
    out = nt.newton(p, evaluate, None, x.copy(), 1, False, np.zeros(2), failed)
    assert failed.all() and np.all(np.isfinite(out))
