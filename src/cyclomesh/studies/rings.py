"""What the two ring studies share: ``cyclomesh tolerance``
(:mod:`cyclomesh.studies.tolerance`) and ``cyclomesh allocate``
(:mod:`cyclomesh.studies.allocate`).

The study file's base case as a :class:`~cyclomesh.tolerance.tasks.RingModel`
(:func:`ring_model`), the rings run in chunks on an execution backend
(:func:`run_rings`), and a whole study run through
:func:`~cyclomesh.studies.execute.execute` for the Python API (:func:`run_whole`,
:class:`StudyFiles`). Nothing here prints.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.exceptions import StudyError
from cyclomesh.results.dataset import resolve_disc_body
from cyclomesh.studyfile.schema import Study, ToleranceSection, load_study
from cyclomesh.tolerance.allocation import Allocation
from cyclomesh.tolerance.tasks import RingModel

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.execution.backends import Backend
    from cyclomesh.publish.pipeline import OutputOptions

__all__ = [
    "StudyFiles",
    "load_tolerance_study",
    "require_tolerance",
    "check_rings",
    "ring_total",
    "ring_model",
    "ring_warnings",
    "ring_count",
    "run_rings",
    "default_chunk",
    "CHUNK_BLOCKS",
    "fmt_number",
    "run_whole",
]

Progress = Callable[[int], None]


def load_tolerance_study(path: str | Path) -> tuple[Study, ToleranceSection]:
    """Load a study file that must have a ``[tolerance]`` section.

    Raises
    ------
    StudyError
        A bad study file, or no ``[tolerance]`` section.
    """
    study = load_study(path)
    require_tolerance(study)
    return study, study.tolerance


def require_tolerance(study: Study) -> None:
    """Refuse, in one line, a study without a ``[tolerance]`` section."""
    if study.tolerance is None:
        raise StudyError(f"{study.path.name}: no [tolerance] section (see examples/tolerance.toml)")


def check_rings(study: Study) -> None:
    """The pre-flight of a ring study: the base case must make a ring model."""
    ring_model(study, study.tolerance)


def ring_total(study: Study, rings: int | None) -> int:
    """The rings a command draws: ``--rings``, else ``tolerance.rings``."""
    return study.tolerance.rings if rings is None else rings


def ring_model(study: Study, spec: ToleranceSection, checked: bool = False) -> RingModel:
    """The fixed part of the tolerance study: the study's base case as core objects.

    ``checked``: the kind checks ``[requirements]`` (``cyclomesh tolerance``); then
    ``min_backdrive_efficiency`` with ``[friction]`` asks for every ring's back-driving
    efficiency (a second solve per ring, :attr:`RingModel.backdrive`; the stage's too with
    ``[stage]``). With ``[stage]`` and ``[friction]`` every ring's stage is also solved
    with friction (:attr:`RingModel.stage_friction`)."""
    base = study.base
    core = base.to_core()
    if np.ndim(core.torque):
        raise StudyError(
            "load.torque_nm: tolerance studies take one torque (of the stack), not a list"
        )
    crank_range = spec.crank_range(base.analysis)
    holes = [k for k in ("hole_radial_um", "hole_tangential_um") if getattr(spec, k) is not None]
    if holes and (core.stage is None or core.stage.bearing is None):
        raise StudyError(
            f"tolerance.{holes[0]}: crank hole errors need the RV stage with its bearings: "
            "add [stage] and [stage.crank_bearing] (docs/stage.md), or remove the key"
        )
    stage_friction = None
    if core.stage is not None and core.friction is not None:
        from cyclomesh.exceptions import DesignError
        from cyclomesh.stage.friction import check_stage_friction

        try:  # before the rings: a DesignError of a ring's solve is a jammed ring
            check_stage_friction(core.friction, core.stage.bearing)
        except DesignError as exc:
            raise StudyError(str(exc)) from None
        stage_friction = core.friction
    return RingModel(
        design=core.design,
        modification=core.modification,
        base_errors_um=core.errors_um,
        base_eccentricity_um=float(base.errors.eccentricity_um),
        torque_nm=float(core.torque),
        crank_angles_deg=spec.crank_angles_deg(base.analysis),
        groove_deformation=bool(core.groove_deformation),
        spec=spec,
        contact_law=core.contact_law,
        discs=core.discs,
        crank_range=crank_range,
        disc_body=resolve_disc_body(
            core.disc_body, core.design, core.modification, core.crank_holes
        ),
        stage=core.stage,
        stage_disc_body=(
            "rigid"
            if core.stage is None
            else resolve_disc_body(
                core.disc_body, core.design, core.modification, core.crank_holes, stage=True
            )
        ),
        base_hole_errors_um=(
            None
            if base.stage is None
            else (base.stage.hole_error_radial_um, base.stage.hole_error_tangential_um)
        ),
        friction=core.mesh_friction,
        backdrive=checked
        and core.friction is not None
        and study.file.requirements.min_backdrive_efficiency is not None,
        stage_friction=stage_friction,
    )


def ring_warnings(model: RingModel) -> list[str]:
    """Warnings of a tolerance or allocation study (:mod:`cyclomesh.studyfile.warnings`)."""
    from cyclomesh.studyfile.warnings import study_warnings

    out = study_warnings(
        model.contact_law, model.crank_angles_deg, True, "rings drawn from [tolerance]"
    )
    stage = None if model.stage is None else model.stage.preload_warning(model.discs)
    return out + ([stage] if stage else [])


def ring_count(spec: ToleranceSection, rings: int | None) -> int:
    n = spec.rings if rings is None else int(rings)
    if n < 1:
        raise StudyError(f"--rings must be at least 1, got {n}")
    return n


def run_rings(
    task: Any,
    n: int,
    model: RingModel,
    backend: Backend | None,
    chunk: int | None,
    progress: Progress | None,
) -> dict[str, np.ndarray]:
    from cyclomesh.execution.backends import SerialBackend, run_chunks

    backend = backend or SerialBackend()
    size = chunk or default_chunk(n, model, backend.workers)
    return run_chunks(task, n, backend=backend, chunk_size=size, progress=progress)


CHUNK_BLOCKS = 8
"""Core calls (of :attr:`~cyclomesh.tolerance.tasks.RingModel.block_rings` rings each) in
one chunk at most. A chunk costs the pool a round trip (the task pickled to the worker,
its result back, the parent's wake-up): at one core call a chunk, a 36-step study of
40,000 rings on two local workers took 0.27 CPU-seconds of the parent and 16.0–16.3 of
the workers, at eight 0.04 and 14.3–14.7 (issue 27; the rings' bits are the same for
every chunking)."""


def default_chunk(n: int, model: RingModel, workers: int) -> int:
    """Whole core calls per chunk, up to :data:`CHUNK_BLOCKS` of them, but at least ~4
    chunks per worker for balance."""
    per_worker = math.ceil(n / (4 * max(1, workers)))
    block = model.block_rings
    if per_worker <= block:
        return max(1, per_worker)
    return block * min(CHUNK_BLOCKS, per_worker // block)


def fmt_number(x: Any) -> str:
    return "n/a" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{x:.4g}"


@dataclass(frozen=True)
class StudyFiles:
    """What :func:`run_tolerance` and :func:`run_allocation` return."""

    result: Any
    files: list[Path]

    @property
    def summary(self) -> dict[str, Any]:
        """Statistics (tolerance) or the allocation record."""
        return getattr(self.result, "summary", None) or self.result.record

    @property
    def rings(self) -> xr.Dataset:
        """Per-ring results."""
        return self.result.rings

    @property
    def allocation(self) -> Allocation:
        """The allocation (of :func:`run_allocation`)."""
        return self.result.allocation


@contextmanager
def _backend(
    backend: Backend | None, scheduler: str | None, workers: int | None
) -> Iterator[Backend | None]:
    if backend is not None or (scheduler is None and workers is None):
        yield backend
        return
    from cyclomesh.execution.backends import make_backend

    own = make_backend(scheduler, workers)
    try:
        yield own
    finally:
        own.close()


def _options(study: Study, figures: bool, options: OutputOptions | None) -> OutputOptions:
    from cyclomesh.publish.pipeline import OutputOptions

    if options is not None:
        return options
    return OutputOptions.from_study(study, None if figures else "none")


def run_whole(
    kind: Any,
    study_path: str | Path,
    out_dir: str | Path,
    backend: Backend | None,
    scheduler: str | None,
    workers: int | None,
    figures: bool,
    options: OutputOptions | None,
    progress: Progress | None,
    **compute: Any,
) -> StudyFiles:
    """Load the study, then :func:`~cyclomesh.studies.execute.execute` ``kind`` on the
    backend of :func:`_backend` into ``out_dir``."""
    from cyclomesh.studies.execute import execute

    study, _ = load_tolerance_study(study_path)
    with _backend(backend, scheduler, workers) as where:
        result = execute(
            kind,
            study,
            out_dir,
            _options(study, figures, options),
            backend=where,
            parallel=True,
            progress=_fixed(progress),
            **compute,
        )
    return StudyFiles(result, _listed(out_dir))


def _fixed(progress: Progress | None) -> Any:
    """``progress`` as :func:`~cyclomesh.studies.execute.execute` takes it."""
    from contextlib import nullcontext

    return lambda: nullcontext(progress or (lambda n: None))


def _listed(out: str | Path) -> list[Path]:
    """The files the completion marker of ``out`` vouches for."""
    from cyclomesh.output.folder import load_results

    return list(load_results(out).files)
