"""Friction in the loaded solve of a disc stack: the coupling of :mod:`cyclomesh.core.friction`
with :func:`cyclomesh.drive.mesh.load_stack` (one narrow hook: its ``friction`` argument).

:class:`FrictionCoupling` takes a stack's unloaded mesh (:class:`~cyclomesh.drive.mesh.StackMesh`,
in its own, possibly mirrored, frame), the friction and the sense of the motion, and

* solves the load sharing with the friction moment arms l + μ_eff·s·m
  (:func:`cyclomesh.core.friction.torque_arm`; for a lubricated coefficient, which depends
  on the pin loads, by a fixed-point iteration on μ to round-off);
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
    Friction,
    bearing_moment,
    contact_losses,
    effective_coefficient,
    input_torque,
    normal_moment,
    pin_resultant,
    tangential_velocity,
    torque_arm,
)
from cyclomesh.core.loadsharing import share_load
from cyclomesh.exceptions import ConvergenceError

__all__ = ["FrictionCoupling", "FRICTION_FIELDS", "COEFFICIENT_TOLERANCE"]

FloatArray = NDArray[np.float64]

COEFFICIENT_TOLERANCE = 1e-12
"""Change of the lubricated coefficients (and of the bearing moments, relative to T) at which
the fixed point is accepted: that of the load sharing's torque residual, 1e-12·T."""
_MAX_FIXED_POINT = 60

FRICTION_FIELDS = {
    # name: per pin (else per disc)
    "friction_force": True,
    "sliding_velocity_tooth": True,
    "sliding_velocity_groove": True,
    "power_loss_tooth": True,
    "power_loss_groove": True,
    "friction_coefficient": True,
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

        The lubricated coefficients (which depend on the pin loads) and the crank bearing's
        friction moment (on the bearing load, the resultant of the pin forces) are found by
        a fixed-point iteration, each step an exact load sharing, until they change by less
        than :data:`COEFFICIENT_TOLERANCE` (relative to T for the moment)."""
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
        mu = mu.reshape(flat)
        moment = np.zeros(shape[:-1])  # (..., A, N): bearing friction moment on each disc
        total: float | FloatArray = torque
        loaded = None
        previous = None
        for _ in range(_MAX_FIXED_POINT):
            loaded, force = share_load(
                mesh.backlash,
                arm,
                mesh.alpha,
                mesh.gamma,
                total,
                torque_arm(arm, m, mu, sign),
                loaded,  # Newton from the last solution (the values move little)
            )
            if not (lubricated or bearing):
                break
            change = 0.0
            new_mu = mu
            if lubricated:
                new_mu, groove = effective_coefficient(
                    self.friction, geo.cos_beta, force.reshape(shape), velocity, mesh.design.width
                )
                new_mu = new_mu.reshape(flat)
                change = np.max(np.abs(new_mu - mu))
            if bearing:  # the fixed point t = T + s·ΣM(t) of the torque on the pins, by secant
                f = force.reshape(shape)
                rx, ry = self._resultant(f, -sign.reshape(shape) * new_mu.reshape(shape) * f)
                moment = bearing_moment(self.friction, np.hypot(rx, ry))
                used = np.broadcast_to(np.asarray(total, float), moment.shape[:-1])
                residual = torque + self._bearing_sense() * np.sum(moment, axis=-1) - used
                change = max(change, np.max(np.abs(residual)) / torque)
                step = residual  # plain iteration: g(t) = T + s·ΣM(t) − t has slope ≈ −1
                if previous is not None:
                    moved = used != previous[0]
                    slope = (residual - previous[1]) / np.where(moved, used - previous[0], 1.0)
                    secant = moved & (slope < -0.5)
                    step = np.where(secant, -residual / np.where(secant, slope, -1.0), step)
                previous = (used, residual)
                total = used + step
            if change <= COEFFICIENT_TOLERANCE:
                break  # the last solve used values within the tolerance of the fixed point
            mu = new_mu
        else:
            raise ConvergenceError(
                "friction coefficients and bearing moments did not settle to "
                f"{COEFFICIENT_TOLERANCE:.0e} in {_MAX_FIXED_POINT} iterations"
            )
        state = {
            "mu": mu.reshape(shape),
            "groove": np.broadcast_to(groove, shape),
            "velocity": velocity,
            "sign": sign.reshape(shape),
        }
        state["bearing_moment"] = moment  # within the tolerance of the one the solve used
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
            "input_torque": t_in,
            "power_loss_bearing": moment * relative,
        }
