"""The compiled passes' logarithm, cosine and sine (kernel_contact's fdlibm algorithms
without branches) against NumPy's and the C library's: within one unit in the last place
everywhere, special values as theirs, and in SIMD lanes (issue 27)."""

import math

import numpy as np
import pytest

numba = pytest.importorskip("numba")

from cyclomesh.core import kernel_contact  # noqa: E402

RNG = np.random.default_rng(29)


@pytest.fixture(scope="module")
def loops():
    passes = kernel_contact.compiled()
    jit = numba.njit(error_model="numpy")

    def loop(f):
        @jit
        def run(x, out):
            for i in range(x.size):
                out[i] = f(x[i])

        return lambda x: (lambda out: (run(x, out), out)[1])(np.empty_like(x))

    return {name: loop(getattr(passes, name)) for name in ("log", "cos", "sin")}


def _ulps(got, ref):
    """Largest difference in units of the reference's last place (finite values)."""
    return np.max(np.abs(got - ref) / np.spacing(np.abs(ref)))


def test_log_within_one_ulp_of_numpy_and_libm(loops):
    x = np.concatenate(
        [
            10.0 ** RNG.uniform(-307, 308, 200_000),
            RNG.uniform(0.5, 2.0, 100_000),
            1.0 + RNG.uniform(-1e-6, 1e-6, 10_000),
            RNG.uniform(0, 1e-308, 1000),  # subnormals
        ]
    )
    got = loops["log"](x)
    assert _ulps(got, np.log(x)) <= 1.0
    libm = np.array([math.log(v) for v in x[::20]])
    assert _ulps(got[::20], libm) <= 1.0
    assert np.mean(got == np.log(x)) > 0.9  # mostly the same bits: the same function


def test_log_special_values(loops):
    got = loops["log"](np.array([0.0, -0.0, -1.0, np.inf, -np.inf, np.nan, 1.0, 5e-324]))
    assert got[0] == -np.inf and got[1] == -np.inf
    assert np.isnan(got[2]) and np.isnan(got[4]) and np.isnan(got[5])
    assert got[3] == np.inf and got[6] == 0.0
    assert got[7] == math.log(5e-324)


@pytest.mark.parametrize("name", ["cos", "sin"])
def test_cos_and_sin_within_one_ulp_of_libm(loops, name):
    x = np.concatenate(
        [
            RNG.uniform(-400, 400, 200_000),
            RNG.uniform(-8e5, 8e5, 100_000),
            np.arange(-1000, 1000) * (np.pi / 2),  # next to the zeros: the reduction's test
            RNG.uniform(-1e-8, 1e-8, 1000),
            [0.0, -0.0],
        ]
    )
    got = loops[name](x)
    ref = getattr(np, name)(x)  # NumPy's float64 cos and sin are the C library's
    assert _ulps(got, ref) <= 1.0
    assert np.mean(got == ref) > 0.9


@pytest.mark.parametrize("name", ["log", "cos", "sin"])
def test_a_loop_of_them_runs_in_simd_lanes(name):
    """The point of these functions: a loop that takes them compiles to vector
    instructions (no call to the C library, no branch left in it)."""
    f = getattr(kernel_contact.compiled(), name)

    @numba.njit(error_model="numpy")
    def run(x, out):
        for i in range(x.size):
            out[i] = f(x[i])

    x = np.linspace(0.5, 2.0, 64)
    run(x, np.empty_like(x))
    ir = run.inspect_llvm(run.signatures[0])
    assert "x double>" in ir
    assert f"@llvm.{name}" not in ir and f"@{name}(" not in ir
