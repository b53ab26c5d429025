"""Study files: the TOML description of a study, validated by one schema.

``schema`` reads and validates a study file (every section, ``[tolerance]`` included);
``measurements`` reads measured pin errors. Running a study is
:mod:`cyclomesh.studies`.
"""

from cyclomesh.studyfile.schema import CaseInputs, CaseSpec, Study, load_study

__all__ = ["CaseInputs", "CaseSpec", "Study", "load_study"]
