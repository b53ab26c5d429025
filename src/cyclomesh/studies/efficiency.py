"""Efficiency maps: ``cyclomesh efficiency`` (docs/efficiency.md).

For every case (with ``[friction]``), the forward and back-driving efficiency, input and
output power and the loss of every path over ``[efficiency] torque_nm`` ×
``input_speed_rpm`` (each a ``{start, stop, points}`` range), each point the exact solve
with friction in the equilibrium of :func:`cyclomesh.analyse` (every torque of one speed
in one call), and the loss breakdown at the rated point. Stages as every kind
(docs/pipeline.md): :func:`compute_efficiency`, :func:`write_efficiency`,
:func:`efficiency_figures`, :func:`efficiency_sections`, :data:`EFFICIENCY`.
"""

from __future__ import annotations

import dataclasses
import html
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.exceptions import StudyError
from cyclomesh.publish.pipeline import case_attrs, summary_document
from cyclomesh.quantities import QUANTITIES, select
from cyclomesh.studies.execute import CommandSteps, StudyKind
from cyclomesh.studyfile.schema import Study

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.figures.render import FigureJob
    from cyclomesh.publish.report import Section

__all__ = [
    "EfficiencyResult",
    "check_efficiency",
    "compute_efficiency",
    "write_efficiency",
    "efficiency_figures",
    "efficiency_sections",
    "EFFICIENCY",
    "MAP_METRICS",
]

PATHS = ("pin_tooth", "pin_groove", "crank_bearings")

MAP_METRICS = {
    name: q.unit
    for name, q in select(
        "peak_efficiency",
        "peak_torque_nm",
        "peak_speed_rpm",
        "rated_torque_nm",
        "rated_speed_rpm",
        "rated_efficiency",
        "rated_backdrive_efficiency",
        "rated_input_power_w",
        "rated_power_loss_w",
        "efficiency_min",
        "backdrive_efficiency_min",
    ).items()
}
"""Numbers of each case in ``summary.json`` with their units (rows of
:data:`cyclomesh.quantities.QUANTITIES`)."""


def _attrs(name: str) -> dict[str, str]:
    """``units`` and ``long_name`` of a map variable, from the registry."""
    return {"units": QUANTITIES[name].unit, "long_name": QUANTITIES[name].long_name}


@dataclass
class EfficiencyResult:
    """The efficiency maps of a study, in memory."""

    study: Study
    maps: dict[str, xr.Dataset] = field(default_factory=dict)
    """Case name → Dataset (torque × input_speed, path)."""
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    checks: dict[str, dict[str, Any]] = field(default_factory=dict)
    seconds: float = 0.0

    def study_warnings(self) -> list[str]:
        return []


def check_efficiency(study: Study) -> None:
    """One-line :class:`StudyError` for a study the efficiency map cannot run."""
    if study.file.efficiency is None:
        raise StudyError(
            "no [efficiency] section: give efficiency.torque_nm and efficiency.input_speed_rpm "
            "as {start, stop, points} (see examples/efficiency.toml)"
        )
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        if inputs.friction is None:
            raise StudyError(
                f"{case.label}: cyclomesh efficiency needs friction: give [friction] "
                "mesh_coefficient, groove_coefficient (and bearing_coefficient) above 0"
            )


def compute_efficiency(
    study: Study, *, backend: Any = None, progress: Callable[[int], None] | None = None
) -> EfficiencyResult:
    """Map the efficiency of every case (nothing is written); ``progress(1)`` per case."""
    import xarray as xr

    from cyclomesh.studies.checks import case_checks
    from cyclomesh.studyfile.usage import check_keys

    check_efficiency(study)
    check_keys(study.raw, "efficiency")
    section = study.file.efficiency
    torques = section.torque_nm.values()
    speeds = section.input_speed_rpm.values()
    rated_torque, rated_speed = section.rated()
    start = time.perf_counter()
    result = EfficiencyResult(study=study)
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        kwargs = inputs.kwargs()
        kwargs.pop("crank_angles")
        friction = kwargs.pop("friction")
        angles = case.analysis.crank_angles_deg()

        table: dict[str, list[Any]] = {
            k: [] for k in ("efficiency", "backdrive_efficiency", "input_power_w", "output_power_w")
        }
        losses: list[list[list[float]]] = []
        for rpm in speeds:
            rec = _point(
                case,
                kwargs,
                friction,
                angles,
                list(torques) if torques.size > 1 else float(torques[0]),
                float(rpm),
            )
            for name in table:
                table[name].append(np.atleast_1d(rec[name]))
            losses.append([np.atleast_1d(rec["power_loss_w"][p]) for p in PATHS])
        dims = ("input_speed", "torque")
        data = {
            "efficiency": (dims, np.array(table["efficiency"]), _attrs("efficiency")),
            "backdrive_efficiency": (
                dims,
                np.array(table["backdrive_efficiency"]),
                _attrs("backdrive_efficiency"),
            ),
            "input_power": (dims, np.array(table["input_power_w"]), _attrs("input_power")),
            "output_power": (dims, np.array(table["output_power_w"]), _attrs("output_power")),
            "power_loss": (
                (*dims, "path"),
                np.moveaxis(np.array(losses), 1, -1),
                {"units": "W", "long_name": "friction power loss per path"},
            ),
        }
        coords = {
            "input_speed": ("input_speed", speeds, {"units": "rpm"}),
            "torque": ("torque", torques, {"units": "N·m"}),
            "path": ("path", list(PATHS)),
        }
        ds = xr.Dataset(data, coords=coords, attrs=case_attrs(study, case))
        ds = ds.transpose("torque", "input_speed", "path")
        rated = _point(case, kwargs, friction, angles, float(rated_torque), float(rated_speed))
        eff = ds["efficiency"].values
        peak = np.unravel_index(int(np.argmax(eff)), eff.shape)
        summary = {
            "peak_efficiency": float(eff[peak]),
            "peak_torque_nm": float(torques[peak[0]]),
            "peak_speed_rpm": float(speeds[peak[1]]),
            "rated_torque_nm": float(rated_torque),
            "rated_speed_rpm": float(rated_speed),
            "rated_efficiency": rated["efficiency"],
            "rated_backdrive_efficiency": rated["backdrive_efficiency"],
            "rated_input_power_w": rated["input_power_w"],
            "rated_power_loss_w": rated["power_loss_w"],
            "efficiency_min": float(eff.min()),
            "backdrive_efficiency_min": float(ds["backdrive_efficiency"].values.min()),
        }
        result.maps[case.name] = ds
        result.summaries[case.name] = summary
        result.checks[case.name] = case_checks(study, case, inputs, summary)
        if progress:
            progress(1)
    result.seconds = time.perf_counter() - start
    return result


def _point(
    case: Any, kwargs: dict[str, Any], friction: Any, angles: Any, torque: Any, rpm: float
) -> dict[str, Any]:
    """The efficiency record of one speed (every torque of ``torque`` in one solve)."""
    from cyclomesh.exceptions import CyclomeshError
    from cyclomesh.results.dataset import analyse
    from cyclomesh.results.efficiency import efficiency_record

    at = dataclasses.replace(friction, speed=rpm * 2.0 * math.pi / 60.0)
    try:
        ds = analyse(**{**kwargs, "torque": torque}, crank_angles_deg=angles, friction=at)
    except CyclomeshError as exc:  # name the case and the point
        raise type(exc)(f"{case.label}, {rpm:g} rpm: {exc}") from None
    return efficiency_record(ds)


def write_efficiency(result: EfficiencyResult, out: Path) -> list[Path]:
    """Write ``<case>/efficiency.nc`` of every case and ``summary.json`` into ``out``."""
    from cyclomesh.output.writers import write_case_netcdf, write_json

    study = result.study
    written, records = write_case_netcdf(
        study,
        out,
        result.maps,
        "efficiency.nc",
        lambda case: {**result.summaries[case.name], "checks": result.checks[case.name]},
    )
    document = summary_document(study, MAP_METRICS, records)
    written.append(write_json(out / "summary.json", document))
    return written


def efficiency_figures(result: EfficiencyResult) -> list[FigureJob]:
    """The efficiency map and the loss breakdown as figure jobs."""
    from cyclomesh.figures import efficiency as plots
    from cyclomesh.figures.render import FigureJob

    return [
        FigureJob(
            "efficiency_map",
            plots.plot_efficiency_map,
            (dict(result.maps),),
            caption="Efficiency against output torque, one curve per input speed (solid: "
            "forward, the input driving; dashed: back-driving), each point the mean over "
            "the analysed crank angles of the exact solve with friction (docs/efficiency.md).",
            section="Efficiency map",
        ),
        FigureJob(
            "loss_breakdown",
            plots.plot_loss_breakdown,
            (dict(result.summaries),),
            caption="Power loss by path at the rated point (forward drive).",
            section="Loss breakdown",
        ),
    ]


def efficiency_sections(result: EfficiencyResult) -> list[Section]:
    """Report sections: study, what is modelled, the summary table."""
    from cyclomesh.publish.report import Section, table_html
    from cyclomesh.studies.checks import checks_section

    study = result.study
    intro = f"<p>{html.escape(study.description)}</p>" if study.description else ""
    intro += (
        "<p><strong>Losses modelled: sliding at the pin–tooth or pin–groove contacts "
        "(Coulomb, or lubricated: boundary or Benedict–Kelley by the film parameter λ), the "
        "crank bearing (SKF constant coefficient), all in "
        "the equilibrium. Not modelled: churning, seals, the output mechanism, the first "
        "stage (docs/efficiency.md).</strong></p>"
    )
    rows = []
    for name, s in result.summaries.items():
        loss = s["rated_power_loss_w"]
        rows.append(
            (
                name,
                f"{100 * s['peak_efficiency']:.2f} % at {s['peak_torque_nm']:g} N·m, "
                f"{s['peak_speed_rpm']:g} rpm",
                f"{100 * s['rated_efficiency']:.2f} %",
                f"{100 * s['rated_backdrive_efficiency']:.2f} %",
                f"{s['rated_input_power_w']:.4g}",
                ", ".join(f"{p}: {(loss.get(p) or 0.0):.3g}" for p in PATHS),
            )
        )
    table = table_html(
        [
            "case",
            "peak efficiency",
            "rated efficiency",
            "rated back-driving",
            "rated input power [W]",
            "rated losses [W]",
        ],
        rows,
    )
    intro += (
        f"<details><summary>study file {html.escape(study.path.name)}</summary>"
        f"<pre>{html.escape(study.text)}</pre></details>"
    )
    return [
        Section("Study", intro),
        checks_section(result.checks),
        Section("Summary", table),
    ]


def _show(result: EfficiencyResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_efficiency

    print_efficiency(result.summaries, out, result.checks)


EFFICIENCY = StudyKind(
    command="efficiency",
    title="efficiency map",
    compute=lambda study, **kw: compute_efficiency(study, **kw),
    write=lambda result, out, options: write_efficiency(result, out),
    figures=lambda result, early: efficiency_figures(result),
    sections=lambda result: efficiency_sections(result),
    keys_first=check_efficiency,  # the section and the friction first
    steps=CommandSteps(progress=lambda study, o: (len(study.cases), "cases"), show=_show),
)
