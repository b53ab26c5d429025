"""The half-plane contact law: physics, exact inverse, behaviour through inflection points."""

from __future__ import annotations

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification, analyse, solve_ltca
from cyclomesh.core.hertz import (
    compliance_coefficients,
    effective_modulus,
    force_from_approach,
    force_from_approach_w,
    half_width,
    pin_tooth_radius,
)
from cyclomesh.core.profile import curvature_radius
from cyclomesh.exceptions import DesignError, StudyError
from cyclomesh.studyfile import load_study

C = TABLE1.disc_material.compliance
NU = TABLE1.disc_material.poisson_ratio
B = TABLE1.width
RP = TABLE1.pin_radius
TPM = Modification(pin_radius=8e-6)


def coefficients(rho_c, depth, groove=False, law="half_plane"):
    return compliance_coefficients(
        RP, rho_c, TABLE1.groove_radius, 0.8, B, C, C, C, groove, law, depth, NU
    )


def test_half_plane_is_johnson_5_41_for_the_disc_plus_eq20_for_the_pin():
    force = np.array([10.0, 300.0, 2000.0])
    rho_c, depth = 4.2e-3, 78e-3
    rho_star = pin_tooth_radius(RP, rho_c)
    b = half_width(force, rho_star, effective_modulus(C, C), B)
    direct = (
        2 * force / (np.pi * B)
        * (C * (np.log(2 * depth / b) - NU / (2 * (1 - NU))) + C * (np.log(4 * RP / b) - 0.5))
    )  # fmt: skip
    alpha, gamma = coefficients(rho_c, depth)
    np.testing.assert_allclose(force * (alpha - gamma * np.log(force)), direct, rtol=1e-13)
    # same γ as Eq. 20: only α changes, so the inverse and its speed carry over
    np.testing.assert_array_equal(gamma, coefficients(rho_c, None, law="paper")[1])


@pytest.mark.parametrize("groove", [False, True])
def test_inverse_is_exact_and_matches_lambert_w(groove):
    force = np.geomspace(1.0, 5e3, 50)
    alpha, gamma = coefficients(np.linspace(-4e-3, 1e3, 50), 80e-3, groove)
    delta = force * (alpha - gamma * np.log(force))
    np.testing.assert_allclose(force_from_approach(delta, alpha, gamma), force, rtol=1e-13)
    np.testing.assert_allclose(force_from_approach_w(delta, alpha, gamma), force, rtol=1e-11)


def test_finite_and_smooth_through_the_inflection_point_where_eq20_diverges():
    a, e, n1 = TABLE1.pin_circle_radius, TABLE1.eccentricity, TABLE1.pins
    inflection = -np.arccos((e * e * n1**3 + a * a) / (e * n1 * (1 + n1) * a))
    phi1 = inflection + np.linspace(-0.05, 0.05, 2001)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_c = curvature_radius(phi1 / TABLE1.teeth, TABLE1, TPM)
        paper = coefficients(rho_c, None, law="paper")[0]
    half = coefficients(rho_c, 79e-3)[0]
    assert np.isinf(rho_c[1000])  # ρc passes through infinity, exactly on the grid
    assert np.isposinf(paper[1000])  # Eq. 20 diverges there (ρ* → ρp, ln ρc → inf) ...
    assert np.nanmax(paper) > 1.25 * np.nanmedian(paper)  # ... and spikes around it
    assert np.all(np.isfinite(half))
    # smooth: second differences at the level of the profile's own variation
    assert np.abs(np.diff(half, 2)).max() < 1e-6 * half.mean()
    assert np.ptp(half) < 0.03 * half.mean()  # no spike: a gentle trend


def test_ltca_with_half_plane_has_no_load_jumps_at_the_inflection_points():
    phi = np.deg2rad(np.arange(0.0, 18.0, 0.05))
    paper = solve_ltca(TABLE1, TPM, torque=250.0, crank_angles=phi, contact_law="paper")
    half = solve_ltca(TABLE1, TPM, torque=250.0, crank_angles=phi, contact_law="half_plane")
    for r in (paper, half):  # equilibrium Σ F·l = T
        np.testing.assert_allclose(np.sum(r.pin_load * r.moment_arm, axis=-1), 250.0, rtol=1e-9)
    jump = lambda r: np.abs(np.diff(r.pin_load, axis=0)).max() / r.pin_load.max()  # noqa: E731
    assert jump(paper) > 0.04  # the artefact of Eq. 20
    assert jump(half) < 0.01
    # the laws agree away from the inflection: peak loads within a few %
    assert half.pin_load.max() == pytest.approx(paper.pin_load.max(), rel=0.03)


def test_default_is_the_half_plane_law_and_is_recorded():
    phi = np.deg2rad([0.0, 3.0])
    default = analyse(TABLE1, TPM, crank_angles=phi)
    paper = analyse(TABLE1, TPM, crank_angles=phi, contact_law="paper")
    half = analyse(TABLE1, TPM, crank_angles=phi, contact_law="half_plane")
    assert default.attrs["contact_law"] == "half_plane"
    assert paper.attrs["contact_law"] == "paper"
    np.testing.assert_array_equal(default.pin_load.values, half.pin_load.values)
    assert not np.array_equal(default.pin_load.values, paper.pin_load.values)


def test_every_api_defaults_to_the_half_plane_law():
    """Every public entry point that takes a contact law defaults to the converged one."""
    import inspect

    from cyclomesh.designspace.sweep import DesignTask, candidate_metrics, design_map
    from cyclomesh.drive.solve import solve_drive, torsion_curve
    from cyclomesh.fe.disc import solve_disc_fe
    from cyclomesh.results.torsion import stiffness
    from cyclomesh.studyfile.schema import AnalysisSection, CaseInputs
    from cyclomesh.tolerance.tasks import RingModel

    for fn in (solve_ltca, analyse, solve_drive, torsion_curve, stiffness, design_map,
               candidate_metrics, solve_disc_fe):  # fmt: skip
        assert inspect.signature(fn).parameters["contact_law"].default == "half_plane", fn
    for cls in (DesignTask, RingModel, CaseInputs):
        assert cls.__dataclass_fields__["contact_law"].default == "half_plane", cls
    assert AnalysisSection().contact_law == "half_plane"


def test_unknown_contact_law_is_refused():
    with pytest.raises(DesignError, match="contact_law"):
        solve_ltca(TABLE1, TPM, contact_law="johnson")


def test_study_key_selects_the_law(tmp_path):
    base = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[analysis]
crank_stop_deg = 1.0
crank_step_deg = 0.5
"""
    path = tmp_path / "s.toml"
    path.write_text(base + 'contact_law = "half_plane"\n', encoding="utf-8")
    assert load_study(path).cases[0].to_core().kwargs()["contact_law"] == "half_plane"
    path.write_text(base, encoding="utf-8")
    assert load_study(path).cases[0].to_core().kwargs()["contact_law"] == "half_plane"
    path.write_text(base + 'contact_law = "paper"\n', encoding="utf-8")
    assert load_study(path).cases[0].to_core().kwargs()["contact_law"] == "paper"
    path.write_text(base + 'contact_law = "fitted"\n', encoding="utf-8")
    with pytest.raises(StudyError, match="contact_law"):
        load_study(path)


def test_every_kind_of_study_solves_with_the_chosen_law():
    """The law reaches the drive (both flanks, stacks), the torsion curve, design maps
    and the tolerance rings: each gives solve_ltca's half-plane numbers where they meet."""
    from cyclomesh.designspace.sweep import candidate_metrics, design_map
    from cyclomesh.drive.solve import mirror_index, solve_drive, torsion_curve
    from cyclomesh.results.torsion import stiffness

    phi = np.deg2rad([0.0, 1.0, 2.0])
    half = solve_ltca(TABLE1, TPM, None, 250.0, phi, contact_law="half_plane")
    paper = solve_ltca(TABLE1, TPM, None, 250.0, phi, contact_law="paper")
    drive = solve_drive(TABLE1, TPM, None, [-250.0, 250.0], phi, contact_law="half_plane")
    np.testing.assert_array_equal(drive.pin_load[1, :, 0], half.pin_load)
    # error-free pair at crank angle 0: the reverse flank is the mirror image of the forward
    np.testing.assert_allclose(
        drive.pin_load[0, 0, 0], half.pin_load[0, mirror_index(40)], rtol=1e-9, atol=1e-9
    )
    assert not np.array_equal(half.pin_load, paper.pin_load)
    curve = torsion_curve(TABLE1, TPM, None, 250.0, phi, points=5, contact_law="half_plane")
    k = list(curve.torque).index(250.0)
    np.testing.assert_allclose(curve.rotation[k], half.transmission_error, rtol=1e-12)
    ds = stiffness(TABLE1, TPM, points=5, crank_angles=phi, contact_law="half_plane")
    assert ds.attrs["contact_law"] == "half_plane"
    metrics = candidate_metrics(TABLE1, TPM, None, 250.0, phi, contact_law="half_plane")
    assert metrics["max_contact_stress"] == half.contact_stress.max()
    grid = design_map(
        TABLE1, {"pin_radius_um": [8.0]}, crank_angles_deg=[0.0, 1.0, 2.0], contact_law="half_plane"
    )
    assert grid.attrs["contact_law"] == "half_plane"
    assert float(grid["max_contact_stress_mpa"][0]) == pytest.approx(
        half.contact_stress.max() * 1e-6, rel=1e-14
    )
    with pytest.raises(DesignError, match="contact_law"):
        solve_drive(TABLE1, TPM, None, 250.0, phi, contact_law="fitted")


def test_tolerance_rings_use_the_study_law(tmp_path):
    from cyclomesh.studies.tolerance import load_tolerance_study, ring_model

    path = tmp_path / "t.toml"
    path.write_text(
        """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[modification]
pin_radius_um = 8.0
[analysis]
contact_law = "half_plane"
[tolerance]
seed = 3
rings = 2
allowable_contact_stress_mpa = 2000.0
radial_um = { distribution = "uniform", half_range = 2.0 }
crank_step_deg = 1.0
crank_stop_deg = 3.0
""",
        encoding="utf-8",
    )
    study, spec = load_tolerance_study(path)
    model = ring_model(study, spec)
    assert model.contact_law == "half_plane"
    metrics = model.metrics(model.draw(np.arange(2)))
    errors = model.pin_errors(model.draw(np.arange(2)))
    direct = solve_ltca(
        TABLE1, TPM, errors, 250.0, np.deg2rad(model.crank_angles_deg), contact_law="half_plane"
    )
    np.testing.assert_allclose(
        metrics["max_contact_stress_mpa"], direct.contact_stress.max(axis=(-2, -1)) * 1e-6
    )
