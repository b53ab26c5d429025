"""Refusals name the key a user typed and the fix, not only the consequence (issue 23).

Each case changes one key of an example and runs the command a user would; the one
error line must name that key (with its unit suffix) and, where the bound is known,
the value that would be accepted.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TABLE2 = (
    (EXAMPLES / "table2.toml").read_text().replace("crank_step_deg = 0.1", "crank_step_deg = 30.0")
)


def _error(tmp_path: Path, text: str, command: str = "run") -> str:
    study = tmp_path / "s.toml"
    study.write_text(text)
    args = [command, str(study)]
    if command != "check":
        args += ["--out", str(tmp_path / "out"), "-q", "--figures", "none"]
    result = CliRunner().invoke(app, args)
    lines = result.output.splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert not (tmp_path / "out").exists()
    return lines[0]


def test_a_pin_circle_too_large_names_the_three_keys_and_the_bounds(tmp_path):
    text = TABLE2.replace("pin_circle_radius_mm = 82.0", "pin_circle_radius_mm = 2000.0")
    line = _error(tmp_path, text, "check")
    assert "design.pin_circle_radius_mm = 2000" in line and "eccentricity too small" not in line
    assert "lower design.pin_circle_radius_mm to at most 1200" in line
    assert "raise design.eccentricity_mm to at least 2.5" in line


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ("width_mm = 12.0 ", "width_mm = 1e-6 ", "design.width_mm"),
        ("youngs_modulus_gpa = 206.0", "youngs_modulus_gpa = 0.1", "youngs_modulus_gpa"),
    ],
)
def test_a_torque_the_contact_cannot_carry_names_width_and_modulus(tmp_path, old, new, key):
    line = _error(tmp_path, TABLE2.replace(old, new))
    assert "torque too large" in line
    assert "raise design.width_mm or the youngs_modulus_gpa of [material]" in line, line


def test_the_factor_of_a_torque_too_large_for_a_thin_disc(tmp_path):
    """The law's largest force is proportional to B (Eqs. 20-23): the width the factor
    asks for is accepted, a tenth of it is not."""
    line = _error(tmp_path, TABLE2.replace("width_mm = 12.0 ", "width_mm = 1e-6 "))
    factor = float(re.search(r"by a factor above ([0-9.e+]+)", line).group(1))
    assert factor > 1
    study = tmp_path / "wide.toml"
    study.write_text(TABLE2.replace("width_mm = 12.0 ", f"width_mm = {3e-6 * factor} "))
    done = CliRunner().invoke(
        app, ["run", str(study), "--out", str(tmp_path / "o2"), "-q", "--figures", "none"]
    )
    assert "torque too large for the contact" not in done.output, done.output


def test_a_clearance_deeper_than_the_teeth_names_the_modification(tmp_path):
    """Δρ − Δa ≥ a + e − sqrt(a² + e² − 2ae·cos(π/n1)) (2995.3 µm on Table 1): no pin
    reaches the teeth midway between two pins; refused at load, by check too."""
    for value, ok in ((2990.0, True), (3400.0, False)):
        text = TABLE2.replace("pin_radius_um = 8.0 ", f"pin_radius_um = {value} ")
        text = text[: text.index("[[cases]]")]
        if ok:
            study = tmp_path / "ok.toml"
            study.write_text(text)
            assert CliRunner().invoke(app, ["check", str(study)]).exit_code == 0
            continue
        line = _error(tmp_path, text, "check")
        assert "modification.pin_radius_um = 3400: no pin reaches the disc's teeth" in line
        assert "it must be below 2995.29" in line
        assert "check the errors" not in line


def test_a_pin_that_does_not_fit_the_concave_bottom_names_the_key_with_its_unit(tmp_path):
    text = TABLE2.replace("pin_radius_um = 8.0 ", "pin_radius_um = -1000.0 ")
    line = _error(tmp_path, text, "check")
    assert "modification.pin_radius_um = -1000: the pin does not fit" in line
    assert re.search(r"raise it above -208\.\d+", line), line


def test_a_measured_pin_beyond_its_bound_names_the_file_and_the_row(tmp_path):
    rows = (EXAMPLES / "measured_pins.csv").read_text().splitlines()
    for k, row in enumerate(rows):
        if row.startswith("3,"):
            cells = row.split(",")
            rows[k] = ",".join([*cells[:3], "-3500"])
            line_number = k + 1
    (tmp_path / "measured_pins.csv").write_text("\n".join(rows) + "\n")
    text = (EXAMPLES / "measured.toml").read_text()
    line = _error(tmp_path, text, "check")
    assert f"errors.file: measured_pins.csv line {line_number} (pin 3): pin_radius_um = -3500" in (
        line
    )
    assert "errors.pin_radius_um" not in line


def test_a_face_width_beyond_a_double_is_not_told_to_grow(tmp_path):
    """design.width_mm = 1e300: the contact law's coefficients (∝ 1/B) underflow, so no
    pin carries the torque although its largest force is not reached; the line used to
    say "raise design.width_mm". It names the width and the modulus and asks for a real
    size instead (1e250 mm still computes)."""
    line = _error(tmp_path, TABLE2.replace("width_mm = 12.0 ", "width_mm = 1e300 "))
    assert "raise design.width_mm" not in line, line
    assert "cannot be evaluated in double precision" in line
    assert "design.width_mm and the youngs_modulus_gpa of [material]" in line
