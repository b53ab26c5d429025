"""The compliant stage's supported bearing Jacobian kept between a study's rings
(:class:`cyclomesh.stage.assembly.SupportedJacobians`, handed to
:func:`cyclomesh.stage.solve.solve` as ``keep`` by the tolerance study's ring model): it
is :func:`~cyclomesh.stage.assembly.bearing_jacobian`'s array, formed once for equal
inputs and again for others, and a solve with it gives the same bits as without it.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import cyclomesh.stage.assembly as assembly
from cyclomesh.stage.assembly import Problem, SupportedJacobians, bearing_jacobian
from cyclomesh.stage.supports import Supports


def _problem(A: int = 7, D: int = 2, N: int = 3, seed: int = 0, supports=None) -> Problem:
    rng = np.random.default_rng(seed)
    pins = [rng.random((A, D, 8)) for _ in range(7)]
    ang = rng.random(A)[:, None] + 2 * np.pi * np.arange(N) / N
    hx, hy = 0.036 * np.cos(ang), 0.036 * np.sin(ang)
    ex, ey = (1e-6 * rng.standard_normal((A, D, N)) for _ in range(2))
    return Problem(*pins, hx, hy, ex, ey, 412.0, 0.036, supports)


SUPPORTS = Supports(
    stiffness=np.array([[3e8, -1e8], [-1e8, 3e8]]), fraction=np.array([0.3, 0.6]), carrier=2e5
)


def test_the_kept_jacobian_is_bearing_jacobians_and_formed_once(monkeypatch):
    p = _problem(supports=SUPPORTS)
    m = 1 + 3 * 2 + SUPPORTS.extra(2, 3)
    built = []
    monkeypatch.setattr(
        assembly, "bearing_jacobian", lambda *a: built.append(1) or bearing_jacobian(*a)
    )
    keep = SupportedJacobians()
    first = keep(p, 2, m)
    np.testing.assert_array_equal(first, bearing_jacobian(p, 2, m))
    assert not first.flags.writeable
    # another ring: its own arrays, the same hole centres and supports: the kept array
    again = _problem(supports=SUPPORTS)
    again.ex = again.ex + 1e-6  # (hole errors do not enter the Jacobian)
    assert keep(again, 2, m) is first and len(built) == 1
    # other hole centres, other supports, other unknowns: formed (and the last two kept)
    other = _problem(seed=1, supports=SUPPORTS)
    np.testing.assert_array_equal(keep(other, 2, m), bearing_jacobian(other, 2, m))
    rigid = _problem(supports=Supports(None, SUPPORTS.fraction, None))
    np.testing.assert_array_equal(keep(rigid, 2, 7), bearing_jacobian(rigid, 2, 7))
    assert len(built) == 3
    assert keep(rigid, 2, 7) is not None and len(built) == 3  # kept
    assert keep(p, 2, m) is not first and len(built) == 4  # dropped (two kept), formed again
    # not pickled: a worker's store starts empty
    copy = pickle.loads(pickle.dumps(keep))
    assert copy._kept == [] and len(keep._kept) == 2


def test_a_problem_with_its_body_is_refused():
    p = _problem(supports=SUPPORTS)
    p.body = object()  # (anything: the store takes the problem without its body)
    with pytest.raises(ValueError, match="without its body"):
        SupportedJacobians()(p, 2, 20)


def test_a_compliant_stage_solved_with_the_kept_jacobian_is_the_same(example, request, monkeypatch):
    """Two rings' stages (other hole errors) at ±412 N·m, numba and NumPy: with one store
    for both, every output equal, bit for bit, to the solve without it; the second ring
    forms no supported Jacobian."""
    from tests.stage.fe_cases import require_fe

    require_fe()
    coarse = request.getfixturevalue("coarse")
    from dataclasses import replace

    from cyclomesh.stage.solve import solve

    phi = np.radians(np.arange(0.0, 360.0, 12.0))
    case = example.case().replace(torque=[412.0, -12.36, 12.36], crank_angles=phi)
    model = example.model().replace(disc_body=coarse)
    built = []
    real = assembly.bearing_jacobian

    def counted(*args):
        built.append(1)
        return real(*args)

    for kernel in ("numpy", "numba"):
        if kernel == "numba":
            pytest.importorskip("numba")
        monkeypatch.setenv("CYCLOMESH_KERNEL", kernel)
        keep = SupportedJacobians()
        rings = (
            ([2e-6, -1e-6, 0.5e-6], [-1e-6, 0.0, 1e-6]),
            ([-1e-6, 1.5e-6, 0.0], [0.5e-6, 1e-6, -2e-6]),
        )
        for ring, (radial, tangential) in enumerate(rings):
            stage = replace(
                model.stage,
                hole_error_radial=np.asarray(radial, float),
                hole_error_tangential=np.asarray(tangential, float),
            )
            ring_model = model.replace(stage=stage)
            plain = solve(case, ring_model)
            built.clear()
            monkeypatch.setattr(assembly, "bearing_jacobian", counted)
            kept = solve(case, ring_model, keep=keep)
            monkeypatch.setattr(assembly, "bearing_jacobian", real)
            assert len(built) == (2 if ring == 0 else 0), (kernel, ring)  # two directions
            for name in plain.__dataclass_fields__:
                a, b = getattr(plain, name), getattr(kept, name)
                if isinstance(a, np.ndarray):
                    np.testing.assert_array_equal(a, b, err_msg=f"{kernel} ring {ring}: {name}")


def test_the_ring_model_holds_a_store_with_the_compliant_stage_only(request, tmp_path):
    """``RingModel.stage_keep``: a store with a stage and the compliant disc, None
    otherwise; not a field (the model's fields, equality and ``replace`` are the
    study's); pickled empty (a worker fills its own)."""
    import dataclasses

    from tests.stage.fe_cases import EXAMPLE, require_fe

    require_fe()
    coarse = request.getfixturevalue("coarse")
    from cyclomesh.studies.rings import ring_model
    from cyclomesh.studyfile.schema import load_study

    text = EXAMPLE.read_text()
    path = tmp_path / "tol.toml"
    path.write_text(
        text[: text.index("[[cases]]")]
        + "[tolerance]\nseed = 3\nrings = 2\nallowable_contact_stress_mpa = 1850.0\n"
        + "crank_step_deg = 30.0\n"
        + 'radial_um = { distribution = "uniform", half_range = 2.0 }\n'
    )
    study = load_study(path)
    rigid = ring_model(study, study.tolerance)
    assert rigid.stage is not None and rigid.stage_keep is None
    compliant = dataclasses.replace(rigid, stage_disc_body=coarse)
    keep = compliant.stage_keep
    assert isinstance(keep, SupportedJacobians)
    assert "stage_keep" not in {f.name for f in dataclasses.fields(compliant)}
    keep._kept.append(("anything",))
    again = dataclasses.replace(compliant)
    assert again == compliant and again.stage_keep is not keep and again.stage_keep._kept == []
    copy = pickle.loads(pickle.dumps(compliant))
    assert isinstance(copy.stage_keep, SupportedJacobians) and copy.stage_keep._kept == []
    assert keep._kept  # (the original's left as it is)
    assert dataclasses.replace(rigid, stage=None, stage_disc_body=coarse).stage_keep is None
