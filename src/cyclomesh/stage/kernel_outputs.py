"""The RV stage's per-pin and per-disc outputs after the compiled iteration in one pass.

With ``CYCLOMESH_KERNEL=numba``, :func:`cyclomesh.stage.equilibrium.solve_direction`
forms from the pins' forces of both flanks (A, D, 2·n1) what it formed with
:func:`cyclomesh.core.fields.contact_fields` (the loaded flanks' groove load
Fc·cos β [N], the Hertzian pressures of tooth and groove [Pa], Eqs. 18 and 24 of [1], and
the pins in contact per disc) and with :func:`cyclomesh.stage.kernel.disc_sums` (each
disc's torque share Σ F·l [N·m] and mesh force −Σ F·n [N] over both flanks) in one
compiled pass (:func:`stage_fields`) instead of some forty NumPy calls and three compiled
ones: the same expressions element by element, the same sums in the same order, so the
same bits as before (the compiled path's; against the NumPy reference these outputs are
as close as they were, tests/stage/test_kernel_outputs.py).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.jit import njit

__all__ = ["stage_fields"]

FloatArray = NDArray[np.float64]

STRESS_FIELDS = ("groove_load", "contact_stress", "groove_stress")
"""The per-pin fields of :func:`stage_fields` (the loaded flanks, (A, D, n1))."""
DISC_FIELDS = ("torque_share", "mesh_fx", "mesh_fy")
"""The per-disc sums of :func:`stage_fields` over both flanks ((A, D))."""


@cache
def _kernel() -> Any:
    from cyclomesh.core.kernel_contact import compiled

    global _pin_row_pressures, _pressures  # Eqs. 18, 24: core.kernel_contact's (one formula)
    passes = compiled()
    _pin_row_pressures, _pressures = passes.pin_row_pressures, passes.pressures
    return njit()(_field_rows)


def stage_fields(
    force: FloatArray,
    block: FloatArray,
    geo,
    design,
    fraction: float,
    wanted: frozenset[str] | set[str],
) -> dict[str, FloatArray]:
    """The stage's outputs of the pins' forces ``force`` [N] (A, D, 2·n1; the loaded
    flanks first) that ``wanted`` names, of :data:`STRESS_FIELDS`, ``contacts`` (loads
    above ``fraction`` of the crank angle's largest loaded-flank load, per disc, none
    where a load is NaN, as :func:`~cyclomesh.core.fields.count_contacts` with the
    stack's two axes) and :data:`DISC_FIELDS`, in one compiled pass (module doc).

    ``block`` the problem's pins (:func:`cyclomesh.stage.kernel_newton.pin_block`,
    (7, A, D, 2·n1): the arms and normals of the sums), ``geo`` the mesh's
    :class:`~cyclomesh.core.contact.UnloadedContact` ((A, D, n1): pin radius, curvature
    radius, cos β of the stresses), ``design`` its :class:`~cyclomesh.core.pair.PairDesign`.
    Each output is the same whatever else is asked."""
    from cyclomesh.core.hertz import effective_modulus
    from cyclomesh.core.kernel_contact import flat_rows, pin_radius_rows

    A, D, P = force.shape
    n1 = P // 2
    shape = (A, D, n1)
    stress = any(name in wanted for name in STRESS_FIELDS)
    disc = any(name in wanted for name in DISC_FIELDS)
    count = "contacts" in wanted
    empty = np.empty((0, 0, 0))
    out_pins = [np.empty(shape) if stress else empty for _ in range(3)]
    out_count = np.empty((A, D) if count else (0, 0), np.int64)
    out_disc = [np.empty((A, D) if disc else (0, 0)) for _ in range(3)]
    if stress:
        rp_rows, repeat = pin_radius_rows(geo.pin_radius, shape)
        rc = flat_rows(geo.curvature_radius, shape).reshape(shape)
        cb = flat_rows(geo.cos_beta, shape).reshape(shape)
    else:
        rp_rows, repeat, rc, cb = np.empty((0, 0)), 1, empty, empty
    c_pin = design.pin_material.compliance
    _kernel()(
        block,
        np.ascontiguousarray(force, dtype=float),
        rp_rows,
        repeat,
        rc,
        cb,
        effective_modulus(c_pin, design.disc_material.compliance),
        effective_modulus(c_pin, design.ring_material.compliance),
        np.pi * design.width,
        design.groove_radius,
        float(fraction),
        *out_pins,
        out_count,
        *out_disc,
    )
    out: dict[str, FloatArray] = {}
    if stress:
        out.update(zip(STRESS_FIELDS, out_pins, strict=True))
    if count:
        out["contacts"] = out_count
    if disc:
        out.update(zip(DISC_FIELDS, out_disc, strict=True))
    return {name: value for name, value in out.items() if name in wanted}


def _field_rows(
    pin, force, rp_in, repeat, rc, cb, e_tooth, e_groove, pi_width, groove_radius, fraction,
    groove, stress, g_stress, contacts, share, fx, fy,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`stage_fields` written for numba. An output of size 0 is not formed.

    The stresses are :func:`cyclomesh.core.kernel_contact._stresses`' expressions (its
    pin rows ``rp_in``, one per ``repeat`` rows of (crank angle, disc), E*/(πB·ρp) and
    E*/(πB·ρg) once per pin row), the count :func:`~cyclomesh.core.kernel_contact.
    _stack_fields`' and the sums :func:`cyclomesh.stage.kernel._disc_sum_rows`' (in
    order over both flanks): their bits."""
    A, D, P = force.shape
    n1 = P // 2
    do_stress = stress.size > 0
    do_count = contacts.size > 0
    do_disc = share.size > 0
    tooth = e_tooth / pi_width
    per_pin = np.empty((2, n1))  # E*/(πB·ρp) of the tooth, E*/(πB·ρg) of the groove
    for i in range(A):
        if do_stress:
            for d in range(D):
                q = i * D + d
                if q % repeat == 0:
                    _pin_row_pressures(
                        rp_in[q // repeat], tooth, e_groove, pi_width, groove_radius, per_pin
                    )
                for j in range(n1):
                    groove[i, d, j], stress[i, d, j], g_stress[i, d, j] = _pressures(
                        force[i, d, j], cb[i, d, j], rc[i, d, j], per_pin[0, j], per_pin[1, j],
                        tooth,
                    )  # fmt: skip
        if do_count:
            top = -math.inf
            nan = False
            for d in range(D):
                for j in range(n1):
                    f = force[i, d, j]
                    nan |= f != f
                    top = f if f > top else top
            limit = fraction * top
            for d in range(D):
                c = 0
                for j in range(n1):
                    c += force[i, d, j] > limit
                contacts[i, d] = 0 if nan else c
        if do_disc:
            for d in range(D):
                a = 0.0
                bx = 0.0
                by = 0.0
                for j in range(P):
                    f = force[i, d, j]
                    a += f * pin[1, i, d, j]
                    bx += f * pin[2, i, d, j]
                    by += f * pin[3, i, d, j]
                share[i, d] = a
                fx[i, d] = -bx
                fy[i, d] = -by
