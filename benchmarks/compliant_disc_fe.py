"""The compliant disc against the whole-disc FE: Table 1, 250 N·m, half_plane law.

Solves the whole-disc FE (bore support, b/10 contact mesh, far mesh 2 mm, as
``examples/fe_table1.toml``) at 0°, 3°, 6°, with and without TPM, and the LTCA with the
rigid and with the FE-condensed disc body beside it; prints the table of
``docs/compliant-disc.md`` (needs the fe extra; about 6–10 min on 2 cores).

    .venv/bin/python benchmarks/compliant_disc_fe.py [--cache-dir DIR]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from cyclomesh import TABLE1, Modification
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.fe.disc import solve_disc_fe
from cyclomesh.fe.influence import influence
from cyclomesh.units import ARCSEC_PER_RAD


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache-dir", default=None)
    args = parser.parse_args()
    print(
        '| case | crank | FE rot. ["] | rigid rot. (err.) | fe rot. (err.) | RMS rigid / fe [%] '
        "| peak pin rigid / fe [%] | max load FE / rigid / fe [N] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, mod in (("TPM", Modification(pin_radius=8e-6)), ("no TPM", Modification())):
        start = time.perf_counter()
        body = influence(TABLE1, mod, cache_dir=args.cache_dir)
        coefficients = time.perf_counter() - start
        for deg in (0.0, 3.0, 6.0):
            phi = np.deg2rad(deg)
            fe = solve_disc_fe(TABLE1, mod, 250.0, phi, 30e-3, 10.0, 2e-3, "half_plane")
            load_fe, rot_fe = fe.pin_load_fe, fe.rotation_fe
            peak, at = load_fe.max(), int(np.argmax(load_fe))
            cells = []
            for disc in ("rigid", body):
                r = solve_ltca(TABLE1, mod, None, 250.0, [phi], True, "half_plane", disc)
                load, rot = r.pin_load[0], float(r.loaded_rotation[0])
                both = (load > 0) | (load_fe > 0)
                rms = np.sqrt(np.mean((load - load_fe)[both] ** 2)) / peak * 100
                cells.append(
                    (
                        rot,
                        (rot - rot_fe) / rot_fe * 100,
                        rms,
                        (load[at] - peak) / peak * 100,
                        load.max(),
                    )
                )
            (r0, e0, s0, p0, m0), (r1, e1, s1, p1, m1) = cells
            print(
                f"| {name} | {deg:g}° | {rot_fe * ARCSEC_PER_RAD:.3f} | "
                f"{r0 * ARCSEC_PER_RAD:.3f} ({e0:+.1f} %) | "
                f"{r1 * ARCSEC_PER_RAD:.3f} ({e1:+.1f} %) | "
                f"{s0:.2f} / {s1:.2f} | {p0:+.2f} / {p1:+.2f} | {peak:.0f} / {m0:.0f} / {m1:.0f} |"
            )
        print(f"(coefficients of {name}: {coefficients:.1f} s)")


if __name__ == "__main__":
    main()
