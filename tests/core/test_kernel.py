"""The compiled load-sharing kernel (numba) against the NumPy reference (issue 27).

Both kernels solve the same equations to round-off; they differ in the last bits of the
libm calls (NumPy's SIMD exp and log are not glibc's), so the comparison is to 1e-13 of
each field's largest value. Elementwise, a pin just engaging (Δφc − φbl ≪ Δφc) carries a
load whose relative error is that of Δφc times Δφc/(Δφc − φbl) (≈ 400 for a pin at 1e-3
of the peak load; its pressure, ∝ √F, more): the per-pin fields are held to 1e-13 of
their largest value, the rotations and the transmission error to 1e-13 elementwise.
"""

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification
from cyclomesh.core import hertz, kernel
from cyclomesh.core.contact import unloaded_contact
from cyclomesh.core.discbody import DiscBody
from cyclomesh.core.fields import contact_stresses
from cyclomesh.core.ltca import pin_compliance, rest_position, solve_ltca
from cyclomesh.core.pair import PinErrors
from cyclomesh.drive.solve import solve_drive
from cyclomesh.exceptions import ConvergenceError, DesignError
from cyclomesh.stage import RollerSet, StageDesign, solve_stage
from tests.stage.rv40 import HOLES, RV40

pytest.importorskip("numba")

MOD = Modification(pin_radius=8e-6)
PHI = np.deg2rad(np.arange(0.0, 360.0, 1.5))
RNG = np.random.default_rng(27)
ERRORS = PinErrors(
    radial=RNG.uniform(-4e-6, 4e-6, (3, 40)), angular=RNG.uniform(-5e-5, 5e-5, (3, 40))
)


def _both(monkeypatch, solve):
    out = {}
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = solve()
    return out["numpy"], out["numba"]


def _agree(ref, got, fields):
    for name in fields:
        a, b = np.asarray(getattr(ref, name)), np.asarray(getattr(got, name))
        assert a.shape == b.shape, name
        fin = np.isfinite(a)
        assert np.array_equal(fin, np.isfinite(b)), name
        a, b = a[fin], b[fin]
        scale = np.max(np.abs(a))
        assert np.max(np.abs(a - b)) <= 1e-13 * scale, name
        if name in ("loaded_rotation", "transmission_error", "torque_share"):
            assert np.all(np.abs(a - b) <= 1e-13 * np.abs(a)), name  # elementwise


LTCA_FIELDS = (
    "pin_load",
    "groove_load",
    "contact_stress",
    "groove_stress",
    "loaded_rotation",
    "transmission_error",
    "gear_ratio",
    "overlap",
    "contacts",
)


@pytest.mark.parametrize("law", ["half_plane", "paper"])
@pytest.mark.parametrize("groove", [True, False])
def test_ltca_kernels_agree_on_both_laws_with_pin_errors(monkeypatch, law, groove):
    ref, got = _both(monkeypatch, lambda: solve_ltca(TABLE1, MOD, ERRORS, 250.0, PHI, groove, law))
    _agree(ref, got, LTCA_FIELDS)
    # the kernel's solution is an equilibrium in its own right
    share = np.sum(got.pin_load * got.moment_arm, axis=-1)
    np.testing.assert_allclose(share, 250.0, rtol=1e-12)


def test_stacks_and_both_flanks_agree(monkeypatch):
    ref, got = _both(
        monkeypatch,
        lambda: solve_drive(TABLE1, MOD, ERRORS, [-250.0, 100.0, 250.0], PHI[::4], True, 2),
    )
    _agree(
        ref,
        got,
        (
            "pin_load",
            "contact_stress",
            "transmission_error",
            "torque_share",
            "mesh_force",
            "force_angle",
            "loaded_rotation",
        ),
    )


def _synthetic_body():
    """A reciprocal, positive-definite influence table (as tests/core/test_discbody.py)."""
    n2 = TABLE1.teeth
    u = np.linspace(-np.pi, 0.0, 13)
    arm = 0.05 * np.abs(np.sin(u)) + 0.01
    d = np.arange(n2)
    dist = np.minimum(d, n2 - d)
    local = 3e-10 * np.exp(-dist)[:, None, None] * np.exp(-((u[:, None] - u[None, :]) ** 2))
    web = 1e-7 * arm[:, None] * arm[None, :]
    return DiscBody(u, (local + web[None])[None], n2)


def test_compliant_disc_agrees(monkeypatch):
    body = _synthetic_body()
    ref, got = _both(
        monkeypatch,
        lambda: solve_ltca(TABLE1, MOD, None, 250.0, PHI[:24], True, "half_plane", body),
    )
    _agree(ref, got, ("pin_load", "contact_stress", "loaded_rotation", "transmission_error"))


def test_stage_agrees(monkeypatch):
    rollers = RollerSet(
        rollers=14, diameter=4e-3, length=9e-3, clearance=5e-6, pitch_diameter=22e-3
    )
    mod = Modification(pin_radius=3e-6)
    ref, got = _both(
        monkeypatch,
        lambda: solve_stage(
            RV40, StageDesign(HOLES, rollers), mod, None, (-412.0, 412.0), PHI[::8], discs=2
        ),
    )
    _agree(ref, got, ("pin_load", "transmission_error", "bearing_load"))


def test_failures_are_the_reference_errors(monkeypatch):
    """A case the kernel cannot finish goes to the reference, which raises its error."""
    messages = []
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        with pytest.raises(ConvergenceError) as info:
            solve_ltca(TABLE1, MOD, None, 5e6, PHI[:4], True, "half_plane")
        messages.append(str(info.value))
    assert messages[0] == messages[1] and "torque too large" in messages[0]


def test_switch_refuses_an_unknown_kernel_in_one_line(monkeypatch):
    monkeypatch.setenv(kernel.ENV_VAR, "fortran")
    with pytest.raises(
        ValueError, match=r"^CYCLOMESH_KERNEL='fortran': expected one of numpy, numba"
    ):
        solve_ltca(TABLE1, MOD, None, 250.0, PHI[:4])
    monkeypatch.delenv(kernel.ENV_VAR)
    assert kernel.kernel_name() == "numpy"  # the reference is the default


def test_numba_solves_without_the_reference(monkeypatch):
    """The compiled path does the work itself: the reference is not called."""

    def refuse(*args, **kwargs):
        raise AssertionError("fell back to the NumPy reference")

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    monkeypatch.setattr(kernel.loadsharing, "share_load", refuse)
    got = solve_ltca(TABLE1, MOD, ERRORS, 250.0, PHI, True, "paper")
    np.testing.assert_allclose(np.sum(got.pin_load * got.moment_arm, axis=-1), 250.0, rtol=1e-12)
    # a tolerance study's rings at a 10° step: the inversions start from the angle
    # before, 10° away, from where Newton may cross the stiffest point of the law
    rng = np.random.default_rng(7)
    rings = PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, (400, 40)), angular=rng.uniform(-5e-5, 5e-5, (400, 40))
    )
    got = solve_ltca(TABLE1, MOD, rings, 250.0, np.deg2rad(np.arange(0.0, 360.0, 10.0)))
    np.testing.assert_allclose(np.sum(got.pin_load * got.moment_arm, axis=-1), 250.0, rtol=1e-12)


def test_the_kernel_keeps_the_reference_constants():
    from cyclomesh.core import hertz, loadsharing

    assert kernel._MAX_ITERATIONS == loadsharing._MAX_ITERATIONS
    assert (kernel._MAX_NEWTON, kernel._ROUND_OFF) == (hertz._MAX_NEWTON, hertz._ROUND_OFF)


CONTACT_FIELDS = (
    "rotation",
    "reverse_rotation",
    "moment_arm",
    "profile_angle",
    "pin_radius",
    "residual",
)
ROUNDED_FIELDS = ("cos_beta", "contact_radius", "curvature_radius")
"""Fields of a cosine or a square root of a sum of squares (kernel_math's cosine, √ for
hypot): to one or two units in the last place, the curvature radius to 1e-14 of itself
(its denominator cancels near an inflection, which amplifies the last bit of cos n2·t;
there the pass takes the C library's cosine, kernel_contact._INFLECTION)."""


@pytest.mark.parametrize(
    "mod, errors",
    [
        (MOD, None),
        (
            Modification(pin_radius=8e-6, pin_circle_radius=-5e-6, rotation=2e-4),
            PinErrors(
                radial=ERRORS.radial,
                angular=ERRORS.angular,
                eccentricity=RNG.uniform(-3e-6, 3e-6, 3),
            ),
        ),
    ],
)
def test_the_compiled_contact_gives_the_reference_bits(monkeypatch, mod, errors):
    """The contact rotations set the pin loads to 1e-11 per unit in their last bit, so the
    compiled passes must reproduce them exactly: the rotations, moment arms and profile
    angles bit for bit, cos β, the contact and the curvature radius (kernel_math's cosine,
    √ for hypot, NumPy's power of 3/2 is not the C library's) to a few units in the last place,
    the flank normals (the reference takes arg n and arg P_s again from cos and sin of
    φ1 = −arccos c, the kernel from c itself) to round-off: unit vectors, within 1e-13
    of 1 (the arccos near a tooth-space bottom, c → 1, amplifies the last bit of c)."""
    ref, got = _both(monkeypatch, lambda: unloaded_contact(TABLE1, mod, errors, PHI, normals=True))
    for name in CONTACT_FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
    for name in ROUNDED_FIELDS:
        a, b = getattr(ref, name), getattr(got, name)
        np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b), err_msg=name)
        a, b = a[np.isfinite(a)], b[np.isfinite(a)]
        # the curvature radius elementwise: next to an inflection the pass takes the C
        # library's cosine, elsewhere one ulp of it moves ρc by at most 32 ulps
        np.testing.assert_allclose(
            b, a, rtol=1e-14 if name == "curvature_radius" else 1e-15, err_msg=name
        )
    for name in ("normal_x", "normal_y"):
        a, b = getattr(ref, name), getattr(got, name)
        assert np.max(np.abs(a - b)) <= 1e-13, name
        assert np.mean(a == b) > 0.5, name  # most to the bit: the same angle, not a new one
    np.testing.assert_allclose(np.hypot(got.normal_x, got.normal_y), 1.0, rtol=1e-15)
    tip = ref.profile_angle == -np.pi  # at a tip or unreachable: the reference's bits,
    # which decide ±π of the force angle
    np.testing.assert_array_equal(got.normal_x[tip], ref.normal_x[tip])
    np.testing.assert_array_equal(got.normal_y[tip], ref.normal_y[tip])
    assert np.isinf(ref.rotation).any()  # the tip pins: unreachable in both


def test_the_compiled_contact_refuses_as_the_reference(monkeypatch):
    """A jammed pin: the compiled pass hands the case back and the reference raises."""
    jam = PinErrors(pin_radius=np.where(np.arange(40) == 3, 20e-6, 0.0))
    messages = []
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        with pytest.raises(DesignError) as info:
            unloaded_contact(TABLE1, MOD, jam, PHI)
        messages.append(str(info.value))
    assert messages[0] == messages[1] and "pin 4 overlaps" in messages[0]


@pytest.mark.parametrize("law", ["half_plane", "paper"])
@pytest.mark.parametrize("groove", [True, False])
def test_the_compiled_compliance_and_stresses_follow_the_reference(monkeypatch, law, groove):
    """The compliance: the same formulas in the same order (the logarithms may differ in
    their last bit); the stresses: the same quantities with the pin's terms taken once
    per pin (a few units in the last place), to 1e-13 of the largest (the kernel's bar)."""
    geo = unloaded_contact(TABLE1, MOD, ERRORS, PHI)
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    ref = pin_compliance(geo, TABLE1, groove, law)
    force = np.where(np.isfinite(geo.rotation), RNG.uniform(0.0, 3e3, geo.rotation.shape), 0.0)
    ref_stress = contact_stresses(geo, TABLE1, force)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    got = pin_compliance(geo, TABLE1, groove, law)
    got_stress = contact_stresses(geo, TABLE1, force)
    for a, b in zip(ref, got, strict=True):
        assert a.shape == b.shape
        np.testing.assert_allclose(b, a, rtol=2e-15)  # inf (paper law, unreachable) alike
    for a, b in zip(ref_stress, got_stress, strict=True):
        assert np.all((b == 0.0) == (a == 0.0))  # an unloaded pin: none
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-13 * np.max(a))


def test_the_compiled_contact_keeps_the_reference_constants():
    from cyclomesh.core import contact, kernel_contact

    assert kernel_contact._TOLERANCE == contact.CONTACT_TOLERANCE
    assert kernel_contact._MAX_ITERATIONS == contact._MAX_ITERATIONS


def test_the_compiled_mod_2pi_is_numpys():
    """The wrap of the contact rotations (np.mod(x, 2π)) bit for bit, sign of zero
    included, on and next to every multiple of 2π up to ±8π and beyond."""
    from cyclomesh.core import kernel_contact

    kernel_contact.compiled()  # compiles _mod_2pi in place
    two_pi = 2.0 * np.pi
    k = np.arange(-10, 11) * two_pi
    x = np.concatenate(
        [RNG.uniform(-70.0, 70.0, 20_000), k, np.nextafter(k, np.inf), np.nextafter(k, -np.inf)]
    )
    got = np.array([kernel_contact._mod_2pi(v) for v in x])
    ref = np.mod(x, two_pi)
    np.testing.assert_array_equal(got, ref)
    assert np.array_equal(np.signbit(got), np.signbit(ref))


def test_the_force_angle_of_a_tip_pin_on_the_x_axis_is_the_references(monkeypatch):
    """Pin 1 at crank angle 180° sits at a tooth tip on the x-axis, out of reach with
    Δρ = 8 µm and just reached without: its normal is along −x, and the last bits of
    sin(−π) decide whether its force angle reads +180° or −180° (they did differ while
    the kernel took sin φ1 = −√(1 − c²) = 0 there)."""
    angles = np.deg2rad([0.0, 90.0, 180.0, 270.0])
    for mod in (MOD, Modification()):
        ref, got = _both(
            monkeypatch, lambda mod=mod: solve_drive(TABLE1, mod, None, 250.0, angles, discs=2)
        )
        assert np.max(np.abs(got.force_angle - ref.force_angle)) <= 1e-13  # not 2π apart


def test_a_rings_bits_do_not_depend_on_its_batch(monkeypatch):
    """The compiled load sharing starts from the crank angles before, within a ring
    only: a ring solved alone or with others, one disc or a stack, gives the same bits
    (docs/pipeline.md, reproducibility)."""
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    batch = solve_ltca(TABLE1, MOD, ERRORS, 250.0, PHI)
    stack = solve_drive(TABLE1, MOD, ERRORS, 250.0, PHI, discs=2)
    for r in range(ERRORS.radial.shape[0]):
        ring = PinErrors(radial=ERRORS.radial[r], angular=ERRORS.angular[r])
        alone = solve_ltca(TABLE1, MOD, ring, 250.0, PHI)
        np.testing.assert_array_equal(alone.pin_load, batch.pin_load[r])
        np.testing.assert_array_equal(alone.loaded_rotation, batch.loaded_rotation[r])
        two = solve_drive(TABLE1, MOD, ring, 250.0, PHI, discs=2)
        np.testing.assert_array_equal(two.pin_load, stack.pin_load[r])
    # and the angles before matter only to round-off: every angle solved on its own
    single = [solve_ltca(TABLE1, MOD, None, 250.0, PHI[k : k + 1]) for k in range(0, PHI.size, 17)]
    whole = solve_ltca(TABLE1, MOD, None, 250.0, PHI)
    for k, one in zip(range(0, PHI.size, 17), single, strict=True):
        np.testing.assert_allclose(one.pin_load[0], whole.pin_load[k], rtol=0, atol=1e-13 * 3e3)


@pytest.mark.parametrize("law", ["half_plane", "paper"])
def test_the_warm_start_reaches_the_roots_of_the_cold_one_and_the_reference(monkeypatch, law):
    """Each crank angle after a ring's first starts from the roots of the angles before,
    extrapolated; Newton's method run to round-off makes the start irrelevant: the same
    rotations and loads as each angle started from the single-pin bound (``angle_axis``
    False) and as the reference, also where the angles jump (the extrapolation far off,
    from either side of the root)."""
    phi = np.deg2rad([0.0, 0.1, 0.2, 0.3, 47.0, 47.1, 200.0, 200.05, 200.1, 359.9, 1.0])
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")  # the same inputs for all three
    geo = unloaded_contact(TABLE1, MOD, ERRORS, np.sort(phi))
    backlash = geo.rotation - rest_position(geo.rotation, geo.moment_arm)[..., None]
    alpha, gamma = pin_compliance(geo, TABLE1, True, law)
    problem = (backlash, geo.moment_arm, alpha, gamma, 250.0)
    ref_rot, ref_force = kernel.share_load(*problem)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    warm_rot, warm_force = kernel.share_load(*problem, angle_axis=True)
    cold_rot, cold_force = kernel.share_load(*problem)
    top = np.max(ref_force)
    np.testing.assert_allclose(warm_rot, cold_rot, rtol=1e-14, atol=0)
    np.testing.assert_allclose(warm_force, cold_force, rtol=0, atol=1e-14 * top)
    np.testing.assert_allclose(warm_rot, ref_rot, rtol=1e-13, atol=0)
    np.testing.assert_allclose(warm_force, ref_force, rtol=0, atol=1e-13 * top)


@pytest.mark.parametrize("block", [1, 7 * 40, 97 * 40, 10**6])
def test_the_contact_blocks_change_no_bit(monkeypatch, block):
    """The compiled contact in blocks of crank angles (kernel_contact.BLOCK_CONTACTS),
    sizes that divide the rings × angles or not, one row or all at once: every field the
    same bits as the default block, three rings with errors, with normals."""
    from cyclomesh.core import kernel_contact

    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    phi = np.deg2rad(np.arange(0.0, 360.0, 0.7))  # 515 angles × 3 rings
    ref = unloaded_contact(TABLE1, MOD, ERRORS, phi, normals=True)
    monkeypatch.setattr(kernel_contact, "BLOCK_CONTACTS", block)
    got = unloaded_contact(TABLE1, MOD, ERRORS, phi, normals=True)
    for name in (*CONTACT_FIELDS, *ROUNDED_FIELDS, "normal_x", "normal_y"):
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)


def test_the_curvature_radius_next_to_an_inflection_keeps_the_references_bits(monkeypatch):
    """A pin driven to a pole of ρc (bisection on the crank angle for 1/ρc = 0), and
    crank angles around it, where the denominator of ρc cancels: every ρc within 1e-14
    of the reference's (the compiled pass takes the C library's cosine there,
    kernel_contact._INFLECTION; the case that showed the need, section42's Case 3 with its
    random pin errors at 7e-12 of the field's scale, is checked by the baseline
    comparison: this revolution does not meet a last-bit difference of the cosine)."""
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    phi = np.deg2rad(np.arange(0.0, 10.0, 0.1))
    rho = unloaded_contact(TABLE1, MOD, None, phi).curvature_radius
    k, pin = np.unravel_index(np.argmax(np.where(np.isfinite(rho), np.abs(rho), 0)), rho.shape)

    def inverse(x):  # 1/ρc of the pin at crank angle x
        return 1.0 / unloaded_contact(TABLE1, MOD, None, [x]).curvature_radius[0, pin]

    lo, hi = phi[max(k - 1, 0)], phi[min(k + 1, phi.size - 1)]
    assert inverse(lo) * inverse(hi) < 0  # an inflection between
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inverse(lo) * inverse(mid) <= 0 else (mid, hi)
    near = lo + np.arange(-500, 501) * 1e-7
    ref, got = _both(monkeypatch, lambda: unloaded_contact(TABLE1, MOD, None, near))
    a, b = ref.curvature_radius[:, pin], got.curvature_radius[:, pin]
    assert np.max(np.abs(a)) > 1e3 * np.median(np.abs(rho[np.isfinite(rho)]))
    np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b))
    fin = np.isfinite(a)
    np.testing.assert_allclose(b[fin], a[fin], rtol=1e-14)


def _ring_problem(monkeypatch, rings, step_deg, law="half_plane", seed=32):
    """The load sharing's inputs of ``rings`` tolerance rings (the pin errors of
    examples/tolerance.toml) at a crank step of ``step_deg``, from the NumPy contact."""
    rng = np.random.default_rng(seed)
    errors = PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, (rings, 40)),
        angular=rng.uniform(-5e-5, 5e-5, (rings, 40)),
    )
    monkeypatch.setenv(kernel.ENV_VAR, "numpy")
    geo = unloaded_contact(TABLE1, MOD, errors, np.deg2rad(np.arange(0.0, 360.0, step_deg)))
    backlash = geo.rotation - rest_position(geo.rotation, geo.moment_arm)[..., None]
    alpha, gamma = pin_compliance(geo, TABLE1, True, law)
    return backlash, geo.moment_arm, alpha, gamma, 250.0


@pytest.mark.parametrize("law", ["half_plane", "paper"])
def test_the_secant_start_reaches_the_references_roots(monkeypatch, law):
    """At a 10° crank step (a tolerance study's 36 steps) the roots before are too far
    apart to extrapolate and each crank angle starts from the secant start
    (kernel._secant_start), as does a ring's first angle and every angle solved on its
    own: the roots and loads of the reference to round-off, each way."""
    problem = _ring_problem(monkeypatch, 12, 10.0, law)
    ref_rot, ref_force = kernel.share_load(*problem)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    monkeypatch.setattr(kernel.loadsharing, "share_load", None)  # no fallback taken
    top = np.max(ref_force)
    for angle_axis in (True, False):
        rot, force = kernel.share_load(*problem, angle_axis=angle_axis)
        np.testing.assert_allclose(rot, ref_rot, rtol=1e-13, atol=0)
        np.testing.assert_allclose(force, ref_force, rtol=0, atol=1e-13 * top)


def test_the_secant_start_is_near_the_root_and_keeps_within_reach(monkeypatch):
    """The secant start of a 10° case lies within 1e-2·T of the root in torque (about
    3e-4·T typically), whatever the case before; where the springs' root lies beyond the
    warm start's reach (pins outside the candidates could carry load there) the start
    given is kept."""
    bl, arm, alpha, gamma, torque = _ring_problem(monkeypatch, 3, 10.0)
    bl, arm, alpha, gamma = (
        np.ascontiguousarray(v).reshape(-1, 40) for v in (bl, arm, alpha, gamma)
    )
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    assert kernel._compiled() is not None
    n_pins = 40
    scratch = [np.empty(n_pins, np.int64), np.empty(n_pins)] + [np.zeros(n_pins) for _ in range(4)]
    worst = 0.0
    for k in range(bl.shape[0]):
        candidates = np.empty(n_pins, np.int64)
        n_cand = kernel._usable(k, bl, arm, candidates)
        x = kernel._secant_start(
            k, np.nan, np.inf, candidates, n_cand, bl, arm, alpha, gamma, torque, *scratch
        )
        loaded = np.isfinite(bl[k]) & (x > bl[k])
        approach = (x - bl[k][loaded]) * arm[k][loaded]
        force = hertz.force_from_approach(approach, alpha[k][loaded], gamma[k][loaded])
        worst = max(worst, abs(np.sum(force * arm[k][loaded]) - torque) / torque)
        # a reach below the springs' root: the start given is kept
        kept = kernel._secant_start(
            k, 1.25, 0.5 * x, candidates, n_cand, bl, arm, alpha, gamma, torque, *scratch
        )
        assert kept == 1.25
    assert worst < 1e-2, worst


def test_a_rings_bits_do_not_depend_on_its_batch_at_a_10_degree_step(monkeypatch):
    """The secant start depends on the case alone and the pins' last inversions on the
    ring's cases before: a ring solved alone or in a batch gives the same bits."""
    bl, arm, alpha, gamma, torque = _ring_problem(monkeypatch, 4, 10.0)
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    rot, force = kernel.share_load(bl, arm, alpha, gamma, torque, angle_axis=True)
    for r in range(bl.shape[0]):
        one_rot, one_force = kernel.share_load(
            bl[r], arm[r], alpha[r], gamma[r], torque, angle_axis=True
        )
        np.testing.assert_array_equal(one_rot, rot[r])
        np.testing.assert_array_equal(one_force, force[r])
