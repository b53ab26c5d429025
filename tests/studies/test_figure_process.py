"""The overview's figure process (cyclomesh.figures.worker.FigureProcess): forked as
``cyclomesh run`` starts, it draws the one batch it is sent exactly as this process
would, re-raises a plot's error here, and is gone after ``close`` (a refused study)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cyclomesh.figures.overview import OverviewCase, plot_overview
from cyclomesh.figures.render import FigureJob, render_figures
from cyclomesh.figures.worker import FigureProcess

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _overview(shift: float = 0.0) -> FigureJob:
    angles = np.arange(0.0, 360.0, 30.0)
    case = OverviewCase(
        crank_angle=angles,
        pin=np.arange(1, 41),
        pin_load_at=0.0,
        pin_load=np.linspace(0.0, 900.0, 40) + shift,
        transmission_error=np.cos(np.radians(angles)) + shift,
        max_contact_stress=900.0 + 10.0 * np.sin(np.radians(angles)),
        contacts=np.full(angles.size, 9),
    )
    return FigureJob("overview", plot_overview, ({"case": case},), caption="c", section="s")


def _boom(*args: object) -> None:
    raise ValueError("a plot that fails")


INNER = "CYCLOMESH_TEST_FIGURE_PROCESS_INNER"
"""Set in the fresh interpreter that runs a test of this module (:func:`_fresh`)."""


def _fresh(request: pytest.FixtureRequest) -> bool:
    """True in a fresh interpreter, where the test runs; else run it in one and check it
    passed there (False: nothing more to do here). The figure process forks only from a
    process with one thread, and a full test session has left others (Dask, servers), so
    in this process it would draw here and the test would not test it."""
    if os.environ.get(INNER):
        return True
    from cyclomesh.execution.runtime import usable_cpus

    if usable_cpus() < 2:
        pytest.skip("one usable CPU: the figures are drawn in the command's process")
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
         f"{__file__}::{request.node.name}"],
        env={**os.environ, INNER: "1"},
        capture_output=True,
        text=True,
        timeout=300,
    )  # fmt: skip
    assert done.returncode == 0 and "1 passed" in done.stdout, done.stdout[-3000:]
    return False


def _process() -> FigureProcess:
    process = FigureProcess()
    assert process.active, "no figure process in a fresh interpreter with two CPUs"
    return process


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def test_draws_its_batch_as_this_process_does(tmp_path, request):
    if not _fresh(request):
        return
    job = _overview()
    with _process() as process:
        process.submit([job], ("png", "svg"), 60)
        (drawn,) = process.map([job], tmp_path, ("png", "svg"), 60)
        assert not process.active
    (here,) = render_figures([job], None, ("png", "svg"), 60, workers=1)
    assert drawn.png == here.png and drawn.png.startswith(b"\x89PNG")
    assert [p.name for p in drawn.files] == ["overview.png", "overview.svg"]
    assert (tmp_path / "overview.png").read_bytes() == here.png


def test_a_second_batch_is_drawn_here(tmp_path, request):
    if not _fresh(request):
        return
    first, second = _overview(), _overview(shift=50.0)
    with _process() as process:
        process.submit([first], ("png",), 50)
        (drawn,) = process.map([second], None, ("png",), 50)
    (here,) = render_figures([second], None, ("png",), 50, workers=1)
    assert drawn.png == here.png


def test_a_plot_error_is_raised_here(request):
    if not _fresh(request):
        return
    job = FigureJob("broken", _boom)
    with _process() as process, pytest.raises(ValueError, match="a plot that fails"):
        process.map([job], None, ("png",), 50)


def test_close_stops_the_process_at_once(request):
    if not _fresh(request):
        return
    process = _process()
    pid = process._pid
    process.submit([_overview()], ("png",), 50)
    process.close()  # as after a refused study: killed, not waited for
    assert not process.active and _gone(pid)
    process.close()  # twice is harmless


def test_refused_run_leaves_no_figure_process(tmp_path):
    """``cyclomesh run`` of a study it refuses, with the default figures: one error line,
    exit 2, nothing written, and no process of it left behind (its stderr pipe closes)."""
    study = tmp_path / "bad.toml"
    text = (EXAMPLES / "table2.toml").read_text(encoding="utf-8")
    study.write_text(text.replace("pins = 40", "pins = 2", 1), encoding="utf-8")
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "cyclomesh", "run", str(study), "--out", str(out), "-q"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error: ") and len(done.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_the_process_imports_no_3d_toolkit(request):
    """The figure process imports matplotlib without ``mpl_toolkits.mplot3d`` (no figure
    is 3D), silently, and draws the overview as this process does (above)."""
    if not _fresh(request):
        return
    import warnings

    from cyclomesh.figures import worker

    assert "matplotlib" not in sys.modules  # else the import below would test nothing
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        worker._import_matplotlib()
    assert sys.modules["mpl_toolkits.mplot3d"] is None
    assert "matplotlib.figure" in sys.modules


@pytest.mark.parametrize(
    "command, args, forked",
    [
        ("run", ["s.toml"], True),
        ("run", ["s.toml", "--out", "o", "-q"], True),
        ("run", ["s.toml", "--figures", "svg,png"], True),
        ("run", ["s.toml", "--figures=overview"], True),
        ("run", ["s.toml", "--figures", "none"], False),
        ("run", ["s.toml", "--figures", "all"], False),
        ("run", ["s.toml", "--figures=all,svg"], False),
        ("run", ["s.toml", "--figures", "nonsense"], False),  # refused later
        ("run", ["s.toml", "--figures"], False),  # a usage error
        ("run", ["s.toml", "--help"], False),
        ("run", ["--figures", "none", "s.toml", "--figures", "png"], True),  # the last one
        ("check", ["s.toml"], False),
        ("stiffness", ["s.toml"], False),
        ("tolerance", ["s.toml"], False),
    ],
)
def test_which_commands_fork_early(command, args, forked, monkeypatch):
    """The command group forks the overview's process from the raw command line exactly
    when the command will draw the overview (the parsed ``--figures`` decides the same,
    :func:`cyclomesh.figures.early.wants_overview`); not after an option of the group
    (``--help``, ``--version``: no command runs)."""
    from cyclomesh.figures import early, worker

    made = []

    class Spy:
        active = True

        def __init__(self) -> None:
            made.append(self)

        def close(self) -> None:
            made.remove(self)

    monkeypatch.setattr(worker, "FigureProcess", Spy)
    early.fork_early([command, *args])
    assert len(made) == int(forked)
    early.close_early()
    assert not made
    early.fork_early(["--version", command, *args])
    assert not made
    usable, figures = early._raw_figures(args)
    assert (usable and early.wants_overview(command, figures)) is forked


@pytest.mark.parametrize("entry", ["main", "app"])
def test_the_command_forks_before_pydantic(tmp_path, entry):
    """``cyclomesh run`` with the default figures forks the overview's process once,
    after NumPy is imported (once, for both processes) and before the options are
    converted (pydantic), with OpenBLAS's idle spin shortened; from the command's
    entry (``cyclomesh.__main__.main``) also before typer is imported, from a command
    line run in a process (``app([...])``) by the command group. The process draws the
    overview, which is written."""
    out = tmp_path / "out"
    args = ["run", str(EXAMPLES / "table2.toml"), "--out", str(out), "-q"]
    args += ["--crank-step-deg", "30"]
    run = (
        f"sys.argv = ['cyclomesh', *{args!r}]\nfrom cyclomesh.__main__ import main\nmain()\n"
        if entry == "main"
        else f"from cyclomesh.cli import app\napp({args!r})\n"
    )
    code = (
        "import atexit, os, sys\n"
        "from cyclomesh.figures import worker\n"
        "seen = []\n"
        "atexit.register(lambda: print(seen))  # the entry ends the process after atexit\n"
        "init = worker.FigureProcess.__init__\n"
        "def spy(self):\n"
        "    seen.append(tuple(m in sys.modules for m in ('numpy', 'pydantic', 'typer'))\n"
        "                + (os.environ.get('OPENBLAS_THREAD_TIMEOUT'),))\n"
        "    init(self)\n"
        "worker.FigureProcess.__init__ = spy\n"
        "try:\n"
        + "".join(f"    {line}\n" for line in run.splitlines())
        + "except SystemExit as exc:\n    assert not exc.code, exc.code\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    typer = entry == "app"
    assert done.stdout.strip().splitlines()[-1] == f"[(True, False, {typer}, '20')]", done.stdout
    assert (out / "figures" / "overview.png").read_bytes().startswith(b"\x89PNG")
