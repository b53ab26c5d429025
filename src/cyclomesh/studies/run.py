"""Run studies: every case of a study file through its crank angles (``cyclomesh run``).

Stages (see ``docs/pipeline.md``):

1. :func:`compute_run`: analyse every case (:func:`cyclomesh.analyse`) with the core
   inputs built once when the study was loaded; nothing is written.
2. :func:`write_run`: per case ``<case>/results.nc`` (NetCDF), ``<case>/results.parquet``
   (pin-level, long format), ``<case>/angles.csv`` (per crank angle) and, with
   ``csv=True``, ``<case>/results.csv`` (pin-level, long format); ``summary.json``.
3. :func:`run_figures` (:mod:`cyclomesh.studies.run_figures`): the figure jobs;
   :func:`run_sections`: the report sections.

:data:`RUN` is the kind that :func:`cyclomesh.studies.execute.execute` runs.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.publish.pipeline import case_attrs, summary_document
from cyclomesh.publish.report import (
    metrics_table,
    table_cell,
    warning_sections,
)
from cyclomesh.quantities import QUANTITIES
from cyclomesh.results.efficiency import EFFICIENCY_METRICS
from cyclomesh.results.frame import Frame, Var, as_xarray
from cyclomesh.results.metrics import DRIVE_METRICS, METRICS, STAGE_METRICS, STIFFNESS_METRICS
from cyclomesh.studies.execute import CommandSteps, StudyKind
from cyclomesh.studies.preflight import refuse_friction_with_stage
from cyclomesh.studies.run_figures import (  # split from here: old paths work
    input_figures,
    overview_figures,
    run_figures,
)
from cyclomesh.studyfile.schema import CaseInputs, CaseSpec, Study, folder_name

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.publish.pipeline import OutputOptions
    from cyclomesh.publish.report import Section

__all__ = [
    "RunResult",
    "compute_run",
    "annotate",
    "summary_record",
    "write_case",
    "write_run",
    "input_figures",
    "run_figures",
    "overview_figures",
    "run_sections",
    "case_folder",
]

Hook = Callable[[str], None]


@dataclass
class RunResult:
    """The computed results of a run study, in memory."""

    study: Study
    frames: dict[str, Frame | xr.Dataset] = field(default_factory=dict)
    """Case name → annotated results of :func:`cyclomesh.results.dataset.analyse_frame`:
    a :class:`~cyclomesh.results.frame.Frame` (no xarray), or a Dataset for a case with
    a ``[stage]`` or ``[friction]`` (whose post-processing is xarray's)."""
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → metrics of :data:`cyclomesh.results.metrics.METRICS` (plain JSON numbers)."""
    checks: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → requirement checks and design warnings (:mod:`cyclomesh.studies.checks`)."""
    warnings: dict[str, list[str]] = field(default_factory=dict)
    """Case name → warnings (:mod:`cyclomesh.studyfile.warnings`)."""

    @property
    def results(self) -> dict[str, xr.Dataset]:
        """Case name → annotated Dataset of :func:`cyclomesh.analyse` (the frames as
        :class:`xarray.Dataset`, converted once when first asked for)."""
        converted = self.__dict__.setdefault("_datasets", {})
        for name, ds in self.frames.items():
            if name not in converted or converted[name][0] is not ds:
                converted[name] = (ds, as_xarray(ds))
        return {name: converted[name][1] for name in self.frames}

    def study_warnings(self) -> list[str]:
        """The warnings of the study, each once (prefixed by the case where not all)."""
        from cyclomesh.studyfile.warnings import merge_warnings

        return merge_warnings(self.warnings)

    @property
    def inputs(self) -> list[CaseInputs]:
        """Core inputs of the cases (built once when the study was loaded)."""
        return self.study.inputs


def annotate(ds: Frame, case: CaseSpec, inputs: CaseInputs, study: Study) -> Frame:
    """Add the case's per-pin errors [µm, µrad] and its inputs (attributes) to ``ds``."""
    errors = inputs.errors_um
    out = ds.assign(
        {
            name: Var("pin", errors[key], {"units": q.unit, "long_name": q.long_name})
            for name, key in (
                ("pin_radial_error", "radial_um"),
                ("pin_angular_error", "angular_urad"),
                ("pin_radius_error", "pin_radius_um"),
            )
            for q in (QUANTITIES[name],)
        }
    )
    out.attrs.update(case_attrs(study, case))
    return out


def summary_record(summary: xr.Dataset | Frame) -> dict[str, Any]:
    """The metrics of :func:`cyclomesh.summarize` as plain JSON values (non-finite → None).

    A summary with a ``torque`` dimension (a list of torques) gives ``torque_nm`` and,
    for every metric that depends on the torque, a list with one value per torque.
    """
    from cyclomesh.output.writers import jsonable

    record: dict[str, Any] = {}
    if "torque" in summary.dims:
        record["torque_nm"] = jsonable(summary["torque"].values)
    for name in (*METRICS, *DRIVE_METRICS):
        if name in summary:
            value = jsonable(
                summary[name].values if summary[name].ndim else summary[name].values[()]
            )
            if name.startswith("contacts_"):
                value = (
                    [int(round(v)) for v in value]
                    if isinstance(value, list)
                    else (int(round(value)) if isinstance(value, float) else value)
                )
            record[name] = value
    if "gear_ratio_step_deg" in summary.attrs:  # the step the ratio ripple was taken over
        record["gear_ratio_step_deg"] = jsonable(summary.attrs["gear_ratio_step_deg"])
    return record


def compute_run(
    study: Study,
    on_start: Hook | None = None,
    on_done: Hook | None = None,
    *,
    backend: Any = None,
    progress: Callable[[int], None] | None = None,
) -> RunResult:
    """Analyse every case of ``study`` (nothing is written).

    ``on_start(name)`` and ``on_done(name)`` are called around each case, ``progress(1)``
    after each. The cases run in this process (one vectorised core call each), so
    ``backend`` is not used; it is there for the one signature of every kind.
    """
    from cyclomesh.exceptions import CyclomeshError
    from cyclomesh.results.dataset import analyse_frame, summary_frame
    from cyclomesh.studies.checks import case_checks, case_warnings
    from cyclomesh.studyfile.usage import check_keys

    check_keys(study.raw, "run")
    run = RunResult(study=study)
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        if on_start:
            on_start(case.name)
        kwargs = inputs.kwargs()
        kwargs.pop("crank_angles")
        try:
            ds = analyse_frame(**kwargs, crank_angles_deg=case.analysis.crank_angles_deg())
        except CyclomeshError as exc:  # name the case
            raise type(exc)(f"{case.label}: {exc}") from None
        ds = annotate(ds, case, inputs, study)
        if inputs.stage is not None or "power_loss" in ds:  # post-processed with xarray
            ds = ds.to_xarray()
        sheet = None
        if inputs.stage is not None:
            try:
                ds, sheet = _with_stage(ds, case, inputs)
            except CyclomeshError as exc:  # name the case
                raise type(exc)(f"{case.label}: {exc}") from None
        run.summaries[case.name] = summary_record(summary_frame(ds))
        run.summaries[case.name].update(efficiency_summary(ds, case))
        if sheet is not None:
            run.summaries[case.name].update(sheet)
        run.frames[case.name] = ds
        run.warnings[case.name] = case_warnings(
            case, inputs, ds, _zero_friction(case, inputs), _support_range(sheet)
        )
        run.checks[case.name] = case_checks(study, case, inputs, run.summaries[case.name], ds)
        if on_done:
            on_done(case.name)
        if progress:
            progress(1)
    return run


def _support_range(sheet: dict[str, Any] | None) -> str | None:
    """The support bearings' radial load at rated torque beyond the range of their tangent
    stiffness from the preload (:meth:`~cyclomesh.stage.bearing.TaperedRollerBearing.
    linear_limit`), or None."""
    if sheet is None or "stage_support_bearing_linear_limit_n" not in sheet:
        return None
    load = sheet["stage_max_support_bearing_load_n"]
    limit = sheet["stage_support_bearing_linear_limit_n"]
    if load <= limit:
        return None
    return (
        f"stage.crankshaft.support_bearing: a support bearing carries {load:.4g} N at rated "
        f"torque, beyond the {limit:.4g} N up to which its stiffness from the preload holds "
        "(a roller unloads); raise preload_n, or give support_bearing_stiffness_n_per_um"
    )


def _zero_friction(case: Any, inputs: Any) -> str | None:
    """A ``[friction]`` whose coefficients are all 0 is the frictionless model: say so,
    as the efficiency and the losses it would give (1 and 0) are not reported."""
    if case.friction is None or inputs.friction is not None:
        return None
    return (
        "friction: every coefficient of [friction] is 0, the frictionless model (the "
        "paper's assumption 3: efficiency 1, no loss), so no efficiency or loss is "
        "reported; give mesh_coefficient > 0 for friction"
    )


def efficiency_summary(ds: xr.Dataset | Frame, case: CaseSpec) -> dict[str, Any]:
    """The friction numbers of a case (:func:`cyclomesh.results.efficiency.efficiency_record`),
    or with no friction the input speed alone."""
    from cyclomesh.results.efficiency import efficiency_record

    record = efficiency_record(ds) if "power_loss" in ds else {}
    return record | {"input_speed_rpm": case.load.speed_rpm(case.design.pins - 1)}


def _with_stage(ds: xr.Dataset, case: CaseSpec, inputs: CaseInputs) -> tuple[xr.Dataset, dict]:
    """The case's Dataset with the RV stage's variables, and its data sheet (``[stage]``)."""
    from cyclomesh.results.stage import data_sheet, solve_case, stage_dataset, stage_mesh

    result = solve_case(inputs)
    # the reported mesh (summary, verdict, figures) is the stage's, not the rigid bearings'
    ds = stage_mesh(ds, result, inputs.design.teeth)
    if result.friction is not None:  # and so are the efficiency and the losses
        from cyclomesh.results.efficiency import friction_attrs
        from cyclomesh.results.stage import stage_efficiency_variables

        variables = stage_efficiency_variables(
            inputs, result, "torque" in ds.dims, ds.sizes.get("disc", 1)
        )
        ds = ds.assign(
            {name: (dims, values, attrs) for name, (dims, values, attrs) in variables.items()}
        )
        ds.attrs.update(friction_attrs(inputs.friction))  # the mesh alone may have had none
    stage = stage_dataset(result, inputs.stage, inputs.design.pins)
    if "disc" not in ds.dims:  # one disc: no disc dimension, as the mesh variables
        stage = stage.isel(disc=0, drop=True)
    # the same angles (and torques) as the mesh's, bit for bit: no alignment
    stage = stage.assign_coords(crank_angle=ds["crank_angle"])
    if "torque" in stage.dims:
        stage = stage.assign_coords(torque=ds["torque"])
    rated = case.stage.rated_torque_nm
    if rated is None:
        torques = np.atleast_1d(np.asarray(inputs.torque, float))
        rated = float(np.max(np.abs(torques)))
    merged = ds.assign({name: stage[name] for name in stage.data_vars}).assign_coords(
        crank=stage["crank"]
    )
    merged.attrs.update(stage.attrs)
    return merged, data_sheet(inputs, rated)


def case_folder(name: str) -> str:
    """Folder of a case's files inside the output folder."""
    return folder_name(name)


def write_case(ds: xr.Dataset | Frame, folder: Path, csv: bool = False) -> dict[str, Path]:
    """Write one case: ``results.nc``, ``results.parquet``, ``angles.csv`` and, with
    ``csv``, ``results.csv`` (see :mod:`cyclomesh.output.writers`)."""
    from cyclomesh.output import writers as output

    folder.mkdir(parents=True, exist_ok=True)
    files = {"netcdf": output.write_netcdf(ds, folder / "results.nc")}
    # the stage's per-crank variables live in results.nc only (the tables are pin-level)
    ds = ds.drop_vars([n for n, v in ds.data_vars.items() if "crank" in v.dims], errors="ignore")
    if "crank" in ds.coords:
        ds = ds.drop_vars("crank")
    files["parquet"] = output.write_parquet(ds, folder / "results.parquet")
    files["angles_csv"] = output.write_angle_csv(ds, folder / "angles.csv")
    if csv:
        files["csv"] = output.write_pin_csv(ds, folder / "results.csv")
    return files


def write_run(run: RunResult, out: Path, options: OutputOptions) -> list[Path]:
    """Write every case's result files and ``summary.json`` into ``out``."""
    from cyclomesh.output.writers import write_json

    study = run.study
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    records = []
    for case in study.cases:
        folder = case_folder(case.name)
        written += write_case(run.frames[case.name], out / folder, options.csv).values()
        records.append(
            {
                "name": case.name,
                "results": f"{folder}/results.nc",
                **run.summaries[case.name],
                "checks": run.checks[case.name],
                "warnings": run.warnings.get(case.name, []),
            }
        )
    units = {
        name: m.unit
        for name, m in (METRICS | DRIVE_METRICS | STAGE_METRICS | EFFICIENCY_METRICS).items()
    }
    document = summary_document(study, units, records, warnings=run.study_warnings())
    written.append(write_json(out / "summary.json", document))
    return written


def _flat(prefix: str, value: Any) -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flat(f"{prefix}.{key}" if prefix else key, item))
        return out
    if isinstance(value, list):
        values = np.asarray(value, dtype=float)
        text = f"{len(values)} values, {values.min():.4g} … {values.max():.4g}"
        return {prefix: text}
    return {prefix: value}


def _play_in_arcmin(record: dict[str, Any]) -> dict[str, Any]:
    """The record with its play in arcmin (``play_arcmin_*``), the unit of the terminal,
    the verdict and ``cyclomesh stiffness``; summary.json keeps ``play_arcsec_*``."""

    def arcmin(value: Any) -> Any:
        if isinstance(value, list):
            return [arcmin(v) for v in value]
        return None if value is None else value / 60.0

    return {
        (k.replace("play_arcsec", "play_arcmin") if k.startswith("play_arcsec") else k): (
            arcmin(v) if k.startswith("play_arcsec") else v
        )
        for k, v in record.items()
    }


def run_sections(run: RunResult) -> list[Section]:
    """Report sections of a run study: study, inputs, summary (figures come after)."""
    from cyclomesh.publish.report import Section, table_html

    study = run.study
    names = [case.name for case in study.cases]
    intro = f"<p>{html.escape(study.description)}</p>" if study.description else ""
    intro += table_html(
        ["case", "description", "results"],
        [(c.name, c.description, f"{case_folder(c.name)}/results.nc") for c in study.cases],
    )
    flats = [
        _flat("", case.model_dump(mode="json", exclude={"name", "description"}))
        for case in study.cases
    ]
    for flat, case, inputs in zip(flats, study.cases, study.inputs, strict=True):
        if case.errors.file is not None or case.errors.random is not None:
            for key, values in inputs.errors_um.items():
                flat[f"errors: total {key}"] = _flat("", list(values))[""]
    keys = list(dict.fromkeys(k for flat in flats for k in flat))
    rows = [[k, *(table_cell(f.get(k)) for f in flats)] for k in keys]
    inputs_html = table_html(
        ["key", *names], [r for r in rows if any(v is not None for v in r[1:])]
    )
    inputs_html += (
        "<p>Per-pin errors are the sum of the lists, the file and the random draws. "
        "In the CSV and Parquet files an infinite backlash (pin unreachable by the loaded "
        "flank) is a missing value.</p>"
        f"<details><summary>study file {html.escape(study.path.name)}</summary>"
        f"<pre>{html.escape(study.text)}</pre></details>"
    )
    summary = metrics_table(
        {
            n: _play_in_arcmin(
                {k: v for k, v in run.summaries[n].items() if k not in STAGE_METRICS}
            )
            for n in names
        },
        METRICS | DRIVE_METRICS | STIFFNESS_METRICS | EFFICIENCY_METRICS,
    )
    from cyclomesh.studies.checks import checks_section

    sections = [
        Section("Study", intro),
        checks_section(run.checks),
        Section("Summary", summary),
        Section("Inputs", inputs_html),
    ]
    staged = [n for n in names if any(k in STAGE_METRICS for k in run.summaries[n])]
    if staged:
        keys = [k for k in STAGE_METRICS if any(k in run.summaries[n] for n in staged)]
        sheet = table_html(
            ["", *staged],
            [
                [
                    f"{STAGE_METRICS[k].long_name} [{STAGE_METRICS[k].unit}]",
                    *(table_cell(run.summaries[n].get(k)) for n in staged),
                ]
                for k in keys
            ]
            + [
                [
                    f"compliance share at rated torque: {part.replace('_', ' ')} [%]",
                    *(
                        table_cell(100.0 * run.summaries[n]["compliance_share"][part])
                        if "compliance_share" in run.summaries[n]
                        else table_cell(None)
                        for n in staged
                    ),
                ]
                for part in dict.fromkeys(
                    p for n in staged for p in run.summaries[n].get("compliance_share", {})
                )
            ],
        )
        sheet += (
            "<p>RV stage (docs/stage.md): discs on the crank bearings, mesh, bearings and "
            "springs solved together; rigidity (b/a, 50-100 % of rated), lost motion "
            "(mid-points at ±3 %) and backlash (width at zero torque) by the catalogue's "
            "definitions over at most 360 of the case's crank angles; the compliance shares "
            "split the output twist at rated torque by virtual work; the first stage, the "
            "main bearings and the housing are not modelled.</p>"
        )
        sections.append(Section("Data sheet (RV stage)", sheet))
    return warning_sections(run.study_warnings()) + sections


def _show_run(result: RunResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_run

    print_run(result.summaries, out, result.checks, result.study_warnings())


RUN = StudyKind(
    command="run",
    title="",
    compute=lambda study, **kw: compute_run(study, **kw),
    write=lambda result, out, options: write_run(result, out, options),
    figures=lambda result, early: run_figures(result, early),
    sections=lambda result: run_sections(result),
    early_figures=lambda study: input_figures(study),
    overview=lambda result: overview_figures(result),
    preflight=refuse_friction_with_stage,
    steps=CommandSteps(progress=lambda study, o: (len(study.cases), "cases"), show=_show_run),
)
"""``cyclomesh run`` (:func:`cyclomesh.studies.execute.execute`)."""
