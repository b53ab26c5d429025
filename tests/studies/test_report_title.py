"""The report's title says the kind of study once (issue 23: "Tolerance study: …:
tolerance study")."""

from __future__ import annotations

import re
from pathlib import Path

from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.studies.execute import report_title

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_the_kind_of_study_is_added_only_when_the_title_does_not_say_it():
    assert report_title("Tolerance study: Table 1", "tolerance study") == "Tolerance study: Table 1"
    assert report_title("Table 1 pair", "tolerance study") == "Table 1 pair: tolerance study"
    assert report_title("Table 2", "") == "Table 2"


def test_the_tolerance_report_title_is_not_doubled(tmp_path):
    text = (EXAMPLES / "tolerance.toml").read_text()
    text = text.replace("rings = 1000", "rings = 4").replace(
        "crank_step_deg = 1.0", "crank_step_deg = 30.0"
    )
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app,
        ["tolerance", str(tmp_path / "s.toml"), "--out", str(out), "-q"]
        + ["--figures", "none", "--workers", "1"],
    )
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text()
    (heading,) = re.findall(r"<h1>(.*?)</h1>", page)
    assert heading.lower().count("tolerance study") == 1, heading
    assert heading.startswith("Tolerance study: Table 1 design"), heading
