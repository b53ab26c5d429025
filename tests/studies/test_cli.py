"""End-to-end runs of ``cyclomesh run`` on the examples, and refused inputs.

The examples run with ``--crank-step-deg`` coarse enough to keep the suite fast.
"""

from __future__ import annotations

import csv
import hashlib
import json
import shutil
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh import summarize
from cyclomesh.cli import app
from cyclomesh.studyfile.measurements import read_pin_errors_csv

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def numbers(count: int, value: float = 0.0) -> str:
    """A TOML list of ``count`` equal numbers."""
    return "[" + ", ".join([repr(float(value))] * count) + "]"


FIGURES = (
    "profile",
    "loads",
    "profile_stress",
    "stress_maps",
    "transmission_error",
    "gear_ratio",
    "contacts",
    "backlash",
    "mesh_force",
)
STEP_DEG = "5"


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


@pytest.fixture(scope="module")
def table2(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("table2") / "out"
    result = invoke(
        "run",
        str(EXAMPLES / "table2.toml"),
        "--out",
        str(out),
        "--crank-step-deg",
        STEP_DEG,
        "--csv",
        "--figures",
        "all,png,svg,pdf",
    )
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def section42(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("section42") / "out"
    result = invoke(
        "run",
        str(EXAMPLES / "section42.toml"),
        "-o",
        str(out),
        "--crank-step-deg",
        STEP_DEG,
        "-q",
        "--figures",
        "all",
    )
    assert result.exit_code == 0, result.output
    assert result.stdout == ""  # --quiet
    return out


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text(encoding="utf-8"))


def test_summary_matches_the_netcdf_results(table2):
    document = summary(table2)
    assert document["title"].startswith("Table 2 of Li et al. (2022)")
    assert [c["name"] for c in document["cases"]] == ["Case 1", "Case 2", "Case 3", "Case 4"]
    for record in document["cases"]:
        with xr.open_dataset(table2 / record["results"]) as ds:
            ds = ds.load()
        assert ds.sizes["crank_angle"] == 72 and ds.sizes["pin"] == 40
        te = ds["transmission_error"].values
        expected = {
            "max_pin_load_n": float(ds["pin_load"].max()),
            "max_groove_load_n": float(ds["groove_load"].max()),
            "max_contact_stress_mpa": float(ds["contact_stress"].max()),
            "max_groove_stress_mpa": float(ds["groove_stress"].max()),
            "te_mean_arcsec": float(te.mean()),
            "te_pp_arcsec": float(te.max() - te.min()),
        }
        for key, value in expected.items():
            assert record[key] == pytest.approx(value, rel=1e-12), key
        assert record["min_contacts"] == int(ds["contacts"].min())
        assert record["max_contacts"] == int(ds["contacts"].max())
        recomputed = summarize(ds)
        assert record["gear_ratio_ripple_pct"] == pytest.approx(
            float(recomputed["gear_ratio_ripple_pct"]), rel=1e-12
        )
        # study inputs recorded with the results
        assert ds.attrs["case_name"] == record["name"]
        sha = hashlib.sha256((EXAMPLES / "table2.toml").read_bytes()).hexdigest()
        assert ds.attrs["study_sha256"] == sha == document["study_sha256"]
        inputs = json.loads(ds.attrs["case_inputs_json"])
        assert inputs["load"]["torque_nm"] == 250.0
        assert inputs["analysis"]["crank_step_deg"] == float(STEP_DEG)


def test_table2_behaves_like_the_paper(table2):
    cases = {c["name"]: c for c in summary(table2)["cases"]}
    with xr.open_dataset(table2 / cases["Case 1"]["results"]) as ds:
        assert ds.attrs["groove_deformation"] == 0
    with xr.open_dataset(table2 / cases["Case 2"]["results"]) as ds:
        assert ds.attrs["groove_deformation"] == 1
        assert ds.attrs["modification_pin_radius_um"] == 8.0
    # TPM cuts the number of loaded pins and raises the peak load and stress (Section 4.1)
    for tpm, plain in (("Case 1", "Case 3"), ("Case 2", "Case 4")):
        assert cases[tpm]["max_contacts"] < cases[plain]["min_contacts"]
        assert cases[tpm]["max_pin_load_n"] > cases[plain]["max_pin_load_n"]
        assert cases[tpm]["max_contact_stress_mpa"] > cases[plain]["max_contact_stress_mpa"]


def test_results_csv_is_long_format_with_unit_suffixes(table2):
    record = summary(table2)["cases"][0]
    folder = table2 / Path(record["results"]).parent
    assert folder.name == "Case_1"
    with (folder / "results.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    with xr.open_dataset(folder / "results.nc") as ds:
        ds = ds.load()
    assert len(rows) == 72 * 40
    for column in (
        "crank_angle_deg",
        "pin",
        "pin_load_n",
        "groove_load_n",
        "contact_stress_mpa",
        "groove_stress_mpa",
        "backlash_arcsec",
        "profile_angle_deg",
        "contact_radius_mm",
        "transmission_error_arcsec",
        "gear_ratio",
        "contacts",
        "pin_radial_error_um",
        "pin_angular_error_urad",
    ):
        assert column in rows[0], column
    text = (folder / "results.csv").read_text().lower()
    assert "nan" not in text and "inf" not in text
    backlash = ds["backlash"].values
    blank = sum(row["backlash_arcsec"] == "" for row in rows)
    assert blank == np.count_nonzero(~np.isfinite(backlash))
    assert blank > 0  # TPM: some pins cannot be reached by the loaded flank
    row = rows[40 * 3 + 19]  # fourth crank angle, pin 20
    at = ds.isel(crank_angle=3).sel(pin=20)
    assert float(row["crank_angle_deg"]) == float(at["crank_angle"]) and row["pin"] == "20"
    assert float(row["pin_load_n"]) == pytest.approx(float(at["pin_load"]), rel=1e-9, abs=1e-9)
    assert float(row["transmission_error_arcsec"]) == pytest.approx(
        float(at["transmission_error"]), rel=1e-9
    )


def test_parquet_has_every_csv_column_with_its_unit(table2):
    import pyarrow.parquet as pq

    folder = table2 / "Case_2"
    table = pq.read_table(folder / "results.parquet")
    with (folder / "results.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert table.column_names == list(rows[0])
    assert table.num_rows == len(rows) == 72 * 40
    units = {f.name: f.metadata[b"units"].decode() for f in table.schema}
    assert units["pin_load_n"] == "N" and units["contact_stress_mpa"] == "MPa"
    assert units["transmission_error_arcsec"] == "arcsec" and units["crank_angle_deg"] == "deg"
    with xr.open_dataset(folder / "results.nc") as ds:
        ds = ds.load()
    load = table.column("pin_load_n").to_numpy().reshape(72, 40)
    np.testing.assert_array_equal(load, ds["pin_load"].values)  # bit for bit
    backlash = table.column("backlash_arcsec")
    assert backlash.null_count == np.count_nonzero(~np.isfinite(ds["backlash"].values)) > 0
    te = table.column("transmission_error_arcsec").to_numpy().reshape(72, 40)
    np.testing.assert_array_equal(te, np.repeat(ds["transmission_error"].values[:, None], 40, 1))


def test_angle_csv_has_one_row_per_crank_angle(table2):
    folder = table2 / "Case_2"
    with (folder / "angles.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    with xr.open_dataset(folder / "results.nc") as ds:
        ds = ds.load()
    assert len(rows) == 72
    assert list(rows[0])[:4] == [
        "crank_angle_deg",
        "transmission_error_arcsec",
        "gear_ratio",
        "contacts",
    ]
    stress = np.array([float(r["max_contact_stress_mpa"]) for r in rows])
    np.testing.assert_array_equal(stress, ds["contact_stress"].max("pin").values)
    te = np.array([float(r["transmission_error_arcsec"]) for r in rows])
    np.testing.assert_array_equal(te, ds["transmission_error"].values)  # shortest round trip
    assert {"max_pin_load_n", "max_groove_load_n", "max_groove_stress_mpa"} <= set(rows[0])


def test_figures_written_in_every_requested_format(table2):
    for name in FIGURES:
        png = table2 / "figures" / f"{name}.png"
        svg = table2 / "figures" / f"{name}.svg"
        pdf = table2 / "figures" / f"{name}.pdf"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
        assert b"<svg" in svg.read_bytes()[:1000], name
        assert pdf.read_bytes()[:5] == b"%PDF-", name
    assert not (table2 / "figures" / "pin_errors.png").exists()  # no case has pin errors


def test_report_is_stamped_and_self_contained(table2):
    page = (table2 / "report.html").read_text(encoding="utf-8")
    assert f"cyclomesh version: <code>{version('cyclomesh')}</code>" in page
    assert hashlib.sha256((EXAMPLES / "table2.toml").read_bytes()).hexdigest() in page
    assert page.count("data:image/png;base64,") == len(FIGURES)
    assert "Table 2 of Li et al. (2022)" in page and "max_contact_stress_mpa" in page
    assert "pin_radius_um = 8.0" in page  # the study file itself
    assert 'src="http' not in page and "<link" not in page


def test_section42_random_errors_and_their_figure(section42):
    cases = {c["name"]: c for c in summary(section42)["cases"]}
    with xr.open_dataset(section42 / cases["Case 3"]["results"]) as ds:
        assert np.all(np.abs(ds["pin_radial_error"].values) <= 4.0)
        assert np.all(np.abs(ds["pin_angular_error"].values) <= 50.0)
        assert ds["pin_radial_error"].attrs["units"] == "um"
    # random pin errors make the contact irregular and raise the peak stress (Section 4.2)
    assert cases["Case 3"]["max_contact_stress_mpa"] > cases["Case 2"]["max_contact_stress_mpa"]
    assert cases["Case 1"]["min_contacts"] > cases["Case 2"]["max_contacts"]
    assert (section42 / "figures" / "pin_errors.png").exists()
    assert not (section42 / "figures" / "pin_errors.svg").exists()  # PNG only by default
    assert not (section42 / "Case_3" / "results.csv").exists()  # the pin CSV is opt-in
    assert (section42 / "Case_3" / "results.parquet").exists()


def test_measured_example_records_the_csv_errors(tmp_path):
    out = tmp_path / "out"
    study = tmp_path / "measured.toml"
    text = (EXAMPLES / "measured.toml").read_text(encoding="utf-8")
    study.write_text(text.replace("stress_pin = 20", "stress_pin = 20\nenabled = false"))
    shutil.copy(EXAMPLES / "measured_pins.csv", tmp_path)
    result = invoke("run", str(study), "--out", str(out), "--crank-step-deg", "10", "--quiet")
    assert result.exit_code == 0, result.output
    assert not (out / "figures").exists()
    measured = read_pin_errors_csv(EXAMPLES / "measured_pins.csv", 40)
    with xr.open_dataset(out / "Measured_ring" / "results.nc") as ds:
        np.testing.assert_allclose(ds["pin_radial_error"].values, measured["radial_um"])
        np.testing.assert_allclose(ds["pin_radius_error"].values, measured["pin_radius_um"])
    assert "data:image" not in (out / "report.html").read_text(encoding="utf-8")


# --- refused inputs: one line on stderr, exit 2, no traceback, nothing written ----------

TABLE2 = (EXAMPLES / "table2.toml").read_text(encoding="utf-8")
BAD_RUNS = {
    "unknown key": (
        TABLE2.replace("width_mm = 12.0", "width_mm = 12.0\nwidht_mm = 1.0"),
        [],
        "design.widht_mm",
    ),
    "wrong type": (TABLE2.replace("torque_nm = 250.0", 'torque_nm = "250"'), [], "load.torque_nm"),
    "list of wrong length": (
        TABLE2.replace("[load]", "[errors]\npin_radius_um = " + numbers(41) + "\n[load]"),
        [],
        "errors.pin_radius_um: expected 40 values (one per pin), got 41",
    ),
    "negative size": (TABLE2.replace("width_mm = 12.0", "width_mm = -12.0"), [], "design.width_mm"),
    "missing CSV": (
        TABLE2.replace("[load]", '[errors]\nfile = "pins.csv"\n[load]'),
        [],
        "errors.file",
    ),
    "malformed CSV": (
        TABLE2.replace("[load]", '[errors]\nfile = "bad.csv"\n[load]'),
        [],
        "errors.file: bad.csv: missing column 'pin_radius_um'",
    ),
    "malformed TOML": (TABLE2.replace("[load]", "[load"), [], "invalid TOML"),
    "undercut design": (
        TABLE2.replace("eccentricity_mm = 1.5", "eccentricity_mm = 2.0"),
        [],
        "undercut",
    ),
    "bad step option": (TABLE2, ["--crank-step-deg", "-1"], "analysis.crank_step_deg"),
    "bad figures option": (TABLE2, ["--figures", "png,gif"], "--figures: unknown format 'gif'"),
    "bad case key": (
        TABLE2.replace('name = "Case 4"', 'name = "Case 4"\nanalysis.groove = true'),
        [],
        'case "Case 4": analysis.groove: unknown key',
    ),
}


@pytest.mark.parametrize("name", list(BAD_RUNS))
def test_refused_input_exits_2_with_one_line(tmp_path, name):
    text, options, expected = BAD_RUNS[name]
    study = tmp_path / "study.toml"
    study.write_text(text, encoding="utf-8")
    (tmp_path / "bad.csv").write_text("pin,radial_um,angular_urad\n1,0,0\n")
    out = tmp_path / "out"
    result = invoke("run", str(study), "--out", str(out), *options)
    assert result.exit_code == 2
    assert result.stdout == ""
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1
    assert expected in result.stderr
    assert "Traceback" not in result.output
    assert isinstance(result.exception, SystemExit)
    assert not out.exists()


def test_refused_input_leaves_an_existing_out_dir_empty(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    result = invoke("run", str(tmp_path / "missing.toml"), "--out", str(out))
    assert result.exit_code == 2
    assert result.stderr.startswith("error: study file not found: ")
    assert list(out.iterdir()) == []


def test_installed_command_reports_errors_without_traceback(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(TABLE2.replace("pins = 40", "pins = 2"), encoding="utf-8")
    run = subprocess.run(
        [sys.executable, "-m", "cyclomesh", "run", str(study), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2
    assert run.stderr == "error: design.pins: expected a number >= 3, got 2\n"
    version_run = subprocess.run(
        [sys.executable, "-m", "cyclomesh", "--version"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert version_run.stdout.strip() == f"cyclomesh {version('cyclomesh')}"


def test_check_command(tmp_path):
    result = invoke("check", str(EXAMPLES / "section42.toml"))
    assert result.exit_code == 0
    assert "3 case(s) OK: Case 1, Case 2, Case 3" in result.stdout
    assert invoke("check", str(EXAMPLES / "tolerance.toml")).stdout.endswith(
        "[tolerance] OK; for run, tolerance, allocate\n"
    )


TOLERANCE = (EXAMPLES / "tolerance.toml").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("seed = 20220810", "seed = true", "tolerance.seed: expected an integer, got true"),
        ("rings = 1000", 'rings = "12"', 'tolerance.rings: expected an integer, got "12"'),
        ("rings = 1000", "rings = 1000\nring = 5", "tolerance.ring: unknown key"),
        ("bisections = 6", "bisections = 6\nbisect = 2", "tolerance.allocation.bisect: unknown"),
        ("half_range = 4.0", "half_range = -4.0", "tolerance.radial_um.half_range: expected a"),
    ],
)
def test_check_refuses_bad_tolerance_keys_before_any_work(tmp_path, old, new, expected):
    study = tmp_path / "study.toml"
    assert old in TOLERANCE
    study.write_text(TOLERANCE.replace(old, new, 1), encoding="utf-8")
    for command in (["check"], ["run", "--out", str(tmp_path / "o")]):
        result = invoke(command[0], str(study), *command[1:])
        assert result.exit_code == 2, result.output
        assert result.stderr.startswith(f"error: {expected}"), result.stderr
        assert result.stderr.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_installed_command_runs_with_forked_figure_and_ring_workers(tmp_path):
    """The command as users start it: figure workers forked before the solve (run), ring
    workers forked before the progress bar (tolerance); every file written."""
    out = tmp_path / "run"
    command = [sys.executable, "-m", "cyclomesh"]
    run = subprocess.run(
        [*command, "run", str(EXAMPLES / "section42.toml"), "-o", str(out), "-q"]
        + ["--crank-step-deg", "10", "--figures", "png,svg,all"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    names = {p.name for p in (out / "figures").iterdir()}
    assert names == {f"{n}.{ext}" for n in (*FIGURES, "pin_errors") for ext in ("png", "svg")}
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == len(FIGURES) + 1
    tolerance = subprocess.run(
        [*command, "tolerance", str(EXAMPLES / "tolerance.toml"), "-o", str(tmp_path / "tol")]
        + ["--rings", "8", "-q", "--workers", "2"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert tolerance.returncode == 0, tolerance.stderr
    for name in ("tolerance_histograms", "tolerance_ecdfs", "tolerance_exceedance"):
        assert (tmp_path / "tol" / "figures" / f"{name}.png").is_file()
    summary = json.loads((tmp_path / "tol" / "tolerance_summary.json").read_text())
    assert summary["rings"] == 8
