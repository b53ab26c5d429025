"""Studies: TOML files describing cases, their runs and their output files.

``config`` reads and validates a study file; ``measurements`` reads measured pin
errors; ``results`` runs the cases and writes NetCDF, CSV and JSON.
"""

from cyclomesh.study.config import CaseInputs, CaseSpec, Study, load_study

__all__ = ["CaseInputs", "CaseSpec", "Study", "load_study"]
