"""Study files: parsing, merging, unit conversion and one-line error messages."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile import load_study
from cyclomesh.studyfile.measurements import read_pin_errors_csv
from cyclomesh.studyfile.schema import crank_angles_deg, deep_merge

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def numbers(count: int, value: float = 0.0) -> str:
    """A TOML list of ``count`` equal numbers."""
    return "[" + ", ".join([repr(float(value))] * count) + "]"


DESIGN = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
"""


def write(tmp_path: Path, text: str, name: str = "study.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def csv_text(pins: int = 40, header: str = "pin,radial_um,angular_urad,pin_radius_um") -> str:
    rows = [f"{p},{0.1 * p:.1f},{-p},{-0.5}" for p in range(1, pins + 1)]
    return "\n".join(["# comment line", header, *rows]) + "\n"


# --- crank angles ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("start", "stop", "step", "count"),
    [
        (0.0, 360.0, 0.1, 3600),
        (0.0, 360.0, 1.0, 360),
        (0.0, 10.0, 3.0, 4),
        (0.0, 1.0, 0.1, 10),
        (10.0, 20.0, 0.7, 15),
        (0.0, 9.0, 9.0 / 7.0, 7),
    ],
)
def test_crank_angles_exclude_stop_like_arange(start, stop, step, count):
    angles = crank_angles_deg(start, stop, step)
    assert len(angles) == count
    assert angles[0] == start
    assert angles[-1] < stop - 1e-6 * step <= angles[-1] + step  # stop excluded, none missing
    np.testing.assert_allclose(np.diff(angles), step, rtol=1e-12)


def test_default_analysis_is_3600_angles_at_0_1_deg(tmp_path):
    case = load_study(write(tmp_path, DESIGN)).cases[0]
    inputs = case.to_core()
    assert inputs.crank_angles.shape == (3600,)
    assert np.rad2deg(inputs.crank_angles[-1]) == pytest.approx(359.9, abs=1e-9)


# --- the examples and the defaults ----------------------------------------------------


def test_table2_example_cases_match_the_paper():
    study = load_study(EXAMPLES / "table2.toml")
    flags = [(c.modification.pin_radius_um, c.analysis.groove_deformation) for c in study.cases]
    assert [c.name for c in study.cases] == ["Case 1", "Case 2", "Case 3", "Case 4"]
    assert flags == [(8.0, False), (8.0, True), (0.0, False), (0.0, True)]
    core = study.cases[0].to_core()
    assert core.design.pins == 40
    assert core.design.pin_circle_radius == pytest.approx(82e-3, rel=1e-15)
    assert core.design.groove_radius == pytest.approx(3.505e-3, rel=1e-15)
    assert core.modification.pin_radius == pytest.approx(8e-6, rel=1e-15)
    assert core.torque == 250.0
    assert core.design.pin_material.youngs_modulus == pytest.approx(206e9)
    assert study.sha256 == hashlib.sha256((EXAMPLES / "table2.toml").read_bytes()).hexdigest()


def test_section42_case3_draws_within_the_half_ranges():
    study = load_study(EXAMPLES / "section42.toml")
    assert all(c.analysis.groove_deformation for c in study.cases)
    ideal, tpm, errors = (c.to_core() for c in study.cases)
    assert ideal.modification.pin_radius == 0.0 and tpm.modification.pin_radius == 8e-6
    assert not np.any(tpm.errors.radial)
    radial, angular = errors.errors.radial, errors.errors.angular
    assert radial.shape == angular.shape == (40,)
    assert np.all(np.abs(radial) <= 4e-6) and np.all(np.abs(angular) <= 50e-6)
    assert np.ptp(radial) > 4e-6 and np.ptp(angular) > 50e-6  # spread over the range
    assert np.all(errors.errors.pin_radius == 0.0)


def test_measured_example_reads_the_csv():
    study = load_study(EXAMPLES / "measured.toml")
    nominal, measured = (c.to_core() for c in study.cases)
    table = read_pin_errors_csv(EXAMPLES / "measured_pins.csv", 40)
    np.testing.assert_allclose(measured.errors.radial, table["radial_um"] * 1e-6, rtol=1e-15)
    np.testing.assert_allclose(measured.errors.angular, table["angular_urad"] * 1e-6)
    assert float(measured.errors.eccentricity) == pytest.approx(1e-6)
    assert not np.any(nominal.errors.radial)


def test_defaults_are_table1_steel_250_nm_and_no_modification(tmp_path):
    study = load_study(write(tmp_path, 'title = "only a design"\n' + DESIGN))
    (case,) = study.cases
    assert case.name == "only a design" and study.title == "only a design"
    core = case.to_core()
    assert core.torque == 250.0 and core.groove_deformation is True
    assert core.modification.pin_radius == 0.0 and core.modification.pin_circle_radius == 0.0
    for material in (core.design.pin_material, core.design.disc_material):
        assert material.youngs_modulus == pytest.approx(206e9) and material.poisson_ratio == 0.3
    assert study.figures.stress_pin is None and study.tolerance is None  # pin n1/2


def test_cases_deep_merge_and_overrides_win(tmp_path):
    text = (
        DESIGN
        + """
[modification]
pin_circle_radius_um = -2.0
pin_radius_um = 8.0
[[cases]]
name = "a"
modification.pin_radius_um = 5.0
[[cases]]
name = "b"
analysis.crank_step_deg = 1.0
"""
    )
    study = load_study(write(tmp_path, text), {"analysis": {"crank_step_deg": 10.0}})
    a, b = study.cases
    assert (a.modification.pin_circle_radius_um, a.modification.pin_radius_um) == (-2.0, 5.0)
    assert b.modification.pin_radius_um == 8.0
    assert a.analysis.crank_step_deg == b.analysis.crank_step_deg == 10.0
    assert deep_merge({"x": {"y": 1, "z": [1]}}, {"x": {"z": [2]}}) == {"x": {"y": 1, "z": [2]}}


def test_material_per_part_falls_back_to_common_then_steel(tmp_path):
    text = (
        DESIGN
        + """
[material]
youngs_modulus_gpa = 200.0
[material.ring]
youngs_modulus_gpa = 110.0
poisson_ratio = 0.28
"""
    )
    design = load_study(write(tmp_path, text)).cases[0].to_core().design
    assert design.pin_material.youngs_modulus == pytest.approx(200e9)
    assert design.ring_material.youngs_modulus == pytest.approx(110e9)
    assert design.ring_material.poisson_ratio == 0.28
    assert design.disc_material.poisson_ratio == 0.3


def test_errors_add_up_lists_scalars_file_and_random(tmp_path):
    write(tmp_path, csv_text(), "pins.csv")
    text = (
        DESIGN
        + """
[errors]
radial_um = 1.0
angular_urad = """
        + numbers(40, 10.0)
        + """
file = "pins.csv"
random = { seed = 3, pin_radius_um = 2.0 }
"""
    )
    case = load_study(write(tmp_path, text)).cases[0]
    per_pin = case.pin_errors()
    pins = np.arange(1, 41)
    np.testing.assert_allclose(per_pin["radial_um"], 1.0 + np.round(0.1 * pins, 1))
    np.testing.assert_allclose(per_pin["angular_urad"], 10.0 - pins)
    drawn = np.random.default_rng(3)
    drawn.uniform(0, 0, 40), drawn.uniform(0, 0, 40)
    np.testing.assert_allclose(per_pin["pin_radius_um"], -0.5 + drawn.uniform(-2.0, 2.0, 40))


def test_random_draws_are_reproducible_and_independent_per_field(tmp_path):
    def draws(extra: str) -> dict:
        text = DESIGN + f"[errors.random]\nseed = 11\nradial_um = 4.0\n{extra}"
        return load_study(write(tmp_path, text)).cases[0].pin_errors()

    first, again, more = draws(""), draws(""), draws("angular_urad = 50.0\n")
    np.testing.assert_array_equal(first["radial_um"], again["radial_um"])
    np.testing.assert_array_equal(first["radial_um"], more["radial_um"])
    assert len(np.unique(first["radial_um"])) == 40  # one independent draw per pin
    assert np.all(np.abs(more["angular_urad"]) <= 50.0) and np.any(more["angular_urad"])


TOLERANCE = """
[tolerance]
seed = 1
rings = 100
allowable_contact_stress_mpa = 2000.0
radial_um = { distribution = "uniform", half_range = 4.0 }
"""


def test_tolerance_section_is_validated_with_the_study(tmp_path):
    spec = load_study(write(tmp_path, DESIGN + TOLERANCE)).tolerance
    assert spec.rings == 100 and spec.radial_um.half_range == 4.0
    assert spec.angular_urad is None and spec.allocation.confidence == 0.95


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("seed = 1", "seed = true", "tolerance.seed: expected an integer, got true"),
        ("rings = 100", 'rings = "12"', 'tolerance.rings: expected an integer, got "12"'),
        ("rings = 100", "rings = 12.0", "tolerance.rings: expected an integer, got 12.0"),
        ("rings = 100", "rings = 100\nring = 3", "tolerance.ring: unknown key (expected one of"),
        ("half_range = 4.0", 'half_range = "4"', "tolerance.radial_um.half_range: expected a "),
        ("half_range = 4.0", "half_range = 4.0, hlf = 1", "tolerance.radial_um.hlf: unknown key"),
        ("seed = 1", "", "tolerance.seed: required key missing"),
    ],
)
def test_tolerance_section_refuses_what_run_sections_refuse(tmp_path, old, new, expected):
    with pytest.raises(StudyError) as info:
        load_study(write(tmp_path, DESIGN + TOLERANCE.replace(old, new)))
    assert str(info.value).startswith(expected)
    assert "\n" not in str(info.value)


# --- one-line messages naming the key -------------------------------------------------

TABLE2 = (EXAMPLES / "table2.toml").read_text(encoding="utf-8")

BAD = {
    "unknown key": (
        TABLE2.replace("width_mm = 12.0", "width_mm = 12.0\nwidht_mm = 12.0"),
        "design.widht_mm: unknown key (expected one of: pins,",
    ),
    "unknown key in a case": (
        TABLE2.replace('name = "Case 3"', 'name = "Case 3"\nload.torque = 1.0'),
        'case "Case 3": load.torque: unknown key',
    ),
    "unknown section": (TABLE2 + "\n[loads]\ntorque_nm = 1.0\n", "loads: unknown key"),
    "wrong type": (
        TABLE2.replace("pins = 40", 'pins = "40"'),
        'design.pins: expected an integer, got "40"',
    ),
    "float for an integer": (
        TABLE2.replace("pins = 40", "pins = 40.0"),
        "design.pins: expected an integer",
    ),
    "wrong bool": (
        TABLE2.replace("groove_deformation = false", "groove_deformation = 0", 1),
        'case "Case 1": analysis.groove_deformation: expected true or false, got 0',
    ),
    "negative size": (
        TABLE2.replace("pin_radius_mm = 3.5", "pin_radius_mm = -3.5"),
        "design.pin_radius_mm: expected a number > 0, got -3.5",
    ),
    "zero step": (
        TABLE2.replace("crank_step_deg = 0.1", "crank_step_deg = 0.0"),
        "analysis.crank_step_deg: expected a number >= 0.0001, got 0.0",
    ),
    "infinite torque": (
        TABLE2.replace("torque_nm = 250.0", "torque_nm = inf"),
        "load.torque_nm: expected a finite number, got inf",
    ),
    "missing key": (TABLE2.replace("width_mm = 12.0", ""), "design.width_mm: required key missing"),
    "list too short": (
        TABLE2.replace("[load]", "[errors]\nradial_um = " + numbers(39) + "\n[load]"),
        'case "Case 1": errors.radial_um: expected 40 values (one per pin), got 39',
    ),
    "list of strings": (
        TABLE2.replace("[load]", '[errors]\nangular_urad = [1.0, "x"]\n[load]'),
        'errors.angular_urad: item 2 is "x": expected a number',
    ),
    "random without seed": (
        TABLE2.replace("[load]", "[errors.random]\nradial_um = 4.0\n[load]"),
        "errors.random.seed: required key missing",
    ),
    "negative half-range": (
        TABLE2.replace("[load]", "[errors.random]\nseed = 1\nradial_um = -4.0\n[load]"),
        "errors.random.radial_um: expected a number >= 0",
    ),
    "stress pin beyond the ring": (
        TABLE2.replace("stress_pin = 20", "stress_pin = 41"),
        "figures.stress_pin: expected a pin number from 1 to 40, got 41",
    ),
    "Poisson ratio": (
        TABLE2.replace("poisson_ratio = 0.3", "poisson_ratio = 0.5"),
        "material.poisson_ratio: expected a number < 0.5, got 0.5",
    ),
    "case without name": (
        TABLE2.replace('name = "Case 2"', ""),
        "cases[1]: name: required key missing",
    ),
    "clashing case folders": (
        TABLE2.replace('name = "Case 2"', 'name = "case 1"'),
        'case "case 1": name clashes with case "Case 1"',
    ),
    "stop before start": (
        TABLE2.replace("crank_stop_deg = 360.0", "crank_stop_deg = 0.0"),
        "analysis: crank_start_deg = 0, crank_stop_deg = 0 and crank_step_deg = 0.1 give fewer",
    ),
    "malformed TOML": (TABLE2.replace("pins = 40", "pins = "), "study.toml: invalid TOML: "),
    "undercut": (
        TABLE2.replace("eccentricity_mm = 1.5", "eccentricity_mm = 2.0"),
        'case "Case 1": undercut profile',
    ),
    "K1 >= 1": (
        TABLE2.replace("eccentricity_mm = 1.5", "eccentricity_mm = 2.1"),
        'case "Case 1": design.eccentricity_mm = 2.1, design.pins = 40 and '
        "design.pin_circle_radius_mm = 82 give K1 = e·n1/a = 1.024; it must be below 1",
    ),
    "K1 too small from the pin circle": (
        TABLE2.replace("pin_circle_radius_mm = 82.0", "pin_circle_radius_mm = 2000.0"),
        "design.pin_circle_radius_mm = 2000 give K1 = e·n1/a = 0.03; it must be at least "
        "0.05 (a cycloid disc, not a circle): lower design.pin_circle_radius_mm to at most "
        "1200, or raise design.eccentricity_mm to at least 2.5",
    ),
    "interfering pins": (
        TABLE2.replace("pin_radius_mm = 3.5", "pin_radius_mm = 6.5").replace(
            "groove_radius_mm = 3.505", "groove_radius_mm = 6.6"
        ),
        'case "Case 1": design.pin_radius_mm = 6.5: neighbouring pins interfere',
    ),
}


@pytest.mark.parametrize("name", list(BAD))
def test_bad_input_is_one_line_naming_the_key(tmp_path, name):
    text, expected = BAD[name]
    with pytest.raises(StudyError) as info:
        load_study(write(tmp_path, text))
    message = str(info.value)
    assert expected in message
    assert "\n" not in message


def test_missing_study_file(tmp_path):
    with pytest.raises(StudyError, match="study file not found: .*nope.toml"):
        load_study(tmp_path / "nope.toml")


@pytest.mark.parametrize(
    ("csv", "expected"),
    [
        (None, "errors.file: file not found: "),
        (csv_text(header="pin,radial_um,pin_radius_um"), "missing column 'angular_urad'"),
        (csv_text(header="pin,radial_um,angular_urad,pin_radius_um,note"), "unknown column 'note'"),
        (csv_text(pins=39), "expected 40 rows (one per pin), got 39; missing pin 40"),
        (
            csv_text().replace("\n5,0.5,", "\n5,abc,"),
            "line 7: radial_um 'abc' is not a finite number",
        ),
        (csv_text().replace("\n5,0.5,", "\n4,0.5,"), "line 7: pin 4 appears twice"),
        (csv_text().replace("\n5,0.5,-5,-0.5", "\n5,0.5,-5"), "line 7: expected 4 values"),
        ("", "the file is empty"),
    ],
)
def test_bad_csv_names_errors_file(tmp_path, csv, expected):
    if csv is not None:
        write(tmp_path, csv, "pins.csv")
    text = DESIGN + '[[cases]]\nname = "measured"\nerrors.file = "pins.csv"\n'
    with pytest.raises(StudyError) as info:
        load_study(write(tmp_path, text))
    message = str(info.value)
    assert message.startswith('case "measured": errors.file: ')
    assert expected in message and "\n" not in message


def test_named_materials_and_explicit_values(tmp_path):
    from cyclomesh.core.materials import MATERIALS

    base = (EXAMPLES / "table2.toml").read_text().split("[material]")[0]
    path = tmp_path / "m.toml"
    path.write_text(
        base
        + '[material]\nname = "gcr15"\n[material.ring]\nname = "nodular_iron"\n'
        + "poisson_ratio = 0.28\n"
    )
    study = load_study(path)
    design = study.inputs[0].design
    assert design.disc_material.youngs_modulus == MATERIALS["gcr15"].youngs_modulus
    assert design.ring_material.youngs_modulus == 176e9  # EN 1563
    assert design.ring_material.poisson_ratio == 0.28  # explicit value wins over the name
    material = study.cases[0].material
    assert material.allowable_mpa("disc") == 1500.0 and material.allowable_mpa("ring") == 600.0
    assert material.names() == {"pin": "GCr15", "disc": "GCr15", "ring": "EN-GJS-700-2"}
    assert all(grade.source and grade.allowable_contact_stress > 0 for grade in MATERIALS.values())
    path.write_text(base + '[material]\nname = "unobtainium"\n')
    with pytest.raises(StudyError, match=r"^material\.name: unknown material 'unobtainium'"):
        load_study(path)
    # without a name or value, no allowable (steel's E and ν as before)
    path.write_text(base)
    assert load_study(path).cases[0].material.allowable_mpa("disc") is None


def _table2_base() -> str:
    return (EXAMPLES / "table2.toml").read_text().split("[[cases]]")[0]


def test_groove_radius_defaults_to_the_table1_clearance(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(_table2_base().replace("groove_radius_mm = 3.505", ""))
    design = load_study(path).inputs[0].design
    assert design.groove_radius == pytest.approx(3.505e-3, abs=1e-15)
    path.write_text(
        _table2_base()
        .replace("groove_radius_mm = 3.505", "")
        .replace("pin_radius_mm = 3.5", "pin_radius_mm = 4.0")
    )
    assert load_study(path).inputs[0].design.groove_radius == pytest.approx(4.005e-3)


def test_tangential_errors_become_angular(tmp_path):
    path = tmp_path / "t.toml"
    tangential = [0.1 * k for k in range(40)]
    path.write_text(
        _table2_base() + f"\n[errors]\ntangential_um = {tangential}\nangular_urad = 10.0\n"
    )
    study = load_study(path)
    angular = study.inputs[0].errors_um["angular_urad"]
    assert np.allclose(angular, 10.0 + np.array(tangential) / 82.0 * 1e3, rtol=1e-14)
    assert np.allclose(study.inputs[0].errors.angular, angular * 1e-6)
    # ±5 µm tangential on a = 82 mm is ±60.98 µrad
    path.write_text(_table2_base() + "\n[errors]\ntangential_um = 5.0\n")
    assert load_study(path).inputs[0].errors_um["angular_urad"][0] == pytest.approx(60.9756, 1e-5)
    path.write_text(_table2_base() + "\n[errors]\ntangential_um = [1.0, 2.0]\n")
    with pytest.raises(StudyError, match="errors.tangential_um: expected 40 values"):
        load_study(path)


def test_random_tangential_errors_keep_the_other_draws(tmp_path):
    path = tmp_path / "r.toml"
    path.write_text(_table2_base() + "\n[errors.random]\nseed = 3\nradial_um = 4.0\n")
    before = load_study(path).inputs[0].errors_um
    path.write_text(
        _table2_base() + "\n[errors.random]\nseed = 3\nradial_um = 4.0\ntangential_um = 5.0\n"
    )
    after = load_study(path).inputs[0].errors_um
    assert np.array_equal(before["radial_um"], after["radial_um"])
    assert not np.any(before["angular_urad"])
    assert np.all(np.abs(after["angular_urad"]) <= 5.0 / 82.0 * 1e3)
    assert np.std(after["angular_urad"]) > 10.0
    path.write_text(
        _table2_base() + "\n[errors.random]\nseed = 3\nangular_urad = 4.0\ntangential_um = 5.0\n"
    )
    with pytest.raises(StudyError, match="angular_urad or tangential_um"):
        load_study(path)


def test_tolerance_tangential_draws():
    from cyclomesh.studyfile.schema import ToleranceSection
    from cyclomesh.tolerance.sampling import draw_ring_errors

    spec = ToleranceSection.model_validate(
        {
            "seed": 1,
            "allowable_contact_stress_mpa": 2000.0,
            "radial_um": {"distribution": "uniform", "half_range": 4.0},
            "tangential_um": {"distribution": "uniform", "half_range": 5.0},
        }
    )
    drawn = draw_ring_errors(spec, 40, 82e-3, range(50))
    assert np.max(np.abs(drawn.angular_urad)) <= 5.0 / 0.082 and np.std(drawn.angular_urad) > 20
    base = ToleranceSection.model_validate(
        {
            "seed": 1,
            "allowable_contact_stress_mpa": 2000.0,
            "radial_um": {"distribution": "uniform", "half_range": 4.0},
        }
    )
    # the radial draws do not change when a tangential tolerance is added
    assert np.array_equal(draw_ring_errors(base, 40, 82e-3, range(50)).radial_um, drawn.radial_um)
    with pytest.raises(ValueError, match="angular_urad or tangential_um"):
        ToleranceSection.model_validate(
            {
                "seed": 1,
                "allowable_contact_stress_mpa": 2000.0,
                "angular_urad": {"distribution": "uniform", "half_range": 4.0},
                "tangential_um": {"distribution": "uniform", "half_range": 5.0},
            }
        )
