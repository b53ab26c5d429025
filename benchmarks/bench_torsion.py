"""Solving time of a torsion curve: 41 torques × 360 crank angles × 40 pins.

Example design of Table 1 (Li et al., Machines 2022), Δρ = 8 µm, groove deformation on,
rated torque 250 N·m, 41 evenly spaced torques from −250 to +250 N·m (0 left out, ±3 %
added: 42 loaded states), one revolution at 1°, one disc (and a two-disc stack), on one
core. Prints the best and median over the repeats.

    .venv/bin/python benchmarks/bench_torsion.py [--repeat 5] [--discs 1]
"""

from __future__ import annotations

import argparse
import os
import time

# one core: keep BLAS/OpenMP pools from spreading over the machine
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import numpy as np  # noqa: E402

from cyclomesh import TABLE1, Modification  # noqa: E402
from cyclomesh.drive.solve import torsion_curve  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--discs", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()

    phi = np.deg2rad(np.arange(360.0))
    mod = Modification(pin_radius=8e-6)
    for discs in args.discs:

        def run(discs=discs):
            return torsion_curve(TABLE1, mod, None, 250.0, phi, True, discs, 41)

        curve = run()  # warm-up
        times = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            run()
            times.append(time.perf_counter() - start)
        best = min(times)
        states = curve.torque.size * phi.size * TABLE1.pins * discs
        print(
            f"{discs} disc(s): {curve.torque.size} torques x {phi.size} crank angles x "
            f"{TABLE1.pins * discs} pins: best {best:.3f} s, median {np.median(times):.3f} s "
            f"over {args.repeat} runs ({states / best:,.0f} pin-steps/s)"
        )


if __name__ == "__main__":
    main()
