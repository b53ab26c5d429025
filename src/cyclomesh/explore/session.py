"""The explorer's model side: one study file, a state of the page, and its analysis.

A state of the page is the study file's chosen case with the page's changes: study keys
as dotted paths (``{"modification.pin_radius_um": 5.0}``), the pin errors (the case's
own, scaled by a factor, or drawn anew from ``[tolerance]`` with a seed) and the crank
angle shown. :meth:`Session.study_text` turns a state into a one-case study file (TOML);
:meth:`Session.analyse` loads that very file through :func:`cyclomesh.studyfile.load_study`
and runs it through :func:`cyclomesh.studies.run.compute_run`, the one pipeline of
``cyclomesh run``: the same validation, the same one-line messages, the same numbers.
The file the page downloads is the same text, so ``cyclomesh run`` on it reproduces the
numbers the page shows.

Nothing here serves HTTP (:mod:`cyclomesh.explore.app` does); the arrays returned are
plain JSON lists in the units of the labels (mm, N, MPa, arcsec, deg).
"""

from __future__ import annotations

import copy
import math
import tempfile
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np

from cyclomesh.exceptions import CyclomeshError, StudyError
from cyclomesh.studyfile.schema import CASE_SECTIONS, Study, deep_merge, load_study

__all__ = ["Session", "ExploreError", "DEFAULT_STEP_DEG", "MAX_EXPLORE_ANGLES"]

DEFAULT_STEP_DEG = 1.0
"""Crank step of the explorer [deg] when the study's gives more than
:data:`MAX_EXPLORE_ANGLES` angles (360 steps a revolution answer in tens of ms)."""
MAX_EXPLORE_ANGLES = 720
MAX_EXAGGERATION = 1e5
_FILE_KEYS = ("errors.file", "modification.profile_file")
"""Keys holding a file name relative to the study's folder (made absolute)."""
_ERROR_KEYS = ("radial_um", "angular_urad", "pin_radius_um")


class ExploreError(StudyError):
    """A refused explorer input, one line naming the key (``key``: the dotted key)."""

    def __init__(self, message: str, key: str = "") -> None:
        super().__init__(message)
        self.key = key


def _show(value: Any) -> str:
    return f'"{value}"' if isinstance(value, str) else repr(value)


def _number(request: dict[str, Any], key: str, default: float, lo: float, hi: float) -> float:
    """A number of the request's own keys (not study keys), or a one-line error."""
    parts = key.split(".")
    value: Any = request
    for part in parts:
        value = value.get(part) if isinstance(value, dict) else None
        if value is None:
            return default
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ExploreError(f"{key}: expected a number, got {_show(value)}", key)
    if not lo <= value <= hi:
        raise ExploreError(f"{key}: expected a number from {lo:g} to {hi:g}, got {value:g}", key)
    return float(value)


def _set(table: dict[str, Any], dotted: str, value: Any) -> None:
    parts = dotted.split(".")
    if not dotted or any(not p for p in parts):
        raise ExploreError(
            f"{dotted!r}: expected a dotted study key like modification.pin_radius_um"
        )
    if parts[0] in ("cases", "title", "description"):
        raise ExploreError(f"{dotted}: the explorer changes the keys of a case only", dotted)
    node = table
    for i, part in enumerate(parts[:-1]):
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, dict):
            where = ".".join(parts[: i + 1])
            raise ExploreError(f"{dotted}: {where} is not a table", dotted)
        node = child
    node[parts[-1]] = value


def _get(table: dict[str, Any], dotted: str) -> Any:
    node: Any = table
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def _floats(values: Any) -> list[float]:
    return [float(v) for v in np.asarray(values, float).reshape(-1)]


def _names(summary: dict[str, Any]) -> dict[str, dict[str, str]]:
    """``units`` and ``labels`` of a summary's metrics, from the one quantities registry
    (every metric a run, a stage, friction or a torsion curve writes: the names and units
    of ``summary.json``)."""
    from cyclomesh.quantities import QUANTITIES

    known = [QUANTITIES[n] for n in summary if n in QUANTITIES]
    return {"units": {q.name: q.unit for q in known}, "labels": {q.name: q.label for q in known}}


def _json_array(values: Any) -> list[float | None]:
    """Numbers as a JSON list, non-finite → None (null)."""
    return [v if math.isfinite(v) else None for v in np.asarray(values, float).reshape(-1).tolist()]


class Session:
    """One study file explored in the browser.

    Parameters
    ----------
    path : str or Path
        The study file; loaded and validated once here (a bad file is refused before the
        server starts).

    The analysis of a state is cached (the last few states), so that moving the crank
    angle or the exaggeration only redraws.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.study: Study = load_study(self.path)
        self.folder = self.path.resolve().parent
        self.raw = self.study.raw
        self.cases = [case.name for case in self.study.cases]
        self._tmp = tempfile.TemporaryDirectory(prefix="cyclomesh-explore-")
        self._lock = threading.Lock()
        self._cache: OrderedDict[str, Any] = OrderedDict()
        self._outlines: OrderedDict[Any, Any] = OrderedDict()

    def close(self) -> None:
        """Remove the temporary study files."""
        self._tmp.cleanup()

    # --- the state as a study file -------------------------------------------------------

    def _case_index(self, request: dict[str, Any]) -> int:
        name = request.get("case")
        if name is None:
            return 0
        if name not in self.cases:
            raise ExploreError(f"case: expected one of {self.cases}, got {_show(name)}", "case")
        return self.cases.index(name)

    def _base(self, index: int) -> dict[str, Any]:
        """The chosen case as a one-case study table (no ``[[cases]]``)."""
        raw = copy.deepcopy(self.raw)
        cases = raw.pop("cases", None) or []
        sections = {k: raw.pop(k) for k in CASE_SECTIONS if k in raw}
        if cases:
            own = {k: v for k, v in cases[index].items() if k not in ("name", "description")}
            sections = deep_merge(sections, own)
            case = self.study.cases[index]
            raw["title"] = case.name
            raw["description"] = case.description
        else:
            raw["title"] = self.study.title
        where = f'{self.path.name}, case "{self.cases[index]}"'
        raw["description"] = (
            (raw.get("description") or "") + f" (changed in cyclomesh explore from {where})"
        ).strip()
        table = {**raw, **sections}
        for key in _FILE_KEYS:
            name = _get(table, key)
            if isinstance(name, str) and not Path(name).is_absolute():
                _set(table, key, str((self.folder / name).resolve()))
        return table

    def defaults(self, case: str | None = None) -> dict[str, Any]:
        """The values of the page's controls for a case of the study (study units)."""
        index = self._case_index({"case": case})
        spec = self.study.cases[index]
        torque = spec.load.torque_nm
        torque = max(torque, key=abs) if isinstance(torque, list) else torque
        analysis = spec.analysis
        angles = len(analysis.crank_angles_deg())
        step = analysis.crank_step_deg if angles <= MAX_EXPLORE_ANGLES else DEFAULT_STEP_DEG
        return {
            "case": spec.name,
            "cases": self.cases,
            "title": self.study.title,
            "file": self.path.name,
            "overrides": {
                "modification.pin_circle_radius_um": spec.modification.pin_circle_radius_um,
                "modification.pin_radius_um": spec.modification.pin_radius_um,
                "modification.rotation_urad": spec.modification.rotation_urad,
                "load.torque_nm": float(torque),
                "analysis.contact_law": analysis.contact_law,
                "analysis.groove_deformation": analysis.groove_deformation,
                "analysis.disc_body": analysis.disc_body,
                "analysis.crank_step_deg": step,
                "design.discs": spec.design.discs,
            },
            "study_step_deg": analysis.crank_step_deg,
            "crank_start_deg": analysis.crank_start_deg,
            "crank_stop_deg": analysis.crank_stop_deg,
            "tolerance": self.study.tolerance is not None,
            "torsion": spec.stiffness is not None,
            "pins": spec.design.pins,
        }

    def _table(self, request: dict[str, Any]) -> dict[str, Any]:
        """The state's study table before the pin errors are rewritten."""
        if not isinstance(request, dict):
            raise ExploreError("expected a JSON object with overrides")
        overrides = request.get("overrides") or {}
        if not isinstance(overrides, dict):
            raise ExploreError("overrides: expected an object of dotted study keys", "overrides")
        table = self._base(self._case_index(request))
        torque = _get(table, "load.torque_nm")
        if isinstance(torque, list) and torque and "load.torque_nm" not in overrides:
            _set(table, "load.torque_nm", max(torque, key=lambda t: abs(t) if _real(t) else 0))
        for key, value in overrides.items():
            _set(table, str(key), value)
        return table

    def study_text(self, request: dict[str, Any]) -> str:
        """The one-case study file (TOML) of a state of the page; validated.

        Raises
        ------
        StudyError
            The one line of :func:`load_study` (or of the explorer's own keys).
        """
        with self._lock:  # one temporary study file: one state at a time
            return self._study_text(request)

    def _study_text(self, request: dict[str, Any]) -> str:
        from cyclomesh.output.writers import toml_dumps

        table = self._table(request)
        errors = request.get("pin_errors") or {}
        if not isinstance(errors, dict):
            raise ExploreError("pin_errors: expected an object", "pin_errors")
        mode = errors.get("mode", "own")
        if mode not in ("own", "scaled", "drawn"):
            raise ExploreError(
                f'pin_errors.mode: expected "own", "scaled" or "drawn", got {_show(mode)}',
                "pin_errors.mode",
            )
        factor = _number(request, "pin_errors.factor", 1.0, 0.0, 100.0)
        seed = _number(request, "pin_errors.seed", 0, 0, 2**63 - 1)
        if seed != int(seed):
            raise ExploreError(
                f"pin_errors.seed: expected a whole number, got {seed:g}", "pin_errors.seed"
            )
        text = toml_dumps(table)
        if mode == "own" or (mode == "scaled" and factor == 1.0):
            self._checked(text)  # validated: the one line of load_study
            return text
        study = self._load(text)
        case, inputs = study.cases[0], study.inputs[0]
        own = inputs.errors_um
        ecc = case.errors.eccentricity_um
        if mode == "scaled":
            new = {k: factor * own[k] for k in _ERROR_KEYS}
            ecc = factor * ecc
        else:
            if study.tolerance is None:
                raise ExploreError(
                    "pin_errors.mode: drawing errors needs a [tolerance] section in the study",
                    "pin_errors.mode",
                )
            from cyclomesh.tolerance.sampling import draw_ring_errors

            spec = study.tolerance.model_copy(update={"seed": int(seed)})
            ring = draw_ring_errors(
                spec, inputs.design.pins, inputs.design.pin_circle_radius, [0]
            ).scaled(factor)
            new = {k: own[k] + getattr(ring, k)[0] for k in _ERROR_KEYS}
            ecc = ecc + float(ring.eccentricity_um[0])
        table["errors"] = {
            "eccentricity_um": float(ecc),
            **{k: _floats(new[k]) for k in _ERROR_KEYS},
        }
        text = toml_dumps(table)
        self._checked(text)
        return text

    def _checked(self, text: str) -> Study:
        """The state's study, loaded and refused as ``cyclomesh run`` refuses it (work
        limit, keys the run cannot honour): what the page accepts, the command runs."""
        from cyclomesh.studies.preflight import preflight
        from cyclomesh.studyfile.kinds import check_study_work

        study = self._load(text)
        check_study_work(study, "run")
        preflight(study, "run", work=False)
        return study

    def _load(self, text: str) -> Study:
        path = Path(self._tmp.name) / "explore.toml"
        path.write_text(text, encoding="utf-8")
        return load_study(path)

    # --- the analysis ---------------------------------------------------------------------

    def analyse(self, request: dict[str, Any]) -> dict[str, Any]:
        """The summary metrics, verdicts and plot arrays of a state of the page.

        Raises
        ------
        StudyError
            A refused value, one line (the key is :attr:`ExploreError.key` where known).
        """
        angle = _number(request, "crank_angle_deg", 0.0, -1e6, 1e6)
        scale = _number(request, "exaggeration", 1.0, 0.0, MAX_EXAGGERATION)
        torsion = bool(request.get("torsion", False))
        with self._lock:
            text = self._study_text(request)
            solved = self._solved(text, torsion)
            outline = self._outline(solved["study"])
        return {
            **solved["payload"],
            **_scene(solved, outline, angle, scale),
            "study_toml": text,
        }

    def _solved(self, text: str, torsion: bool) -> dict[str, Any]:
        key = f"{torsion}\n{text}"
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        import time

        from cyclomesh.studies.run import compute_run

        start = time.perf_counter()
        study = self._load(text)
        try:
            run = compute_run(study)
        except CyclomeshError as exc:
            raise StudyError(str(exc)) from None
        name = study.cases[0].name
        ds = run.results[name]
        for dim in ("torque", "disc"):
            if dim in ds.dims:
                ds = ds.isel({dim: 0})
        summary = run.summaries[name]
        payload: dict[str, Any] = {
            "case": name,
            "summary": summary,
            **_names(summary),
            "checks": run.checks[name],
            "warnings": run.warnings.get(name, []),
            "plots": _plots(ds, study),
        }
        if torsion:
            payload["torsion"] = self._torsion(study, text)
        payload["seconds"] = time.perf_counter() - start
        solved = {"study": study, "ds": ds, "payload": payload}
        self._cache[key] = solved
        while len(self._cache) > 8:
            self._cache.popitem(last=False)
        return solved

    def _torsion(self, study: Study, text: str) -> dict[str, Any]:
        """The torsion curve of the state (``cyclomesh stiffness``): the case's
        ``[stiffness]``, else ±|T| of the load in 21 torques."""
        import tomllib

        from cyclomesh.output.writers import toml_dumps
        from cyclomesh.studies.stiffness import compute_stiffness

        table = tomllib.loads(text)
        for section in ("figures", "tolerance", "design_space", "fe"):  # not the curve's
            table.pop(section, None)
        if "stiffness" not in table:
            torque = abs(float(study.inputs[0].torque))
            table["stiffness"] = {"rated_torque_nm": torque, "points": 21}
        result = compute_stiffness(self._load(toml_dumps(table)))
        name = study.cases[0].name
        curve = result.curves[name]
        rotation = curve["rotation"].mean("crank_angle")
        return {
            "torque_nm": _json_array(curve["torque"].values),
            "rotation_arcsec": _json_array(rotation.values),
            "summary": result.summaries[name],
            **_names(result.summaries[name]),
            "rated_torque_nm": result.summaries[name].get("rated_torque_nm"),
            "checks": result.checks[name],
        }

    def _outline(self, study: Study) -> Any:
        """The disc profile (disc frame, m) of the state's design and modification."""
        from cyclomesh.core.outline import disc_outline

        inputs = study.inputs[0]
        key = (inputs.design, repr(inputs.modification))
        if key not in self._outlines:
            outline = disc_outline(
                inputs.design, inputs.modification, chord_tolerance=5e-6, samples_per_tooth=128
            )
            self._outlines[key] = (outline.x, outline.y)
            while len(self._outlines) > 8:
                self._outlines.popitem(last=False)
        self._outlines.move_to_end(key)
        return self._outlines[key]


def _real(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _plots(ds: Any, study: Study) -> dict[str, Any]:
    """The arrays of the curves over the crank angle (one torque, disc 1)."""
    load = ds["pin_load"].values
    stress = ds["contact_stress"].values
    profile = ds["profile_angle"].values
    # the stress of every pin over the profile through its mesh cycles: one polyline,
    # a break (None) wherever the pin is out of contact
    xs: list[float | None] = []
    ys: list[float | None] = []
    for i in range(load.shape[1]):
        on = load[:, i] > 0
        if not on.any():
            continue
        x = np.where(on, profile[:, i], np.nan)
        y = np.where(on, stress[:, i], np.nan)
        xs += [*_json_array(x), None]
        ys += [*_json_array(y), None]
    return {
        "crank_angle_deg": _json_array(ds["crank_angle"].values),
        "te_arcsec": _json_array(ds["transmission_error"].values),
        "gear_ratio": _json_array(ds["gear_ratio"].values),
        "contacts": [int(v) for v in ds["contacts"].values],
        "max_stress_mpa": _json_array(stress.max(axis=1)),
        "stress_profile": {"profile_angle_deg": xs, "stress_mpa": ys},
        "ideal_ratio": int(study.inputs[0].design.teeth),
    }


def _scene(solved: dict[str, Any], outline: Any, angle_deg: float, scale: float) -> dict[str, Any]:
    """The disc and the pin ring to scale at the crank angle nearest ``angle_deg`` [mm].

    Fixed frame (the pin wheel, counter-clockwise positive; :mod:`cyclomesh.core.contact`):
    disc centre at (e + εe)(cos φ, sin φ); the disc turned by φt + (φc − φt) + Δφc =
    −φ/n2 + rest + loaded rotation (so TE = −(rest + loaded), Eq. 25); pin i at radius
    a + εa,i and angle ψi + εψ,i with radius ρp + ερ,i (Eq. 5). ``scale`` multiplies
    the loaded rotation Δφc, the deformation (1: to scale; larger: the loaded pins cut
    into the disc by about ``scale`` times their contact approach).
    """
    ds, study = solved["ds"], solved["study"]
    inputs = study.inputs[0]
    design, errors = inputs.design, inputs.errors_um
    angles = ds["crank_angle"].values
    # nearest computed angle, modulo a revolution
    diff = (angles - angle_deg + 180.0) % 360.0 - 180.0
    j = int(np.argmin(np.abs(diff)))
    phi = np.deg2rad(angles[j])
    te = float(ds["transmission_error"].values[j])
    rest = float(ds["rest_rotation"].values[j])
    loaded = float(ds["loaded_rotation"].values[j])
    turn = rest + scale * loaded if math.isfinite(rest + loaded) else 0.0  # arcsec
    theta = -phi / design.teeth + np.deg2rad(turn / 3600.0)
    ecc = design.eccentricity + study.cases[0].errors.eccentricity_um * 1e-6
    cx, cy = ecc * math.cos(phi), ecc * math.sin(phi)
    x, y = outline
    c, s = math.cos(theta), math.sin(theta)
    disc_x = (c * x - s * y + cx) * 1e3
    disc_y = (s * x + c * y + cy) * 1e3
    n1 = design.pins
    psi = 2 * np.pi * np.arange(n1) / n1 + errors["angular_urad"] * 1e-6
    radius = design.pin_circle_radius + errors["radial_um"] * 1e-6
    rho = design.pin_radius + errors["pin_radius_um"] * 1e-6
    return {
        "crank_angle_deg": float(angles[j]),
        "index": j,
        "exaggeration": scale,
        "at_angle": {
            "pin_load_n": _json_array(ds["pin_load"].values[j]),
            "groove_load_n": _json_array(ds["groove_load"].values[j]),
            "contact_stress_mpa": _json_array(ds["contact_stress"].values[j]),
            "profile_angle_deg": _json_array(ds["profile_angle"].values[j]),
            "te_arcsec": te,
            "contacts": int(ds["contacts"].values[j]),
        },
        "scene": {
            "disc_x_mm": _json_array(np.append(disc_x, disc_x[0])),
            "disc_y_mm": _json_array(np.append(disc_y, disc_y[0])),
            "disc_centre_mm": [cx * 1e3, cy * 1e3],
            "pin_x_mm": _json_array(radius * np.cos(psi) * 1e3),
            "pin_y_mm": _json_array(radius * np.sin(psi) * 1e3),
            "pin_radius_mm": _json_array(rho * 1e3),
            "pin_circle_radius_mm": design.pin_circle_radius * 1e3,
        },
    }
