"""Summarise ``cyclomesh fe`` results: FE against the LTCA with both contact laws.

Run: ``cyclomesh fe examples/fe_table1.toml --out fe-table1``, then
``.venv/bin/python benchmarks/fe_compare.py fe-table1 [--pins]`` (``--pins``: per-pin tables too).
Prints, per case and crank angle, the largest pin load and contact stress and the disc's
loaded position in the TE convention −(φc − φt + Δφc) (the same rest position in all
three), FE and LTCA, and the RMS
difference of the pin loads from FE in % of the FE peak load.
"""

import sys
from pathlib import Path

import numpy as np
import xarray as xr


def main() -> None:
    root = Path(sys.argv[1])
    print(
        "| case | crank [deg] | loaded pins FE/paper/half | max load FE / paper / half_plane [N] "
        "| max stress FE / paper / half_plane [MPa] "
        "| TE-convention position FE / paper / half_plane [arcsec] "
        "| RMS load error paper / half_plane [% of peak] |"
    )
    print("|---|---|---|---|---|---|---|")
    for path in sorted(root.glob("*/fe.nc")):
        ds = xr.load_dataset(path)
        case = ds.attrs.get("case_name", ds.attrs.get("case"))
        for phi in ds.crank_angle.values:
            d = ds.sel(crank_angle=phi)
            fe = d.pin_load_fe.values
            paper, half = d.pin_load_ltca_paper.values, d.pin_load_ltca_half_plane.values
            print(
                f"| {case} | {phi:g} | {(fe > 0).sum()}/{(paper > 0).sum()}/"
                f"{(half > 0).sum()} | {fe.max():.0f} / {paper.max():.0f} / {half.max():.0f} | "
                f"{np.nanmax(d.contact_stress_fe.values):.0f} / "
                f"{d.contact_stress_ltca_paper.values.max():.0f} / "
                f"{d.contact_stress_ltca_half_plane.values.max():.0f} | "
                f"{float(d.rotation_fe):.2f} / {float(d.rotation_ltca_paper):.2f} / "
                f"{float(d.rotation_ltca_half_plane):.2f} | "
                f"{100 * np.sqrt(np.mean((paper - fe) ** 2)) / fe.max():.1f} / "
                f"{100 * np.sqrt(np.mean((half - fe) ** 2)) / fe.max():.1f} |"
            )
    if "--pins" in sys.argv:
        _pin_tables(root)
    conv = sorted(root.glob("*/convergence.csv"))
    for path in conv:
        print(f"\n{path.parent.name}: {path.read_text()}")


def _pin_tables(root: Path) -> None:
    """Per case and crank angle: the loads and stresses of every loaded pin."""
    for path in sorted(root.glob("*/fe.nc")):
        ds = xr.load_dataset(path)
        case = ds.attrs.get("case_name", ds.attrs.get("case"))
        for phi in ds.crank_angle.values:
            d = ds.sel(crank_angle=phi)
            rows = {
                "load FE [N]": d.pin_load_fe,
                "load LTCA paper [N]": d.pin_load_ltca_paper,
                "load LTCA half_plane [N]": d.pin_load_ltca_half_plane,
                "stress FE [MPa]": d.contact_stress_fe,
                "stress LTCA paper [MPa]": d.contact_stress_ltca_paper,
                "stress LTCA half_plane [MPa]": d.contact_stress_ltca_half_plane,
            }
            loaded = np.flatnonzero(sum(np.asarray(v) for v in rows.values()) > 0)
            print(f"\n{case}, crank angle {phi:g}°\n")
            print("| pin | " + " | ".join(str(i + 1) for i in loaded) + " |")
            print("|---|" + "---|" * loaded.size)
            for name, v in rows.items():
                print(f"| {name} | " + " | ".join(f"{x:.0f}" for x in np.asarray(v)[loaded]) + " |")


if __name__ == "__main__":
    main()
