"""Run tolerance studies from a study file and write their results.

:func:`run_tolerance` draws ``rings`` rings, computes their metrics (chunked, on local
cores or a Dask cluster) and writes, in the output folder:

- ``tolerance_rings.nc``: per-ring metrics (dimension ``ring``), units in attributes;
- ``tolerance_summary.json``: statistics over the rings (see
  :func:`cyclomesh.tolerance.output.summary`);
- ``worst_ring.toml``: the ring with the highest peak tooth contact stress as an
  ordinary study file (``cyclomesh run worst_ring.toml`` reproduces it);
- ``figures/tolerance_*.png`` and a section of ``report.html``.

:func:`run_allocation` finds the largest scale factor on the stated tolerances that
keeps the probability of exceeding the allowable contact stress below a target
(:mod:`cyclomesh.tolerance.allocation`) and writes ``allocation_rings.nc``,
``allocation.json`` and ``figures/allocation_exceedance.png``.

The tolerance study runs the base description of the study file (its top-level
sections; ``[[cases]]`` are not used); the sampled errors add to the base's ``[errors]``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    Task,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.text import Text

from cyclomesh.exceptions import StudyError
from cyclomesh.study.config import Study, load_study
from cyclomesh.tolerance.allocation import Allocation, allocate_factor
from cyclomesh.tolerance.engine import Backend, make_backend, run_rings
from cyclomesh.tolerance.output import metrics_dataset, summary, worst_ring, worst_ring_study
from cyclomesh.tolerance.sampling import RingErrors
from cyclomesh.tolerance.spec import ToleranceSpec, parse_tolerance
from cyclomesh.tolerance.tasks import (
    BLOCK_RINGS,
    STRESS_METRIC,
    AllocationTask,
    RingModel,
    ToleranceTask,
)

__all__ = [
    "ToleranceRun",
    "AllocationRun",
    "load_tolerance_study",
    "ring_model",
    "run_tolerance",
    "run_allocation",
]


def load_tolerance_study(path: str | Path) -> tuple[Study, ToleranceSpec]:
    """Load a study file and validate its ``[tolerance]`` section.

    Raises
    ------
    StudyError
        A bad study file, or no/invalid ``[tolerance]`` section.
    """
    study = load_study(path)
    if study.tolerance is None:
        raise StudyError(f"{Path(path).name}: no [tolerance] section (see examples/tolerance.toml)")
    return study, parse_tolerance(study.tolerance)


def ring_model(study: Study, spec: ToleranceSpec) -> RingModel:
    """The fixed part of the tolerance study: the study's base case as core objects."""
    base = study.base
    core = base.to_core()
    if np.ndim(core.torque) or core.discs != 1:
        raise StudyError(
            "tolerance studies take one disc and one torque: set [load] torque_nm to a "
            "number and leave [design] discs at 1"
        )
    return RingModel(
        design=core.design,
        modification=core.modification,
        base_errors_um=base.pin_errors(),
        base_eccentricity_um=float(base.errors.eccentricity_um),
        torque_nm=float(core.torque),
        crank_angles_deg=spec.crank_angles_deg(),
        groove_deformation=bool(core.groove_deformation),
        spec=spec,
    )


class _RateColumn(ProgressColumn):
    def render(self, task: Task) -> Text:
        speed = task.finished_speed or task.speed
        return Text("-- rings/s" if speed is None else f"{speed:,.1f} rings/s")


@contextmanager
def _progress(total: int, label: str, quiet: bool) -> Iterator[Callable[[int], None]]:
    console = Console(stderr=True)
    if quiet or not console.is_terminal:
        yield lambda done: None
        return
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        _RateColumn(),
        TimeElapsedColumn(),
        TextColumn("left"),
        TimeRemainingColumn(),
        console=console,
        transient=False,
    ) as bar:
        task = bar.add_task(label, total=total)
        yield lambda done: bar.advance(task, done)


def _say(message: str, quiet: bool) -> None:
    if not quiet:
        Console(stderr=True, highlight=False).print(message)


@dataclass(frozen=True)
class ToleranceRun:
    """Outcome of :func:`run_tolerance`."""

    rings: xr.Dataset
    summary: dict[str, Any]
    files: dict[str, Path]
    seconds: float


@dataclass(frozen=True)
class AllocationRun:
    """Outcome of :func:`run_allocation`."""

    allocation: Allocation
    rings: xr.Dataset
    files: dict[str, Path]
    seconds: float


def run_tolerance(
    study_path: str | Path,
    out_dir: str | Path,
    *,
    rings: int | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_rings: int | None = None,
    quiet: bool = False,
    figures: bool = True,
    backend: Backend | None = None,
) -> ToleranceRun:
    """Monte Carlo tolerance study of a study file's ``[tolerance]`` section.

    Parameters
    ----------
    study_path : path
        Study file with a ``[tolerance]`` section.
    out_dir : path
        Output folder (created).
    rings : int, optional
        Number of rings (default: ``tolerance.rings``).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``); default: local cores.
    workers : int, optional
        Local processes (default: all cores; 1 runs in this process).
    chunk_rings : int, optional
        Rings per chunk (default 16, one solve block; a chunk that does not start and
        end on multiples of 16 computes the blocks it touches in full).
    quiet : bool
        No progress bar and no messages.
    figures : bool
        Draw the figures and the report section.
    backend : Backend, optional
        Use this backend instead of ``scheduler``/``workers`` (not closed).
    """
    start = time.perf_counter()
    study, spec = load_tolerance_study(study_path)
    n = spec.rings if rings is None else int(rings)
    if n < 1:
        raise StudyError(f"--rings must be at least 1, got {n}")
    model = ring_model(study, spec)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    own = backend is None
    backend = backend or make_backend(scheduler, workers)
    try:
        chunk = chunk_rings or BLOCK_RINGS
        _say(
            f"tolerance study: {n} rings, {len(model.crank_angles_deg)} crank angles, "
            f"{backend.workers} worker(s), {chunk} rings per chunk",
            quiet,
        )
        with _progress(n, "rings", quiet) as advance:
            per_ring = run_rings(
                ToleranceTask(model), n, backend=backend, chunk_rings=chunk, progress=advance
            )
    finally:
        if own:
            backend.close()
    seconds = time.perf_counter() - start
    ds = metrics_dataset(
        per_ring,
        spec,
        {
            "study_title": study.title,
            "study_sha256": study.sha256,
            "crank_step_deg": spec.crank_step_deg,
            "torque_nm": model.torque_nm,
            "groove_deformation": int(model.groove_deformation),
        },
    )
    stats = summary(ds, spec, spec.allocation.confidence)
    stats["seconds"] = seconds
    stats["rings_per_second"] = n / seconds if seconds > 0 else math.nan
    files = {"rings": out / "tolerance_rings.nc", "summary": out / "tolerance_summary.json"}
    ds.to_netcdf(files["rings"])
    files["summary"].write_text(json.dumps(_jsonable(stats), indent=2) + "\n", encoding="utf-8")
    k = worst_ring(ds)
    files["worst_ring"] = out / "worst_ring.toml"
    note = (
        f"Worst ring of the tolerance study {study.title!r} ({study.path.name}): ring {k} of "
        f"seed {spec.seed},\npeak tooth contact stress "
        f"{float(ds[STRESS_METRIC].sel(ring=k)):.6g} MPa. "
        "Reproduce with: cyclomesh run worst_ring.toml --out DIR"
    )
    files["worst_ring"].write_text(
        worst_ring_study(model, study.base.model_dump(), k, f"{study.title}: worst ring {k}", note),
        encoding="utf-8",
    )
    if figures:
        from cyclomesh.tolerance.figures import write_tolerance_figures

        files.update(write_tolerance_figures(ds, stats, out))
    return ToleranceRun(ds, stats, files, seconds)


def run_allocation(
    study_path: str | Path,
    out_dir: str | Path,
    *,
    target_probability: float | None = None,
    rings: int | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_rings: int | None = None,
    quiet: bool = False,
    figures: bool = True,
    backend: Backend | None = None,
) -> AllocationRun:
    """Largest scale factor on the stated tolerances that meets the target probability.

    Parameters are those of :func:`run_tolerance`, and ``target_probability`` (default:
    ``tolerance.allocation.target_probability``).
    """
    start = time.perf_counter()
    study, spec = load_tolerance_study(study_path)
    alloc = spec.allocation
    target = alloc.target_probability if target_probability is None else target_probability
    if not 0.0 < target < 1.0:
        raise StudyError(f"--target-probability must lie in (0, 1), got {target:g}")
    n = spec.rings if rings is None else int(rings)
    if n < 1:
        raise StudyError(f"--rings must be at least 1, got {n}")
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
    task = AllocationTask(model, factors, alloc.bisections, allowable)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    own = backend is None
    backend = backend or make_backend(scheduler, workers)
    try:
        chunk = chunk_rings or BLOCK_RINGS
        _say(
            f"tolerance allocation: {n} rings, scale factors up to {alloc.factor_max:g} in "
            f"{alloc.factor_steps} steps + {alloc.bisections} bisections, "
            f"{backend.workers} worker(s)",
            quiet,
        )
        with _progress(n, "rings", quiet) as advance:
            per_ring = run_rings(task, n, backend=backend, chunk_rings=chunk, progress=advance)
    finally:
        if own:
            backend.close()
    seconds = time.perf_counter() - start
    result = allocate_factor(
        per_ring["critical_factor_lower"],
        per_ring["critical_factor_upper"],
        target,
        alloc.confidence,
        alloc.factor_max,
    )
    ds = xr.Dataset(
        {
            name: xr.DataArray(per_ring[name], dims=("ring",), attrs={"units": "1"})
            for name in ("critical_factor_lower", "critical_factor_upper")
        },
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
    files = {"rings": out / "allocation_rings.nc", "allocation": out / "allocation.json"}
    ds.to_netcdf(files["rings"])
    record = result.as_dict()
    record.update(
        nominal_contact_stress_mpa=nominal,
        allowable_contact_stress_mpa=allowable,
        seconds=seconds,
        study_title=study.title,
    )
    files["allocation"].write_text(json.dumps(_jsonable(record), indent=2) + "\n", encoding="utf-8")
    if figures:
        from cyclomesh.tolerance.figures import write_allocation_figures

        files.update(write_allocation_figures(result, record, out))
    return AllocationRun(result, ds, files, seconds)


def _nominal_stress(model: RingModel) -> float:
    pins = model.design.pins
    zero = RingErrors(
        np.zeros(1, dtype=np.int64),
        np.zeros((1, pins)),
        np.zeros((1, pins)),
        np.zeros((1, pins)),
        np.zeros(1),
    )
    return float(model.metrics(zero)[STRESS_METRIC][0])


def _jsonable(value: Any) -> Any:
    """NaN and infinities as null (strict JSON), numpy scalars as Python numbers."""
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
