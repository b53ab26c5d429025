"""Before/after check of the compliant-disc solver: results saved once, compared later.

Solves Table 1 with the FE disc body (bore support, the ``fe`` extra; the coefficients
come from the cache, ``CYCLOMESH_CACHE_DIR`` or ``--cache-dir``) with and without TPM:
one revolution of the forward flank (:func:`solve_ltca`), both flanks (:func:`solve_drive`,
±250 N·m), a two-disc stack, a torsion curve, and rings with pin errors; every array of
every result is saved to (``--save``) or compared with (``--compare``) an ``.npz`` file.

    .venv/bin/python benchmarks/discbody_regression.py --save /tmp/before.npz     # old code
    .venv/bin/python benchmarks/discbody_regression.py --compare /tmp/before.npz  # new code

Used to show that a change to :mod:`cyclomesh.core.discbody` that only makes it faster
computes the same results to round-off (it prints the largest relative difference of
each array, relative to the array's largest magnitude).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from cyclomesh import TABLE1, Modification
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.core.pair import PinErrors
from cyclomesh.drive.solve import solve_drive, torsion_curve


def results(cache_dir: str | None) -> dict[str, np.ndarray]:
    from cyclomesh.fe.influence import influence

    out: dict[str, np.ndarray] = {}
    phi = np.deg2rad(np.arange(3600) * 0.1)
    coarse = phi[::20]
    rng = np.random.default_rng(17)
    errors = PinErrors(angular=rng.normal(0.0, 2e-5, (3, TABLE1.pins)))
    for name, mod in (("tpm", Modification(pin_radius=8e-6)), ("notpm", Modification())):
        body = influence(TABLE1, mod, cache_dir=cache_dir)
        runs = {
            "ltca": solve_ltca(TABLE1, mod, None, 250.0, phi, True, "half_plane", body),
            "flanks": solve_drive(
                TABLE1, mod, None, [-250.0, 250.0], coarse, True, 1, "half_plane", body
            ),
            "stack": solve_drive(
                TABLE1, mod, None, [-250.0, 40.0, 250.0], coarse, True, 2, "half_plane", body
            ),
            "errors": solve_ltca(TABLE1, mod, errors, 250.0, coarse, True, "half_plane", body),
            "curve": torsion_curve(
                TABLE1, mod, None, 250.0, coarse[:12], True, 2, 11, None, "half_plane", body
            ),
        }
        for run, res in runs.items():
            for field in dataclasses.fields(res):
                value = getattr(res, field.name)
                if isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
                    out[f"{name}/{run}/{field.name}"] = value
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", metavar="NPZ")
    group.add_argument("--compare", metavar="NPZ")
    parser.add_argument("--cache-dir", default=None)
    parser.add_argument("--rtol", type=float, default=1e-12)
    args = parser.parse_args()
    new = results(args.cache_dir)
    if args.save:
        np.savez(args.save, **new)
        print(f"saved {len(new)} arrays to {args.save}")
        return
    old = dict(np.load(args.compare))
    assert sorted(old) == sorted(new), "different sets of arrays"
    worst = 0.0
    for key in sorted(old):
        a, b = old[key], new[key]
        assert a.shape == b.shape, key
        same_inf = np.array_equal(np.isfinite(a), np.isfinite(b))
        fin = np.isfinite(a) & np.isfinite(b)
        scale = np.max(np.abs(a[fin]), initial=0.0)
        diff = np.max(np.abs(a[fin] - b[fin]), initial=0.0)
        rel = diff / scale if scale > 0 else diff
        worst = max(worst, rel if same_inf else np.inf)
        flag = "" if same_inf and rel <= args.rtol else "   <-- DIFFERS"
        print(f"{key:42s} {rel:10.2e}{'' if same_inf else ' (inf/nan pattern)'}{flag}")
    print(f"largest relative difference: {worst:.2e} (tolerance {args.rtol:.0e})")
    raise SystemExit(0 if worst <= args.rtol else 1)


if __name__ == "__main__":
    main()
