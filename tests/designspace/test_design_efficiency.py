"""Efficiency in design maps: metric, objective (maximised) and min_efficiency."""

import numpy as np
import pytest

from cyclomesh import TABLE1, PinErrors
from cyclomesh.core.friction import Friction
from cyclomesh.designspace.sweep import Constraints, design_map
from cyclomesh.exceptions import DesignError

AXES = {"pin_radius_um": [4.0, 8.0, 12.0]}
ANGLES = np.arange(0.0, 9.0, 3.0)
FRICTION = Friction(mesh=0.1, groove=0.1, bearing=0.0025, bearing_diameter=0.04)


def test_efficiency_metric_objective_and_constraint():
    ds = design_map(
        TABLE1,
        AXES,
        torque=250.0,
        crank_angles_deg=ANGLES,
        friction=FRICTION,
        objective="efficiency",
    )
    eff = ds["efficiency"].values
    assert np.all((eff > 0.8) & (eff < 1.0))
    np.testing.assert_allclose(ds["loss_fraction"].values, 1.0 - eff, rtol=1e-12)
    best = float(ds.attrs["optimum_pin_radius_um"])
    assert best == AXES["pin_radius_um"][int(np.argmax(eff))]
    # the frictionless metrics are those of the map without friction, bit for bit
    plain = design_map(TABLE1, AXES, torque=250.0, crank_angles_deg=ANGLES)
    np.testing.assert_array_equal(ds["max_contact_stress_mpa"], plain["max_contact_stress_mpa"])
    assert "efficiency" not in plain
    limit = float(np.sort(eff)[1])  # two of three meet it
    ds = design_map(
        TABLE1,
        AXES,
        torque=250.0,
        crank_angles_deg=ANGLES,
        friction=FRICTION,
        constraints=Constraints(min_efficiency=limit),
    )
    assert int(ds["feasible"].sum()) == 2


def test_robust_map_takes_the_low_percentile_of_efficiency():
    rng = np.random.default_rng(2)
    errors = PinErrors(radial=rng.uniform(-3e-6, 3e-6, (4, TABLE1.pins)))
    ds = design_map(
        TABLE1,
        {"pin_radius_um": [8.0, 10.0]},
        errors=errors,
        torque=250.0,
        crank_angles_deg=ANGLES,
        friction=FRICTION,
    )
    assert np.all(np.isfinite(ds["efficiency"].values))


def test_efficiency_needs_friction():
    with pytest.raises(DesignError, match="need friction"):
        design_map(TABLE1, AXES, torque=250.0, crank_angles_deg=ANGLES, objective="efficiency")
