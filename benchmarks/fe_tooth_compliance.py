"""Tooth compliance along the profile of Table 1 by FE, against the contact laws.

Run: ``.venv/bin/python benchmarks/fe_tooth_compliance.py [--far-size-mm 1.0]`` (needs the ``fe``
extra; about 20 s an angle here). One steel pin pressed with 4e4 N/m (480 N on the
12 mm face) onto the disc of Table 1 with its TPM (Δρ = 8 µm), bore of 30 mm fixed; the
disc's approach at the contact centre over the load, per unit face width, against the
disc term of Eq. 20 ("paper") and of the half-plane law (d = contact radius, and
d = contact radius − bore radius). Prints a Markdown table.
"""

import argparse
import time

import numpy as np

from cyclomesh import TABLE1, Modification
from cyclomesh.fe.tooth import tooth_compliance


def inflection_deg(design, modification) -> float:
    """φ1 of the inflection point on the loaded flank (denominator of Eq. 4 = 0) [deg]."""
    a = design.pin_circle_radius + modification.pin_circle_radius
    e, n1 = design.eccentricity, design.pins
    return -float(np.degrees(np.arccos((e * e * n1**3 + a * a) / (e * n1 * (1 + n1) * a))))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--far-size-mm", type=float, default=1.0)
    parser.add_argument("--elements", type=float, default=8.0)
    args = parser.parse_args()
    mod = Modification(pin_radius=8e-6)
    infl = inflection_deg(TABLE1, mod)
    angles = [-150, -120, -90, -70, -55, -47, infl, -36, -30, -20, -10]
    t = time.perf_counter()
    r = tooth_compliance(
        TABLE1, mod, angles, elements_per_half_width=args.elements, far_size=args.far_size_mm * 1e-3
    )
    dt = time.perf_counter() - t
    unit = 1e-12  # m²/N  (= µm per N/mm)
    print(f"far mesh {args.far_size_mm} mm, {args.elements} elements on b, {dt:.0f} s")
    print(
        "| φ1 [deg] | ρc [mm] | FE | paper (Eq. 20) | half-plane d=r | half-plane d=r−r_b "
        "| paper/FE | half-plane/FE | b FE/Hertz | p0 FE/Hertz |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for i, phi in enumerate(r.profile_angle_deg):
        print(
            f"| {phi:.2f} | {r.curvature_radius[i] * 1e3:.4g} | {r.fe[i] / unit:.3f} | "
            f"{r.paper[i] / unit:.3f} | {r.half_plane[i] / unit:.3f} | "
            f"{r.half_plane_bore[i] / unit:.3f} | {r.paper[i] / r.fe[i]:.3f} | "
            f"{r.half_plane[i] / r.fe[i]:.3f} | "
            f"{r.half_width_fe[i] / r.half_width_hertz[i]:.3f} | "
            f"{r.peak_pressure_fe[i] / r.peak_pressure_hertz[i]:.3f} |"
        )
    print("compliances per unit face width in 1e-12 m²/N (µm per N/mm)")


if __name__ == "__main__":
    main()
