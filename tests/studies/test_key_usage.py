"""Every kind of study × every schema key: used or refused, never ignored.

For each kind of study (run, stiffness, tolerance, allocate, design, fe) and each key of
the study-file schema, :mod:`cyclomesh.studyfile.usage` says whether the kind uses it,
refuses it, or leaves it to another kind (a key in another kind's own section). Here:

* every schema key has a test value in :data:`CHANGE` (a new key fails until it does);
* a *used* key changes what the kind computes, draws or reports: the result's numbers,
  its figure jobs' data, its report sections (without the echo of the study file and
  of the inputs table) or its output options;
* a *refused* key is refused with one line naming it (exit status 2 from the CLI);
* an *other* key lies in the section of another kind of study.

The studies are tiny (3 crank angles, 2-3 rings, 2 candidates); the FE solver is
replaced by a recorder of its arguments (the FE model has its own tests).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import re
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import xarray as xr

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.schema import load_study
from cyclomesh.studyfile.usage import (
    KINDS,
    OWN_SECTIONS,
    REFUSED,
    classify,
    schema_keys,
    set_keys,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

DESIGN = {
    "pins": 40,
    "pin_circle_radius_mm": 82.0,
    "pin_radius_mm": 3.5,
    "groove_radius_mm": 3.505,
    "eccentricity_mm": 1.5,
    "width_mm": 12.0,
}
COMMON = {
    "title": "t",
    "description": "d",
    "design": DESIGN,
    "modification": {"pin_radius_um": 8.0},
    "analysis": {"crank_start_deg": 0.0, "crank_stop_deg": 9.0, "crank_step_deg": 3.0},
}
TOLERANCE = {
    "seed": 1,
    "rings": 3,
    "allowable_contact_stress_mpa": 1100.0,
    "radial_um": {"distribution": "uniform", "half_range": 3.0},
    "angular_urad": {"distribution": "uniform", "half_range": 20.0},
    "allocation": {"factor_max": 1.5, "factor_steps": 2, "bisections": 1},
}
BASE = {
    "run": {**COMMON, "load": {"torque_nm": 250.0}, "cases": [{"name": "a"}]},
    "stiffness": {
        **COMMON,
        "stiffness": {"rated_torque_nm": 250.0, "points": 3},
        "cases": [{"name": "a"}],
    },
    "tolerance": {**COMMON, "load": {"torque_nm": 250.0}, "tolerance": TOLERANCE},
    "allocate": {
        **COMMON,
        "load": {"torque_nm": 250.0},
        "tolerance": {
            **TOLERANCE,
            "allowable_contact_stress_mpa": 1400.0,
            "allocation": {"factor_max": 2.0, "factor_steps": 4, "bisections": 4},
        },
    },
    "design": {
        **COMMON,
        "load": {"torque_nm": 250.0},
        "tolerance": TOLERANCE,
        "design_space": {"pin_radius_um": {"start": 6.0, "stop": 10.0, "points": 2}},
    },
    "fe": {
        **{k: v for k, v in COMMON.items() if k != "analysis"},
        "load": {"torque_nm": 250.0},
        "fe": {"crank_angles_deg": [0.0, 3.0]},
        "cases": [{"name": "a"}],
    },
    "efficiency": {
        **COMMON,
        "friction": {"mesh_coefficient": 0.05, "groove_coefficient": 0.06},
        "efficiency": {
            "torque_nm": {"start": 100.0, "stop": 250.0, "points": 2},
            "input_speed_rpm": {"start": 500.0, "stop": 1000.0, "points": 2},
        },
        "cases": [{"name": "a"}],
    },
}

DELETE = object()


class Replace(dict):
    """A table that replaces the one in the study (a distribution, a range) whole."""


RANDOM = {"errors": {"random": {"seed": 1, "radial_um": 3.0, "angular_urad": 20.0}}}
ROBUST = {"design_space": {"rings": 2}}


def _range(start: float, stop: float) -> dict[str, Any]:
    return {"start": start, "stop": stop, "points": 2}


def _nested(key: str, value: Any) -> dict[str, Any]:
    out: Any = value
    for part in reversed(key.split(".")):
        out = {part: out}
    return out


# key -> the change that sets it (a nested table merged into the study; DELETE removes)
CHANGE: dict[str, Any] = {
    "title": "t2",
    "description": "d2",
    "design.pins": 38,
    "design.pin_circle_radius_mm": 80.0,
    "design.pin_radius_mm": 3.4,
    "design.groove_radius_mm": 3.51,
    "design.eccentricity_mm": 1.45,
    "design.width_mm": 11.0,
    "design.discs": 2,
    "modification.pin_circle_radius_um": -2.0,
    "modification.pin_radius_um": 10.0,
    "modification.rotation_urad": 20.0,
    "modification.profile_file": "PROFILE",
    "material.youngs_modulus_gpa": 200.0,
    "material.poisson_ratio": 0.28,
    "load.torque_nm": 200.0,
    "errors.eccentricity_um": 2.0,
    "errors.radial_um": 3.0,
    "errors.angular_urad": 20.0,
    "errors.pin_radius_um": 2.0,
    "errors.file": str(EXAMPLES / "measured_pins.csv"),
    "errors.random.seed": 2,
    "errors.random.radial_um": 4.0,
    "errors.random.angular_urad": 30.0,
    "errors.random.pin_radius_um": 1.0,
    "analysis.crank_start_deg": 1.0,
    "analysis.crank_stop_deg": 12.0,
    "analysis.crank_step_deg": 1.5,
    "analysis.groove_deformation": False,
    "analysis.contact_law": "paper",
    "analysis.disc_body": "fe",
    "figures.enabled": False,
    "figures.crank_angles_deg": [3.0],
    "figures.stress_pin": 10,
    "figures.stress_over": "contact_radius",
    "figures.formats": ["svg"],
    "figures.dpi": 100,
    "cases": [{"name": "a"}, {"name": "b", "modification": {"pin_radius_um": 10.0}}],
    "tolerance.seed": 2,
    "tolerance.rings": 4,
    "tolerance.allowable_contact_stress_mpa": 5000.0,
    "tolerance.crank_start_deg": 1.0,
    "tolerance.crank_stop_deg": 12.0,
    "tolerance.crank_step_deg": 1.5,
    "tolerance.radial_um": {"distribution": "uniform", "half_range": 5.0},
    "tolerance.angular_urad": {"distribution": "normal", "sigma": 10.0},
    "tolerance.pin_radius_um": {"distribution": "uniform", "half_range": 1.0},
    "tolerance.eccentricity_um": {"distribution": "uniform", "half_range": 1.0},
    "tolerance.position": {"distribution": "true_position", "zone_diameter_um": 6.0},
    "tolerance.allocation.target_probability": 0.3,
    "tolerance.allocation.confidence": 0.9,
    "tolerance.allocation.factor_max": 1.2,
    "tolerance.allocation.factor_steps": 3,
    "tolerance.allocation.bisections": 2,
    "stiffness.rated_torque_nm": 200.0,
    "stiffness.points": 21,
    "stiffness.series_stiffness_nm_per_arcmin": 113.0,
    "design_space.pin_circle_radius_um": _range(-2.0, 0.0),
    "design_space.pin_radius_um": _range(6.0, 12.0),
    "design_space.rotation_urad": _range(0.0, 20.0),
    "design_space.max_play_arcmin": 0.001,
    "design_space.min_play_arcmin": 100.0,
    "design_space.allowable_contact_stress_mpa": 1.0,
    "design_space.max_te_pp_arcsec": 1e-6,
    "design_space.min_contacts": 40,
    "design_space.max_lost_motion_arcmin": 1e-6,
    "design_space.objective": "te_pp",
    "design_space.rings": 2,
    "design_space.lost_motion": True,
    "fe.bore_radius_mm": 25.0,
    "fe.crank_angles_deg": [0.0, 4.0],
    "fe.elements_per_half_width": 6.0,
    "fe.far_size_mm": 2.5,
}
HOLES = {"crank_holes": 3, "crank_hole_circle_radius_mm": 45.0, "crank_hole_radius_mm": 10.0}
BEARING = {"rollers": 10, "roller_diameter_mm": 4.0, "roller_length_mm": 9.0}
STAGE = {"design": {"disc": HOLES}, "stage": {"crank_bearing": BEARING}}
CHANGE.update(
    {
        "stage.output_speed_rpm": 30.0,
        "stage.rated_torque_nm": 200.0,
        "stage.crank_bearing.rollers": 11,
        "stage.crank_bearing.roller_diameter_mm": 3.5,
        "stage.crank_bearing.roller_length_mm": 8.0,
        "stage.crank_bearing.radial_clearance_um": 5.0,
        "stage.crank_bearing.dynamic_load_rating_kn": 20.0,
        "stage.crank_bearing.rating_factor": 1.0,
        "stage.crankshaft_stiffness_n_per_um": 200.0,
        "stage.carrier_stiffness_nm_per_arcmin": 500.0,
        "stage.hole_error_radial_um": 5.0,
        "stage.hole_error_tangential_um": 5.0,
    }
)
for _part in ("pin", "disc", "ring"):
    CHANGE[f"material.{_part}.youngs_modulus_gpa"] = 200.0
    CHANGE[f"material.{_part}.poisson_ratio"] = 0.28
# issue 18: named materials and allowables, requirements, tangential errors, geometry maps
for _part in ("", "pin.", "disc.", "ring."):
    CHANGE[f"material.{_part}name"] = "42CrMo4"
    CHANGE[f"material.{_part}allowable_contact_stress_mpa"] = 900.0
CHANGE.update(
    {
        "requirements.max_contact_stress_mpa": 900.0,
        "requirements.max_groove_stress_mpa": 30.0,
        "requirements.max_te_pp_arcsec": 0.5,
        "requirements.min_contacts": 10,
        "requirements.max_gear_ratio_ripple_pct": 0.1,
        "requirements.max_play_arcmin": 0.5,
        "requirements.max_lost_motion_arcmin": 0.5,
        "requirements.min_torsional_rigidity_nm_per_arcmin": 3000.0,
        "requirements.max_mesh_force_n": 4000.0,
        "requirements.min_bearing_life_h": 6000.0,
        "requirements.tolerance_percentile": 90.0,
        "errors.tangential_um": 2.0,
        "errors.random.tangential_um": 3.0,
        "tolerance.tangential_um": {"distribution": "uniform", "half_range": 4.0},
        "design_space.pin_circle_radius_mm": _range(81.0, 82.0),
        "design_space.pin_radius_mm": _range(3.4, 3.5),
        "design_space.eccentricity_mm": _range(1.4, 1.5),
        "design_space.width_mm": _range(11.0, 12.0),
    }
)
# issue 25: friction, the input speed, efficiency requirement
CHANGE.update(
    {
        "load.input_speed_rpm": 1000.0,
        "friction.mesh_coefficient": 0.05,
        "friction.groove_coefficient": 0.06,
        "friction.bearing_coefficient": 0.004,
        "friction.bearing_diameter_mm": 50.0,
        "friction.pins": "fixed",
        "friction.lubricant.grade": 320,
        "friction.lubricant.viscosity_40c_cst": 200.0,
        "friction.lubricant.viscosity_100c_cst": 25.0,
        "friction.lubricant.temperature_c": 70.0,
        "friction.lubricant.roughness_um": 0.2,
        "friction.lubricant.composite_roughness_um": 0.3,
        "friction.lubricant.pressure_viscosity_per_gpa": 15.0,
        "friction.lubricant.density_kg_m3": 850.0,
        "requirements.min_efficiency": 0.9,
        "requirements.min_backdrive_efficiency": 0.9,
        "efficiency.torque_nm": _range(150.0, 250.0),
        "efficiency.input_speed_rpm": _range(500.0, 2000.0),
        "efficiency.rated_torque_nm": 120.0,
        "efficiency.rated_speed_rpm": 700.0,
        "design_space.min_efficiency": 0.999,
        "tolerance.hole_radial_um": {"distribution": "uniform", "half_range": 2.0},
        "tolerance.hole_tangential_um": {"distribution": "normal", "sigma": 1.0},
        "design_space.min_stage_l10_h": 1e9,
        "design_space.min_stage_rigidity_nm_per_arcmin": 1e9,
        "design_space.max_stage_lost_motion_arcmin": 1e-6,
    }
)
FRICTION = {
    "friction": {
        "mesh_coefficient": 0.03,
        "groove_coefficient": 0.04,
        "bearing_coefficient": 0.002,
        "bearing_diameter_mm": 40.0,
    }
}
LUBRICATED = {  # boundary caps above Benedict–Kelley's value at this speed
    "load": {"input_speed_rpm": 3000.0},
    "friction": {
        "mesh_coefficient": 0.2,
        "groove_coefficient": 0.2,
        "lubricant": {"grade": 220, "temperature_c": 60.0},
    },
}
CHANGE["design.disc.crank_holes"] = 2
CHANGE["design.disc.crank_hole_circle_radius_mm"] = 44.0
CHANGE["design.disc.crank_hole_radius_mm"] = 11.0
CHANGE["design.disc.bore_radius_mm"] = 20.0  # drawn by export, another kind's key

# issue 26: crankshafts and carrier from their geometry, measured loops
SHAFT = {"support_span_mm": 40.0, "disc_pitch_mm": 11.0}
TAPERED = {"rollers": 13, "roller_length_mm": 8.0, "contact_angle_deg": 13.1, "preload_n": 3e3}
PILLARS = {
    "pillars": 3,
    "pillar_diameter_mm": 14.0,
    "pillar_length_mm": 24.0,
    "pillar_circle_radius_mm": 36.0,
}
CHANGE.update(
    {
        "stage.crankshaft.support_span_mm": 45.0,
        "stage.crankshaft.disc_pitch_mm": 12.0,
        "stage.crankshaft.support_bearing_stiffness_n_per_um": 300.0,
        "stage.crankshaft.support_bearing.rollers": 15,
        "stage.crankshaft.support_bearing.roller_length_mm": 6.0,
        "stage.crankshaft.support_bearing.contact_angle_deg": 20.0,
        "stage.crankshaft.support_bearing.preload_n": 1e3,
        "stage.carrier.pillars": 4,
        "stage.carrier.pillar_diameter_mm": 12.0,
        "stage.carrier.pillar_length_mm": 20.0,
        "stage.carrier.pillar_circle_radius_mm": 40.0,
        "stiffness.measured_file": str(EXAMPLES / "rv_stage_measured_loop.csv"),
        "stage.duty_cycle.torque_nm": [250.0, -100.0],
        "stage.duty_cycle.output_speed_rpm": [10.0, 30.0],
        "stage.duty_cycle.time_share": [0.3, 0.7],
        "stage.duty_cycle.file": str(EXAMPLES / "rv_stage_duty_cycle.csv"),
    }
)
DUTY = {"torque_nm": [200.0, -150.0], "output_speed_rpm": [15.0, 15.0], "time_share": [0.5, 0.5]}

# keys whose change needs something else in both studies (kind, key) or (None, key)
CONTEXT: dict[tuple[str | None, str], dict[str, Any]] = {
    **{(None, f"errors.random.{k}"): RANDOM for k in ("seed", "radial_um", "angular_urad")},
    (None, "errors.random.pin_radius_um"): RANDOM,
    (None, "errors.random.tangential_um"): RANDOM,
    **{("design", k): ROBUST for k in schema_keys() if k.startswith("tolerance.")},
    **{
        (kind, k): STAGE
        for kind in ("run", "stiffness", "design", "tolerance", "allocate")
        for k in schema_keys()
        if k.startswith(("stage.", "design.disc."))
    },
    **{
        (kind, k): LUBRICATED if k.startswith("friction.lubricant.") else FRICTION
        for kind in ("run", "stiffness", "efficiency", "design", "tolerance", "allocate")
        for k in schema_keys()
        if k.startswith("friction.")
    },
    ("design", "design_space.min_efficiency"): FRICTION,
    **{
        (kind, f"tolerance.{k}"): STAGE
        for kind in ("tolerance", "allocate", "design")
        for k in ("hole_radial_um", "hole_tangential_um")
    },
    **{
        ("design", f"design_space.{k}"): STAGE
        for k in (
            "min_stage_l10_h",
            "min_stage_rigidity_nm_per_arcmin",
            "max_stage_lost_motion_arcmin",
        )
    },
    # the ratio P_out/P_in of Coulomb friction is the same at every speed: a lubricant's is not
    ("tolerance", "load.input_speed_rpm"): LUBRICATED,
    ("allocate", "load.input_speed_rpm"): LUBRICATED,
}


def change_table(key: str, kind: str = "run") -> dict[str, Any]:
    """The nested table that sets ``key`` to its test value."""
    staged = ("run", "stiffness", "design", "tolerance", "allocate")
    if key.startswith("design.disc.") and kind not in staged:
        return {"design": {"disc": dict(HOLES)}}
    if key == "stage.duty_cycle.file":  # instead of the three lists (not both)
        steps = {"stage": {"duty_cycle": Replace({"file": CHANGE[key]})}}
        return steps if kind in staged else merge(STAGE, steps)
    if key.startswith("stage.") and kind not in staged:
        whole = {  # a valid [stage.crankshaft] / [stage.carrier] around the key
            "stage.crankshaft.support_bearing.": {
                "stage": {"crankshaft": {**SHAFT, "support_bearing": TAPERED}}
            },
            "stage.crankshaft.": {"stage": {"crankshaft": SHAFT}},
            "stage.carrier.": {"stage": {"crankshaft": SHAFT, "carrier": PILLARS}},
            "stage.duty_cycle.": {"stage": {"duty_cycle": DUTY}},
        }
        extra = next((v for k, v in whole.items() if key.startswith(k)), {})
        return merge(merge(STAGE, extra), _nested(key, CHANGE[key]))
    if key == "tolerance.tangential_um":  # instead of angular_urad (not both)
        return {"tolerance": {"angular_urad": DELETE, "tangential_um": CHANGE[key]}}
    if key == "friction.lubricant.viscosity_40c_cst":  # instead of the grade (not both)
        oil = {"viscosity_40c_cst": 200.0, "viscosity_100c_cst": 18.0}
        if kind in ("run", "stiffness", "efficiency", "design", "tolerance", "allocate"):
            return {"friction": {"lubricant": {"grade": DELETE, **oil}}}
        return {"friction": {**FRICTION["friction"], "lubricant": oil}}
    if key.startswith("friction.") and kind not in (
        "run",
        "stiffness",
        "efficiency",
        "design",
        "tolerance",
        "allocate",
    ):
        context = LUBRICATED if key.startswith("friction.lubricant.") else FRICTION
        return merge({"friction": context["friction"]}, _nested(key, CHANGE[key]))
    if key == "errors.random.tangential_um":  # instead of angular_urad (not both)
        return {"errors": {"random": {"angular_urad": DELETE, "tangential_um": CHANGE[key]}}}
    if key == "tolerance.position":
        return {
            "tolerance": {
                "radial_um": DELETE,
                "angular_urad": DELETE,
                "position": CHANGE[key],
            }
        }
    value = CHANGE[key]
    return _nested(key, Replace(value) if isinstance(value, dict) else value)


def merge(base: dict[str, Any], change: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in change.items():
        if value is DELETE:
            out.pop(key, None)
        elif isinstance(value, Replace):
            out[key] = dict(value)
        elif isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


for _kind in ("run", "stiffness", "design", "tolerance", "allocate"):
    for _key in schema_keys():
        if _key.startswith("stage.crankshaft.support_bearing."):
            CONTEXT[(_kind, _key)] = merge(
                STAGE,
                {
                    "design": {"discs": 2},
                    "stage": {"crankshaft": {**SHAFT, "support_bearing": TAPERED}},
                },
            )
        elif _key.startswith("stage.crankshaft."):
            CONTEXT[(_kind, _key)] = merge(
                STAGE, {"design": {"discs": 2}, "stage": {"crankshaft": SHAFT}}
            )
        elif _key.startswith("stage.duty_cycle."):
            CONTEXT[(_kind, _key)] = merge(STAGE, {"stage": {"duty_cycle": DUTY}})
        elif _key.startswith("stage.carrier."):
            CONTEXT[(_kind, _key)] = merge(
                STAGE, {"stage": {"crankshaft": SHAFT, "carrier": PILLARS}}
            )


def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def write_study(tmp_path: Path, data: dict[str, Any], name: str) -> Path:
    data = copy.deepcopy(data)
    if data.get("modification", {}).get("profile_file") == "PROFILE":
        csv = tmp_path / "profile.csv"
        angles = np.linspace(-180.0, 180.0, 37)
        rows = "".join(f"{a},{1.0 + 0.01 * abs(a)}\n" for a in angles)
        csv.write_text("profile_angle_deg,normal_deviation_um\n" + rows)
        data["modification"]["profile_file"] = str(csv)
    path = tmp_path / f"{name}.toml"
    path.write_text("".join(f"{k} = {toml_value(v)}\n" for k, v in data.items()))
    return path


# --- fingerprints: what a kind computes, draws and reports -------------------------------


def _feed(h: Any, obj: Any) -> None:
    if isinstance(obj, xr.Dataset | xr.DataArray):
        ds = obj.to_dataset(name="_") if isinstance(obj, xr.DataArray) else obj
        for name in sorted(map(str, ds.variables)):
            h.update(name.encode())
            _feed(h, ds[name].values)
    elif isinstance(obj, np.ndarray):
        h.update(f"{obj.dtype}{obj.shape}".encode())
        h.update(obj.tobytes() if obj.dtype != object else repr(obj.tolist()).encode())
    elif isinstance(obj, dict):
        for key in sorted(obj, key=str):
            h.update(str(key).encode())
            _feed(h, obj[key])
    elif isinstance(obj, list | tuple):
        h.update(f"[{len(obj)}".encode())
        for item in obj:
            _feed(h, item)
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        h.update(type(obj).__name__.encode())
        _feed(h, {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)})
    elif callable(obj):
        h.update(getattr(obj, "__qualname__", repr(obj)).encode())
    else:
        h.update(repr(obj).encode())


def digest(*parts: Any) -> str:
    h = hashlib.sha256()
    for part in parts:
        _feed(h, part)
    return h.hexdigest()


def report_text(sections: list[Any]) -> list[str]:
    """Report sections without the inputs echo (the study file, the inputs table)."""
    return [
        re.sub(r"<details>.*?</details>", "", s.html, flags=re.S)
        for s in sections
        if s.heading != "Inputs"
    ]


def without_time(record: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in record.items() if k not in ("seconds", "rings_per_second")}


def job_data(jobs: list[Any]) -> list[Any]:
    return [(j.name, j.plot, j.args, j.kwargs, j.caption) for j in jobs]


def fingerprint(kind: str, path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    from cyclomesh.publish.pipeline import OutputOptions

    study = load_study(path)
    options = OutputOptions.from_study(study)
    head = (study.title, options.figures, options.dpi)
    if kind == "run":
        from cyclomesh.studies import run as k

        r = k.compute_run(study)
        jobs = k.input_figures(study) + k.run_figures(r)
        return digest(head, r.results, r.summaries, r.warnings, job_data(jobs),
                      report_text(k.run_sections(r)))  # fmt: skip
    if kind == "stiffness":
        from cyclomesh.studies import stiffness as k

        r = k.compute_stiffness(study)
        return digest(head, r.curves, r.summaries, job_data(k.stiffness_figures(r)),
                      report_text(k.stiffness_sections(r)))  # fmt: skip
    if kind == "tolerance":
        from cyclomesh.studies import tolerance as k

        r = k.compute_tolerance(study)
        return digest(head, r.rings, without_time(r.summary), job_data(k.tolerance_figures(r)),
                      report_text(k.tolerance_sections(r)))  # fmt: skip
    if kind == "allocate":
        from cyclomesh.studies import allocate as k

        r = k.compute_allocation(study)
        return digest(head, r.rings, without_time(r.record), job_data(k.allocation_figures(r)),
                      report_text(k.allocation_sections(r)))  # fmt: skip
    if kind == "design":
        from cyclomesh.studies import designmap as k

        r = k.compute_design(study)
        return digest(head, r.map, r.summary, job_data(k.design_figures(r)),
                      report_text(k.design_sections(r)))  # fmt: skip
    if kind == "efficiency":
        from cyclomesh.studies import efficiency as k

        r = k.compute_efficiency(study)
        return digest(head, r.maps, r.summaries, r.checks, job_data(k.efficiency_figures(r)),
                      report_text(k.efficiency_sections(r)))  # fmt: skip
    if kind == "fe":
        from cyclomesh.studies import fe as k

        calls = fake_fe(monkeypatch)
        r = k.compute_fe(study)
        return digest(head, calls, r.cases, r.summaries, job_data(k.fe_figures(r)),
                      report_text(k.fe_sections(r)))  # fmt: skip
    raise ValueError(kind)


def fake_fe(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Replace the FE solver by a recorder of its arguments returning the LTCA's loads."""
    import cyclomesh.fe.disc as disc
    from cyclomesh.core.ltca import solve_ltca

    calls: list[Any] = []

    def solve(design, modification, torque, crank_angle, **kwargs):
        calls.append((repr(design), repr(modification), torque, crank_angle, kwargs))
        by_law = {}
        for law in ("paper", "half_plane"):
            r = solve_ltca(design, modification, None, torque, [crank_angle], True, law)
            by_law[law] = (r.pin_load[0], r.contact_stress[0], float(r.loaded_rotation[0]))
        mine = by_law[kwargs.get("contact_law", "half_plane")]
        return SimpleNamespace(
            pin_load_fe=mine[0],
            pin_load_ltca=mine[0],
            contact_stress_fe=mine[1],
            contact_stress_ltca=mine[1],
            stress_resolved=np.ones_like(mine[0], dtype=bool),
            rotation_fe=mine[2],
            rotation_ltca=mine[2],
            rest_rotation=0.0,
            nodes=100,
            ltca_by_law=by_law,
        )

    monkeypatch.setattr(disc, "solve_disc_fe", solve)
    return calls


# --- the tests --------------------------------------------------------------------------


def test_every_schema_key_has_a_test_value():
    assert set(schema_keys()) == set(CHANGE), "add the new key to CHANGE (and to usage.USED)"


@pytest.mark.parametrize("kind", KINDS)
def test_every_key_is_used_refused_or_another_kinds(kind):
    for key in schema_keys():
        what = classify(kind, key)
        if what == "other":
            owners = [k for k in OWN_SECTIONS if k != kind]
            assert any(
                key == own or key.startswith(own + ".") for k in owners for own in OWN_SECTIONS[k]
            ), f"{kind}: {key} is not in another kind's section"


def _cases(kind: str, what: str) -> list[tuple[str, str]]:
    return [(kind, key) for key in schema_keys() if classify(kind, key) == what]


NEUTRAL = {
    # a rotation of the profile turns every tooth alike: it moves the TE, not the loads,
    # and an allocation reports only the contact stress; the key reaches the ring model
    ("allocate", "modification.rotation_urad"),
    # likewise the efficiency, which the rotation leaves alone: the key reaches the inputs
    ("efficiency", "modification.rotation_urad"),
    # the torsion test is at rest: no oil film, so the lubricated coefficient is the
    # boundary one; the key reaches the inputs (and the report's note names it)
    *(("stiffness", k) for k in schema_keys() if k.startswith("friction.lubricant.")),
}

USED_CASES = [c for kind in KINDS for c in _cases(kind, "used")]
REFUSED_CASES = [c for kind in KINDS for c in _cases(kind, "refused")]


@pytest.fixture(scope="module")
def baselines():
    return {}


@pytest.fixture(scope="module")
def fe_cache(tmp_path_factory):
    """One cache of the disc body's FE coefficients for every kind (20 s once)."""
    return tmp_path_factory.mktemp("cache")


@pytest.mark.parametrize(("kind", "key"), USED_CASES, ids=[f"{k}-{v}" for k, v in USED_CASES])
def test_a_used_key_changes_the_study(kind, key, tmp_path, monkeypatch, baselines, fe_cache):
    if key == "analysis.disc_body":
        pytest.importorskip("skfem")
        pytest.importorskip("gmsh")
        monkeypatch.setenv("CYCLOMESH_CACHE_DIR", str(fe_cache))
    if (kind, key) in NEUTRAL:  # physically without effect on what the kind reports
        from cyclomesh.studies.tolerance import ring_model

        start = merge(BASE[kind], CONTEXT.get((kind, key)) or {})
        paths = [
            write_study(tmp_path, data, name)
            for data, name in ((start, "a"), (merge(start, change_table(key, kind)), "b"))
        ]
        studies = list(map(load_study, paths))
        if kind == "efficiency":
            assert studies[0].inputs[0].modification != studies[1].inputs[0].modification
            return
        if kind == "stiffness":
            from cyclomesh.studies.stiffness import at_rest

            frictions = [s.inputs[0].friction for s in studies]
            assert frictions[0] != frictions[1]
            assert at_rest(frictions[0]) == at_rest(frictions[1])
            return
        models = [ring_model(s, s.tolerance) for s in studies]
        assert models[0].modification != models[1].modification
        return
    context = CONTEXT.get((kind, key)) or CONTEXT.get((None, key)) or {}
    base = merge(BASE[kind], context)
    cache = (kind, json.dumps(context, sort_keys=True))
    if cache not in baselines:
        baselines[cache] = fingerprint(kind, write_study(tmp_path, base, "base"), monkeypatch)
    changed = write_study(tmp_path, merge(base, change_table(key, kind)), "changed")
    assert fingerprint(kind, changed, monkeypatch) != baselines[cache], f"{kind} ignores {key}"


@pytest.mark.parametrize(("kind", "key"), REFUSED_CASES, ids=[f"{k}-{v}" for k, v in REFUSED_CASES])
def test_a_refused_key_is_refused_in_one_line(kind, key, tmp_path, monkeypatch):
    context = CONTEXT.get((kind, key)) or CONTEXT.get((None, key)) or {}
    base = merge(BASE[kind], context) if kind != "fe" else BASE[kind]
    change = merge(context, change_table(key, kind)) if key.startswith("errors.random") else {}
    path = write_study(tmp_path, merge(base, change or change_table(key, kind)), "refused")
    load_study(path)  # a valid study file: the kind refuses it, not the schema
    with pytest.raises(StudyError) as info:
        fingerprint(kind, path, monkeypatch)
    message = str(info.value)
    assert "\n" not in message
    # refused by the kind's table (for this key, or one it needs set with it, such as the
    # crank holes of a stage), not by some other check
    keys = [key, *set_keys(change or change_table(key, kind))]
    reasons = {w for p, w in REFUSED[kind].items() for k in keys if k == p or k.startswith(p + ".")}
    assert any(why in message for why in reasons), message


@pytest.mark.parametrize(
    ("command", "key"),
    [
        ("design", "stage"),
        ("stiffness", "figures.stress_pin"),
        ("tolerance", "cases"),
        ("allocate", "figures.stress_pin"),
        ("design", "cases"),
    ],  # fmt: skip
)
def test_the_cli_refuses_with_exit_status_2(command, key, tmp_path):
    from typer.testing import CliRunner

    from cyclomesh.cli import app

    kind = command
    full = next(k for k in schema_keys() if k == key or k.startswith(key + "."))
    path = write_study(tmp_path, merge(BASE[kind], change_table(full, kind)), "cli")
    out = tmp_path / "out"
    result = CliRunner().invoke(app, [command, str(path), "--out", str(out), "--quiet"])
    assert result.exit_code == 2, result.output
    assert key in result.output and "Traceback" not in result.output
    assert not (out / "report.html").exists()


@pytest.mark.parametrize("kind", ["run", "stiffness"])
def test_crank_holes_without_a_stage_are_refused(kind, tmp_path, monkeypatch):
    path = write_study(tmp_path, merge(BASE[kind], {"design": {"disc": HOLES}}), "holes")
    with pytest.raises(StudyError, match=r"design\.disc: .*add \[stage\]"):
        fingerprint(kind, path, monkeypatch)
