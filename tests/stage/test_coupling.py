"""The compliant disc's coupling compiled (cyclomesh.stage.coupling) against the NumPy
reference (cyclomesh.stage.equilibrium.body_coupling): the same Body, bit for bit."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import cyclomesh.stage.equilibrium as eq
from cyclomesh.core.discbody import DiscBody, FreeDiscBody

pytest.importorskip("numba")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage.toml"


def _body(period: int, seed: int = 0, N: int = 3) -> FreeDiscBody:
    """A free disc of random coefficients: 39 teeth, 9 profile angles, N holes."""
    rng = np.random.default_rng(seed)
    n2, m = 39, 9
    u = np.linspace(-2.8, -0.2, m)
    table = rng.normal(size=(period, n2, m, m)) * 1e-9
    diagonal = rng.normal(size=(period, m)) * 1e-9
    pins = DiscBody(u, table, n2, diagonal=diagonal)
    hole_pin = rng.normal(size=(n2, m, N, 2)) * 1e-9
    hole_hole = rng.normal(size=(N, 2, N, 2)) * 1e-9
    return FreeDiscBody(pins, hole_pin, hole_hole, N)


def _direction(A: int = 7, D: int = 2, n1: int = 40, seed: int = 1, N: int = 3):
    """The arrays body_coupling reads of a direction (mesh, problem, reach, start), random,
    with the edge cases: angles outside the grid and NaN, backlashes inf, arms ≤ 0, a
    crank angle and disc without a candidate."""
    rng = np.random.default_rng(seed)
    angle = rng.uniform(-3.2, 0.1, size=(A, D, n1))
    angle[0, 0, :3] = np.nan
    bl = rng.uniform(-1e-4, 4e-4, size=(A, D, 2 * n1))
    bl[rng.random(bl.shape) < 0.1] = np.inf
    arm = rng.uniform(-5e-3, 60e-3, size=(A, D, 2 * n1))
    bl[1, D - 1, :n1] = np.inf  # no candidate on the last disc at crank angle 1
    tooth = rng.integers(0, 39, size=(A * D * n1,))
    geo = SimpleNamespace(rotation=np.zeros((A, D, n1)), profile_angle=angle.reshape(-1))
    mesh = SimpleNamespace(geo=geo, tooth=tooth)
    ang = rng.uniform(0, 2 * np.pi, size=(A, 1)) + 2 * np.pi * np.arange(N) / N
    prob = SimpleNamespace(
        bl=bl, arm=arm, hx=36e-3 * np.cos(ang), hy=36e-3 * np.sin(ang), scale=36e-3
    )
    reach = rng.uniform(1e-4, 3e-4, size=A)
    start = {
        "pin_force": rng.uniform(0, 100, size=(A, D, 2 * n1)),
        "bearing_fx": rng.normal(size=(A, D, N)) * 1e3,
        "bearing_fy": rng.normal(size=(A, D, N)) * 1e3,
    }
    return mesh, prob, reach, start


def _equal(ref, got):
    (b0, z0), (b1, z1) = ref, got
    for name in ("pin_w", "w", "flank", "hole_w", "energy", "pins"):
        np.testing.assert_array_equal(getattr(b1, name), getattr(b0, name), name)
    np.testing.assert_array_equal(z1, z0)


@pytest.mark.parametrize(("period", "N", "D"), [(1, 3, 2), (13, 3, 2), (39, 2, 1), (13, 3, 3)])
def test_the_compiled_coupling_is_the_references_bit_for_bit(monkeypatch, period, N, D):
    body = _body(period, N=N)
    mesh, prob, reach, start = _direction(D=D, N=N)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    ref = eq.body_coupling(mesh, prob, body, reach, start)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    got = eq.body_coupling(mesh, prob, body, reach, start)
    _equal(ref, got)
    b = got[0]
    for name in ("w", "hole_w", "energy"):  # the compiled Hessian reads them as they are
        assert getattr(b, name).flags.c_contiguous, name
    assert np.all(b.pins[1, D - 1] == -1)  # padding only
    # a padding unknown moves its row's pin by itself (the reference's c0/c0)
    P = b.pins.shape[-1]
    assert b.pin_w[1, D - 1, np.arange(P), np.arange(P)].tolist() == [1.0] * P


def test_the_reference_memo_gives_what_the_compiled_coupling_forms(monkeypatch):
    """A lighter torque's coupling through the reference's memo (the candidates a subset
    of the rated torque's) and the compiled coupling, which keeps no memo: the same."""
    body = _body(13, seed=3)
    mesh, prob, reach, start = _direction(seed=4)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    memo: dict = {}
    eq.body_coupling(mesh, prob, body, reach, start, memo)
    ref = eq.body_coupling(mesh, prob, body, 0.7 * reach, start, memo)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    got = eq.body_coupling(mesh, prob, body, 0.7 * reach, start, {})
    _equal(ref, got)


def test_the_stages_coupling_on_the_examples_fe_disc(monkeypatch, tmp_path):
    """The example's stage with a coarse FE disc at ±412 N·m: every coupling of the solve
    (both directions) compiled and by the reference, the same bits."""
    pytest.importorskip("skfem")
    try:
        import gmsh  # noqa: F401
    except (ImportError, OSError) as exc:  # pragma: no cover
        pytest.skip(f"fe extra not usable here: {exc}")
    from cyclomesh.fe.influence import free_influence
    from cyclomesh.stage.solve import solve
    from cyclomesh.studyfile.schema import load_study

    ex = load_study(EXAMPLE).cases[0].to_core()
    coarse = dict(points=7, far_size=4e-3, flank_size=1.5e-3, elements_per_half_width=2.0)
    body = free_influence(ex.design, ex.modification, ex.crank_holes, tmp_path, **coarse)
    seen = []
    compiled = eq.body_coupling

    def both(mesh, prob, body, reach, start, memo=None):
        got = compiled(mesh, prob, body, reach, start, memo)
        monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
        try:
            ref = compiled(mesh, prob, body, reach, start, None)
        finally:
            monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
        _equal(ref, got)
        seen.append(got[0].pins.shape)
        return got

    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    monkeypatch.setattr(eq, "body_coupling", both)
    phi = np.radians(np.arange(0.0, 360.0, 30.0))
    case = ex.case().replace(torque=np.array([412.0, -412.0]), crank_angles=phi)
    solve(case, ex.model().replace(disc_body=body))
    assert len(seen) == 2 and all(s[0] == phi.size for s in seen)


def test_the_compiled_positions_are_the_references(monkeypatch):
    """_positions (a warm start's pin unknowns, the reference's memo): the same integers."""
    rng = np.random.default_rng(5)
    here = np.stack([rng.permutation(40)[:9] for _ in range(60)]).reshape(30, 2, 9)
    there = np.stack([rng.permutation(40)[:12] for _ in range(60)]).reshape(30, 2, 12)
    here[here > 33] = -1  # padding
    there[there > 35] = -1
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    ref = eq._positions(here, there)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    got = eq._positions(here, there)
    assert 0 < np.sum(ref[0]) < ref[0].size
    for a, b in zip(ref, got, strict=True):
        assert a.dtype == b.dtype and a.shape == b.shape
        np.testing.assert_array_equal(b, a)
