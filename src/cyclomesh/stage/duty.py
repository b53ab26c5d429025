"""Life of the crank bearings over a duty cycle (a load spectrum of the output).

A duty cycle is a list of steps, each a torque T_i on the output, an output speed n_i and
a share t_i of the time. The reducer catalogue's equivalent values (Nabtesco RV
catalogue, "selection": equivalent load torque and average speed, cubic-mean rule with
the roller-bearing exponent 10/3) are

    T_eq = (Σ t_i·n_i·|T_i|^(10/3) / Σ t_i·n_i)^(3/10),     n_eq = Σ t_i·n_i / Σ t_i,

and ISO 281:2007 (variable load and speed; Harris & Kotzalas, Ch. 8, Palmgren–Miner) gives
the equivalent dynamic load of a bearing over the cycle from its equivalent loads P_i of
each step (each the p-mean over a revolution), weighted by the revolutions of each step:

    P = (Σ t_i·n_i·P_i^p / Σ t_i·n_i)^(1/p),     L10 = (C_r/P)^p   [10⁶ rev],

p = 10/3; the crank pin turns n1 times against its hole per output revolution, so
L10h = 10⁶·L10/(60·n1·n_eq). SI units (N, N·m) and rev/min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import DesignError
from cyclomesh.stage.bearing import LIFE_EXPONENT, life_hours, rating_life

__all__ = ["DutyCycle", "cycle_life"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DutyCycle:
    """Steps of a duty cycle: torque [N·m] (negative: reverse), output speed [rpm] and
    time share (any positive weights; normalised), one value each per step."""

    torque: tuple[float, ...]
    speed: tuple[float, ...]
    share: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.torque)
        if n == 0 or len(self.speed) != n or len(self.share) != n:
            raise DesignError(
                "stage.duty_cycle: torque_nm, output_speed_rpm and time_share need one value "
                "per step each, the same number of steps"
            )
        for name, values, positive in (
            ("torque_nm", self.torque, False),
            ("output_speed_rpm", self.speed, True),
            ("time_share", self.share, True),
        ):
            for v in values:
                if not math.isfinite(v) or (positive and v <= 0) or (not positive and v == 0):
                    raise DesignError(
                        f"stage.duty_cycle.{name}: every value must be "
                        f"{'positive' if positive else 'a non-zero number'}, got {v!r}"
                    )

    def equivalent(self) -> tuple[float, float]:
        """(T_eq [N·m], n_eq [rpm]) by the catalogue's cubic-mean rule (module doc)."""
        t, n, s = (np.asarray(v, float) for v in (self.torque, self.speed, self.share))
        rev = s * n
        p = LIFE_EXPONENT
        torque = float((np.sum(rev * np.abs(t) ** p) / np.sum(rev)) ** (1.0 / p))
        return torque, float(np.sum(rev) / np.sum(s))


def cycle_life(
    cycle: DutyCycle, step_loads: list[ArrayLike], rating: float, pins: int
) -> tuple[FloatArray, FloatArray]:
    """Equivalent load [N] and L10h [h] of every crank bearing over the duty cycle.

    Parameters
    ----------
    cycle : DutyCycle
    step_loads : list of array_like
        Bearing loads of each step over the crank angles of a revolution [N], (A, ...).
    rating : float
        C_r [N].
    pins : int
        n1.

    Returns
    -------
    equivalent, hours : ndarray
        Shape of one step's loads without the angle axis.
    """
    p = LIFE_EXPONENT
    per_step = np.stack([np.mean(np.asarray(q, float) ** p, axis=0) for q in step_loads])
    rev = np.asarray(cycle.share, float) * np.asarray(cycle.speed, float)
    weights = rev / np.sum(rev)
    equivalent = np.tensordot(weights, per_step, axes=1) ** (1.0 / p)
    _, speed = cycle.equivalent()
    return equivalent, life_hours(rating_life(rating, equivalent), pins * speed)
