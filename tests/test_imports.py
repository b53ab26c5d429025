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
