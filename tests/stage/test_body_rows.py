"""stage.assembly.Body's compact pin rows (``w``, ``flank``): the whole ``pin_w`` formed
from them, a taken and a near problem's, and the compiled evaluation and Newton
(stage.kernel_compliant) on the compact rows against the same body given whole: the
same numbers, bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cyclomesh.stage.assembly import Body


def _compact(seed: int = 0, A: int = 5, D: int = 2, n1: int = 9, P: int = 4, lam: int = 7):
    """A random Body with compact rows and the whole pin_w the reference forms
    (equilibrium.body_coupling's put_along_axis)."""
    rng = np.random.default_rng(seed)
    order = np.argsort(rng.random((A, D, 2 * n1)), axis=-1)[..., :P]
    w = rng.standard_normal((A, D, P, lam))
    w[0, 0, 1] = 0.0  # a row of zeros
    dense = np.zeros((A, D, 2 * n1, lam))
    np.put_along_axis(dense, order[..., None], w, axis=2)
    body = Body(
        w,
        rng.standard_normal((A, D, 3, 2, lam)),
        rng.standard_normal((A, D, lam, lam)),
        np.where(rng.random((A, D, P)) < 0.8, order, -1),
        np.ascontiguousarray(order),
        2 * n1,
    )
    return body, dense


def test_the_whole_pin_w_is_the_references():
    body, dense = _compact()
    np.testing.assert_array_equal(body.pin_w, dense)
    idx = np.array([1, 3, 4])
    taken = body[idx]
    np.testing.assert_array_equal(taken.pin_w, dense[idx])
    np.testing.assert_array_equal(taken.pins, body.pins[idx])


def test_a_near_problems_rows_are_the_taken_whole_rows():
    """Body.near(order): pin_w as np.take_along_axis of the whole one (equilibrium._near),
    rows whose flank is not among ``order`` dropped."""
    body, dense = _compact(seed=2)
    rng = np.random.default_rng(5)
    A, D, F = dense.shape[:3]
    for count in (1, 6, F):
        order = np.argsort(rng.random((A, D, F)), axis=-1)[..., :count]
        near = body.near(order)
        np.testing.assert_array_equal(
            near.pin_w, np.take_along_axis(dense, order[..., None], axis=2)
        )
        np.testing.assert_array_equal(near.w, body.w)


def test_of_dense_keeps_every_flank():
    _, dense = _compact(seed=3)
    A, D, F, lam = dense.shape
    body = Body.of_dense(dense, np.zeros((A, D, 3, 2, lam)), np.zeros((A, D, lam, lam)))
    np.testing.assert_array_equal(body.pin_w, dense)
    assert body.flanks == F and body.flank.shape == (A, D, F)


def test_the_compiled_newton_reads_the_compact_rows_as_the_whole(monkeypatch, tmp_path):
    """The compiled evaluation and Newton (stage.kernel_compliant) of the example's
    compliant problems (coarse FE disc, 412 N·m) on the coupling's compact rows and on the
    same body with every flank a row (Body.of_dense): bit for bit."""
    pytest.importorskip("numba")
    try:  # the fe extra
        import gmsh  # noqa: F401
        import skfem  # noqa: F401
    except (ImportError, OSError) as exc:  # pragma: no cover
        pytest.skip(f"fe extra not usable here: {exc}")
    import cyclomesh.stage.equilibrium as eq
    import cyclomesh.stage.newton as nt
    from cyclomesh.fe.influence import free_influence
    from cyclomesh.stage import kernel_compliant as kc
    from cyclomesh.stage.solve import solve
    from cyclomesh.studyfile.schema import load_study

    example = Path(__file__).resolve().parents[2] / "examples" / "rv_stage.toml"
    ex = load_study(example).cases[0].to_core()
    coarse = dict(points=7, far_size=4e-3, flank_size=1.5e-3, elements_per_half_width=2.0)
    body = free_influence(ex.design, ex.modification, ex.crank_holes, tmp_path, **coarse)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    found = []
    compiled = eq._body_kernel

    def kept(p, law, x, discs, phi, state=None, start=None):
        first = x.copy() if start is None else start(np.arange(p.bl.shape[0]))
        found.append((p, law, first, discs))
        return compiled(p, law, x, discs, phi, state, start)

    monkeypatch.setattr(eq, "_body_kernel", kept)
    case = ex.case().replace(torque=412.0, crank_angles=np.radians(np.arange(0.0, 360.0, 30)))
    solve(case, ex.model().replace(disc_body=body))
    assert found
    settings = nt.kernel_settings(10**6, compliant=True)
    for p, law, start, D in found:
        b = p.body
        assert b.w.shape[2] < b.flanks  # compact: fewer rows than flanks
        whole = Body.of_dense(b.pin_w, b.hole_w, b.energy, b.pins)
        dense = eq.dataclasses.replace(p, body=whole)
        got = kc.evaluate(p, law, start, D)
        ref = kc.evaluate(dense, law, start, D)
        for a, r in zip(got, ref, strict=True):
            np.testing.assert_array_equal(a, r)
        x1, x2 = start.copy(), start.copy()
        s1, s2 = {}, {}
        f1 = kc.newton(p, law, x1, D, p.jacobian, settings, state=s1)
        f2 = kc.newton(dense, law, x2, D, p.jacobian, settings, state=s2)
        np.testing.assert_array_equal(f1, f2)
        np.testing.assert_array_equal(x1, x2)
        assert s1.keys() == s2.keys()
        for key in s1:
            np.testing.assert_array_equal(s1[key], s2[key])
