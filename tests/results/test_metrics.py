"""The one metrics table: every summary carries exactly its metrics, computed one way."""

import numpy as np

from cyclomesh import TABLE1, Modification, PinErrors, solve_ltca, summarize, to_dataset
from cyclomesh.results.dataset import ltca_metrics
from cyclomesh.results.metrics import METRICS


def test_core_metrics_equal_the_dataset_summary_bit_for_bit():
    rng = np.random.default_rng(3)
    errors = PinErrors(radial=rng.uniform(-4e-6, 4e-6, (3, 40)))  # three rings at once
    angles = np.deg2rad(np.arange(0.0, 360.0, 5.0))
    modification = Modification(pin_radius=8e-6)
    result = solve_ltca(TABLE1, modification, errors, 250.0, angles)
    direct = ltca_metrics(result, TABLE1.teeth)
    summary = summarize(to_dataset(result, TABLE1, modification, 250.0, True))
    assert list(direct) == list(METRICS) == list(summary.data_vars)
    for name, metric in METRICS.items():
        assert direct[name].shape == (3,), name
        np.testing.assert_array_equal(direct[name], summary[name].values, err_msg=name)
        assert summary[name].attrs == {"units": metric.unit, "long_name": metric.long_name}
        assert metric.unit in ("1", "%") or name.endswith(
            {"arcsec": "_arcsec", "N": "_n", "MPa": "_mpa"}[metric.unit]
        ), name  # names carry their unit
    # the rings differ, and each ring's metrics are its own (a one-ring solve agrees)
    assert len(set(direct["max_contact_stress_mpa"].tolist())) == 3
    one = solve_ltca(TABLE1, modification, PinErrors(radial=errors.radial[1]), 250.0, angles)
    single = ltca_metrics(one, TABLE1.teeth)
    for name in METRICS:
        assert single[name] == direct[name][1], name


def test_drive_metrics_reduce_the_scaled_fields_bit_for_bit():
    """drive_metrics takes each crank angle's largest pin value before the unit scale
    (max(s·x) = s·max(x) for s > 0); the same bits as scaling every pin first."""
    from cyclomesh.drive.solve import solve_drive
    from cyclomesh.quantities import QUANTITIES
    from cyclomesh.results.dataset import drive_metrics

    rng = np.random.default_rng(8)
    errors = PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, (3, 40)), angular=rng.uniform(-5e-5, 5e-5, (3, 40))
    )
    angles = np.deg2rad(np.arange(0.0, 360.0, 10.0))
    result = solve_drive(TABLE1, Modification(pin_radius=8e-6), errors, 250.0, angles, discs=2)
    got = drive_metrics(result, TABLE1.teeth)
    for name, metric in METRICS.items():
        source, how = metric.reduce
        if QUANTITIES[source].dims != ("crank_angle", "pin"):
            continue
        scaled = getattr(result, source)[:, 0] * QUANTITIES[source].scale  # (3, A, 2, 40)
        want = (np.min if how == "min" else np.max)(scaled, axis=(-3, -2, -1))
        np.testing.assert_array_equal(got[name], want > 0 if how == "positive" else want)
