"""Result folders that cannot be lost or misread (issue 15, items 1, 2 and disk full).

Every result file is written to a temporary name and renamed into place, in a staging
folder moved into ``--out`` only once complete; ``summary.json`` is the completion
marker, written last; ``--out`` is locked while a command runs;
:func:`cyclomesh.load_results` refuses an incomplete folder.
"""

from __future__ import annotations

import errno
import json
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

import cyclomesh
from cyclomesh.cli import app
from cyclomesh.exceptions import OutputError
from cyclomesh.output.folder import LOCK, MARKER, ResultFolder, load_results
from cyclomesh.output.writers import jsonable

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
QUICK = ("--crank-step-deg", "10", "--figures", "none", "-q")


def run(out: Path, *more: str):
    return CliRunner().invoke(app, ["run", str(EXAMPLES / "table2.toml"), "--out", str(out), *more])


def one_line_error(result) -> str:
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    return lines[0]


def test_marker_written_last_lists_every_file(tmp_path):
    out = tmp_path / "out"
    assert run(out, *QUICK).exit_code == 0
    marker = json.loads((out / MARKER).read_text())
    assert marker["status"] == "complete" and marker["command"] == "run"
    listed = {f["path"] for f in marker["files"]}
    on_disk = {
        p.relative_to(out).as_posix()
        for p in out.rglob("*")
        if p.is_file() and p.name not in (MARKER, LOCK)
    }
    assert listed == on_disk and "Case_1/results.nc" in listed
    assert not list(out.rglob("*.tmp"))
    results = cyclomesh.load_results(out)
    ds = results.dataset("Case_1/results.nc")
    assert np.isfinite(ds["pin_load"].values).all()
    assert results.summary["cases"][0]["name"] == "Case 1"


def test_load_results_refuses_incomplete_or_changed_folders(tmp_path):
    out = tmp_path / "out"
    assert run(out, *QUICK).exit_code == 0
    nc = out / "Case_2" / "results.nc"
    nc.write_bytes(nc.read_bytes()[:1000])  # a truncated file under the final name
    with pytest.raises(OutputError, match="changed"):
        load_results(out)
    (out / MARKER).unlink()
    with pytest.raises(OutputError, match="did not finish"):
        load_results(out)


def test_failed_run_keeps_the_earlier_result(tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert run(out, *QUICK).exit_code == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != LOCK}
    from cyclomesh.studies import run as kind

    def broken(*args, **kwargs):
        raise cyclomesh.ConvergenceError("injected failure")

    monkeypatch.setattr(kind, "compute_run", broken)
    assert "injected failure" in one_line_error(run(out, *QUICK))
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != LOCK}
    assert after == before  # the old result is still there, byte for byte
    load_results(out)


def test_failed_run_into_a_new_folder_writes_nothing(tmp_path, monkeypatch):
    from cyclomesh.studies import run as kind

    def broken(*args, **kwargs):
        raise cyclomesh.ConvergenceError("injected failure")

    monkeypatch.setattr(kind, "compute_run", broken)
    out = tmp_path / "new" / "out"
    one_line_error(run(out, *QUICK))
    assert not out.exists()


@pytest.mark.parametrize("target", ["netcdf", "parquet", "text"])
def test_disk_full_is_one_line_naming_the_path(tmp_path, monkeypatch, target):
    """A writer failing with ENOSPC (as on a full disk) midway: one line, exit 2, no
    partial file under a final name, no temporary file, no marker."""
    import netCDF4

    from cyclomesh.output import writers

    def full(*args, **kwargs):
        path = next(a for a in args if isinstance(a, str | Path))
        Path(path).write_bytes(b"\0" * 100)  # a partial file
        raise OSError(errno.ENOSPC, "No space left on device")

    if target == "netcdf":

        def hdf_error(path, *args, **kwargs):  # HDF5 reports a full disk as "HDF error"
            Path(path).write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
            raise RuntimeError("NetCDF: HDF error")

        monkeypatch.setattr(netCDF4, "Dataset", hdf_error)
        monkeypatch.setattr("shutil.disk_usage", lambda p: type("U", (), {"free": 0})())
    elif target == "parquet":
        monkeypatch.setattr(writers, "write_parquet_table", lambda table, path: full(path))
    else:  # report.html and the marker
        real_write = Path.write_bytes

        def write_bytes(self, data):
            real_write(self, data[: len(data) // 2])
            if self.name.startswith(".report.html"):
                raise OSError(errno.ENOSPC, "No space left on device")
            return real_write(self, data)

        monkeypatch.setattr(Path, "write_bytes", write_bytes)
    out = tmp_path / "out"
    line = one_line_error(run(out, *QUICK))
    assert "no space left on the device" in line and str(out) in line
    assert not (out / MARKER).exists()
    assert not list(out.rglob("*.tmp"))
    assert not list(out.rglob("results.nc")) or target != "netcdf"


def test_second_command_into_a_locked_folder_fails_at_once(tmp_path):
    out = tmp_path / "out"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(
                f"""
                import sys, time
                from cyclomesh.output.folder import ResultFolder
                with ResultFolder({str(out)!r}, "run"):
                    print("locked", flush=True)
                    time.sleep(30)
                """
            ),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        start = time.perf_counter()
        line = one_line_error(run(out, *QUICK))
        assert time.perf_counter() - start < 5
        assert f"PID {holder.pid}" in line and "in use" in line
        assert not (out / "Case_1").exists()
    finally:
        holder.kill()
        holder.wait()
    assert run(out, *QUICK).exit_code == 0  # the lock dies with its holder


def test_result_folder_keeps_the_marker_for_last(tmp_path):
    from cyclomesh.output.writers import write_json

    with ResultFolder(tmp_path, "test") as folder:
        write_json(folder.path / MARKER, {"answer": 42.0, "bad": float("nan")})
        assert not (folder.path / MARKER).exists() and not (tmp_path / MARKER).exists()
        write_json(folder.path / "other.json", {"x": 1})
        assert folder.marker == folder.path / MARKER
        assert not (tmp_path / "other.json").exists()  # staged until the end
    assert (tmp_path / "other.json").exists() and not folder.path.exists()
    marker = json.loads((tmp_path / MARKER).read_text())
    assert marker["answer"] == 42.0 and marker["bad"] is None
    assert [f["path"] for f in marker["files"]] == ["other.json"]


@pytest.mark.parametrize("steps", [36, 360])
def test_parquet_bytes_as_pyarrow_parquet_writes_them(tmp_path, steps):
    """The Parquet file of a run is byte for byte what ``pyarrow.parquet.write_table``
    (zstd) writes of the same table (the writer of ``pyarrow._parquet`` is called
    directly, without pyarrow's file systems): a NaN column (missing values), integers,
    booleans, field and file metadata."""
    import pyarrow.parquet as pq

    from cyclomesh.output.writers import long_table, write_parquet

    ds = cyclomesh.analyse(
        cyclomesh.TABLE1,
        cyclomesh.Modification(pin_radius=8e-6),
        torque=250.0,
        crank_angles=np.linspace(0.0, 2 * np.pi, steps, endpoint=False),
    )
    ds["backlash"].values[0, :3] = np.inf  # missing values in the table
    write_parquet(ds, tmp_path / "ours.parquet")
    table = long_table(ds)
    attrs = json.dumps(jsonable(dict(ds.attrs)), ensure_ascii=False)
    table = table.replace_schema_metadata({"cyclomesh.attrs": attrs})
    pq.write_table(table, tmp_path / "theirs.parquet", compression="zstd")
    ours = (tmp_path / "ours.parquet").read_bytes()
    assert ours == (tmp_path / "theirs.parquet").read_bytes()
    back = pq.read_table(tmp_path / "ours.parquet")
    assert back.num_rows == steps * 40 and back.column("backlash_arcsec").null_count >= 3
    assert back.schema.field("pin_load_n").metadata[b"units"] == b"N"


def test_netcdf_variables_have_a_fill_value(tmp_path):
    import netCDF4

    from cyclomesh.output.writers import write_netcdf

    ds = xr.Dataset(
        {"load": ("x", np.arange(3.0), {"units": "N"}), "n": ("x", np.arange(3))},
        coords={"x": [1, 2, 3]},
    )
    path = write_netcdf(ds, tmp_path / "a.nc")
    with netCDF4.Dataset(path) as nc:
        assert np.isnan(nc["load"]._FillValue)
        assert nc["n"].filters() is not None and nc["n"].get_fill_value() is not None
    xr.testing.assert_identical(xr.load_dataset(path), ds)


def _wait_for(condition, process) -> bool:
    """Poll ``condition()`` until it holds (True) or ``process`` has ended (False)."""
    while not condition():
        if process.poll() is not None:
            return False
        time.sleep(0.005)
    return True


def test_kill_during_a_run_never_leaves_a_readable_partial_folder(tmp_path):
    """``kill -9`` of ``cyclomesh run`` into a folder that holds an earlier run, at
    observable moments (the lock taken; a result file staged; the first figure staged):
    the folder stays complete (the earlier result until the new one is moved in) and
    every NetCDF file under its final name is whole; a kill that lands in the swap (only
    after the last moment, the figures) leaves a folder without a marker, which the
    reader refuses. No kill depends on a delay."""
    from cyclomesh.output.folder import STAGING

    out = tmp_path / "out"
    assert run(out, "--crank-step-deg", "30", "-q").exit_code == 0
    earlier = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != LOCK}
    command = [
        sys.executable,
        "-m",
        "cyclomesh",
        "run",
        str(EXAMPLES / "table2.toml"),
        "--out",
        str(out),
        "--crank-step-deg",
        "1",
        "-q",
    ]
    staged = out / STAGING

    def holds(pattern: str) -> bool:
        """A file matching ``pattern`` is staged; False once the run has moved the staging
        folder in while it was being scanned (the moment passed unseen)."""
        try:
            return any(staged.rglob(pattern))
        except FileNotFoundError:
            return False

    moments = {
        "locked": lambda pid: (out / LOCK).read_text().strip() == str(pid),
        "result staged": lambda pid: holds("results.nc"),
        "figure staged": lambda pid: holds("*.png"),
    }
    killed = 0
    for name, moment in moments.items():
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        reached = _wait_for(lambda: moment(process.pid), process)  # noqa: B023
        process.kill()
        process.wait()
        killed += reached
        if name == "figure staged":
            # the figures are the run's last files: a kill seen here may land in the swap
            # (the earlier marker removed, the files being renamed in), which leaves a
            # folder without a marker by design; it must then be refused, never read
            try:
                results = load_results(out)
            except OutputError as exc:
                assert "no summary.json" in str(exc) and not (out / MARKER).exists(), exc
                continue
        else:
            results = load_results(out)  # complete: the swap cannot have begun
        if reached and name == "locked":
            now = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != LOCK}
            assert now == earlier, name  # nothing moved in yet: the earlier result as it was
        for nc in results.netcdf:
            ds = xr.load_dataset(nc)
            assert np.isfinite(ds["pin_load"].values).all(), nc
    assert killed >= 2  # the lock and the staged result are seen before the run ends
    assert run(out, *QUICK).exit_code == 0  # the next run cleans up and completes
    assert not list(out.rglob(".*.tmp")) and not staged.exists()
    load_results(out)
