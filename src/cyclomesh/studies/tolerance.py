"""Tolerance studies: Monte Carlo rings (``cyclomesh tolerance``), on the one pipeline.

The study runs the base description of the study file (its top-level sections;
``[[cases]]`` are refused) with the errors of ``[tolerance]`` added to the base's
``[errors]``, for the whole stack of discs, over the crank angles of ``[tolerance]``
falling back key by key to ``[analysis]``'s. Stages (see ``docs/pipeline.md``):

1. :func:`compute_tolerance` draws the rings and computes their metrics
   (:data:`cyclomesh.results.metrics.METRICS`) in chunks through :mod:`cyclomesh.execution.backends`
   (local processes or a Dask cluster, bit-for-bit the same), then the statistics;
2. :func:`write_tolerance` writes ``tolerance_rings.nc`` and ``tolerance_rings.parquet``
   (per-ring metrics, units in attributes / field metadata), ``tolerance_summary.json``
   (statistics) and ``worst_ring.toml`` (the ring with the highest peak tooth contact
   stress as an ordinary study file: ``cyclomesh run worst_ring.toml`` reproduces it);
   ``jammed_ring.toml`` and ``unsolved_ring.toml``, the first ring that jams the disc and
   the first one on which a solver did not converge (an outcome of the study, not its
   end: flagged ``jammed`` / ``unsolved`` per ring, NaN metrics, counted as exceeding);
3. :func:`tolerance_figures` and :func:`tolerance_sections` give the figures and the
   report (``report.html``).

The tolerance allocation (``cyclomesh allocate``) is :mod:`cyclomesh.studies.allocate`;
what both share is :mod:`cyclomesh.studies.rings`. Nothing here prints; progress goes
to a callback.
"""

from __future__ import annotations

import html
import json
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.quantities import select
from cyclomesh.results.metrics import DRIVE_METRICS, METRICS, STAGE_RING_METRICS, STRESS_METRIC
from cyclomesh.studies.execute import CommandSteps, StudyKind
from cyclomesh.studies.rings import (
    Progress,
    StudyFiles,
    check_rings,
    fmt_number,
    load_tolerance_study,
    require_tolerance,
    ring_count,
    ring_model,
    ring_total,
    ring_warnings,
    run_rings,
    run_whole,
)
from cyclomesh.studyfile.schema import Study, ToleranceSection
from cyclomesh.studyfile.usage import check_keys
from cyclomesh.tolerance.tasks import RingModel

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.execution.backends import Backend
    from cyclomesh.figures.render import FigureJob
    from cyclomesh.publish.pipeline import OutputOptions
    from cyclomesh.publish.report import Section
    from cyclomesh.tolerance.statistics import Proportion

__all__ = [
    "ToleranceResult",
    "StudyFiles",
    "load_tolerance_study",
    "ring_model",
    "compute_tolerance",
    "write_tolerance",
    "tolerance_figures",
    "tolerance_sections",
    "metrics_dataset",
    "ring_statistics",
    "worst_ring",
    "jammed_rings",
    "unsolved_rings",
    "unsolved_summary",
    "check_some_solved",
    "nonfinite_reason",
    "write_unsolved_ring",
    "worst_ring_study",
    "run_tolerance",
    "TOLERANCE",
]

# --- results of a tolerance study --------------------------------------------------------

RING_METRICS = (
    METRICS | DRIVE_METRICS | select("efficiency", "backdrive_efficiency") | STAGE_RING_METRICS
)
"""The per-ring metrics of a tolerance study: those of a run, a stack's, with
``[friction]`` the forward efficiency (:func:`cyclomesh.tolerance.tasks.ring_efficiency`;
the back-driving one when ``[requirements] min_backdrive_efficiency`` asks for it) and
with ``[stage]`` the stage's (:meth:`cyclomesh.tolerance.tasks.RingModel.stage_metrics`)."""


def metrics_dataset(
    per_ring: Mapping[str, np.ndarray],
    spec: ToleranceSection,
    attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Per-ring metrics as an xarray Dataset with dimension ``ring``, units and long
    names from :data:`RING_METRICS`. Its variables are built without xarray's probe for
    Dask arrays (:func:`cyclomesh.results.arrays.variable`: dask.array is not imported)."""
    import xarray as xr

    from cyclomesh.results.arrays import FIRST_ARRAYS, variable

    ring = np.asarray(per_ring["ring"], dtype=np.int64)
    data = {}
    for name, values in per_ring.items():
        if name == "ring":
            continue
        arr = np.asarray(values)
        if arr.dtype == np.bool_:
            arr = arr.astype(np.int8)  # NetCDF has no boolean
        metric = RING_METRICS.get(name)
        attrs_ = (
            {"units": metric.unit, "long_name": metric.long_name}
            if metric
            else {"units": "1", "long_name": name.replace("_", " ")}
        )
        if name == "jammed":
            attrs_["long_name"] = "1: the ring's errors jam the disc (a pin overlaps it)"
        elif name == "unsolved":
            attrs_["long_name"] = (
                "1: a solver did not converge on the ring (its metrics are NaN, the message "
                "in unsolved_reason)"
            )
        elif name == "unsolved_reason":
            attrs_["long_name"] = "the solver's one-line error of an unsolved ring ('' if solved)"
        elif arr.dtype.kind == "f" and np.any(np.isnan(arr)):
            attrs_["nonfinite"] = nonfinite_reason(per_ring, np.isnan(arr))
        data[name] = variable(("ring",), arr, attrs_)
    # the coordinate first, as in the Dataset of DataArrays before (the files' order);
    # its index imports dask.base: not while a preload thread imports Dask
    with FIRST_ARRAYS:
        ds = xr.Dataset({"ring": variable(("ring",), ring, {"units": "1"}), **data})
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


def nonfinite_reason(per_ring: Mapping[str, np.ndarray], nan: np.ndarray) -> str:
    """The ``nonfinite`` attribute of a metric that is NaN at the rings ``nan``: why."""
    why = []
    if np.any(np.asarray(per_ring.get("jammed", False))[nan]):
        why.append("the ring jams the disc (jammed = 1), no contact")
    if np.any(np.asarray(per_ring.get("unsolved", False))[nan]):
        why.append("a solver did not converge on the ring (unsolved = 1, see unsolved_reason)")
    return "NaN: " + ("; or ".join(why) or "the ring jams the disc (jammed = 1), no contact")


def worst_ring(ds: xr.Dataset, metric: str = STRESS_METRIC) -> int | None:
    """Index k of the ring with the largest ``metric`` (the first one if tied) among the
    rings that do not jam the disc; None if every ring jams."""
    values = np.asarray(ds[metric].values, dtype=float)
    if not np.any(np.isfinite(values)):
        return None
    return int(ds["ring"].values[int(np.nanargmax(values))])


def at_ring(ds: xr.Dataset, name: str, k: int) -> Any:
    """The value of the per-ring variable ``name`` at ring k (``ds[name].sel(ring=k)``,
    by NumPy: a selection builds a Variable, whose probe for Dask arrays imports
    dask.array where it is installed, :mod:`cyclomesh.results.arrays`)."""
    return np.asarray(ds[name].values)[int(np.flatnonzero(ds["ring"].values == k)[0])]


def _flagged(ds: xr.Dataset, flag: str) -> np.ndarray:
    """Indices k of the rings whose 0/1 variable ``flag`` is set (none without it)."""
    if flag not in ds:
        return np.zeros(0, dtype=np.int64)
    return np.asarray(ds["ring"].values[np.asarray(ds[flag].values) != 0], dtype=np.int64)


def jammed_rings(ds: xr.Dataset) -> np.ndarray:
    """Indices k of the rings whose errors jam the disc (``jammed`` of a tolerance study)."""
    return _flagged(ds, "jammed")


def unsolved_rings(ds: xr.Dataset) -> np.ndarray:
    """Indices k of the rings on which a solver did not converge (``unsolved``)."""
    return _flagged(ds, "unsolved")


def _proportion(p: Proportion) -> dict[str, Any]:
    """A proportion of the rings with its Clopper–Pearson interval, JSON-ready."""
    return {
        "count": p.count,
        "rings": p.total,
        "probability": p.estimate,
        "lower": p.lower,
        "upper": p.upper,
    }


def _outcome(
    rings: np.ndarray, total: int, confidence: float, file: str, meaning: str, **extra: Any
) -> dict[str, Any]:
    """The summary block of the ``rings`` (of ``total``) that a study could not analyse
    (jammed or unsolved): their proportion, the first of them, ``extra`` (e.g. the
    solver's message), the file that reproduces the first and what it means."""
    from cyclomesh.tolerance.statistics import exceedance_probability

    return {
        **_proportion(exceedance_probability(rings.size, total, confidence)),
        "first_ring": int(rings[0]) if rings.size else None,
        **extra,
        "file": file if rings.size else None,
        "meaning": meaning,
    }


def unsolved_summary(ds: xr.Dataset, confidence: float) -> dict[str, Any]:
    """The ``unsolved`` block of a summary (JSON-ready): how many rings did not converge,
    the probability of it with its Clopper–Pearson interval, the first such ring, the
    solver's one-line message for it and the file that reproduces it."""
    unsolved = unsolved_rings(ds)
    message = str(at_ring(ds, "unsolved_reason", int(unsolved[0]))) if unsolved.size else None
    return _outcome(
        unsolved,
        ds.sizes["ring"],
        confidence,
        "unsolved_ring.toml",
        "a solver did not converge on the ring (ConvergenceError): its metrics "
        "are NaN, it is left out of the percentiles and counts as exceeding",
        message=message,
    )


def ring_statistics(
    ds: xr.Dataset, spec: ToleranceSection, confidence: float = 0.95
) -> dict[str, Any]:
    """Statistics over the rings (JSON-ready): mean, std, percentiles with intervals,
    exceedance probability of the allowable contact stress, worst ring."""
    from cyclomesh.tolerance.statistics import PERCENTILES, describe, exceedance_probability

    n = ds.sizes["ring"]
    runs = np.ones(n, dtype=bool)
    for flag in ("jammed", "unsolved"):
        if flag in ds:
            runs &= np.asarray(ds[flag].values) == 0
    stats = {}
    for name, metric in RING_METRICS.items():
        if name in ds and name != "any_overlap":
            stats[name] = {
                "unit": metric.unit,
                "description": metric.long_name,
                **describe(np.asarray(ds[name].values)[runs]),
            }
    allowable = spec.allowable_contact_stress_mpa
    exceed = {}
    for name in ("max_contact_stress_mpa", "max_groove_stress_mpa"):
        if name in ds:
            # a ring that jams the disc meets no allowable, and nothing shows that one
            # the solver could not solve meets it: both count as exceeding (conservative)
            count = int(np.count_nonzero(ds[name].values[runs] > allowable))
            count += int(np.count_nonzero(~runs))
            exceed[name] = _proportion(exceedance_probability(count, n, confidence))
    k = worst_ring(ds)
    return {
        "rings": n,
        "seed": spec.seed,
        "confidence": confidence,
        "allowable_contact_stress_mpa": allowable,
        "metrics": stats,
        "exceedance": exceed,
        "jam": _outcome(
            jammed_rings(ds),
            n,
            confidence,
            "jammed_ring.toml",
            "a pin overlaps the disc at every rotation (the pins jam the disc): "
            "the ring cannot be assembled; its metrics are NaN and it counts as exceeding",
        ),
        "unsolved": unsolved_summary(ds, confidence),
        "worst_ring": (
            None
            if k is None
            else {
                "ring": k,
                STRESS_METRIC: float(at_ring(ds, STRESS_METRIC, k)),
                "file": "worst_ring.toml",
            }
        ),
        "overlap_rings": int(np.count_nonzero(ds["any_overlap"].values))
        if "any_overlap" in ds
        else None,
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
        **_stage_worst(ds),
    }


def _stage_worst(ds: xr.Dataset) -> dict[str, Any]:
    """With ``[stage]``: the ring whose weakest crank bearing has the shortest L10h (or,
    without a bearing, the largest crank bearing load), the stage's worst ring."""
    name, pick = ("stage_l10_h_min", np.nanargmin)
    if name not in ds:
        name, pick = ("stage_max_crank_bearing_load_n", np.nanargmax)
    if name not in ds:
        return {}
    values = np.asarray(ds[name].values, dtype=float)
    if not np.any(np.isfinite(values)):
        return {"stage_worst_ring": None}
    i = int(pick(values))
    k = int(ds["ring"].values[i])
    return {
        "stage_worst_ring": {
            "ring": k,
            "by": name,
            **{m: float(ds[m].values[i]) for m in STAGE_RING_METRICS if m in ds},
        }
    }


def worst_ring_study(
    model: RingModel,
    base: Mapping[str, Any],
    ring: int,
    title: str,
    note: str = "",
    factor: float = 1.0,
) -> str:
    """The study file (TOML text) that ``cyclomesh run`` needs to reproduce one ring.

    Parameters
    ----------
    model : RingModel
        The tolerance study's fixed part.
    base : mapping
        The base case's sections in study units (``design``, ``modification``,
        ``material``, ``load``, ``friction``, ``analysis``), e.g. ``CaseSpec.model_dump()``; the
        ``errors`` and crank angles are replaced by the ring's own.
    ring : int
        Ring index k.
    title : str
        Title of the new study.
    note : str
        Comment lines put at the top.
    factor : float
        Scale factor on the ring's drawn errors (an allocation's; 1: as drawn).
    """
    from cyclomesh.output.writers import toml_dumps

    drawn = model.draw([ring])
    if factor != 1.0:
        drawn = drawn.scaled(np.array([factor]))
    total = model.total_errors_um(drawn)
    spec = model.spec
    sections: dict[str, Any] = {"title": title}
    for name in ("design", "modification", "material", "load", "friction"):
        table = _drop_none(base.get(name) or {})
        if table:
            sections[name] = table
    analysis = dict(_drop_none(base.get("analysis", {})))
    start, stop, step = model.crank_range or spec.crank_range()
    analysis.update(
        crank_start_deg=start,
        crank_stop_deg=stop,
        crank_step_deg=step,
        groove_deformation=bool(model.groove_deformation),
        contact_law=model.contact_law,
    )
    sections["analysis"] = analysis
    sections["errors"] = {
        "eccentricity_um": float(total["eccentricity_um"][0]),
        "radial_um": [float(v) for v in total["radial_um"][0]],
        "angular_urad": [float(v) for v in total["angular_urad"][0]],
        "pin_radius_um": [float(v) for v in total["pin_radius_um"][0]],
    }
    if model.stage is not None and base.get("stage"):
        stage = dict(_drop_none(base["stage"]))
        for key, name in (
            ("hole_error_radial_um", "hole_radial_um"),
            ("hole_error_tangential_um", "hole_tangential_um"),
        ):
            if name in total:
                stage[key] = np.asarray(total[name][0], float).tolist()
        sections["stage"] = stage
    header = "".join(f"# {line}\n" for line in note.splitlines())
    return header + toml_dumps(sections) + "\n"


def _drop_none(table: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in table.items():
        if value is None:
            continue
        out[key] = _drop_none(value) if isinstance(value, Mapping) else value
    return {k: v for k, v in out.items() if not (isinstance(v, dict) and not v)}


@dataclass(frozen=True)
class ToleranceResult:
    """Outcome of :func:`compute_tolerance`."""

    study: Study
    spec: ToleranceSection
    model: RingModel
    rings: xr.Dataset
    summary: dict[str, Any]
    seconds: float


def compute_tolerance(
    study: Study,
    *,
    rings: int | None = None,
    backend: Backend | None = None,
    chunk_rings: int | None = None,
    progress: Progress | None = None,
) -> ToleranceResult:
    """Draw the rings of ``study``'s ``[tolerance]`` section and compute their metrics.

    Parameters
    ----------
    study : Study
        With a ``[tolerance]`` section.
    rings : int, optional
        Number of rings (default: ``tolerance.rings``).
    backend : Backend, optional
        Where to run (:func:`cyclomesh.execution.backends.make_backend`; default: serial).
    chunk_rings : int, optional
        Rings per chunk (default: whole core calls, see
        :func:`cyclomesh.tolerance.tasks.block_rings`, up to
        :data:`~cyclomesh.studies.rings.CHUNK_BLOCKS` of them, at least ~4 chunks per
        worker: :func:`~cyclomesh.studies.rings.default_chunk`).
    progress : callable, optional
        Called with the number of rings of every finished chunk.
    """
    from cyclomesh.studies.checks import case_checks, percentile_summary

    check_keys(study.raw, "tolerance")  # [stage], [[cases]], ...: refused in one line
    from cyclomesh.tolerance.tasks import ToleranceTask

    require_tolerance(study)
    start = time.perf_counter()
    spec = study.tolerance
    n = ring_count(spec, rings)
    model = ring_model(study, spec, checked=True)
    per_ring = run_rings(ToleranceTask(model), n, model, backend, chunk_rings, progress)
    check_some_solved(per_ring, spec.seed)
    seconds = time.perf_counter() - start
    ds = metrics_dataset(
        per_ring,
        spec,
        {
            "study_title": study.title,
            "study_sha256": study.sha256,
            "crank_step_deg": model.crank_range[2],
            "discs": model.discs,
            "torque_nm": model.torque_nm,
            "groove_deformation": int(model.groove_deformation),
            "contact_law": model.contact_law,
        },
    )
    stats = ring_statistics(ds, spec, spec.allocation.confidence)
    stats["discs"] = model.discs
    stats["torque_nm"] = model.torque_nm
    stats["crank_angles"] = len(model.crank_angles_deg)
    stats["warnings"] = ring_warnings(model)
    p = study.file.requirements.tolerance_percentile
    stats["checks"] = case_checks(
        study,
        study.base,
        study.base.to_core(),
        percentile_summary(ds, p),
        where=f"P{p:g} of {_ran(stats, n)} (P{100 - p:g} for lower limits)",
    )
    stats["seconds"] = seconds
    stats["rings_per_second"] = n / seconds if seconds > 0 else math.nan
    return ToleranceResult(study, spec, model, ds, stats, seconds)


def check_some_solved(per_ring: Mapping[str, np.ndarray], seed: int) -> None:
    """Refuse, in one line, a study in which a solver failed on some rings and no ring
    was solved (jammed or unsolved, every one): it has no result. (Every ring jamming the
    disc is a result: P(jam) = 1.)

    Raises
    ------
    ConvergenceError
        Naming the first unsolved ring and the solver's message.
    """
    from cyclomesh.exceptions import ConvergenceError

    unsolved = np.asarray(per_ring["unsolved"], dtype=bool)
    jammed = np.asarray(per_ring["jammed"], dtype=bool)
    if not unsolved.any() or not np.all(unsolved | jammed):
        return
    i = int(np.argmax(unsolved))
    n, jam = unsolved.size, int(jammed.sum())
    raise ConvergenceError(
        f"no ring of the {n} could be solved ({int(unsolved.sum())} did not converge"
        + (f", {jam} jam the disc" if jam else "")
        + f"); first: ring {int(per_ring['ring'][i])} (seed {seed}): "
        + str(per_ring["unsolved_reason"][i])
    )


def write_tolerance(result: ToleranceResult, out: Path) -> list[Path]:
    """Write ``tolerance_rings.nc``, ``tolerance_rings.parquet``, ``tolerance_summary.json``
    and ``worst_ring.toml`` into ``out``."""
    from cyclomesh.output.folder import write_text
    from cyclomesh.output.writers import write_json, write_netcdf, write_parquet

    out.mkdir(parents=True, exist_ok=True)
    ds, study, spec = result.rings, result.study, result.spec
    files = [
        write_netcdf(ds, out / "tolerance_rings.nc"),
        # the table of numbers: the solver's messages stay in the NetCDF file
        write_parquet(
            ds.drop_vars("unsolved_reason", errors="ignore"), out / "tolerance_rings.parquet"
        ),
        write_json(out / "tolerance_summary.json", result.summary),
    ]
    k = worst_ring(ds)
    if k is not None:
        note = (
            f"Worst ring of the tolerance study {study.title!r} ({study.path.name}): ring {k} "
            f"of seed {spec.seed},\npeak tooth contact stress "
            f"{float(at_ring(ds, STRESS_METRIC, k)):.6g} MPa. "
            "Reproduce with: cyclomesh run worst_ring.toml --out DIR"
        )
        text = worst_ring_study(
            result.model, study.base.model_dump(), k, f"{study.title}: worst ring {k}", note
        )
        files.append(write_text(out / "worst_ring.toml", text))
    jammed = jammed_rings(ds)
    if jammed.size:
        j = int(jammed[0])
        note = (
            f"First ring of the tolerance study {study.title!r} ({study.path.name}) whose "
            f"errors jam the disc: ring {j} of seed {spec.seed} ({jammed.size} of "
            f"{ds.sizes['ring']} rings jam).\n"
            "cyclomesh run jammed_ring.toml refuses it, naming the pin that overlaps the disc."
        )
        text = worst_ring_study(
            result.model, study.base.model_dump(), j, f"{study.title}: jammed ring {j}", note
        )
        files.append(write_text(out / "jammed_ring.toml", text))
    unsolved = result.summary.get("unsolved") or {}
    if unsolved.get("count"):
        files.append(write_unsolved_ring(result.model, study, unsolved, out))
    return files


def write_unsolved_ring(
    model: RingModel, study: Study, block: Mapping[str, Any], out: Path, factor: float = 1.0
) -> Path:
    """Write ``unsolved_ring.toml``: the first ring on which a solver did not converge
    (``block``: :func:`unsolved_summary`), its errors scaled by ``factor`` (an allocation's
    scale factor), as an ordinary study file that ``cyclomesh run`` refuses with the
    solver's one-line error."""
    from cyclomesh.output.folder import write_text

    k = int(block["first_ring"])
    scaled = "" if factor == 1.0 else f", its errors scaled by {factor:.6g}"
    note = (
        f"First ring of the study {study.title!r} "
        f"({study.path.name}) on which a solver did not converge: ring {k} of seed "
        f"{model.spec.seed}{scaled} ({block['count']} of {block['rings']} rings did not "
        f"converge).\n{block['message']}\n"
        "cyclomesh run unsolved_ring.toml stops with this error (exit status 2)."
    )
    text = worst_ring_study(
        model, study.base.model_dump(), k, f"{study.title}: unsolved ring {k}", note, factor
    )
    return write_text(out / "unsolved_ring.toml", text)


def tolerance_figures(result: ToleranceResult) -> list[FigureJob]:
    """Histograms, distribution functions and the exceedance curve, as figure jobs."""
    from cyclomesh.figures import tolerance as plots
    from cyclomesh.figures.render import FigureJob

    stats = result.summary
    allowable = stats["allowable_contact_stress_mpa"]
    ds = plots.reduce_rings(result.rings, allowable)  # the workers get no per-ring data
    section = "Tolerance study (Monte Carlo)"
    return [
        FigureJob(
            "tolerance_histograms",
            plots.plot_metric_histograms,
            (ds, allowable),
            caption="Histograms of the per-ring metrics",
            section=section,
        ),
        FigureJob(
            "tolerance_ecdfs",
            plots.plot_metric_ecdfs,
            (ds, allowable),
            caption="Empirical distribution functions",
            section=section,
        ),
        FigureJob(
            "tolerance_exceedance",
            plots.plot_stress_exceedance,
            (ds, allowable, stats["confidence"]),
            caption="Probability that the peak tooth contact stress exceeds a level",
            section=section,
        ),
    ]


def tolerance_sections(result: ToleranceResult) -> list[Section]:
    """Report section of a tolerance study: statistics table, exceedance, worst ring."""
    from cyclomesh.publish.report import Section, table_html

    stats = result.summary
    conf = stats["confidence"]
    rows = []
    for name, s in stats["metrics"].items():
        pct = [
            f"{fmt_number(p['estimate'])} [{fmt_number(p['lower'])}, {fmt_number(p['upper'])}]"
            for p in s["percentiles"]
        ]
        m = RING_METRICS.get(name)
        label = name if m is None else m.label + ("" if m.unit == "1" else f" [{m.unit}]")
        rows.append([label, fmt_number(s["mean"]), fmt_number(s["std"]), *pct])
    header = ["metric", "mean", "std"] + [f"P{p:g} [{conf:.0%} CI]" for p in stats["percentiles"]]
    ex = stats["exceedance"][STRESS_METRIC]
    worst = stats["worst_ring"]
    jam = stats["jam"]
    from cyclomesh.publish.report import description_html

    worst_text = (
        "every ring jams the disc"
        if worst is None
        else f"Worst ring: {worst['ring']} ({worst[STRESS_METRIC]:.5g} MPa), written to "
        f"<code>{html.escape(worst['file'])}</code>"
    )
    jam_text = (
        f" Probability that the pins jam the disc (a pin overlaps it at every rotation): "
        f"<b>{jam['probability']:.4g}</b> ({jam['count']} of {jam['rings']} rings; "
        f"{conf:.0%} Clopper–Pearson interval [{jam['lower']:.4g}, {jam['upper']:.4g}]); "
        + (
            f"first jammed ring {jam['first_ring']} written to "
            f"<code>{html.escape(jam['file'])}</code>; jammed rings count as exceeding and "
            "are left out of the statistics below."
            if jam["count"]
            else "no ring jams."
        )
    )
    from cyclomesh.publish.console import unsolved_text

    said = unsolved_text(stats.get("unsolved") or {})
    if said:
        jam_text += (
            f" {html.escape(said)}; unsolved rings count as exceeding and are left out of "
            "the statistics below."
        )
    stage = stats.get("stage_worst_ring")
    if stage:
        life = stage.get("stage_l10_h_min")
        worst_text += (
            f". RV stage: the weakest ring is {stage['ring']}"
            + ("" if life is None else f" (L10h of its weakest crank bearing {life:.5g} h")
            + f"{', ' if life is not None else ' ('}largest crank bearing load "
            f"{stage['stage_max_crank_bearing_load_n']:.5g} N)"
        )
    text = description_html(result.study) + (
        f"<p>{stats['rings']} rings, seed {stats['seed']}. Probability that the peak tooth "
        f"contact stress exceeds {stats['allowable_contact_stress_mpa']:g} MPa: "
        f"<b>{ex['probability']:.4g}</b> ({ex['count']} of {ex['rings']} rings; {conf:.0%} "
        f"Clopper–Pearson interval [{ex['lower']:.4g}, {ex['upper']:.4g}]).{jam_text} "
        f"{worst_text}.</p>"
        + table_html(header, rows)
        + "<p>Methods: "
        + html.escape("; ".join(f"{k}: {v}" for k, v in stats["methods"].items()))
        + ".</p>"
    )
    from cyclomesh.publish.report import warning_sections
    from cyclomesh.studies.checks import checks_section

    return warning_sections(stats.get("warnings", [])) + [
        checks_section({result.study.title: stats["checks"]}),
        Section("Tolerance study (Monte Carlo)", text),
    ]


def run_tolerance(
    study_path: str | Path,
    out_dir: str | Path,
    *,
    rings: int | None = None,
    backend: Backend | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_rings: int | None = None,
    figures: bool = True,
    options: OutputOptions | None = None,
    progress: Progress | None = None,
) -> StudyFiles:
    """A whole tolerance study: compute, write the files, the figures and ``report.html``.

    Runs on ``backend``, else on a Dask cluster at ``scheduler`` or on ``workers``
    local processes (closed at the end), else in this process.
    """
    return run_whole(
        TOLERANCE,
        study_path,
        out_dir,
        backend,
        scheduler,
        workers,
        figures,
        options,
        progress,
        rings=rings,
        chunk_rings=chunk_rings,
    )


def _banner(study: Study, options: Any, workers: int) -> str:
    n = ring_total(study, options["rings"])
    angles = len(study.tolerance.crank_angles_deg(study.base.analysis))
    line = f"tolerance study: {n} rings, {angles} crank angles, {workers} worker(s)"
    return line + _fast_hint(study)


def _fast_hint(study: Study) -> str:
    """With [stage] on the NumPy path: how to get the compiled stage solve (docs/tolerance.md,
    "The fast path for a stage study"); else nothing."""
    from cyclomesh.core.kernel import ENV_VAR, kernel_name

    if "stage" not in study.raw or kernel_name() == "numba":
        return ""
    return (
        f"; the stage solves run on NumPy: with the fast extra (pip install 'cyclomesh[fast]') "
        f"{ENV_VAR}=numba makes them about 2.5x faster (docs/tolerance.md)"
    )


def _show(result: ToleranceResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_tolerance

    print_tolerance(result.summary, out)


TOLERANCE = StudyKind(
    command="tolerance",
    title="tolerance study",
    compute=lambda study, **kw: compute_tolerance(study, **kw),
    write=lambda result, out, options: write_tolerance(result, out),
    figures=lambda result, early: tolerance_figures(result),
    sections=lambda result: tolerance_sections(result),
    keys_first=require_tolerance,
    preflight=check_rings,
    probe_free=True,  # metrics_dataset, at_ring, the NetCDF and Parquet writers
    steps=CommandSteps(
        load=lambda path, options: load_tolerance_study(path)[0],
        parallel=lambda study, options: True,
        banner=_banner,
        progress=lambda study, o: (ring_total(study, o["rings"]), "rings"),
        compute=lambda study, o, backend: {"rings": o["rings"], "chunk_rings": o["chunk_rings"]},
        show=_show,
    ),
)
"""``cyclomesh tolerance`` (:func:`cyclomesh.studies.execute.execute`)."""


def _ran(stats: dict, rings: int) -> str:
    """The rings the percentiles are over: "200 rings", or "5 rings that did not jam (of
    200)" when some jammed, "198 rings that converged (of 200)" when a solver failed on
    some (their metrics are NaN, left out of the percentiles)."""
    jammed = int((stats.get("jam") or {}).get("count") or 0)
    unsolved = int((stats.get("unsolved") or {}).get("count") or 0)
    if not jammed and not unsolved:
        return f"{rings} rings"
    which = " and ".join(
        ([] if not jammed else ["did not jam"]) + ([] if not unsolved else ["converged"])
    )
    return f"{rings - jammed - unsolved} rings that {which} (of {rings})"
