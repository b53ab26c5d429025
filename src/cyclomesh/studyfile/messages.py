"""One line from pydantic's errors: :func:`one_line` names the dotted key, what was
expected and what was given (``errors.radial_um: expected 40 values (one per pin), got
39``); :func:`parse_section` validates one table alone.
"""

from __future__ import annotations

import types
import typing
from typing import Any

from pydantic import (
    BaseModel,
    ValidationError,
)

from cyclomesh.exceptions import StudyError

__all__ = ["one_line", "parse_section", "show"]

# --- one-line messages from pydantic's errors -------------------------------------------


def show(value: Any) -> str:
    """A value as the user typed it in TOML, shortened."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = '"' + value.replace('"', '\\"') + '"'
    elif isinstance(value, dict):
        text = "a table"
    elif isinstance(value, list):
        text = f"a list of {len(value)} values"
    else:
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


_TAGS = ("uniform", "normal", "true_position")
"""Tags of discriminated unions, which pydantic puts in an error's location."""


def _dotted(loc: tuple[int | str, ...]) -> str:
    text = ""
    for part in loc:
        if part in _TAGS:
            continue
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _model_at(model: type[BaseModel], loc: tuple[int | str, ...]) -> type[BaseModel] | None:
    """The model class that validates the table at ``loc`` (None if not a model)."""
    current: Any = model
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(current, type) and issubclass(current, BaseModel)):
            return None
        field = current.model_fields.get(part)
        if field is None:
            return None
        current = field.annotation
        while typing.get_origin(current) in (typing.Union, types.UnionType):
            current = next(a for a in typing.get_args(current) if a is not type(None))
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


_EXPECTED = {
    "float_type": "a number",
    "float_parsing": "a number",
    "int_type": "an integer",
    "int_from_float": "an integer",
    "bool_type": "true or false",
    "string_type": "a string",
    "list_type": "a list",
    "dict_type": "a table",
    "model_type": "a table",
    "model_attributes_type": "a table",
}
_BOUNDS = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def one_line(exc: ValidationError, model: type[BaseModel], prefix: str = "") -> str:
    """The first error of ``exc`` as ``dotted.key: what is expected, got what``.

    The one message formatter of every section. An unknown (misspelt) key is reported
    before the missing key that usually comes with it. ``prefix`` is the dotted name of
    the table ``model`` validated (empty for the whole file).
    """
    errors = exc.errors(include_url=False)
    first = min(errors, key=lambda e: e["type"] != "extra_forbidden")
    loc = tuple(first["loc"])
    kind, value, ctx = first["type"], first.get("input"), first.get("ctx", {})
    if kind == "union_tag_invalid":
        loc = (*loc, "distribution")
        hint = (
            " (a true-position zone goes under tolerance.position)"
            if ctx.get("tag") == "true_position"
            else ""
        )
        what = (
            f"unknown distribution {ctx.get('tag')!r}, expected one of {ctx.get('expected_tags')}"
        )
        what += hint
    elif kind == "union_tag_not_found":
        what = "missing distribution (uniform or normal)"
    elif kind == "missing":
        what = "required key missing"
    elif kind == "extra_forbidden":
        parent = _model_at(model, loc[:-1])
        allowed = ", ".join(parent.model_fields) if parent else ""
        what = "unknown key" + (f" (expected one of: {allowed})" if allowed else "")
    elif kind in _EXPECTED:
        what = f"expected {_EXPECTED[kind]}, got {show(value)}"
    elif kind in _BOUNDS:
        bound = next(iter(ctx.values()))
        shown = f"{bound}" if isinstance(bound, int) else f"{bound:g}"
        what = f"expected a number {_BOUNDS[kind]} {shown}, got {show(value)}"
    elif kind == "finite_number":
        what = f"expected a finite number, got {show(value)}"
    elif kind == "literal_error":
        what = f"expected one of {ctx.get('expected')}, got {show(value)}"
    elif kind in ("too_short", "too_long"):
        limit = ctx.get("min_length", ctx.get("max_length"))
        side = "at least" if kind == "too_short" else "at most"
        what = f"expected {side} {limit} values, got {ctx.get('actual_length')}"
    elif kind == "value_error":
        what = str(ctx.get("error", first["msg"]))
    else:
        what = first["msg"]
    key = _dotted(((prefix,) if prefix else ()) + loc)
    more = f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return f"{key}: {what}" + (more if len(errors) > 1 else "") if key else what


def parse_section(model: type[BaseModel], raw: Any, prefix: str) -> Any:
    """Validate one table of a study file on its own, e.g. ``parse_section(ToleranceSection,
    {...}, "tolerance")``; errors as :func:`one_line` with the dotted ``prefix``.

    Raises
    ------
    StudyError
        Not a table, or the first problem of the table.
    """
    if not isinstance(raw, dict):
        raise StudyError(f"{prefix}: expected a table, got {show(raw)}")
    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        raise StudyError(one_line(exc, model, prefix)) from None
