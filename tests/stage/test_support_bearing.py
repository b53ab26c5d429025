"""The crankshafts' support bearings from their geometry: a preloaded pair of tapered
roller bearings (:class:`cyclomesh.stage.bearing.TaperedRollerBearing`, docs/stage.md)."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cyclomesh.exceptions import DesignError
from cyclomesh.stage.bearing import LOAD_EXPONENT, TaperedRollerBearing, roller_constant
from cyclomesh.stage.crankshaft import Crankshaft

EXAMPLE = Path(__file__).parents[2] / "examples" / "rv_stage.toml"
TAPERED = TaperedRollerBearing(
    rollers=13, length=8e-3, contact_angle=math.radians(13.1), preload=1000.0
)


def _roller_force(bearing: TaperedRollerBearing, radial: float) -> float:
    """Radial force [N] of the whole roller set at a radial displacement [m] of the cone,
    summed roller by roller (axial position held: the preload's pair)."""
    psi = 2 * np.pi * np.arange(bearing.rollers) / bearing.rollers
    c = math.cos(bearing.contact_angle)
    delta = np.maximum(bearing.approach() + radial * c * np.cos(psi), 0.0)
    load = roller_constant(bearing.length) * delta**LOAD_EXPONENT
    return float(np.sum(load * c * np.cos(psi)))


@pytest.mark.parametrize("rollers, angle_deg, preload", [(13, 13.1, 1000.0), (17, 25.0, 4e3)])
def test_tangent_stiffness_is_the_roller_sums_slope(rollers, angle_deg, preload):
    """k_r = (Z/2)(10/9)(Q0/δ0)cos²α is the slope at zero of the roller-by-roller force."""
    b = TaperedRollerBearing(rollers, 8e-3, math.radians(angle_deg), preload)
    h = 1e-5 * b.approach()
    slope = (_roller_force(b, h) - _roller_force(b, -h)) / (2 * h)
    assert slope == pytest.approx(b.radial_stiffness(), rel=1e-8)
    # preload balance: the rollers' axial components carry F_a0
    q0 = roller_constant(b.length) * b.approach() ** LOAD_EXPONENT
    assert q0 * rollers * math.sin(b.contact_angle) == pytest.approx(preload, rel=1e-12)


def test_approach_is_palmgren_per_contact():
    """δ0/2 per raceway contact is Palmgren's 3.84e-5·Q^0.9/l^0.8 (mm, N)."""
    q0 = TAPERED.roller_load()
    per_contact_mm = 3.84e-5 * q0**0.9 / 8.0**0.8
    assert TAPERED.approach() * 1e3 / 2 == pytest.approx(per_contact_mm, rel=1e-12)


def test_linear_limit_unloads_the_opposite_roller():
    b = TAPERED
    radial = b.linear_limit() / b.radial_stiffness()  # the tangent model's displacement
    assert b.approach() - radial * math.cos(b.contact_angle) == pytest.approx(
        0.0, abs=1e-12 * b.approach()
    )
    # up to there the roller law's force stays within 2 % of the tangent's (its secant
    # stiffness is 1.8 % lower at the limit, whatever the preload and angle: docs/stage.md)
    for z in (13, 30):
        b = TaperedRollerBearing(z, 8e-3, 0.4, 3e3)
        radial = b.linear_limit() / b.radial_stiffness()
        assert 0.97 < _roller_force(b, radial) / b.linear_limit() < 0.99


def test_crankshaft_takes_the_bearing_stiffness():
    shaft = Crankshaft(0.04, 0.011, 0.018, support_bearing=TAPERED)
    given = Crankshaft(0.04, 0.011, 0.018, support_stiffness=TAPERED.radial_stiffness())
    assert shaft.support_stiffness == TAPERED.radial_stiffness()
    np.testing.assert_array_equal(shaft.compliance(2), given.compliance(2))
    with pytest.raises(DesignError, match="not both"):
        Crankshaft(0.04, 0.011, 0.018, support_stiffness=4e8, support_bearing=TAPERED)
    for kwargs, key in (
        (dict(rollers=2), "rollers"),
        (dict(contact_angle=0.0), "contact_angle_deg"),
        (dict(preload=-1.0), "preload_n"),
        (dict(length=math.nan), "roller_length_mm"),
    ):
        args = dict(rollers=13, length=8e-3, contact_angle=0.2, preload=1e3) | kwargs
        with pytest.raises(DesignError, match=key):
            TaperedRollerBearing(**args)


def test_support_loads_are_the_beams_reactions():
    """Simply supported beam: one disc at mid-span splits its force in halves; two discs
    with opposite forces load the supports with the couple F·pitch/L each."""
    shaft = Crankshaft(0.04, 0.011, 0.018)
    one = shaft.support_loads(np.array([[[30.0, 40.0]]]))
    np.testing.assert_allclose(one, [[25.0, 25.0]], rtol=1e-15)
    force = np.array([[100.0, 0.0], [-100.0, 0.0]])
    np.testing.assert_allclose(shaft.support_loads(force), [100 * 0.011 / 0.04] * 2, rtol=1e-14)
    # the reactions' vector sum and moment balance the loads (random forces, 3 discs)
    rng = np.random.default_rng(1)
    f = rng.normal(size=(5, 3, 2))
    x = shaft.positions(3)
    far = np.einsum("adk,d->ak", f, x) / shaft.support_span
    near = f.sum(axis=1) - far
    np.testing.assert_allclose(
        shaft.support_loads(f), np.stack([np.hypot(*near.T), np.hypot(*far.T)], -1), rtol=1e-13
    )


def _study(tmp_path: Path, support: str) -> Path:
    text = EXAMPLE.read_text()
    base = text[: text.index("[[cases]]")]  # three crankshafts
    base = base[: base.index("[stage.duty_cycle]")] + base[base.index("[stage.crank_bearing]") :]
    base = base.replace("support_bearing_stiffness_n_per_um = 400.0\n", support, 1)
    path = tmp_path / "rv.toml"
    path.write_text(base)
    return path


def test_run_with_support_bearing_geometry_end_to_end(tmp_path):
    """``cyclomesh run`` with [stage.crankshaft.support_bearing]: the data sheet reports the
    bearing's stiffness, the run equals the run with that stiffness given, and a preload
    too small for the support loads is warned about; both keys at once exit 2."""
    from typer.testing import CliRunner

    from cyclomesh.cli import app

    geometry = (
        "\n[stage.crankshaft.support_bearing]\nrollers = 13\nroller_length_mm = 8.0\n"
        "contact_angle_deg = 13.1\npreload_n = 1000.0\n"
    )
    runner = CliRunner()
    common = ["--crank-step-deg", "30", "--figures", "none"]
    sheets = {}
    k = TAPERED.radial_stiffness() * 1e-6
    for name, support in (
        ("geometry", geometry),
        ("given", f"support_bearing_stiffness_n_per_um = {k!r}\n"),
    ):
        out = tmp_path / name
        result = runner.invoke(
            app, ["run", str(_study(tmp_path, support)), "--out", str(out), *common]
        )
        assert result.exit_code == 0, result.output
        sheets[name] = json.loads((out / "summary.json").read_text())["cases"][0]
    geo, given = sheets["geometry"], sheets["given"]
    assert geo["stage_support_bearing_stiffness_n_per_um"] == pytest.approx(k, rel=1e-15)
    for key in ("stage_torsional_rigidity_nm_per_arcmin", "stage_max_support_bearing_load_n"):
        assert geo[key] == pytest.approx(given[key], rel=1e-12)
    assert "stage_support_bearing_linear_limit_n" not in given
    warned = [w for w in geo["warnings"] if "support_bearing" in w]
    assert (
        geo["stage_max_support_bearing_load_n"] > geo["stage_support_bearing_linear_limit_n"]
    ) == bool(warned)
    both = _study(tmp_path, f"support_bearing_stiffness_n_per_um = 400.0\n{geometry}")
    result = runner.invoke(app, ["run", str(both), "--out", str(tmp_path / "both"), *common])
    assert result.exit_code == 2
    assert "not both" in result.output and "Traceback" not in result.output


def test_support_range_warning():
    from cyclomesh.studies.run import _support_range

    sheet = {
        "stage_max_support_bearing_load_n": 2600.0,
        "stage_support_bearing_linear_limit_n": 2400.0,
    }
    assert "raise preload_n" in _support_range(sheet)
    assert _support_range(sheet | {"stage_max_support_bearing_load_n": 2000.0}) is None
    assert _support_range({"stage_max_support_bearing_load_n": 2600.0}) is None
    assert _support_range(None) is None
