"""The disc's crank holes (``[design.disc]``): one set of keys for supports and cranks."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cyclomesh import TABLE1, CrankHoles, DesignError
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
"""


def study(tmp_path: Path, disc: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(DESIGN + "\n[design.disc]\n" + disc, encoding="utf-8")
    return path


def test_hole_centres_are_equally_spaced_on_the_circle():
    holes = CrankHoles(count=3, circle_radius=0.038, radius=0.011)
    centres = holes.centres
    np.testing.assert_allclose(np.hypot(*centres.T), 0.038, rtol=0, atol=1e-15)
    gaps = np.diff(np.unwrap(np.arctan2(centres[:, 1], centres[:, 0])))
    np.testing.assert_allclose(gaps, 2 * math.pi / 3, rtol=0, atol=1e-14)
    holes.check_fits(TABLE1)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"count": 1, "circle_radius": 0.03, "radius": 0.01}, "2 to 12"),
        ({"count": 3, "circle_radius": 0.01, "radius": 0.011}, "disc centre"),
        ({"count": 6, "circle_radius": 0.03, "radius": 0.02}, "overlap"),
        ({"count": 3, "circle_radius": -0.03, "radius": 0.01}, "positive"),
    ],
)
def test_bad_holes_are_refused(kwargs, match):
    with pytest.raises(DesignError, match=match):
        CrankHoles(**kwargs)


def test_holes_reaching_the_tooth_root_are_refused():
    with pytest.raises(DesignError, match="tooth root"):
        CrankHoles(count=3, circle_radius=0.070, radius=0.011).check_fits(TABLE1)


def test_study_keys_reach_the_case_inputs(tmp_path):
    text = "crank_holes = 2\ncrank_hole_circle_radius_mm = 40.0\ncrank_hole_radius_mm = 12.0\n"
    inputs = load_study(study(tmp_path, text)).inputs[0]
    assert inputs.crank_holes == CrankHoles(count=2, circle_radius=0.040, radius=0.012)


def test_no_holes_by_default(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(DESIGN, encoding="utf-8")
    assert load_study(path).inputs[0].crank_holes is None


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("crank_holes = 3\n", "crank_hole_circle_radius_mm"),
        ("crank_hole_radius_mm = 11.0\n", "set crank_holes"),
        (
            "crank_holes = 3\ncrank_hole_circle_radius_mm = 75.0\ncrank_hole_radius_mm = 11.0\n",
            "tooth root",
        ),
    ],
)
def test_bad_study_keys_give_one_line(tmp_path, text, match):
    with pytest.raises(StudyError, match=match) as info:
        load_study(study(tmp_path, text))
    assert "\n" not in str(info.value)
