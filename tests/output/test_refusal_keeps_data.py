"""A refused command leaves its ``--out`` exactly as it found it (issue 23, item 1).

Every kind of command (run, stiffness, tolerance, allocate, design, fe, export,
efficiency; run also with its figures drawn) first
writes a complete result into a folder; the same command with an input it refuses
only after it computed part of the study (a torque no pin can carry, a ring that jams,
a degenerate sweep, a case that cannot be exported) must then leave every file of that
result byte-identical and ``load_results`` accepting it. A folder the failing command
created itself is removed, also when the disc is full.
"""

from __future__ import annotations

import errno
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.output.folder import LOCK, STAGING, load_results

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
NO_FIGURES = ("-q", "--figures", "none")


def _edit(name: str, *subs: tuple[str, str], cut_cases: bool = False) -> str:
    """The example ``name`` with each ``(regex, replacement)`` applied once (checked)."""
    text = (EXAMPLES / name).read_text(encoding="utf-8")
    if cut_cases:
        text = text[: text.index("[[cases]]")]
    for pattern, repl in subs:
        text, n = re.subn(pattern, repl, text, count=1, flags=re.MULTILINE)
        assert n == 1, pattern
    return text


TOLERANCE = (
    ("tolerance.toml"),
    (r"^rings = .*$", "rings = 3"),
    (r"^crank_step_deg = 1\.0", "crank_step_deg = 30.0"),
    (r"^factor_steps = .*$", "factor_steps = 2"),
    (r"^bisections = .*$", "bisections = 1"),
)
FE = (
    ("fe_table1.toml"),
    (r"^elements_per_half_width = .*$", "elements_per_half_width = 3.0"),
    (r"^far_size_mm = .*$", "far_size_mm = 5.0"),
)
EFFICIENCY = (
    ("efficiency.toml"),
    (r"points = 12", "points = 2"),
    (r"points = 6 ", "points = 2 "),
)
LAST_CASE = '\n[[cases]]\nname = "refused"\n'  # after the cases that compute
STAGE_TORQUE = (r"^torque_nm = .*$", "torque_nm = 1e300")

# command, options, the good study, the refused study (both as text)
CASES = {
    "run": (
        ("run", "--crank-step-deg", "30"),
        _edit("table2.toml"),
        _edit("table2.toml", STAGE_TORQUE),
    ),
    "run-overlap": (
        ("run", "--crank-step-deg", "30"),
        _edit("table2.toml"),
        _edit("table2.toml") + LAST_CASE + "modification.pin_radius_um = -8.0\n",
    ),
    "stiffness": (
        ("stiffness", "--crank-step-deg", "60"),
        _edit("stiffness.toml", (r"^points = .*$", "points = 5")),
        _edit(
            "stiffness.toml",
            (r"^points = .*$", "points = 5"),
            (r"^rated_torque_nm = .*$", "rated_torque_nm = 1e300"),
        ),
    ),
    "stiffness-tiny-torque": (  # refused after the torsion curve: the TE does not move
        ("stiffness", "--crank-step-deg", "60"),
        _edit("stiffness.toml", (r"^points = .*$", "points = 5")),
        _edit(
            "stiffness.toml",
            (r"^points = .*$", "points = 5"),
            (r"^rated_torque_nm = .*$", "rated_torque_nm = 1e-300"),
        ),
    ),
    "run-with-figures": (  # the slow path of run (figures drawn), not results/frame.py's
        ("run", "--crank-step-deg", "30", "--figures", "png"),
        _edit("table2.toml"),
        _edit("table2.toml") + LAST_CASE + "modification.pin_radius_um = -8.0\n",
    ),
    "efficiency": (  # the last torque of the map is one no pin can carry
        ("efficiency",),
        _edit(*EFFICIENCY),
        _edit(*EFFICIENCY, (r"stop = 300\.0, points = 2", "stop = 1e300, points = 2")),
    ),
    "tolerance": (  # jammed rings are counted (issue 23): a failure after the files
        ("tolerance", "--workers", "1"),
        _edit(*TOLERANCE),
        None,
    ),
    "allocate": (
        ("allocate", "--workers", "1"),
        _edit(*TOLERANCE),
        _edit(*TOLERANCE, (r"half_range = 4\.0", "half_range = 3000.0")),
    ),
    "design": (  # a failure after the result files were written (below)
        ("design", "--workers", "1"),
        _edit("design.toml", (r"points = 21", "points = 2"), (r"points = 25", "points = 2")),
        None,
    ),
    "fe": (
        ("fe", "--crank-angles", "0", "--no-convergence"),
        _edit(*FE, cut_cases=True),
        _edit(*FE, STAGE_TORQUE, cut_cases=True),
    ),
    "export": (
        ("export", "--format", "csv"),
        _edit("table2.toml"),
        _edit("table2.toml") + LAST_CASE + "modification.rotation_urad = -20.0\n",
    ),
}


def _fail_at_the_report(monkeypatch, after_first_call: bool) -> None:
    """Make ``publish`` (the report, after the result files) fail as on a full disk."""
    from cyclomesh.exceptions import OutputError
    from cyclomesh.publish import pipeline

    real = pipeline.publish
    calls = []

    def publish(out, *args, **kwargs):
        calls.append(out)
        if after_first_call and len(calls) == 1:
            return real(out, *args, **kwargs)
        assert any(Path(out).iterdir())  # result files already written
        raise OutputError(f"cannot write {out}/report.html: no space left on the device")

    monkeypatch.setattr(pipeline, "publish", publish)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != LOCK
    }


def _invoke(args: tuple[str, ...], study: Path, out: Path):
    command, *more = args
    extra = NO_FIGURES if command != "export" and "--figures" not in more else ("-q",)
    return CliRunner().invoke(app, [command, str(study), "--out", str(out), *more, *extra])


@pytest.mark.parametrize("name", list(CASES))
def test_refused_command_keeps_the_earlier_result_byte_identical(tmp_path, monkeypatch, name):
    args, good, bad = CASES[name]
    if bad is None:  # the same study, failing after its files were written (a full disk)
        bad = good
        _fail_at_the_report(monkeypatch, after_first_call=True)
    (tmp_path / "good.toml").write_text(good, encoding="utf-8")
    (tmp_path / "bad.toml").write_text(bad, encoding="utf-8")
    out = tmp_path / "out"
    first = _invoke(args, tmp_path / "good.toml", out)
    assert first.exit_code == 0, first.output
    before = _snapshot(out)
    assert "summary.json" in before
    refused = _invoke(args, tmp_path / "bad.toml", out)
    lines = [line for line in refused.output.splitlines() if line.strip()]
    assert refused.exit_code == 2 and len(lines) == 1, refused.output
    assert lines[0].startswith("error: ") and "internal error" not in lines[0], lines[0]
    assert _snapshot(out) == before  # every file byte-identical, nothing added
    assert not (out / STAGING).exists()
    load_results(out)  # still complete
    fresh = tmp_path / "fresh" / "out"
    assert _invoke(args, tmp_path / "bad.toml", fresh).exit_code == 2
    assert not (tmp_path / "fresh").exists()  # the folders it created are removed


def test_disk_full_on_a_fresh_folder_leaves_no_folder(tmp_path, monkeypatch):
    """No free byte: even the lock file cannot be created; no empty folder is left."""
    import os

    real_open = os.open

    def full(path, flags, *args, **kwargs):
        if str(path).endswith(LOCK):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", full)
    out = tmp_path / "new" / "out"
    result = CliRunner().invoke(
        app, ["run", str(EXAMPLES / "table2.toml"), "--out", str(out), *NO_FIGURES]
    )
    assert result.exit_code == 2 and "no space left" in result.output, result.output
    assert not (tmp_path / "new").exists()
