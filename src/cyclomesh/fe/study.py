"""``cyclomesh fe STUDY.toml --out DIR``: the whole-disc FE model beside the LTCA.

For every case of a study file, at a few crank angles, :func:`~cyclomesh.fe.disc.solve_disc_fe`
solves the disc with its pins by FE and the LTCA beside it, and writes to
``DIR/<case folder>/``:

* ``fe.nc``: dimensions ``crank_angle`` [deg] and ``pin``; ``pin_load_fe``,
  ``pin_load_ltca`` [N], ``contact_stress_fe``, ``contact_stress_ltca`` [MPa],
  ``rotation_fe``, ``rotation_ltca`` [arcsec]: the disc's loaded position in the TE
  convention, −(φc − φt + Δφc) (Eq. 25); the ``*_ltca`` variables use the case's
  ``[analysis] contact_law``, and ``*_ltca_paper`` / ``*_ltca_half_plane`` give both laws;
* ``fe.png``: pin loads and contact stresses, FE against LTCA;
* ``convergence.csv``: the first crank angle at half and at the full contact mesh
  density (pin loads, rotation), the mesh-convergence table.

Optional study table ``[fe]`` (all keys optional)::

    [fe]
    bore_radius_mm = 30.0          # bore tied to the rigid centre
    crank_angles_deg = [0.0, 3.0, 6.0]
    elements_per_half_width = 8.0  # contact mesh size b/N
    far_size_mm = 1.5              # mesh size away from the contacts
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import xarray as xr

from cyclomesh.exceptions import StudyError
from cyclomesh.hertz import CONTACT_LAWS
from cyclomesh.study.schema import FeSection, folder_name

__all__ = ["run_fe_study"]

ARCSEC = 180.0 / np.pi * 3600.0


def run_fe_study(
    study_path: Path,
    out: Path,
    crank_angles_deg: list[float] | None = None,
    convergence: bool = True,
    progress=None,
) -> list[Path]:
    """Run ``cyclomesh fe`` on a study file; return the ``fe.nc`` files written."""
    from cyclomesh.fe.disc import solve_disc_fe
    from cyclomesh.study import load_study

    study = load_study(study_path)
    section = study.file.fe or FeSection()
    angles = np.asarray(crank_angles_deg or section.crank_angles_deg, float)
    written = []
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        folder = out / folder_name(case.name)
        folder.mkdir(parents=True, exist_ok=True)
        design, mod = inputs.design, inputs.modification
        if (
            np.any(inputs.errors.radial)
            or np.any(inputs.errors.angular)
            or np.any(inputs.errors.pin_radius)
        ):
            raise StudyError(f"{case.name}: the FE model takes no pin errors yet ([errors])")
        n1 = design.pins
        rows = {k: np.zeros((angles.size, n1)) for k in ("lf", "ll", "sf", "sl")}
        rot = np.zeros((2, angles.size))
        laws = {
            law: (np.zeros((angles.size, n1)), np.zeros((angles.size, n1)), np.zeros(angles.size))
            for law in CONTACT_LAWS
        }
        kw = dict(
            bore_radius=section.bore_radius_mm * 1e-3,
            far_size=section.far_size_mm * 1e-3,
            contact_law=inputs.contact_law,
        )
        for j, phi in enumerate(angles):
            if progress:
                progress(f"{case.name}: crank angle {phi:g}°")
            r = solve_disc_fe(
                design,
                mod,
                inputs.torque,
                np.deg2rad(phi),
                elements_per_half_width=section.elements_per_half_width,
                **kw,
            )
            rows["lf"][j], rows["ll"][j] = r.pin_load_fe, r.pin_load_ltca
            rows["sf"][j], rows["sl"][j] = r.contact_stress_fe, r.contact_stress_ltca
            rot[0, j] = -(r.rest_rotation + r.rotation_fe) * ARCSEC
            rot[1, j] = -(r.rest_rotation + r.rotation_ltca) * ARCSEC
            for law, (load, stress, rotation) in r.ltca_by_law.items():
                laws[law][0][j], laws[law][1][j] = load, stress / 1e6
                laws[law][2][j] = -(r.rest_rotation + rotation) * ARCSEC
            if convergence and j == 0:
                coarse = solve_disc_fe(
                    design,
                    mod,
                    inputs.torque,
                    np.deg2rad(phi),
                    elements_per_half_width=section.elements_per_half_width / 2,
                    **kw,
                )
                _write_convergence(folder / "convergence.csv", section, coarse, r)
        per_law = {}
        for law, (load, stress, rotation) in laws.items():
            per_law[f"pin_load_ltca_{law}"] = (("crank_angle", "pin"), load, {"units": "N"})
            per_law[f"contact_stress_ltca_{law}"] = (
                ("crank_angle", "pin"),
                stress,
                {"units": "MPa"},
            )
            per_law[f"rotation_ltca_{law}"] = ("crank_angle", rotation, {"units": "arcsec"})
        ds = xr.Dataset(
            {
                **per_law,
                "pin_load_fe": (("crank_angle", "pin"), rows["lf"], {"units": "N"}),
                "pin_load_ltca": (("crank_angle", "pin"), rows["ll"], {"units": "N"}),
                "contact_stress_fe": (("crank_angle", "pin"), rows["sf"] / 1e6, {"units": "MPa"}),
                "contact_stress_ltca": (("crank_angle", "pin"), rows["sl"] / 1e6, {"units": "MPa"}),
                "rotation_fe": ("crank_angle", rot[0], {"units": "arcsec"}),
                "rotation_ltca": ("crank_angle", rot[1], {"units": "arcsec"}),
            },
            coords={
                "crank_angle": ("crank_angle", angles, {"units": "deg"}),
                "pin": ("pin", np.arange(1, n1 + 1)),
            },
            attrs={
                "case": case.name,
                "contact_law": inputs.contact_law,
                "bore_radius_mm": section.bore_radius_mm,
                "elements_per_half_width": section.elements_per_half_width,
                "far_size_mm": section.far_size_mm,
                "rotation_convention": "TE convention of Eq. 25: -(rest + loaded rotation)",
            },
        )
        path = folder / "fe.nc"
        ds.to_netcdf(path)
        _figure(ds, folder / "fe.png")
        written.append(path)
    return written


def _write_convergence(path: Path, section: FeSection, coarse, fine) -> None:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "quantity",
                f"N={section.elements_per_half_width / 2:g}",
                f"N={section.elements_per_half_width:g}",
                "relative change",
            ]
        )
        w.writerow(["nodes", coarse.nodes, fine.nodes, ""])
        w.writerow(
            [
                "rotation_arcsec",
                coarse.rotation_fe * ARCSEC,
                fine.rotation_fe * ARCSEC,
                fine.rotation_fe / coarse.rotation_fe - 1,
            ]
        )
        for i in np.flatnonzero(fine.pin_load_fe > 0):
            c, f = coarse.pin_load_fe[i], fine.pin_load_fe[i]
            w.writerow([f"pin_load_{i + 1}_n", c, f, f / c - 1 if c else ""])


def _figure(ds: xr.Dataset, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for k, phi in enumerate(ds.crank_angle.values):
        color = f"C{k}"
        for ax, var in zip(axes, ("pin_load", "contact_stress"), strict=True):
            ax.plot(
                ds.pin, ds[f"{var}_fe"].sel(crank_angle=phi), "o", color=color, label=f"FE {phi:g}°"
            )
            ax.plot(
                ds.pin,
                ds[f"{var}_ltca"].sel(crank_angle=phi),
                "-",
                color=color,
                label=f"LTCA {phi:g}°",
            )
    axes[0].set_ylabel("pin load [N]")
    axes[1].set_ylabel("contact stress [MPa]")
    axes[1].set_xlabel("pin")
    axes[0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
