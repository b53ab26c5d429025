"""Profile geometry and its modification (Eqs. 1-4 of Li et al., Machines 2022)."""

import dataclasses

import numpy as np
import pytest

from cyclomesh import TABLE1, DesignError, Modification, PairDesign
from cyclomesh.core.profile import check_profile, curvature_radius, modified_profile

MODIFICATIONS = [
    Modification(),
    Modification(pin_radius=8e-6),
    Modification(pin_radius=-5e-6),
    Modification(pin_circle_radius=-10e-6),
    Modification(pin_circle_radius=10e-6),
    Modification(pin_circle_radius=-6e-6, pin_radius=4e-6),
]


@pytest.mark.parametrize("mod", MODIFICATIONS)
def test_eq4_matches_numerical_curvature(mod):
    """Eq. 4 against the curvature of the profile points, by central differences."""
    n2 = TABLE1.teeth
    phi1 = np.linspace(-np.pi + 0.05, np.pi - 0.05, 301)
    h = 1e-4
    x0, y0 = modified_profile(TABLE1, mod, phi1)
    xp, yp = modified_profile(TABLE1, mod, phi1 + h)
    xm, ym = modified_profile(TABLE1, mod, phi1 - h)
    dx, dy = (xp - xm) / (2 * h), (yp - ym) / (2 * h)
    ddx, ddy = (xp - 2 * x0 + xm) / h**2, (yp - 2 * y0 + ym) / h**2
    # counter-clockwise traversal: positive curvature = convex seen from the pins
    kappa = (dx * ddy - dy * ddx) / np.hypot(dx, dy) ** 3
    rho_eq4 = curvature_radius(phi1 / n2, TABLE1, mod)
    # compare curvatures (finite through the inflection points, where ρc → ±∞);
    # |κ| is about 270 1/m at the tip, the difference-quotient error about 1e-3 1/m
    np.testing.assert_allclose(kappa, 1.0 / rho_eq4, rtol=0, atol=0.01)
    assert np.any(kappa < 0) and np.any(kappa > 0)  # both signs were tested


def test_example_curvature_signs():
    """Tooth-space bottom concave (about -3.7 mm), flanks and tip convex (about 4-4.6 mm)."""
    n2 = TABLE1.teeth
    mod = Modification(pin_radius=8e-6)
    root = curvature_radius(0.0, TABLE1, mod)
    tip = curvature_radius(np.pi / n2, TABLE1, mod)
    assert -3.8e-3 < root < -3.6e-3
    assert 4.5e-3 < tip < 4.7e-3


def test_profile_offset_is_exact():
    """Every profile point lies at ρp + Δρ from the modified pin-centre locus."""
    mod = Modification(pin_circle_radius=-3e-6, pin_radius=8e-6)
    n2, n1 = TABLE1.teeth, TABLE1.pins
    a, e = TABLE1.pin_circle_radius + mod.pin_circle_radius, TABLE1.eccentricity
    phi1 = np.linspace(0, 2 * np.pi, 2001)
    x, y = modified_profile(TABLE1, mod, phi1)
    t = np.linspace(0, 2 * np.pi / n2, 200001)
    lx = a * np.cos(t) - e * np.cos(n1 * t)
    ly = a * np.sin(t) - e * np.sin(n1 * t)
    # distance of a few profile points to the sampled locus
    for k in range(0, 2001, 250):
        d = np.min(np.hypot(lx - x[k], ly - y[k]))
        assert d == pytest.approx(TABLE1.pin_radius + mod.pin_radius, abs=2e-9)


def test_undercut_profile_is_refused():
    design = dataclasses.replace(
        TABLE1, eccentricity=1.9e-3, pin_radius=4.5e-3, groove_radius=4.6e-3
    )
    with pytest.raises(DesignError, match="undercut"):
        check_profile(design, Modification())


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"eccentricity": 2.2e-3}, "K1"),
        ({"pin_radius": -1e-3}, "pin_radius"),
        ({"width": 0.0}, "width"),
        ({"pin_radius": 6.5e-3, "groove_radius": 6.6e-3}, "interfere"),
        ({"groove_radius": 3.5e-3}, "groove_radius"),
        ({"pins": 2}, "pins"),
    ],
)
def test_invalid_designs_are_refused(changes, match):
    with pytest.raises(DesignError, match=match):
        dataclasses.replace(TABLE1, **changes)


def test_modification_that_removes_the_pin_radius_is_refused():
    with pytest.raises(DesignError, match="pin_radius"):
        check_profile(TABLE1, Modification(pin_radius=-3.6e-3))


def test_table1_is_the_paper_design():
    assert TABLE1 == PairDesign(40, 82e-3, 3.5e-3, 3.505e-3, 1.5e-3, 12e-3)
    assert TABLE1.teeth == 39
