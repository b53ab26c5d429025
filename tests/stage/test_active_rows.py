"""The compliant disc's active set inside the compiled Newton (task i45e,
stage.kernel_compliant._newton_rows' ``active``): each warm crank angle iterated on the
body's pin unknowns of the pins loaded at the crank angle before (and their neighbours)
plus the holes', checked (every pin left out carries no load at the reduced root), grown
by those that do. The same root as on every candidate's unknowns (``_ACTIVE`` 0) and as
the NumPy path's, with pin and crank-hole errors, at the rated torque and a light one;
from an empty set (``_ACTIVE`` 2) every loaded pin comes in by the check.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("numba")
from tests.stage.fe_cases import require_fe

require_fe()

import cyclomesh.stage.equilibrium as eq  # noqa: E402
from cyclomesh.core.pair import PinErrors  # noqa: E402
from cyclomesh.stage import kernel_compliant as kc  # noqa: E402
from cyclomesh.stage.solve import solve  # noqa: E402

PHI = np.radians(np.arange(0.0, 360.0, 3.0))
TORQUES = ([-412.0, 412.0], [-12.36, 12.36])


def _solve(example, body, torque):
    """The example's stage with the coarse disc, a ring's pin errors and crank-hole errors
    (benchmarks/bench_stage.py's tolerance study's sizes)."""
    case = example.case().replace(torque=torque, crank_angles=PHI)
    model = example.model().replace(disc_body=body)
    rng = np.random.default_rng(7)
    n1 = example.design.pins
    pins = PinErrors(radial=rng.uniform(-2e-6, 2e-6, n1), angular=rng.uniform(-2e-5, 2e-5, n1))
    stage = dataclasses.replace(
        model.stage,
        hole_error_radial=np.array([3e-6, -2e-6, 1e-6]),
        hole_error_tangential=np.array([-2e-6, 2e-6, 0.0]),
    )
    return solve(case.replace(errors=pins), model.replace(stage=stage))


def _arrays(result) -> dict[str, np.ndarray]:
    return {
        f.name: getattr(result, f.name)
        for f in dataclasses.fields(result)
        if isinstance(getattr(result, f.name), np.ndarray) and f.name != "residual"
    }


def _close_all(ref, got, rtol=1e-13, skip=()):
    """Every array of ``got`` within rtol of the largest of ``ref``'s (the residual, a
    round-off itself, left out; the directions of the forces at the round-off too; the
    positions of a disc that floats are its canonical ones, stage.floating). The Hertz
    stresses (σ ∝ √F) as σ²: a pin touching with a load at the round-off (1e-12 N) has a
    stress of ~100 Pa against the largest's 1 GPa
    (main's compiled Newton against the NumPy path: 7.2e-8 of the largest σ, 5e-15 of the
    largest σ²)."""
    a, b = _arrays(ref), _arrays(got)
    assert a.keys() == b.keys()
    for name, value in a.items():
        if value.dtype.kind != "f" or not value.size or name in skip:
            continue
        if "stress" in name:
            value, b[name] = value**2, b[name] ** 2
        size = a.get(name[:-6])
        if name.endswith("_angle") and size is not None:
            # the direction of a force at the round-off (0 or 1e-12 N): ±π, anything
            tiny = np.abs(size) <= 1e-9 * np.nanmax(np.abs(size))
            value, b[name] = np.where(tiny, 0.0, value), np.where(tiny, 0.0, b[name])
        scale = np.nanmax(np.abs(value))
        diff = np.nanmax(np.abs(b[name] - value)) if scale > 0 else np.nanmax(np.abs(b[name]))
        assert diff <= rtol * max(scale, 1e-300), (name, diff, scale)


def _equal_all(ref, got):
    """Every array of ``got`` equal to ``ref``'s, bit for bit."""
    a, b = _arrays(ref), _arrays(got)
    for name, value in a.items():
        np.testing.assert_array_equal(b[name], value, err_msg=name)


def solve_counted(example, coarse, monkeypatch, tally, **switches):
    """The numba path's results at each of :data:`TORQUES` with ``kernel_compliant``'s
    module switches set (``_ACTIVE=0``, ...), and per torque the sum over the kernel's
    calls of ``tally(stats)`` (its statistics: ``counts``, ``active``); the switches are
    undone after."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    for name, value in switches.items():
        monkeypatch.setattr(kc, name, value)
    compiled = eq.kernel_compliant
    sums: list = []

    def counted(*args, **kwargs):
        stats = kwargs.setdefault("stats", {})
        failed = compiled(*args, **kwargs)
        sums[-1] = sums[-1] + np.asarray(tally(stats))
        return failed

    monkeypatch.setattr(eq, "kernel_compliant", counted)
    out = []
    for t in TORQUES:
        sums.append(0)
        out.append(_solve(example, coarse, t))
    monkeypatch.undo()
    return out, sums


def _run(example, coarse, monkeypatch, active):
    """The numba path's results at both torques with ``_ACTIVE`` = active, and the
    kernel's active-set statistics summed: (reduced crank angles, grows, left for K)."""

    def tally(stats):
        a = stats["active"]
        return int(np.sum(a[:, 0] > 0)), int(a[:, 1].sum()), int(a[:, 2].sum())

    out, sums = solve_counted(example, coarse, monkeypatch, tally, _ACTIVE=active)
    return out, sum(sums)


@pytest.fixture(scope="module")
def whole(example, coarse):
    """Every candidate's unknowns (main's compiled Newton)."""
    mp = pytest.MonkeyPatch()
    try:
        return _run(example, coarse, mp, 0)[0]
    finally:
        mp.undo()


def test_the_active_set_finds_the_whole_root(example, coarse, whole, monkeypatch):
    """``_ACTIVE`` 1 (the default): the outputs within 1e-13 of each one's largest of the
    iteration on every candidate's unknowns; most crank angles reduced."""
    got, tally = _run(example, coarse, monkeypatch, 1)
    assert tally[0] > 0
    for ref, res in zip(whole, got, strict=True):
        _close_all(ref, res)


def test_an_empty_set_grows_to_the_loaded_pins(example, coarse, whole, monkeypatch):
    """``_ACTIVE`` 2: every crank angle from the holes' unknowns alone; the check adds
    each loaded pin, and the root is the same."""
    got, tally = _run(example, coarse, monkeypatch, 2)
    assert tally[0] > 0 and tally[1] >= tally[0] - tally[2]
    for ref, res in zip(whole, got, strict=True):
        _close_all(ref, res)


def test_the_active_set_is_the_references_root(example, coarse, monkeypatch):
    """Against the NumPy path (the reference): 1e-13 of each output's largest."""
    got, _ = _run(example, coarse, monkeypatch, 1)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    for t, res in zip(TORQUES, got, strict=True):
        ref = _solve(example, coarse, t)
        _close_all(ref, res)
        if abs(t[0]) < 100.0:  # a disc floats at some crank angles (every load on it 0):
            # its position the canonical one (stage.floating), the same on both paths
            pins = np.max(ref.pin_load, axis=-1, initial=0.0)
            bearings = np.max(ref.bearing_load, axis=-1, initial=0.0)
            idle = (pins == 0.0) & (bearings == 0.0)
            assert np.sum(idle) >= 10 and np.array_equal(
                idle,
                (np.max(res.pin_load, axis=-1, initial=0.0) == 0.0)
                & (np.max(res.bearing_load, axis=-1, initial=0.0) == 0.0),
            )
