"""Study-file keys of the drive characteristics: torque lists, discs, [stiffness]."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile import load_study

DESIGN = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[modification]
pin_radius_um = 8.0
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_torque_list_discs_and_stiffness_reach_the_core(tmp_path):
    study = load_study(
        write(
            tmp_path,
            DESIGN.replace("width_mm = 12.0", "width_mm = 12.0\ndiscs = 2")
            + "[load]\ntorque_nm = [-250, 100.0, 250]\n"
            + "[stiffness]\nrated_torque_nm = 250.0\nseries_stiffness_nm_per_arcmin = 113.0\n",
        )
    )
    core = study.cases[0].to_core()
    np.testing.assert_array_equal(core.torque, [-250.0, 100.0, 250.0])
    assert core.discs == 2 and core.kwargs()["discs"] == 2
    section = study.cases[0].stiffness
    assert section.rated_torque_nm == 250.0 and section.points == 41
    assert section.series_stiffness_nm_per_arcmin == 113.0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "[load]\ntorque_nm = 0.0\n",
            "load.torque_nm: expected a torque other than 0 (with no load",
        ),
        (
            "[load]\ntorque_nm = [250.0, 0]\n",
            "load.torque_nm: item 2 is 0: expected a torque other than 0",
        ),
        ("[load]\ntorque_nm = []\n", "at least one torque"),
        ("[load]\ntorque_nm = [1.0, 1.0]\n", "must differ"),
        ('[load]\ntorque_nm = "250"\n', "expected a number or a list"),
        ("[stiffness]\npoints = 5\n", "stiffness.rated_torque_nm: required key missing"),
        (
            "[stiffness]\nrated_torque_nm = -1.0\n",
            "stiffness.rated_torque_nm: expected a number > 0",
        ),
        ("[stiffness]\nrated_torque_nm = 1.0\npoints = 1\n", "stiffness.points"),
        ('[stiffness]\nrated_torque_nm = "250"\n', "stiffness.rated_torque_nm: expected a number"),
        ("[stiffness]\nrated_torque_nm = 1.0\nrated_nm = 1.0\n", "stiffness.rated_nm: unknown key"),
        (
            "[stiffness]\nrated_torque_nm = 1.0\nseries_stiffness_nm_per_arcmin = 0.0\n",
            "stiffness.series_stiffness_nm_per_arcmin: expected a number > 0",
        ),
    ],
)
def test_bad_drive_keys_give_one_line(tmp_path, text, message):
    with pytest.raises(StudyError, match=message.replace("[", r"\[").replace("(", r"\(")):
        load_study(write(tmp_path, DESIGN + text))


def test_discs_must_be_positive(tmp_path):
    with pytest.raises(StudyError, match="design.discs"):
        load_study(write(tmp_path, DESIGN.replace("width_mm = 12.0", "width_mm = 12.0\ndiscs = 0")))


def test_a_case_overrides_the_stiffness_section(tmp_path):
    study = load_study(
        write(
            tmp_path,
            DESIGN
            + "[stiffness]\nrated_torque_nm = 250.0\n"
            + '[[cases]]\nname = "a"\n[[cases]]\nname = "b"\nstiffness.rated_torque_nm = 100.0\n',
        )
    )
    assert [c.stiffness.rated_torque_nm for c in study.cases] == [250.0, 100.0]
    assert study.file.stiffness.rated_torque_nm == 250.0
