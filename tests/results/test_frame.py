"""The short path of ``cyclomesh run`` (issue 27): results as a Frame of NumPy arrays.

The files a Frame writes must read back exactly as the files xarray writes of the same
results (every variable, dimension, dtype, attribute and value), its summary must be
:func:`cyclomesh.summarize`'s, and ``angles.csv`` must be the bytes pyarrow writes.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from cyclomesh import TABLE1, Modification, PinErrors
from cyclomesh.core.friction import Friction
from cyclomesh.output import writers
from cyclomesh.results.dataset import analyse, analyse_frame, summarize, summary_frame
from cyclomesh.results.frame import Frame, Var, as_frame

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
ANGLES = np.arange(0.0, 360.0, 15.0)


def _errors() -> PinErrors:
    rng = np.random.default_rng(3)
    return PinErrors(radial=rng.uniform(-4e-6, 4e-6, 40), angular=rng.uniform(-5e-5, 5e-5, 40))


CASES = {
    "plain": {},
    "errors and a modification": {
        "modification": Modification(pin_radius=8e-6, pin_circle_radius=-4e-6),
        "errors": _errors(),
    },
    "torques and a stack": {"torque": [-250.0, 250.0], "discs": 2, "contact_law": "paper"},
    "friction": {"friction": Friction(mesh=0.05, groove=0.03)},
}


@pytest.fixture(scope="module", params=list(CASES))
def frame(request) -> Frame:
    return analyse_frame(TABLE1, crank_angles_deg=ANGLES, **CASES[request.param])


def _xarray_file(ds: xr.Dataset, path: Path) -> Path:
    """The results written by xarray's own writer (booleans as 0/1 bytes, as
    :func:`~cyclomesh.output.writers.write_netcdf` writes them)."""
    out = ds.copy()
    for name in list(out.data_vars):
        if out[name].dtype == np.bool_:
            out[name] = out[name].astype(np.int8)
    out.to_netcdf(path)
    return path


def test_to_xarray_keeps_every_variable_as_it_is(frame):
    ds = frame.to_xarray()
    assert list(ds.variables) == list(frame.variables)
    assert dict(ds.sizes) == frame.sizes
    for name, var in frame.variables.items():
        assert ds[name].dims == var.dims
        assert ds[name].attrs == var.attrs
        assert ds[name].dtype == var.dtype
        np.testing.assert_array_equal(ds[name].values, var.values)
    assert ds.attrs == frame.attrs


@pytest.mark.parametrize("name", list(CASES))
def test_analyse_frame_equals_analyse(name):
    """``analyse_frame`` is ``analyse`` without xarray, bit for bit."""
    ds = analyse(TABLE1, crank_angles_deg=ANGLES, **CASES[name])
    frame = analyse_frame(TABLE1, crank_angles_deg=ANGLES, **CASES[name])
    xr.testing.assert_identical(ds, frame.to_xarray())
    assert list(ds.variables) == list(frame.variables)


def test_netcdf_of_a_frame_reads_as_xarrays_file(frame, tmp_path):
    """Every variable, its dimensions, dtype, attributes (units) and values, and the
    global attributes: the file a Frame writes and the file xarray writes of the same
    results read back the same."""
    ours = xr.open_dataset(writers.write_netcdf(frame, tmp_path / "frame.nc"))
    theirs = xr.open_dataset(_xarray_file(frame.to_xarray(), tmp_path / "xarray.nc"))
    try:
        assert list(ours.variables) == list(theirs.variables)
        assert dict(ours.sizes) == dict(theirs.sizes)
        for name in theirs.variables:
            a, b = ours[name], theirs[name]
            assert a.dims == b.dims and a.dtype == b.dtype, name
            assert a.attrs == b.attrs, name
            np.testing.assert_array_equal(a.values, b.values, err_msg=name)
        assert ours.attrs == theirs.attrs
        assert all("units" in ours[name].attrs for name in ours.data_vars)
        # and what was computed comes back: values, dtypes (booleans as 0/1), attributes
        for name, var in frame.variables.items():
            assert ours[name].attrs == var.attrs, name
            np.testing.assert_array_equal(ours[name].values, var.values, err_msg=name)
    finally:
        ours.close()
        theirs.close()


def test_summary_of_a_frame_is_summarize(frame):
    xr.testing.assert_identical(summary_frame(frame).to_xarray(), summarize(frame.to_xarray()))


def test_angle_csv_is_the_bytes_pyarrow_writes(frame, tmp_path):
    ours = writers.write_angle_csv(frame, tmp_path / "ours.csv").read_bytes()
    theirs = writers._write_csv(writers.angle_table(frame), tmp_path / "arrow.csv").read_bytes()
    assert ours == theirs
    assert ours.count(b"\n") == 1 + frame.sizes["crank_angle"] * frame.sizes.get("torque", 1)


def test_arrow_float_formats_as_arrow_does():
    import pyarrow as pa
    import pyarrow.csv as pacsv

    rng = np.random.default_rng(11)
    values = rng.standard_normal(4000) * 10.0 ** rng.integers(-25, 25, 4000)
    values = np.concatenate(
        [
            values,
            np.round(values, 3),
            10.0 ** np.arange(-12, 22),
            [0.0, -0.0, 5e-324, 1.7976931348623157e308, 1e-6, 9.999999e-7, 999999999.5, 1e10],
        ]
    )
    buffer = io.BytesIO()
    options = pacsv.WriteOptions(quoting_style="none", quoting_header="none")
    pacsv.write_csv(pa.table({"x": values}), buffer, options)
    expected = buffer.getvalue().decode().splitlines()[1:]
    assert [writers.arrow_float(v) for v in values.tolist()] == expected
    assert writers.arrow_floats(values.tolist()) == expected  # the fast path, the same
    negative = (-values).tolist() + [np.nan, np.inf, -np.inf, 1e9, 1e10 - 1, 1e10, 0.5]
    assert writers.arrow_floats(negative) == [writers.arrow_float(v) for v in negative]


def test_arrow_array_is_pyarrows_array():
    import pyarrow as pa

    floats = np.array([1.5, np.nan, -np.inf, 2.0, 0.0, 7.0, 8.0, 9.0, 10.0])
    mask = ~np.isfinite(floats)
    assert writers.arrow_array(floats, mask).equals(pa.array(floats, mask=mask))
    for values in (np.arange(11, dtype=np.int64), np.array([True, False, True] * 5)):
        assert writers.arrow_array(values).equals(pa.array(values))


def test_frame_refuses_inconsistent_sizes_and_selects_like_xarray(frame):
    with pytest.raises(ValueError, match="dimension pin"):
        Frame({"a": Var("pin", np.zeros(3)), "b": Var("pin", np.zeros(4))})
    ds = frame.to_xarray()
    if "disc" in frame.dims:
        np.testing.assert_array_equal(
            frame["mesh_force"].sel(disc=2).values, ds["mesh_force"].sel(disc=2).values
        )
    back = as_frame(ds)
    assert list(back.variables) == list(frame.variables)
    smaller = frame.drop_vars(["play", "pin_load"])
    assert "play" not in smaller and "pin_load" not in smaller and "play" in frame


RUN_IMPORTS = (
    "import sys, json\n"
    "from cyclomesh.cli import app\n"
    "try:\n    app(sys.argv[1:])\nexcept SystemExit as exc:\n    assert not exc.code, exc.code\n"
    "heavy = ('xarray', 'pandas', 'dask', 'matplotlib', 'jinja2', 'pyarrow.csv',"
    " 'pyarrow.compute')\n"
    "print(json.dumps(sorted(m for m in heavy if m in sys.modules)))\n"
)


def _run(tmp_path: Path, *figures: str) -> tuple[Path, list[str]]:
    out = tmp_path / ("out-" + "-".join(figures or ("default",)))
    args = ["run", str(EXAMPLES / "table2.toml"), "--out", str(out), "-q"]
    args += ["--crank-step-deg", "10", *(["--figures", *figures] if figures else [])]
    done = subprocess.run(
        [sys.executable, "-c", RUN_IMPORTS, *args], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    return out, json.loads(done.stdout.strip().splitlines()[-1])


def test_run_without_figures_imports_no_dataset_library(tmp_path):
    """``run --figures none`` end to end: no xarray, pandas, dask, matplotlib, jinja2,
    nor pyarrow's CSV and compute modules; every result file written, no figure, and
    the report shows no image."""
    out, imported = _run(tmp_path, "none")
    assert imported == []
    assert not (out / "figures").exists()
    assert "data:image/png" not in (out / "report.html").read_text(encoding="utf-8")
    for case in json.loads((out / "summary.json").read_text())["cases"]:
        folder = out / Path(case["results"]).parent
        assert {p.name for p in folder.iterdir()} == {"results.nc", "results.parquet", "angles.csv"}


def test_default_figures_are_the_overview(tmp_path):
    """The default: one overview figure, in the report under the summary table (before
    the inputs), and this process imports no xarray (the worker draws from NumPy
    arrays) nor matplotlib (the figure process forked as the command starts draws it,
    cyclomesh.figures.worker), and the run draws no figure but the overview (issue 27)."""
    out, imported = _run(tmp_path)
    assert "xarray" not in imported and "pandas" not in imported
    assert "matplotlib" not in imported
    assert [p.name for p in (out / "figures").iterdir()] == ["overview.png"]
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == 1
    summary, image, inputs = (
        page.index(s) for s in ("<h2>Summary", "data:image/png", "<h2>Inputs")
    )
    assert summary < image < inputs


def test_figures_all_draws_every_figure(tmp_path):
    out, _ = _run(tmp_path, "all")
    names = {p.stem for p in (out / "figures").iterdir()}
    assert {"loads", "transmission_error", "stress_maps", "gear_ratio", "profile"} <= names
    assert "overview" not in names
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == len(names)


def test_overview_figure_draws_every_case_torque_and_disc(tmp_path):
    from cyclomesh.figures.render import render_figures
    from cyclomesh.studies.run import compute_run, overview_figures
    from cyclomesh.studyfile import load_study

    study = tmp_path / "s.toml"
    text = (EXAMPLES / "table2.toml").read_text(encoding="utf-8")
    study.write_text(text.replace("crank_step_deg = 0.1", "crank_step_deg = 30.0", 1))
    run = compute_run(load_study(study))
    (job,) = overview_figures(run)
    cases = job.args[0]
    assert list(cases) == [case.name for case in run.study.cases]
    for name, case in cases.items():
        summary = run.summaries[name]
        assert np.nanmax(case.max_contact_stress) == pytest.approx(
            summary["max_contact_stress_mpa"], rel=1e-12
        )
        assert case.pin_load.shape == (40,) and case.pin_load_at == 0.0
    (drawn,) = render_figures([job], None, workers=1)
    assert drawn.png.startswith(b"\x89PNG")


def test_figures_option_words():
    from cyclomesh.exceptions import StudyError
    from cyclomesh.publish.pipeline import parse_figures

    assert parse_figures("png,svg") == (("png", "svg"), "overview")
    assert parse_figures("all") == (("png",), "all")
    assert parse_figures("all", ("svg",)) == (("svg",), "all")
    assert parse_figures("svg, ALL") == (("svg",), "all")
    assert parse_figures("none") == ((), "overview")
    with pytest.raises(StudyError, match="at most one of overview, all"):
        parse_figures("all,overview")
    with pytest.raises(StudyError, match="unknown format 'gif'"):
        parse_figures("png,gif")
