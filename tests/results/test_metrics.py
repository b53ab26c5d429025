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
