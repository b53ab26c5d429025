"""The reported position of a disc that carries nothing (cyclomesh.stage.floating): a
point of its free set that does not depend on the solver's path, the nearest to the disc
centred on its crank pins."""

import numpy as np
import pytest

import cyclomesh.stage.newton as nt
from cyclomesh.stage.assembly import Problem
from cyclomesh.stage.floating import canonical_positions, floating_discs
from cyclomesh.stage.supports import Supports
from tests.stage.test_newton import HOLES, LIGHT, _hard_stage, _solve

L = HOLES.circle_radius
R = 2.5e-6  # half the clearance [m]


def _disc(ex, ey, pins=None, shafts=None):
    """One crank angle, one disc of three holes (no supports unless ``shafts``), the
    pins (bl, arm, nx, ny) given or none."""
    angles = 2 * np.pi * np.arange(3) / 3
    hx, hy = L * np.cos(angles)[None], L * np.sin(angles)[None]
    bl, arm, nx, ny = pins if pins is not None else (np.full(1, np.inf), *np.zeros((3, 1)))
    shape = (1, 1, np.size(bl))

    def field(v):
        return np.reshape(np.asarray(v, float), shape)

    return Problem(
        bl=field(bl), arm=field(arm), nx=field(nx), ny=field(ny),
        alpha=np.ones(shape), gamma=np.zeros(shape), dmax=np.full(shape, np.inf),
        hx=hx, hy=hy, ex=np.reshape(ex, (1, 1, 3)), ey=np.reshape(ey, (1, 1, 3)),
        torque=1.0, scale=L, supports=shafts,
    )  # fmt: skip


def _free(p, x, tol=1e-15):
    """Every pin open and every hole inside the clearance at x (one disc, one angle)."""
    c, th, ux, uy = x[0, 0], x[0, 1], x[0, 2], x[0, 3]
    ok = np.isfinite(p.bl)
    delta = p.arm * (th - np.where(ok, p.bl, 0)) + p.nx * ux + p.ny * uy
    dx = ux + (th - c) * -p.hy[:, None, :] + p.ex
    dy = uy + (th - c) * p.hx[:, None, :] + p.ey
    return np.all(delta[ok] <= tol) and np.all(np.hypot(dx, dy) <= R + tol)


def test_a_free_centred_disc_turns_with_the_carrier():
    """No hole errors, no pins: the centred position θ = c, u = 0 is free and is taken."""
    p = _disc(np.zeros(3), np.zeros(3))
    x = np.array([[3e-5, 1e-5, 1e-6, -2e-6]])  # where a solver stopped
    out, s = canonical_positions(p, x, 1, np.array([[True]]), R)
    assert np.array_equal(out, np.array([[3e-5, 3e-5, 0.0, 0.0]]))
    assert np.array_equal(s, np.zeros((1, 3)))


def test_a_disc_that_carries_load_is_left_where_it_is():
    p = _disc(np.zeros(3), np.zeros(3))
    x = np.array([[3e-5, 1e-5, 1e-6, -2e-6]])
    out, _ = canonical_positions(p, x, 1, np.array([[False]]), R)
    assert np.array_equal(out, x)


def test_the_centred_position_is_the_least_squares_one():
    """Hole errors within the clearance: the holes' mean error is taken out by u and their
    mean tangential error by the rotation (equally spaced holes)."""
    rng = np.random.default_rng(1)
    ex, ey = rng.uniform(-0.5e-6, 0.5e-6, 3), rng.uniform(-0.5e-6, 0.5e-6, 3)
    p = _disc(ex, ey)
    out, s = canonical_positions(p, np.zeros((1, 4)), 1, np.array([[True]]), R)
    jx, jy = -p.hy[0] / L, p.hx[0] / L
    omega = -np.sum(ex * jx + ey * jy) / (3 * L)
    np.testing.assert_allclose(out[0], [0, omega, -ex.mean(), -ey.mean()], rtol=0, atol=1e-21)
    dx = out[0, 2] + out[0, 1] * L * jx + ex
    dy = out[0, 3] + out[0, 1] * L * jy + ey
    np.testing.assert_allclose(s[0], np.hypot(dx, dy), rtol=1e-15)


@pytest.mark.parametrize("case", ["hole", "pin", "both"])
def test_a_blocked_centre_goes_to_the_nearest_free_point(case):
    """The centred position not free (a hole error beyond the clearance, a pin closed
    there): the result is free, on the boundary, and nearer to the centre than any free
    point found by brute force around it (the projection, in r_c·θ, u)."""
    ex, ey = np.zeros(3), np.zeros(3)
    pins = None
    if case in ("hole", "both"):
        ex = np.array([4e-6, 0.0, 0.0])  # least squares leaves hole 0 at 2/3·4 µm > 2.5 µm
    if case in ("pin", "both"):
        # one pin closing by 1 µm at the centre (bl < c), normal along x
        pins = (np.array([-1e-6 / 0.06]), np.array([0.06]), np.array([0.6]), np.array([0.8]))
    p = _disc(ex, ey, pins)
    out, _ = canonical_positions(p, np.zeros((1, 4)), 1, np.array([[True]]), R)
    assert _free(p, out, 1e-15)
    centre, _ = canonical_positions(_disc(ex, ey), np.zeros((1, 4)), 1, np.array([[True]]), 1.0)
    z = np.array([out[0, 1] * L, out[0, 2], out[0, 3]])
    z0 = np.array([centre[0, 1] * L, centre[0, 2], centre[0, 3]])
    dist = np.linalg.norm(z - z0)
    assert dist > 1e-8  # it had to move
    rng = np.random.default_rng(0)
    for _ in range(4000):  # no free point nearer (a convex set: the projection is unique)
        trial = z + rng.normal(0.0, 1.0, 3) * dist * rng.choice([1e-3, 1e-2, 0.1, 1.0])
        x = np.array([[0.0, trial[0] / L, trial[1], trial[2]]])
        if _free(p, x, 0.0):
            assert np.linalg.norm(trial - z0) >= dist * (1 - 1e-12)


def test_the_crankshafts_deflection_and_end_plate_are_held():
    """With supports the crank pins' deflection w' and the end plate's turn β move the
    centre: d = u + (θ − c − (x_d/S)·β)·ẑ×h + ε − w'."""
    sup = Supports(stiffness=np.eye(1), fraction=np.array([0.25]), carrier=1.0)
    p = _disc(np.zeros(3), np.zeros(3), shafts=sup)
    w = np.array([0.3e-6, -0.1e-6] * 3)  # every crank pin moved the same
    x = np.concatenate([[1e-5, 0.0, 0.0, 0.0], w, [4e-6]])[None]
    out, _ = canonical_positions(p, x, 1, np.array([[True]]), R)
    np.testing.assert_allclose(out[0, 1], 1e-5 + 0.25 * 4e-6, rtol=1e-15)
    np.testing.assert_allclose(out[0, 2:4], [0.3e-6, -0.1e-6], rtol=1e-12)
    assert np.array_equal(out[0, 4:], x[0, 4:])


def test_floating_means_every_force_below_the_threshold():
    pins = np.array([[[0.0, 1e-12], [0.0, 5.0]]])
    bearings = np.array([[[0.0, 0.0, 1e-11], [0.0, 0.0, 0.0]]])
    assert floating_discs(pins, bearings, 1e-10).tolist() == [[True, False]]


def test_two_solver_paths_report_the_same_floating_disc(monkeypatch):
    """±3 % with pin and hole errors: a disc floats at many crank angles. Another Newton
    path (a step cap of 10 µm instead of 100 µm) used to move its translation by 1.5 % to
    3 % of the largest (any point of the flat set solves the equilibrium); the canonical
    position moves only as much as the determined unknowns it holds (the carrier, the
    crankshafts), i.e. within the solve's tolerance, as the loads do."""
    errors, stage = _hard_stage(0)
    torques = [-LIGHT, LIGHT]
    first = _solve(errors, stage, torques)
    monkeypatch.setattr(nt, "_STEP_CAP", 1e-5)
    other = _solve(errors, stage, torques)
    idle = np.max(first.bearing_load, axis=-1) == 0.0
    assert np.sum(idle) > 20, "discs that float"
    for name in ("disc_translation_x", "disc_translation_y", "bearing_deflection"):
        a, b = getattr(first, name), getattr(other, name)
        assert np.max(np.abs(a - b)) <= 1e-10 * np.max(np.abs(a)), name
    rot = first.disc_rotation - first.transmission_error[..., None]
    rot_other = other.disc_rotation - other.transmission_error[..., None]
    assert np.max(np.abs(rot - rot_other)) <= 1e-10 * np.max(np.abs(rot))


def test_a_floating_disc_reports_no_load():
    """A disc that carries nothing reports zero pin loads, contact stresses and crank
    bearing loads: no disc is left with a load between 0 and the floating threshold
    (the solve's loads on a floating disc are its round-off, ~1e-13 N, which depends on
    Newton's path and which σ ∝ √F would magnify to ~1e-9 of the largest stress; they
    were reported until the loads of a floating disc were set to 0)."""
    errors, stage = _hard_stage(0)
    torques = [-LIGHT, LIGHT]
    got = _solve(errors, stage, torques)
    load = np.maximum(np.max(got.pin_load, axis=-1), np.max(got.opposite_pin_load, axis=-1))
    load = np.maximum(load, np.max(got.bearing_load, axis=-1))  # (Q, A, D)
    idle = load == 0.0
    assert np.sum(idle) > 20, "discs that float"
    assert np.all(got.contact_stress[idle] == 0.0) and np.all(got.groove_stress[idle] == 0.0)
    threshold = 1e-9 * LIGHT / L  # FLOATING_LOAD·T/r_c
    assert np.all(load[~idle] > threshold)
