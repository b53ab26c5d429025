"""The RV cycloid stage: discs on crankshafts, crank bearings, stage rigidity and life.

Pure physics (NumPy/SciPy, SI units): :mod:`cyclomesh.stage.bearing` (a needle roller set
with clearance: load distribution, stiffness, ISO 281 rating and life) and
:mod:`cyclomesh.stage.solve` (equilibrium of every disc and the carrier at each crank
angle). See ``docs/stage.md``.
"""

from cyclomesh.stage.bearing import RollerSet
from cyclomesh.stage.solve import (
    Stage,
    StageDesign,
    StageTorsion,
    bearing_life,
    solve_stage,
    stage_torsion_curve,
)

__all__ = [
    "RollerSet",
    "Stage",
    "StageDesign",
    "StageTorsion",
    "bearing_life",
    "solve_stage",
    "stage_torsion_curve",
]
