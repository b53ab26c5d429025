"""Crankshafts and carrier from their geometry in the RV stage (docs/stage.md)."""

import math

import numpy as np
import pytest

from cyclomesh.core.pair import Modification
from cyclomesh.exceptions import DesignError
from cyclomesh.stage import RollerSet, StageDesign, solve_stage
from cyclomesh.stage import solve as stage_solve
from cyclomesh.stage.carrier import Carrier, pillar_stiffness
from cyclomesh.stage.crankshaft import Crankshaft, beam_compliance, shear_coefficient
from cyclomesh.stage.equilibrium import Supports
from tests.stage.rv40 import HOLES, RV40

ROLLERS = RollerSet(rollers=14, diameter=4e-3, length=9e-3, clearance=5e-6, pitch_diameter=22e-3)
MOD = Modification(pin_radius=3e-6)
PHI = np.deg2rad(np.arange(0.0, 360.0, 15.0))
SHAFT = Crankshaft(support_span=0.05, disc_pitch=0.012, pin_diameter=0.018, support_stiffness=1e9)
CARRIER = Carrier(pillars=3, pillar_diameter=0.012, pillar_length=0.03, pillar_circle_radius=0.036)


def _closed_form(span, a, x, EI, kGA, ks):
    """Deflection at x of a simply supported Timoshenko beam under a unit load at a
    (Timoshenko & Gere): bending + shear + the support springs' rigid motion."""
    b = span - a
    if x <= a:
        bend = b * x * (span**2 - b**2 - x**2) / (6.0 * EI * span)
        shear = b * x / (span * kGA)
    else:
        xr = span - x
        bend = a * xr * (span**2 - a**2 - xr**2) / (6.0 * EI * span)
        shear = a * xr / (span * kGA)
    springs = 0.0 if ks is None else (b / span) * (1 - x / span) / ks + (a / span) * (x / span) / ks
    return bend + shear + springs


@pytest.mark.parametrize("ks", [None, 3e8])
def test_beam_matches_closed_form(ks):
    span, d, E, nu = 0.06, 0.02, 206e9, 0.3
    EI = E * math.pi * d**4 / 64
    kGA = shear_coefficient(nu) * E / (2 * (1 + nu)) * math.pi * d**2 / 4
    loads = np.array([0.013, 0.029, 0.041])
    C = beam_compliance(span, loads, EI, kGA, ks)
    for i, x in enumerate(loads):
        for j, a in enumerate(loads):
            exact = _closed_form(span, a, x, EI, kGA, ks)
            assert abs(C[i, j] - exact) <= 1e-9 * abs(exact)


def test_pillar_is_a_guided_timoshenko_beam():
    d, length, E, nu = 0.01, 0.03, 206e9, 0.3
    EI = E * math.pi * d**4 / 64
    kGA = shear_coefficient(nu) * E / (2 * (1 + nu)) * math.pi * d**2 / 4
    # a cantilever of half the length, twice: the guided beam's inflection is at mid-length
    half = length / 2
    cantilever = half**3 / (3 * EI) + half / kGA
    assert pillar_stiffness(d, length, E, nu) == pytest.approx(1 / (2 * cantilever), rel=1e-12)


def _solve(stage, torque=(-412.0, 412.0), phi=PHI):
    return solve_stage(RV40, stage, MOD, None, torque, phi, discs=2)


def test_general_assembly_reproduces_the_stage(monkeypatch):
    """The assembly of crankshafts and carrier, with both rigid, is today's stage."""
    plain = StageDesign(HOLES, ROLLERS)
    ref = _solve(plain)
    rigid = Supports(stiffness=None, fraction=np.array([0.4, 0.6]), carrier=None)
    monkeypatch.setattr(stage_solve, "stage_supports", lambda stage, discs, order: rigid)
    got = _solve(plain)
    scale = np.max(np.abs(ref.transmission_error))
    assert np.max(np.abs(got.transmission_error - ref.transmission_error)) <= 1e-10 * scale
    assert np.max(np.abs(got.bearing_load - ref.bearing_load)) <= 1e-9 * np.max(ref.bearing_load)


def test_stiff_crankshaft_and_carrier_tend_to_the_rigid_stage():
    ref = _solve(StageDesign(HOLES, ROLLERS))
    twists = []
    for scale in (1e3, 1e4):
        shaft = Crankshaft(0.05, 0.012, 0.018, 1e9 * scale, youngs_modulus=206e9 * scale)
        carrier = Carrier(3, 0.012, 0.03, 0.036, youngs_modulus=206e9 * scale)
        got = _solve(StageDesign(HOLES, ROLLERS, crankshaft=shaft, carrier=carrier))
        twists.append(np.max(np.abs(got.twist - ref.twist)) / np.max(np.abs(ref.twist)))
    # the difference falls with the compliance (first order)
    assert twists[1] < 0.2 * twists[0]
    assert twists[1] < 1e-3


def test_elastic_stage_balances_and_shares_add_to_one():
    stage = StageDesign(HOLES, ROLLERS, crankshaft=SHAFT, carrier=CARRIER)
    res = _solve(stage)
    total = sum(res.work.values())
    tw = res.torque[:, None] * res.twist
    assert np.max(np.abs(total - tw) / tw) <= 1e-9
    for part in ("mesh", "crank_bearings", "crankshafts", "carrier"):
        assert np.all(res.work[part] > 0)
    # reverse flanks: the same stage mirrored, the twist opposite
    assert np.all(res.twist[0] < 0) and np.all(res.twist[1] > 0)
    # softer than the rigid crankshafts and carrier
    ref = _solve(StageDesign(HOLES, ROLLERS))
    assert np.all(np.abs(res.twist) > np.abs(ref.twist))


def test_carrier_override_share_is_its_series_compliance():
    k = 500.0 / np.radians(1 / 60)
    res = _solve(StageDesign(HOLES, ROLLERS, carrier_stiffness=k))
    T = res.torque[:, None]
    share = res.work["carrier"] / (T * res.twist)
    assert np.max(np.abs(share * res.twist - T / k)) <= 1e-12 * np.max(np.abs(res.twist))


def test_keys_exclude_each_other():
    with pytest.raises(DesignError, match="not both"):
        StageDesign(HOLES, ROLLERS, crankshaft=SHAFT, crankshaft_stiffness=1e8)
    with pytest.raises(DesignError, match="needs"):
        StageDesign(HOLES, ROLLERS, carrier=CARRIER)
    with pytest.raises(DesignError, match="do not fit"):
        Crankshaft(0.01, 0.012, 0.018).positions(2)


def test_data_sheet_backlash_and_budget():
    """Backlash of the mesh alone is its play 2Δρ/(e·n2) (docs/drive.md); the stage adds
    the bearings' free travel; the compliance shares add up to 1."""
    from cyclomesh.core.pair import PinErrors
    from cyclomesh.results.stage import data_sheet
    from cyclomesh.studyfile.schema import CaseInputs

    inputs = CaseInputs(
        design=RV40,
        modification=MOD,
        errors=PinErrors(),
        torque=412.0,
        crank_angles=PHI,
        groove_deformation=True,
        errors_um={},
        discs=2,
        contact_law="half_plane",
        crank_holes=HOLES,
        stage=StageDesign(HOLES, ROLLERS, crankshaft=SHAFT, carrier=CARRIER),
    )
    sheet = data_sheet(inputs, 412.0)
    arcmin = np.radians(1 / 60)
    play = 2 * 3e-6 / (1.3e-3 * 39) / arcmin
    assert sheet["mesh_backlash_arcmin"] == pytest.approx(play, rel=0.02)
    assert (
        sheet["stage_backlash_arcmin"] > sheet["mesh_backlash_arcmin"] + 0.5 * 5e-6 / 36e-3 / arcmin
    )
    # the width at ±0.1 % is below the lost motion at ±3 %
    assert sheet["stage_backlash_arcmin"] < sheet["stage_lost_motion_arcmin"]
    shares = sheet["compliance_share"]
    assert sum(shares.values()) == pytest.approx(1.0, abs=1e-9)
    assert shares["disc_body"] == 0.0 and shares["hole_errors"] == 0.0
    assert all(shares[p] > 0.01 for p in ("mesh", "crank_bearings", "crankshafts", "carrier"))


def test_one_disc_crankshaft_and_carrier_are_series_springs():
    """With one disc at mid-span each crankshaft is a radial spring 1/C in series with its
    bearing and the end plate turns the crank pins by β/2 (the output by T/(4K_β)): the
    geometric stage equals the override springs' stage (another code path), and each
    part's share is its compliance alone."""
    shaft = Crankshaft(
        support_span=0.05, disc_pitch=0.012, pin_diameter=0.018, support_stiffness=1e9
    )
    geometric = StageDesign(HOLES, ROLLERS, crankshaft=shaft, carrier=CARRIER)
    springs = StageDesign(
        HOLES,
        ROLLERS,
        crankshaft_stiffness=1.0 / shaft.compliance(1)[0, 0],
        carrier_stiffness=4.0 * CARRIER.torsional_stiffness(),
    )
    a, b = (
        solve_stage(RV40, s, MOD, None, (-300.0, 300.0), PHI, discs=1) for s in (geometric, springs)
    )
    scale = np.max(np.abs(b.twist))
    assert np.max(np.abs(a.twist - b.twist)) <= 1e-9 * scale
    assert np.max(np.abs(a.bearing_load - b.bearing_load)) <= 1e-8 * np.max(b.bearing_load)
    T = a.torque[:, None]
    for part in ("mesh", "crank_bearings", "crankshafts", "carrier"):
        assert np.allclose(a.work[part], b.work[part], rtol=1e-8, atol=1e-12 * np.max(T * b.twist))
    # the carrier's share is its series compliance
    assert np.allclose(a.work["carrier"] / T, T / (4.0 * CARRIER.torsional_stiffness()), rtol=1e-9)
