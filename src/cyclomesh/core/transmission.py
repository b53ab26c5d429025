"""Loaded transmission error and instantaneous gear ratio (Eqs. 25, 26 of [1]).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["transmission_error", "gear_ratio", "is_full_revolution"]

FloatArray = NDArray[np.float64]


def transmission_error(rest_rotation: ArrayLike, loaded_rotation: ArrayLike) -> FloatArray:
    """Loaded transmission error TE = φa − φt (Eq. 25 of [1]) [rad].

    Measured positive in the disc's direction of motion (clockwise, since the disc turns
    by φt = −φin/n2), so a disc that lags its theoretical position has negative TE.

    Parameters
    ----------
    rest_rotation : array_like
        φc − φt, counter-clockwise rotation of the disc at rest from its theoretical
        position (where the first pin touches) [rad].
    loaded_rotation : array_like
        Δφc, further counter-clockwise rotation under the torque [rad].
    """
    return -(np.asarray(rest_rotation, float) + np.asarray(loaded_rotation, float))


def is_full_revolution(crank_angles: ArrayLike) -> bool:
    """True if the crank angles [rad] are uniform and span whole revolutions, end excluded."""
    phi = np.asarray(crank_angles, float)
    if phi.size < 3:
        return False
    step = np.diff(phi)
    span = phi[-1] - phi[0] + step[0]
    turns = span / (2.0 * np.pi)
    return bool(
        np.allclose(step, step[0], rtol=1e-9, atol=1e-12)
        and abs(turns - round(turns)) < 1e-9
        and round(turns) >= 1
    )


def gear_ratio(te: ArrayLike, crank_angles: ArrayLike, teeth: int) -> FloatArray:
    """Instantaneous gear ratio i = dφin/dφout (Eq. 26 of [1], written the right way up).

    With the disc (output) rotation φout = φin/n2 + TE (clockwise positive),
    i = n2/(1 + n2·dTE/dφin); the ideal value is n2. The derivative is a central
    difference over the crank step (periodic when the angles span whole revolutions,
    second-order one-sided at the ends otherwise).

    Parameters
    ----------
    te : array_like
        Transmission error [rad], crank angle on the last axis.
    crank_angles : array_like
        Crank angles [rad], increasing.
    teeth : int
        n2.
    """
    te = np.asarray(te, float)
    phi = np.asarray(crank_angles, float)
    if phi.size < 2:
        return np.full(te.shape, float(teeth))
    if is_full_revolution(phi):
        h = phi[1] - phi[0]
        dte = (np.roll(te, -1, axis=-1) - np.roll(te, 1, axis=-1)) / (2.0 * h)
    else:
        dte = np.gradient(te, phi, axis=-1, edge_order=2 if phi.size > 2 else 1)
    return teeth / (1.0 + teeth * dte)
