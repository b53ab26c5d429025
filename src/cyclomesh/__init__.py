"""cyclomesh: loaded tooth contact analysis of cycloid-pin gear pairs.

Implements the model of X. Li, L. Tang, H. He, L. Sun, "Design and Load Distribution
Analysis of the Mismatched Cycloid-Pin Gear Pair in RV Speed Reducers", Machines 10
(2022) 672, doi:10.3390/machines10080672.

The names below are imported on first use, so ``import cyclomesh`` (and the
``cyclomesh`` command's start) stays fast: ``import cyclomesh.core.ltca`` loads NumPy and
SciPy only, and xarray comes with :func:`analyse`.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {
    "analyse": "cyclomesh.results.dataset",
    "summarize": "cyclomesh.results.dataset",
    "to_dataset": "cyclomesh.results.dataset",
    "stiffness": "cyclomesh.results.torsion",
    "summarize_stiffness": "cyclomesh.results.torsion",
    "solve_drive": "cyclomesh.drive.solve",
    "solve_ltca": "cyclomesh.core.ltca",
    "LTCA": "cyclomesh.core.ltca",
    "PairDesign": "cyclomesh.core.pair",
    "Material": "cyclomesh.core.pair",
    "CrankHoles": "cyclomesh.core.pair",
    "Modification": "cyclomesh.core.pair",
    "PinErrors": "cyclomesh.core.pair",
    "ProfileDeviation": "cyclomesh.core.deviation",
    "export_profile": "cyclomesh.output.export",
    "disc_outline": "cyclomesh.core.outline",
    "design_map": "cyclomesh.designspace.sweep",
    "Constraints": "cyclomesh.designspace.sweep",
    "STEEL": "cyclomesh.core.pair",
    "TABLE1": "cyclomesh.core.pair",
    "METRICS": "cyclomesh.results.metrics",
    "CyclomeshError": "cyclomesh.exceptions",
    "DesignError": "cyclomesh.exceptions",
    "ConvergenceError": "cyclomesh.exceptions",
    "StudyError": "cyclomesh.exceptions",
    "OutputError": "cyclomesh.exceptions",
    "load_results": "cyclomesh.output.folder",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'cyclomesh' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
