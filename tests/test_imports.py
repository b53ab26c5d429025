"""Import hygiene: the core and the command start without the heavy result libraries."""

import subprocess
import sys

import pytest

HEAVY = ("xarray", "pandas", "matplotlib", "pyarrow", "netCDF4", "distributed")


@pytest.mark.parametrize(
    "modules, absent",
    [
        ("cyclomesh.core.ltca", HEAVY),  # the core: NumPy and SciPy only
        ("cyclomesh.stage.solve, cyclomesh.results.stage", HEAVY),  # the RV stage, same
        ("cyclomesh.drive.solve, cyclomesh.results.torsion", HEAVY),  # drive characteristics, same
        ("cyclomesh, cyclomesh.cli", (*HEAVY, "scipy", "pydantic")),  # --help
        # the overview's figure process: forked before the kind's modules are imported
        ("cyclomesh.figures.worker", (*HEAVY, "numpy", "pydantic", "cyclomesh.studyfile.schema")),
        # ... by the command's entry, from the raw command line, before typer is imported
        (
            "cyclomesh.__main__, cyclomesh.figures.early; "
            "cyclomesh.figures.early.wants_overview('run', 'png,svg')",
            (*HEAVY, "numpy", "pydantic", "typer", "cyclomesh.cli"),
        ),
        ("cyclomesh.tolerance.tasks", HEAVY),  # what tolerance workers run
        ("cyclomesh.studies.run, cyclomesh.studies.tolerance, cyclomesh.publish.pipeline", HEAVY),
        ("cyclomesh.studies.allocate, cyclomesh.studies.rings", HEAVY),
        ("cyclomesh.studies.stiffness", HEAVY),
        # plot modules: matplotlib only when a figure is drawn (in the figure workers)
        (
            "cyclomesh.figures.run, cyclomesh.figures.tolerance, cyclomesh.figures.drive",
            ("matplotlib", "scipy.stats"),
        ),
        # design maps: the chunk function and the kind of study, and its plots
        ("cyclomesh.designspace.sweep, cyclomesh.studies.designmap", HEAVY),
        ("cyclomesh.figures.designmap", ("matplotlib", "xarray")),
    ],
)
def test_modules_import_without_heavy_libraries(modules, absent):
    code = f"import sys, {modules}; print(sorted(m for m in {absent!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", f"{modules} imports {out.stdout.strip()}"


def test_lazy_names_of_the_package():
    import cyclomesh

    assert cyclomesh.TABLE1.pins == 40
    assert callable(cyclomesh.analyse) and "analyse" in dir(cyclomesh)
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        cyclomesh.nonsense  # noqa: B018


def _assert_never_imported(args: list[str], modules: tuple[str, ...]) -> None:
    """``cyclomesh ARGS`` in a fresh interpreter succeeds and leaves every one of
    ``modules`` unimported."""
    code = (
        "import sys\n"
        "from cyclomesh.cli import app\n"
        f"args = {args!r}\n"
        "try:\n    app(args)\nexcept SystemExit as exc:\n    assert not exc.code, exc.code\n"
        f"print(sorted(m for m in {tuple(modules)!r} if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stdout


def test_run_without_figures_never_imports_matplotlib(tmp_path):
    """``cyclomesh run --figures none`` end to end: no figure asked, matplotlib never
    imported (issue 27), nor ``dask.array`` and ``scipy.fft`` (xarray imports them to
    probe for Dask arrays unless the variables are built as in
    :mod:`cyclomesh.results.arrays`; a check only where Dask is installed), and the
    result files are all there."""
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "examples" / "table2.toml"
    out = tmp_path / "out"
    args = ["run", str(example), "--out", str(out), "-q", "--figures", "none"]
    heavy = ("matplotlib", "scipy.stats", "dask.array", "scipy.fft", "scipy.fftpack")
    _assert_never_imported(args + ["--crank-step-deg", "10"], heavy)
    assert (out / "summary.json").is_file() and not (out / "figures").exists()


def test_tolerance_without_figures_never_imports_dask_array(tmp_path):
    """``cyclomesh tolerance --figures none`` end to end on two local workers: the
    per-ring Dataset is built, reduced and written without xarray's probe for Dask
    arrays (issue 27; :class:`~cyclomesh.studies.execute.StudyKind` ``probe_free``),
    so ``dask.array`` and ``scipy.fft`` are never imported (a check only where Dask is
    installed), and the result files are all there."""
    import json
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "examples" / "tolerance.toml"
    out = tmp_path / "out"
    args = ["tolerance", str(example), "--out", str(out), "-q", "--figures", "none"]
    _assert_never_imported(args + ["--rings", "8", "--workers", "2"], ("dask.array", "scipy.fft"))
    files = json.loads((out / "summary.json").read_text())["files"]
    assert {"tolerance_rings.nc", "tolerance_rings.parquet", "worst_ring.toml"} <= {
        f["path"] for f in files
    }


def test_run_figures_index_numpy_not_xarray():
    """The default figures of a plain run, drawn in this process as a figure worker draws
    them: ``dask.array`` and ``scipy.fft`` are never imported (xarray's indexing and
    reductions would import them in every worker when Dask is installed), and every
    figure is drawn."""
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "examples" / "table2.toml"
    code = (
        "import sys\n"
        "from cyclomesh.figures.render import render_figures\n"
        "from cyclomesh.studies import run as kind\n"
        "from cyclomesh.studyfile import load_study\n"
        f"study = load_study({str(example)!r})\n"
        "jobs = kind.run_figures(kind.compute_run(study))\n"
        "drawn = render_figures(jobs, None, workers=1)\n"
        "assert [f.name for f in drawn] == [j.name for j in jobs] and all(f.png for f in drawn)\n"
        "print(len(drawn), sorted(m for m in ('dask.array', 'scipy.fft') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    count, absent = done.stdout.strip().splitlines()[-1].split(" ", 1)
    assert int(count) >= 9 and absent == "[]", done.stdout


@pytest.mark.parametrize("thread", [False, True])
def test_the_command_ends_its_process_after_atexit(thread):
    """The command's entry ends its process without the interpreter's teardown
    (``cyclomesh.__main__.end_process``) only after the ``atexit`` functions have run and
    the standard streams are flushed, with the command's exit status; with another
    thread alive it leaves the exit to Python, which waits for the thread."""
    code = (
        "import atexit, sys, threading\n"
        "import cyclomesh.__main__ as entry\n"
        "atexit.register(lambda: print('atexit ran'))\n"
        "go = threading.Event()\n"
        "def late():\n    go.wait(60)\n    print('thread done')\n"
        f"if {thread}:\n    threading.Thread(target=late).start()\n"
        "end = entry.end_process\n"
        "def spy(code):\n    end(code)  # the thread is alive here\n    go.set()\n"
        "entry.end_process = spy\n"
        "sys.stdout.write('buffered, no newline')\n"
        "sys.argv = ['cyclomesh', '--version']\n"
        "entry.main()\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("buffered, no newlinecyclomesh ")
    assert lines[1:] == (["thread done", "atexit ran"] if thread else ["atexit ran"])
    refused = subprocess.run(
        [sys.executable, "-m", "cyclomesh", "run", "no-such-study.toml", "--out", "x"],
        capture_output=True,
        text=True,
    )
    assert refused.returncode == 2 and refused.stderr.startswith("error: ")
