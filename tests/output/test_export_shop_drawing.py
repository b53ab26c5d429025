"""The DXF as a shop drawing: crank holes, bore and centre marks from [design.disc] on
their own layers; one folder per distinct drawing (issue 23)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import ezdxf
import numpy as np
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.output.folder import load_results

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _stage_study(tmp_path: Path, bore: float | None = 15.0) -> Path:
    text = (EXAMPLES / "rv_stage.toml").read_text()
    if bore is not None:
        text = text.replace(
            "crank_hole_radius_mm = 13.0", f"crank_hole_radius_mm = 13.0\nbore_radius_mm = {bore}"
        )
    study = tmp_path / "rv.toml"
    study.write_text(text)
    return study


def _export(study: Path, out: Path, *extra: str):
    args = ["export", str(study), "--out", str(out), "--chord-tolerance-um", "5", *extra]
    return CliRunner().invoke(app, args)


def test_crank_holes_bore_and_centre_marks_are_drawn_where_the_study_puts_them(tmp_path):
    out = tmp_path / "out"
    result = _export(_stage_study(tmp_path), out, "--format", "dxf", "-q")
    assert result.exit_code == 0, result.output
    for folder, count in (("three_crankshafts", 3), ("two_crankshafts", 2)):
        msp = ezdxf.readfile(out / folder / "profile.dxf").modelspace()
        holes = sorted(
            (c.dxf.center.x, c.dxf.center.y, c.dxf.radius)
            for c in msp.query('CIRCLE[layer=="CRANK_HOLES"]')
        )
        angles = 2 * np.pi * np.arange(count) / count  # hole k at 2πk/N in the disc frame
        expected = sorted((36 * math.cos(t), 36 * math.sin(t), 13.0) for t in angles)
        np.testing.assert_allclose(holes, expected, atol=1e-9)
        (bore,) = msp.query('CIRCLE[layer=="BORE"]')
        assert tuple(bore.dxf.center)[:2] == (0.0, 0.0) and bore.dxf.radius == 15.0
        lines = list(msp.query('LINE[layer=="CENTRE"]'))
        assert len(lines) == 2 * (1 + count)  # a cross at the disc centre and each hole
        mids = {
            (
                round((ln.dxf.start.x + ln.dxf.end.x) / 2, 9),
                round((ln.dxf.start.y + ln.dxf.end.y) / 2, 9),
            )
            for ln in lines
        }
        assert (0.0, 0.0) in mids and len(mids) == 1 + count
        meta = json.loads((out / folder / "export.json").read_text())
        assert meta["crank_holes"] == count and meta["bore_radius_mm"] == 15.0
        assert {"CRANK_HOLES", "BORE", "CENTRE"} <= set(meta["layers"])


def test_without_design_disc_only_the_centre_mark_is_added(tmp_path):
    out = tmp_path / "out"
    assert _export(EXAMPLES / "table2.toml", out, "--format", "dxf,svg", "-q").exit_code == 0
    doc = ezdxf.readfile(out / "Case_1" / "profile.dxf")
    assert "CRANK_HOLES" not in doc.layers and "BORE" not in doc.layers
    assert len(doc.modelspace().query('LINE[layer=="CENTRE"]')) == 2
    assert 'id="centre"' in (out / "Case_1" / "profile.svg").read_text()


def test_a_bore_that_cuts_the_crank_holes_is_refused_naming_the_key(tmp_path):
    study = _stage_study(tmp_path, bore=25.0)  # r_c − r = 23 mm
    for args in (["check", str(study)], ["export", str(study), "--out", str(tmp_path / "o")]):
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 2, result.output
        assert "design.disc.bore_radius_mm = 25: the bore cuts the crank holes" in result.output
        assert "below crank_hole_circle_radius_mm − crank_hole_radius_mm = 23" in result.output
    assert not (tmp_path / "o").exists()


def test_cases_with_the_same_drawing_are_written_once_and_said_so(tmp_path):
    """Table 2's cases 1 and 2 (and 3 and 4) differ only in groove_deformation."""
    out = tmp_path / "out"
    result = _export(EXAMPLES / "table2.toml", out, "--format", "dxf")
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["Case_1", "Case_3"]
    text = " ".join(result.output.split())  # the terminal wraps long lines
    assert "Case 2: the same drawing as Case 1 (only non-profile keys differ)" in text
    assert "Case 4: the same drawing as Case 3" in text
    summary = load_results(out).summary
    assert summary["case_folders"] == {
        "Case 1": "Case_1",
        "Case 2": "Case_1",
        "Case 3": "Case_3",
        "Case 4": "Case_3",
    }
    assert set(summary["same_profile"]) == {"Case 2", "Case 4"}
    meta = json.loads((out / "Case_1" / "export.json").read_text())
    assert meta["title"].endswith(": Case 1, Case 2")


def test_a_bore_alone_is_the_exports_key_and_every_kind_leaves_it(tmp_path):
    """[design.disc] bore_radius_mm without crank holes or [stage]: drawn by export,
    validated and left alone by run, tolerance and allocate (not a crank hole)."""
    text = (EXAMPLES / "tolerance.toml").read_text()
    text = text.replace("[modification]", "[design.disc]\nbore_radius_mm = 20.0\n\n[modification]")
    study = tmp_path / "bore.toml"
    study.write_text(text)
    for kind in ("run", "tolerance", "allocate", "export"):
        result = CliRunner().invoke(app, ["check", "--kind", kind, str(study)])
        assert result.exit_code == 0, (kind, result.output)
    out = tmp_path / "out"
    assert _export(study, out, "--format", "dxf", "-q").exit_code == 0
    (folder,) = [p for p in out.iterdir() if p.is_dir()]
    msp = ezdxf.readfile(folder / "profile.dxf").modelspace()
    assert [c.dxf.radius for c in msp.query('CIRCLE[layer=="BORE"]')] == [20.0]
    assert not msp.query('CIRCLE[layer=="CRANK_HOLES"]')
    too_big = text.replace("bore_radius_mm = 20.0", "bore_radius_mm = 77.0")  # root 77 mm
    study.write_text(too_big)
    result = CliRunner().invoke(app, ["check", str(study)])
    assert result.exit_code == 2 and "the bore reaches the tooth root" in result.output
