"""Run the cases of a study and write their results: NetCDF, long CSV, summary JSON.

File formats (see ``docs/study-files.md``):

- ``results.nc``: the core's Dataset (:func:`cyclomesh.analyse`) plus the per-pin errors
  of the case (``pin_radial_error`` [µm], ``pin_angular_error`` [µrad],
  ``pin_radius_error`` [µm]) and the study inputs as attributes (``case_name``,
  ``study_title``, ``study_sha256``, ``case_inputs_json``: the validated case, in the
  study file's units).
- ``results.csv``: the same numbers in long format, one row per crank angle and pin,
  columns named after the variables with their unit suffix (``crank_angle_deg``, ``pin``,
  ``pin_load_n``, ...); per-angle values (``transmission_error_arcsec``, ...) repeat on
  every pin's row. A backlash that is infinite (the loaded flank cannot reach the pin)
  is written as an **empty cell**, which spreadsheets treat as blank (ignored by MIN,
  AVERAGE, charts); the files never contain ``NaN`` or ``inf``.
- ``summary.json``: the title and one record per case with the numbers of
  :func:`cyclomesh.summarize`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from cyclomesh.study.config import CaseSpec, Study, folder_name

__all__ = [
    "SUMMARY_KEYS",
    "run_case",
    "annotate",
    "summary_record",
    "write_results_csv",
    "write_case",
    "write_summary",
    "csv_column",
]

SUMMARY_KEYS = (
    "te_mean_arcsec",
    "te_pp_arcsec",
    "max_pin_load_n",
    "max_groove_load_n",
    "max_contact_stress_mpa",
    "max_groove_stress_mpa",
    "contacts_min",
    "contacts_max",
    "gear_ratio_ripple_pct",
    "max_overlap_arcsec",
    "overlap",
)
"""Keys of a case's record in ``summary.json`` besides ``name`` and ``results``."""
DRIVE_SUMMARY_KEYS = ("play_arcsec_mean", "play_arcsec_max", "max_mesh_force_n")
"""Keys of the drive characteristics in a case's record (see docs/drive.md)."""

_UNIT_SUFFIX = {
    "N": "n",
    "MPa": "mpa",
    "arcsec": "arcsec",
    "deg": "deg",
    "mm": "mm",
    "um": "um",
    "µm": "um",
    "urad": "urad",
    "µrad": "urad",
    "N m": "nm",
    "1": "",
    "": "",
}


def run_case(case: CaseSpec) -> xr.Dataset:
    """Analyse one case with :func:`cyclomesh.analyse` and record its inputs."""
    from cyclomesh import analyse

    return annotate(analyse(**case.to_core().kwargs()), case)


def annotate(ds: xr.Dataset, case: CaseSpec, study: Study | None = None) -> xr.Dataset:
    """Add the case's per-pin errors [µm, µrad] and its inputs (attributes) to ``ds``."""
    errors = case.pin_errors()
    out = ds.assign(
        pin_radial_error=("pin", errors["radial_um"], {"units": "um", "long_name": "εa,i"}),
        pin_angular_error=("pin", errors["angular_urad"], {"units": "urad", "long_name": "εψ,i"}),
        pin_radius_error=("pin", errors["pin_radius_um"], {"units": "um", "long_name": "ερ,i"}),
    )
    # The core converts the crank angles to radians and back; put back the angles of the
    # study file exactly (15.0, not 14.999999999999998) so that ds.sel(crank_angle=15) works.
    exact = case.analysis.crank_angles_deg()
    crank = out["crank_angle"]
    if crank.shape == exact.shape and np.allclose(crank.values, exact, rtol=0, atol=1e-9):
        out = out.assign_coords(crank_angle=crank.copy(data=exact))
    out.attrs.update(
        case_name=case.name,
        case_description=case.description,
        case_inputs_json=json.dumps(case.model_dump(mode="json"), ensure_ascii=False),
    )
    if study is not None:
        out.attrs.update(
            study_title=study.title, study_file=study.path.name, study_sha256=study.sha256
        )
    return out


def _number(value: Any) -> float | int | bool | None:
    item = value.item() if hasattr(value, "item") else value
    if isinstance(item, bool | np.bool_):
        return bool(item)
    if isinstance(item, int | np.integer):
        return int(item)
    item = float(item)
    return item if math.isfinite(item) else None


def summary_record(summary: xr.Dataset) -> dict[str, Any]:
    """The numbers of :func:`cyclomesh.summarize` as plain JSON values (non-finite → null).

    A summary with a ``torque`` dimension (a list of torques) gives ``torque_nm`` and a
    list per key, one value per torque.
    """
    record: dict[str, Any] = {}
    if "torque" in summary.dims:
        record["torque_nm"] = [_number(t) for t in summary["torque"].values]
    for key in (*SUMMARY_KEYS, *DRIVE_SUMMARY_KEYS):
        if key in summary:
            values = np.atleast_1d(summary[key].values)
            numbers = [_number(v) for v in values]
            if key.startswith("contacts_"):
                numbers = [int(round(v)) if isinstance(v, float) else v for v in numbers]
            record[key] = numbers if "torque" in summary[key].dims else numbers[0]
    if "gear_ratio_step_deg" in summary.attrs:  # the step the ratio ripple was taken over
        record["gear_ratio_step_deg"] = _number(summary.attrs["gear_ratio_step_deg"])
    return record


def csv_column(name: str, units: str | None) -> str:
    """Column name: the variable name with its unit suffix (``pin_load`` + N → ``pin_load_n``)."""
    suffix = _UNIT_SUFFIX.get((units or "").strip(), (units or "").strip().lower())
    if not suffix or name.endswith(f"_{suffix}"):
        return name
    return f"{name}_{suffix}"


def write_results_csv(ds: xr.Dataset, path: Path) -> Path:
    """Write ``ds`` in long format, one row per crank angle and pin (see module docstring).

    Infinite and missing values are written as empty cells.
    """
    frame = ds.drop_vars([v for v in ds.data_vars if ds[v].ndim == 0]).to_dataframe()
    frame = frame.reset_index()
    names = {}
    for column in frame.columns:
        source = ds[column] if column in ds.variables else None
        names[column] = csv_column(
            column, source.attrs.get("units") if source is not None else None
        )
    frame = frame.rename(columns=names)
    for column in frame.columns:
        if frame[column].dtype.kind == "f":
            frame[column] = frame[column].where(np.isfinite(frame[column]))
        elif frame[column].dtype.kind == "b":
            frame[column] = frame[column].astype(int)
    frame.to_csv(path, index=False, na_rep="", float_format="%.10g")
    return path


def write_case(ds: xr.Dataset, folder: Path) -> dict[str, Path]:
    """Write ``results.nc`` and ``results.csv`` of one case into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    nc = folder / "results.nc"
    ds.to_netcdf(nc)
    return {"netcdf": nc, "csv": write_results_csv(ds, folder / "results.csv")}


def case_folder(name: str) -> str:
    """Folder of a case's files inside the output folder."""
    return folder_name(name)


def write_summary(
    path: Path,
    title: str,
    cases: Sequence[tuple[str, str, Mapping[str, Any]]],
    extra: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``summary.json``.

    Parameters
    ----------
    path : Path
    title : str
    cases : sequence of (name, relative path of results.nc, summary record)
    extra : mapping, optional
        More top-level keys (study file hash, version).
    """
    document: dict[str, Any] = {"title": title, **(extra or {})}
    document["cases"] = [
        {"name": name, "results": results, **record} for name, results, record in cases
    ]
    path.write_text(json.dumps(document, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return path
