"""Nothing on stderr before the one error line (issue 23, item 2).

Refusals come at load time naming the key (a seed beyond 64 bits, a sweep whose values
repeat); NumPy's RuntimeWarnings raised on the way to a refusal are not printed; Ctrl-C
of a study is one line and exit 130; a read-only folder is called read-only. These run
the command as a user does (a subprocess), so that whatever reaches stderr is seen.
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from cyclomesh.cli import app

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def cyclomesh(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cyclomesh", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=600,
    )


def only_error_line(done: subprocess.CompletedProcess) -> str:
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("error: "), done.stderr
    assert "internal error" not in done.stderr, done.stderr
    return done.stderr.strip()


def test_a_seed_beyond_64_bits_is_refused_by_check_naming_the_key(tmp_path):
    text = (EXAMPLES / "tolerance.toml").read_text()
    (tmp_path / "s.toml").write_text(text.replace("seed = 20220810", f"seed = {2**64}"))
    for command in (["check"], ["tolerance", "--out", "out", "-q"]):
        line = only_error_line(cyclomesh(command[0], "s.toml", *command[1:], cwd=tmp_path))
        assert line.startswith("error: tolerance.seed: expected a number <= 9223372036854775807")
    assert not (tmp_path / "out").exists()


def test_a_sweep_whose_values_repeat_is_refused_naming_the_key(tmp_path):
    text = (EXAMPLES / "design.toml").read_text()
    text = text.replace("start = -10.0, stop = 0.0, points = 21", "start = 0, stop = 0, points = 3")
    (tmp_path / "s.toml").write_text(text)
    line = only_error_line(cyclomesh("check", "s.toml", cwd=tmp_path))
    assert line.startswith("error: design_space.pin_circle_radius_um: start = stop = 0")


def test_no_runtime_warning_before_the_error_line(tmp_path):
    """Δρ = 3400 µm (no pin reaches the flanks: NaN backlash on the way) and a profile
    table with a 1e300 µm deviation (overflow on the way): the error line alone."""
    text = (EXAMPLES / "table2.toml").read_text()
    (tmp_path / "rho.toml").write_text(
        text + '\n[[cases]]\nname = "loose"\nmodification.pin_radius_um = 3400.0\n'
    )
    done = cyclomesh("run", "rho.toml", "--out", "o1", "-q", "--figures", "none", cwd=tmp_path)
    assert "modification.pin_radius_um = 3400: no pin reaches" in only_error_line(done)
    angles = np.linspace(-180, 0, 19)
    rows = [f"{a},{1e300 if k == 5 else 8.0}" for k, a in enumerate(angles)]
    (tmp_path / "profile.csv").write_text(
        "profile_angle_deg,normal_deviation_um\n" + "\n".join(rows)
    )
    head = text[: text.index("[[cases]]")]
    head = head.replace("[modification]", '[modification]\nprofile_file = "profile.csv"')
    (tmp_path / "p.toml").write_text(head)
    for command in (["check"], ["run", "--out", "o2", "-q", "--figures", "none"]):
        line = only_error_line(cyclomesh(command[0], "p.toml", *command[1:], cwd=tmp_path))
        assert "modification.profile_file profile.csv: line" in line  # the file and its row


def test_ctrl_c_of_a_study_is_one_line_and_exit_130(tmp_path):
    """SIGINT to the command's process group (as a terminal sends it) once the study
    computes on two worker processes: one line, exit 130, no folder left behind."""
    text = (EXAMPLES / "tolerance.toml").read_text().replace("rings = 1000", "rings = 400")
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "cyclomesh", "tolerance", "s.toml", "--out", "out", "-q"]
        + ["--workers", "2", "--figures", "none"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    while not (out / ".cyclomesh.staging").exists() and process.poll() is None:
        time.sleep(0.005)  # polls an observable state; no timing is asserted
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert stderr == "error: interrupted (Ctrl-C): --out is left as it was\n"
    assert not out.exists()


def test_read_only_folder_is_named_read_only(tmp_path, monkeypatch):
    real_open = os.open

    def read_only(path, flags, *args, **kwargs):
        if str(path).endswith(".cyclomesh.lock"):
            raise OSError(errno.EROFS, "Read-only file system")
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", read_only)
    monkeypatch.setattr("shutil.disk_usage", lambda p: type("U", (), {"free": 0})())
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(EXAMPLES / "table2.toml"), "--out", str(out), "-q", "--figures", "none"]
    )
    assert result.exit_code == 2
    assert result.output == f"error: --out {out}: read-only file system\n"


def test_a_key_or_table_given_twice_is_named(tmp_path):
    cases = [
        ("title = 'x'\n[design]\npins = 40\npins = 41\n", "key design.pins given twice (line 4"),
        ("title = 'x'\n[design]\npins = 40\n[design]\n", "table [design] declared twice (line 4)"),
        (
            "title = 'x'\n[[cases]]\nmodification = {pin_radius_um = 1.0}\n"
            "modification.pin_radius_um = 2.0\n",
            "key modification.pin_radius_um of a [[cases]] entry given twice (line 4",
        ),
    ]
    for text, expected in cases:
        (tmp_path / "s.toml").write_text(text)
        line = only_error_line(cyclomesh("check", "s.toml", cwd=tmp_path))
        assert line.startswith(f"error: s.toml: {expected}"), line


def test_an_overlapping_pin_names_the_key_and_the_amount(tmp_path):
    text = (EXAMPLES / "table2.toml").read_text()
    (tmp_path / "s.toml").write_text(
        text + '\n[[cases]]\nname = "tight"\nmodification.pin_radius_um = -8.0\n'
    )
    done = cyclomesh("run", "s.toml", "--out", "o", "-q", "--figures", "none", cwd=tmp_path)
    line = only_error_line(done)
    assert "by 8 µm" in line and "raise modification.pin_radius_um (Δρ) by at least 8 µm" in line


def test_a_forked_worker_that_catches_ctrl_c_stays_silent():
    """A worker forked before its initializer ignores SIGINT inherits the command's
    handler; Ctrl-C there must neither write the command's line a second time nor
    touch the staging folder: the process that installed the handler does both."""
    script = (
        "import os, signal, sys\n"
        "from cyclomesh.cli.errors import _one_line_interrupt\n"
        "with _one_line_interrupt():\n"
        "    child = os.fork()\n"
        "    if child == 0:\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        os._exit(0)\n"
        "    _, status = os.waitpid(child, 0)\n"
        "    print(os.waitstatus_to_exitcode(status))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "130\n"
    assert done.stderr == ""


def test_a_rated_torque_too_small_to_turn_the_mesh_is_one_line(tmp_path):
    """stiffness.rated_torque_nm = 1e-300: the TE at 50 % and 100 % of it is one double,
    so the rigidity would be 0/0; it printed six lines of RuntimeWarning and wrote a
    result with a null rigidity. Now the error line alone, naming the key."""
    text = (EXAMPLES / "stiffness.toml").read_text()
    text = text.replace("rated_torque_nm = 250.0", "rated_torque_nm = 1e-300", 1)
    (tmp_path / "s.toml").write_text(text.replace("points = 41", "points = 5", 1))
    done = cyclomesh(
        "stiffness", "s.toml", "--out", "o", "-q", "--figures", "none",
        "--crank-step-deg", "60", cwd=tmp_path,
    )  # fmt: skip
    line = only_error_line(done)
    assert "rated torque 1e-300 N·m" in line and "stiffness.rated_torque_nm" in line
    assert not (tmp_path / "o").exists()


def test_the_numba_kernel_prints_only_the_error_line(tmp_path):
    """CYCLOMESH_KERNEL=numba (the opt-in compiled pin-step): the refusals on the way
    through the kernel (a torque no pin can carry, a pin that overlaps the disc, a
    clearance deeper than the teeth) are the same one line, no RuntimeWarning or
    compiler message before it, and no folder is left."""
    import pytest

    pytest.importorskip("numba")
    text = (
        (EXAMPLES / "table2.toml")
        .read_text()
        .replace("crank_step_deg = 0.1", "crank_step_deg = 30.0")
    )
    cases = {
        "torque": (text.replace("torque_nm = 250.0", "torque_nm = 1e300"), "torque too large"),
        "overlap": (
            text + '\n[[cases]]\nname = "x"\nmodification.pin_radius_um = -8.0\n',
            "by 8 µm",
        ),
        "deep": (
            text + '\n[[cases]]\nname = "x"\nmodification.pin_radius_um = 3400.0\n',
            "no pin reaches",
        ),
    }
    env = dict(os.environ, CYCLOMESH_KERNEL="numba")
    for name, (study, words) in cases.items():
        (tmp_path / f"{name}.toml").write_text(study)
        done = subprocess.run(
            [sys.executable, "-m", "cyclomesh", "run", f"{name}.toml", "--out", name, "-q"]
            + ["--figures", "none"],
            capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600,
        )  # fmt: skip
        assert words in only_error_line(done), (name, done.stderr)
        assert not (tmp_path / name).exists()


def test_an_unknown_kernel_is_a_refusal_not_an_internal_error(tmp_path):
    """CYCLOMESH_KERNEL=bogus was "internal error (ValueError: ...)": now the one line
    names the variable and its values, exit 2, no folder."""
    env = dict(os.environ, CYCLOMESH_KERNEL="bogus")
    done = subprocess.run(
        [sys.executable, "-m", "cyclomesh", "run", str(EXAMPLES / "table2.toml"), "--out", "o"]
        + ["-q", "--figures", "none", "--crank-step-deg", "30"],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600,
    )  # fmt: skip
    assert "CYCLOMESH_KERNEL='bogus': expected one of numpy, numba" in only_error_line(done)
    assert not (tmp_path / "o").exists()


def test_a_stage_that_finds_no_equilibrium_names_the_case_and_the_clearance(tmp_path):
    """A crank-bearing clearance of 5000 µm lets the discs float (issue 23: 'no descent'):
    one line naming the case, the crank angle and the key to check, with its value."""
    text = (EXAMPLES / "rv_stage.toml").read_text()
    assert "radial_clearance_um = 5.0" in text and "crank_step_deg = 1.0" in text
    text = text.replace("radial_clearance_um = 5.0", "radial_clearance_um = 5000.0")
    (tmp_path / "s.toml").write_text(text.replace("crank_step_deg = 1.0", "crank_step_deg = 30.0"))
    done = cyclomesh("run", "s.toml", "--out", "o", "-q", "--figures", "none", cwd=tmp_path)
    line = only_error_line(done)
    assert line.startswith('error: case "') and "crank angle" in line
    assert "stage.crank_bearing.radial_clearance_um (now 5000 µm" in line
    assert not (tmp_path / "o").exists()
