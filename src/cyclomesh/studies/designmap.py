"""Design maps (``cyclomesh design``): a study's ``[design_space]`` on the one pipeline.

The study's base description (its top-level sections; ``[[cases]]`` are refused) fixes
the design and its stack of discs, the torque of the stack, the crank angles
(``[analysis]``; for a robust map ``[tolerance]``'s keys over ``[analysis]``'s, the rule of
the tolerance studies), the pin errors and the unswept part of the modification
(including a ``profile_file``); ``[design_space]``
(:class:`~cyclomesh.studyfile.schema.DesignSpaceSection`) gives the swept parameters, the
constraints, the objective and, with ``rings = K``, the number of rings drawn from
``[tolerance]`` for a robust map. Stages (see ``docs/pipeline.md``):

1. :func:`compute_design` analyses every candidate (:mod:`cyclomesh.designspace.sweep`), in
   chunks through :mod:`cyclomesh.execution.backends` when a backend is given (local processes
   or a Dask cluster, bit-for-bit the same);
2. :func:`write_design` writes ``design.nc`` (one dimension per swept parameter, every
   metric with units, ``feasible``, ``reason``), ``summary.json`` (the optimum, its
   metrics, the number of feasible candidates) and ``best.toml`` (the optimum as a study
   file that ``cyclomesh run`` reruns to the same numbers);
3. :func:`design_figures` (one contour map per metric) and :func:`design_sections`.

See ``docs/design-map.md``. Nothing here prints; progress goes to a callback.
"""

from __future__ import annotations

import html
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.designspace.sweep import (
    GEOMETRY,
    METRICS,
    Constraints,
    parameter_value,
)
from cyclomesh.exceptions import DesignError, StudyError
from cyclomesh.results.dataset import resolve_disc_body
from cyclomesh.studies.execute import CommandSteps, StudyKind
from cyclomesh.studyfile.schema import DesignSpaceSection, Study, load_study
from cyclomesh.units import RAD_PER_ARCMIN, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.execution.backends import Backend
    from cyclomesh.figures.render import FigureJob
    from cyclomesh.publish.report import Section

__all__ = [
    "DesignResult",
    "load_design_study",
    "constraints",
    "compute_design",
    "best_study",
    "write_design",
    "design_figures",
    "design_sections",
]

Progress = Callable[[int], None]
SECTION = "Design map"


def require_design_space(study: Study) -> None:
    """Refuse, in one line, a study without a ``[design_space]`` section."""
    if study.file.design_space is None:
        raise StudyError(
            f"{study.path.name}: no [design_space] section (see docs/design-map.md, "
            "examples/design.toml)"
        )


def load_design_study(path: str | Path) -> tuple[Study, DesignSpaceSection]:
    """Load a study file that must have a ``[design_space]`` section.

    Raises
    ------
    StudyError
        A bad study file, or no ``[design_space]`` section.
    """
    study = load_study(path)
    require_design_space(study)
    _preflight(study)
    return study, study.file.design_space


def constraints(space: DesignSpaceSection) -> Constraints:
    """The constraints of a ``[design_space]`` in SI units."""

    def scaled(value: float | None, scale: float) -> float | None:
        return None if value is None else value * scale

    return Constraints(
        max_play=scaled(space.max_play_arcmin, RAD_PER_ARCMIN),
        min_play=scaled(space.min_play_arcmin, RAD_PER_ARCMIN),
        allowable_contact_stress=scaled(space.allowable_contact_stress_mpa, 1e6),
        max_te_pp=scaled(space.max_te_pp_arcsec, RAD_PER_ARCSEC),
        min_contacts=space.min_contacts,
        max_lost_motion=scaled(space.max_lost_motion_arcmin, RAD_PER_ARCMIN),
        min_efficiency=space.min_efficiency,
        min_stage_l10=scaled(space.min_stage_l10_h, 3600.0),
        min_stage_rigidity=scaled(space.min_stage_rigidity_nm_per_arcmin, 1.0 / RAD_PER_ARCMIN),
        max_stage_lost_motion=scaled(space.max_stage_lost_motion_arcmin, RAD_PER_ARCMIN),
        min_stage_efficiency=space.min_stage_efficiency,
    )


@dataclass(frozen=True)
class DesignResult:
    """A computed design map."""

    study: Study
    space: DesignSpaceSection
    map: xr.Dataset
    summary: dict[str, Any]
    best_toml: str | None
    seconds: float
    marks: dict[str, dict[str, float]]


def compute_design(
    study: Study,
    *,
    backend: Backend | None = None,
    chunk: int | None = None,
    progress: Progress | None = None,
) -> DesignResult:
    """Compute the design map of a study's base case (see the module doc).

    Parameters
    ----------
    study : Study
        With a ``[design_space]`` section.
    backend : Backend, optional
        Where the candidates run (default: this process).
    chunk : int, optional
        Candidates per chunk of work.
    progress : callable, optional
        Called with the number of candidates finished.
    """
    from cyclomesh.studyfile.usage import check_keys

    check_keys(study.raw, "design")  # [stage], [[cases]], ...: refused in one line
    from cyclomesh.designspace.sweep import design_map

    start = time.perf_counter()
    space = study.file.design_space
    if space is None:
        raise StudyError(f"{study.path.name}: no [design_space] section")
    from cyclomesh.studyfile.warnings import has_pin_errors, stage_warning, study_warnings

    base = study.base.to_core()
    _preflight(study)  # before any FE table is built
    if np.ndim(base.torque):
        raise StudyError("load.torque_nm: a design map takes one torque (of the stack), not a list")
    errors = base.errors
    angles = study.base.analysis.crank_angles_deg()
    if space.rings:
        from cyclomesh.studies.tolerance import ring_model

        if study.file.tolerance is None:
            raise StudyError("design_space.rings: a robust map needs a [tolerance] section")
        model = ring_model(study, study.file.tolerance)
        errors = model.pin_errors(model.draw(np.arange(space.rings)))
        angles = model.crank_angles_deg  # [tolerance] keys over [analysis]'s
    warnings = study_warnings(
        base.contact_law,
        angles,
        bool(space.rings) or has_pin_errors(base.errors_um, study.base.errors.eccentricity_um),
        "rings drawn from [tolerance]" if space.rings else "pin errors",
    ) + [w for w in (stage_warning(base),) if w]
    try:
        bodies = map_bodies(study)
        ds = design_map(
            base.design,
            space.axes(),
            base=base.modification,
            errors=errors,
            torque=base.torque,
            crank_angles_deg=angles,
            groove_deformation=base.groove_deformation,
            contact_law=base.contact_law,
            discs=base.discs,
            disc_body=bodies[0],
            constraints=constraints(space),
            friction=base.friction,
            stage=base.stage,
            stage_disc_body=bodies[1],
            objective=space.objective,
            lost_motion=space.lost_motion,
            backend=backend,
            chunk=chunk,
            progress=progress,
        )
    except DesignError as exc:
        raise StudyError(f"design_space: {exc}") from None
    ds.attrs["study_title"] = study.title
    ds.attrs["study_sha256"] = study.sha256
    label = "study's design" if set(space.axes()) & set(GEOMETRY) else "study's modification"
    marks = {
        label: {key: parameter_value(base.design, base.modification, key) for key in space.axes()}
    }
    summary = _summary(ds, space, study.title)
    summary["warnings"] = warnings
    if summary["optimum"] is not None:
        summary["checks"] = _optimum_checks(study, base, summary["optimum"], ds)
    best = best_study(study, ds) if summary["optimum"] is not None else None
    return DesignResult(study, space, ds, summary, best, time.perf_counter() - start, marks)


_AS_SUMMARY = {  # design-map variable -> the summary metric the requirements read
    "max_contact_stress_mpa": "max_contact_stress_mpa",
    "te_pp_arcsec": "te_pp_arcsec",
    "min_contacts": "min_contacts",
    "play_arcmin": "play_arcmin_max",
    "lost_motion_arcmin": "lost_motion_arcmin_max",
    "stage_l10_h_min": "stage_l10_h_min",
    "stage_torsional_rigidity_nm_per_arcmin_min": "stage_torsional_rigidity_nm_per_arcmin_min",
    "stage_lost_motion_arcmin_max": "stage_lost_motion_arcmin_max",
    "stage_efficiency": "stage_efficiency",
}


def _optimum_checks(
    study: Study, base: Any, optimum: dict[str, Any], ds: xr.Dataset
) -> dict[str, Any]:
    """The verdict table of the optimum: its map values against ``[requirements]``, and
    the design warnings of its geometry."""
    from dataclasses import replace

    from cyclomesh.designspace.sweep import parameter
    from cyclomesh.studies.checks import case_checks

    design, modification = base.design, base.modification
    geometry, changes = {}, {}
    for key, value in optimum["parameters"].items():
        field, scale, _, _ = parameter(key)
        if field.startswith("design."):
            geometry[field[len("design.") :]] = value * scale
        else:
            changes[field] = value * scale
    if "pin_radius" in geometry:
        geometry["groove_radius"] = (
            geometry["pin_radius"] + design.groove_radius - design.pin_radius
        )
    inputs = replace(
        base, design=replace(design, **geometry), modification=replace(modification, **changes)
    )
    values = {_AS_SUMMARY[k]: v for k, v in optimum["metrics"].items() if k in _AS_SUMMARY}
    where = (
        f"P{ds.attrs['robust_percentile']:g} over {ds.attrs['rings']} rings"
        if ds.attrs["robust"]
        else ""
    )
    return case_checks(study, study.base, inputs, values, where=where)


def _summary(ds: xr.Dataset, space: DesignSpaceSection, title: str) -> dict[str, Any]:
    dims = list(ds["feasible"].dims)
    optimum = None
    if all(f"optimum_{d}" in ds.attrs for d in dims):
        where = {d: float(ds.attrs[f"optimum_{d}"]) for d in dims}
        cell = ds.sel(where)
        values = {var: float(cell[var]) for var, *_ in METRICS.values() if var in ds}
        optimum = {"parameters": where, "metrics": values}
    reasons = ds["reason"].values
    failed = (reasons != "") & ~np.char.endswith(reasons.astype(str), " violated")
    return {
        "title": title,
        "objective": space.objective,
        "objective_variable": ds.attrs["objective_variable"],
        "robust": bool(ds.attrs["robust"]),
        "rings": int(ds.attrs["rings"]) if ds.attrs["robust"] else 0,
        "robust_percentile": float(ds.attrs["robust_percentile"]),
        "discs": int(ds.attrs["discs"]),
        "torque_nm": float(ds.attrs["torque_nm"]),
        "crank_angles": int(ds.attrs["crank_angles"]),
        "candidates": int(ds.attrs["candidates"]),
        "feasible_candidates": int(ds.attrs["feasible_candidates"]),
        "failed_candidates": int(failed.sum()),
        "parameters": {d: ds[d].values.tolist() for d in dims},
        "constraints": space.constraints_dict(),
        "optimum": optimum,
    }


def best_study(study: Study, ds: xr.Dataset) -> str:
    """The study file (TOML) of the optimum: the base case with the optimum modification.

    ``cyclomesh run best.toml`` reruns it; file names inside are made absolute. A robust
    map keeps the ``[tolerance]`` section (the rings' distributions and seed).
    """
    from cyclomesh.output.writers import toml_dumps

    base = study.base.model_dump()
    sections: dict[str, Any] = {"title": f"{study.title}: optimum of the design map"}
    names = ("design", "modification", "material", "load", "errors", "analysis", "friction")
    for name in (*names, "stage"):
        table = _drop_none(base.get(name) or {})
        if table:
            sections[name] = table
    modification = sections.setdefault("modification", {})
    design = sections["design"]
    for d in ds["feasible"].dims:
        value = float(ds.attrs[f"optimum_{d}"])
        if d in GEOMETRY:
            if d == "pin_radius_mm" and design.get("groove_radius_mm") is not None:
                # the groove moved with the pin in the map: the same clearance
                design["groove_radius_mm"] += value - design["pin_radius_mm"]
            design[d] = value
        else:
            modification[d] = value
    folder = study.path.parent.resolve()
    if modification.get("profile_file"):
        modification["profile_file"] = str(folder / modification["profile_file"])
    errors = sections.get("errors", {})
    if errors.get("file"):
        errors["file"] = str(folder / errors["file"])
    if study.file.tolerance is not None and ds.attrs["robust"]:
        sections["tolerance"] = _drop_none(study.file.tolerance.model_dump())
    note = (
        f"Optimum of the design map of {study.title!r} ({study.path.name}), objective "
        f"{ds.attrs['objective']}"
        + (f", robust over {ds.attrs['rings']} rings" if ds.attrs["robust"] else "")
        + ".\nRerun with: cyclomesh run best.toml --out DIR"
    )
    return "".join(f"# {line}\n" for line in note.splitlines()) + toml_dumps(sections) + "\n"


def _drop_none(table: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in table.items():
        if value is None:
            continue
        if isinstance(value, Mapping):
            value = _drop_none(value)
            if not value:
                continue
        out[key] = value
    return out


def write_design(result: DesignResult, out: Path) -> list[Path]:
    """Write ``design.nc``, ``summary.json`` and (if any candidate is feasible) ``best.toml``."""
    from cyclomesh.output.folder import write_text
    from cyclomesh.output.writers import write_json, write_netcdf

    out.mkdir(parents=True, exist_ok=True)
    files = [
        write_netcdf(result.map, out / "design.nc"),
        write_json(out / "summary.json", dict(result.summary, seconds=result.seconds)),
    ]
    if result.best_toml is not None:
        path = out / "best.toml"
        files.append(write_text(path, result.best_toml))
    return files


def design_figures(result: DesignResult) -> list[FigureJob]:
    """One contour map per metric (a line for one swept parameter)."""
    from cyclomesh.figures import designmap as plots
    from cyclomesh.figures.render import FigureJob

    ds = result.map
    robust = (
        f", {ds.attrs['robust_percentile']:g}th-percentile value over {ds.attrs['rings']} rings"
        if ds.attrs["robust"]
        else ""
    )
    jobs = []
    for metric in plots.map_metrics(ds):
        attrs = ds[metric].attrs
        caption = (
            f"{attrs['long_name']} [{attrs['units']}]{robust}; hatched: infeasible; "
            "star: optimum; cross: the study's own modification."
        )
        keep = [metric, "feasible"]
        jobs.append(
            FigureJob(
                f"design_{metric}",
                plots.plot_design_map,
                (ds[keep], metric, result.marks),
                caption=caption,
                section=SECTION,
            )
        )
    return jobs


def design_sections(result: DesignResult) -> list[Section]:
    """The report section of a design map (figures are attached to it by heading)."""
    from cyclomesh.publish.report import Section, table_html

    s = result.summary
    rows: list[tuple[str, Any]] = [
        ("study", s["title"]),
        ("discs (torque of the stack)", f"{s['discs']} ({s['torque_nm']:g} N·m)"),
        ("objective (minimised)", s["objective_variable"]),
        ("candidates", s["candidates"]),
        ("feasible", s["feasible_candidates"]),
        ("failed (undercut, interference, ...)", s["failed_candidates"]),
        (
            "robust",
            f"{s['rings']} rings, percentile {s['robust_percentile']:g}"
            if s["robust"]
            else "no (nominal)",
        ),
    ]
    rows += [(f"constraint {k}", v) for k, v in s["constraints"].items()]
    if s["optimum"] is None:
        rows.append(("optimum", "none: no candidate is feasible"))
    else:
        rows += [(f"optimum {k}", v) for k, v in s["optimum"]["parameters"].items()]
        rows += [(f"at the optimum: {k}", v) for k, v in s["optimum"]["metrics"].items()]
    from cyclomesh.publish.report import description_html

    text = description_html(result.study) + (
        "<p>Every candidate (modification and geometry) analysed with the full model at "
        "the study's torque over its crank angles"
        + (", each metric its robust value over the rings" if s["robust"] else "")
        + f" ({html.escape('docs/design-map.md')}). <code>best.toml</code> is the optimum "
        "as a study file.</p>"
    )
    from cyclomesh.publish.report import warning_sections

    sections = [Section(SECTION, text + table_html(["", "value"], rows))]
    if s.get("checks"):
        from cyclomesh.studies.checks import checks_section

        sections.insert(0, checks_section({"optimum": s["checks"]}))
    return warning_sections(s.get("warnings", [])) + sections


def map_bodies(study: Study) -> tuple[Any, Any]:
    """The disc bodies (mesh, stage) of a map's candidates: ``"rigid"``; with
    ``disc_body = "fe"`` over the modification the base design's bodies, resolved here
    once (from the cache or built); over swept geometry a builder of each candidate
    geometry's body (:class:`~cyclomesh.fe.influence.GeometryBody`, the FE model's
    settings and the cache folder fixed now), called in the map's workers.

    Raises
    ------
    DesignError
        ``disc_body = "fe"`` without the fe extra.
    """
    base = study.base.to_core()
    if not fe_geometry(study):
        mesh = resolve_disc_body(base.disc_body, base.design, base.modification, base.crank_holes)
        stage = "rigid"
        if base.stage is not None:
            stage = resolve_disc_body(
                base.disc_body, base.design, base.modification, base.crank_holes, stage=True
            )
        return mesh, stage
    from cyclomesh.results.dataset import FE_EXTRA_MESSAGE, fe_extra_available

    if not fe_extra_available():
        raise DesignError(FE_EXTRA_MESSAGE)
    from cyclomesh.fe.influence import GeometryBody

    holes = base.crank_holes
    stage = "rigid" if base.stage is None else GeometryBody.with_defaults(holes, free=True)
    return GeometryBody.with_defaults(holes), stage


def fe_geometry(study: Study) -> bool:
    """Whether the map builds an FE disc body per candidate geometry (``disc_body =
    "fe"`` with a :data:`~cyclomesh.designspace.sweep.GEOMETRY` axis)."""
    swept = set(study.file.design_space.axes()) & set(GEOMETRY)
    return study.base.analysis.disc_body == "fe" and bool(swept)


def fe_notice(study: Study, workers: int = 1) -> str:
    """The one-line notice of a map that builds FE disc bodies per geometry: how many
    bodies (those not in the cache), and roughly how long
    (:data:`~cyclomesh.fe.influence.SECONDS_PER_BODY` each, over ``workers``); "" for
    any other map. Geometries the design or the profile check refuses are not counted
    (their candidates are infeasible before any FE)."""
    if not fe_geometry(study):
        return ""
    from cyclomesh.designspace.sweep import DesignTask, parameter
    from cyclomesh.fe.influence import SECONDS_PER_BODY, GeometryBody

    base = study.base.to_core()
    builders = {"held": GeometryBody.with_defaults(base.crank_holes)}
    if base.stage is not None:
        builders["free"] = GeometryBody.with_defaults(base.crank_holes, free=True)
    axes = {k: v for k, v in study.file.design_space.axes().items() if k in GEOMETRY}
    geometry = DesignTask(  # the map's geometries, made as the map makes them
        base.design,
        base.modification,
        tuple(
            (parameter(k)[0], tuple(float(x) * parameter(k)[1] for x in np.atleast_1d(v)))
            for k, v in axes.items()
        ),
        None,
        1.0,
        (0.0,),
    )
    geometries, missing, seconds = 0, 0, 0.0
    for index in range(geometry.size):
        try:
            design = geometry.candidate(index)[0]
        except DesignError:
            continue
        geometries += 1
        for kind, builder in builders.items():
            if not builder.path(design, base.modification).exists():
                missing += 1
                seconds += SECONDS_PER_BODY[kind]
    total = geometries * len(builders)
    if not geometries:
        return 'disc_body = "fe": no geometry passes the design checks, no FE body to build'
    if not missing:
        return f'disc_body = "fe": {total} FE disc bodies of {geometries} geometries, all cached'
    minutes = seconds / max(workers, 1) / 60.0
    kinds = ", held and free for the stage" if len(builders) > 1 else ""
    return (
        f'disc_body = "fe": {missing} of {total} FE disc bodies to build ({geometries} '
        f"geometries{kinds}), roughly {minutes:.1f} min on {workers} worker(s); "
        "cached for a re-run"
    )


def _preflight(study: Study) -> None:
    """The design map's own refusals before it computes (``cyclomesh check --kind design``
    too): a list of torques, a robust map without ``[tolerance]``."""
    torques = [case.load.torque_nm for case in study.cases]
    if any(isinstance(t, list) for t in torques):
        raise StudyError(
            "load.torque_nm: a design map takes one torque; give a number "
            "(cyclomesh stiffness sweeps torques)"
        )
    if study.file.design_space.rings and study.file.tolerance is None:
        raise StudyError(
            "design_space.rings: a robust map needs a [tolerance] section to draw rings"
        )


def _candidates(study: Study) -> int:
    return math.prod(len(v) for v in study.file.design_space.axes().values())


def _parallel(study: Study, options: Any) -> bool:
    """A nominal map runs in this process unless ``--workers`` or ``--scheduler`` is
    given; a robust map runs on all local cores by default."""
    scheduler, workers = options["scheduler"], options["workers"]
    rings = study.file.design_space.rings
    return bool(scheduler is not None or workers not in (None, 1) or (rings and workers != 1))


def _banner(study: Study, options: Any, workers: int) -> str:
    rings = study.file.design_space.rings
    notice = fe_notice(study, workers)
    return (
        f"design map: {_candidates(study)} candidates"
        + (f" x {rings} rings" if rings else "")
        + f", {workers} worker(s)"
        + (f"\n{notice}" if notice else "")
    )


def _show(result: DesignResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_design

    print_design(result.summary, result.seconds, out)


DESIGN = StudyKind(
    command="design",
    title="design map",
    compute=lambda study, **kw: compute_design(study, **kw),
    write=lambda result, out, options: write_design(result, out),
    figures=lambda result, early: design_figures(result),
    sections=lambda result: design_sections(result),
    keys_first=require_design_space,
    preflight=_preflight,
    steps=CommandSteps(
        load=lambda path, options: load_design_study(path)[0],
        parallel=_parallel,
        banner=_banner,
        progress=lambda study, options: (_candidates(study), "candidates"),
        compute=lambda study, options, backend: {"chunk": 1 if backend else None},
        show=_show,
    ),
)
"""``cyclomesh design`` (:func:`cyclomesh.studies.execute.execute`)."""
