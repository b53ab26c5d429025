"""The compiled pin inversion (cyclomesh.stage.kernel_newton._pin_force, Eq. 20 of Li et
al. 2022: δ = F(α − γ ln F)) against the law itself: Halley's iteration from the
third-order start about a pin's last inversion (its memo), or from the reference's
fixed-point start, ends at the root to round-off, from near and far memos, for the
linear spring and up to the law's reach dmax (half its stiffest point, as the problem's),
and refuses a δ past the stiffest point."""

import numpy as np
import pytest

pytest.importorskip("numba")

import cyclomesh.stage.kernel_newton as kn  # noqa: E402


def _root(delta, a, g):
    """F of δ = F(α − γ ln F) below the stiffest point by Newton in long double (from
    the reference's fixed-point start)."""
    y = np.log(np.longdouble(delta) / a)
    for _ in range(3):
        y = np.log(np.longdouble(delta) / (a - g * y))
    for _ in range(60):
        e = np.exp(y)
        y = y - (e * (a - g * y) - delta) / (e * (a - g - g * y))
    return np.exp(y)


def _force():
    kn._kernels_newton()
    return kn._pin_force


@pytest.mark.parametrize("alpha, gamma", [(2.0e-9, 8.0e-11), (1.6e-9, 1.0e-10), (2.4e-9, 6e-11)])
def test_the_inversion_is_the_root_to_round_off(alpha, gamma):
    force = _force()
    a, g = np.longdouble(alpha), np.longdouble(gamma)
    top = 0.5 * gamma * np.exp(alpha / gamma - 1.0)  # dmax: half the stiffest point
    rng = np.random.default_rng(7)
    worst = 0.0
    for delta in np.concatenate(
        [np.geomspace(1e-9, 0.999 * top, 40), rng.uniform(0, min(top, 1e-4), 20)]
    ):
        ref = _root(delta, a, g)
        # the test's residual 2e-15·δ is a relative error of F of 2e-15·(α − γy)/(α − γ − γy)
        y = np.log(float(ref))
        tol = 2e-15 * (alpha - gamma * y) / (alpha - gamma - gamma * y) + 1e-15
        cold, y = force(delta, alpha, gamma, True, 0.0, 0.0, 0.0)
        assert abs(cold - ref) <= tol * ref and abs(y - np.log(cold)) <= 1e-15 * max(1.0, abs(y))
        # from memos at relative distances from 1e-9 to the window's factor of 2
        for rel in (1e-9, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 0.5, -0.3, -0.49):
            d0 = delta * (1.0 + rel)
            f0 = float(_root(d0, a, g))
            got, y = force(delta, alpha, gamma, True, d0, np.log(f0), f0)
            err = float(abs(got - ref) / ref)
            worst = max(worst, err)
            assert err <= tol, (delta, rel, err)
            assert abs(y - np.log(got)) <= 1e-15 * max(1.0, abs(y))
    assert worst > 0.0


def test_near_the_reach_the_stiffest_point_and_past_it():
    force = _force()
    alpha, gamma = 2.0e-9, 8.0e-11
    top = gamma * np.exp(alpha / gamma - 1.0)  # the stiffest point; the reach is half
    a, g = np.longdouble(alpha), np.longdouble(gamma)
    # below the reach (q = γ/(α − γ − γy) ≤ 0.6: Halley's last step ends the inversion),
    # then up to the stiffest point, where no pin gets (|q| > 10: no last step there)
    for frac, slack in ((0.45, 1.0), (0.495, 1.0), (0.4999, 1.0), (0.99, 10.0), (0.99999, 10.0)):
        delta = frac * top
        ref = _root(delta, a, g)
        y = np.log(float(ref))  # the law's condition number grows there (as above)
        tol = slack * (2e-15 * (alpha - gamma * y) / (alpha - gamma - gamma * y) + 1e-15)
        got, _ = force(delta, alpha, gamma, True, 0.0, 0.0, 0.0)
        assert abs(got - ref) <= tol * ref
        for rel in (-0.3, -1e-3, 1e-6):
            d0 = delta * (1.0 + rel)
            f0 = float(_root(d0, a, g))
            got, _ = force(delta, alpha, gamma, True, d0, np.log(f0), f0)
            assert abs(got - ref) <= tol * ref
    assert force(1.5 * top, alpha, gamma, False, 0.0, 0.0, 0.0)[0] == -1.0  # past it


def test_the_linear_spring():
    force = _force()
    assert force(3e-6, 2e-9, 0.0, False, 0.0, 0.0, 0.0) == (3e-6 / 2e-9, 0.0)
