"""The compliant disc in the core: rigid limit, coupled load sharing, interpolation.

Synthetic influence tables (no FE) check the solver; ``test_fe_influence.py`` checks
the FE coefficients themselves.
"""

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification
from cyclomesh.core.discbody import DiscBody, share_load_coupled, tooth_index
from cyclomesh.core.loadsharing import share_load
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.drive.solve import solve_drive, torsion_curve
from cyclomesh.exceptions import DesignError

MOD = Modification(pin_radius=8e-6)
PHI = np.deg2rad(np.arange(0.0, 12.0, 0.25))


def synthetic_body(scale: float = 1.0, m: int = 13) -> DiscBody:
    """A reciprocal, positive-definite table: web torsion l_i·l_j/k plus a local term
    decaying with the tooth offset, smooth in the profile angles [m/N]."""
    n2 = TABLE1.teeth
    u = np.linspace(-np.pi, 0.0, m)
    arm = 0.05 * np.abs(np.sin(u)) + 0.01
    d = np.arange(n2)
    dist = np.minimum(d, n2 - d)
    local = 3e-10 * np.exp(-dist)[:, None, None] * np.exp(-((u[:, None] - u[None, :]) ** 2))
    web = 1e-7 * arm[:, None] * arm[None, :]
    table = scale * (local + web[None])[None]
    return DiscBody(u, table, n2)


def test_rigid_is_bit_for_bit_the_rigid_path():
    a = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane")
    b = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", "rigid")
    for name in ("pin_load", "loaded_rotation", "contact_stress", "transmission_error"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    da = solve_drive(TABLE1, MOD, None, [-250.0, 250.0], PHI, True, 2, "half_plane")
    db = solve_drive(TABLE1, MOD, None, [-250.0, 250.0], PHI, True, 2, "half_plane", "rigid")
    assert np.array_equal(da.pin_load, db.pin_load)
    assert np.array_equal(da.transmission_error, db.transmission_error)


def test_zero_body_reproduces_the_rigid_solution():
    body = synthetic_body(scale=0.0)
    rigid = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane")
    zero = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", body)
    np.testing.assert_allclose(zero.pin_load, rigid.pin_load, rtol=0, atol=1e-9)
    np.testing.assert_allclose(zero.loaded_rotation, rigid.loaded_rotation, rtol=1e-12)


def test_coupled_solution_balances_and_is_compatible():
    body = synthetic_body()
    r = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", body)
    moment = np.sum(r.pin_load * r.moment_arm, axis=-1)
    np.testing.assert_allclose(moment, 250.0, rtol=1e-12)
    # compatibility: l(Δφ − φbl) − Σ C F = δ(F) on the loaded pins, ≤ 0 gap elsewhere
    from cyclomesh.core.contact import unloaded_contact
    from cyclomesh.core.hertz import force_from_approach
    from cyclomesh.core.ltca import pin_compliance

    geo = unloaded_contact(TABLE1, MOD, None, PHI)
    alpha, gamma = pin_compliance(geo, TABLE1, True, "half_plane")
    tooth = tooth_index(TABLE1.pins, TABLE1.pitch, PHI)
    c = body.matrix(tooth, geo.profile_angle)
    w = np.einsum("aij,aj->ai", c, r.pin_load)
    with np.errstate(invalid="ignore"):
        approach = r.moment_arm * (r.loaded_rotation[:, None] - r.backlash) - w
    loaded = r.pin_load > 0
    f = force_from_approach(np.where(loaded, approach, 0.0), alpha, gamma)
    np.testing.assert_allclose(f[loaded], r.pin_load[loaded], rtol=1e-9)
    reach = np.isfinite(r.backlash) & (r.moment_arm > 0) & ~loaded
    assert np.all(approach[reach] <= 1e-12 * np.max(approach[loaded]))
    # a softer disc turns further
    rigid = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane")
    assert np.all(r.loaded_rotation > rigid.loaded_rotation)


def test_both_flanks_and_stacks_with_a_body():
    body = synthetic_body()
    one = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", body)
    d = solve_drive(TABLE1, MOD, None, [-250.0, 250.0], PHI, True, 1, "half_plane", body)
    assert np.array_equal(d.pin_load[1, :, 0], one.pin_load)
    # the mirror image: the reverse flank at −φ equals the forward flank at φ
    sym = solve_drive(
        TABLE1, MOD, None, [-250.0, 250.0], np.deg2rad([-3.0, 3.0]), True, 1, "half_plane", body
    )
    np.testing.assert_allclose(
        sym.transmission_error[0, 0], -sym.transmission_error[1, 1], rtol=1e-10
    )
    stack = solve_drive(TABLE1, MOD, None, [250.0], PHI[:8], True, 2, "half_plane", body)
    np.testing.assert_allclose(stack.torque_share.sum(axis=-1), 250.0, rtol=1e-12)
    curve = torsion_curve(TABLE1, MOD, None, 250.0, PHI[:4], True, 1, 11, None, "half_plane", body)
    rigid = torsion_curve(TABLE1, MOD, None, 250.0, PHI[:4], True, 1, 11, None, "half_plane")
    assert np.all(curve.torsional_rigidity < rigid.torsional_rigidity)


def test_interpolation_reproduces_the_grid_and_is_symmetric():
    body = synthetic_body()
    u = body.profile_angles
    k = np.array([0, 1, 5, 38])
    ang = u[[2, 5, 7, 10]]
    c = body.matrix(k, ang)
    assert c[1, 0] == pytest.approx(body.table[0, 1, 2, 5], rel=1e-14)
    assert c[0, 0] == pytest.approx(body.diagonal[0, 2], rel=1e-14)
    np.testing.assert_allclose(c, c.T, rtol=1e-13)
    mid = body.matrix(k, ang + 0.37 * (u[1] - u[0]))
    np.testing.assert_allclose(mid, mid.T, rtol=1e-13)


def test_fe_needs_half_plane_and_a_body():
    body = synthetic_body()
    with pytest.raises(DesignError, match="half_plane"):
        solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "paper", body)
    with pytest.raises(DesignError, match="disc_body"):
        solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", "fe")
    with pytest.raises(DesignError, match="disc_body"):
        solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", "soft")


def test_share_load_coupled_with_zero_matrix_matches_share_load():
    rng = np.random.default_rng(3)
    bl = np.abs(rng.normal(0, 1e-5, (5, 8)))
    arm = rng.uniform(0.02, 0.06, (5, 8))
    alpha = np.full((5, 8), 2e-9)
    gamma = np.full((5, 8), 1e-10)
    x0, f0 = share_load(bl, arm, alpha, gamma, 200.0)
    body = DiscBody(np.linspace(-np.pi, 0, 5), np.zeros((1, 39, 5, 5)), 39)
    x1, f1 = share_load_coupled(
        bl, arm, alpha, gamma, 200.0, body, np.zeros((5, 8), int), np.full((5, 8), -1.0)
    )
    np.testing.assert_allclose(x1, x0, rtol=1e-13)
    np.testing.assert_allclose(f1, f0, rtol=1e-12, atol=1e-9)


STUDY = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[load]
torque_nm = 250.0
[analysis]
crank_stop_deg = 2.0
crank_step_deg = 1.0
contact_law = "{law}"
disc_body = "fe"
[[cases]]
name = "TPM"
modification.pin_radius_um = 8.0
"""


def test_check_refuses_fe_without_the_extra(tmp_path, monkeypatch, capsys):
    from typer.testing import CliRunner

    import cyclomesh.results.dataset
    from cyclomesh.cli import app

    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(law="half_plane"))
    monkeypatch.setattr(cyclomesh.results.dataset, "fe_extra_available", lambda: False)
    out = CliRunner().invoke(app, ["check", str(path)])
    assert out.exit_code == 2
    lines = [line for line in out.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "fe extra" in lines[0] and "cyclomesh[fe]" in lines[0]
    path.write_text(STUDY.format(law="paper"))
    out = CliRunner().invoke(app, ["check", str(path)])
    assert out.exit_code == 2 and "half_plane" in out.output


def test_tolerance_and_design_map_take_a_body():
    from cyclomesh.designspace.sweep import design_map
    from cyclomesh.tolerance.tasks import RingModel

    body = synthetic_body()
    fields = RingModel.__dataclass_fields__
    assert "disc_body" in fields
    ds = design_map(
        TABLE1,
        {"pin_radius_um": [6.0, 8.0]},
        torque=250.0,
        crank_angles_deg=[0.0, 1.0],
        contact_law="half_plane",
        disc_body=body,
    )
    rigid = design_map(
        TABLE1,
        {"pin_radius_um": [6.0, 8.0]},
        torque=250.0,
        crank_angles_deg=[0.0, 1.0],
        contact_law="half_plane",
    )
    assert ds.attrs["disc_body"] == "fe" and rigid.attrs["disc_body"] == "rigid"
    name = next(v for v in ds.data_vars if "stress" in v)
    assert not np.allclose(ds[name].values, rigid[name].values)


@pytest.mark.parametrize("name", ["numpy", "numba"])
def test_pins_beyond_the_first_set_are_added_exactly(monkeypatch, name):
    # the first candidate set made too small on purpose (the last loaded pin of the
    # solution dropped): the check after the solve must find the pin that would
    # penetrate, add it and solve again, to the same solution as all pins. The compiled
    # kernel starts each ring from the rigid disc with the pins that start can reach
    # added to the given set (and later angles with their own): the dropped pin back in
    # the set, the check has nothing to add there
    import cyclomesh.core.discbody as cdb
    from cyclomesh.core import kernel, kernel_discbody

    if name == "numba" and kernel_discbody.compiled() is None:
        pytest.skip("numba not installed")
    monkeypatch.setenv(kernel.ENV_VAR, name)
    body = synthetic_body()
    full = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", body)
    calls = []
    real = cdb._solve_set

    def shrunk(candidate, arrays, *rest):
        if not calls:
            bl = np.where(full.pin_load > 0, arrays[0], -np.inf)
            drop = np.argmax(bl, axis=-1)[:, None]
            np.put_along_axis(candidate, drop, False, -1)  # in place: the caller's set
        calls.append(1)
        return real(candidate, arrays, *rest)

    monkeypatch.setattr(cdb, "_solve_set", shrunk)
    r = solve_ltca(TABLE1, MOD, None, 250.0, PHI, True, "half_plane", body)
    assert (len(calls) > 1) == (name == "numpy")
    np.testing.assert_allclose(r.pin_load, full.pin_load, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(r.loaded_rotation, full.loaded_rotation, rtol=1e-12)


@pytest.mark.parametrize("stage", [True, False])
def test_fe_body_over_swept_geometry_checked_for_design(tmp_path, stage):
    """disc_body = "fe" over swept geometry (design_space.pin_circle_radius_mm) passes
    `cyclomesh check --kind design`, with and without [stage]: each candidate geometry gets
    its own FE body (tests/designspace/test_design_fe_geometry.py; it was once solved with
    the base geometry's table, 887 MPa on the map where the candidate's own table gives
    867, then refused). One DiscBody over geometry is still refused by the core map, in
    one line naming the key."""
    from pathlib import Path

    from typer.testing import CliRunner

    from cyclomesh.cli import app
    from cyclomesh.designspace.sweep import design_map

    name = "rv_stage.toml" if stage else "table2.toml"
    text = (Path(__file__).parents[2] / "examples" / name).read_text()
    text = text.replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1)
    text = text.replace('contact_law = "paper"', 'contact_law = "half_plane"')
    path = tmp_path / "rv.toml"
    path.write_text(text)
    out = CliRunner().invoke(app, ["check", str(path)])
    assert out.exit_code == 0, out.output
    base = text[: text.index("[figures]" if "[figures]" in text else "[[cases]]")]
    path.write_text(  # a design map takes the base only, and no [figures] keys
        base + '[design_space]\nobjective = "max_contact_stress"\n'
        "pin_circle_radius_mm = { start = 63.0, stop = 65.0, points = 2 }\n"
    )
    out = CliRunner().invoke(app, ["check", str(path), "--kind", "design"])
    assert out.exit_code == 0, out.output
    u = np.linspace(-np.pi, 0.0, 5)
    body = DiscBody(u, np.zeros((1, TABLE1.teeth, 5, 5)), TABLE1.teeth)
    with pytest.raises(DesignError, match="design_space.pin_radius_mm: a DiscBody") as info:
        design_map(TABLE1, {"pin_radius_mm": [3.5, 3.6]}, disc_body=body)
    assert "\n" not in str(info.value)
    if not stage:
        return
    # without crank bearings (rigid bearings hold the hole centres) every kind refuses it
    text = text.replace("[stage.crank_bearing]", "[not_a_bearing]")
    cut = text.index("[not_a_bearing]")
    end = text.find("\n[", cut + 1)
    path.write_text(text[:cut] + (text[end + 1 :] if end > 0 else ""))
    out = CliRunner().invoke(app, ["check", str(path)])
    assert out.exit_code == 2 and "[stage.crank_bearing]" in out.output


@pytest.mark.parametrize("period", [1, 3, 13])
def test_reciprocal_matrix_is_the_symmetrised_matrix(period):
    """The fast path of the load sharing (whole 4×4 windows of the symmetrised table,
    pairs i < j once) equals ½(C + Cᵀ) of the plain interpolation to round-off, for any
    period of the support, angles off the grid (clamped) or NaN, and leading axes."""
    rng = np.random.default_rng(period)
    u = np.linspace(-np.pi, 0.0, 9)
    body = DiscBody(u, rng.normal(size=(period, TABLE1.teeth, 9, 9)), TABLE1.teeth)
    for shape in ((16,), (5, 12), (2, 3, 7)):
        k = rng.integers(-50, 200, shape)
        ang = rng.uniform(u[0] - 0.3, u[-1] + 0.3, shape)
        ang[..., 0] = np.nan
        c = body.matrix(k, ang)
        sym = 0.5 * (c + np.swapaxes(c, -1, -2))
        fast = body.reciprocal_matrix(k, ang)
        np.testing.assert_allclose(fast, sym, rtol=0, atol=1e-14 * np.max(np.abs(sym)))
        assert np.array_equal(fast, np.swapaxes(fast, -1, -2))
        own = body.self_compliance(k, ang)
        assert np.array_equal(np.diagonal(fast, axis1=-2, axis2=-1), own)
        assert np.array_equal(body.reciprocal_matrix(k, ang, own), fast)


def test_risky_pin_check_masks_the_padding_before_multiplying():
    """Issue 23: when the cases of a batch add different numbers of risky pins (pins that
    a negative body coefficient could bring into contact), the padding entries of the
    shorter cases (pins that cannot touch: φbl = inf, l = 0) entered l·(Δφc − φbl) before
    the mask: 0·inf, a raw `invalid value encountered in multiply` RuntimeWarning that
    `cyclomesh tolerance` printed with disc_body = "fe" (RV-40E-size pair, ±3 µm)."""
    import warnings

    inf = np.inf
    bl = np.array([[0.0, 1e-3, 1e-3, 1e-3], [0.0, 1e-3, inf, inf]])
    arm = np.array([[0.04, 0.04, 0.04, 0.04], [0.04, 0.04, 0.0, 0.0]])
    alpha, gamma = np.full((2, 4), 2e-9), np.full((2, 4), 1e-10)
    table = np.zeros((1, 39, 5, 5))
    table[0, 0] = 1e-10  # the pins' own tooth: a positive block
    table[0, 5] = -1e-6  # a negative coefficient elsewhere: every far pin is risky
    body = DiscBody(np.linspace(-np.pi, 0, 5), table, 39)
    tooth, angle = np.zeros((2, 4), int), np.full((2, 4), -1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        x, f = share_load_coupled(bl, arm, alpha, gamma, 200.0, body, tooth, angle)
    # one pin carries the torque; the far pins stay clear
    np.testing.assert_allclose(f[:, 0] * 0.04, 200.0, rtol=1e-12)
    assert np.all(f[:, 1:] == 0.0) and np.all(x < 1e-3)
