"""Sampling of pin-ring errors and validation of the [tolerance] section."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.schema import ToleranceSection, parse_section
from cyclomesh.tolerance.sampling import draw_ring_errors


def parse_tolerance(raw):
    """Validate a [tolerance] table on its own (as the study loader does)."""
    return parse_section(ToleranceSection, raw, "tolerance")


A_M = 82e-3  # pin-circle radius of Table 1 [m]


def spec(**kinds):
    return parse_tolerance({"seed": 11, "allowable_contact_stress_mpa": 1500.0, **kinds})


UNIFORM = {"distribution": "uniform", "half_range": 4.0}


def test_ring_errors_depend_only_on_seed_and_ring():
    s = spec(radial_um=UNIFORM, angular_urad={"distribution": "normal", "sigma": 30.0})
    batch = draw_ring_errors(s, 40, A_M, range(10))
    for k in (0, 3, 9):
        alone = draw_ring_errors(s, 40, A_M, [k])
        np.testing.assert_array_equal(alone.radial_um[0], batch.radial_um[k], strict=True)
        np.testing.assert_array_equal(alone.angular_urad[0], batch.angular_urad[k])
    reordered = draw_ring_errors(s, 40, A_M, [9, 3, 0])
    np.testing.assert_array_equal(reordered.radial_um, batch.radial_um[[9, 3, 0]])
    other_seed = draw_ring_errors(
        spec(radial_um=UNIFORM).model_copy(update={"seed": 12}), 40, A_M, range(10)
    )
    assert not np.array_equal(other_seed.radial_um, batch.radial_um)


def test_each_kind_has_its_own_stream():
    """Adding a pin-radius distribution leaves the radial draws unchanged."""
    a = draw_ring_errors(spec(radial_um=UNIFORM), 40, A_M, range(5))
    b = draw_ring_errors(
        spec(radial_um=UNIFORM, pin_radius_um={"distribution": "normal", "sigma": 1.0}),
        40,
        A_M,
        range(5),
    )
    np.testing.assert_array_equal(a.radial_um, b.radial_um)
    assert np.all(a.pin_radius_um == 0) and np.all(b.pin_radius_um != 0)


def test_uniform_and_normal_draws_have_the_stated_distribution():
    s = spec(
        radial_um=UNIFORM,
        angular_urad={"distribution": "normal", "sigma": 50.0},
        eccentricity_um={"distribution": "uniform", "half_range": 2.0},
    )
    e = draw_ring_errors(s, 40, A_M, range(500))  # 20,000 pins
    radial = e.radial_um.ravel()
    assert np.all(np.abs(radial) <= 4.0)
    assert stats.kstest(radial, stats.uniform(loc=-4.0, scale=8.0).cdf).pvalue > 1e-3
    assert stats.kstest(e.angular_urad.ravel(), stats.norm(scale=50.0).cdf).pvalue > 1e-3
    assert e.eccentricity_um.shape == (500,)
    assert np.all(np.abs(e.eccentricity_um) <= 2.0)


def test_true_position_is_uniform_over_the_zone():
    """The pin centre is uniform in area over the zone: not crowded at the centre."""
    zone_um = 10.0
    radius = zone_um / 2
    s = spec(position={"distribution": "true_position", "zone_diameter_um": zone_um})
    e = draw_ring_errors(s, 40, A_M, range(500))
    x = e.radial_um.ravel()
    y = e.angular_urad.ravel() * A_M  # tangential [µm] = angular [µrad] * a [m]
    r2 = (x**2 + y**2) / radius**2
    assert r2.max() <= 1.0 + 1e-12
    # half of the area of a disc lies within R/sqrt(2)
    n = r2.size
    inside = np.count_nonzero(r2 <= 0.5) / n
    assert inside == pytest.approx(0.5, abs=4 * np.sqrt(0.25 / n))
    # r²/R² is uniform on [0, 1] and the direction is uniform
    assert stats.kstest(r2, "uniform").pvalue > 1e-3
    theta = np.arctan2(y, x)
    assert stats.kstest(theta, stats.uniform(loc=-np.pi, scale=2 * np.pi).cdf).pvalue > 1e-3


def test_scaling_scales_the_same_draws():
    s = spec(radial_um=UNIFORM, eccentricity_um={"distribution": "normal", "sigma": 1.0})
    e = draw_ring_errors(s, 40, A_M, range(4))
    half = e.scaled(0.5)
    np.testing.assert_array_equal(half.radial_um, 0.5 * e.radial_um)
    np.testing.assert_array_equal(half.eccentricity_um, 0.5 * e.eccentricity_um)
    per_ring = e.scaled(np.array([0.0, 1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(per_ring.radial_um[3], 3.0 * e.radial_um[3])
    assert np.all(per_ring.radial_um[0] == 0)


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        (
            {"radial_um": {"distribution": "triangular", "half_range": 4.0}},
            r"^tolerance\.radial_um\.distribution: unknown distribution 'triangular'",
        ),
        (
            {"radial_um": {"distribution": "uniform", "half_range": -4.0}},
            r"^tolerance\.radial_um\.half_range: expected a number >= 0, got -4\.0",
        ),
        (
            {"angular_urad": {"distribution": "normal", "sigma": -1.0}},
            r"^tolerance\.angular_urad\.sigma: ",
        ),
        (
            {"radial_um": {"distribution": "uniform", "half_rnge": 4.0}},
            r"^tolerance\.radial_um\.half_rnge: unknown key",
        ),
        ({"radial_um": {"half_range": 4.0}}, r"^tolerance\.radial_um: missing distribution"),
        (
            {"radial_um": {"distribution": "true_position", "zone_diameter_um": 4.0}},
            r"true-position zone goes under tolerance\.position",
        ),
        (
            {
                "position": {"distribution": "true_position", "zone_diameter_um": 8.0},
                "radial_um": UNIFORM,
            },
            r"^tolerance: position .* replaces radial_um",
        ),
        (
            {"position": {"distribution": "true_position", "zone_diameter_um": -8.0}},
            r"^tolerance\.position\.zone_diameter_um: ",
        ),
        ({"rings": 0}, r"^tolerance\.rings: "),
        ({"crank_step_deg": 0.0}, r"^tolerance\.crank_step_deg: "),
        ({"allocation": {"target_probability": 1.5}}, r"^tolerance\.allocation\.target_prob"),
        ({"bogus": 1}, r"^tolerance\.bogus: unknown key"),
    ],
)
def test_bad_tolerance_sections_give_one_line_errors(raw, message):
    with pytest.raises(StudyError, match=message) as info:
        parse_tolerance({"seed": 1, "allowable_contact_stress_mpa": 1500.0, **raw})
    assert "\n" not in str(info.value)


def test_seed_and_allowable_are_required():
    with pytest.raises(StudyError, match=r"^tolerance\.seed: required key missing"):
        parse_tolerance({"allowable_contact_stress_mpa": 1500.0})
    missing = r"^tolerance\.allowable_contact_stress_mpa: required key missing"
    with pytest.raises(StudyError, match=missing):
        parse_tolerance({"seed": 1})


def test_crank_angles_fall_back_to_analysis_key_by_key():
    """One rule (issue 14): [tolerance] crank keys override [analysis]'s, else fall back."""
    from cyclomesh.studyfile.schema import AnalysisSection

    angles = spec().crank_angles_deg()  # [analysis] defaults: a revolution at 0.1°
    assert angles.size == 3600 and angles[0] == 0.0 and angles[-1] == pytest.approx(359.9)
    analysis = AnalysisSection(crank_step_deg=1.0, crank_stop_deg=90.0)
    assert spec().crank_angles_deg(analysis).size == 90
    own = parse_tolerance(
        {"seed": 1, "allowable_contact_stress_mpa": 1500.0, "crank_stop_deg": 45.0}
    )
    assert own.crank_range(analysis) == (0.0, 45.0, 1.0)


def test_too_few_crank_angles_name_the_key():
    short = parse_tolerance(
        {"seed": 1, "allowable_contact_stress_mpa": 1500.0, "crank_stop_deg": 0.5}
    )
    from cyclomesh.studyfile.schema import AnalysisSection

    with pytest.raises(StudyError, match=r"^tolerance\.crank_step_deg: fewer than 2 crank"):
        short.crank_range(AnalysisSection(crank_step_deg=1.0))


def test_crank_hole_errors_have_their_own_streams_per_disc_and_crank():
    """[stage]: hole errors drawn per disc and crank, ring k's from (seed, k) alone, the
    pin errors unchanged by them, the same distributions, scaled with the rest."""
    plain = draw_ring_errors(spec(radial_um=UNIFORM), 40, A_M, range(6))
    assert plain.hole_radial_um is None
    s = spec(
        radial_um=UNIFORM,
        hole_radial_um=UNIFORM,
        hole_tangential_um={"distribution": "normal", "sigma": 2.0},
    )
    batch = draw_ring_errors(s, 40, A_M, range(6), holes=(2, 3))
    np.testing.assert_array_equal(plain.radial_um, batch.radial_um)
    assert batch.hole_radial_um.shape == batch.hole_tangential_um.shape == (6, 2, 3)
    assert np.all(np.abs(batch.hole_radial_um) <= 4.0) and np.all(batch.hole_radial_um != 0)
    assert not np.array_equal(batch.hole_radial_um, batch.hole_tangential_um)
    alone = draw_ring_errors(s, 40, A_M, [4], holes=(2, 3))
    np.testing.assert_array_equal(alone.hole_tangential_um[0], batch.hole_tangential_um[4])
    np.testing.assert_array_equal(batch.scaled(0.5).hole_radial_um, 0.5 * batch.hole_radial_um)
    np.testing.assert_array_equal(batch.take([1, 3]).hole_radial_um, batch.hole_radial_um[[1, 3]])
    # only the tangential kind given: the radial holes stay 0
    only = draw_ring_errors(spec(hole_tangential_um=UNIFORM), 40, A_M, range(2), holes=(2, 3))
    assert np.all(only.hole_radial_um == 0) and np.all(only.hole_tangential_um != 0)
    # the same distribution on 2000 draws: uniform on ±4 µm (Kolmogorov–Smirnov)
    many = draw_ring_errors(spec(hole_radial_um=UNIFORM), 40, A_M, range(400), holes=(1, 5))
    assert stats.kstest(many.hole_radial_um.ravel(), stats.uniform(-4.0, 8.0).cdf).pvalue > 1e-3


def _per_ring(s, pins, a, rings, holes=None):
    """The draws ring by ring from the ring's own NumPy generators (the contract of the
    module doc), written out independently of draw_ring_errors."""
    from cyclomesh.tolerance import sampling as smp

    def gen(k, kind):
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence([s.seed, k, kind])))

    def standard(dist, rng, size):
        if dist.distribution == "uniform":
            return rng.uniform(-1.0, 1.0, size) * dist.half_range
        return rng.standard_normal(size) * dist.sigma

    out = {name: np.zeros((len(rings), pins)) for name in ("radial", "angular", "pin_radius")}
    out["eccentricity"] = np.zeros(len(rings))
    for name in ("hole_radial_um", "hole_tangential_um"):
        out[name] = np.zeros((len(rings), *(holes or (0, 0))))
    for j, k in enumerate(rings):
        if s.radial_um is not None:
            out["radial"][j] = standard(s.radial_um, gen(k, smp._RADIAL), pins)
        if s.angular_urad is not None:
            out["angular"][j] = standard(s.angular_urad, gen(k, smp._ANGULAR), pins)
        if s.tangential_um is not None:
            out["angular"][j] = standard(s.tangential_um, gen(k, smp._TANGENTIAL), pins) / a
        if s.position is not None:
            u = gen(k, smp._POSITION).random((2, pins))
            r, theta = np.sqrt(u[0]), 2.0 * np.pi * u[1]
            half = 0.5 * s.position.zone_diameter_um
            out["radial"][j] = half * (r * np.cos(theta))
            out["angular"][j] = half * (r * np.sin(theta)) / a
        if s.pin_radius_um is not None:
            out["pin_radius"][j] = standard(s.pin_radius_um, gen(k, smp._PIN_RADIUS), pins)
        if s.eccentricity_um is not None:
            out["eccentricity"][j] = standard(s.eccentricity_um, gen(k, smp._ECCENTRICITY), 1)[0]
        for name, kind in (
            ("hole_radial_um", smp._HOLE_RADIAL),
            ("hole_tangential_um", smp._HOLE_TANGENTIAL),
        ):
            if holes and getattr(s, name) is not None:
                size = holes[0] * holes[1]
                out[name][j] = standard(getattr(s, name), gen(k, kind), size).reshape(holes)
    return out


@pytest.mark.parametrize("seed", [0, 11, 2**32 - 1, 2**40 + 5, 2**70 + 3])
@pytest.mark.parametrize(
    "kinds",
    [
        {
            "radial_um": UNIFORM,
            "angular_urad": {"distribution": "uniform", "half_range": 50.0},
            "pin_radius_um": {"distribution": "normal", "sigma": 1.0},
            "eccentricity_um": {"distribution": "uniform", "half_range": 2.0},
            "hole_radial_um": UNIFORM,
            "hole_tangential_um": {"distribution": "normal", "sigma": 2.0},
        },
        {
            "position": {"distribution": "true_position", "zone_diameter_um": 8.0},
            "pin_radius_um": {"distribution": "uniform", "half_range": 1.5},
            "eccentricity_um": {"distribution": "normal", "sigma": 1.0},
            "hole_tangential_um": UNIFORM,
        },
        {"tangential_um": UNIFORM, "radial_um": {"distribution": "normal", "sigma": 2.0}},
    ],
)
def test_batched_draws_are_the_per_ring_generators_bit_for_bit(seed, kinds):
    """Every number of a batch's draws is that of the ring's own NumPy generators (the
    reproducibility contract of the module doc), for large seeds and ring indices too."""
    s = spec(**kinds).model_copy(update={"seed": seed})
    for rings in ([0, 1, 2, 3, 17, 2**31, 2**32 - 1], [5, 2**32, 2**33 + 1], []):
        got = draw_ring_errors(s, 40, A_M, rings, holes=(2, 3))
        ref = _per_ring(s, 40, A_M, rings, holes=(2, 3))
        for name, value in (
            ("radial", got.radial_um),
            ("angular", got.angular_urad),
            ("pin_radius", got.pin_radius_um),
            ("eccentricity", got.eccentricity_um),
            ("hole_radial_um", got.hole_radial_um),
            ("hole_tangential_um", got.hole_tangential_um),
        ):
            np.testing.assert_array_equal(value, ref[name], strict=True, err_msg=name)


def _generator(seed, ring, kind):
    """Ring ``ring``'s stream of error kind ``kind``, as NumPy builds it for one ring."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, ring, kind])))


@pytest.mark.parametrize("seed", [0, 1, 20220810, 2**32 + 5, 2**63 - 1])
def test_uniform_streams_are_numpys_generators_bit_for_bit(seed):
    """All rings' streams at once equal a NumPy generator per ring, at the ends of the
    ring range too (k = 0, 2**32 − 1) and for seeds of one and two 32-bit words."""
    from cyclomesh.tolerance.sampling import uniform_streams

    rings = np.array([0, 1, 2, 7, 999_999, 2**31, 2**32 - 1, 3])
    for kind in (1, 2, 5, 8):
        got = uniform_streams(seed, rings, kind, 81)
        want = np.array([_generator(seed, int(k), kind).random(81) for k in rings])
        np.testing.assert_array_equal(got, want, strict=True)
    assert uniform_streams(seed, np.array([], dtype=np.int64), 1, 4).shape == (0, 4)
    with pytest.raises(ValueError, match="2\\*\\*32"):
        uniform_streams(seed, [2**32], 1, 4)


def test_drawn_errors_are_each_rings_own_generator_draws():
    """draw_ring_errors (all rings' uniform streams at once) gives every ring the draws of
    its own generators: U(−1, 1)·half range, N(0, 1)·σ, the unit disc of the true
    position, and rings beyond 2**32 (one generator per ring) too."""
    from cyclomesh.tolerance.sampling import unit_disc

    seed = 20220810
    s = spec(
        radial_um=UNIFORM,
        angular_urad={"distribution": "uniform", "half_range": 50.0},
        pin_radius_um={"distribution": "normal", "sigma": 1.0},
        eccentricity_um={"distribution": "uniform", "half_range": 2.0},
    ).model_copy(update={"seed": seed})
    rings = [0, 5, 123_456, 2**32 + 1]
    got = draw_ring_errors(s, 40, A_M, rings)
    for j, k in enumerate(rings):
        np.testing.assert_array_equal(
            got.radial_um[j], _generator(seed, k, 1).uniform(-1.0, 1.0, 40) * 4.0
        )
        np.testing.assert_array_equal(
            got.angular_urad[j], _generator(seed, k, 2).uniform(-1.0, 1.0, 40) * 50.0
        )
        np.testing.assert_array_equal(
            got.pin_radius_um[j], _generator(seed, k, 3).standard_normal(40) * 1.0
        )
        assert got.eccentricity_um[j] == _generator(seed, k, 4).uniform(-1.0, 1.0, 1)[0] * 2.0
    zone = spec(position={"distribution": "true_position", "zone_diameter_um": 8.0})
    got = draw_ring_errors(zone, 40, A_M, rings)
    for j, k in enumerate(rings):
        x, y = unit_disc(_generator(11, k, 5), 40)
        np.testing.assert_array_equal(got.radial_um[j], 4.0 * x)
        np.testing.assert_array_equal(got.angular_urad[j], 4.0 * y / A_M)
