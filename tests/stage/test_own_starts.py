"""The compliant disc's own starts formed only where the compiled Newton reads them
(stage.kernel_compliant.newton's ``start``, equilibrium._body_starts, with the rigid stage
and the bearing start formed for those crank angles only): the kernel's stops and
restarts give the same bits as every crank angle's start formed, whether it gets the
starts it always reads ahead or asks for each, and where it gives crank angles up; the
starts formed on demand move the solution at round-off only (the rigid stage and the
stiff-limit split are warm from the crank angle before among the rows asked for).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("numba")
from tests.stage.fe_cases import require_fe

require_fe()

import cyclomesh.stage.equilibrium as eq  # noqa: E402
import cyclomesh.stage.newton as nt  # noqa: E402
from cyclomesh.stage import kernel_compliant as kc  # noqa: E402
from cyclomesh.stage.solve import solve  # noqa: E402

PHI = np.radians(np.arange(0.0, 360.0, 2.0))


def _solve(example, body, torque, phi=PHI):
    case = example.case().replace(torque=torque, crank_angles=phi)
    return solve(case, example.model().replace(disc_body=body))


def _arrays(result) -> dict[str, np.ndarray]:
    return {
        f.name: getattr(result, f.name)
        for f in dataclasses.fields(result)
        if isinstance(getattr(result, f.name), np.ndarray)
    }


def _kernel(monkeypatch, mode: str, log: list, table: bool = True):
    """equilibrium's kernel_compliant wrapped: ``all`` every start formed before (the
    kernel given x, as before its ``start``), ``ahead`` as the solve calls it, ``ask``
    every start asked for where read (no rows ahead); ``log`` gets (crank angles, rows
    formed, calls of ``start``, counts) of each call. ``table``: the rows asked for are
    those of every crank angle's starts formed together (the kernel's stops alone), else
    formed for the rows asked for (the solve's own)."""
    compiled = kc.newton

    def wrapped(p, law, x, discs, jacobian, settings, stats=None, state=None, start=None):
        assert start is not None  # (numba, no friction: the own starts asked for)
        asked: list[int] = []
        every = start(np.arange(x.shape[0])) if table and mode != "all" else None

        def counted(idx):
            asked.append(idx.size)
            return start(idx) if every is None else every[idx]

        found: dict = {}
        if mode == "all":
            x[:] = counted(np.arange(x.shape[0]))
            failed = compiled(p, law, x, discs, jacobian, settings, found, state)
        else:
            failed = compiled(
                p, law, x, discs, jacobian, settings, found, state, counted, mode == "ahead"
            )
        log.append((x.shape[0], sum(asked), len(asked), found["counts"]))
        return failed

    monkeypatch.setattr(eq, "kernel_compliant", wrapped)


@pytest.mark.parametrize("stall", [False, True])
def test_the_starts_asked_for_give_the_same_bits(example, coarse, monkeypatch, stall):
    """Every array of the numba solve (±412 and ±12.36 N·m) bit for bit with every own
    start formed, with the kernel's counts the same; with a stall declared after 0 steps
    (``stall``) the kernel retries each warm crank angle not at its root from its own
    start and gives it up to the NumPy path, from that start."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    if stall:
        monkeypatch.setattr(nt, "_STALL_ITERATIONS", 0)
    stops: list[int] = []
    for torque in ([-412.0, 412.0], [-12.36, 12.36]):
        logs = {}
        results = {}
        for mode in ("all", "ahead", "ask"):
            logs[mode] = []
            _kernel(monkeypatch, mode, logs[mode])
            results[mode] = _arrays(_solve(example, coarse, torque))
        for mode in ("ahead", "ask"):
            assert results[mode].keys() == results["all"].keys()
            for name, ref in results["all"].items():
                np.testing.assert_array_equal(results[mode][name], ref, err_msg=name)
            assert len(logs[mode]) == len(logs["all"]) == 2
            for got, ref in zip(logs[mode], logs["all"], strict=True):
                np.testing.assert_array_equal(got[3], ref[3])  # the same iterations
                assert got[1] <= got[0] == ref[1]
        for got in logs["ask"]:
            assert got[2] == got[1]  # one row a call
        if not stall:  # fewer rows formed than crank angles
            assert all(got[1] < 0.7 * got[0] for got in logs["ahead"])
        stops.extend(got[2] - 1 for got in logs["ahead"])  # the kernel's stops
        if stall:  # cold retries and crank angles given up (their start asked for)
            assert any(np.any(c[:, 2] == 3) for *_, c in logs["ahead"])
    assert max(stops) > 10  # (measured 17–20 at 412 N·m, 139 with the stall)


def _near(got, ref, rel: float, name: str = "", of=None) -> None:
    """``got`` within ``rel`` of the largest magnitude of ``of`` (default ``ref``; its
    columns each for 2-D starts, the whole array else)."""
    if name == "residual":  # (the gradient's largest at the root: round-off itself)
        return
    of = ref if of is None else of
    scale = np.nanmax(np.abs(of), axis=0 if of.ndim == 2 else None, initial=0.0)
    scale = np.where(scale > 0, scale, 1.0)
    same = np.isnan(got) & np.isnan(ref)  # (NaN where nothing is defined, in both)
    assert np.all(same | (np.abs(got - ref) <= rel * scale)), name


@pytest.mark.parametrize("stall", [False, True])
def test_the_starts_on_demand_move_at_round_off(example, coarse, monkeypatch, stall):
    """The solve's own starts (the rigid stage and the bearing start formed for the rows
    asked for) against every start formed together: every array within 10⁻¹³ of its
    largest (measured ≤ 10⁻¹⁵), ahead and asked for one by one, with and without crank
    angles given up (``stall``)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    if stall:
        monkeypatch.setattr(nt, "_STALL_ITERATIONS", 0)
    for torque in ([-412.0, 412.0], [-12.36, 12.36]):
        results, logs = {}, {}
        for mode in ("all", "ahead", "ask"):
            logs[mode] = []
            _kernel(monkeypatch, mode, logs[mode], table=False)
            results[mode] = _arrays(_solve(example, coarse, torque))
        for mode in ("ahead", "ask"):
            for name, ref in results["all"].items():
                _near(results[mode][name], ref, 1e-13, name)
            for got, ref in zip(logs[mode], logs["all"], strict=True):
                assert got[1] <= got[0] == ref[1]
        if not stall:
            assert all(got[1] < 0.7 * got[0] for got in logs["ahead"])


def test_the_compiled_solve_is_the_numpy_one(example, coarse, monkeypatch):
    """The compiled solve with its starts on demand, and with every start formed together
    (``all``: the eager path's starts), within 10⁻¹³ of each array's largest of the NumPy
    path's (±412 N·m)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    lazy = _arrays(_solve(example, coarse, [-412.0, 412.0]))
    _kernel(monkeypatch, "all", [])
    every = _arrays(_solve(example, coarse, [-412.0, 412.0]))
    monkeypatch.undo()
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    reference = _arrays(_solve(example, coarse, [-412.0, 412.0]))
    assert lazy.keys() == every.keys() == reference.keys()
    for name, ref in reference.items():
        _near(every[name], ref, 1e-13, name)
        _near(lazy[name], ref, 1e-13, name)
    # without the mesh's TE (a tolerance ring's outputs) the rigid stage is formed on
    # demand too
    outputs = ("transmission_error", "bearing_load", "contact_stress")
    case = example.case().replace(torque=[-412.0, 412.0], crank_angles=PHI)
    model = example.model().replace(disc_body=coarse)
    numpy_few = _arrays(solve(case, model, outputs=outputs))
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    few = _arrays(solve(case, model, outputs=outputs))
    for name in ("transmission_error", "bearing_load", "contact_stress"):
        _near(few[name], numpy_few[name], 1e-13, name)
        _near(few[name], reference[name], 1e-13, name)


def test_a_start_formed_alone_is_near_the_row_formed_with_all(example, coarse, monkeypatch):
    """equilibrium._body_starts' rows (the rigid stage, the bearing start, its state and
    the body's z) whether formed for every crank angle, for a few or one by one: the same
    to round-off (each column within 10⁻¹³ of its largest), the first row bit for bit (no
    crank angle before it to warm from)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    seen = []
    compiled = kc.newton

    def wrapped(p, law, x, discs, jacobian, settings, stats=None, state=None, start=None):
        A = x.shape[0]
        every = start(np.arange(A))
        some = np.array([0, 3, 4, A - 1])
        _near(start(some), every[some], 1e-13, of=every)
        np.testing.assert_array_equal(start(some)[0], every[0])
        for i in (1, A // 2):
            _near(start(np.array([i])), every[[i]], 1e-13, of=every)
        seen.append(every)
        return compiled(p, law, x, discs, jacobian, settings, stats, state, start)

    monkeypatch.setattr(eq, "kernel_compliant", wrapped)
    _solve(example, coarse, [-412.0, 412.0])
    assert len(seen) == 2
    for every in seen:  # the body's start: the loads on the disc × c0, not all 0
        assert np.all(np.isfinite(every)) and np.any(every[:, -10:] != 0.0)


def _owned_reference(pins: np.ndarray, run: int) -> np.ndarray:
    A = pins.shape[0]
    need = np.zeros(A, bool)
    need[::run] = True
    if A > 1:
        here, there = pins[1:], pins[:-1]
        match = np.any(here[..., :, None] == there[..., None, :], axis=-1)
        need[1:] |= np.any((here >= 0) & ~match, axis=(1, 2))
    return need


@pytest.mark.parametrize("A, run", [(1, 1), (7, 7), (50, 50), (50, 4)])
def test_the_starts_always_read_are_the_new_candidates(A, run):
    """kernel_compliant._owned: the first crank angle of each run and those with a
    candidate pin (−1 padding) that was none at the crank angle before, as NumPy finds
    them; padding alone asks for nothing."""
    rng = np.random.default_rng(A + run)
    pins = np.sort(rng.integers(0, 12, (A, 2, 6)), axis=-1)
    pins[rng.random(pins.shape) < 0.3] = -1
    np.testing.assert_array_equal(kc._owned(pins, run), _owned_reference(pins, run))
    same = np.broadcast_to(pins[:1], pins.shape).copy()
    expect = np.zeros(A, bool)
    expect[::run] = True
    np.testing.assert_array_equal(kc._owned(same, run), expect)
    padding = np.full((A, 2, 3), -1)
    np.testing.assert_array_equal(kc._owned(padding, run), expect)
