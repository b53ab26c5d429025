"""Unsolved rings on every backend: the local process pool and a Dask cluster carry each
ring's ``unsolved`` flag and the solver's message back, bit for bit the serial run's.

The failing rings come from :class:`_unsolvable.UnsolvableRings`, a ring model whose mesh
solve raises :class:`~cyclomesh.exceptions.ConvergenceError` for chosen rings: it travels
to the worker processes with the task and they import it from tests/execution (on their
``sys.path`` as on this process's, like the engine tests' ``_tolerance_dummy``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1] / "studies"))
from _unsolvable import MESSAGE, UnsolvableRings  # noqa: E402
from test_tolerance_study import write_study  # noqa: E402

from cyclomesh.execution.backends import DaskBackend, ProcessBackend, SerialBackend  # noqa: E402
from cyclomesh.studies import allocate, tolerance  # noqa: E402

FAIL = (2, 9)


def _unsolvable(monkeypatch, module) -> None:
    original = module.ring_model
    monkeypatch.setattr(
        module, "ring_model", lambda *a, **k: UnsolvableRings.of(original(*a, **k), FAIL)
    )


def _same(a, b) -> None:
    assert list(a.data_vars) == list(b.data_vars)
    for name in a.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name, strict=True)


@pytest.mark.parametrize("study_kind", ["tolerance", "allocate"])
def test_unsolved_rings_are_the_same_on_every_backend(tmp_path, monkeypatch, cluster, study_kind):
    local, _ = cluster
    study = tolerance.load_tolerance_study(write_study(tmp_path))[0]
    module = tolerance if study_kind == "tolerance" else allocate
    _unsolvable(monkeypatch, module)
    compute = tolerance.compute_tolerance if module is tolerance else allocate.compute_allocation
    backends = {
        "serial": (SerialBackend(), 12),
        "2 processes": (ProcessBackend(workers=2), 1),
        "Dask": (DaskBackend(local.scheduler_address), 5),
    }
    rings = {}
    try:
        for name, (backend, chunk) in backends.items():
            rings[name] = compute(study, backend=backend, chunk_rings=chunk).rings
    finally:
        for backend, _ in backends.values():
            backend.close()
    reference = rings.pop("serial")
    unsolved = reference["unsolved"].values.astype(bool)
    assert reference["ring"].values[unsolved].tolist() == list(FAIL)
    reasons = reference["unsolved_reason"].values[unsolved].tolist()
    assert all(r.endswith(MESSAGE) for r in reasons)
    assert np.all(np.isnan(reference["max_contact_stress_mpa"].values[unsolved]))
    for name, ds in rings.items():
        _same(reference, ds), name
