"""A Dask cluster that goes away is a one-line ClusterError naming its address, in
seconds: the scheduler killed mid-run, or every worker dead (the run used to wait
forever). Real ``dask scheduler`` and ``dask worker`` processes on loopback."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from cyclomesh.execution.backends import ClusterError, DaskBackend, run_chunks
from cyclomesh.studyfile.schema import ToleranceSection, parse_section

TESTS = Path(__file__).parent
sys.path.insert(0, str(TESTS))
from _tolerance_dummy import DummyTask  # noqa: E402

pytest.importorskip("distributed")
DASK = shutil.which("dask", path=str(Path(sys.executable).parent)) or shutil.which("dask")
SPEC = parse_section(
    ToleranceSection,
    {
        "seed": 7,
        "allowable_contact_stress_mpa": 1090.0,
        "radial_um": {"distribution": "uniform", "half_range": 4.0},
    },
    "tolerance",
)


@pytest.fixture
def cluster(tmp_path):
    if DASK is None:
        pytest.skip("no dask command")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(TESTS), *sys.path]))
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
    file = tmp_path / "scheduler.json"
    scheduler = subprocess.Popen(
        [
            DASK,
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            "0",
            "--no-dashboard",
            "--scheduler-file",
            str(file),
        ],
        **quiet,
    )
    deadline = time.monotonic() + 30
    while not file.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    worker = subprocess.Popen(
        [
            DASK,
            "worker",
            "--no-nanny",
            "--nthreads",
            "1",
            "--no-dashboard",
            "--scheduler-file",
            str(file),
        ],
        **quiet,
    )
    address = json.loads(file.read_text())["address"]
    try:
        yield address, scheduler, worker
    finally:
        for process in (worker, scheduler):
            process.kill()
            process.wait()


def _connect(address: str) -> DaskBackend:
    backend = DaskBackend(address, timeout_s=10.0, no_worker_timeout_s=2.0)
    deadline = time.monotonic() + 30
    while not backend.client.nthreads() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert backend.client.nthreads(), "the worker did not start"
    return backend


def test_all_workers_dead_is_a_timeout_naming_the_address(cluster):
    address, _, worker = cluster
    backend = _connect(address)
    try:
        threading.Timer(1.0, worker.send_signal, (signal.SIGKILL,)).start()
        start = time.perf_counter()
        with pytest.raises(ClusterError, match=f"no Dask worker left at {address}"):
            run_chunks(DummyTask(SPEC, sleep_s=0.3), 200, backend=backend, chunk_size=1)
        assert time.perf_counter() - start < 20
    finally:
        backend.close()


def test_lost_scheduler_is_one_line_naming_the_address(cluster):
    address, scheduler, _ = cluster
    backend = _connect(address)
    try:
        threading.Timer(1.0, scheduler.send_signal, (signal.SIGKILL,)).start()
        start = time.perf_counter()
        with pytest.raises(ClusterError, match=f"at {address}") as caught:
            run_chunks(DummyTask(SPEC, sleep_s=0.3), 200, backend=backend, chunk_size=1)
        assert "\n" not in str(caught.value)
        assert time.perf_counter() - start < 60
    finally:
        backend.close()


def test_lost_scheduler_mid_study_prints_only_the_error_line(cluster, tmp_path):
    """``cyclomesh tolerance --scheduler``: the scheduler killed once the study computes
    (its staging folder exists): exit 2 and one line on stderr, no logged tracebacks."""
    address, scheduler, _ = cluster
    examples = TESTS.parents[1] / "examples"
    text = (examples / "tolerance.toml").read_text().replace("rings = 1000", "rings = 400")
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "cyclomesh", "tolerance", "s.toml", "--out", str(out), "-q"]
        + ["--figures", "none", "--scheduler", address, "--chunk-rings", "1"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    while not (out / ".cyclomesh.staging").exists() and process.poll() is None:
        time.sleep(0.01)  # polls an observable state; no timing is asserted
    scheduler.kill()
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 2, stderr
    assert stderr.count("\n") == 1 and stderr.startswith("error: "), stderr
    assert address in stderr and not out.exists()
