"""LTCA of Table 1 with both contact laws (docs/contact-law.md, Evidence 2).

Run: ``.venv/bin/python benchmarks/ltca_laws.py`` — 250 N·m, improved model, crank angles 0–18° at
0.05° (two pin pitches), without and with the TPM (Δρ = 8 µm); prints a Markdown table.
"""

import numpy as np

from cyclomesh import TABLE1, Modification, solve_ltca

ARCSEC = 180.0 / np.pi * 3600.0


def main() -> None:
    phi = np.deg2rad(np.arange(0.0, 18.0, 0.05))
    rows = {}
    for name, mod in (("no TPM", None), ("TPM", Modification(pin_radius=8e-6))):
        for law in ("paper", "half_plane"):
            r = solve_ltca(TABLE1, mod, torque=250.0, crank_angles=phi, contact_law=law)
            rows[f"{law}, {name}"] = (
                r.pin_load.max(),
                r.contact_stress.max() / 1e6,
                np.ptp(r.transmission_error) * ARCSEC,
                np.abs(np.diff(r.pin_load, axis=0)).max(),
            )
    print("| | " + " | ".join(rows) + " |")
    print("|---" * (len(rows) + 1) + "|")
    labels = (
        "max pin load [N]",
        "max contact stress [MPa]",
        "TE peak-to-peak [arcsec]",
        "largest load jump between 0.05° steps [N]",
    )
    for k, label in enumerate(labels):
        print(f"| {label} | " + " | ".join(f"{v[k]:.3g}" for v in rows.values()) + " |")


if __name__ == "__main__":
    main()
