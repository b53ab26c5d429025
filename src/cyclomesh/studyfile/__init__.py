"""Study files: the TOML description of a study, validated by one schema.

``schema`` reads and validates a study file (every section, ``[tolerance]`` included);
``measurements`` reads measured pin errors; ``kinds`` is the registry of the kinds of
study (what each command takes from a file). Running a study is
:mod:`cyclomesh.studies`. The names below load the schema (pydantic) on first use, so
the command line reads the registry without it.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["CaseInputs", "CaseSpec", "Study", "load_study"]


def __getattr__(name: str) -> Any:
    if name not in __all__:
        raise AttributeError(f"module 'cyclomesh.studyfile' has no attribute {name!r}")
    value = getattr(import_module("cyclomesh.studyfile.schema"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
