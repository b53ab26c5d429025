"""Every failure of issue 15's trial is a one-line error with exit status 2, in seconds.

Each test generates a small bad case from an example study file (or a fault), runs the
command in-process (Typer's CliRunner) and checks: exit 2, one line ``error: ...``
naming the key or path and the bound, and nothing written to ``--out``. The cases that
used to blow the memory or hang run under a time limit (and ``crank_step_deg = 1e-9``
under an address-space limit, in a subprocess).
"""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.output.writers import toml_dumps

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def set_key(raw: dict, dotted: str, value: Any) -> None:
    *path, last = dotted.split(".")
    node = raw
    for part in path:
        node = node.setdefault(part, {})
    node[last] = value


def study(tmp_path: Path, example: str, changes: dict[str, Any] | None = None) -> Path:
    """The example with ``changes`` (dotted keys; a value None deletes the key)."""
    raw = tomllib.loads((EXAMPLES / f"{example}.toml").read_text())
    for dotted, value in (changes or {}).items():
        if value is None:
            *path, last = dotted.split(".")
            node = raw
            for part in path:
                node = node[part]
            node.pop(last)
        else:
            set_key(raw, dotted, value)
    shutil.copy(EXAMPLES / "measured_pins.csv", tmp_path / "measured_pins.csv")
    path = tmp_path / "study.toml"
    path.write_text(toml_dumps(raw), encoding="utf-8")
    return path


def invoke(*args: Any):
    return CliRunner().invoke(app, [str(a) for a in args])


def refused(result, *words: str, out: Path | None = None) -> str:
    """Exit 2, one line ``error: ...`` containing ``words``, nothing written to ``out``."""
    assert result.exit_code == 2, (result.exit_code, result.output, result.exception)
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    assert "internal error" not in lines[0], lines[0]
    for word in words:
        assert word in lines[0], (word, lines[0])
    if out is not None:
        assert not out.exists(), sorted(out.rglob("*"))
    return lines[0]


# --- 3: physically impossible input -----------------------------------------------------


@pytest.mark.parametrize(
    "example, key, value, words",
    [
        ("table2", "errors.eccentricity_um", -1500.0, ["errors.eccentricity_um", "750"]),
        ("table2", "modification.rotation_urad", 1e6, ["rotation_urad", "16110"]),
        ("table2", "material.youngs_modulus_gpa", 206e9, ["youngs_modulus_gpa", "1200"]),
        ("table2", "material.poisson_ratio", -0.999, ["poisson_ratio", "0"]),
        ("table2", "errors.angular_urad", 1e6, ["angular_urad", "16110"]),
        ("table2", "errors.radial_um", -5000.0, ["radial_um", "3500"]),
        ("table2", "design.eccentricity_mm", 1e300, ["K1", "e+"]),
    ],
)
def test_impossible_physics_is_refused(tmp_path, example, key, value, words):
    path = study(tmp_path, example, {key: value})
    for command in ("check", "run"):
        out = tmp_path / "out"
        args = ["--out", out, "--figures", "none", "-q"] if command == "run" else []
        refused(invoke(command, path, *args), *words, out=out if command == "run" else None)


# --- 5 and 6: tracebacks, memory and hangs ---------------------------------------------


BOUNDED = [
    ("table2", {"analysis.crank_step_deg": 1e-9}, "check", ["crank_step_deg", "0.0001"]),
    ("table2", {"analysis.crank_step_deg": 1e-5}, "run", ["crank_step_deg", "0.0001"]),
    ("table2", {"analysis.crank_start_deg": -1e300}, "check", ["crank_start_deg", "36000"]),
    (
        "stiffness",
        {"analysis.crank_step_deg": 0.1},
        "stiffness",
        ["pin-steps", "--no-work-limit", "crank_step_deg"],
    ),
    ("tolerance", {"tolerance.crank_step_deg": 0.00036}, "tolerance", ["crank_step_deg"]),
    ("tolerance", {"tolerance.rings": 10**15}, "tolerance", ["rings", "10000000"]),
    ("table2", {"design.discs": 1000000}, "run", ["design.discs", "8"]),
    ("table2", {"design.discs": 100}, "check", ["design.discs", "8"]),
    (
        "design",
        {
            "design_space.pin_circle_radius_um.points": 1001,
            "design_space.pin_radius_um.points": 1001,
            "design_space.rotation_urad": {"start": 0.0, "stop": 10.0, "points": 1001},
        },
        "design",
        ["candidates", "100000"],
    ),
    ("design", {"load.torque_nm": [-250.0, 250.0]}, "design", ["load.torque_nm", "one torque"]),
    ("stiffness", {"stiffness.points": 10**7}, "stiffness", ["stiffness.points", "1001"]),
    ("fe_table1", {"fe.far_size_mm": 1e-300}, "check", ["fe.far_size_mm", "0.2"]),
    ("fe_table1", {"fe.bore_radius_mm": 78.0}, "check", ["fe.bore_radius_mm", "61.6"]),
    ("fe_table1", {"fe.crank_angles_deg": [1e300]}, "check", ["crank_angles_deg", "36000"]),
    ("table2", {"cases": [{"name": "a", "design": {"pins": 10**6}}]}, "check", ["pins", "400"]),
]


@pytest.mark.parametrize("example, changes, command, words", BOUNDED)
def test_bounds_are_one_line_errors_in_seconds(tmp_path, example, changes, command, words):
    path = study(tmp_path, example, changes)
    out = tmp_path / "out"
    args = [] if command == "check" else ["--out", out, "--figures", "none", "-q"]
    start = time.perf_counter()
    refused(invoke(command, path, *args), *words, out=out)
    assert time.perf_counter() - start < 10


def test_work_limit_can_be_lifted(tmp_path):
    path = study(tmp_path, "tolerance", {"tolerance.rings": 10**7})
    refused(invoke("check", path), "pin-steps", "--no-work-limit")
    result = invoke("check", path, "--no-work-limit")
    assert result.exit_code == 0, result.output


def test_validator_does_not_allocate_what_it_validates(tmp_path):
    """``crank_step_deg = 1e-9`` used to build a 2.6 TiB arange in ``check``: under a
    1 GiB address-space limit it must still be a one-line error."""
    path = study(tmp_path, "table2", {"analysis.crank_step_deg": 1e-9})
    code = textwrap.dedent(
        f"""
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))
        from typer.testing import CliRunner
        from cyclomesh.cli import app
        r = CliRunner().invoke(app, ["check", {str(path)!r}])
        print(r.exit_code, r.output.strip())
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.stdout.startswith("2 error: analysis.crank_step_deg"), done.stdout + done.stderr


def test_deep_nesting_is_one_line(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text(
        (EXAMPLES / "table2.toml").read_text() + "\n[extra]\nx = " + "[" * 5000 + "]" * 5000
    )
    for command in ("check", "run"):
        refused(invoke(command, path, *(["--out", tmp_path / "o"] if command == "run" else [])))


def test_fe_crank_angle_flag_is_bounded(tmp_path):
    pytest.importorskip("skfem")
    pytest.importorskip("gmsh")
    out = tmp_path / "out"
    result = invoke("fe", EXAMPLES / "fe_table1.toml", "--out", out, "--crank-angles", "1e300")
    refused(result, "--crank-angles", "36000", out=out)


@pytest.mark.parametrize("kind", ["fifo", "device", "folder", "huge"])
@pytest.mark.parametrize("which", ["study", "csv"])
def test_only_regular_files_of_bounded_size_are_read(tmp_path, kind, which):
    target = tmp_path / "target"
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "device":
        target = Path("/dev/zero")
    elif kind == "folder":
        target.mkdir()
    else:
        with open(target, "wb") as fh:
            fh.truncate(128 << 20)  # sparse: no disk used
    if which == "study":
        path = target
    else:
        path = study(tmp_path, "measured")
        path.write_text(path.read_text().replace("measured_pins.csv", str(target)))
    start = time.perf_counter()
    line = refused(invoke("check", path))
    assert time.perf_counter() - start < 5
    assert "regular file" in line or "limit" in line


def test_too_many_workers_is_refused(tmp_path):
    out = tmp_path / "out"
    result = invoke("tolerance", EXAMPLES / "tolerance.toml", "--out", out, "--workers", 1000)
    refused(result, "--workers 1000", out=out)


def test_garbage_scheduler_is_refused_at_once(tmp_path):
    pytest.importorskip("distributed")
    out = tmp_path / "out"
    start = time.perf_counter()
    result = invoke(
        "tolerance", EXAMPLES / "tolerance.toml", "--out", out, "--scheduler", "garbage"
    )
    refused(result, "--scheduler", "tcp://HOST:PORT", out=out)
    assert time.perf_counter() - start < 3


@pytest.mark.parametrize("flags", [["--no-such-flag"], ["--rings", "many"], []])
def test_usage_errors_are_one_line(tmp_path, flags):
    args = ["tolerance", *flags] if flags else ["run", EXAMPLES / "table2.toml"]
    refused(invoke(*args))


# --- 9 to 11: small designs, names, messages ---------------------------------------------


SMALL = {
    "design.pins": 10,
    "design.pin_circle_radius_mm": 40.0,
    "design.pin_radius_mm": 3.0,
    "design.groove_radius_mm": 3.005,
    "design.eccentricity_mm": 1.5,
    "figures.stress_pin": None,
    "cases": [{"name": "small"}],
}


def test_designs_with_fewer_than_20_pins_run(tmp_path):
    path = study(tmp_path, "table2", SMALL)
    out = tmp_path / "out"
    result = invoke("run", path, "--out", out, "--crank-step-deg", "5", "-q", "--figures", "all")
    assert result.exit_code == 0, result.output
    assert (out / "figures" / "profile_stress.png").exists()


def test_hostile_case_names_and_titles(tmp_path):
    """A case name that is bad mathtext, a title with DEL: figures drawn, and the
    worst ring written as a study file reads back."""
    name = "$x^{$ \\u007f"
    path = study(
        tmp_path,
        "tolerance",
        {"title": "t\x7fitle $x^{$", "tolerance.rings": 4, "tolerance.crank_step_deg": 10.0},
    )
    out = tmp_path / "tol"
    result = invoke("tolerance", path, "--out", out, "--workers", 1, "-q")
    assert result.exit_code == 0, result.output
    assert invoke("check", out / "worst_ring.toml").exit_code == 0
    path = study(tmp_path, "table2", {"cases": [{"name": name}, {"name": "b\x7f"}]})
    out = tmp_path / "run"
    result = invoke("run", path, "--out", out, "--crank-step-deg", "10", "-q", "--figures", "all")
    assert result.exit_code == 0, result.output
    assert len(list((out / "figures").glob("*.png"))) >= 5


def test_k1_is_printed_with_few_digits(tmp_path):
    path = study(tmp_path, "table2", {"design.eccentricity_mm": 1e200})
    line = refused(invoke("check", path))
    assert len(line) < 300 and "1e+201" in line or "e+" in line


def test_core_error_names_the_case(tmp_path):
    path = study(tmp_path, "table2", {"cases": [{"name": "jam", "errors": {"radial_um": -3400.0}}]})
    out = tmp_path / "out"
    line = refused(invoke("run", path, "--out", out, "--figures", "none"), out=out)
    assert 'case "jam"' in line


# --- 8: pool workers die with their parent -------------------------------------------------


@pytest.mark.parametrize("pool", ["ProcessBackend", "FigurePool", "FigureProcess"])
def test_pool_workers_die_with_their_parent(pool):
    code = textwrap.dedent(
        f"""
        import os, sys, time
        if {pool!r} == "ProcessBackend":
            from cyclomesh.execution.backends import ProcessBackend
            backend = ProcessBackend(2)
            backend.start()
            pids = backend.worker_pids()
        elif {pool!r} == "FigureProcess":  # the overview's, forked as a run starts
            from cyclomesh.figures.worker import FigureProcess
            p = FigureProcess()
            pids = [p._pid] if p.active else []
        else:
            from cyclomesh.figures.render import FigurePool
            p = FigurePool(2)
            p._pool.submit(os.getpid).result()
            pids = list(p._pool._processes)
        print(" ".join(map(str, pids)), flush=True)
        time.sleep(60)
        """
    )
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in parent.stdout.readline().split()]
        assert pids
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 10
    alive = pids
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = [pid for pid in pids if _alive(pid)]
    assert not alive, f"orphaned workers {alive}"


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


# --- 7: figure memory does not grow with the rings -----------------------------------------


def test_tolerance_figures_get_reduced_statistics_only():
    import pickle

    import xarray as xr

    from cyclomesh.figures.tolerance import reduce_rings
    from cyclomesh.results.metrics import STRESS_METRIC

    def rings(n: int) -> xr.Dataset:
        rng = np.random.default_rng(0)
        return xr.Dataset(
            {
                STRESS_METRIC: ("ring", rng.normal(1800, 100, n)),
                "te_pp_arcsec": ("ring", rng.normal(10, 1, n)),
                "min_contacts": ("ring", rng.integers(5, 9, n)),
            },
            coords={"ring": np.arange(n)},
        )

    small = len(pickle.dumps(reduce_rings(rings(5_000), 2000.0)))
    large = len(pickle.dumps(reduce_rings(rings(500_000), 2000.0)))
    assert large < 1.1 * small < 200_000


def test_memory_limit_subprocess_guard():
    """The address-space limit used above is available (else that test proves nothing)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    assert hard == resource.RLIM_INFINITY or hard >= 1 << 30
