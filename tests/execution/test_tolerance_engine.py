"""The chunked Monte Carlo engine: reproducible across chunkings and backends, no ring lost.

These tests use a cheap chunk function (tests/execution/_tolerance_dummy.py) that depends only on
the sampled errors, so they run without the numerical core.
"""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

from cyclomesh.execution.backends import (
    ClusterError,
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    chunk_bounds,
    run_chunks,
)
from cyclomesh.studyfile.schema import ToleranceSection, parse_section

sys.path.insert(0, str(Path(__file__).parent))
from _tolerance_dummy import DummyTask  # noqa: E402

SPEC = parse_section(
    ToleranceSection,
    {
        "seed": 7,
        "allowable_contact_stress_mpa": 1090.0,
        "radial_um": {"distribution": "uniform", "half_range": 4.0},
        "angular_urad": {"distribution": "normal", "sigma": 20.0},
    },
    "tolerance",
)


def _same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for name in a:
        if name == "pid":
            continue
        np.testing.assert_array_equal(a[name], b[name], err_msg=name, strict=True)


def test_chunk_bounds_cover_every_ring_once():
    chunks = chunk_bounds(10, 3, first=5)
    assert chunks == [(5, 8), (8, 11), (11, 14), (14, 15)]


@pytest.mark.parametrize("chunk_rings", [1, 3, 7, 50])
def test_serial_results_independent_of_chunking(chunk_rings):
    task = DummyTask(SPEC)
    reference = run_chunks(task, 23, chunk_size=23)
    _same(reference, run_chunks(task, 23, chunk_size=chunk_rings))
    np.testing.assert_array_equal(reference["ring"], np.arange(23))


def test_first_ring_offset_gives_the_same_rings():
    task = DummyTask(SPEC)
    whole = run_chunks(task, 20, chunk_size=6)
    tail = run_chunks(task, 8, chunk_size=3, first=12)
    for name in ("ring", "max_contact_stress_mpa", "radial_um"):
        np.testing.assert_array_equal(whole[name][12:], tail[name])


def test_process_pool_is_bit_for_bit_serial():
    task = DummyTask(SPEC)
    reference = run_chunks(task, 30, chunk_size=4)
    backend = ProcessBackend(workers=2, in_flight_per_worker=1)
    try:
        calls = []
        got = run_chunks(task, 30, chunk_size=7, backend=backend, progress=calls.append)
    finally:
        backend.close()
    _same(reference, got)
    assert sum(calls) == 30
    assert os.getpid() not in set(got["pid"].tolist())


def test_killing_a_local_worker_loses_no_ring_and_counts_none_twice():
    task = DummyTask(SPEC, sleep_s=0.1)
    rings, chunk = 30, 2
    reference = run_chunks(DummyTask(SPEC), rings, chunk_size=chunk)
    backend = ProcessBackend(workers=2, in_flight_per_worker=1)
    finished = []

    def kill_after_a_few(done: int) -> None:
        finished.append(done)
        if len(finished) == 3:
            os.kill(backend.worker_pids()[0], signal.SIGKILL)

    try:
        got = run_chunks(task, rings, chunk_size=chunk, backend=backend, progress=kill_after_a_few)
    finally:
        backend.close()
    assert backend.restarts == 1
    assert sum(finished) == rings  # each chunk reported once
    _same(reference, got)  # and stored once (run_chunks checks the ring counts too)


def test_dask_cluster_is_bit_for_bit_serial(cluster):
    local, _ = cluster
    task = DummyTask(SPEC)
    reference = run_chunks(task, 30, chunk_size=4)
    backend = DaskBackend(local.scheduler_address)
    try:
        got = run_chunks(task, 30, chunk_size=5, backend=backend)
    finally:
        backend.close()
    _same(reference, got)
    assert len(set(got["pid"].tolist())) == 2  # both workers took part


def test_killing_a_worker_loses_no_ring_and_counts_none_twice(cluster):
    _, client = cluster
    task = DummyTask(SPEC, sleep_s=0.15)
    rings, chunk = 40, 2
    reference = run_chunks(DummyTask(SPEC), rings, chunk_size=chunk)
    pids = client.run(os.getpid)
    victim = sorted(pids.values())[0]
    finished = []

    def kill_after_a_few(done: int) -> None:
        finished.append(done)
        if len(finished) == 4:
            os.kill(victim, signal.SIGKILL)

    backend = DaskBackend(client=client)
    got = run_chunks(task, rings, chunk_size=chunk, backend=backend, progress=kill_after_a_few)
    assert sum(finished) == rings  # each chunk reported once
    _same(reference, got)  # and stored once (run_chunks checks the ring counts too)
    assert victim in set(got["pid"].tolist())  # the victim did some work before dying
    client.wait_for_workers(2, timeout=30)


def test_unreachable_scheduler_is_a_one_line_cluster_error():
    pytest.importorskip("distributed")
    with pytest.raises(ClusterError, match=r"cannot reach the Dask scheduler.*127\.0\.0\.1:9"):
        DaskBackend("tcp://127.0.0.1:9", timeout_s=1.0)


def test_serial_backend_is_the_default():
    assert SerialBackend().workers == 1
