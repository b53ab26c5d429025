"""Pin-steps per second of the core solver (one pin at one crank angle, fully solved).

Example design of Table 1 (Li et al., Machines 2022), Δρ = 8 µm, groove deformation on,
250 N·m, one revolution at 0.1° (3600 crank angles × 40 pins), on one core.

    .venv/bin/python benchmarks/bench_core.py [--repeat 7] [--profile] [--disc-body fe]
        [--kernel numpy|numba|both]

``--disc-body fe`` (the fe extra; implies ``--contact-law half_plane``) solves with the
compliant disc: the influence coefficients are computed once (timed, unless already in
the cache) and the revolution is timed as before. ``--kernel`` sets CYCLOMESH_KERNEL
(:mod:`cyclomesh.core.kernel`; ``both``: numpy then numba in one process, with their
ratio and the largest difference of the pin loads). Rates are given per second of wall
time and per CPU-second of the process (``time.process_time``), which other jobs on a
shared machine disturb less.
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
from cyclomesh.core.ltca import solve_ltca  # noqa: E402
from cyclomesh.execution.runtime import tune_allocator  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--profile", action="store_true", help="print where the time goes")
    parser.add_argument(
        "--contact-law", default="half_plane", help='"half_plane" (default) or "paper"'
    )
    parser.add_argument("--disc-body", default="rigid", help='"rigid" or "fe"')
    parser.add_argument("--cache-dir", default=None, help="cache of the FE coefficients")
    parser.add_argument(
        "--no-tune", action="store_true", help="leave glibc's malloc thresholds alone"
    )
    parser.add_argument(
        "--kernel", default=None, help='"numpy", "numba" or "both" (default: CYCLOMESH_KERNEL)'
    )
    args = parser.parse_args()
    if args.kernel == "both":
        rates, loads = {}, {}
        for name in ("numpy", "numba"):
            os.environ["CYCLOMESH_KERNEL"] = name
            print(f"-- kernel {name}")
            rates[name], loads[name] = _bench(args)
        ref = loads["numpy"]
        diff = np.max(np.abs(loads["numba"] - ref)) / np.max(np.abs(ref))
        wall, cpu = (rates["numba"][i] / rates["numpy"][i] for i in (0, 1))
        print(
            f"numba/numpy: {wall:.2f}x ({cpu:.2f}x per CPU-second); pin loads differ by "
            f"{diff:.1e} of the largest"
        )
        return
    if args.kernel is not None:
        os.environ["CYCLOMESH_KERNEL"] = args.kernel
    _bench(args)


def _bench(args):
    if not args.no_tune:
        tune_allocator()  # as every cyclomesh process that solves does

    phi = np.deg2rad(np.arange(3600) * 0.1)
    mod = Modification(pin_radius=8e-6)
    body = "rigid"
    if args.disc_body == "fe":
        from cyclomesh.fe.influence import influence

        args.contact_law = "half_plane"
        start = time.perf_counter()
        body = influence(TABLE1, mod, cache_dir=args.cache_dir)
        print(f"influence coefficients: {time.perf_counter() - start:.3f} s (cache or one-off)")

    def run():
        return solve_ltca(TABLE1, mod, None, 250.0, phi, True, args.contact_law, body)

    run()  # warm-up
    times, cpu = [], []
    for _ in range(args.repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        run()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    best = min(times)
    pin_steps = phi.size * TABLE1.pins
    print(
        f"revolution of {phi.size} steps x {TABLE1.pins} pins: best {best * 1e3:.1f} ms, "
        f"median {np.median(times) * 1e3:.1f} ms over {args.repeat} runs"
    )
    print(
        f"pin-steps per second: {pin_steps / best:,.0f} "
        f"(per CPU-second: {pin_steps / min(cpu):,.0f}, steadier on a shared machine)"
    )
    result = run()
    if args.profile:
        import cProfile
        import pstats

        profiler = cProfile.Profile()
        profiler.runcall(run)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(10)
    return (pin_steps / best, pin_steps / min(cpu)), result.pin_load


if __name__ == "__main__":
    main()
