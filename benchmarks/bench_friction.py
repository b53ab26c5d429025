"""Pin-steps per second of the drive solve with friction against the frictionless one.

Example design of Table 1 (Li et al., Machines 2022), Δρ = 8 µm, groove deformation on,
250 N·m, one revolution at 0.1° (3600 crank angles × 40 pins), one core. Four solves of
:func:`cyclomesh.drive.solve.solve_drive`: frictionless, Coulomb pins (μ = 0.1), Coulomb
pins and crank bearing, and the lubricated (Benedict–Kelley) coefficient; timed
alternately, best of ``--repeat``. The target of issue 25: friction within 1.5× of the
frictionless solve.

    .venv/bin/python benchmarks/bench_friction.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import time

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import numpy as np  # noqa: E402

from cyclomesh import TABLE1, Modification  # noqa: E402
from cyclomesh.core.friction import Friction, Lubricant  # noqa: E402
from cyclomesh.drive.solve import solve_drive  # noqa: E402
from cyclomesh.execution.runtime import tune_allocator  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    tune_allocator()
    phi = np.deg2rad(np.arange(3600) * 0.1)
    mod = Modification(pin_radius=8e-6)
    speed = 2.0 * np.pi * 1500.0 / 60.0
    variants = {
        "frictionless": None,
        "Coulomb pins": Friction(mesh=0.1, groove=0.1, speed=speed),
        "Coulomb pins + bearing": Friction(
            mesh=0.1, groove=0.1, bearing=0.0025, bearing_diameter=0.04, speed=speed
        ),
        "lubricated pins": Friction(
            mesh=0.1, groove=0.1, lubricant=Lubricant(220.0, 19.0, 60.0), speed=speed
        ),
    }
    best = dict.fromkeys(variants, np.inf)
    for _ in range(args.repeat):
        for name, friction in variants.items():
            start = time.perf_counter()
            solve_drive(TABLE1, mod, None, 250.0, phi, friction=friction)
            best[name] = min(best[name], time.perf_counter() - start)
    steps = phi.size * TABLE1.pins
    for name, seconds in best.items():
        ratio = seconds / best["frictionless"]
        print(
            f"{name:24s} {seconds:7.3f} s  {steps / seconds:12.0f} pin-steps/s  "
            f"{ratio:5.2f}x frictionless"
        )


if __name__ == "__main__":
    main()
