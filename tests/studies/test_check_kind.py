"""``cyclomesh check`` refuses what the command would refuse before computing (issue 23).

For every refusal a command makes before it computes (the key-usage table, a missing
section, the export's limits), ``check --kind`` refuses the same file with the same
line, and ``check`` without ``--kind`` refuses it for the commands the file is written
for; an accepted check means the command starts computing.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DISC = (
    "\n[design.disc]\ncrank_holes = 3\ncrank_hole_circle_radius_mm = 45.0\n"
    "crank_hole_radius_mm = 10.0\n"
)


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


def one_line(result) -> str:
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert lines[0].startswith("error: ")
    return lines[0]


def test_crank_holes_without_a_stage_refused_by_check_as_by_run(tmp_path):
    text = (EXAMPLES / "table2.toml").read_text()
    head, cases = text.split("[[cases]]", 1)
    study = tmp_path / "s.toml"
    study.write_text(head + DISC + "\n[[cases]]" + cases)
    refused = one_line(invoke("run", str(study), "--out", str(tmp_path / "o"), "-q"))
    assert "design.disc" in refused
    assert one_line(invoke("check", str(study), "--kind", "run")) == refused
    line = one_line(invoke("check", str(study)))
    assert line.startswith("error: cyclomesh run would refuse it: ") and "design.disc" in line


@pytest.mark.parametrize(
    ("example", "kind", "edit", "expect"),
    [
        ("section42.toml", "tolerance", None, "no [tolerance] section"),
        ("tolerance.toml", "tolerance", '\n[[cases]]\nname = "x"\n', "cases"),
        ("table2.toml", "stiffness", None, "figures.stress_pin"),
        ("table2.toml", "design", None, "no [design_space] section"),
        ("tolerance.toml", "allocate", '\n[[cases]]\nname = "x"\n', "cases"),
        (
            "table2.toml",
            "export",
            '\n[[cases]]\nname = "neg"\nmodification.rotation_urad = -20.0\n',
            "rotation",
        ),
        ("stiffness.toml", "fe", None, "pin errors"),
        ("table2.toml", "efficiency", None, "no [efficiency] section"),
    ],
)
def test_check_kind_refuses_as_the_command_does(tmp_path, example, kind, edit, expect):
    study = tmp_path / "s.toml"
    study.write_text((EXAMPLES / example).read_text() + (edit or ""))
    checked = one_line(invoke("check", str(study), "--kind", kind))
    assert expect in checked
    extra = ["--workers", "1"] if kind in ("tolerance", "allocate") else []
    ran = one_line(invoke(kind, str(study), "--out", str(tmp_path / "o"), "-q", *extra))
    assert ran == checked
    assert not (tmp_path / "o").exists()


def test_check_accepts_every_example_for_every_command_it_is_written_for():
    for example in sorted(EXAMPLES.glob("*.toml")):
        result = invoke("check", str(example))
        assert result.exit_code == 0, (example.name, result.output)
        assert "for run" in result.output


def test_check_kind_unknown_is_one_line():
    line = one_line(invoke("check", str(EXAMPLES / "table2.toml"), "--kind", "walk"))
    assert "--kind" in line and "export" in line and "efficiency" in line


def test_check_help_names_every_kind():
    """Every command that computes from a study file is a --kind (efficiency came later)."""
    from cyclomesh.studyfile.kinds import KINDS

    text = " ".join(invoke("check", "--help").output.split())
    for spec in KINDS:
        if spec.command != "explore":
            assert spec.command in text.split("--kind", 1)[1], spec.command


def test_friction_with_a_stage_refused_by_check_as_by_run(tmp_path):
    """What the stage's equilibrium does not take with friction (a crank-bearing coefficient
    with rigid crank bearings, docs/stage.md) is refused by check as by run."""
    text = (EXAMPLES / "rv_stage.toml").read_text()
    for head in ("[stage.crank_bearing]", "[stage.crankshaft]", "[stage.duty_cycle]",
                 "[stage.carrier]"):  # fmt: skip
        start = text.index("\n" + head) + 1
        text = text[:start] + text[text.index("\n[", start + 1) + 1 :]
    friction = (
        "[friction]\nmesh_coefficient = 0.1\ngroove_coefficient = 0.1\n"
        "bearing_coefficient = 0.0025\nbearing_diameter_mm = 18.0\n\n"
    )
    study = tmp_path / "s.toml"
    study.write_text(text.replace("\n[stage]\n", "\n" + friction + "[stage]\n", 1))
    refused = one_line(invoke("run", str(study), "--out", str(tmp_path / "o"), "-q"))
    assert "bearing_coefficient" in refused and "[stage.crank_bearing]" in refused
    assert one_line(invoke("check", str(study), "--kind", "run")) == refused
    line = one_line(invoke("check", str(study)))
    assert line.startswith("error: cyclomesh run would refuse it: ") and "bearing" in line
    assert not (tmp_path / "o").exists()


def test_allocate_refuses_a_bad_target_probability_before_the_folder(tmp_path):
    out = tmp_path / "out"
    line = one_line(
        invoke(
            "allocate",
            str(EXAMPLES / "tolerance.toml"),
            "--out",
            str(out),
            "--target-probability",
            "0",
        )
    )
    assert "--target-probability" in line and not out.exists()


@pytest.mark.parametrize(
    ("example", "old", "new", "expect"),
    [
        ("design.toml", "torque_nm = 250.0", "torque_nm = [100.0, 250.0]", "load.torque_nm"),
        ("design.toml", "[design_space]\n", "[design_space]\nrings = 4\n", "needs a [tolerance]"),
    ],
)
def test_check_kind_design_refuses_what_design_refuses_before_computing(
    tmp_path, example, old, new, expect
):
    """`check --kind design` (and plain `check` of a file with [design_space]) accepted
    the list of torques and the robust map without [tolerance], and `cyclomesh design`
    then refused them (issue 23: check refuses whatever the command would refuse before
    computing). (The compliant disc over swept geometry, once refused here, is taken:
    tests/designspace/test_design_fe_geometry.py.)"""
    text = (EXAMPLES / example).read_text()
    text = text[: text.index("[[cases]]")] if "[[cases]]" in text else text
    assert old in text
    study = tmp_path / "s.toml"
    study.write_text(text.replace(old, new, 1))
    checked = one_line(invoke("check", str(study), "--kind", "design"))
    assert expect in checked, checked
    assert "cyclomesh design would refuse it" in one_line(invoke("check", str(study)))
    ran = one_line(invoke("design", str(study), "--out", str(tmp_path / "o"), "-q"))
    assert ran == checked
    assert not (tmp_path / "o").exists()
