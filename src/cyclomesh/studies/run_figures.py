"""The figures of a run (``cyclomesh run``): the jobs of the default overview, of every
figure (``--figures all``) and of the study's inputs, each a
:class:`~cyclomesh.figures.render.FigureJob` drawn by the renderer (in parallel workers,
while the solve runs for the inputs). Split from :mod:`cyclomesh.studies.run` as a pure
move; the old import paths there still work.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.core.pair import Modification
from cyclomesh.results.profile import profile_curves

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.figures.render import FigureJob
    from cyclomesh.studyfile.schema import Study

__all__ = ["figure_cases", "input_figures", "run_figures", "overview_figures", "stress_pin"]


def stress_pin(results: dict[str, Any], pin: int) -> int:
    """The pin of the stress-over-the-profile figure when [figures] stress_pin is not
    given: ``pin`` (half the pin count) if it carries load in some case, else the pin of
    the highest tooth contact stress of the first case (pin errors can lift a pin off at
    every crank angle: the figure would be empty)."""
    loaded = [
        bool(np.any(np.asarray(ds["pin_load"].sel(pin=pin).values) > 0))
        for ds in results.values()
        if pin in ds["pin"].values
    ]
    if any(loaded) or not results:
        return pin
    ds = next(iter(results.values()))
    stress = np.asarray(ds["contact_stress"].values, dtype=float)
    axis = ds["contact_stress"].dims.index("pin")
    peak = np.nanmax(np.moveaxis(stress, axis, -1).reshape(-1, stress.shape[axis]), axis=0)
    if not np.any(np.isfinite(peak)) or not np.nanmax(peak) > 0:
        return pin
    return int(ds["pin"].values[int(np.nanargmax(peak))])


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
    "crank_bearing_loads": "Crank bearing loads (RV stage)",
    "compliance_budget": "Compliance budget (RV stage)",
}


def figure_cases(results: dict[str, xr.Dataset]) -> dict[str, xr.Dataset]:
    """Results as the run figures take them: one torque and one disc each.

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


def _job(name: str, plot: Callable[..., Any], *args: Any, caption: str) -> FigureJob:
    from cyclomesh.figures.render import FigureJob

    return FigureJob(name, plot, args, caption=caption, section=_HEADINGS[name])


def input_figures(study: Study) -> list[FigureJob]:
    """The figures of a run study that need its inputs only (profile, pin errors): they
    can be drawn while the cases are solved."""
    from cyclomesh.figures import run as plots

    cases = list(zip(study.cases, study.inputs, strict=True))
    first = cases[0][1]
    modifications: dict[str, Modification] = {}
    for case, inputs in cases:
        same = [k for k, m in modifications.items() if m == inputs.modification]
        if same:
            modifications[f"{same[0]}, {case.name}"] = modifications.pop(same[0])
        else:
            modifications[case.name] = inputs.modification
    jobs = [
        _job(
            "profile",
            plots.plot_profile,
            profile_curves(first.design, modifications),
            caption="Tooth profile with its modification (Eqs. 1-3 of Li et al. 2022): one "
            "tooth space and the normal modification over the profile.",
        )
    ]
    with_errors = {
        case.name: inputs.errors
        for case, inputs in cases
        if any(np.any(getattr(inputs.errors, f)) for f in ("radial", "angular", "pin_radius"))
    }
    if with_errors:
        jobs.append(
            _job(
                "pin_errors",
                plots.plot_pin_errors,
                with_errors,
                first.design.pins,
                caption="Pin errors per pin (Eq. 5), cases with errors only.",
            )
        )
    return jobs


def run_figures(run: Any, inputs: list[FigureJob] | None = None) -> list[FigureJob]:
    """The figures of a run study (``run``: a :class:`~cyclomesh.studies.run.RunResult`)
    as jobs for :func:`cyclomesh.figures.render.render_figures`.

    ``inputs``: the jobs of :func:`input_figures` if they were made already (e.g.
    submitted to a :class:`~cyclomesh.figures.render.FigurePool` before the solve).
    """
    from cyclomesh.figures import drive as drive_plots
    from cyclomesh.figures import run as plots

    settings = run.study.figures
    results = figure_cases(run.results)
    job = _job

    def only(*names: str) -> dict[str, xr.Dataset]:
        """The variables a figure draws (figures may be drawn in other processes)."""
        return {case: ds[list(names)] for case, ds in results.items()}

    jobs = list(input_figures(run.study) if inputs is None else inputs)
    angles = settings.crank_angles_deg
    pin = settings.stress_pin or stress_pin(
        results, min(case.design.pins for case in run.study.cases) // 2
    )
    jobs += [
        job(
            "loads",
            plots.plot_loads,
            only("pin_load", "groove_load"),
            angles,
            caption="Load on every pin (tooth side) and on every groove at the chosen crank "
            "angles.",
        ),
        job(
            "profile_stress",
            plots.plot_profile_stress,
            only("pin_load", "contact_stress", settings.stress_over),
            pin,
            settings.stress_over,
            caption=f"Contact stress over the tooth profile, pin {pin}, through its mesh cycle.",
        ),
        job(
            "stress_maps",
            plots.plot_stress_maps,
            only("contact_stress", "groove_stress"),
            caption="Contact stress of every pin over the crank angle, on teeth and on grooves.",
        ),
        job(
            "transmission_error",
            plots.plot_transmission_error,
            only("transmission_error"),
            caption="Loaded transmission error (Eq. 25) over one mesh cycle and over all angles.",
        ),
        job(
            "gear_ratio",
            plots.plot_gear_ratio,
            only("gear_ratio"),
            caption="Instantaneous gear ratio (Eq. 26); the dotted line is the ideal ratio n2. "
            "The spikes where a pin enters or leaves contact are real.",
        ),
        job(
            "contacts", plots.plot_contacts, only("contacts"), caption="Number of pins in contact."
        ),
        job(
            "backlash",
            plots.plot_backlash,
            only("backlash"),
            angles,
            caption="Unloaded backlash of every pin (Eq. 11); unreachable pins are left out.",
        ),
        job(
            "mesh_force",
            drive_plots.plot_mesh_force,
            {k: v[["mesh_force", "mesh_force_angle"]] for k, v in results.items()},
            caption="Mesh force: magnitude and direction of the resultant of the pin forces on "
            "the disc, the load its crank bearing carries (docs/drive.md).",
        ),
    ]
    staged = {k: v[["crank_bearing_load"]] for k, v in results.items() if "crank_bearing_load" in v}
    if staged:
        from cyclomesh.figures import stage as stage_plots

        jobs.append(
            job(
                "crank_bearing_loads",
                stage_plots.plot_crank_bearing_loads,
                staged,
                caption="Load of every crank bearing of the RV stage over the crank angle "
                "(colour: crankshaft, line style: disc; docs/stage.md).",
            )
        )
    budgets = {
        k: dict(v["compliance_share"]) for k, v in run.summaries.items() if "compliance_share" in v
    }
    if budgets:
        from cyclomesh.figures import stage as stage_plots

        jobs.append(
            job(
                "compliance_budget",
                stage_plots.plot_compliance_budget,
                budgets,
                caption="Compliance budget of the RV stage at rated torque: each part's share "
                "of the output twist from rest (virtual work, shares add to 1); the first "
                "stage is not modelled (docs/stage.md).",
            )
        )
    stacks = {k: v[["torque_share"]] for k, v in run.results.items() if "torque_share" in v}
    if stacks:
        jobs.append(
            job(
                "torque_share",
                drive_plots.plot_torque_share,
                stacks,
                caption="Split of the torque between the discs of a stack over the revolution "
                "(the largest torque of a torque list).",
            )
        )
    return jobs


_OVERVIEW_DIMS = ("torque", "crank_angle", "disc", "pin")


def _pick(var: Any, at: dict[str, int]) -> np.ndarray:
    """A variable (Frame or Dataset) at the torque and disc indices ``at`` (those its
    dimensions have), axes (crank angle[, pin])."""
    order = [dim for dim in _OVERVIEW_DIMS if dim in var.dims]
    index = tuple(at.get(dim, slice(None)) for dim in order)
    return np.asarray(var.transpose(*order).values[index])


def overview_figures(run: Any) -> list[FigureJob]:
    """The overview figure of a run study (``run``: a
    :class:`~cyclomesh.studies.run.RunResult`; :mod:`cyclomesh.figures.overview`), the one
    figure of the default ``--figures`` set: pin loads at the first crank angle of
    ``[figures] crank_angles_deg``, TE, peak contact stress and pins in contact over
    the crank angle, one line per case, torque and disc (as :func:`figure_cases`
    splits them). Built from the results' NumPy arrays: no xarray."""
    import warnings

    from cyclomesh.figures.overview import OverviewCase, plot_overview
    from cyclomesh.figures.render import FigureJob

    target = float(run.study.figures.crank_angles_deg[0])
    cases: dict[str, OverviewCase] = {}
    for name, ds in run.frames.items():
        torques = ds["torque"].values if "torque" in ds.dims else [None]
        discs = ds["disc"].values if "disc" in ds.dims else [None]
        angles = np.asarray(ds["crank_angle"].values, dtype=float)
        k = int(np.argmin(np.abs((angles - target + 180.0) % 360.0 - 180.0)))
        for t, torque in enumerate(torques):
            for d, disc in enumerate(discs):
                at = {"torque": t, "disc": d}
                label = name + ("" if torque is None else f", {torque:g} N·m")
                label += "" if disc is None else f", disc {disc}"
                with warnings.catch_warnings():  # an angle where no pin is loaded: NaN
                    warnings.simplefilter("ignore", RuntimeWarning)
                    peak = np.nanmax(_pick(ds["contact_stress"], at), axis=-1)
                cases[label] = OverviewCase(
                    crank_angle=angles,
                    pin=np.asarray(ds["pin"].values),
                    pin_load_at=float(angles[k]),
                    pin_load=_pick(ds["pin_load"], at)[k],
                    transmission_error=_pick(ds["transmission_error"], at),
                    max_contact_stress=peak,
                    contacts=_pick(ds["contacts"], at),
                )
    return [
        FigureJob(
            "overview",
            plot_overview,
            (cases,),
            caption="Overview: load on every pin at one crank angle (Eq. 18 of Li et al. "
            "2022), loaded transmission error (Eq. 25), peak tooth contact stress over the "
            "pins (Eq. 24) and pins in contact over the crank angle; --figures all draws "
            "every figure of the run.",
            section="Summary",  # under the summary table, on the report's first screen
        )
    ]
