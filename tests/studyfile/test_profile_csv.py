"""``[modification] profile_file``: tabulated profile deviations in study files."""

import numpy as np
import pytest

from cyclomesh import StudyError
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.studyfile.schema import load_study

DESIGN = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[analysis]
crank_start_deg = 0.0
crank_stop_deg = 9.0
crank_step_deg = 0.5
"""


def write(tmp_path, modification, csv_text, name="profile.csv"):
    (tmp_path / name).write_text(csv_text)
    path = tmp_path / "study.toml"
    path.write_text(DESIGN + "[modification]\n" + modification)
    return path


def table(angles, values, tooth=None):
    head = "tooth," if tooth is not None else ""
    lines = [f"# a comment\n{head}profile_angle_deg,normal_deviation_um"]
    for k, (a, v) in enumerate(zip(angles, values, strict=True)):
        lines.append((f"{tooth[k]}," if tooth is not None else "") + f"{a},{v}")
    return "\n".join(lines) + "\n"


def run(path):
    kwargs = load_study(path).cases[0].to_core().kwargs()
    assert kwargs.pop("discs") == 1  # one disc: solve_ltca's problem
    return solve_ltca(**kwargs)


def test_constant_table_in_a_study_equals_pin_radius_modification(tmp_path):
    angles = np.linspace(-180, 0, 19)
    with_table = run(write(tmp_path, 'profile_file = "profile.csv"\n', table(angles, [8.0] * 19)))
    plain = tmp_path / "plain.toml"
    plain.write_text(DESIGN + "[modification]\npin_radius_um = 8.0\n")
    reference = run(plain)
    np.testing.assert_allclose(
        with_table.transmission_error, reference.transmission_error, atol=1e-14
    )
    np.testing.assert_allclose(with_table.pin_load, reference.pin_load, rtol=1e-9, atol=1e-8)


def test_per_tooth_table_in_a_study(tmp_path):
    angles = np.linspace(-180, 180, 37)
    teeth = np.repeat(np.arange(1, 40), angles.size)
    values = 6.0 + 0.5 * np.sin(np.deg2rad(np.tile(angles, 39) / 2)) * (teeth % 3)
    text = table(np.tile(angles, 39), values, teeth)
    res = run(write(tmp_path, 'profile_file = "profile.csv"\npin_radius_um = 1.0\n', text))
    assert np.all(res.contacts >= 1)
    case = load_study(tmp_path / "study.toml").cases[0]
    assert case.profile_deviation().teeth == 39 and not case.profile_deviation().symmetric


@pytest.mark.parametrize(
    ("csv_text", "message"),
    [
        (
            table([-180, -170, -175, *range(-160, 1, 10)], [0.0] * 20),
            r"line 5: .*does not increase",
        ),
        (table(np.linspace(-180, 0, 7), [0.0] * 7), r"line 4: .*too coarse"),
        (table(np.linspace(-180, 0, 19), [0.0] * 18 + ["x"]), r"line 21: normal_deviation_um"),
        ("angle,normal_deviation_um\n0,0\n", "missing column 'profile_angle_deg'"),
        (table([-180, 0], [0, 0], tooth=[1, 40]), r"line 4: tooth 40 is not in 1..39"),
    ],
)
def test_bad_tables_name_the_file_and_line(tmp_path, csv_text, message):
    path = write(tmp_path, 'profile_file = "profile.csv"\npin_radius_um = 8.0\n', csv_text)
    with pytest.raises(StudyError, match=message) as info:
        load_study(path)
    assert "profile.csv" in str(info.value) and "\n" not in str(info.value)


def test_a_table_that_loops_the_profile_is_refused_naming_the_line(tmp_path):
    angles = np.linspace(-180, 0, 91)
    bump = -60.0 * np.exp(-(((angles + 60.0) / 4.0) ** 2))
    path = write(
        tmp_path, 'profile_file = "profile.csv"\npin_radius_um = 8.0\n', table(angles, bump)
    )
    with pytest.raises(StudyError, match=r"line \d+: .*(loop|tighter)"):
        load_study(path)
