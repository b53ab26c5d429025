"""Results of tolerance studies: per-ring NetCDF, summary statistics, the worst ring as a study.

The worst ring is written as an ordinary study file (TOML with explicit per-pin error
lists) that ``cyclomesh run`` reproduces in full. Floats are written with ``repr`` (the
shortest decimal that reads back to the same double), so the errors read back bit
for bit; no TOML writer package is needed for such a simple file.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from cyclomesh.tolerance.spec import ToleranceSpec
from cyclomesh.tolerance.statistics import (
    PERCENTILES,
    describe,
    exceedance_probability,
)
from cyclomesh.tolerance.tasks import STRESS_METRIC, RingModel

__all__ = [
    "METRICS",
    "metrics_dataset",
    "summary",
    "worst_ring",
    "worst_ring_study",
    "toml_dumps",
]

METRICS: dict[str, tuple[str, str]] = {
    "max_contact_stress_mpa": ("MPa", "peak contact stress, pin-tooth (Eq. 24)"),
    "max_groove_stress_mpa": ("MPa", "peak contact stress, pin-groove (Eq. 24)"),
    "max_pin_load_n": ("N", "largest pin load Fc"),
    "max_groove_load_n": ("N", "largest groove load Fp"),
    "te_mean_arcsec": ("arcsec", "mean loaded transmission error (Eq. 25)"),
    "te_pp_arcsec": ("arcsec", "peak-to-peak loaded transmission error"),
    "gear_ratio_ripple_pct": ("%", "gear-ratio ripple, peak-to-peak in % of n2 (Eq. 26)"),
    "contacts_min": ("1", "fewest pins in contact"),
    "contacts_max": ("1", "most pins in contact"),
    "max_overlap_arcsec": ("arcsec", "largest interference with an unloaded-side pin"),
}
"""Per-ring metrics that are summarised: name -> (unit, description)."""


def metrics_dataset(
    per_ring: Mapping[str, NDArray[Any]],
    spec: ToleranceSpec,
    attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Per-ring metrics as an xarray Dataset with dimension ``ring`` and units in attributes."""
    ring = np.asarray(per_ring["ring"], dtype=np.int64)
    data = {}
    for name, values in per_ring.items():
        if name == "ring":
            continue
        arr = np.asarray(values)
        if arr.dtype == np.bool_:
            arr = arr.astype(np.int8)  # NetCDF has no boolean
        unit, text = METRICS.get(name, ("1", name.replace("_", " ")))
        data[name] = xr.DataArray(arr, dims=("ring",), attrs={"units": unit, "long_name": text})
    ds = xr.Dataset(data, coords={"ring": ("ring", ring, {"units": "1"})})
    ds.attrs.update(
        {
            "seed": spec.seed,
            "allowable_contact_stress_mpa": spec.allowable_contact_stress_mpa,
            "tolerance": json.dumps(spec.model_dump(exclude_none=True)),
            "sampling": "ring k uses numpy PCG64(SeedSequence([seed, k, kind])) per error kind",
        }
    )
    ds.attrs.update(dict(attrs or {}))
    return ds


def worst_ring(ds: xr.Dataset, metric: str = STRESS_METRIC) -> int:
    """Index k of the ring with the largest ``metric`` (the first one if tied)."""
    return int(ds["ring"].values[int(np.argmax(ds[metric].values))])


def summary(ds: xr.Dataset, spec: ToleranceSpec, confidence: float = 0.95) -> dict[str, Any]:
    """Statistics over the rings (JSON-ready): mean, std, percentiles with intervals,
    exceedance probability of the allowable contact stress, worst ring.
    """
    n = ds.sizes["ring"]
    stats = {}
    for name, (unit, text) in METRICS.items():
        if name in ds:
            stats[name] = {"unit": unit, "description": text, **describe(ds[name].values)}
    allowable = spec.allowable_contact_stress_mpa
    exceed = {}
    for name in ("max_contact_stress_mpa", "max_groove_stress_mpa"):
        if name in ds:
            count = int(np.count_nonzero(ds[name].values > allowable))
            p = exceedance_probability(count, n, confidence)
            exceed[name] = {
                "count": p.count,
                "rings": p.total,
                "probability": p.estimate,
                "lower": p.lower,
                "upper": p.upper,
            }
    k = worst_ring(ds)
    out: dict[str, Any] = {
        "rings": n,
        "seed": spec.seed,
        "confidence": confidence,
        "allowable_contact_stress_mpa": allowable,
        "metrics": stats,
        "exceedance": exceed,
        "worst_ring": {
            "ring": k,
            STRESS_METRIC: float(ds[STRESS_METRIC].sel(ring=k)),
            "file": "worst_ring.toml",
        },
        "overlap_rings": int(np.count_nonzero(ds["overlap"].values)) if "overlap" in ds else None,
        "methods": {
            "percentile": "linear interpolation between order statistics (numpy, type 7)",
            "percentile_interval": (
                f"distribution-free order-statistic interval, {confidence:.0%} two-sided "
                "(binomial ranks; NaN where there are too few rings)"
            ),
            "exceedance_interval": f"Clopper-Pearson exact, {confidence:.0%} two-sided",
            "std": "sample standard deviation (ddof = 1)",
        },
        "percentiles": list(PERCENTILES),
    }
    return out


# --- the worst ring as a study file ------------------------------------------------------


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a valid TOML basic string
    if isinstance(value, list | tuple | np.ndarray):
        return "[" + ", ".join(_toml_value(v) for v in list(value)) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def toml_dumps(data: Mapping[str, Any], _prefix: str = "") -> str:
    """A TOML document for nested dicts of numbers, strings, booleans and lists."""
    lines = []
    tables = []
    for key, value in data.items():
        if isinstance(value, Mapping):
            tables.append((key, value))
        else:
            lines.append(f"{key} = {_toml_value(value)}")
    out = "\n".join(lines)
    for key, value in tables:
        name = f"{_prefix}.{key}" if _prefix else key
        body = toml_dumps(value, name)
        out += ("\n\n" if out else "") + f"[{name}]" + ("\n" + body if body else "")
    return out


def worst_ring_study(
    model: RingModel,
    base: Mapping[str, Any],
    ring: int,
    title: str,
    note: str = "",
) -> str:
    """The study file (TOML text) that ``cyclomesh run`` needs to reproduce one ring.

    Parameters
    ----------
    model : RingModel
        The tolerance study's fixed part.
    base : mapping
        The base case's sections in study units (``design``, ``modification``,
        ``material``, ``load``, ``analysis``), e.g. ``CaseSpec.model_dump()``; the
        ``errors`` and crank angles are replaced by the ring's own.
    ring : int
        Ring index k.
    title : str
        Title of the new study.
    note : str
        Comment lines put at the top.
    """
    total = model.total_errors_um(model.draw([ring]))
    spec = model.spec
    sections: dict[str, Any] = {"title": title}
    for name in ("design", "modification", "material", "load"):
        table = _drop_none(base.get(name) or {})
        if table:
            sections[name] = table
    analysis = dict(_drop_none(base.get("analysis", {})))
    analysis.update(
        crank_start_deg=float(spec.crank_start_deg),
        crank_stop_deg=float(spec.crank_stop_deg),
        crank_step_deg=float(spec.crank_step_deg),
        groove_deformation=bool(model.groove_deformation),
    )
    sections["analysis"] = analysis
    sections["errors"] = {
        "eccentricity_um": float(total["eccentricity_um"][0]),
        "radial_um": [float(v) for v in total["radial_um"][0]],
        "angular_urad": [float(v) for v in total["angular_urad"][0]],
        "pin_radius_um": [float(v) for v in total["pin_radius_um"][0]],
    }
    header = "".join(f"# {line}\n" for line in note.splitlines())
    return header + toml_dumps(sections) + "\n"


def _drop_none(table: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in table.items():
        if value is None:
            continue
        out[key] = _drop_none(value) if isinstance(value, Mapping) else value
    return {k: v for k, v in out.items() if not (isinstance(v, dict) and not v)}
