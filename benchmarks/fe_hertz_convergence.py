"""Mesh convergence of the FE contact solver on the Hertz classics (needs the ``fe`` extra).

Run: ``.venv/bin/python benchmarks/fe_hertz_convergence.py`` — prints a Markdown table of the
half-width and peak-pressure errors against Hertz for a cylinder (R = 3.5 mm, steel,
P = 250 N/mm) on a flat and in a seat of radius 1.5 R, at 5 … 40 elements per half-width.
"""

import time

from cyclomesh.fe.hertz_check import cylinder_contact


def main() -> None:
    print("| case | elements on b | nodes | closed nodes | b error | p0 error | time [s] |")
    print("|---|---|---|---|---|---|---|")
    for name, seat in (("flat", None), ("seat 1.5R", 1.5 * 3.5e-3)):
        for n in (5, 10, 20, 40):
            t = time.perf_counter()
            r = cylinder_contact(seat_radius=seat, elements_per_half_width=n)
            dt = time.perf_counter() - t
            print(
                f"| {name} | {n} | {r.nodes} | {r.closed_nodes} | "
                f"{100 * r.half_width_error:+.2f} % | {100 * r.peak_pressure_error:+.2f} % | "
                f"{dt:.1f} |"
            )


if __name__ == "__main__":
    main()
