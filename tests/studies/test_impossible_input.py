"""Physically impossible or jamming input (issue 23): refused in one line, or computed
and flagged (negative play: a failing verdict row and a warning everywhere)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def each_command(commands, study, tmp_path):
    """The result of every command on ``study`` (``check`` takes no ``--out``)."""
    for command in commands:
        out = () if command == "check" else ("--out", tmp_path / command)
        yield invoke(command, study, *out)


def refused(result, *words):
    """Exit 2 with one error line holding every word, and no traceback."""
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert lines[-1].startswith("error:"), result.output
    assert "Traceback" not in result.output
    text = " ".join(result.output.split())
    for word in words:
        assert word in text, (word, result.output)


def test_negative_play_is_run_but_fails_the_verdict_and_warns(tmp_path):
    """[errors] eccentricity_um = -700 on table2 (inside |εe| < e/2): the play is negative
    (the pins jam the disc); the run says so in the verdict table (FAIL), summary.json
    warnings, the terminal and the report."""
    text = (EXAMPLES / "table2.toml").read_text(encoding="utf-8")
    text = text.split("[[cases]]")[0]  # the base case only
    assert "crank_step_deg = 0.1\n" in text
    text = text.replace("crank_step_deg = 0.1\n", "crank_step_deg = 4.0\n")
    text = text.replace("[load]", "[errors]\neccentricity_um = -700.0\n\n[load]")
    study = tmp_path / "jam.toml"
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    result = invoke("run", study, "--out", out, "--figures", "none")
    assert result.exit_code == 0, result.output
    assert "pins jam the disc" in " ".join(result.output.split())
    summary = json.loads((out / "summary.json").read_text())
    assert any("pins jam the disc" in w for w in summary["warnings"])
    (case,) = summary["cases"].values() if isinstance(summary["cases"], dict) else summary["cases"]
    rows = {row["check"]: row for row in case["checks"]["rows"]}
    assert rows["jam"]["verdict"] == "fail" and rows["jam"]["value"] < -200.0  # arcmin
    assert "FAIL" in result.output
    assert "pins jam the disc" in (out / "report.html").read_text()


def test_a_positive_or_zero_play_adds_no_jam_row(tmp_path):
    """Every case of table2: with TPM (positive play) and without (cases 3 and 4: zero
    clearance, whose play is zero up to round-off, e.g. -4.7e-10 arcmin) no jam."""
    text = (EXAMPLES / "table2.toml").read_text(encoding="utf-8")
    study = tmp_path / "ok.toml"
    assert "crank_step_deg = 0.1\n" in text
    study.write_text(text.replace("crank_step_deg = 0.1\n", "crank_step_deg = 4.0\n"), "utf-8")
    out = tmp_path / "out"
    assert invoke("run", study, "--out", out, "--figures", "none").exit_code == 0
    summary = json.loads((out / "summary.json").read_text())
    cases = summary["cases"].values() if isinstance(summary["cases"], dict) else summary["cases"]
    for case in cases:
        assert "jam" not in {row["check"] for row in case["checks"]["rows"]}
    assert not any("jam" in w for w in summary["warnings"])


def _measured(tmp_path: Path, line: int, column: int, value: str) -> Path:
    """examples/measured.toml with one cell of its CSV replaced."""
    lines = (EXAMPLES / "measured_pins.csv").read_text(encoding="utf-8").splitlines()
    data = [i for i, text in enumerate(lines) if text and not text.startswith(("#", "pin"))]
    cells = lines[data[line]].split(",")
    cells[column] = value
    lines[data[line]] = ",".join(cells)
    (tmp_path / "measured_pins.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    study = tmp_path / "measured.toml"
    study.write_text((EXAMPLES / "measured.toml").read_text(encoding="utf-8"), "utf-8")
    return study


@pytest.mark.parametrize(
    ("column", "value", "words"),
    [
        (1, "1_0", ["'1_0' is not a finite number", "plain decimals"]),
        (0, "1_0", ["pin '1_0' is not an integer"]),
        (1, "0x1", ["'0x1' is not a finite number"]),
        (3, "-3500", ["pin_radius_um", "-3500", "below the pin radius"]),
        (3, "-4000", ["pin_radius_um", "below the pin radius"]),
    ],
)
def test_measured_pins_csv_refuses_python_syntax_and_pins_without_radius(
    tmp_path, column, value, words
):
    study = _measured(tmp_path, 6, column, value)
    for result in each_command(("check", "run"), study, tmp_path):
        refused(result, *words)


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        ("groove_radius_mm = 3.005", "groove_radius_mm = 100.0", ["groove_radius", "overlap"]),
        (
            "roller_length_mm = 9.0",
            "roller_length_mm = 50.0",
            ["roller_length_mm = 50", "disc width", "width_mm = 10"],
        ),
        (  # was "stage.crank_bearing.pitch_diameter must be positive, got -0.004" (issue 23)
            "roller_diameter_mm = 4.0",
            "roller_diameter_mm = 30.0",
            ["roller_diameter_mm = 30", "crank_hole_radius_mm = 13", "below 13 mm"],
        ),
        (
            "rollers = 14",
            "rollers = 60",
            ["60 rollers of 4 mm do not fit on the pitch circle of 22 mm (at most 17)"],
        ),
        (
            "output_speed_rpm = 15.0",
            "hole_error_radial_um = 1000.0\noutput_speed_rpm = 15.0",
            ["hole_error_radial_um", "1000 µm", "jam the stage"],
        ),
    ],
)
def test_a_stage_that_cannot_be_built_is_refused(tmp_path, old, new, words):
    text = (EXAMPLES / "rv_stage.toml").read_text(encoding="utf-8")
    assert old in text
    study = tmp_path / "stage.toml"
    study.write_text(text.replace(old, new, 1), encoding="utf-8")
    for result in each_command(("check", "run", "stiffness"), study, tmp_path):
        refused(result, *words)


def test_hole_errors_a_disc_takes_up_by_moving_are_accepted(tmp_path):
    """A uniform tangential hole error only turns the disc: no misfit, accepted however
    large (within the schema's bounds); a radial one of the clearance's size too."""
    text = (EXAMPLES / "rv_stage.toml").read_text(encoding="utf-8")
    for extra in ("hole_error_tangential_um = 200.0", "hole_error_radial_um = 5.0"):
        study = tmp_path / "stage.toml"
        study.write_text(
            text.replace("output_speed_rpm = 15.0", f"{extra}\noutput_speed_rpm = 15.0", 1),
            "utf-8",
        )
        result = invoke("check", study)
        assert result.exit_code == 0, result.output


def test_run_and_stiffness_check_the_stage_by_one_definition(tmp_path):
    """Issue 23: with [stage], `run` checked the mean lost motion and rigidity over the
    crank angles, `stiffness` the largest and smallest (docs/requirements.md): two
    verdicts for one design. Now both check the same numbers; the rigidity row says what
    was checked and that the reducer's is lower."""
    text = (EXAMPLES / "rv_stage.toml").read_text(encoding="utf-8")
    assert "crank_step_deg = 1.0\n" in text
    text = text.replace("crank_step_deg = 1.0\n", "crank_step_deg = 12.0\n", 1)
    text = text.replace(
        "[stage]\n",
        "[requirements]\nmax_lost_motion_arcmin = 1.1\n"
        "min_torsional_rigidity_nm_per_arcmin = 468.0\n\n[stage]\n",
        1,
    )
    study = tmp_path / "stage.toml"
    study.write_text(text, encoding="utf-8")
    rows = {}
    for command in ("run", "stiffness"):
        out = tmp_path / command
        result = invoke(command, study, "--out", out, "--figures", "none")
        assert result.exit_code == 0, result.output
        summary = json.loads((out / "summary.json").read_text())
        cases = summary["cases"]
        cases = cases if isinstance(cases, dict) else {c["name"]: c for c in cases}
        rows[command] = {
            name: {row["check"]: row for row in case["checks"]["rows"]}
            for name, case in cases.items()
        }
    assert rows["run"].keys() == rows["stiffness"].keys()
    for case in rows["run"]:
        for key in ("max_lost_motion_arcmin", "min_torsional_rigidity_nm_per_arcmin"):
            a, b = rows["run"][case][key], rows["stiffness"][case][key]
            assert a["value"] == pytest.approx(b["value"], rel=1e-9), (case, key)
            assert a["verdict"] == b["verdict"]
            # the example's stage has crankshafts and carrier: the row names them and
            # does not say they are left out
            assert "stage: mesh + crank bearings + crankshafts + carrier" in a["note"]
            assert "the reducer's is worse" in a["note"]
            assert "crankshafts not included" not in a["note"]


def test_no_modification_on_the_requirements_example_jams_in_run_and_stiffness(tmp_path):
    """Issue 23: modification.pin_radius_um = 0 on examples/requirements.toml (Δa = -3 µm
    left, random pin errors): the play at zero load is negative (about -2 arcmin) and
    was reported with no word. Both kinds that compute the play fail a 'jam' row and
    warn in summary.json and on the terminal."""
    text = (EXAMPLES / "requirements.toml").read_text(encoding="utf-8")
    for old, new in (
        ("pin_radius_um = 5.0", "pin_radius_um = 0.0"),
        ("crank_step_deg = 0.5\n", "crank_step_deg = 10.0\n"),
    ):
        assert old in text
        text = text.replace(old, new, 1)
    study = tmp_path / "req.toml"
    study.write_text(text, encoding="utf-8")
    for command, extra in (("run", ()), ("stiffness", ("--crank-step-deg", "30"))):
        out = tmp_path / command
        result = invoke(command, study, "--out", out, "--figures", "none", *extra)
        assert result.exit_code == 0, result.output
        assert "pins jam the disc" in " ".join(result.output.split()), command
        summary = json.loads((out / "summary.json").read_text())
        assert any("pins jam the disc" in w for w in summary["warnings"]), command
        (case,) = summary["cases"]
        rows = {row["check"]: row for row in case["checks"]["rows"]}
        assert rows["jam"]["verdict"] == "fail" and rows["jam"]["value"] < -1.0, command
