"""Run a study: analyse every case, draw the figures, write files and the report.

:func:`run_study` first checks every case (core objects built), then computes every
case, then draws the figures, and only then writes anything, so a bad input leaves
the output folder untouched. The output folder receives::

    summary.json               title, study hash, one record per case
    report.html                inputs, summary table, figures (self-contained)
    <case folder>/results.nc   the core's Dataset with the study inputs as attributes
    <case folder>/results.csv  the same, long format (see cyclomesh.study.results)
    figures/<name>.png|.svg    the figures of the report
"""

from __future__ import annotations

import html
import io
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from cyclomesh.study.config import CaseInputs, Study
from cyclomesh.study.results import (
    annotate,
    case_folder,
    summary_record,
    write_case,
    write_summary,
)

__all__ = ["StudyRun", "compute_study", "study_figures", "write_study", "run_study"]

Hook = Callable[[str], None]


@dataclass
class StudyRun:
    """The computed results of a study, in memory."""

    study: Study
    inputs: list[CaseInputs]
    results: dict[str, xr.Dataset] = field(default_factory=dict)
    """Case name → annotated Dataset of :func:`cyclomesh.analyse`."""
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → record of :func:`cyclomesh.summarize` (plain JSON numbers)."""


def compute_study(
    study: Study, on_start: Hook | None = None, on_done: Hook | None = None
) -> StudyRun:
    """Check all cases, then analyse them one after the other (nothing is written).

    ``on_start(name)`` and ``on_done(name)`` are called around each case (progress).
    """
    from cyclomesh import analyse, summarize

    run = StudyRun(study=study, inputs=study.to_core())
    for case, inputs in zip(study.cases, run.inputs, strict=True):
        if on_start:
            on_start(case.name)
        ds = annotate(analyse(**inputs.kwargs()), case, study)
        run.results[case.name] = ds
        run.summaries[case.name] = summary_record(summarize(ds))
        if on_done:
            on_done(case.name)
    return run


def figure_cases(results: dict[str, xr.Dataset]) -> dict[str, xr.Dataset]:
    """Results as the figures take them: one torque and one disc each.

    A case with a list of torques becomes one entry per torque (``"case, 250 N·m"``), a
    stack of discs one entry per disc (``"case, disc 2"``).
    """
    out: dict[str, xr.Dataset] = {}
    for name, ds in results.items():
        parts = {name: ds}
        for dim, label in (("torque", "{:g} N·m"), ("disc", "disc {}")):
            split = {}
            for key, part in parts.items():
                if dim not in part.dims:
                    split[key] = part
                    continue
                for value in part[dim].values:
                    split[f"{key}, {label.format(value)}"] = part.sel({dim: value})
            parts = split
        out.update(parts)
    return out


def study_figures(run: StudyRun) -> dict[str, tuple[Any, str]]:
    """The figures of a study: name → (Figure, caption)."""
    from cyclomesh import figures

    settings = run.study.figures
    results = figure_cases(run.results)
    first = run.inputs[0]
    modifications: dict[str, Any] = {}
    for case, inputs in zip(run.study.cases, run.inputs, strict=True):
        same = [k for k, m in modifications.items() if m == inputs.modification]
        if same:
            modifications[f"{same[0]}, {case.name}"] = modifications.pop(same[0])
        else:
            modifications[case.name] = inputs.modification
    out: dict[str, tuple[Any, str]] = {
        "profile": (
            figures.plot_profile(first.design, modifications),
            "Tooth profile with its modification (Eqs. 1-3 of Li et al. 2022): one tooth "
            "space and the normal modification over the profile.",
        )
    }
    with_errors = {
        case.name: inputs.errors
        for case, inputs in zip(run.study.cases, run.inputs, strict=True)
        if any(np.any(getattr(inputs.errors, f)) for f in ("radial", "angular", "pin_radius"))
    }
    if with_errors:
        out["pin_errors"] = (
            figures.plot_pin_errors(with_errors, first.design.pins),
            "Pin errors per pin (Eq. 5), cases with errors only.",
        )
    angles = settings.crank_angles_deg
    pin = settings.stress_pin
    out.update(
        loads=(
            figures.plot_loads(results, angles),
            "Load on every pin (tooth side) and on every groove at the chosen crank angles.",
        ),
        profile_stress=(
            figures.plot_profile_stress(results, pin, settings.stress_over),
            f"Contact stress over the tooth profile, pin {pin}, through its mesh cycle.",
        ),
        stress_maps=(
            figures.plot_stress_maps(results),
            "Contact stress of every pin over the crank angle, on teeth and on grooves.",
        ),
        transmission_error=(
            figures.plot_transmission_error(results),
            "Loaded transmission error (Eq. 25) over one mesh cycle and over all angles.",
        ),
        gear_ratio=(
            figures.plot_gear_ratio(results),
            "Instantaneous gear ratio (Eq. 26); the dotted line is the ideal ratio n2.",
        ),
        contacts=(
            figures.plot_contacts(results),
            "Number of pins in contact.",
        ),
        backlash=(
            figures.plot_backlash(results, angles),
            "Unloaded backlash of every pin (Eq. 11); unreachable pins are left out.",
        ),
    )
    from cyclomesh import drive_figures

    out["mesh_force"] = (
        drive_figures.plot_mesh_force(results),
        "Mesh force: magnitude and direction of the resultant of the pin forces on the "
        "disc, the load its crank bearing carries (docs/drive.md).",
    )
    stacks = {name: ds for name, ds in run.results.items() if "torque_share" in ds}
    if stacks:
        out["torque_share"] = (
            drive_figures.plot_torque_share(stacks),
            "Split of the torque between the discs of a stack over the revolution "
            "(largest torque of a torque list).",
        )
    return out


_HEADINGS = {
    "profile": "Tooth profile and modification",
    "pin_errors": "Pin errors",
    "loads": "Loads on pins and grooves",
    "profile_stress": "Contact stress over the tooth profile",
    "stress_maps": "Contact stress of all pins",
    "transmission_error": "Loaded transmission error",
    "gear_ratio": "Instantaneous gear ratio",
    "contacts": "Pins in contact",
    "backlash": "Backlash",
    "mesh_force": "Mesh force (crank bearing load)",
    "torque_share": "Torque split between the discs",
}


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


def _cell(value: Any) -> Any:
    if isinstance(value, bool):
        return "true" if value else "false"
    return value


def _sections(run: StudyRun, figs: dict[str, tuple[Any, str]], files: list[str]) -> list:
    from cyclomesh.report import Section, table_html

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
    for flat, case in zip(flats, study.cases, strict=True):
        if case.errors.file is not None or case.errors.random is not None:
            for key, values in case.pin_errors().items():
                flat[f"errors: total {key}"] = _flat("", list(values))[""]
    keys = list(dict.fromkeys(k for flat in flats for k in flat))
    rows = [[k, *(_cell(f.get(k)) for f in flats)] for k in keys]
    inputs = table_html(["key", *names], [r for r in rows if any(v is not None for v in r[1:])])
    inputs += (
        "<p>Per-pin errors are the sum of the lists, the file and the random draws. "
        "In results.csv an infinite backlash (pin unreachable by the loaded flank) is "
        "an empty cell.</p>"
        f"<details><summary>study file {html.escape(study.path.name)}</summary>"
        f"<pre>{html.escape(study.text)}</pre></details>"
    )
    columns = list(next(iter(run.summaries.values())))
    summary = table_html(
        ["case", *columns], [[n, *(run.summaries[n].get(c) for c in columns)] for n in names]
    )
    sections = [
        Section("Study", intro),
        Section("Inputs", inputs),
        Section("Summary", summary),
    ]
    sections += [Section(_HEADINGS.get(name, name), "", [fig]) for name, fig in figs.items()]
    listing = "".join(f"<li><code>{html.escape(f)}</code></li>" for f in files)
    sections.append(Section("Files", f"<ul>{listing}</ul>"))
    return sections


def write_study(
    run: StudyRun, out: Path, figs: dict[str, tuple[Any, str]] | None = None
) -> list[Path]:
    """Write the results, figures, summary and report of ``run`` into ``out``."""
    from cyclomesh.report import cyclomesh_version, write_report

    study = run.study
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    records = []
    for case in study.cases:
        folder = case_folder(case.name)
        paths = write_case(run.results[case.name], out / folder)
        written += paths.values()
        records.append((case.name, f"{folder}/results.nc", run.summaries[case.name]))
    images: dict[str, tuple[Any, str]] = {}
    if figs:
        (out / "figures").mkdir(exist_ok=True)
        for name, (fig, caption) in figs.items():
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png", dpi=study.figures.dpi)
            images[name] = (buffer.getvalue(), caption)  # rendered once, reused by the report
            for fmt in study.figures.formats:
                path = out / "figures" / f"{name}.{fmt}"
                if fmt == "png":
                    path.write_bytes(images[name][0])
                else:
                    fig.savefig(path, format=fmt, dpi=study.figures.dpi)
                written.append(path)
    stamp = {
        "study file": study.path.name,
        "SHA-256 of the study file": study.sha256,
    }
    written.append(
        write_summary(
            out / "summary.json",
            study.title,
            records,
            {
                "study_file": study.path.name,
                "study_sha256": study.sha256,
                "cyclomesh_version": cyclomesh_version(),
            },
        )
    )
    files = [p.relative_to(out).as_posix() for p in written] + ["report.html"]
    sections = _sections(run, images, files)
    written.append(write_report(out / "report.html", study.title, sections, stamp))
    return written


def run_study(
    study: Study,
    out: str | Path,
    on_start: Hook | None = None,
    on_done: Hook | None = None,
) -> list[Path]:
    """Compute every case of ``study``, draw its figures and write everything into ``out``.

    Returns the paths written. Nothing is written if a case is refused or fails.
    """
    run = compute_study(study, on_start, on_done)
    figs = study_figures(run) if study.figures.enabled else {}
    return write_study(run, Path(out), figs)


def load_summary(path: str | Path) -> dict[str, Any]:
    """Read a ``summary.json`` written by :func:`write_study`."""
    return json.loads(Path(path).read_text(encoding="utf-8"))
