"""Tolerance allocation (``cyclomesh allocate``): the largest scale factor on the stated
tolerances of ``[tolerance]`` that keeps the probability of exceeding the allowable
contact stress under the target, on the one pipeline.

With ``[friction]`` every ring is solved with friction in the equilibrium (the contact
stress of the criterion includes its effect on the load sharing) and the rings'
forward efficiency at the stated tolerances is reported beside the other metrics. The
criterion stays the contact stress: an efficiency requirement (``min_efficiency``) is
checked by ``cyclomesh tolerance`` over the rings, not allocated against (the
efficiency hardly moves with the pin errors, see docs/efficiency.md).

Stages as for :mod:`cyclomesh.studies.tolerance` (see ``docs/pipeline.md``):
:func:`compute_allocation`, :func:`write_allocation` (``allocation_rings.nc``,
``allocation.json``), :func:`allocation_figures` and :func:`allocation_sections`
(``allocation_report.html``). Nothing here prints; progress goes to a callback.
"""

from __future__ import annotations

import html
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.exceptions import StudyError
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
from cyclomesh.studies.tolerance import (
    check_some_solved,
    nonfinite_reason,
    unsolved_summary,
    write_unsolved_ring,
)
from cyclomesh.studyfile.schema import Study
from cyclomesh.studyfile.usage import check_keys
from cyclomesh.tolerance.allocation import Allocation
from cyclomesh.tolerance.tasks import RingModel

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.execution.backends import Backend
    from cyclomesh.figures.render import FigureJob
    from cyclomesh.publish.pipeline import OutputOptions
    from cyclomesh.publish.report import Section

__all__ = [
    "AllocationResult",
    "StudyFiles",
    "compute_allocation",
    "write_allocation",
    "allocation_figures",
    "allocation_sections",
    "run_allocation",
    "ALLOCATE",
]


@dataclass(frozen=True)
class AllocationResult:
    """Outcome of :func:`compute_allocation`."""

    study: Study
    allocation: Allocation
    rings: xr.Dataset
    record: dict[str, Any]
    seconds: float
    model: RingModel | None = None


def _nominal_stress(model: RingModel) -> float:
    from cyclomesh.tolerance.sampling import RingErrors

    pins = model.design.pins
    zero = RingErrors(
        np.zeros(1, dtype=np.int64),
        np.zeros((1, pins)),
        np.zeros((1, pins)),
        np.zeros((1, pins)),
        np.zeros(1),
    )
    return float(model.metrics(zero)[_stress_metric(model)][0])


STAGE_STRESS_METRIC = "stage_max_contact_stress_mpa"


def _stress_metric(model: RingModel) -> str:
    """The allocation's criterion: the peak tooth contact stress, with ``[stage]`` the one
    of the stage solve (pins loaded through the crank bearings, the hole errors in)."""
    return STRESS_METRIC if model.stage is None else STAGE_STRESS_METRIC


def _check_stated(per_ring: dict[str, np.ndarray], model: RingModel, metric: str) -> None:
    """Refuse, in one line, an allocation in which no ring can be solved at the stated
    tolerances (factor 1: every ring jams the disc or does not converge there): it has no
    statistics there. The line is the first ring's own error.

    Raises
    ------
    CyclomeshError
        That of the first ring, solved again alone.
    """
    if np.any(np.isfinite(per_ring[metric])):
        return
    from cyclomesh.exceptions import CyclomeshError

    first = int(per_ring["ring"][0])
    try:
        model.metrics(model.draw([first]))
    except CyclomeshError as exc:
        raise type(exc)(
            f"no ring of the {per_ring['ring'].size} can be solved at the stated tolerances "
            f"(factor 1); {exc}"
        ) from None


def compute_allocation(
    study: Study,
    *,
    target_probability: float | None = None,
    rings: int | None = None,
    backend: Backend | None = None,
    chunk_rings: int | None = None,
    progress: Progress | None = None,
) -> AllocationResult:
    """Largest scale factor on the stated tolerances that meets the target probability.

    Parameters are those of :func:`compute_tolerance`, and ``target_probability``
    (default: ``tolerance.allocation.target_probability``).
    """

    check_keys(study.raw, "allocate")  # [stage], [[cases]], ...: refused in one line
    import xarray as xr

    from cyclomesh.tolerance.allocation import allocate_factor
    from cyclomesh.tolerance.tasks import AllocationTask

    require_tolerance(study)
    start = time.perf_counter()
    spec = study.tolerance
    alloc = spec.allocation
    target = alloc.target_probability if target_probability is None else target_probability
    if not 0.0 < target < 1.0:
        raise StudyError(f"--target-probability must lie in (0, 1), got {target:g}")
    n = ring_count(spec, rings)
    model = ring_model(study, spec)
    allowable = spec.allowable_contact_stress_mpa
    nominal = _nominal_stress(model)
    if nominal > allowable:
        raise StudyError(
            f"the nominal ring (no sampled errors) already exceeds the allowable contact "
            f"stress: {nominal:.1f} MPa > {allowable:g} MPa; no tolerance can meet it"
        )
    factors = tuple(
        alloc.factor_max * (i + 1) / alloc.factor_steps for i in range(alloc.factor_steps)
    )
    task = AllocationTask(model, factors, alloc.bisections, allowable, _stress_metric(model))
    per_ring = run_rings(task, n, model, backend, chunk_rings, progress)
    check_some_solved(per_ring, spec.seed)
    _check_stated(per_ring, model, _stress_metric(model))
    seconds = time.perf_counter() - start
    result = allocate_factor(
        per_ring["critical_factor_lower"],
        per_ring["critical_factor_upper"],
        target,
        alloc.confidence,
        alloc.factor_max,
    )
    from cyclomesh.tolerance.statistics import describe
    from cyclomesh.tolerance.tasks import STATED_METRICS

    stated = [name for name in STATED_METRICS if name in per_ring]
    every = METRICS | DRIVE_METRICS | STAGE_RING_METRICS | select("efficiency")
    data = {
        name: xr.DataArray(per_ring[name], dims=("ring",), attrs={"units": "1"})
        for name in ("critical_factor_lower", "critical_factor_upper")
    }
    data["critical_factor_upper"].attrs["nonfinite"] = (
        "inf: the ring does not exceed the allowable stress up to factor_max"
    )
    for name in stated:
        data[name] = xr.DataArray(
            per_ring[name],
            dims=("ring",),
            attrs={
                "units": every[name].unit,
                "long_name": every[name].long_name + " at the stated tolerances (factor 1)",
            },
        )
        nan = np.isnan(per_ring[name])
        if nan.any():
            data[name].attrs["nonfinite"] = nonfinite_reason(per_ring, nan)
    data["jammed"] = xr.DataArray(
        per_ring["jammed"].astype(np.int8),
        dims=("ring",),
        attrs={"units": "1", "long_name": "1: the ring jams the disc at the stated tolerances"},
    )
    data["unsolved"] = xr.DataArray(
        per_ring["unsolved"].astype(np.int8),
        dims=("ring",),
        attrs={
            "units": "1",
            "long_name": "1: a solver did not converge on the ring at a scale factor the "
            "allocation needed (it counts as exceeding there; the message in unsolved_reason)",
        },
    )
    data["unsolved_reason"] = xr.DataArray(
        per_ring["unsolved_reason"],
        dims=("ring",),
        attrs={"units": "1", "long_name": "the solver's one-line error of an unsolved ring"},
    )
    runs = ~(np.asarray(per_ring["jammed"]) | np.isnan(per_ring[stated[0]]))
    ds = xr.Dataset(
        data,
        coords={"ring": ("ring", per_ring["ring"])},
        attrs={
            "seed": spec.seed,
            "allowable_contact_stress_mpa": allowable,
            "nominal_contact_stress_mpa": nominal,
            "study_title": study.title,
            "study_sha256": study.sha256,
            "tolerance": json.dumps(spec.model_dump(exclude_none=True)),
            "method": result.as_dict()["method"],
        },
    )
    record = result.as_dict()
    record.update(
        nominal_contact_stress_mpa=nominal,
        allowable_contact_stress_mpa=allowable,
        seconds=seconds,
        study_title=study.title,
        discs=model.discs,
        crank_angles=len(model.crank_angles_deg),
        at_stated_tolerances={
            name: {
                "unit": every[name].unit,
                "description": every[name].long_name,
                **describe(per_ring[name][runs], confidence=alloc.confidence),
            }
            for name in stated
        },
        warnings=ring_warnings(model),
        unsolved=unsolved_summary(ds, alloc.confidence),
    )
    first = record["unsolved"]["first_ring"]
    if first is not None:
        record["unsolved"]["scale_factor"] = float(
            per_ring["unsolved_factor"][np.flatnonzero(per_ring["ring"] == first)[0]]
        )
        record["unsolved"]["meaning"] = (
            "a solver did not converge on the ring at a scale factor the allocation needed "
            "(ConvergenceError): the ring counts as exceeding the allowable from that factor "
            "on; its metrics at the stated tolerances are NaN if it failed there"
        )
    return AllocationResult(study, result, ds, record, seconds, model)


def write_allocation(result: AllocationResult, out: Path) -> list[Path]:
    """Write ``allocation_rings.nc`` and ``allocation.json`` into ``out``, and
    ``unsolved_ring.toml`` (the first ring a solver did not converge on, its errors scaled
    by the factor where it failed) if there is one."""
    from cyclomesh.output.writers import write_json, write_netcdf

    out.mkdir(parents=True, exist_ok=True)
    files = [
        write_netcdf(result.rings, out / "allocation_rings.nc"),
        write_json(out / "allocation.json", result.record),
    ]
    unsolved = result.record.get("unsolved") or {}
    if unsolved.get("count") and result.model is not None:
        files.append(
            write_unsolved_ring(result.model, result.study, unsolved, out, unsolved["scale_factor"])
        )
    return files


def allocation_figures(result: AllocationResult) -> list[FigureJob]:
    """The exceedance probability against the scale factor, as a figure job."""
    from cyclomesh.figures import tolerance as plots
    from cyclomesh.figures.render import FigureJob

    return [
        FigureJob(
            "allocation_exceedance",
            plots.plot_allocation,
            (result.allocation,),
            caption="Exceedance probability vs. scale factor on the tolerances",
            section="Tolerance allocation",
        )
    ]


def allocation_sections(result: AllocationResult) -> list[Section]:
    """Report section of a tolerance allocation."""
    from cyclomesh.publish.report import Section, description_html, table_html, warning_sections

    statement = html.escape(result.allocation.statement())
    stated = result.record.get("at_stated_tolerances", {})
    rows = [
        [name, m["unit"], fmt_number(m["mean"]), fmt_number(m["min"]), fmt_number(m["max"])]
        + [fmt_number(p["estimate"]) for p in m["percentiles"]]
        for name, m in stated.items()
    ]
    table = ""
    if rows:
        percents = [p["percent"] for p in next(iter(stated.values()))["percentiles"]]
        table = "<p>The rings at the stated tolerances (factor 1):</p>" + table_html(
            ["metric", "unit", "mean", "min", "max", *(f"P{p:g}" for p in percents)], rows
        )
    from cyclomesh.publish.console import unsolved_text

    said = unsolved_text(result.record.get("unsolved") or {})
    if said:
        statement += (
            f" {html.escape(said)}; such a ring counts as exceeding the allowable from the "
            "scale factor where it failed (conservative)."
        )
    return warning_sections(result.record.get("warnings", [])) + [
        Section(
            "Tolerance allocation",
            description_html(result.study) + f"<p>{statement}</p>" + table,
        )
    ]


def run_allocation(
    study_path: str | Path,
    out_dir: str | Path,
    *,
    target_probability: float | None = None,
    rings: int | None = None,
    backend: Backend | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_rings: int | None = None,
    figures: bool = True,
    options: OutputOptions | None = None,
    progress: Progress | None = None,
) -> StudyFiles:
    """A whole tolerance allocation: compute, write the files, the figure and
    ``allocation_report.html`` (``backend``, ``scheduler``, ``workers`` as for
    :func:`run_tolerance`)."""
    return run_whole(
        ALLOCATE,
        study_path,
        out_dir,
        backend,
        scheduler,
        workers,
        figures,
        options,
        progress,
        target_probability=target_probability,
        rings=rings,
        chunk_rings=chunk_rings,
    )


def _check_target(study: Study, options: Any) -> None:
    target = options["target_probability"]
    if target is not None and not 0.0 < target < 1.0:
        raise StudyError(f"--target-probability must lie in (0, 1), got {target:g}")


def _banner(study: Study, options: Any, workers: int) -> str:
    alloc = study.tolerance.allocation
    return (
        f"tolerance allocation: {ring_total(study, options['rings'])} rings, scale factors "
        f"up to {alloc.factor_max:g} in {alloc.factor_steps} steps + {alloc.bisections} "
        f"bisections, {workers} worker(s)"
    )


def _show(result: AllocationResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_allocation, unsolved_text

    statement = result.allocation.statement()
    unsolved = result.record.get("unsolved") or {}
    if unsolved.get("count"):
        said = unsolved_text({**unsolved, "file": str(out / unsolved["file"])})
        statement += f" {said}; counted as exceeding."
    print_allocation(statement, result.record.get("warnings", []), out)


ALLOCATE = StudyKind(
    command="allocate",
    title="tolerance allocation",
    compute=lambda study, **kw: compute_allocation(study, **kw),
    write=lambda result, out, options: write_allocation(result, out),
    figures=lambda result, early: allocation_figures(result),
    sections=lambda result: allocation_sections(result),
    report_name="allocation_report.html",
    keys_first=require_tolerance,
    preflight=check_rings,
    steps=CommandSteps(
        load=lambda path, options: load_tolerance_study(path)[0],
        check=_check_target,
        parallel=lambda study, options: True,
        banner=_banner,
        progress=lambda study, o: (ring_total(study, o["rings"]), "rings"),
        compute=lambda study, o, backend: {
            "target_probability": o["target_probability"],
            "rings": o["rings"],
            "chunk_rings": o["chunk_rings"],
        },
        show=_show,
    ),
)
"""``cyclomesh allocate`` (:func:`cyclomesh.studies.execute.execute`)."""
