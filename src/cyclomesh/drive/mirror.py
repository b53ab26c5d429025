"""The mirror image that maps the forward flanks onto the reverse ones (Eqs. 5–26 of [1]).

A negative torque pushes the disc ahead of its theoretical position onto the other flank
of every tooth space (TE > 0). That state is the mirror image, about the x-axis of the
fixed frame, of a forward state: pin i at angle iψ + εψ,i maps to pin (n1 − i) mod n1 at
angle −(iψ + εψ,i), a disc centre at crank angle φ maps to −φ, and a clockwise torque to a
counter-clockwise one (:mod:`cyclomesh.drive.solve`). :func:`mirror_errors` is the one
place that maps a ring to its mirror image, :func:`unmirror` maps arrays back; the sign a
field takes is its row's parity in :data:`cyclomesh.quantities.QUANTITIES`.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.pair import Modification, PinErrors

__all__ = ["mirror_index", "mirror_errors", "mirror_problem", "unmirror"]

FloatArray = NDArray[np.float64]


def mirror_index(pins: int) -> NDArray[np.int64]:
    """Index of the mirror image of every pin: pin i ↔ pin (n1 − i) mod n1 (0-based)."""
    return (-np.arange(pins)) % pins


def mirror_errors(errors: PinErrors, pins: int) -> PinErrors:
    """The pin ring reflected about the x-axis of the fixed frame.

    Pin i at angle iψ + εψ,i becomes pin (n1 − i) mod n1 at angle −iψ − εψ,i, i.e. with
    angular error −εψ,i; its radial and radius errors go with it; the eccentricity error
    is unchanged. The mapping is an involution.

    Parameters
    ----------
    errors : PinErrors
        Errors of the ring (SI), leading axes are rings.
    pins : int
        n1.
    """
    shape = (*errors.ring_shape(pins), pins)
    index = mirror_index(pins)

    def per_pin(value: ArrayLike) -> FloatArray:
        return np.broadcast_to(np.asarray(value, float), shape)[..., index]

    return PinErrors(
        radial=per_pin(errors.radial),
        angular=-per_pin(errors.angular),
        pin_radius=per_pin(errors.pin_radius),
        eccentricity=errors.eccentricity,
    )


def mirror_problem(
    modification: Modification, errors: PinErrors, pins: int
) -> tuple[Modification, PinErrors]:
    """The gear pair reflected about the x-axis: the one place that maps a problem to its
    mirror image (used for the reverse flanks).

    Δa, Δρ and the rotation modification δ are symmetric about a tooth-space bottom, so a
    modification made of them is its own mirror image; a modification that is not (a
    tabulated profile deviation, per tooth or not) must provide ``mirrored()``, which
    is used when present. The ring goes through :func:`mirror_errors`.
    """
    mirrored = getattr(modification, "mirrored", None)
    return (mirrored() if callable(mirrored) else modification), mirror_errors(errors, pins)


def unmirror(arr: FloatArray, angle_axis: int, disc_axis: int | None, pins: bool) -> FloatArray:
    """Map an array of the mirrored problem back onto the reverse flanks.

    Crank angle −φ → φ (the mirrored problem is solved on the reversed angles), disc k at
    −φ − (k − 1)·2π/N is disc (1 − k) mod N + 1 of the mirrored stack, pin i is pin
    (n1 − i) mod n1.
    """
    out = np.flip(arr, axis=angle_axis)
    if disc_axis is not None:
        out = np.take(out, mirror_index(out.shape[disc_axis]), axis=disc_axis)
    if pins:
        out = out[..., mirror_index(out.shape[-1])]
    return out
