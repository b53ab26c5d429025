"""FE checks: the whole-disc finite-element model beside the LTCA (``cyclomesh fe``).

For every case of a study file, at a few crank angles, :func:`cyclomesh.fe.disc.solve_disc_fe`
solves the disc with its pins by FE (2-D plane strain, unilateral contact; the optional
``fe`` extra) and the LTCA of the same case with both contact laws beside it. The
``[fe]`` section (:class:`~cyclomesh.studyfile.schema.FeSection`, validated with the rest of
the study file) sets the bore, the crank angles and the mesh. Stages (``docs/pipeline.md``):

1. :func:`check_fe`: the cases are ones the FE model takes (no pin errors yet);
2. :func:`compute_fe`: per case a Dataset with dimensions ``crank_angle`` [deg] and
   ``pin``: ``pin_load_fe``, ``pin_load_ltca`` [N], ``contact_stress_fe``,
   ``contact_stress_ltca`` [MPa], ``rotation_fe``, ``rotation_ltca`` [arcsec, the disc's
   loaded position in the TE convention −(φc − φt + Δφc), Eq. 25]; the ``*_ltca``
   variables use the case's ``[analysis] contact_law`` and ``*_ltca_paper`` /
   ``*_ltca_half_plane`` give both laws; the mesh-convergence table of the first crank
   angle (half and full contact mesh density); :data:`cyclomesh.results.metrics.FE_METRICS`;
3. :func:`write_fe`: ``<case>/fe.nc``, ``<case>/convergence.csv``, ``summary.json``;
4. :func:`fe_figures`, :func:`fe_sections`: figure jobs and report sections.

The evidence and its reading are in ``docs/contact-law.md``.
"""

from __future__ import annotations

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
from cyclomesh.results.metrics import FE_METRICS
from cyclomesh.studies.execute import CommandSteps, StudyKind
from cyclomesh.studyfile.schema import FeSection, Study, folder_name
from cyclomesh.units import ARCSEC_PER_RAD

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.figures.render import FigureJob
    from cyclomesh.publish.report import Section

__all__ = [
    "FeResult",
    "check_fe",
    "compute_fe",
    "write_fe",
    "fe_figures",
    "fe_sections",
]

LAWS = ("paper", "half_plane")


@dataclass
class FeResult:
    """The FE checks of a study, in memory."""

    study: Study
    section: FeSection
    cases: dict[str, xr.Dataset] = field(default_factory=dict)
    """Case name → Dataset (see the module doc)."""
    convergence: dict[str, list[list[Any]]] = field(default_factory=dict)
    """Case name → rows of the mesh-convergence table (header first)."""
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → :data:`FE_METRICS` (JSON numbers)."""
    checks: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → requirement checks and design warnings (:mod:`cyclomesh.studies.checks`)."""
    seconds: float = 0.0


def check_fe(study: Study) -> None:
    """Raise a :class:`StudyError` for a case the FE model does not take (pin errors)."""
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        errors = inputs.errors
        if any(np.any(np.asarray(getattr(errors, name))) for name in errors.__dataclass_fields__):
            raise StudyError(
                f"{case.label}: the FE model takes no pin errors yet: remove [errors] "
                "from this case (cyclomesh run handles them)"
            )
        if np.ndim(inputs.torque) or inputs.discs != 1:
            raise StudyError(
                f"{case.label}: the FE model takes one disc and one torque: set [load] "
                "torque_nm to a number and [design] discs to 1"
            )


def _solve(
    inputs: Any, section: FeSection, phi_deg: float, density: float, body: Any = "rigid"
) -> Any:
    from cyclomesh.fe.disc import solve_disc_fe

    return solve_disc_fe(
        inputs.design,
        inputs.modification,
        float(inputs.torque),
        math.radians(phi_deg),
        elements_per_half_width=density,
        bore_radius=section.bore_radius_mm * 1e-3,
        far_size=section.far_size_mm * 1e-3,
        contact_law=inputs.contact_law,
        disc_body=body,
    )


def compute_fe(
    study: Study,
    *,
    crank_angles_deg: list[float] | None = None,
    convergence: bool = True,
    backend: Any = None,
    progress: Callable[[int], None] | None = None,
    log: Callable[[str], None] | None = None,
    cache_dir: str | None = None,
) -> FeResult:
    """Solve every case by FE and LTCA at the crank angles (nothing is written).

    Parameters
    ----------
    crank_angles_deg : list of float, optional
        Crank angles [deg]; default ``[fe] crank_angles_deg``.
    convergence : bool
        Also solve the first crank angle at half the contact mesh density.
    backend : None
        Not used: the FE solves run here, one after the other (one signature of every kind).
    progress : callable, optional
        ``progress(1)`` after each case.
    log : callable, optional
        Called with a line of text before each FE solve.
    cache_dir : str, optional
        Cache of the disc body's coefficients (``[analysis] disc_body = "fe"``).
    """
    from cyclomesh.studyfile.schema import refuse_stage
    from cyclomesh.studyfile.usage import check_keys

    check_keys(study.raw, "fe")
    refuse_stage(study, "fe")
    check_fe(study)
    section = study.file.fe or FeSection()
    angles = np.asarray(
        section.crank_angles_deg if crank_angles_deg is None else crank_angles_deg, float
    )
    if angles.ndim != 1 or angles.size == 0 or not np.all(np.isfinite(angles)):
        raise StudyError("--crank-angles: give one or more finite crank angles [deg]")
    from cyclomesh.studies.checks import case_checks

    start = time.perf_counter()
    result = FeResult(study=study, section=section)
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        solved = []
        body: Any = "rigid"
        if inputs.disc_body == "fe":
            from cyclomesh.fe.influence import influence

            if log:
                log(f"{case.name}: influence coefficients of the disc body (bore)")
            # the whole-disc FE holds the disc at its bore: compare with the same support
            body = influence(
                inputs.design,
                inputs.modification,
                None,
                cache_dir,
                bore_radius=section.bore_radius_mm * 1e-3,
            )
        for phi in angles:
            if log:
                log(f"{case.name}: crank angle {phi:g}°")
            solved.append(
                _solve(inputs, section, float(phi), section.elements_per_half_width, body)
            )
        ds = _dataset(solved, angles, inputs.design.pins)
        ds.attrs.update(
            case_attrs(study, case),
            contact_law=inputs.contact_law,
            disc_body=inputs.disc_body,
            torque_nm=float(inputs.torque),
            bore_radius_mm=section.bore_radius_mm,
            elements_per_half_width=section.elements_per_half_width,
            far_size_mm=section.far_size_mm,
            rotation_convention="TE convention of Eq. 25: -(rest + loaded rotation)",
        )
        result.cases[case.name] = ds
        result.summaries[case.name] = _summary(ds)
        result.checks[case.name] = case_checks(study, case, inputs, result.summaries[case.name])
        if convergence:
            if log:
                log(f"{case.name}: crank angle {angles[0]:g}° at half the mesh density")
            coarse = _solve(
                inputs, section, float(angles[0]), section.elements_per_half_width / 2, body
            )
            result.convergence[case.name] = _convergence(section, coarse, solved[0])
        if progress:
            progress(1)
    result.seconds = time.perf_counter() - start
    return result


def _dataset(solved: list[Any], angles: np.ndarray, pins: int) -> xr.Dataset:
    import xarray as xr

    def rows(get: Callable[[Any], Any], scale: float = 1.0) -> np.ndarray:
        return np.array([get(r) for r in solved], float) * scale

    def position(rotation: Callable[[Any], float]) -> np.ndarray:
        return np.array([-(r.rest_rotation + rotation(r)) * ARCSEC_PER_RAD for r in solved])

    per_pin = ("crank_angle", "pin")
    data: dict[str, Any] = {
        "pin_load_fe": (per_pin, rows(lambda r: r.pin_load_fe), {"units": "N"}),
        "pin_load_ltca": (per_pin, rows(lambda r: r.pin_load_ltca), {"units": "N"}),
        "contact_stress_fe": (per_pin, rows(lambda r: r.contact_stress_fe, 1e-6), {"units": "MPa"}),
        "contact_stress_ltca": (
            per_pin,
            rows(lambda r: r.contact_stress_ltca, 1e-6),
            {"units": "MPa"},
        ),
        "contact_stress_fe_resolved": (
            per_pin,
            rows(lambda r: r.stress_resolved).astype(np.int8),
            {
                "units": "1",
                "long_name": "1: FE peak pressure recovered from the nodal pressures; 0: the "
                "contact is too light for the mesh and contact_stress_fe is the Hertz "
                "pressure (Eq. 24) of the FE load",
            },
        ),
        "rotation_fe": ("crank_angle", position(lambda r: r.rotation_fe), {"units": "arcsec"}),
        "rotation_ltca": ("crank_angle", position(lambda r: r.rotation_ltca), {"units": "arcsec"}),
    }
    for law in LAWS:
        data[f"pin_load_ltca_{law}"] = (
            per_pin,
            rows(lambda r, law=law: r.ltca_by_law[law][0]),
            {"units": "N"},
        )
        data[f"contact_stress_ltca_{law}"] = (
            per_pin,
            rows(lambda r, law=law: r.ltca_by_law[law][1], 1e-6),
            {"units": "MPa"},
        )
        data[f"rotation_ltca_{law}"] = (
            "crank_angle",
            position(lambda r, law=law: r.ltca_by_law[law][2]),
            {"units": "arcsec"},
        )
    return xr.Dataset(
        data,
        coords={
            "crank_angle": ("crank_angle", angles, {"units": "deg"}),
            "pin": ("pin", np.arange(1, pins + 1)),
        },
    )


def _summary(ds: xr.Dataset) -> dict[str, Any]:
    fe_load = ds["pin_load_fe"].values
    peak = float(fe_load.max())
    out: dict[str, Any] = {
        "fe_max_pin_load_n": peak,
        "fe_max_contact_stress_mpa": float(ds["contact_stress_fe"].max()),
        "fe_rotation_arcsec_mean": float(ds["rotation_fe"].mean()),
    }
    for law in LAWS:
        load = ds[f"pin_load_ltca_{law}"].values
        out[f"ltca_{law}_max_pin_load_n"] = float(load.max())
        rms = math.sqrt(float(np.mean((load - fe_load) ** 2)))
        out[f"ltca_{law}_pin_load_rms_pct"] = 100.0 * rms / peak if peak > 0 else None
        out[f"ltca_{law}_rotation_arcsec_mean"] = float(ds[f"rotation_ltca_{law}"].mean())
    load = ds["pin_load_ltca"].values
    out["ltca_max_pin_load_n"] = float(load.max())
    rms = math.sqrt(float(np.mean((load - fe_load) ** 2)))
    out["ltca_pin_load_rms_pct"] = 100.0 * rms / peak if peak > 0 else None
    out["ltca_rotation_arcsec_mean"] = float(ds["rotation_ltca"].mean())
    return out


def _convergence(section: FeSection, coarse: Any, fine: Any) -> list[list[Any]]:
    n = section.elements_per_half_width
    table: list[list[Any]] = [["quantity", f"N={n / 2:g}", f"N={n:g}", "relative change"]]
    table.append(["nodes", coarse.nodes, fine.nodes, ""])
    table.append(
        [
            "rotation_arcsec",
            coarse.rotation_fe * ARCSEC_PER_RAD,
            fine.rotation_fe * ARCSEC_PER_RAD,
            fine.rotation_fe / coarse.rotation_fe - 1 if coarse.rotation_fe else "",
        ]
    )
    for i in np.flatnonzero(fine.pin_load_fe > 0):
        c, f = float(coarse.pin_load_fe[i]), float(fine.pin_load_fe[i])
        table.append([f"pin_load_{i + 1}_n", c, f, f / c - 1 if c else ""])
    return table


def write_fe(result: FeResult, out: Path) -> list[Path]:
    """Write ``<case>/fe.nc``, ``<case>/convergence.csv`` and ``summary.json`` into ``out``."""
    import csv

    from cyclomesh.output.folder import atomic_write
    from cyclomesh.output.writers import write_case_netcdf, write_json

    def convergence(case: Any, folder: Path) -> list[Path]:
        if case.name not in result.convergence:
            return []
        path = folder / "convergence.csv"
        with atomic_write(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
            csv.writer(fh).writerows(result.convergence[case.name])
        return [path]

    study = result.study
    written, records = write_case_netcdf(
        study,
        out,
        result.cases,
        "fe.nc",
        lambda case: {
            "crank_angles_deg": [float(a) for a in result.cases[case.name].crank_angle],
            **result.summaries[case.name],
            "checks": result.checks[case.name],
        },
        convergence,
    )
    document = summary_document(
        study,
        {name: m.unit for name, m in FE_METRICS.items()},
        records,
        fe=result.section.model_dump(),
        seconds=result.seconds,
    )
    written.append(write_json(out / "summary.json", document))
    return written


def fe_figures(result: FeResult) -> list[FigureJob]:
    """One comparison figure per case (FE against both LTCA laws)."""
    from cyclomesh.figures.fe import plot_fe_comparison
    from cyclomesh.figures.render import FigureJob

    return [
        FigureJob(
            f"fe_{folder_name(name)}",
            plot_fe_comparison,
            (ds,),
            caption=f"{name}: pin loads and contact stresses by FE (dots) and LTCA with "
            "Eq. 20 (paper) and the half-plane law, at each crank angle.",
            section="FE against LTCA",
        )
        for name, ds in result.cases.items()
    ]


def fe_sections(result: FeResult) -> list[Section]:
    """Report sections: study and FE model, summary, convergence tables."""
    from cyclomesh.publish.report import Section, table_html

    study, section = result.study, result.section
    intro = f"<p>{html.escape(study.description)}</p>" if study.description else ""
    intro += (
        "<p>Whole disc, 2-D plane strain, linear elastic, frictionless unilateral contact "
        f"with every pin; bore {section.bore_radius_mm:g} mm tied to a rigid centre that "
        f"carries the torque; contact mesh b/{section.elements_per_half_width:g}, far mesh "
        f"{section.far_size_mm:g} mm. What the FE model holds that the LTCA does not (the "
        "web's torsion, pin coupling through the disc) is in docs/contact-law.md.</p>"
    )
    intro += (
        f"<details><summary>study file {html.escape(study.path.name)}</summary>"
        f"<pre>{html.escape(study.text)}</pre></details>"
    )
    from cyclomesh.publish.report import metrics_table
    from cyclomesh.studies.checks import checks_section

    summary = metrics_table(result.summaries, FE_METRICS)
    sections = [Section("Study", intro), checks_section(result.checks), Section("Summary", summary)]
    for name, table in result.convergence.items():
        sections.append(
            Section(
                f"Mesh convergence: {name}",
                table_html(table[0], table[1:]),
            )
        )
    sections.append(Section("FE against LTCA", ""))
    return sections


def require_fe_extra() -> None:
    """Refuse ``cyclomesh fe`` in one line when the fe extra (scikit-fem, gmsh) cannot load."""
    try:
        import gmsh  # noqa: F401
        import skfem  # noqa: F401
    except (ImportError, OSError) as exc:  # gmsh's wheel also needs X11/OpenGL libraries
        raise StudyError(
            f"cyclomesh fe needs the fe extra: pip install -e '.[fe]' ({exc})".replace("\n", " ")
        ) from None


def crank_angles_from(text: str | None) -> list[float] | None:
    """The angles of ``--crank-angles`` [deg] (None: the study's)."""
    if not text:
        return None
    from cyclomesh.studyfile.limits import MAX_ABS_CRANK_DEG

    try:
        angles = [float(a) for a in text.split(",")]
    except ValueError:
        raise StudyError(
            f"--crank-angles: expected numbers separated by commas, got {text!r}"
        ) from None
    if not 1 <= len(angles) <= 24 or not all(abs(a) <= MAX_ABS_CRANK_DEG for a in angles):
        raise StudyError(
            f"--crank-angles: expected 1 to 24 angles within ±{MAX_ABS_CRANK_DEG:g} deg, "
            f"got {text!r}"
        )
    return angles


def _before(options: Any) -> dict[str, Any]:
    require_fe_extra()
    return {"crank_angles_deg": crank_angles_from(options["crank_angles"])}


def _preflight(study: Study) -> None:
    from cyclomesh.studyfile.schema import refuse_stage

    refuse_stage(study, "fe")
    check_fe(study)


def _show(result: FeResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_fe

    print_fe(result.summaries, out, result.checks)


FE = StudyKind(
    command="fe",
    title="FE check",
    compute=lambda study, **kw: compute_fe(study, **kw),
    write=lambda result, out, options: write_fe(result, out),
    figures=lambda result, early: fe_figures(result),
    sections=lambda result: fe_sections(result),
    preflight=_preflight,
    steps=CommandSteps(
        before=_before,
        compute=lambda study, options, backend: {"convergence": options["convergence"]},
        log=True,
        show=_show,
    ),
)
"""``cyclomesh fe`` (:func:`cyclomesh.studies.execute.execute`)."""
