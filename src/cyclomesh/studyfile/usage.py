"""Which study-file keys each kind of study uses, and the one-line refusal of the others.

Every key of the schema (:class:`~cyclomesh.studyfile.schema.StudyFile`, dotted, tables
such as ``tolerance.radial_um`` or ``design_space.pin_radius_um`` counted as one key) is,
for every kind of study (``run``, ``stiffness``, ``tolerance``, ``allocate``, ``design``,
``fe``), one of:

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

KINDS = ("run", "stiffness", "tolerance", "allocate", "design", "fe", "efficiency")

_ALLOWABLES = tuple(
    f"material.{part}allowable_contact_stress_mpa" for part in ("", "pin.", "disc.", "ring.")
)
"""The allowable contact stresses: the default limits of [requirements]. The kinds that
check requirements use them; an allocation (its own allowable in [tolerance]) leaves them."""

OWN_SECTIONS: dict[str, tuple[str, ...]] = {
    "stiffness": ("stiffness",),
    "tolerance": ("tolerance", "requirements.tolerance_percentile"),
    "allocate": ("tolerance",),
    "design": ("design_space",),
    "fe": ("fe",),
    "efficiency": ("efficiency",),
    "export": ("design.disc.bore_radius_mm",),
    "run": (
        "load.torque_nm",
        "load.input_speed_rpm",
        "stage.rated_torque_nm",
        "stage.duty_cycle",
        "requirements",
        *_ALLOWABLES,
    ),
}
"""The sections (or keys) of a kind of study's own: another kind leaves them alone. The
run's load and the stage's data-sheet rating are the run's: ``cyclomesh stiffness`` sweeps
±``stiffness.rated_torque_nm`` instead, and one file serves both (examples/rv_stage.toml).
``[requirements]`` is checked by every kind that computes a quantity (run, stiffness,
tolerance, design, fe); ``cyclomesh allocate`` reports no metric and leaves it, as it
leaves the allowables of ``[material]`` (the default limits) and the tolerance study's
percentile. The disc's bore is drawn by ``cyclomesh export`` (which takes every key) and
computed by no other kind."""

_PAIR = (
    "design.pins",
    "design.pin_circle_radius_mm",
    "design.pin_radius_mm",
    "design.groove_radius_mm",
    "design.eccentricity_mm",
    "design.width_mm",
    "modification",
    "material",
)
_OUTPUT = ("title", "description", "figures.enabled", "figures.formats", "figures.dpi")
_LTCA = (*_PAIR, *_OUTPUT, "design.discs", "load.torque_nm", "errors", "analysis")
_RUN_FIGURES = ("figures.crank_angles_deg", "figures.stress_pin", "figures.stress_over")
_RINGS = (
    "tolerance.seed",
    "tolerance.crank_start_deg",
    "tolerance.crank_stop_deg",
    "tolerance.crank_step_deg",
    "tolerance.radial_um",
    "tolerance.angular_urad",
    "tolerance.pin_radius_um",
    "tolerance.eccentricity_um",
    "tolerance.position",
    "tolerance.tangential_um",
)
_CHECKED = ("requirements", *_ALLOWABLES)
"""What the kinds that check requirements use besides their own keys."""

USED: dict[str, tuple[str, ...]] = {
    "run": (
        *_LTCA,
        *_RUN_FIGURES,
        "cases",
        "stage",
        "design.disc",
        "friction",
        "load.input_speed_rpm",
        *_CHECKED,
    ),
    "stiffness": (
        *_PAIR,
        *_OUTPUT,
        "design.discs",
        "errors",
        "analysis",
        "cases",
        "stiffness",
        "stage",
        "design.disc",
        "friction",
        *_CHECKED,
    ),
    "tolerance": (
        *_LTCA,
        *_RINGS,
        "stage",
        "design.disc",
        "tolerance.hole_radial_um",
        "tolerance.hole_tangential_um",
        "tolerance.rings",
        "tolerance.allowable_contact_stress_mpa",
        "tolerance.allocation.confidence",
        "friction",
        "load.input_speed_rpm",
        *_CHECKED,
        "requirements.tolerance_percentile",
    ),
    "allocate": (*_LTCA, "tolerance", "stage", "design.disc"),
    "design": (*_LTCA, *_RINGS, "design_space", "friction", "stage", "design.disc", *_CHECKED),
    "fe": (
        *_PAIR,
        *_OUTPUT,
        "load.torque_nm",
        "analysis.contact_law",
        "analysis.disc_body",
        "cases",
        "fe",
        *_CHECKED,
    ),
}
USED["efficiency"] = (
    *_PAIR,
    *_OUTPUT,
    "design.discs",
    "errors",
    "analysis",
    "cases",
    "friction",
    "efficiency",
    *_CHECKED,
)
"""Keys (or whole tables) each kind of study uses."""

_HOLES = (
    "design.disc: the crank holes are the crankshafts of the RV stage, which this kind of "
    "study does not take; remove [design.disc] (cyclomesh run and stiffness take [stage])"
)


def _stage(kind: str) -> str:
    return (
        f"stage: [stage] is not taken by cyclomesh {kind} yet; use cyclomesh run or "
        "cyclomesh stiffness for the RV stage, or remove [stage] (docs/stage.md)"
    )


NEEDS: dict[str, dict[str, tuple[str, str]]] = {
    kind: {
        "design.disc": (
            "stage",
            "design.disc: the crank holes are the crankshafts of the RV stage: add [stage] "
            "or remove [design.disc] (docs/stage.md)",
        )
    }
    for kind in ("run", "stiffness", "design", "tolerance", "allocate")
}
"""Keys a kind uses only together with another (key → (needed key, refusal))."""


def _friction(kind: str) -> str:
    return (
        f"friction: [friction] is not taken by cyclomesh {kind} yet; use cyclomesh run, "
        "stiffness or tolerance for friction and efficiency, or remove [friction] "
        "(docs/efficiency.md)"
    )


_BASE_ONLY = (
    "cases: this kind of study analyses the base description only; remove [[cases]] "
    "(cyclomesh run runs them)"
)
_NO_RUN_FIGURES = "this kind of study draws no load or stress figures; remove the key"

REFUSED: dict[str, dict[str, str]] = {
    "run": {},
    "stiffness": {
        **{key: _NO_RUN_FIGURES for key in _RUN_FIGURES},
        "friction.lubricant": "the torsion test is at rest, where the boundary coefficients "
        "apply; remove [friction.lubricant] (cyclomesh run uses it)",
    },
    "tolerance": {
        "cases": _BASE_ONLY,
        **{key: _NO_RUN_FIGURES for key in _RUN_FIGURES},
    },
    "allocate": {
        "friction": _friction("allocate"),
        "cases": _BASE_ONLY,
        **{key: _NO_RUN_FIGURES for key in _RUN_FIGURES},
    },
    "design": {
        "cases": _BASE_ONLY,
        **{key: _NO_RUN_FIGURES for key in _RUN_FIGURES},
    },
    "fe": {
        "design.disc": _HOLES,
        "stage": _stage("fe"),
        "friction": _friction("fe"),
        "design.discs": "the FE model solves one disc; remove [design] discs",
        "errors": "the FE model takes no pin errors yet; remove [errors] (cyclomesh run "
        "handles them)",
        "analysis.crank_start_deg": "cyclomesh fe solves at fe.crank_angles_deg; remove it",
        "analysis.crank_stop_deg": "cyclomesh fe solves at fe.crank_angles_deg; remove it",
        "analysis.crank_step_deg": "cyclomesh fe solves at fe.crank_angles_deg; remove it",
        "analysis.groove_deformation": "the FE model always has the pin-groove contact "
        "(the improved model); remove it",
        **{key: _NO_RUN_FIGURES for key in _RUN_FIGURES},
    },
    "efficiency": {
        "design.disc": _HOLES,
        "stage": _stage("efficiency"),
        "analysis.disc_body": "the efficiency map solves the rigid disc (friction is not "
        "coupled with the FE disc body yet); remove disc_body",
        **{key: _NO_RUN_FIGURES for key in _RUN_FIGURES},
    },
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
