"""Compiled (numba) passes of the pin-step around the load sharing: the unloaded contact,
the compliance of the contact law and the contact stresses (issue 27).

Each pass is the NumPy reference's formula, element by element in one loop over rings,
crank angles and pins, with no temporaries: :func:`cyclomesh.core.contact.unloaded_contact`
(the undeviated profile, Eqs. 5–11 of [1]), :func:`cyclomesh.core.hertz.compliance_coefficients`
(Eqs. 19–23 and the half-plane law) and :func:`cyclomesh.core.fields.contact_stresses`
(Eqs. 18, 24). Additions, products, quotients and square roots are written in the
reference's order and rounded alike (IEEE, no contraction into fused multiply-adds), so
they give its bits; the stresses alone take the pin's terms once per pin (a few units in
their last place of the reference's, :func:`_stresses`). The contact rotations are
differences of angles of order π whose last bit moves the pin loads by about 1e-11 of
their size (a pin's approach is about 1e-4 rad of disc rotation), so the inverse
trigonometric functions there (arccos of the tooth phase, the arctangents of the pin
centre and of the normal) are taken by NumPy between two compiled passes, on the same
arrays as the reference: NumPy's SIMD arccos and arctan2 differ from the C library's in
the last bit. The cosines (cos β, the
curvature radius's cos n2·t, the normals' cos and sin) and the logarithms of the
compliance are this module's own, FreeBSD msun's algorithms without branches
(:func:`_log`, :func:`_cos`, :func:`_sin`, below one unit in the last place like the C
library's and NumPy's, but inlined, so that the loops run in SIMD lanes), hypot is √ of
the sum of squares, the power 3/2 √q·q and the compliance's logarithms of quotients
differences of logarithms: these move cos β, the contact and curvature radii, α and the
pin loads in their last bits (about 1e-16 of their size; the curvature radius by up to
1e-14 of itself: next to an inflection, where its denominator cancels, a pin is finished
again with the C library's cosine, :data:`_INFLECTION`); the rotations, moment arms and
profile angles keep the reference's bits.

The contact runs in blocks of :data:`BLOCK_CONTACTS` contacts (crank angles of a ring ×
pins): the phase pass, NumPy's arctangents and arccos and the finishing pass on one
block's intermediates (64 KiB arrays, reused), the results written in place. Measured on
the bench (3,600 × 40, a machine with a 300 MB last-level cache) the blocks neither gain
nor lose time; they keep the intermediates' memory at 0.6 MB whatever the batch.

The tooth phase's Newton steps run one crank angle's pins at a time in a loop free of
branches, which the compiler turns into SIMD lanes (their square roots and quotients are
correctly rounded there too: the same bits), each pin keeping its c once converged, as
the reference's ``np.where``. The flank normals of a stack (``normals``) come from the
contact's own angles, cos and sin of arg w + arg n − arg P_s, not recomputed from φ1 as
:func:`cyclomesh.core.contact.contact_normal` does: the same angle to a unit or two in
its last place (more near a tooth-space bottom, where arccos c is ill-conditioned).

The callers (:func:`cyclomesh.core.contact.unloaded_contact`,
:func:`cyclomesh.core.ltca.pin_compliance`, :func:`cyclomesh.core.fields.contact_stresses`)
take these passes when :func:`cyclomesh.core.kernel.kernel_name` is ``numba``; a case a
pass cannot finish (a pin jammed at a tooth-space bottom, a contact that does not
converge) is handed back to the reference, which raises its one-line error.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np

from cyclomesh.core.jit import njit

__all__ = ["compiled"]

_TOLERANCE = 1e-13
"""Residual of the contact condition [m], :data:`cyclomesh.core.contact.CONTACT_TOLERANCE`."""
_MAX_ITERATIONS = 40
"""Newton steps of the tooth phase, as :func:`cyclomesh.core.contact.contact_phase`."""


@cache
def compiled() -> Any:
    """The compiled passes as a namespace (``contact_phase``, ``contact_finish``,
    ``compliance``, ``stresses``, ``rests``; the inlined ``log``, ``cos``, ``sin``,
    ``pin_row_pressures``, ``pressures``), or
    None without numba (imported on first use)."""
    try:
        import numba
    except ImportError:
        return None
    jit = njit()
    inline = njit(inline=True)
    global _mod_2pi, _row_min, _mod_2pi_near, _libm_cos, _finish_pin  # compiled in place:
    _math(numba)  # the passes call them compiled
    _mod_2pi = jit(_mod_2pi)
    _mod_2pi_near = inline(_mod_2pi_near)
    _libm_cos = jit(_libm_cos)
    _finish_pin = inline(_finish_pin)
    _row_min = jit(_row_min)
    global _compliance_row, _coefficients, _pin_terms, _pin_row_pressures, _pressures
    _pin_row_pressures = inline(_pin_row_pressures)
    _pressures = inline(_pressures)
    _coefficients = inline(_coefficients)
    _pin_terms = inline(_pin_terms)
    _compliance_row = inline(_compliance_row)

    class Passes:
        contact_phase = jit(_contact_phase)
        contact_finish = jit(_contact_finish)
        compliance = jit(_compliance)
        stresses = jit(_stresses)
        rests = jit(_rests)
        rest_backlash = jit(_rest_backlash)
        overlap_contacts = jit(_overlap_contacts)
        log, cos, sin = _log, _cos, _sin
        pin_row_pressures, pressures = _pin_row_pressures, _pressures

    return Passes


def _contact_phase(
    pcx, pcy, ecx, ecy, s_pin, a, e, n1, q0, q1, wx, wy, c_out, zx, zy, nx, ny, sin_out, d_out,
    residual, reach
):  # fmt: skip  # pragma: no cover (compiled)
    """Tooth phase c = cos u of every contact and the vectors whose arguments NumPy takes.

    Inputs: pcx, pcy = pin_r·(cos, sin)(pin angle) (R, n1); ecx, ecy = ecc·(cos, sin)φ
    (R, A); s_pin = r_pin − ρ' (R, n1); a', e [m], n1. The rows q0 ≤ q < q1 of the
    (R·A, n1) contacts (row q: ring q // A, crank angle q % A), a block of them: fills
    the block's rows q − q0 of w = C − O2 (wx, wy), c, the pin centre on the offset locus
    P_s (zx, zy), the normal (nx, ny) in the tooth frame, sin u, D = |n·D| (``sin_out``,
    ``d_out``, which :func:`_contact_finish` reads instead of taking them again) and
    ``reach`` (q1 − q0, n1), and the rows q of the residual [m] (R·A, n1). Returns the
    number of jammed or unconverged contacts (then the caller takes the reference, which
    raises).
    """
    n_angles = ecx.shape[1]
    n_pins = wx.shape[1]
    g0, g1 = a * a + e * e * n1, a * e * (n1 + 1)
    d0, d1 = a * a + e * e * n1 * n1, 2.0 * a * e * n1
    bad = 0
    # one crank angle's pins at a time, each loop over them free of branches so that
    # the compiler runs it in SIMD lanes (square roots and quotients are correctly
    # rounded there as well, so the bits are the per-element loop's): Newton's steps
    # run until every pin of the angle has converged, a converged pin recomputing its
    # residual at its own c and keeping it, as the reference's ``np.where(done, c, …)``;
    # once only a few pins are left (about one pin in 40 takes a third Newton step) they
    # finish alone (the same operations, one pin at a time). The test |h|/(2w) ≤ tol is
    # taken without the quotient, against 2w·tol widened and narrowed by 1e-12 (the
    # quotient's rounding is 1.1e-16): a pin between the two bounds is decided by the
    # quotient itself, so the decisions, and with them c, are the reference's.
    c_row = np.empty(n_pins)
    w_row = np.empty(n_pins)
    k0_row = np.empty(n_pins)
    h_row = np.empty(n_pins)
    d_row = np.empty(n_pins)
    lo_row = np.empty(n_pins)
    hi_row = np.empty(n_pins)
    ok_row = np.empty(n_pins, np.bool_)
    done_row = np.empty(n_pins, np.bool_)
    left = np.empty(n_pins, np.int64)
    for q in range(q0, q1):
        r, k, b = q // n_angles, q % n_angles, q - q0
        ex, ey = ecx[r, k], ecy[r, k]
        for i in range(n_pins):
            x = pcx[r, i] - ex
            y = pcy[r, i] - ey
            w2 = x * x + y * y
            s = s_pin[r, i]
            w = math.sqrt(w2)
            bad += w < a - e + s - _TOLERANCE  # jammed: the reference raises
            ok = w <= a + e + s
            ok_row[i] = ok
            k0 = a * a + e * e + s * s - w2
            k0_row[i] = k0
            w_row[i] = w
            # an unreachable pin is converged whatever h (its residual is 0)
            lo_row[i] = (2.0 * w) * _TOL_BELOW if ok else np.inf
            hi_row[i] = (2.0 * w) * _TOL_ABOVE if ok else np.inf
            c_row[i] = min(max(k0 / (2.0 * a * e), -1.0), 1.0)
            wx[b, i] = x
            wy[b, i] = y
        steps = 0
        while True:  # an evaluation of every pin, then (most pins left) a step of each
            steps += 1
            active = 0
            unsure = 0
            for i in range(n_pins):
                c = c_row[i]
                d = math.sqrt(d0 - d1 * c)
                g = g0 - g1 * c
                h = k0_row[i] - 2.0 * a * e * c + 2.0 * s_pin[r, i] * g / d
                size = abs(h)
                done = size <= lo_row[i]
                unsure += (size > lo_row[i]) & (size <= hi_row[i])
                done_row[i] = done
                h_row[i] = h
                d_row[i] = d
                active += not done
            if unsure:  # between the bounds: the reference's quotient decides
                for i in range(n_pins):
                    size = abs(h_row[i])
                    unsure_i = size > lo_row[i] and size <= hi_row[i]
                    if unsure_i and size / (2.0 * w_row[i]) <= _TOLERANCE:
                        done_row[i] = True
                        active -= 1
            if active * _FEW <= n_pins or steps >= _MAX_ITERATIONS:
                break
            for i in range(n_pins):
                c = c_row[i]
                s = s_pin[r, i]
                d = d_row[i]
                g = g0 - g1 * c
                dh = -2.0 * a * e + 2.0 * s * (-g1 * d + g * d1 / (2.0 * d)) / (d * d)
                step = min(max(c - h_row[i] / dh, -1.0), 1.0)
                c_row[i] = c if done_row[i] else step
        if active:  # the few pins left, one at a time, each to its own end
            n_left = 0
            for i in range(n_pins):
                if not done_row[i]:
                    left[n_left] = i
                    n_left += 1
            for j in range(n_left):
                i = left[j]
                s = s_pin[r, i]
                two_w = 2.0 * w_row[i]
                c, d, h = c_row[i], d_row[i], h_row[i]
                for _ in range(steps, _MAX_ITERATIONS):  # a step, then an evaluation
                    g = g0 - g1 * c
                    dh = -2.0 * a * e + 2.0 * s * (-g1 * d + g * d1 / (2.0 * d)) / (d * d)
                    c = min(max(c - h / dh, -1.0), 1.0)
                    d = math.sqrt(d0 - d1 * c)
                    g = g0 - g1 * c
                    h = k0_row[i] - 2.0 * a * e * c + 2.0 * s * g / d
                    if abs(h) / two_w <= _TOLERANCE:
                        break
                c_row[i], d_row[i], h_row[i] = c, d, h
        for i in range(n_pins):
            c = c_row[i]
            s = s_pin[r, i]
            ok = ok_row[i]
            res = abs(h_row[i]) / (2.0 * w_row[i]) if ok else 0.0
            bad += not res <= _TOLERANCE  # unconverged: the reference raises
            sin_u = -math.sqrt(1.0 - c * c)
            d = d_row[i]
            vx, vy = (a - e * n1 * c) / d, -e * n1 * sin_u / d
            c_out[b, i] = c
            nx[b, i] = vx
            ny[b, i] = vy
            sin_out[b, i] = sin_u
            d_out[b, i] = d
            zx[b, i] = a - e * c + s * vx
            zy[b, i] = -e * sin_u + s * vy
            residual[q, i] = res
            reach[b, i] = ok
    return bad


_TOL_BELOW = _TOLERANCE * (1.0 - 1e-12)
_TOL_ABOVE = _TOLERANCE * (1.0 + 1e-12)
"""|h| ≤ 2w·_TOL_BELOW gives |h|/(2w) ≤ tol after rounding, |h| > 2w·_TOL_ABOVE gives
more (:func:`_contact_phase`)."""
_FEW = 8
"""The tooth phase's Newton steps leave the SIMD lanes once fewer than one pin in this
many of a crank angle is still stepping."""


def _contact_finish(
    arg_w,
    arg_z,
    arg_n,
    u,
    c_in,
    reach,
    vx_in,
    vy_in,
    sin_in,
    d_in,
    phi_t,
    phi,
    group,
    pin_phase,
    pin_angle,
    a,
    e,
    n1,
    n2,
    rho_gen,
    turn,
    rotation,
    reverse,
    moment_arm,
    cos_beta,
    profile_angle,
    contact_radius,
    curvature,
    normals,
    normal_x,
    normal_y,
    n_angles,
    q0,
    q1,
):  # pragma: no cover (compiled)
    """The contact quantities from the tooth phase and NumPy's angles (module doc).

    The rows q0 ≤ q < q1 of the (R·A, n1) contacts (row q: ring q // A, crank angle
    q % A): arg_w, arg_z, arg_n = arg w, arg P_s, arg n, u = −arccos c, c, ``reach`` and
    the tooth frame's normal, sin u and D of :func:`_contact_phase` of the block (rows
    q − q0); phi_t, phi (P, A): the crank angles of the ring rows r with r // ``group``
    = p (one row for all rings, or one a problem of a stack of them,
    :func:`contact_arrays`); pin_phase = n2·i·ψ (n1,), from which the nearest
    tooth-space bottom of the nominal tooth phase, t_root = 2π·rint((n2·i·ψ + φ)/2π)/n2,
    is taken here as the reference takes it (``np.round``: halves to even);
    pin_angle (R, n1); ``turn`` the rotation modification [rad]. Fills the block's rows q
    of the arrays of :class:`~cyclomesh.core.contact.UnloadedContact` as
    :func:`~cyclomesh.core.contact.unloaded_contact` does, and with ``normals`` the
    outward flank normal in the fixed frame, (cos, sin)(arg w + arg n − arg P_s), from
    the contact's own angles (the reference,
    :func:`cyclomesh.core.contact._fixed_normal`, takes arg n and arg P_s again from
    cos and sin of φ1 = −arccos c: the same angle to a unit or two in its last place).
    """
    c0 = e * e * n1 * n1 + a * a
    c1 = 2.0 * e * n1 * a
    c2 = e * e * n1**3 + a * a
    c3 = e * n1 * (1 + n1) * a
    consts = (a, e, n1, n2, rho_gen, turn, c0, c1, c2, c3)
    n_pins = arg_w.shape[1]
    redo_row = np.empty(n_pins, np.bool_)
    for q in range(q0, q1):
        r, k, b = q // n_angles, q % n_angles, q - q0
        pt = phi_t[r // group, k]
        tr = (phi[r // group, k], pin_phase)
        pa = pin_angle[r]
        # a view per row: with them the compiler vectorises the loop below (with flat
        # offsets it does not)
        rows = (
            arg_w[b], arg_z[b], arg_n[b], u[b], c_in[b], reach[b], vx_in[b], vy_in[b],
            sin_in[b], d_in[b]
        )  # fmt: skip
        outs = (
            rotation[q],
            reverse[q],
            moment_arm[q],
            cos_beta[q],
            profile_angle[q],
            contact_radius[q],
            curvature[q],
        )
        # every pin in SIMD lanes with :func:`_cos` and the wrap of |x| < 8π, then the
        # pins whose angles are beyond those (never on a pin ring of today's designs)
        # or next to an inflection again with the C library's cosine and NumPy's mod
        far = 0
        for i in range(n_pins):
            redo = _finish_pin(_mod_2pi_near, _cos, i, rows, tr, pa, pt, consts, outs)
            redo_row[i] = redo
            far += redo
        if far:
            for i in range(n_pins):
                if redo_row[i]:
                    _finish_pin(_mod_2pi, _libm_cos, i, rows, tr, pa, pt, consts, outs)
        if normals:  # an unreachable pin: along w here, the caller's from φ1 = −π
            nx_row, ny_row = normal_x[q], normal_y[q]
            aw_row, az_row, an_row, ok_row = rows[0], rows[1], rows[2], rows[5]
            # every pin in SIMD lanes (no branch), then the C library's where |angle| is
            # beyond _cos's exact reduction (never on today's pin rings)
            far = 0
            for i in range(n_pins):
                aw = aw_row[i]
                angle = aw + an_row[i] - az_row[i] if ok_row[i] else aw
                nx_row[i] = _cos(angle)
                ny_row[i] = _sin(angle)
                far += not abs(angle) < _TRIG_EXACT_BELOW
            if far:
                for i in range(n_pins):
                    aw = aw_row[i]
                    angle = aw + an_row[i] - az_row[i] if ok_row[i] else aw
                    if not abs(angle) < _TRIG_EXACT_BELOW:
                        nx_row[i] = math.cos(angle)
                        ny_row[i] = math.sin(angle)


def _finish_pin(wrap, cosine, i, rows, tr, pa, pt, consts, outs):  # pragma: no cover
    """Pin ``i`` of one crank angle for :func:`_contact_finish` (branch-free: its values
    and the unreachable pin's by selects), with ``wrap`` = x mod 2π and ``cosine``;
    returns whether a reachable pin's angles lie beyond :func:`_mod_2pi_near`'s or
    :func:`_cos`'s range or it lies next to an inflection (:data:`_INFLECTION`; then the
    caller takes it again exactly)."""
    arg_w, arg_z, arg_n, u, c_in, reach, vx_in, vy_in, sin_in, d_in = rows
    rotation, reverse, moment_arm, cos_beta, profile_angle, contact_radius, curvature = outs
    a, e, n1, n2, rho_gen, turn, c0, c1, c2, c3 = consts
    centre = np.pi / n2
    uu = u[i]
    aw, az = arg_w[i], arg_z[i]
    ok = reach[i]
    c = c_in[i]
    two_pi = 2.0 * np.pi
    t_i = two_pi * np.rint((tr[1][i] + tr[0]) / two_pi) / n2
    sin_u, d = sin_in[i], d_in[i]  # the phase's: the same expressions, the same bits
    vx, vy = vx_in[i], vy_in[i]
    t = t_i + uu / n2
    x_rot = np.pi - (aw - t - az - pt)
    rot = np.pi - wrap(x_rot)
    lateral = pt + rot + t + arg_n[i] - pa[i]
    rot = rot + turn
    x_back = np.pi - (aw - (t_i - uu / n2) + az - pt)
    back = np.pi - wrap(x_back)
    back = back - turn
    gap = rot - back
    turns = np.floor((centre + np.pi - gap) / two_pi)
    back = back - two_pi * turns  # turns = 0 leaves back as it is
    rho_x, rho_y = a - e * c - rho_gen * vx, -e * sin_u - rho_gen * vy
    n2t = n2 * t
    cos_n = cosine(n2t)
    q = c0 - c1 * cos_n  # q**1.5 as √q·q: NumPy's power differs in the last bit anyway
    rotation[i] = rot if ok else np.inf
    reverse[i] = back if ok else -np.inf
    moment_arm[i] = -a * e * n2 * sin_u / d if ok else 0.0
    cos_beta[i] = abs(cosine(lateral)) if ok else 1.0
    profile_angle[i] = uu if ok else -np.pi
    contact_radius[i] = math.sqrt(rho_x * rho_x + rho_y * rho_y) if ok else a + e - rho_gen
    den = c2 - c3 * cos_n
    curvature[i] = q * math.sqrt(q) / den - rho_gen if ok else np.inf
    near = (
        abs(x_rot) < _WRAP_NEAR
        and abs(x_back) < _WRAP_NEAR
        and abs(n2t) < _TRIG_EXACT_BELOW
        and abs(lateral) < _TRIG_EXACT_BELOW
        and abs(den) * _INFLECTION > c3
    )
    return ok and not near


_INFLECTION = 32.0
"""Near an inflection of the profile the curvature radius's denominator
e²n1³ + a'² − e·n1·(1 + n1)·a'·cos n2·t cancels, and one unit in the last place of the
cosine moves ρc by 2.2e-16·c3/|den| of itself (7e-12 measured on section42's Case 3):
where c3/|den| exceeds this (ρc then within a few parts in 1e-15 of itself), the pin is
taken again with the C library's cosine, the reference's bits (a few in a hundred)."""
_WRAP_NEAR = 8.0 * np.pi
"""|x| below which :func:`_mod_2pi_near` is np.mod(x, 2π) bit for bit."""
_TRIG_EXACT_BELOW = 8.0e5
"""|x| [rad] below which :func:`_cos` and :func:`_sin` reduce exactly (the reduction's
n·π/2₁ is exact for n < 2^20)."""


def _libm_cos(x):  # pragma: no cover (compiled)
    """The C library's cosine (the exact fallback of :func:`_finish_pin`)."""
    return math.cos(x)


def _mod_2pi_near(x):  # pragma: no cover (compiled)
    """:func:`_mod_2pi` for |x| < 8π with selects instead of branches (SIMD lanes); a
    value for any other x, which the caller replaces (NaN included)."""
    two_pi = 2.0 * np.pi
    four_pi = 2.0 * two_pi
    p = x - four_pi if x >= four_pi else x
    p = p - two_pi if p >= two_pi else p
    m = x + four_pi if x <= -four_pi else x
    m = m + two_pi if m <= -two_pi else m
    m = m + two_pi if m < 0.0 else 0.0
    return p if x >= 0.0 else m


def _mod_2pi(x):  # pragma: no cover (compiled)
    """np.mod(x, 2π) bit for bit: NumPy takes r = fmod(x, 2π), exact, and adds 2π to a
    negative r (rounded) or gives +0 for r = 0. For |x| < 8π the exact remainder is a
    subtraction of 4π and/or 2π, each exact (Sterbenz: y/2 ≤ x ≤ 2y gives x − y
    exactly), which spares the C library's fmod; beyond, NumPy's own mod."""
    two_pi = 2.0 * np.pi
    if 0.0 <= x < two_pi:
        return x
    if -two_pi < x < 0.0:
        return x + two_pi
    four_pi = 2.0 * two_pi
    if two_pi <= x < 2.0 * four_pi:
        r = x - four_pi if x >= four_pi else x
        return r - two_pi if r >= two_pi else r
    if -2.0 * four_pi < x <= -two_pi:
        r = x + four_pi if x <= -four_pi else x
        r = r + two_pi if r <= -two_pi else r
        return r + two_pi if r < 0.0 else 0.0
    return np.mod(x, two_pi)


def _compliance(
    rp_in,
    repeat,
    rc_in,
    cb_in,
    depth_in,
    n_pins,
    half_plane,
    groove,
    k_tooth,
    k_groove,
    c_disc,
    c_pin,
    c_ring,
    scale,
    gamma_0,
    g_p,
    poisson_term,
    groove_radius,
    alpha,
    gamma,
):  # pragma: no cover (compiled)
    """(α, γ) of δ = F(α − γ ln F) per contact, as
    :func:`~cyclomesh.core.hertz.compliance_coefficients` (flat arrays, rows of
    ``n_pins`` contacts, one pass; the pin radii ``rp_in`` (rows, n_pins), row q of the
    contacts taking row q // ``repeat`` of them, as the crank angles of a ring share
    theirs).

    k_tooth, k_groove = π·B·E* of the pin–tooth and pin–groove pairs; scale = 2/(πB);
    gamma_0, g_p = (c_disc + c_pin)/(πB), (c_ring + c_pin)/(πB); poisson_term =
    ν/(2(1 − ν)) of the disc. The logarithms are :func:`_log`,
    every choice a select, so that the loop over a row runs in SIMD lanes; what depends
    on the pin radius alone (ln 4ρp, the groove pair's α′) is taken once per row of pin
    radii (again only where a row's radii differ from the row before), and the
    logarithms of quotients as differences, ln(4ρ/κ) = ln 4ρ − ln κ with
    ln κ = ½ ln(4ρ*/(πBE*)): the same value to a few units in the last place of α.
    """
    per_pin = np.empty((3, n_pins))  # ρp, ln 4ρp, α′ of the row before
    per_pin[0, :] = np.nan
    consts = (4.0 / k_tooth, scale, c_disc, c_pin, poisson_term, gamma_0, g_p)
    for start in range(0, rc_in.size, n_pins):
        rp_row = rp_in[start // n_pins // repeat]
        _pin_terms(rp_row, per_pin, groove_radius, k_groove, scale, c_ring, c_pin)
        row = (rp_row, rc_in, cb_in, depth_in, per_pin[1], per_pin[2], alpha, gamma, start)
        # the law and the groove term fixed in each loop (no choice left inside it)
        if half_plane:
            if groove:
                _compliance_row(row, n_pins, consts, True, True)
            else:
                _compliance_row(row, n_pins, consts, True, False)
        elif groove:
            _compliance_row(row, n_pins, consts, False, True)
        else:
            _compliance_row(row, n_pins, consts, False, False)


def _pin_terms(rp_row, per_pin, groove_radius, k_groove, scale, c_ring, c_pin):  # pragma: no cover
    """ρp, ln 4ρp and the groove pair's α′ of each pin into ``per_pin`` (3, n_pins), taken
    again only where ``rp_row`` differs from the row they were taken for."""
    n_pins = rp_row.size
    same = 0
    for i in range(n_pins):
        same += rp_row[i] == per_pin[0, i]
    if same < n_pins:
        for i in range(n_pins):
            rp = rp_row[i]
            per_pin[0, i] = rp
            per_pin[1, i] = _log(4.0 * abs(rp))
            rho_g = rp * groove_radius / (groove_radius - rp)
            kappa = math.sqrt(4.0 * rho_g / k_groove)
            per_pin[2, i] = scale * (
                c_ring * (_log(4.0 * abs(groove_radius) / kappa) - 0.5)
                + c_pin * (_log(4.0 * abs(rp) / kappa) - 0.5)
            )


def _compliance_row(row, n_pins, consts, half_plane, groove):  # pragma: no cover (compiled)
    """One row of :func:`_compliance` (inlined there with constant ``half_plane`` and
    ``groove``)."""
    rp_row, rc_in, cb_in, depth_in, log_rp, a_prime, alpha, gamma, start = row
    rc_row = rc_in[start : start + n_pins]
    cb_row = cb_in[start : start + n_pins]
    depth_row = depth_in[start : start + n_pins]
    alpha_row = alpha[start : start + n_pins]
    gamma_row = gamma[start : start + n_pins]
    for i in range(n_pins):
        a, g = _coefficients(
            rp_row[i], rc_row[i], cb_row[i], depth_row[i], log_rp[i], a_prime[i], consts,
            half_plane, groove,
        )  # fmt: skip
        alpha_row[i] = a
        gamma_row[i] = g


def _coefficients(
    rp, rc, cb, depth, log_rp, a_prime, consts, half_plane, groove
):  # pragma: no cover
    """(α, γ) [m/N] of one contact, the formulas of :func:`_compliance` (inlined: in a
    loop over pins they run in SIMD lanes); ``log_rp``, ``a_prime`` the pin's ln 4ρp and
    groove pair's α′."""
    inv_tooth, scale, c_disc, c_pin, poisson_term, gamma_0, g_p = consts
    if half_plane:
        rho_star = rp / (1.0 + rp / rc)
        log_kappa = 0.5 * _log(rho_star * inv_tooth)
        a = scale * (
            c_disc * ((_log(2.0 * depth) - log_kappa) - poisson_term)
            + c_pin * ((log_rp - log_kappa) - 0.5)
        )
    else:
        rho = rp if math.isinf(rc) else rp * rc / (rp + rc)
        log_kappa = 0.5 * _log(rho * inv_tooth)
        a = scale * (
            c_disc * ((_log(4.0 * abs(rc)) - log_kappa) - 0.5)
            + c_pin * ((log_rp - log_kappa) - 0.5)
        )
    g = gamma_0
    if groove:
        c2 = cb * cb
        log_cb = _log(cb) if cb > 0 else 0.0
        a = a + c2 * (a_prime - g_p * log_cb)
        g = g + c2 * g_p
    return a, g


def _stresses(
    force,
    cos_beta,
    rp_in,
    repeat,
    rc_in,
    e_tooth,
    e_groove,
    pi_width,
    groove_radius,
    groove,
    stress,
    g_stress,
):  # pragma: no cover (compiled)
    """Groove load F·cos β [N] and the Hertzian pressures of tooth and groove [Pa] (Eqs.
    18, 24 of [1]), as :func:`~cyclomesh.core.fields.contact_stresses` (flat arrays);
    e_tooth, e_groove = E* of the two pairs [Pa], pi_width = π·B [m]; the pin radii
    ``rp_in`` as :func:`_compliance`'s. With 1/ρ = 1/ρp + 1/ρc (the pin–tooth radius,
    1/ρp alone where ρc is infinite): p = √(F·(E*/πB)·(1/ρp + 1/ρc)), and what depends
    on the pin alone, E*/(πB·ρp) and the groove's E*/(πB·ρg), taken once per row of pin
    radii: one quotient per contact instead of four (the loop is bound by them), the
    pressures to a few units in their last place of the reference's."""
    n_pins = rp_in.shape[1]
    tooth = e_tooth / pi_width
    per_pin = np.empty((2, n_pins))  # E*/(πB·ρp) of the tooth, E*/(πB·ρg) of the groove
    for q in range(force.size // n_pins):
        if q % repeat == 0:
            _pin_row_pressures(
                rp_in[q // repeat], tooth, e_groove, pi_width, groove_radius, per_pin
            )
        for i in range(n_pins):
            j = q * n_pins + i
            groove[j], stress[j], g_stress[j] = _pressures(
                force[j], cos_beta[j], rc_in[j], per_pin[0, i], per_pin[1, i], tooth
            )


def _pin_row_pressures(
    rp_row, tooth, e_groove, pi_width, groove_radius, per_pin
):  # pragma: no cover
    """What the pressures of Eqs. 18 and 24 of [1] take from the pin alone, for a row of
    pin radii ``rp_row`` [m]: ``per_pin[0]`` = E*/(πB·ρp) of the tooth (``tooth`` =
    E*/(πB) [Pa/m]), ``per_pin[1]`` = the groove's E*/(πB·ρg) with 1/ρg = 1/rp − 1/R_g
    (``groove_radius`` R_g [m]) [Pa/m] (:func:`_stresses`, and the stage's output pass
    :func:`cyclomesh.stage.kernel_outputs.stage_fields`: one formula)."""
    for i in range(rp_row.size):
        rp = rp_row[i]
        per_pin[0, i] = tooth / rp
        rho_g = rp * groove_radius / (groove_radius - rp)
        per_pin[1, i] = e_groove / (pi_width * rho_g)


def _pressures(f, cos_beta, rc, k_tooth, k_groove, tooth):  # pragma: no cover (compiled)
    """One contact's groove load F·cos β [N] and the Hertzian pressures of tooth and
    groove [Pa] (Eqs. 18, 24 of [1]): p = √(F·(E*/(πB·ρp) + E*/(πB·ρc))) with ρc = ``rc``
    the tooth's radius of curvature [m] (an unloaded pin: 0), p_g = √(F·cos β·E*/(πB·ρg));
    ``k_tooth``, ``k_groove`` from :func:`_pin_row_pressures`."""
    gf = f * cos_beta
    k = k_tooth + tooth / rc if f > 0 else tooth  # (an unloaded pin: 0)
    return gf, math.sqrt(f * k), math.sqrt(gf * k_groove)


def _overlap_contacts(reverse, rotation, force, m, fraction, overlap, contacts):  # pragma: no cover
    """Per row of m contacts (flat arrays; ``rotation`` one value per row): the overlap
    max(φ' − φ, 0) as np.maximum (NaN propagating) and the number of forces above
    ``fraction`` of the row's largest (NaN: none), as
    :func:`cyclomesh.core.fields.overlap` and :func:`~cyclomesh.core.fields.count_contacts`:
    comparisons and one subtraction, the reference's bits."""
    for r in range(contacts.size):
        rot = rotation[r]
        j0 = r * m
        top = -math.inf
        nan = False
        for i in range(j0, j0 + m):
            d = reverse[i] - rot
            overlap[i] = d if (d >= 0.0 or d != d) else 0.0
            f = force[i]
            nan |= f != f
            top = f if f > top else top
        limit = fraction * top
        count = 0
        for i in range(j0, j0 + m):
            count += force[i] > limit
        contacts[r] = 0 if nan else count


def _row_min(x, arm, cond, sign, j0, m):  # pragma: no cover (compiled)
    """np.min over the row of sign·x where arm ≥ cond (else inf), NaN propagating; if
    that is not finite, np.min over the row of sign·x (the reference's fallback).
    Branch-free loops: the smaller value kept, a NaN remembered."""
    best = math.inf
    nan = False
    for j in range(j0, j0 + m):
        v = sign * x[j] if arm[j] >= cond else math.inf
        nan |= v != v
        best = v if v < best else best
    if nan:
        return math.nan
    if math.isfinite(best):
        return best
    best = math.inf
    for j in range(j0, j0 + m):
        v = sign * x[j]
        nan |= v != v
        best = v if v < best else best
    return math.nan if nan else best


def _rest_backlash(rotation, arm, cond, m, rest, backlash):  # pragma: no cover (compiled)
    """The rest position of every row of m contacts (flat arrays), as :func:`_rests`, and
    the backlash φbl = φc,i − φt − rest of each contact (one subtraction, the
    reference's bits) in the same pass."""
    for i in range(rest.size):
        low = _row_min(rotation, arm, cond, 1.0, i * m, m)
        rest[i] = low
        for j in range(i * m, i * m + m):
            backlash[j] = rotation[j] - low


def _rests(rotation, reverse_rotation, arm, cond, m, rest, reverse):  # pragma: no cover
    """Rest positions on the loaded and on the opposite flanks of every row of m
    contacts (flat arrays), as :func:`cyclomesh.drive.mesh.rest_positions` takes them
    with :func:`cyclomesh.core.ltca.rest_position`: the smallest conditioned contact
    rotation, and minus the smallest conditioned negated reverse rotation (none where
    ``reverse`` is empty)."""
    both = reverse.size > 0
    for i in range(rest.size):
        rest[i] = _row_min(rotation, arm, cond, 1.0, i * m, m)
        if both:
            reverse[i] = -_row_min(reverse_rotation, arm, cond, -1.0, i * m, m)


def rest_arrays(rotation, reverse_rotation, moment_arm, cond):
    """(rest, reverse rest) [rad] of contacts (..., m) in one compiled pass over the rows
    (:func:`_rests`): min, negation and comparisons only, so the reference's bits.
    ``reverse_rotation`` None: the rest on the loaded flanks alone, (rest, None)."""
    shape = rotation.shape
    m = shape[-1]
    rest = np.empty(shape[:-1])
    reverse = np.empty(shape[:-1] if reverse_rotation is not None else (0,))
    rotation = _flat(rotation, shape)
    compiled().rests(
        rotation,
        rotation if reverse_rotation is None else _flat(reverse_rotation, shape),
        _flat(moment_arm, shape),
        float(cond),
        m,
        rest.reshape(-1),
        reverse.reshape(-1),
    )
    return rest, (reverse if reverse_rotation is not None else None)


def rest_and_backlash(rotation, moment_arm, cond):
    """(rest [rad] (...), backlash [rad] (..., m)) of contacts (..., m) in one compiled pass
    (:func:`_rest_backlash`): :func:`cyclomesh.core.ltca.rest_position` and
    rotation − rest[..., None], bit for bit."""
    shape = np.shape(rotation)
    rest = np.empty(shape[:-1])
    backlash = np.empty(shape)
    compiled().rest_backlash(
        _flat(rotation, shape),
        _flat(moment_arm, shape),
        float(cond),
        shape[-1],
        rest.reshape(-1),
        backlash.reshape(-1),
    )
    return rest, backlash


def overlap_contacts(reverse_rotation, rotation, force, fraction):
    """(overlap [rad], contacts) of :func:`cyclomesh.core.fields.contact_fields` for one
    disc (``rotation`` one value per row of pins, (..., 1)) in one compiled pass
    (:func:`_overlap_contacts`), bit for bit."""
    shape = np.shape(force)
    overlap = np.empty(shape)
    contacts = np.empty(shape[:-1], np.int64)
    compiled().overlap_contacts(
        _flat(reverse_rotation, shape),
        _flat(rotation, (*shape[:-1], 1)),
        _flat(force, shape),
        shape[-1],
        float(fraction),
        overlap.reshape(-1),
        contacts.reshape(-1),
    )
    return overlap, contacts


def contact_arrays(
    pin_r, pin_angle, ecc, phi, s_pin, pin_phase, a, e, n1, n2, rho_gen, turn, shape, normals=False
) -> dict[str, np.ndarray] | None:
    """The arrays of :func:`cyclomesh.core.contact.unloaded_contact` (undeviated profile)
    from the compiled passes and NumPy's inverse trigonometric functions (module doc).

    Inputs as the reference builds them: pin_r, pin_angle, s_pin = r_pin − ρ' of shape
    (..., 1, n1), ecc (..., 1, 1), phi (A, 1) [rad] (or (P, 1, …, 1, A, 1): P problems
    stacked on the first ring axis, each with its own crank angles,
    :func:`cyclomesh.core.contact.unloaded_contact_stack`), pin_phase = n2·i·ψ (n1,); ``shape`` the
    contact arrays' (..., A, n1); ``normals``: also the outward flank normals in the
    fixed frame (``normal_x``, ``normal_y``; those of the unreachable pins, φ1 = −π, the
    caller takes from the reference, see :func:`cyclomesh.core.contact.unloaded_contact`).
    Returns a dict of arrays of that shape (with ``arg_w``, the argument of the pin
    centre from the disc centre), or None for a case the reference must refuse.
    """
    passes = compiled()
    ring = shape[:-2]
    n_angles = shape[-2]

    def rows(x, tail):  # (..., 1 or A, n1 or 1) → (R, tail) contiguous
        return np.ascontiguousarray(np.broadcast_to(x, (*ring, *tail)).reshape(-1, math.prod(tail)))

    pcx = rows(pin_r * np.cos(pin_angle), (1, n1))
    pcy = rows(pin_r * np.sin(pin_angle), (1, n1))
    ecx = rows(ecc * np.cos(phi), (n_angles, 1))
    ecy = rows(ecc * np.sin(phi), (n_angles, 1))
    s_rows = rows(s_pin, (1, n1))
    flat = (pcx.shape[0], n_angles, n1)
    n_rows = flat[0] * n_angles
    out = {
        name: np.empty(flat)
        for name in (
            "rotation",
            "reverse_rotation",
            "moment_arm",
            "cos_beta",
            "profile_angle",
            "contact_radius",
            "curvature_radius",
        )
    }
    residual, arg_w = np.empty(flat), np.empty(flat)
    normal = [np.empty(flat if normals else (0, 0, 0)) for _ in range(2)]
    outs = [v.reshape(n_rows, n1) for v in out.values()]
    normal_rows = [v.reshape(n_rows, n1) if normals else v.reshape(0, 0) for v in normal]
    residual_rows, arg_w_rows = residual.reshape(n_rows, n1), arg_w.reshape(n_rows, n1)
    phi_rows = np.ascontiguousarray(phi.reshape(-1, n_angles))  # (P, A): P = 1 or problems
    phi_t = -phi_rows / n2
    group = flat[0] // phi_rows.shape[0]  # ring rows a row of crank angles
    pin_phase = np.ascontiguousarray(pin_phase, float)
    pin_rows = rows(pin_angle, (1, n1))
    # blocks of rows (crank angles of a ring) whose intermediates stay in the cache
    block = max(1, min(n_rows, BLOCK_CONTACTS // n1))
    wx, wy, c, zx, zy, nx, ny, sin_u, d, arg_n, u = (np.empty((block, n1)) for _ in range(11))
    reach = np.empty((block, n1), np.bool_)
    for q0 in range(0, n_rows, block):
        q1 = min(q0 + block, n_rows)
        m = q1 - q0
        bwx, bwy, bc, bzx, bzy, bnx, bny, bsin, bd, barg_n, bu, breach = (
            v[:m] for v in (wx, wy, c, zx, zy, nx, ny, sin_u, d, arg_n, u, reach)
        )
        bad = passes.contact_phase(
            pcx, pcy, ecx, ecy, s_rows, a, e, n1, q0, q1,
            bwx, bwy, bc, bzx, bzy, bnx, bny, bsin, bd, residual_rows, breach,
        )  # fmt: skip
        if bad:
            return None
        arg_w_block = np.arctan2(bwy, bwx, out=arg_w_rows[q0:q1])
        arg_z = np.arctan2(bzy, bzx, out=bzx)
        np.arctan2(bny, bnx, out=barg_n)
        np.negative(np.arccos(bc, out=bu), out=bu)
        passes.contact_finish(
            arg_w_block,
            arg_z,
            barg_n,
            bu,
            bc,
            breach,
            bnx,
            bny,
            bsin,
            bd,
            phi_t,
            phi_rows,
            group,
            pin_phase,
            pin_rows,
            a,
            e,
            n1,
            n2,
            rho_gen,
            float(turn),
            *outs,
            bool(normals),
            *normal_rows,
            n_angles,
            q0,
            q1,
        )
    out["residual"] = residual
    out["arg_w"] = arg_w
    if normals:
        out["normal_x"], out["normal_y"] = normal
    return {name: value.reshape(shape) for name, value in out.items()}


BLOCK_CONTACTS = 8192
"""Contacts (crank angles × pins) per block of :func:`contact_arrays`: its eight
intermediate arrays of a block (64 KiB each) stay in the core's cache from the compiled
pass through NumPy's arctangents and arccos to the next pass, instead of a revolution's
(1.2 MB each for 3,600 angles × 40 pins) going to memory and back. Each contact is
computed alone, so the block size changes no bit (tested)."""


def _flat(x, shape):
    """``x`` broadcast to ``shape``, C-contiguous and flat (a view where ``x`` is already
    that: np.broadcast_to's Python wrapper, a few µs a call, spared)."""
    if type(x) is np.ndarray and x.shape == shape and x.flags.c_contiguous:
        return x.reshape(-1)
    return np.ascontiguousarray(np.broadcast_to(x, shape)).reshape(-1)


def _pin_rows(pin_radius, shape):
    """(pin radii (rows, n1), repeat) of contacts of ``shape``: one row per ring when
    the radii are broadcast along the crank angles (repeat = the angles; no copy of a
    revolution's worth of equal rows), else every row (repeat = 1)."""
    rp = np.asarray(pin_radius, float)
    rp = rp if rp.shape == shape else np.broadcast_to(rp, shape)
    if rp.ndim >= 2 and rp.strides[-2] == 0:
        return np.ascontiguousarray(rp[..., 0, :]).reshape(-1, shape[-1]), shape[-2]
    return np.ascontiguousarray(rp).reshape(-1, shape[-1]), 1


flat_rows = _flat
"""Public name of :func:`_flat` (the stage's output pass reads its contacts so)."""
pin_radius_rows = _pin_rows
"""Public name of :func:`_pin_rows` (the stage's output pass reads its pin radii so)."""


def compliance_arrays(
    pin_radius,
    curvature_radius,
    cos_beta,
    contact_radius,
    design,
    groove_deformation: bool,
    contact_law: str,
) -> tuple[np.ndarray, np.ndarray]:
    """(α, γ) of every contact [m/N] as :func:`cyclomesh.core.ltca.pin_compliance` (the
    reference :func:`~cyclomesh.core.hertz.compliance_coefficients`), in one pass."""
    from cyclomesh.core.hertz import effective_modulus

    shapes = {np.shape(v) for v in (pin_radius, curvature_radius, cos_beta)}
    shape = shapes.pop() if len(shapes) == 1 else np.broadcast_shapes(*shapes)
    c_pin = design.pin_material.compliance
    c_disc = design.disc_material.compliance
    c_ring = design.ring_material.compliance
    nu = design.disc_material.poisson_ratio
    width = design.width
    alpha, gamma = np.empty(shape), np.empty(shape)
    args = (
        *_pin_rows(pin_radius, shape),
        _flat(curvature_radius, shape),
        _flat(cos_beta, shape),
        _flat(contact_radius, shape),
        shape[-1],
        contact_law == "half_plane",
        bool(groove_deformation),
        np.pi * width * effective_modulus(c_disc, c_pin),
        np.pi * width * effective_modulus(c_ring, c_pin),
        c_disc,
        c_pin,
        c_ring,
        2.0 / (np.pi * width),
        (c_disc + c_pin) / (np.pi * width),
        (c_ring + c_pin) / (np.pi * width),
        0.5 * nu / (1.0 - nu),
        design.groove_radius,
    )
    compiled().compliance(*args, alpha.reshape(-1), gamma.reshape(-1))
    return alpha, gamma


def stress_arrays(pin_radius, curvature_radius, cos_beta, force, design):
    """Groove load [N], tooth and groove pressures [Pa] as
    :func:`cyclomesh.core.fields.contact_stresses`, in one pass."""
    from cyclomesh.core.hertz import effective_modulus

    shape = np.shape(force)
    c_pin = design.pin_material.compliance
    out = [np.empty(shape) for _ in range(3)]
    compiled().stresses(
        _flat(force, shape),
        _flat(cos_beta, shape),
        *_pin_rows(pin_radius, shape),
        _flat(curvature_radius, shape),
        effective_modulus(c_pin, design.disc_material.compliance),
        effective_modulus(c_pin, design.ring_material.compliance),
        np.pi * design.width,
        design.groove_radius,
        *(v.reshape(-1) for v in out),
    )
    return tuple(out)


# Logarithm, cosine and sine free of calls and branches (the compiled passes inline them).
# The C library's log and cos are calls, one element at a time (about 9 and 17 ns here),
# and a loop that makes them cannot run in SIMD lanes. These are FreeBSD msun's algorithms
# (Sun's fdlibm, 1993, with Bruce D. Evans's revisions: e_log.c, k_cos.c, k_sin.c and the
# medium-argument reduction of e_rem_pio2.c) written with selects instead of branches, so
# that the compiler inlines them and vectorises the loops around them. Their error is
# below one unit in the last place, as the C library's and NumPy's SIMD ones, so they
# differ from those in the last bit at most (tests/core/test_kernel_math.py). They live
# in this module, not their own: numba caches a pass per its own source file, with what
# it inlines, so a change here must change this file's stamp.


def _math(numba):
    """Compile :func:`_log`, :func:`_cos`, :func:`_sin` in place (the bit casts of
    :func:`_log` as LLVM intrinsics); called by :func:`compiled`."""
    from numba.core import types
    from numba.extending import intrinsic

    @intrinsic
    def to_bits(typingctx, x):  # pragma: no cover (compiled)
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(types.int64))

        return types.int64(types.float64), codegen

    @intrinsic
    def from_bits(typingctx, i):  # pragma: no cover (compiled)
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(types.float64))

        return types.float64(types.int64), codegen

    global _to_bits, _from_bits, _reduce, _kernels, _log, _cos, _sin
    _to_bits, _from_bits = to_bits, from_bits
    inline = njit(inline=True)
    _reduce, _kernels = inline(_reduce), inline(_kernels)
    _log, _cos, _sin = inline(_log), inline(_cos), inline(_sin)


# fdlibm's constants
# e_log.c
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01
_TWO54 = 1.80143985094819840000e16
# k_cos.c, k_sin.c
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
# e_rem_pio2.c: 2/π, π/2 in two parts of 33 bits and the rest
_INVPIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_2T = 2.02226624879595063154e-21


def _to_bits(x):  # pragma: no cover (replaced by the intrinsic)
    raise NotImplementedError


def _from_bits(i):  # pragma: no cover (replaced by the intrinsic)
    raise NotImplementedError


def _log(x):  # pragma: no cover (compiled)
    """ln x as e_log.c (error below 1 ulp), branch-free: 0 → −inf, x < 0 or NaN → NaN,
    +inf → +inf, subnormals scaled by 2^54 first."""
    tiny = x < 2.2250738585072014e-308  # subnormal (or 0, negative, handled below)
    xs = x * _TWO54 if tiny else x
    ix = _to_bits(xs)
    hx = (ix >> 32) & 0x000FFFFF
    k = ((ix >> 52) & 0x7FF) - 1023 - (54 if tiny else 0)
    i = (hx + 0x95F64) & 0x100000
    # the mantissa scaled to [√2/2, √2)
    m = _from_bits(((hx | (i ^ 0x3FF00000)) << 32) | (ix & 0xFFFFFFFF))
    k = k + (i >> 20)
    f = m - 1.0
    hfsq = 0.5 * f * f
    s = f / (2.0 + f)
    dk = float(k)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    r = t2 + t1
    j = (hx - 0x6147A) | (0x6B851 - hx)
    near = dk * _LN2_HI - ((hfsq - (s * (hfsq + r) + dk * _LN2_LO)) - f)
    far = dk * _LN2_HI - ((s * (f - r) - dk * _LN2_LO) - f)
    y = near if j > 0 else far
    y = y if x < 1.7976931348623157e308 else x  # +inf (NaN falls through below)
    y = y if x > 0.0 else (-np.inf if x == 0.0 else np.nan)
    return y


def _reduce(x):  # pragma: no cover (compiled)
    """x = n·π/2 + (y0 + y1), |y0| ≤ π/4, by one Cody–Waite step (e_rem_pio2.c's medium
    case with its second round always taken); returns (n mod 4 as a float, y0, y1)."""
    fn = float(math.floor(x * _INVPIO2 + 0.5))
    t = x - fn * _PIO2_1  # exact: fn·π/2₁ has at most 53 bits
    w = fn * _PIO2_2  # exact as well
    r = t - w
    w = fn * _PIO2_2T - ((t - r) - w)
    y0 = r - w
    y1 = (r - y0) - w
    return fn - 4.0 * math.floor(0.25 * fn), y0, y1  # fn mod 4, exact


def _kernels(y0, y1):  # pragma: no cover (compiled)
    """(cos, sin) of y0 + y1 on [−π/4, π/4]: k_cos.c and k_sin.c."""
    z = y0 * y0
    w = z * z
    rc = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    w1 = 1.0 - hz
    kc = w1 + (((1.0 - w1) - hz) + (z * rc - y0 * y1))
    rs = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    v = z * y0
    ks = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * _S1)
    return kc, ks


def _cos(x):  # pragma: no cover (compiled)
    """cos x for |x| < :data:`_TRIG_EXACT_BELOW` (error below 1 ulp), branch-free: x = n·π/2
    + (y0 + y1), then k_cos or ±k_sin of (y0, y1) by n mod 4."""
    n, y0, y1 = _reduce(x)
    kc, ks = _kernels(y0, y1)
    return kc if n == 0.0 else (-ks if n == 1.0 else (-kc if n == 2.0 else ks))


def _sin(x):  # pragma: no cover (compiled)
    """sin x for |x| < :data:`_TRIG_EXACT_BELOW` (error below 1 ulp), as :func:`_cos`."""
    n, y0, y1 = _reduce(x)
    kc, ks = _kernels(y0, y1)
    return ks if n == 0.0 else (kc if n == 1.0 else (-ks if n == 2.0 else -kc))


# The contact fields of a stack in one pass (issue 27, the 10^6-ring tolerance study):
# what cyclomesh.core.fields.contact_fields otherwise takes from NumPy in eight passes
# over the contacts (products, sums, a maximum, comparisons), with NumPy's own order of
# additions, so the reference's bits.

_PAIRWISE_BLOCK = 128
"""NumPy's ``PW_BLOCKSIZE``: a row of at most this many terms is summed by NumPy's
pairwise summation in one block of eight accumulators (:func:`_row_dot`)."""


def _row_dot(a, b, j0, n):  # pragma: no cover (compiled)
    """Σ a[j]·b[j] over j0 ≤ j < j0 + n (n ≤ :data:`_PAIRWISE_BLOCK`) as ``np.sum(a * b,
    axis=-1)`` adds a contiguous row: NumPy's pairwise summation (its ``pairwise_sum``,
    one block: eight accumulators of every eighth term, combined as ((0+1)+(2+3)) +
    ((4+5)+(6+7)), the remainder added in turn; a row of fewer than eight in turn), onto
    the reduction's identity 0.0: the same additions in the same order, so its bits."""
    if n < 8:
        res = 0.0
        for j in range(j0, j0 + n):
            res += a[j] * b[j]
        return res
    r0 = a[j0] * b[j0]
    r1 = a[j0 + 1] * b[j0 + 1]
    r2 = a[j0 + 2] * b[j0 + 2]
    r3 = a[j0 + 3] * b[j0 + 3]
    r4 = a[j0 + 4] * b[j0 + 4]
    r5 = a[j0 + 5] * b[j0 + 5]
    r6 = a[j0 + 6] * b[j0 + 6]
    r7 = a[j0 + 7] * b[j0 + 7]
    stop = j0 + n - n % 8
    j = j0 + 8
    while j < stop:
        r0 += a[j] * b[j]
        r1 += a[j + 1] * b[j + 1]
        r2 += a[j + 2] * b[j + 2]
        r3 += a[j + 3] * b[j + 3]
        r4 += a[j + 4] * b[j + 4]
        r5 += a[j + 5] * b[j + 5]
        r6 += a[j + 6] * b[j + 6]
        r7 += a[j + 7] * b[j + 7]
        j += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while j < j0 + n:
        res += a[j] * b[j]
        j += 1
    return 0.0 + res


def _stack_fields(
    force,
    arm,
    nx,
    ny,
    reverse,
    rotation,
    n_discs,
    n_pins,
    fraction,
    overlap,
    contacts,
    torque,
    fx,
    fy,
):  # pragma: no cover (compiled)
    """Per row of n_discs × n_pins contacts (flat arrays; ``rotation`` one value per
    row): the overlap max(φ' − φ, 0) of every pin (as :func:`_overlap_contacts`), and
    per disc the pins in contact (load above ``fraction`` of the row's largest, none if
    a load is NaN: :func:`cyclomesh.core.fields.count_contacts` with the stack's two
    axes), the torque share Σ F·l and the mesh force −Σ F·n (:func:`_row_dot`). An
    output of size 0 is not computed. Comparisons, one subtraction, NumPy's sums: the
    reference's bits."""
    m = n_discs * n_pins
    do_overlap = overlap.size > 0
    do_contacts = contacts.size > 0
    do_torque = torque.size > 0
    do_mesh = fx.size > 0
    for r in range(force.size // m):
        j0 = r * m
        if do_overlap:
            rot = rotation[r]
            for i in range(j0, j0 + m):
                d = reverse[i] - rot
                overlap[i] = d if (d >= 0.0 or d != d) else 0.0
        if do_contacts:
            top = -math.inf
            nan = False
            for i in range(j0, j0 + m):
                f = force[i]
                nan |= f != f
                top = f if f > top else top
            limit = fraction * top
            for k in range(n_discs):
                count = 0
                for i in range(j0 + k * n_pins, j0 + (k + 1) * n_pins):
                    count += force[i] > limit
                contacts[r * n_discs + k] = 0 if nan else count
        for k in range(n_discs):
            s = j0 + k * n_pins
            if do_torque:
                torque[r * n_discs + k] = _row_dot(force, arm, s, n_pins)
            if do_mesh:
                fx[r * n_discs + k] = -_row_dot(force, nx, s, n_pins)
                fy[r * n_discs + k] = -_row_dot(force, ny, s, n_pins)


@cache
def _fields_compiled() -> Any:
    """:func:`_stack_fields` compiled (numba imported on first use; None without it)."""
    try:
        inline = njit(inline=True)
    except ImportError:
        return None
    global _row_dot
    _row_dot = inline(_row_dot)
    return njit()(_stack_fields)


def stack_fields(force, stack_axes, fraction, arm=None, normal=None, reverse=None, rotation=None):
    """The contact fields of :func:`cyclomesh.core.fields.contact_fields` that follow from
    the loads of a stack (``force`` (..., n1) with ``stack_axes`` = 1, or (..., N, n1)
    with 2) in one compiled pass (:func:`_stack_fields`), bit for bit: ``overlap``
    [rad] (with ``reverse`` φ' − φt of ``force``'s shape and ``rotation`` broadcast to one
    value per row), ``contacts``, ``torque_share`` [N·m] (with ``arm`` [m]) and
    ``mesh_force_x``/``_y`` [N] (with ``normal``), each only with its inputs. Every
    given array must have ``force``'s shape; rows of more than 128 pins (NumPy's sums
    there recurse) are not taken: None."""
    shape = np.shape(force)
    n_pins = shape[-1]
    n_discs = shape[-2] if stack_axes == 2 else 1
    if n_pins > _PAIRWISE_BLOCK or len(shape) < stack_axes or 0 in shape:
        return None
    per_disc = shape[:-1]
    rows = (*shape[:-stack_axes], *(1,) * stack_axes)
    empty = np.empty(0)
    out = {}
    if reverse is not None:
        out["overlap"] = np.empty(shape)
    out["contacts"] = np.empty(per_disc, np.int64)
    if arm is not None:
        out["torque_share"] = np.empty(per_disc)
    if normal is not None:
        out["mesh_force_x"], out["mesh_force_y"] = np.empty(per_disc), np.empty(per_disc)
    _fields_compiled()(
        _flat(force, shape),
        empty if arm is None else _flat(arm, shape),
        empty if normal is None else _flat(normal[0], shape),
        empty if normal is None else _flat(normal[1], shape),
        empty if reverse is None else _flat(reverse, shape),
        empty if reverse is None else _flat(rotation, rows),
        n_discs,
        n_pins,
        float(fraction),
        *(
            out[name].reshape(-1) if name in out else empty
            for name in ("overlap", "contacts", "torque_share", "mesh_force_x", "mesh_force_y")
        ),
    )
    return out
