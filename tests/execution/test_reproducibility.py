"""A ring's result depends only on the ring, never on the rings it was batched with.

Regression of issue 15 (4): ring 3736 of ``examples/tolerance.toml`` came out one ULP
different in ``max_contact_stress_mpa`` with ``--chunk-rings 17`` than with the default,
because the Newton inversion of the contact law (Eq. 20) stopped when the *whole batch*
had converged, giving some elements extra steps. Every iteration now stops per element.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from cyclomesh.core.contact import contact_phase
from cyclomesh.core.hertz import force_from_approach
from cyclomesh.execution.backends import run_chunks
from cyclomesh.studies.rings import CHUNK_BLOCKS, default_chunk
from cyclomesh.studies.tolerance import load_tolerance_study, ring_model
from cyclomesh.tolerance.tasks import AllocationTask, ToleranceTask

EXAMPLE = Path(__file__).parents[2] / "examples" / "tolerance.toml"


def _bitwise(a: dict, b: dict, label: str) -> None:
    assert a.keys() == b.keys()
    for name in a:
        x, y = np.asarray(a[name]), np.asarray(b[name])
        assert x.dtype == y.dtype and x.shape == y.shape, (label, name)
        same = x.view(np.uint8) == y.view(np.uint8)  # bit for bit (NaN payloads, -0.0)
        assert same.all(), f"{label}: {name} differs at rows {np.argwhere(~same)[:3, 0]}"


@pytest.fixture(scope="module")
def model():
    loaded, spec = load_tolerance_study(EXAMPLE)
    return ring_model(loaded, spec)


def test_rings_of_the_reported_case_identical_over_chunkings(model):
    # rings 3728..3751 at 1° hold ring 3736 (the reported one) and ring 3752's neighbours
    task, first, n = ToleranceTask(model), 3728, 24
    default = model.block_rings
    reference = run_chunks(task, n, first=first, chunk_size=n)
    for size in (1, 7, 17, default):
        _bitwise(reference, run_chunks(task, n, first=first, chunk_size=size), f"chunk {size}")


def test_default_chunks_are_whole_core_calls_and_balance_the_workers(model):
    block = model.block_rings
    for n in (1, 5, block, 3 * block + 1, 100 * block, 10**6):
        for workers in (1, 2, 7):
            size = default_chunk(n, model, workers)
            assert 1 <= size <= CHUNK_BLOCKS * block, (n, workers, size)
            assert size <= block or size % block == 0, (n, workers, size)  # no part call
            assert size <= -(-n // (4 * workers)), (n, workers, size)  # 4 chunks a worker
            if n >= 4 * workers * CHUNK_BLOCKS * block:  # a large study: the largest chunks
                assert size == CHUNK_BLOCKS * block


def test_allocation_factors_identical_over_chunkings(model):
    coarse = dataclasses.replace(model, crank_angles_deg=np.arange(0.0, 360.0, 6.0))
    task = AllocationTask(coarse, (0.5, 1.0, 1.5, 2.0), 4, 1900.0)
    reference = run_chunks(task, 20, chunk_size=20)
    for size in (1, 7, 17):
        _bitwise(reference, run_chunks(task, 20, chunk_size=size), f"chunk {size}")


def test_contact_law_inversion_is_elementwise():
    rng = np.random.default_rng(3)
    alpha = rng.uniform(1.5e-10, 2.5e-10, 500)
    gamma = rng.uniform(1e-11, 2e-11, 500)
    delta_max = gamma * np.exp(alpha / gamma - 1.0)  # stiffest point of Eq. 20
    delta = rng.uniform(0.0, 0.9, 500) * delta_max
    batch = force_from_approach(delta, alpha, gamma)
    alone = np.array([force_from_approach(delta[i], alpha[i], gamma[i]) for i in range(500)])
    assert np.array_equal(batch, alone)


def test_contact_phase_is_elementwise():
    rng = np.random.default_rng(4)
    a, e, n1, s = 0.082, 0.0015, 40, 0.0035
    w2 = rng.uniform((a - e + s) ** 2, (a + e + s) ** 2, 300)
    batch = contact_phase(w2, a, e, n1, s)
    for i in range(300):
        alone = contact_phase(w2[i : i + 1], a, e, n1, s)
        for x, y in zip(batch, alone, strict=True):
            assert x[i] == y[0]
