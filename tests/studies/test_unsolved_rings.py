"""A ring that a solver cannot solve is an outcome of a ring study, not its end.

A :class:`~cyclomesh.exceptions.ConvergenceError` on one drawn ring used to abort the
whole study. Now the ring is flagged ``unsolved`` (its metrics NaN with a ``nonfinite``
attribute saying why), counted as exceeding every allowable (conservative, as a ring that
jams the disc), left out of the percentiles, named in summary.json with the solver's
one-line message, and written to ``unsolved_ring.toml`` that ``cyclomesh run`` refuses
with that message. The other rings keep their bits.

Real failing rings get fixed as the solvers improve, so these tests make chosen rings
fail on purpose (tests/execution/_unsolvable.py): in this process the solve of a case
with a chosen ring's pin errors raises (serial backend, ``--workers 1``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.studies.tolerance import load_tolerance_study, ring_model

sys.path.insert(0, str(Path(__file__).parents[1] / "execution"))
from _unsolvable import MESSAGE, STAGE_MESSAGE, fail_rings  # noqa: E402
from test_tolerance_study import write_study  # noqa: E402

FAIL = (3, 7)
FLAGS = ("jammed", "unsolved", "unsolved_reason")


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


def _model(study: Path):
    s, spec = load_tolerance_study(study)
    return ring_model(s, spec)


def _load(path: Path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:
        return ds.load()


def _no_unattributed_nan(ds: xr.Dataset) -> None:
    for name, var in ds.data_vars.items():
        if var.dtype.kind == "f" and np.isnan(var.values).any():
            assert "nonfinite" in var.attrs, name
        assert "units" in var.attrs, name


def _same_other_rings(ds: xr.Dataset, clean: xr.Dataset, failed: np.ndarray) -> None:
    """Every variable of the rings that did not fail equals the run without a failure."""
    assert [v for v in ds.data_vars] == [v for v in clean.data_vars]
    keep = ~failed
    for name in ds.data_vars:
        if name in FLAGS:
            continue
        np.testing.assert_array_equal(ds[name].values[keep], clean[name].values[keep], err_msg=name)


@pytest.fixture
def clean_run(tmp_path):
    """The study and its tolerance run without a failure."""
    study = write_study(tmp_path)
    out = tmp_path / "clean"
    result = invoke("tolerance", study, "--out", out, "--workers", "1", "--figures", "none")
    assert result.exit_code == 0, result.output
    return study, out


def test_unsolved_rings_are_an_outcome_of_the_tolerance_study(tmp_path, monkeypatch, clean_run):
    study, clean_out = clean_run
    clean = _load(clean_out / "tolerance_rings.nc")
    fail_rings(monkeypatch, _model(study), FAIL)
    outs = {}
    for chunk in ("12", "5", "1"):
        out = tmp_path / f"out{chunk}"
        args = ("--workers", "1", "--chunk-rings", chunk, "--figures", "none")
        result = invoke("tolerance", study, "--out", out, *args)
        assert result.exit_code == 0, result.output
        outs[chunk] = (out, result.output)
    out, printed = outs["12"]
    ds = _load(out / "tolerance_rings.nc")
    for chunk in ("5", "1"):  # the batching changes no bit, the flags and messages neither
        other = _load(outs[chunk][0] / "tolerance_rings.nc")
        for name in ds.data_vars:
            np.testing.assert_array_equal(ds[name].values, other[name].values, err_msg=name)
    unsolved = ds["unsolved"].values.astype(bool)
    assert ds["ring"].values[unsolved].tolist() == list(FAIL)
    assert ds["unsolved"].attrs["units"] == "1" and "converge" in ds["unsolved"].attrs["long_name"]
    assert ds["unsolved_reason"].values[unsolved].tolist() == [MESSAGE] * len(FAIL)
    assert set(ds["unsolved_reason"].values[~unsolved].tolist()) == {""}
    _no_unattributed_nan(ds)
    stress = ds["max_contact_stress_mpa"].values
    assert np.all(np.isnan(stress[unsolved])) and np.all(np.isfinite(stress[~unsolved]))
    assert "did not converge" in ds["max_contact_stress_mpa"].attrs["nonfinite"]
    _same_other_rings(ds, clean, unsolved)
    # summary.json: the count, the first ring, its message and file; statistics
    summary = json.loads((out / "tolerance_summary.json").read_text())
    block = summary["unsolved"]
    assert block["count"] == len(FAIL) and block["rings"] == 12
    assert block["first_ring"] == FAIL[0] and block["message"] == MESSAGE
    assert block["file"] == "unsolved_ring.toml"
    assert block["lower"] < block["probability"] == len(FAIL) / 12 < block["upper"]
    allowable = summary["allowable_contact_stress_mpa"]
    ex = summary["exceedance"]["max_contact_stress_mpa"]
    assert ex["count"] == np.count_nonzero(stress[~unsolved] > allowable) + len(FAIL)
    stats = summary["metrics"]["max_contact_stress_mpa"]
    assert stats["count"] == 12 - len(FAIL)
    assert stats["mean"] == pytest.approx(np.mean(stress[~unsolved]), rel=1e-14)
    # what the designer reads
    said = (
        f"{len(FAIL)} rings did not converge (first: ring {FAIL[0]}, {MESSAGE}), written to "
        f"{out / 'unsolved_ring.toml'}"
    )
    assert "".join(said.split()) in "".join(printed.split())  # rich wraps long paths
    assert f"{12 - len(FAIL)} of 12 rings (seed 4; {len(FAIL)} unsolved" in printed
    with_report = tmp_path / "with_report"
    result = invoke("tolerance", study, "--out", with_report, "--workers", "1", "--figures", "none")
    assert result.exit_code == 0, result.output
    html = " ".join((with_report / "report.html").read_text().split())
    assert f"{len(FAIL)} rings did not converge (first: ring {FAIL[0]}," in html
    assert "written to unsolved_ring.toml" in html
    # the file reproduces the failure with its one line, exit 2 ...
    ring_file = out / "unsolved_ring.toml"
    assert f"ring {FAIL[0]} of seed 4" in ring_file.read_text()
    refused = invoke("run", ring_file, "--out", tmp_path / "refused", "--figures", "none")
    assert refused.exit_code == 2
    assert MESSAGE in refused.output and "Traceback" not in refused.output
    # ... and is the ring: solved (the failure undone) it gives the clean study's numbers
    monkeypatch.undo()
    rerun = invoke("run", ring_file, "--out", tmp_path / "ring", "--figures", "none", "-q")
    assert rerun.exit_code == 0, rerun.output
    case = json.loads((tmp_path / "ring" / "summary.json").read_text())["cases"][0]
    assert case["max_contact_stress_mpa"] == float(clean["max_contact_stress_mpa"][FAIL[0]])


def test_a_study_in_which_no_ring_is_solved_stops_with_one_line(tmp_path, monkeypatch):
    """Every ring unsolved: no statistics to give, one line naming the first ring and the
    solver's message, exit 2, no result file full of NaN."""
    study = write_study(tmp_path)
    fail_rings(monkeypatch, _model(study), range(12))
    out = tmp_path / "out"
    result = invoke("tolerance", study, "--out", out, "--workers", "1", "--figures", "none")
    assert result.exit_code == 2
    line = " ".join(result.output.split())
    assert "no ring of the 12 could be solved (12 did not converge); first: ring 0" in line
    assert MESSAGE in line and "Traceback" not in result.output
    assert not (out / "tolerance_rings.nc").exists()


def test_allocation_counts_unsolved_rings_as_exceeding(tmp_path, monkeypatch):
    """``cyclomesh allocate``: a ring that does not converge at a scale factor counts as
    exceeding there (its bracket ends at that factor), its metrics at the stated
    tolerances are NaN (attributed), allocation.json names it, unsolved_ring.toml holds
    its errors at that factor, and the other rings keep their bits."""
    study = write_study(tmp_path)
    clean = invoke(
        "allocate", study, "--out", tmp_path / "clean", "--workers", "1", "--figures", "none"
    )
    assert clean.exit_code == 0, clean.output
    clean_ds = _load(tmp_path / "clean" / "allocation_rings.nc")
    assert not clean_ds["unsolved"].values.any() and not clean_ds["jammed"].values.any()
    fail_rings(monkeypatch, _model(study), FAIL)  # the drawn errors: scale factor 1
    out = tmp_path / "alloc"
    result = invoke("allocate", study, "--out", out, "--workers", "1", "--figures", "none")
    assert result.exit_code == 0, result.output
    ds = _load(out / "allocation_rings.nc")
    _no_unattributed_nan(ds.drop_vars("critical_factor_upper"))  # inf: its own attribute
    unsolved = ds["unsolved"].values.astype(bool)
    assert ds["ring"].values[unsolved].tolist() == list(FAIL)
    upper = ds["critical_factor_upper"].values
    assert np.all(upper[unsolved] <= 1.0)  # exceeding at factor 1 at the latest
    assert np.all(np.isnan(ds["max_contact_stress_mpa"].values[unsolved]))
    _same_other_rings(ds, clean_ds, unsolved)
    record = json.loads((out / "allocation.json").read_text())
    block = record["unsolved"]
    assert block["count"] == len(FAIL) and block["first_ring"] == FAIL[0]
    assert block["message"] == f"scale factor 1: {MESSAGE}" and block["scale_factor"] == 1.0
    stated = record["at_stated_tolerances"]["max_contact_stress_mpa"]
    assert stated["count"] == 12 - len(FAIL) and np.isfinite(stated["mean"])
    said = f"{len(FAIL)} rings did not converge (first: ring {FAIL[0]}"
    assert "".join(said.split()) in "".join(result.output.split())
    refused = invoke("run", out / "unsolved_ring.toml", "--out", tmp_path / "r", "-q")
    assert refused.exit_code == 2 and MESSAGE in refused.output


def test_a_nominal_case_that_does_not_converge_still_stops_the_allocation(tmp_path, monkeypatch):
    """Not a drawn ring: the nominal ring (no sampled errors) of an allocation is the
    study's own case; its failure stops the study with the solver's one line, exit 2."""
    study = write_study(tmp_path)
    import cyclomesh.drive.solve as where

    original = where.check

    def check(case, *args, **kwargs):
        if case.errors is not None and not np.any(np.asarray(case.errors.radial)):
            from cyclomesh.exceptions import ConvergenceError

            raise ConvergenceError(MESSAGE)
        return original(case, *args, **kwargs)

    monkeypatch.setattr(where, "check", check)
    out = tmp_path / "alloc"
    result = invoke("allocate", study, "--out", out, "--workers", "1", "--figures", "none")
    assert result.exit_code == 2 and MESSAGE in result.output
    assert "Traceback" not in result.output and not (out / "allocation.json").exists()


STAGE_EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage_friction.toml"


def test_a_stage_ring_whose_stage_solve_fails_is_unsolved(tmp_path, monkeypatch):
    """The RV stage with friction: a ring whose stage solve does not converge is unsolved
    (the mesh's metrics of that ring are NaN too: the ring has no result), the efficiency
    statistics are over the other rings, and they keep their bits."""
    extra = (
        "\n[tolerance]\nseed = 3\nrings = 4\nallowable_contact_stress_mpa = 1850.0\n"
        "crank_step_deg = 30.0\n"
        'radial_um = { distribution = "uniform", half_range = 2.0 }\n'
        'hole_radial_um = { distribution = "uniform", half_range = 3.0 }\n'
    )
    study = tmp_path / "stage.toml"
    study.write_text(STAGE_EXAMPLE.read_text() + extra)
    args = ("--workers", "1", "--figures", "none", "-q")
    clean = invoke("tolerance", study, "--out", tmp_path / "clean", *args)
    assert clean.exit_code == 0, clean.output
    fail_rings(monkeypatch, _model(study), [2], stage=True)
    result = invoke("tolerance", study, "--out", tmp_path / "out", *args)
    assert result.exit_code == 0, result.output
    ds = _load(tmp_path / "out" / "tolerance_rings.nc")
    unsolved = ds["unsolved"].values.astype(bool)
    assert unsolved.tolist() == [False, False, True, False]
    assert str(ds["unsolved_reason"].values[2]) == STAGE_MESSAGE
    assert np.isnan(ds["stage_efficiency"].values[2]) and np.isnan(ds["efficiency"].values[2])
    _no_unattributed_nan(ds)
    _same_other_rings(ds, _load(tmp_path / "clean" / "tolerance_rings.nc"), unsolved)
    summary = json.loads((tmp_path / "out" / "tolerance_summary.json").read_text())
    assert summary["unsolved"]["first_ring"] == 2
    assert summary["metrics"]["stage_efficiency"]["count"] == 3
    assert (tmp_path / "out" / "unsolved_ring.toml").is_file()


def test_a_robust_design_map_candidate_with_an_unsolved_ring_is_infeasible(tmp_path, monkeypatch):
    """A robust map solves each candidate over all its rings at once: a ring that does not
    converge makes the candidate infeasible with the solver's message as its reason, as
    a ring that jams the disc does (no robust value over rings that were not all
    solved); the map goes on."""
    from cyclomesh.designspace.sweep import DesignTask

    study = write_study(tmp_path)
    model = _model(study)
    errors = model.pin_errors(model.draw(np.arange(4)))
    task = DesignTask(
        model.design,
        model.modification,
        (("pin_radius", (6e-6, 8e-6)),),
        errors,
        model.torque_nm,
        tuple(np.deg2rad(model.crank_angles_deg[:4])),
    )
    clean = task(0, 2)
    assert set(clean["reason"].tolist()) == {""}
    fail_rings(monkeypatch, model, [2])
    failed = task(0, 2)
    assert failed["reason"].tolist() == [MESSAGE, MESSAGE]
    assert np.all(np.isnan(failed["max_contact_stress"]))


def test_an_allocation_with_rings_that_jam_at_the_stated_tolerances_goes_on(tmp_path):
    """At ±9 µm radial errors on the example's 8 µm modification some rings jam the disc at
    the stated tolerances (factor 1): they count as exceeding (their brackets end at or
    below 1), their stated metrics are NaN (attributed, ``jammed`` = 1) and the statistics
    there are over the others (the allocation used to stop at the first such ring)."""
    from test_tolerance_study import EXAMPLE

    text = (
        EXAMPLE.read_text(encoding="utf-8")
        .replace("half_range = 4.0 }", "half_range = 9.0 }")
        .replace("crank_step_deg = 1.0 ", "crank_step_deg = 10.0 ")
    )
    study = tmp_path / "jam.toml"
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "alloc"
    args = ("--rings", "16", "--workers", "1", "--figures", "none")
    result = invoke("allocate", study, "--out", out, *args)
    assert result.exit_code == 0, result.output
    ds = _load(out / "allocation_rings.nc")
    jammed = ds["jammed"].values.astype(bool)
    assert 0 < jammed.sum() < jammed.size and not ds["unsolved"].values.any()
    assert np.all(ds["critical_factor_upper"].values[jammed] <= 1.0)
    assert np.all(np.isnan(ds["max_contact_stress_mpa"].values[jammed]))
    assert "jams the disc" in ds["max_contact_stress_mpa"].attrs["nonfinite"]
    record = json.loads((out / "allocation.json").read_text())
    stated = record["at_stated_tolerances"]["max_contact_stress_mpa"]
    assert stated["count"] == (~jammed).sum()
    assert record["unsolved"]["count"] == 0 and not (out / "unsolved_ring.toml").exists()
