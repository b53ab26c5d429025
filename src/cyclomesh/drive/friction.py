"""Friction in the loaded solve of a disc stack: the coupling of :mod:`cyclomesh.core.friction`
with :func:`cyclomesh.drive.mesh.load_stack` (one narrow hook: its ``friction`` argument).

:class:`FrictionCoupling` takes a stack's unloaded mesh (:class:`~cyclomesh.drive.mesh.StackMesh`,
in its own, possibly mirrored, frame), the friction and the sense of the motion, and

* solves the load sharing with the friction moment arms l + μ_eff·s·m
  (:func:`cyclomesh.core.friction.torque_arm`); a lubricated coefficient and the crank
  bearing's moment, which depend on the pin loads, in the same Newton loop
  (:class:`cyclomesh.core.friction.FrictionBalance`);
* returns the per-pin tangential forces, sliding velocities and power losses, and the
  input (crank) torque from the moment balance of the crank.

The motion: ``motion = +1`` for the crank turning counter-clockwise in the mesh's frame
(φ increasing), −1 for the opposite; ``loading = ±1`` instead for a torsion test, the crank
held and the disc turning counter-clockwise (+1, the torque rising on the forward flanks)
or clockwise about its centre. The mirror problem of the reverse flanks turns each sense
over (the caller passes it in that frame).

References
----------
See :mod:`cyclomesh.core.friction`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.friction import (
    Film,
    Friction,
    FrictionBalance,
    bearing_moment,
    coefficients,
    contact_losses,
    effective_coefficient,
    input_torque,
    loaded_film_parameter,
    lubrication_constants,
    normal_moment,
    pin_resultant,
    tangential_velocity,
    torque_arm,
)
from cyclomesh.core.loadsharing import share_load

__all__ = ["FrictionCoupling", "FRICTION_FIELDS", "mean_efficiency", "mean_backdrive_efficiency"]

FloatArray = NDArray[np.float64]

FRICTION_FIELDS = {
    # name: per pin (else per disc)
    "friction_force": True,
    "sliding_velocity_tooth": True,
    "sliding_velocity_groove": True,
    "power_loss_tooth": True,
    "power_loss_groove": True,
    "friction_coefficient": True,
    "film_parameter": True,
    "input_torque": False,
    "power_loss_bearing": False,
}
"""The fields :meth:`FrictionCoupling.fields` adds to a loaded state, per pin or per disc;
the sign each takes in the mirror image is its row's parity in
:data:`cyclomesh.quantities.QUANTITIES`."""


@dataclass(frozen=True)
class FrictionCoupling:
    """Friction of one loaded state of a stack (see the module doc).

    Parameters
    ----------
    mesh : StackMesh
        The unloaded stack, arrays (..., A, N, n1).
    friction : Friction
    motion : float
        +1 or −1: sense of the crank's turn in the mesh's frame (drive); 0 for a torsion
        test (crank held), with ``loading``.
    loading : float
        +1 or −1: sense of the disc's turn about its centre in a torsion test.
    """

    mesh: object
    friction: Friction
    motion: float = 1.0
    loading: float = 0.0

    def _velocity(self) -> FloatArray:
        """Tangential velocity of the disc at each contact, per unit of the motion [m/rad]."""
        mesh, geo = self.mesh, self.mesh.geo
        discs = geo.rotation.shape[-2]
        if self.motion == 0.0:  # torsion test: the disc turns about its centre, v·t = m
            return self.loading * normal_moment(geo.contact_radius, geo.moment_arm)
        crank = mesh.phi[:, None] + 2.0 * np.pi * np.arange(discs) / discs  # (A, N)
        v = tangential_velocity(
            mesh.eccentricity,
            crank[..., None],
            mesh.normal_x,
            mesh.normal_y,
            geo.contact_radius,
            geo.moment_arm,
            mesh.design.teeth,
        )
        return self.motion * v

    def _film(self) -> Film:
        """Reduced radii and E' of the pin contacts (:meth:`.Film.of_contacts`)."""
        geo = self.mesh.geo
        return Film.of_contacts(self.mesh.design, geo.pin_radius, geo.curvature_radius)

    def _resultant(
        self, force: FloatArray, tangential: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Resultant R of the pin forces on each disc, −F·n + T·t summed [N], (..., A, N)."""
        return pin_resultant(force, tangential, self.mesh.normal_x, self.mesh.normal_y)

    def _bearing_sense(self) -> float:
        """Sense of the crank bearing's friction moment on the disc (module doc): with the
        crank's turn in a drive, against the disc's turn in a torsion test."""
        return self.motion if self.motion != 0.0 else -self.loading

    def share(self, torque: float) -> tuple[FloatArray, FloatArray, dict[str, FloatArray]]:
        """Load sharing with friction: (rotation (..., A), force (..., A, N·n1), state).

        Coulomb coefficients: the load sharing with the friction moment arms. The
        lubricated coefficients (which depend on the pin loads) and the crank bearing's
        friction moment (on the bearing load, the resultant of the pin forces) are
        functions of the pin loads, hence of the rotation alone: they enter the same
        Newton loop (:class:`~cyclomesh.core.friction.FrictionBalance`), so that μ and M_b
        are those of the returned loads exactly and the torque residual is at round-off
        (:data:`~cyclomesh.core.loadsharing.ROUND_OFF_TORQUE`), in one load sharing."""
        mesh, geo = self.mesh, self.mesh.geo
        flat = mesh.backlash.shape
        shape = geo.rotation.shape
        arm = geo.moment_arm.reshape(flat)
        velocity = self._velocity()
        sign = np.sign(velocity).reshape(flat)
        m = normal_moment(geo.contact_radius, geo.moment_arm).reshape(flat)
        lubricated = self.friction.lubricant is not None and self.motion != 0.0
        bearing = self.friction.bearing > 0
        mu, groove = effective_coefficient(self.friction, geo.cos_beta)
        mu = np.broadcast_to(mu, shape).reshape(flat)
        film = self._film() if lubricated else None
        lam = np.zeros(shape)
        arm_cap = torque_arm(arm, m, mu, sign)  # the boundary (largest) coefficient
        moment = np.zeros(shape[:-1])  # (..., A, N): bearing friction moment on each disc
        if not (lubricated or bearing):
            loaded, force = share_load(mesh.backlash, arm, mesh.alpha, mesh.gamma, torque, arm_cap)
        else:
            data = {"arm": arm, "normal_moment": m, "sign": sign}
            if lubricated:
                speed = np.abs(velocity) * self.friction.speed
                data["cos_beta"] = np.broadcast_to(geo.cos_beta, shape).reshape(flat)
                constants = lubrication_constants(
                    self.friction, geo.cos_beta, speed, mesh.design.width, film
                )
                constants = {
                    key: np.broadcast_to(value, shape).reshape(flat)
                    for key, value in constants.items()
                }
                constants["cos_beta"] = data["cos_beta"]
                data.update(constants)
            else:
                data["mu"] = mu
            if bearing:
                discs = shape[-2]
                data["normal_x"] = np.broadcast_to(mesh.normal_x, shape).reshape(flat)
                data["normal_y"] = np.broadcast_to(mesh.normal_y, shape).reshape(flat)
                index = np.arange(discs, dtype=float)[:, None]
                data["disc"] = np.broadcast_to(index, shape).reshape(flat)
            balance = FrictionBalance(
                self.friction, data, mesh.design.width, shape[-2], self._bearing_sense(), film
            )
            # the start and the candidates from the smallest arm a pin can have
            loaded, force = share_load(
                mesh.backlash,
                arm,
                mesh.alpha,
                mesh.gamma,
                torque,
                np.minimum(arm, arm_cap),
                balance=balance,
            )
            f = force.reshape(shape)
            if lubricated:  # the coefficients and λ of the returned loads, as the loop had them
                on = force > 0
                sub = {key: value[on] for key, value in constants.items()}
                mu_on, groove_on, _ = coefficients(
                    self.friction, sub["cos_beta"], force[on], constants=sub
                )
                mu = mu.copy()
                mu[on] = mu_on
                groove = np.array(np.broadcast_to(groove, shape)).reshape(flat)
                groove[on] = groove_on
                lam = loaded_film_parameter(constants, force, groove).reshape(shape)
                groove = groove.reshape(shape)
            if bearing:
                rx, ry = self._resultant(f, -sign.reshape(shape) * mu.reshape(shape) * f)
                moment = bearing_moment(self.friction, np.hypot(rx, ry))
        state = {
            "mu": mu.reshape(shape),
            "groove": np.broadcast_to(groove, shape),
            "velocity": velocity,
            "sign": sign.reshape(shape),
            "bearing_moment": moment,  # those of the returned loads: the balance's own
            "film_parameter": lam,
        }
        return loaded, force, state

    def fields(self, force: FloatArray, state: dict[str, FloatArray]) -> dict[str, FloatArray]:
        """Per-pin friction force [N], sliding velocities [m/s], power losses [W] and
        coefficient [-], and the input torque per disc [N·m] (:data:`FRICTION_FIELDS`)."""
        mesh = self.mesh
        mu, groove, velocity, sign = state["mu"], state["groove"], state["velocity"], state["sign"]
        speed = self.friction.speed if self.motion != 0.0 else 0.0
        friction_force = mu * force
        sliding = np.abs(velocity) * speed
        loss = contact_losses(mu, force, velocity, speed)
        discs = force.shape[-2]
        crank = mesh.phi[:, None] + 2.0 * np.pi * np.arange(discs) / discs
        t_in = input_torque(
            force,
            -sign * friction_force,
            mesh.normal_x,
            mesh.normal_y,
            mesh.eccentricity[..., 0],
            crank,
        )
        moment = state["bearing_moment"]
        if self.motion != 0.0:  # the crank overcomes the bearing's drag too
            t_in = t_in + self.motion * moment
        relative = speed * (1.0 + 1.0 / mesh.design.teeth)  # crank against disc
        return {
            "friction_force": friction_force,
            "sliding_velocity_tooth": np.where(groove, 0.0, sliding),
            "sliding_velocity_groove": np.where(groove, sliding, 0.0),
            "power_loss_tooth": np.where(groove, 0.0, loss),
            "power_loss_groove": np.where(groove, loss, 0.0),
            "friction_coefficient": mu,
            "film_parameter": state["film_parameter"],
            "input_torque": t_in,
            "power_loss_bearing": moment * relative,
        }


def _mean_loss(friction: dict) -> NDArray[np.float64]:
    """Power loss of the pins and the crank bearings [W], the mean over the crank angles of
    the first torque, (...) of every ring."""
    loss = np.sum(friction["power_loss_tooth"] + friction["power_loss_groove"], axis=(-2, -1))
    loss = loss + np.sum(friction["power_loss_bearing"], axis=-1)  # (..., Q, A)
    return np.mean(loss[..., 0, :], axis=-1)


def mean_efficiency(result, teeth: int, speed: float) -> NDArray[np.float64]:
    """Forward efficiency of every ring of a one-torque drive with friction [-]:
    P_out/(P_out + P_loss), P_out = |T|·ω/n2 [W] (``teeth`` n2, ``speed`` ω [rad/s]),
    P_loss the mean over the crank angles of the pins' and the crank bearings' losses (as
    :func:`cyclomesh.results.efficiency.efficiency_record` takes it for one case).
    ``result``: a :class:`~cyclomesh.drive.solve.Drive` (or the RV stage read as one,
    :func:`cyclomesh.stage.efficiency.as_drive`); the tolerance rings' and the stage's
    efficiency."""
    p_out = np.abs(result.torque[0]) * speed / teeth
    return p_out / (p_out + _mean_loss(result.friction))


def mean_backdrive_efficiency(forward, backward, teeth: int, speed: float) -> NDArray[np.float64]:
    """Back-driving efficiency of every ring [-]: (P_out − P_loss,b)/P_out with P_out =
    |T|·ω/n2 of the forward drive and P_loss,b the mean over the crank angles of the
    back-driven solve's losses (pins and crank bearings), as
    :func:`cyclomesh.results.efficiency.efficiency_record` takes it for one case: the
    output shaft delivers P_out, the crank receives what the losses leave of it."""
    p_out = np.abs(forward.torque[0]) * speed / teeth
    return (p_out - _mean_loss(backward.friction)) / p_out
