"""The RV stage's efficiency from its solves with friction (:mod:`cyclomesh.stage.friction`).

:func:`as_drive` lays a stage solve's friction results out as a drive's
(:class:`~cyclomesh.drive.solve.Drive`), the one conversion through which ``cyclomesh run``
(:func:`cyclomesh.results.stage.stage_efficiency_variables`) and the rings and candidates
of the tolerance studies and design maps (:func:`stage_efficiency`) read the stage; the
drive's own formulas then reduce it (docs/efficiency.md: η = P_out/(P_out + P_loss),
η_b = (P_out − P_loss,b)/P_out, means over the crank angles as ratios of mean powers).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from cyclomesh.drive.friction import mean_backdrive_efficiency, mean_efficiency
from cyclomesh.stage.solve import solve

__all__ = ["as_drive", "stage_efficiency"]


def as_drive(result, motion: float, speed: float):
    """The friction results of a stage solve (:attr:`~cyclomesh.stage.solve.Stage.friction`,
    ``motion`` +1 the crank driving every torque, −1 every torque driving it back) laid out
    as a drive's (:class:`~cyclomesh.drive.solve.Drive`), so that the drive's efficiency
    formulas take the stage as they are: ``power_loss_bearing`` [W] summed over the crank
    pins of each disc (Q, A, D), ``input_torque`` [N·m] the stage's total ±sgn(T)·P_in/ω
    (Q, A, 1; P_in from the crank pins' forces,
    :func:`cyclomesh.stage.friction.power_terms`; − back-driving, the
    crank turning the other way), ``speed`` ω [rad/s]. The one conversion of the stage's
    friction results (module doc).

    Returns a namespace with ``friction``, ``torque`` [N·m] (Q,), ``contacts`` (Q, A, D),
    ``transmission_error`` and ``loaded_rotation`` (the output's TE [rad], (Q, A))."""
    fr = dict(result.friction)
    fr["power_loss_bearing"] = np.sum(fr["power_loss_bearing"], axis=-1)
    sign = motion * np.sign(result.torque)[:, None]  # the crank's turn: T_in·ω = P_in
    fr["input_torque"] = (sign * fr["input_power"] / speed)[..., None]
    return SimpleNamespace(
        contacts=result.contacts,
        transmission_error=result.transmission_error,
        loaded_rotation=result.transmission_error,
        torque=result.torque,
        friction=fr,
    )


def stage_efficiency(case, model, backdrive: bool = False) -> dict[str, float]:
    """The RV stage's efficiency at one torque [-]: ``stage_efficiency`` from the stage
    solved with the crank driving the torque (``model.friction`` in the equilibrium,
    :func:`cyclomesh.stage.solve.solve`) and, with ``backdrive``,
    ``stage_backdrive_efficiency`` from a second solve with the torque driving the crank
    back. The solves are read as a drive's (:func:`as_drive`, as ``cyclomesh run`` reads
    them) and reduced by the drive's formulas
    (:func:`cyclomesh.drive.friction.mean_efficiency`,
    :func:`~cyclomesh.drive.friction.mean_backdrive_efficiency`): the losses at the pins
    (pin–tooth or pin–groove) and in the crank bearings, averaged over the crank angles.
    A tolerance ring's and a design-map candidate's stage efficiency.

    ``case``: one ring (pin errors without a ring axis) and one torque [N·m]; ``model``: a
    :class:`~cyclomesh.core.case.Model` with a stage and friction (not frictionless)."""
    teeth, speed = case.design.teeth, model.friction.speed
    forward = as_drive(solve(case, model, positions=False), 1.0, speed)
    out = {"stage_efficiency": float(mean_efficiency(forward, teeth, speed))}
    if backdrive:
        back = as_drive(solve(case, model, motion=-1.0, positions=False), -1.0, speed)
        out["stage_backdrive_efficiency"] = float(
            mean_backdrive_efficiency(forward, back, teeth, speed)
        )
    return out
