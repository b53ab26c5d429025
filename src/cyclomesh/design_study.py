"""``cyclomesh design``: design maps from a study file's ``[design_space]`` section.

The study's base case fixes the design, the torque, the crank angles, the pin errors and
the unswept part of the modification; ``[design_space]`` gives the swept parameters, the
constraints, the objective and, with ``rings = K``, the number of rings drawn from the
``[tolerance]`` section for a robust map. See ``docs/design-map.md``.

Outputs in the output folder: ``design.nc``, ``summary.json``, ``best.toml``, one figure
per metric (``design_<metric>.png``) and ``report.html``.
"""

from __future__ import annotations

import html
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import xarray as xr
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from cyclomesh.designmap import (
    ARCMIN,
    ARCSEC,
    METRICS,
    PARAMETERS,
    Constraints,
    design_map,
)
from cyclomesh.exceptions import DesignError, StudyError

__all__ = [
    "Range",
    "DesignSpace",
    "parse_design_space",
    "DesignResult",
    "compute_design",
    "best_study",
    "write_design",
    "run_design",
]


class Range(BaseModel):
    """``{ start = , stop = , points = }``: ``numpy.linspace(start, stop, points)``."""

    model_config = ConfigDict(extra="forbid", strict=True)
    start: float
    stop: float
    points: Annotated[int, Field(ge=1, le=1001)]

    @field_validator("start", "stop")
    @classmethod
    def _finite(cls, value: float) -> float:
        if not math.isfinite(value):
            raise ValueError("must be a finite number")
        return value

    def values(self) -> np.ndarray:
        """The grid values, in the unit of the key."""
        return np.linspace(self.start, self.stop, self.points)


class DesignSpace(BaseModel):
    """The validated ``[design_space]`` section (see ``docs/design-map.md``)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    pin_circle_radius_um: Range | None = None
    pin_radius_um: Range | None = None
    rotation_urad: Range | None = None
    max_play_arcmin: float | None = None
    min_play_arcmin: float | None = None
    allowable_contact_stress_mpa: Annotated[float, Field(gt=0)] | None = None
    max_te_pp_arcsec: Annotated[float, Field(gt=0)] | None = None
    min_contacts: Annotated[int, Field(ge=0)] | None = None
    objective: Literal["max_contact_stress", "te_pp", "lost_motion", "play"] = "max_contact_stress"
    rings: Annotated[int, Field(ge=0)] = 0
    lost_motion: bool | None = None

    def axes(self) -> dict[str, np.ndarray]:
        """Swept parameters (study units), in the order of :data:`PARAMETERS`."""
        return {key: getattr(self, key).values() for key in PARAMETERS if getattr(self, key)}

    def constraints(self) -> Constraints:
        """The constraints in SI units."""
        return Constraints(
            max_play=None if self.max_play_arcmin is None else self.max_play_arcmin * ARCMIN,
            min_play=None if self.min_play_arcmin is None else self.min_play_arcmin * ARCMIN,
            allowable_contact_stress=None
            if self.allowable_contact_stress_mpa is None
            else self.allowable_contact_stress_mpa * 1e6,
            max_te_pp=None if self.max_te_pp_arcsec is None else self.max_te_pp_arcsec * ARCSEC,
            min_contacts=self.min_contacts,
        )

    def constraints_dict(self) -> dict[str, Any]:
        """The constraints that are set, in study units."""
        keys = (
            "max_play_arcmin",
            "min_play_arcmin",
            "allowable_contact_stress_mpa",
            "max_te_pp_arcsec",
            "min_contacts",
        )
        return {k: getattr(self, k) for k in keys if getattr(self, k) is not None}


def parse_design_space(raw: Any) -> DesignSpace:
    """Validate a raw ``[design_space]`` table.

    Raises
    ------
    StudyError
        One line naming the dotted key, e.g. ``design_space.pin_radius_um.points: ...``.
    """
    if raw is None:
        raise StudyError("no [design_space] section (see docs/design-map.md)")
    try:
        space = DesignSpace.model_validate(raw)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"] if not str(p).startswith("function-"))
        loc = loc.split(".float")[0].split(".int")[0]
        raise StudyError(f"design_space.{loc}: {err['msg']}") from None
    if not space.axes():
        raise StudyError(
            "design_space: sweep at least one of "
            + ", ".join(f"{key} = {{ start = , stop = , points = }}" for key in PARAMETERS)
        )
    return space


@dataclass(frozen=True)
class DesignResult:
    """A computed design map with its summary and the optimum as a study file."""

    map: xr.Dataset
    summary: dict[str, Any]
    best_toml: str | None
    seconds: float
    base_marks: dict[str, dict[str, float]]


def _study_units(modification: Any, key: str) -> float:
    name, scale, *_ = PARAMETERS[key]
    return float(getattr(modification, name)) / scale


def compute_design(
    study: Any,
    space: DesignSpace,
    *,
    backend: Any = None,
    chunk: int | None = None,
    progress: Any = None,
) -> DesignResult:
    """Compute the design map of a study's base case (see module doc).

    Parameters
    ----------
    study : cyclomesh.study.config.Study
    space : DesignSpace
    backend : execution backend, optional
        Where the candidates run (default: this process).
    """
    start = time.perf_counter()
    base = study.base.to_core()
    errors = base.errors
    if space.rings:
        from cyclomesh.tolerance.runner import ring_model
        from cyclomesh.tolerance.spec import parse_tolerance

        if study.tolerance is None:
            raise StudyError(
                "design_space.rings: a robust map needs a [tolerance] section to draw rings"
            )
        model = ring_model(study, parse_tolerance(study.tolerance))
        errors = model.pin_errors(model.draw(np.arange(space.rings)))
    try:
        ds = design_map(
            base.design,
            space.axes(),
            base=base.modification,
            errors=errors,
            torque=base.torque,
            crank_angles_deg=study.base.analysis.crank_angles_deg(),
            groove_deformation=base.groove_deformation,
            constraints=space.constraints(),
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
    marks = {"base case": {key: _study_units(base.modification, key) for key in space.axes()}}
    summary = _summary(ds, space)
    best = best_study(study, ds) if summary["optimum"] is not None else None
    return DesignResult(ds, summary, best, time.perf_counter() - start, marks)


def _summary(ds: xr.Dataset, space: DesignSpace) -> dict[str, Any]:
    dims = list(ds["feasible"].dims)
    optimum = None
    if all(f"optimum_{d}" in ds.attrs for d in dims):
        where = {d: float(ds.attrs[f"optimum_{d}"]) for d in dims}
        cell = ds.sel(where)
        metrics = {}
        for var, *_ in METRICS.values():
            if var in ds:
                metrics[var] = float(cell[var])
        optimum = {"parameters": where, "metrics": metrics}
    return {
        "title": ds.attrs.get("study_title"),
        "objective": space.objective,
        "objective_variable": ds.attrs["objective_variable"],
        "robust": bool(ds.attrs["robust"]),
        "rings": int(ds.attrs["rings"]) if ds.attrs["robust"] else 0,
        "robust_percentile": ds.attrs["robust_percentile"],
        "candidates": int(ds.attrs["candidates"]),
        "feasible_candidates": int(ds.attrs["feasible_candidates"]),
        "failed_candidates": int(np.sum(~np.isin(ds["reason"].values, ["", *_violations(ds)]))),
        "parameters": {d: ds[d].values.tolist() for d in dims},
        "constraints": space.constraints_dict(),
        "optimum": optimum,
    }


def _violations(ds: xr.Dataset) -> list[str]:
    return sorted({r for r in np.unique(ds["reason"].values) if str(r).endswith(" violated")})


def best_study(study: Any, ds: xr.Dataset) -> str:
    """The study file (TOML) of the optimum: the base case with the optimum modification.

    ``cyclomesh run best.toml`` reruns it; file names inside are made absolute.
    """
    from cyclomesh.tolerance.output import toml_dumps

    base = study.base.model_dump()
    sections: dict[str, Any] = {"title": f"{study.title}: optimum of the design map"}
    for name in ("design", "modification", "material", "load", "errors", "analysis"):
        table = _drop_none(base.get(name) or {})
        if table:
            sections[name] = table
    modification = sections.setdefault("modification", {})
    for d in ds["feasible"].dims:
        modification[d] = float(ds.attrs[f"optimum_{d}"])
    folder = study.path.parent.resolve()
    if modification.get("profile_file"):
        modification["profile_file"] = str(folder / modification["profile_file"])
    errors = sections.get("errors", {})
    if errors.get("file"):
        errors["file"] = str(folder / errors["file"])
    if study.tolerance is not None and ds.attrs["robust"]:
        sections["tolerance"] = study.tolerance
    note = (
        f"Optimum of the design map of {study.title!r} ({study.path.name}), objective "
        f"{ds.attrs['objective']}"
        + (f", robust over {ds.attrs['rings']} rings" if ds.attrs["robust"] else "")
        + ".\nRerun with: cyclomesh run best.toml --out DIR"
    )
    return "".join(f"# {line}\n" for line in note.splitlines()) + toml_dumps(sections) + "\n"


def _drop_none(table: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in table.items():
        if value is None:
            continue
        if isinstance(value, dict):
            value = _drop_none(value)
            if not value:
                continue
        out[key] = value
    return out


def design_figures(result: DesignResult) -> dict[str, tuple[Any, str]]:
    """One figure per metric: {file stem: (Figure, caption)}."""
    from cyclomesh.design_figures import map_metrics, plot_design_map

    ds = result.map
    out = {}
    for metric in map_metrics(ds):
        caption = (
            f"{ds[metric].attrs['long_name']} [{ds[metric].attrs['units']}]"
            + (
                f", {ds.attrs['robust_percentile']:g}th-percentile value over {ds.attrs['rings']} "
                "rings"
                if ds.attrs["robust"]
                else ""
            )
            + "; hatched: infeasible; star: optimum; cross: the study's own modification"
        )
        out[f"design_{metric}"] = (plot_design_map(ds, metric, result.base_marks), caption)
    return out


def design_section(result: DesignResult, figures: list[tuple[Any, str]]) -> Any:
    """The report section of a design map."""
    from cyclomesh.report import Section, table_html

    s = result.summary
    rows = [
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
    text = (
        "<p>Every candidate modification analysed with the full model at the study's torque "
        "over its crank angles"
        + (
            ", each metric the robust value over the rings (see docs/design-map.md)"
            if s["robust"]
            else ""
        )
        + ". <code>best.toml</code> is the optimum as a study file.</p>"
    )
    return Section(
        f"Design map: {html.escape(str(s['title']))}",
        text + table_html(["", "value"], rows),
        figures,
    )


def write_design(result: DesignResult, out: Path, figures: bool = True) -> dict[str, Path]:
    """Write ``design.nc``, ``summary.json``, ``best.toml``, figures and ``report.html``."""
    from cyclomesh.report import write_report

    out.mkdir(parents=True, exist_ok=True)
    files = {"map": out / "design.nc", "summary": out / "summary.json"}
    result.map.to_netcdf(files["map"])
    summary = dict(result.summary, seconds=result.seconds)
    files["summary"].write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    if result.best_toml is not None:
        files["best"] = out / "best.toml"
        files["best"].write_text(result.best_toml, encoding="utf-8")
    shown = []
    if figures:
        for stem, (fig, caption) in design_figures(result).items():
            path = out / f"{stem}.png"
            fig.savefig(path, dpi=110)
            files[stem] = path
            shown.append((fig, caption))
    section = design_section(result, shown)
    files["report"] = write_report(
        out / "report.html",
        f"{result.summary['title']}: design map",
        [section],
        {"SHA-256 of the study file": str(result.map.attrs.get("study_sha256", ""))},
    )
    return files


def run_design(
    study_path: str | Path,
    out_dir: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    quiet: bool = True,
    figures: bool = True,
) -> tuple[DesignResult, dict[str, Path]]:
    """Load a study, compute its design map (serially for a nominal map, on local
    processes or a Dask cluster for a robust one, or when asked), write the outputs."""
    from cyclomesh.study.config import load_study

    study = load_study(study_path)
    space = parse_design_space(study.design_space)
    backend = None
    if scheduler or workers not in (None, 1) or (space.rings and workers != 1):
        from cyclomesh.tolerance.engine import make_backend

        backend = make_backend(scheduler, workers)
    try:
        result = compute_design(study, space, backend=backend, chunk=1 if backend else None)
    finally:
        if backend is not None:
            backend.close()
    return result, write_design(result, Path(out_dir), figures)


def design(
    study: Annotated[
        Path,
        typer_argument("Study file (TOML) with a [design_space] section."),
    ],
    out: Annotated[Path, typer_option("--out", "-o", help="Output folder (created if needed).")],
    scheduler: Annotated[
        str | None,
        typer_option(
            "--scheduler",
            help="Dask scheduler address (tcp://HOST:PORT); default: local processes for a "
            "robust map, this process for a nominal one.",
        ),
    ] = None,
    workers: Annotated[
        int | None, typer_option("--workers", help="Local worker processes (default: all cores).")
    ] = None,
    quiet: Annotated[bool, typer_option("--quiet", "-q", help="No summary.")] = False,
) -> None:
    """Design map: sweep the modification, map the metrics, mark the optimum."""
    import typer

    result, files = run_design(study, out, scheduler=scheduler, workers=workers, quiet=quiet)
    if not quiet:
        s = result.summary
        typer.echo(
            f"{s['candidates']} candidates, {s['feasible_candidates']} feasible, "
            f"{s['failed_candidates']} failed; {result.seconds:.1f} s"
        )
        if s["optimum"] is None:
            typer.echo("no feasible candidate: relax the constraints or widen the ranges")
        else:
            where = ", ".join(f"{k} = {v:g}" for k, v in s["optimum"]["parameters"].items())
            value = s["optimum"]["metrics"][s["objective_variable"]]
            typer.echo(f"optimum: {where} ({s['objective_variable']} = {value:.6g})")
        typer.echo(f"report: {files['report']}")


def typer_argument(help: str) -> Any:
    import typer

    return typer.Argument(help=help, metavar="STUDY.toml")


def typer_option(*names: str, help: str) -> Any:
    import typer

    return typer.Option(*names, help=help, show_default=False)


def register(app: Any) -> None:
    """Add ``design`` to the Typer ``app`` with the CLI's error handling."""
    from cyclomesh.cli import cli_errors

    app.command("design")(cli_errors()(design))
