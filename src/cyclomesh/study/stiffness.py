"""``cyclomesh stiffness``: the torsion curve of every case of a study.

For each case, the ``[stiffness]`` section gives ``rated_torque_nm`` (required),
``points`` (default 41) and ``series_stiffness_nm_per_arcmin`` (optional); the crank
angles come from ``[analysis]``. :func:`run_stiffness` first checks every case, then
computes every torsion curve (:func:`cyclomesh.torsion.stiffness`), draws the figures,
and only then writes::

    summary.json                  title, study hash, one record per case (docs/drive.md)
    report.html                   inputs, summary, torsion curves, rigidity, play, split
    <case folder>/stiffness.nc    the torsion curve with the study inputs as attributes
    figures/<name>.png|.svg       the figures of the report

The numbers are those of the cycloid-pin mesh alone; the whole-drive curve (with the
series stiffness) is reported beside it. See ``docs/drive.md``.
"""

from __future__ import annotations

import html
import io
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import xarray as xr

from cyclomesh.exceptions import StudyError
from cyclomesh.study.config import CaseInputs, CaseSpec, Study
from cyclomesh.study.results import _number, case_folder, write_summary

__all__ = [
    "STIFFNESS_KEYS",
    "StiffnessRun",
    "compute_stiffness",
    "stiffness_figures",
    "write_stiffness",
    "run_stiffness",
]

Hook = Callable[[str], None]

STIFFNESS_KEYS = (
    "play_arcmin_mean",
    "play_arcmin_max",
    "lost_motion_arcmin_mean",
    "lost_motion_arcmin_max",
    "torsional_rigidity_nm_per_arcmin_mean",
    "torsional_rigidity_nm_per_arcmin_min",
)
"""Keys of a case's record in ``summary.json`` (plus ``drive_…`` with a series stiffness)."""

CAVEAT = (
    "These are the characteristics of the cycloid-pin mesh alone. A whole RV reducer is "
    "much softer: crank bearings, crankshafts and the first stage add compliance in series "
    "(RV catalogues quote about 113 N·m/arcmin for a reducer of the size of the Table 1 "
    "pair, RV-42N, rated 412 N·m, lost motion < 1 arcmin). Do not compare the mesh "
    "rigidity with a catalogue figure; [stiffness] series_stiffness_nm_per_arcmin adds "
    "the rest of the drive as a linear spring in series, reported beside the mesh."
)


@dataclass
class StiffnessRun:
    """The computed torsion curves of a study, in memory."""

    study: Study
    inputs: list[CaseInputs]
    results: dict[str, xr.Dataset] = field(default_factory=dict)
    """Case name → Dataset of :func:`cyclomesh.torsion.stiffness` with the case inputs."""
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → record of :func:`cyclomesh.torsion.summarize_stiffness` (JSON numbers)."""


def _section(case: CaseSpec):
    if case.stiffness is None:
        raise StudyError(
            f"{case.label}: no [stiffness] section: give at least stiffness.rated_torque_nm "
            "(see examples/stiffness.toml)"
        )
    return case.stiffness


def compute_stiffness(
    study: Study, on_start: Hook | None = None, on_done: Hook | None = None
) -> StiffnessRun:
    """Check every case, then compute the torsion curve of each (nothing is written)."""
    from cyclomesh.torsion import stiffness, summarize_stiffness

    for case in study.cases:
        _section(case)
    run = StiffnessRun(study=study, inputs=study.to_core())
    for case, inputs in zip(study.cases, run.inputs, strict=True):
        section = _section(case)
        if on_start:
            on_start(case.name)
        ds = stiffness(
            inputs.design,
            inputs.modification,
            inputs.errors,
            section.rated_torque_nm,
            section.points,
            groove_deformation=inputs.groove_deformation,
            crank_angles_deg=case.analysis.crank_angles_deg(),
            discs=inputs.discs,
            series_stiffness_nm_per_arcmin=section.series_stiffness_nm_per_arcmin,
        )
        ds.attrs.update(
            case_name=case.name,
            case_description=case.description,
            case_inputs_json=json.dumps(case.model_dump(mode="json"), ensure_ascii=False),
            study_title=study.title,
            study_file=study.path.name,
            study_sha256=study.sha256,
        )
        run.results[case.name] = ds
        summary = summarize_stiffness(ds)
        record = {"rated_torque_nm": section.rated_torque_nm, "discs": inputs.discs}
        for key in summary.data_vars:
            record[str(key)] = _number(summary[key].values)
        run.summaries[case.name] = record
        if on_done:
            on_done(case.name)
    return run


def stiffness_figures(run: StiffnessRun) -> dict[str, tuple[Any, str]]:
    """The figures of a stiffness study: name → (Figure, caption)."""
    from cyclomesh import drive_figures

    results = run.results
    out: dict[str, tuple[Any, str]] = {
        "torsion_curve": (
            drive_figures.plot_torsion_curve(results),
            "Torsion curve: rotation of the disc (stack) from its theoretical position "
            "against torque in % of rated; band: range over the crank angles, line: mean; "
            "arrow: lost motion between -3 % and +3 %; dotted: rigidity secants 50-100 %. "
            "Right: the whole drive with the series stiffness, if given.",
        ),
        "torsional_rigidity": (
            drive_figures.plot_rigidity(results),
            "Torsional rigidity over the crank angle (secant between 50 % and 100 % of "
            "rated, mean of both directions).",
        ),
        "play": (
            drive_figures.plot_play(results),
            "Play at zero load and lost motion (±3 % of rated) over the crank angle.",
        ),
    }
    stacks = {name: ds for name, ds in results.items() if "torque_share" in ds}
    if stacks:
        out["torque_share"] = (
            drive_figures.plot_torque_share(stacks),
            "Split of the rated torque between the discs of a stack over the revolution.",
        )
    return out


_HEADINGS = {
    "torsion_curve": "Torsion curve",
    "torsional_rigidity": "Torsional rigidity",
    "play": "Play and lost motion",
    "torque_share": "Torque split between the discs",
}


def _sections(run: StiffnessRun, figs: dict[str, tuple[Any, str]], files: list[str]) -> list:
    from cyclomesh.report import Section, table_html

    study = run.study
    intro = f"<p>{html.escape(study.description)}</p>" if study.description else ""
    intro += f"<p><strong>{html.escape(CAVEAT)}</strong></p>"
    intro += (
        "<p>play = TE of the reverse-flank rest position − TE of the forward-flank rest "
        "position (zero load); lost motion = TE(−3 % T_r) − TE(+3 % T_r); torsional "
        "rigidity = mean over both directions of 0.5·T_r/|TE(±T_r) − TE(±0.5·T_r)|.</p>"
    )
    rows = []
    for case, inputs in zip(study.cases, run.inputs, strict=True):
        section = _section(case)
        rows.append(
            (
                case.name,
                case.description,
                section.rated_torque_nm,
                inputs.discs,
                run.results[case.name].sizes["torque"],
                run.results[case.name].sizes["crank_angle"],
                section.series_stiffness_nm_per_arcmin,
                f"{case_folder(case.name)}/stiffness.nc",
            )
        )
    intro += table_html(
        [
            "case",
            "description",
            "rated torque [N·m]",
            "discs",
            "torques",
            "crank angles",
            "series stiffness [N·m/arcmin]",
            "results",
        ],
        rows,
    )
    intro += (
        f"<details><summary>study file {html.escape(study.path.name)}</summary>"
        f"<pre>{html.escape(study.text)}</pre></details>"
    )
    names = [case.name for case in study.cases]
    columns = list(dict.fromkeys(k for n in names for k in run.summaries[n]))
    summary = table_html(
        ["case", *columns], [[n, *(run.summaries[n].get(c) for c in columns)] for n in names]
    )
    sections = [Section("Study", intro), Section("Summary", summary)]
    sections += [Section(_HEADINGS.get(name, name), "", [fig]) for name, fig in figs.items()]
    listing = "".join(f"<li><code>{html.escape(f)}</code></li>" for f in files)
    sections.append(Section("Files", f"<ul>{listing}</ul>"))
    return sections


def write_stiffness(
    run: StiffnessRun, out: Path, figs: dict[str, tuple[Any, str]] | None = None
) -> list[Path]:
    """Write the torsion curves, figures, summary and report of ``run`` into ``out``."""
    from cyclomesh.report import cyclomesh_version, write_report

    study = run.study
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    records = []
    for case in study.cases:
        folder = out / case_folder(case.name)
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "stiffness.nc"
        run.results[case.name].to_netcdf(path)
        written.append(path)
        records.append(
            (case.name, f"{case_folder(case.name)}/stiffness.nc", run.summaries[case.name])
        )
    images: dict[str, tuple[Any, str]] = {}
    if figs:
        (out / "figures").mkdir(exist_ok=True)
        for name, (fig, caption) in figs.items():
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png", dpi=study.figures.dpi)
            images[name] = (buffer.getvalue(), caption)
            for fmt in study.figures.formats:
                path = out / "figures" / f"{name}.{fmt}"
                if fmt == "png":
                    path.write_bytes(images[name][0])
                else:
                    fig.savefig(path, format=fmt, dpi=study.figures.dpi)
                written.append(path)
    written.append(
        write_summary(
            out / "summary.json",
            study.title,
            records,
            {
                "study_file": study.path.name,
                "study_sha256": study.sha256,
                "cyclomesh_version": cyclomesh_version(),
                "scope": "cycloid-pin mesh only; drive_* numbers add the series stiffness",
            },
        )
    )
    files = [p.relative_to(out).as_posix() for p in written] + ["report.html"]
    stamp = {"study file": study.path.name, "SHA-256 of the study file": study.sha256}
    title = f"{study.title}: torsion curve"
    written.append(write_report(out / "report.html", title, _sections(run, images, files), stamp))
    return written


def run_stiffness(
    study: Study,
    out: str | Path,
    on_start: Hook | None = None,
    on_done: Hook | None = None,
) -> list[Path]:
    """Compute, draw and write the torsion curve of every case; nothing is written on error."""
    run = compute_stiffness(study, on_start, on_done)
    figs = stiffness_figures(run) if study.figures.enabled else {}
    return write_stiffness(run, Path(out), figs)
