"""Which study-file keys each kind of study uses, and the one-line refusal of the others.

Every key of the schema (:class:`~cyclomesh.studyfile.schema.StudyFile`, dotted, tables
such as ``tolerance.radial_um`` or ``design_space.pin_radius_um`` counted as one key) is,
for every kind of study (``run``, ``stiffness``, ``tolerance``, ``allocate``, ``design``,
``fe``), one of:

The tables are built from the registry of the kinds of study
(:data:`cyclomesh.studyfile.kinds.KINDS`), where each kind declares its keys:

* **used**: it changes what the study computes, writes or draws (:data:`USED`);
* **refused**: the kind cannot honour it; a study file that sets it is refused in one
  line naming the key and why (:data:`REFUSED`, :func:`check_keys`; exit status 2);
* **another kind's**: it lies in the section of another kind of study (``[stiffness]``,
  ``[tolerance]``, ``[design_space]``, ``[fe]``, ``[tolerance.allocation]``), which every
  kind validates (``cyclomesh check``) and leaves to its own command, so one file can
  hold a run and its tolerance study, and ``best.toml`` of a robust map (which keeps
  its ``[tolerance]``) reruns with ``cyclomesh run``.

``tests/studies/test_key_usage.py`` checks every kind against every key: a used key changes the
result, a refused key is refused, nothing else is left over.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Iterator, Mapping
from typing import Any

from pydantic import BaseModel

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.kinds import KINDS as _REGISTRY

__all__ = [
    "KINDS",
    "OWN_SECTIONS",
    "USED",
    "REFUSED",
    "schema_keys",
    "classify",
    "set_keys",
    "check_keys",
]

KINDS = tuple(spec.command for spec in _REGISTRY if spec.used is not None)
"""The kinds of study whose keys are checked (``export`` takes every key)."""

OWN_SECTIONS: dict[str, tuple[str, ...]] = {spec.command: spec.own for spec in _REGISTRY}
"""The sections (or keys) of a kind of study's own: another kind leaves them alone. The
run's load and the stage's data-sheet rating are the run's: ``cyclomesh stiffness`` sweeps
±``stiffness.rated_torque_nm`` instead, and one file serves both (examples/rv_stage.toml).
``[requirements]`` is checked by every kind that computes a quantity (run, stiffness,
tolerance, design, fe); ``cyclomesh allocate`` reports no metric and leaves it, as it
leaves the allowables of ``[material]`` (the default limits) and the tolerance study's
percentile. The disc's bore is drawn by ``cyclomesh export`` (which takes every key) and
computed by no other kind."""

USED: dict[str, tuple[str, ...]] = {
    spec.command: spec.used for spec in _REGISTRY if spec.used is not None
}
"""Keys (or whole tables) each kind of study uses."""

NEEDS: dict[str, dict[str, tuple[str, str]]] = {
    spec.command: dict(spec.needs) for spec in _REGISTRY if spec.needs
}
"""Keys a kind uses only together with another (key → (needed key, refusal))."""

REFUSED: dict[str, dict[str, str]] = {
    spec.command: dict(spec.refused) for spec in _REGISTRY if spec.used is not None
}
"""Keys each kind of study refuses, with the reason (the fix is in the message)."""

_LEAF_TABLES = ("RangeSection", "Uniform", "Normal", "TruePosition")


def _model_of(annotation: Any) -> type[BaseModel] | None:
    """The section model of a field (through ``X | None``), None for a plain value or a
    union of models (a tagged distribution: one key)."""
    args = typing.get_args(annotation)
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        models = [a for a in args if a is not type(None)]
        if len(models) != 1:
            return None
        annotation = models[0]
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return None if annotation.__name__ in _LEAF_TABLES else annotation
    return None


def schema_keys(model: type[BaseModel] | None = None, prefix: str = "") -> list[str]:
    """Every key of the study file schema, dotted (a distribution or a range is one key)."""
    if model is None:
        from cyclomesh.studyfile.schema import StudyFile

        model = StudyFile
    out = []
    for name, field in model.model_fields.items():
        key = f"{prefix}{name}"
        sub = _model_of(field.annotation)
        if sub is None:
            out.append(key)
        else:
            out += schema_keys(sub, key + ".")
    return out


def _matches(key: str, pattern: str) -> bool:
    return key == pattern or key.startswith(pattern + ".")


def classify(kind: str, key: str) -> str:
    """``"used"``, ``"refused"`` or ``"other"`` (another kind's section) for a key."""
    if _drawn_only(key):  # the export's: every kind leaves it, with or without holes
        return "other"
    if any(_matches(key, p) for p in REFUSED[kind]):
        return "refused"
    for other, sections in OWN_SECTIONS.items():  # a key another kind owns by name
        named = [p for p in sections if "." in p]
        if other != kind and any(_matches(key, p) for p in named) and key not in USED[kind]:
            return "other"
    if any(_matches(key, p) for p in USED[kind]):
        return "used"
    for other, sections in OWN_SECTIONS.items():
        if other != kind and any(_matches(key, s) for s in sections):
            return "other"
    if _matches(key, "tolerance.allocation"):  # cyclomesh allocate's subsection
        return "other"
    raise KeyError(f"{kind}: key {key} is neither used, refused nor another kind's")


def _drawn_only(key: str) -> bool:
    """A key only ``cyclomesh export`` uses (the disc's bore)."""
    return any(_matches(key, p) for p in OWN_SECTIONS["export"])


def _walk(table: Mapping[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    for name, value in table.items():
        key = f"{prefix}{name}"
        if isinstance(value, Mapping):
            yield from _walk(value, key + ".")
        else:
            yield key, value


_UNSET = object()


def _default(key: str) -> Any:
    """The schema default of a dotted key (``_UNSET`` if it has none)."""
    from cyclomesh.studyfile.schema import StudyFile

    model: Any = StudyFile
    parts = key.split(".")
    for i, part in enumerate(parts):
        fields = getattr(model, "model_fields", None)
        if not fields or part not in fields:
            return _UNSET
        field = fields[part]
        if i == len(parts) - 1:
            return _UNSET if field.is_required() else field.default
        model = _model_of(field.annotation)
    return _UNSET


def set_keys(raw: Mapping[str, Any]) -> list[str]:
    """The dotted keys a study file sets to something other than their default (its own
    tables and its cases' keys; ``cases`` if it has any)."""
    items = list(_walk({k: v for k, v in raw.items() if k != "cases"}))
    cases = raw.get("cases") or []
    for case in cases:
        if isinstance(case, Mapping):
            items += [(k, v) for k, v in _walk(case) if k not in ("name", "description")]
    keys = [key for key, value in items if value != _default(key)]
    return (["cases"] if cases else []) + list(dict.fromkeys(keys))


def _present(raw: Mapping[str, Any], section: str) -> bool:
    """Whether the file or one of its cases has the table ``section`` (even all defaults)."""
    cases = [c for c in raw.get("cases") or [] if isinstance(c, Mapping)]
    return any(section in table for table in (raw, *cases))


def check_keys(raw: Mapping[str, Any], kind: str) -> None:
    """Refuse, in one line, the first key of the file that ``kind`` cannot honour.

    Raises
    ------
    StudyError
        ``<key>: <why and the fix>`` (exit status 2 from the CLI).
    """
    keys = set_keys(raw)
    for section in REFUSED[kind]:  # a refused section counts when present
        if "." not in section and section != "cases" and _present(raw, section):
            keys.insert(0, section)
    for key in (k for k in keys if not _drawn_only(k)):
        for pattern, (needed, why) in NEEDS.get(kind, {}).items():
            if _matches(key, pattern) and not _present(raw, needed):
                raise StudyError(why if kind == "run" else f"cyclomesh {kind}: {why}")
        for pattern, why in REFUSED[kind].items():
            if _matches(key, pattern):
                text = why if why.startswith(pattern.split(".")[0]) else f"{key}: {why}"
                if kind != "run":
                    text = f"cyclomesh {kind}: {text}"
                raise StudyError(text)
