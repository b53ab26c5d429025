"""Time of the profile export: the whole disc outline at a chord tolerance, and the files.

Table 1 pair of Li et al. (Machines 2022), Δρ = 8 µm: ``disc_outline`` at 1, 0.1 and
0.01 µm (vertices, seconds), with a rotation modification δ = 100 µrad at 0.1 µm, then
``export_profile`` (DXF with polyline and splines, SVG, CSV) at 0.1 µm.

    .venv/bin/python benchmarks/bench_export.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace

from cyclomesh import TABLE1, Modification, disc_outline, export_profile


def best(repeat: int, work) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = work()
        times.append(time.perf_counter() - start)
    return min(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    tpm = Modification(pin_radius=8e-6)
    for tol in (1e-6, 1e-7, 1e-8):
        seconds, outline = best(args.repeat, lambda t=tol: disc_outline(TABLE1, tpm, t))
        print(f"outline at {tol * 1e6:g} µm: {len(outline.x):6d} vertices, {seconds:.3f} s")
    turned = replace(tpm, rotation=100e-6)
    seconds, outline = best(args.repeat, lambda: disc_outline(TABLE1, turned, 1e-7))
    print(f"outline with δ = 100 µrad at 0.1 µm: {len(outline.x):6d} vertices, {seconds:.3f} s")
    with tempfile.TemporaryDirectory() as folder:
        seconds, _ = best(args.repeat, lambda: export_profile(TABLE1, tpm, folder))
    print(f"export_profile (dxf, svg, csv) at 0.1 µm: {seconds:.3f} s")


if __name__ == "__main__":
    main()
