"""End to end: `cyclomesh tolerance` and `cyclomesh allocate` on the real core.

Few rings and a 10° crank step keep these fast. Results must be bit-for-bit identical
whatever the chunking and wherever the chunks run (this process, local processes, a
Dask cluster on loopback).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import typer
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.studies.allocate import run_allocation
from cyclomesh.studies.tolerance import run_tolerance

EXAMPLE = Path(__file__).parents[2] / "examples" / "tolerance.toml"

STUDY = """
title = "tolerance test"

[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0

[modification]
pin_radius_um = 8.0

[load]
torque_nm = 250.0

[tolerance]
seed = 4
rings = 12
allowable_contact_stress_mpa = {allowable}
crank_step_deg = 10.0
{kinds}

[tolerance.allocation]
factor_max = 2.0
factor_steps = 4
bisections = 3
"""

KINDS = """radial_um = { distribution = "uniform", half_range = 4.0 }
angular_urad = { distribution = "uniform", half_range = 50.0 }"""


def write_study(folder: Path, allowable: float = 1850.0, kinds: str = KINDS) -> Path:
    path = folder / "study.toml"
    path.write_text(STUDY.format(allowable=allowable, kinds=kinds), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def cli() -> typer.Typer:
    """The cyclomesh command."""
    return app


def test_cli_has_the_tolerance_commands():
    names = [c.name or c.callback.__name__ for c in app.registered_commands]
    assert {"run", "check", "tolerance", "allocate"} <= set(names)


def invoke(app, *args):
    return CliRunner().invoke(app, [str(a) for a in args])


def rings_nc(folder: Path) -> xr.Dataset:
    with xr.open_dataset(folder / "tolerance_rings.nc") as ds:
        return ds.load()


def assert_identical_metrics(a: xr.Dataset, b: xr.Dataset) -> None:
    assert list(a.data_vars) == list(b.data_vars)
    np.testing.assert_array_equal(a["ring"].values, b["ring"].values)
    for name in a.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name, strict=True)


def test_example_file_is_a_valid_study_and_tolerance_section():
    from cyclomesh.studies.tolerance import load_tolerance_study

    study, spec = load_tolerance_study(EXAMPLE)
    assert spec.rings == 1000 and spec.allowable_contact_stress_mpa == 2000.0
    assert spec.radial_um.half_range == 4.0 and spec.angular_urad.half_range == 50.0
    assert study.base.modification.pin_radius_um == 8.0


def test_tolerance_command_writes_its_files(cli, tmp_path):
    study = write_study(tmp_path)
    out = tmp_path / "out"
    result = invoke(cli, "tolerance", study, "--out", out, "--workers", "1")
    assert result.exit_code == 0, result.output
    for name in (
        "tolerance_rings.nc",
        "tolerance_summary.json",
        "worst_ring.toml",
        "report.html",
        "figures/tolerance_histograms.png",
        "figures/tolerance_exceedance.png",
        "figures/tolerance_ecdfs.png",
        "tolerance_rings.parquet",
    ):
        assert (out / name).is_file(), name
    ds = rings_nc(out)
    import pyarrow.parquet as pq

    table = pq.read_table(out / "tolerance_rings.parquet")
    numbers = [name for name in ds.data_vars if name != "unsolved_reason"]  # text: NetCDF only
    assert table.column_names == ["ring", *numbers]
    for name in numbers:
        np.testing.assert_array_equal(table.column(name).to_numpy(), ds[name].values)
    units = table.schema.field("max_contact_stress_mpa").metadata[b"units"]
    assert units == b"MPa"
    assert ds.sizes["ring"] == 12
    assert ds["max_contact_stress_mpa"].attrs["units"] == "MPa"
    summary = json.loads((out / "tolerance_summary.json").read_text())
    stress = ds["max_contact_stress_mpa"].values
    ex = summary["exceedance"]["max_contact_stress_mpa"]
    assert ex["count"] == np.count_nonzero(stress > 1850.0)
    assert ex["lower"] <= ex["probability"] <= ex["upper"]
    assert summary["worst_ring"]["ring"] == int(np.argmax(stress))
    p50 = summary["metrics"]["max_contact_stress_mpa"]["percentiles"][1]
    assert p50["estimate"] == pytest.approx(np.median(stress))
    assert "Tolerance study" in (out / "report.html").read_text()


def test_results_are_bit_for_bit_across_chunkings_and_engines(tmp_path, cluster):
    local, _ = cluster
    study = write_study(tmp_path)
    runs = {
        "serial, one chunk": dict(workers=1, chunk_rings=12),
        "serial, chunks of 5": dict(workers=1, chunk_rings=5),
        "2 processes, chunks of 1": dict(workers=2, chunk_rings=1),
    }
    results = {
        name: run_tolerance(study, tmp_path / str(i), figures=False, **kw).rings
        for i, (name, kw) in enumerate(runs.items())
    }
    results["Dask LocalCluster, chunks of 3"] = run_tolerance(
        study,
        tmp_path / "dask",
        scheduler=local.scheduler_address,
        chunk_rings=3,
        figures=False,
    ).rings
    reference = results.pop("serial, one chunk")
    for name, ds in results.items():
        assert_identical_metrics(reference, ds), name
    # ring k does not depend on how many rings are drawn either
    more = run_tolerance(study, tmp_path / "more", rings=40, workers=1, figures=False)
    assert_identical_metrics(reference, more.rings.isel(ring=slice(0, 12)))


def test_allocation_is_bit_for_bit_across_chunkings(tmp_path):
    study = write_study(tmp_path)
    runs = [dict(workers=1), dict(workers=1, chunk_rings=5), dict(workers=2, chunk_rings=3)]
    brackets = [
        run_allocation(study, tmp_path / str(i), figures=False, **kw).rings
        for i, kw in enumerate(runs)
    ]
    for other in brackets[1:]:
        assert_identical_metrics(brackets[0], other)


def test_worst_ring_round_trip_through_cyclomesh_run(cli, tmp_path):
    study = write_study(tmp_path)
    out = tmp_path / "tol"
    assert invoke(cli, "tolerance", study, "--out", out, "--workers", "1", "-q").exit_code == 0
    summary = json.loads((out / "tolerance_summary.json").read_text())
    worst = summary["worst_ring"]
    result = invoke(cli, "run", out / "worst_ring.toml", "--out", tmp_path / "run", "-q")
    assert result.exit_code == 0, result.output
    record = json.loads((tmp_path / "run" / "summary.json").read_text())
    (case,) = record["cases"] if "cases" in record else [record]
    # bit for bit: the core's result for a ring does not depend on its batch
    assert case["max_contact_stress_mpa"] == worst["max_contact_stress_mpa"]
    ring = rings_nc(out).sel(ring=worst["ring"])
    for name in ("te_pp_arcsec", "max_pin_load_n", "gear_ratio_ripple_pct", "min_contacts"):
        assert case[name] == float(ring[name]), name


def test_allocation_is_monotone_and_consistent(tmp_path):
    factors = {}
    for allowable in (1700.0, 1850.0, 2000.0):
        study = write_study(tmp_path, allowable)
        run = run_allocation(
            study,
            tmp_path / f"a{allowable:g}",
            target_probability=0.25,
            workers=1,
            figures=allowable == 1850.0,
        )
        a = run.allocation
        assert np.all(np.diff(a.curve_probability) >= 0)
        factors[allowable] = a.factor
        if allowable == 1850.0:
            tol = run_tolerance(study, tmp_path / "t", workers=1, figures=False)
            exceeded = np.count_nonzero(tol.rings["max_contact_stress_mpa"].values > allowable)
            # first passage: a ring that exceeds at the stated tolerances has f* ≤ 1
            assert a.probability_at_stated >= exceeded / 12
            lower = run.rings["critical_factor_lower"].values
            upper = run.rings["critical_factor_upper"].values
            assert np.all(lower < upper)
            assert (tmp_path / "a1850" / "figures" / "allocation_exceedance.png").is_file()
    assert factors[1700.0] <= factors[1850.0] <= factors[2000.0]
    assert factors[1700.0] < factors[2000.0]
    study = write_study(tmp_path, 1850.0)
    loose = run_allocation(
        study, tmp_path / "b", target_probability=0.5, workers=1, figures=False
    ).allocation
    assert loose.factor >= factors[1850.0]


def test_allocate_command_states_the_factor(cli, tmp_path):
    study = write_study(tmp_path)
    result = invoke(
        cli,
        "allocate",
        study,
        "--out",
        tmp_path / "a",
        "--workers",
        "1",
        "--target-probability",
        "0.2",
    )
    assert result.exit_code == 0, result.output
    assert "Scale factor on the stated tolerances" in result.output
    record = json.loads((tmp_path / "a" / "allocation.json").read_text())
    assert record["target_probability"] == 0.2 and record["rings"] == 12


@pytest.mark.parametrize(
    ("kinds", "allowable", "extra", "message"),
    [
        (
            'radial_um = { distribution = "triangular", half_range = 4.0 }',
            1850.0,
            [],
            "error: tolerance.radial_um.distribution: unknown distribution 'triangular'",
        ),
        (
            'radial_um = { distribution = "uniform", half_range = -4.0 }',
            1850.0,
            [],
            "error: tolerance.radial_um.half_range:",
        ),
        (
            KINDS,
            1850.0,
            ["--scheduler", "tcp://127.0.0.1:9"],
            "error: cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'",
        ),
    ],
)
def test_bad_inputs_exit_2_with_one_line(cli, tmp_path, kinds, allowable, extra, message):
    study = write_study(tmp_path, allowable, kinds)
    result = invoke(cli, "tolerance", study, "--out", tmp_path / "o", "-q", *extra)
    assert result.exit_code == 2
    assert result.stderr.startswith(message), result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr


def test_allocate_refuses_a_nominal_design_above_the_allowable(cli, tmp_path):
    study = write_study(tmp_path, allowable=500.0)
    result = invoke(cli, "allocate", study, "--out", tmp_path / "o", "-q")
    assert result.exit_code == 2
    assert "nominal ring (no sampled errors) already exceeds" in result.stderr


def test_study_without_tolerance_section_is_refused(cli, tmp_path):
    path = tmp_path / "plain.toml"
    path.write_text(STUDY.split("[tolerance]")[0], encoding="utf-8")
    result = invoke(cli, "tolerance", path, "--out", tmp_path / "o")
    assert result.exit_code == 2
    assert "no [tolerance] section" in result.stderr


def test_importing_cyclomesh_does_not_import_distributed():
    import subprocess
    import sys

    code = (
        "import sys, cyclomesh, cyclomesh.cli, cyclomesh.studies.tolerance;"
        "print('distributed' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_a_ring_that_jams_at_a_large_factor_counts_as_exceeding(tmp_path):
    """At four times the example's tolerances some rings jam the disc (a pin overlaps it
    at every rotation): such a ring exceeds the allowable at that factor, the allocation
    goes on, and every ring's bracket is the one it has when solved alone."""
    text = (
        EXAMPLE.read_text(encoding="utf-8")
        .replace("factor_max = 2.0 ", "factor_max = 4.0 ")
        .replace("crank_step_deg = 1.0 ", "crank_step_deg = 5.0 ")
    )
    study = tmp_path / "jam.toml"
    study.write_text(text, encoding="utf-8")
    batched = run_allocation(study, tmp_path / "batched", rings=8, workers=1, figures=False)
    alone = run_allocation(
        study, tmp_path / "alone", rings=8, workers=1, chunk_rings=1, figures=False
    )
    for name in ("critical_factor_lower", "critical_factor_upper"):
        assert np.array_equal(batched.rings[name].values, alone.rings[name].values), name
    assert np.all(np.isfinite(batched.rings["critical_factor_upper"].values))


def test_rings_that_jam_the_disc_are_an_outcome_not_an_error(cli, tmp_path):
    """Issue 23: at ±9 µm radial pin errors on the 8 µm modification of the example some
    rings jam the disc (a pin overlaps it at every rotation). The study counts them: P(jam)
    with its interval, jammed rings exceed the allowable, the first one is written as a
    study file that `cyclomesh run` refuses, and the batching does not change a bit."""
    text = (
        EXAMPLE.read_text(encoding="utf-8")
        .replace("half_range = 4.0 }", "half_range = 9.0 }")
        .replace("crank_step_deg = 1.0 ", "crank_step_deg = 10.0 ")
    )
    study = tmp_path / "jam.toml"
    study.write_text(text, encoding="utf-8")
    outs = {}
    for chunk in ("16", "1"):
        out = tmp_path / f"out{chunk}"
        args = ("--rings", "16", "--workers", "1", "--chunk-rings", chunk, "--figures", "png")
        result = invoke(cli, "tolerance", study, "--out", out, *args)
        assert result.exit_code == 0, result.output
        outs[chunk] = out
    ds = rings_nc(outs["16"])
    alone = rings_nc(outs["1"])
    for name in ds.data_vars:
        np.testing.assert_array_equal(ds[name].values, alone[name].values)
    jammed = ds["jammed"].values.astype(bool)
    assert 0 < jammed.sum() < jammed.size
    stress = ds["max_contact_stress_mpa"].values
    assert np.all(np.isnan(stress[jammed])) and np.all(np.isfinite(stress[~jammed]))
    assert "nonfinite" in ds["max_contact_stress_mpa"].attrs
    summary = json.loads((outs["16"] / "tolerance_summary.json").read_text())
    jam = summary["jam"]
    assert jam["count"] == jammed.sum() and jam["rings"] == 16
    assert jam["lower"] < jam["probability"] == jammed.sum() / 16 < jam["upper"]
    ex = summary["exceedance"]["max_contact_stress_mpa"]
    assert ex["count"] == np.count_nonzero(stress[~jammed] > 2000.0) + jammed.sum()
    assert summary["metrics"]["max_contact_stress_mpa"]["count"] == (~jammed).sum()
    first = int(ds["ring"].values[jammed][0])
    assert jam["first_ring"] == first
    assert summary["worst_ring"]["ring"] == int(ds["ring"].values[np.nanargmax(stress)])
    refused = invoke(cli, "run", outs["16"] / "jammed_ring.toml", "--out", tmp_path / "r")
    assert refused.exit_code == 2 and "overlaps the disc" in refused.output
    assert "jam" in (outs["16"] / "report.html").read_text()


def test_tolerance_with_friction_gives_efficiency_statistics(cli, tmp_path):
    """[friction] in a tolerance study: every ring's forward efficiency (the pins' and the
    crank bearing's losses in the equilibrium), its P5/P50/P95 over the rings, and the
    worst ring rerun by `cyclomesh run` gives its efficiency again."""
    study = write_study(tmp_path)
    text = study.read_text(encoding="utf-8").replace(
        "[tolerance]\n",
        "[friction]\nmesh_coefficient = 0.08\ngroove_coefficient = 0.06\n"
        "bearing_coefficient = 0.0025\nbearing_diameter_mm = 40.0\n\n"
        "[requirements]\nmin_efficiency = 0.5\ntolerance_percentile = 90.0\n\n[tolerance]\n",
    )
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "tol"
    result = invoke(cli, "tolerance", study, "--out", out, "--workers", "1", "--figures", "none")
    assert result.exit_code == 0, result.output
    ds = rings_nc(out)
    eff = ds["efficiency"].values
    assert ds["efficiency"].attrs["units"] == "1"
    assert np.all((eff > 0.8) & (eff < 1.0)) and np.ptp(eff) > 0  # the rings differ
    summary = json.loads((out / "tolerance_summary.json").read_text())
    stats = summary["metrics"]["efficiency"]
    assert summary["percentiles"][:3] == [5.0, 50.0, 95.0]
    for p, q in zip(stats["percentiles"][:3], (5.0, 50.0, 95.0), strict=True):
        assert p["estimate"] == pytest.approx(np.percentile(eff, q), rel=1e-12)
    (row,) = [r for r in summary["checks"]["rows"] if r["check"] == "min_efficiency"]
    assert row["value"] == pytest.approx(np.percentile(eff, 10.0), rel=1e-12)  # P10: a minimum
    k = summary["worst_ring"]["ring"]
    rerun = invoke(cli, "run", out / "worst_ring.toml", "--out", tmp_path / "run", "-q")
    assert rerun.exit_code == 0, rerun.output
    record = json.loads((tmp_path / "run" / "summary.json").read_text())["cases"][0]
    assert record["efficiency"] == pytest.approx(float(ds["efficiency"].sel(ring=k)), rel=1e-12)
    # frictionless: no efficiency
    plain = tmp_path / "plain"
    study.write_text(write_study(tmp_path).read_text(encoding="utf-8"), encoding="utf-8")
    result = invoke(cli, "tolerance", study, "--out", plain, "--workers", "1", "--figures", "none")
    assert result.exit_code == 0, result.output
    assert "efficiency" not in rings_nc(plain)


def _rv_jam_study(tmp_path: Path, half_range_um: float, stage: bool) -> Path:
    """The issue's trigger: the RV-40E-size example at the nominal optimum Δρ = 1.5 µm of
    its design map, ±`half_range_um` radial pin errors, one case (tolerance analyses the
    base), mesh alone or with the stage."""
    text = (Path(__file__).parents[2] / "examples" / "rv_stage.toml").read_text("utf-8")
    text = text[: text.index("\n[[cases]]")] + "\n"
    assert "[modification]\npin_radius_um = 3.0" in text
    text = text.replace(
        "[modification]\npin_radius_um = 3.0", "[modification]\npin_radius_um = 1.5"
    )
    text = text.replace(
        "[stiffness]\n",
        "[tolerance]\nseed = 1\nallowable_contact_stress_mpa = 2000.0\ncrank_step_deg = 10.0\n"
        f'radial_um = {{ distribution = "uniform", half_range = {half_range_um} }}\n\n'
        "[stiffness]\n",
        1,
    )
    if not stage:  # the mesh alone: no [stage...], no [design.disc]
        for section in (
            "[design.disc]",
            "[stage]",
            "[stage.crankshaft]",
            "[stage.carrier]",
            "[stage.duty_cycle]",
            "[stage.crank_bearing]",
        ):
            i = text.index("\n" + section) + 1
            text = text[:i] + text[text.index("\n[", i + 1) + 1 :]
    study = tmp_path / f"rv_jam_{half_range_um:g}_{stage}.toml"
    study.write_text(text, encoding="utf-8")
    return study


@pytest.mark.parametrize(
    "half_range_um, stage", [(5.0, False), (2.0, False), (5.0, True)], ids=["5um", "2um", "stage"]
)
def test_the_rv_example_at_its_optimum_counts_jammed_rings(cli, tmp_path, half_range_um, stage):
    """Issue 23: a tolerance study of the RV-40E-size map's optimum Δρ = 1.5 µm at ±5 µm
    died at the first ring that jams ("pin 7 overlaps the disc", exit 2, no statistics).
    It now ends with P(jam) and its interval, the first jammed ring written, and the
    statistics said to be over the rings that do not jam (none: said so, no table of
    NaN)."""
    study = _rv_jam_study(tmp_path, half_range_um, stage)
    out = tmp_path / "out"
    rings = 6 if stage else 16
    result = invoke(cli, "tolerance", study, "--out", out, "--rings", rings, "--workers", "1")
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "tolerance_summary.json").read_text())
    jam = summary["jam"]
    jammed = rings_nc(out)["jammed"].values.astype(bool)
    assert jam["count"] == jammed.sum() > 0 and jam["rings"] == rings
    assert jam["lower"] <= jam["probability"] == jammed.sum() / rings <= jam["upper"]
    assert (out / "jammed_ring.toml").is_file()
    text = " ".join(result.output.split())
    assert "jam: P(the pins jam the disc) = " in text and "Clopper-Pearson" in text
    assert "P(max σH tooth > 2000 MPa)" in text
    assert "nan" not in text.split("P(max σH")[0]
    if jammed.all():
        assert f"no statistics: every one of the {rings} rings jams the disc" in text
    else:
        ran = rings - jammed.sum()
        assert f"{ran} of {rings} rings (seed 1; {jammed.sum()} jammed" in text
        assert f"P95 of {ran} rings that did not jam (of {rings})" in text
