"""cyclomesh: loaded tooth contact analysis of cycloid-pin gear pairs.

Implements the model of X. Li, L. Tang, H. He, L. Sun, "Design and Load Distribution
Analysis of the Mismatched Cycloid-Pin Gear Pair in RV Speed Reducers", Machines 10
(2022) 672, doi:10.3390/machines10080672.
"""

from cyclomesh.analysis import analyse, summarize, to_dataset
from cyclomesh.design import STEEL, TABLE1, Material, Modification, PairDesign, PinErrors
from cyclomesh.designmap import Constraints, design_map
from cyclomesh.exceptions import ConvergenceError, CyclomeshError, DesignError, StudyError
from cyclomesh.ltca import LTCA, solve_ltca
from cyclomesh.modification import ProfileDeviation

__all__ = [
    "analyse",
    "summarize",
    "to_dataset",
    "solve_ltca",
    "LTCA",
    "PairDesign",
    "Material",
    "Modification",
    "PinErrors",
    "ProfileDeviation",
    "design_map",
    "Constraints",
    "STEEL",
    "TABLE1",
    "CyclomeshError",
    "DesignError",
    "ConvergenceError",
    "StudyError",
]
