"""The Hertz classics by FE: a cylinder on a flat and a cylinder in a concave seat.

Half models (x ≥ 0, symmetry u_x = 0 on x = 0), plane strain. The cylinder of radius R
(centre (0, R)) rests on the block at the origin; the block's bottom is fixed and the
cylinder is pressed by a line load P/2 (per unit thickness, on the half model) at its
top. Hertz (Johnson §4.3 and §5.6): half-width b = sqrt(4PR*/(πE*)), peak pressure
p0 = 2P/(πb), with 1/R* = 1/R − 1/Rg for a seat of radius Rg (flat: Rg = ∞).

From the FE contact forces λ_i at the slave nodes [N/m]:

* the peak pressure is the top of a least-squares parabola through the nodal
  pressures (force over tributary length) within b/2 of the centre, a local recovery
  that averages out the oscillation of node-to-segment multipliers on non-matching
  meshes (the single node on the axis scatters by a few % on fine meshes);
* the half-width is b = 2·sqrt(Σ x_i² λ_i / Σ λ_i) (for Hertz's pressure
  p0·sqrt(1 − x²/b²), ∫x²p dx / ∫p dx = b²/4), which uses the whole distribution and
  converges as h², where the last closed node would only locate b to ±h.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cyclomesh.fe.mesh import Refinement, mesh_block, mesh_half_disk
from cyclomesh.fe.solve import (
    Body,
    ContactPair,
    boundary_chain,
    solve_contact,
    summarize_contact,
)

__all__ = ["HertzCheck", "hertz_reference", "cylinder_contact"]


@dataclass(frozen=True)
class HertzCheck:
    """FE and Hertz values of one classic case (SI, per unit thickness)."""

    half_width_fe: float
    half_width_hertz: float
    peak_pressure_fe: float
    peak_pressure_hertz: float
    load: float
    load_fe: float
    elements_per_half_width: float
    nodes: int
    closed_nodes: int

    @property
    def half_width_error(self) -> float:
        return self.half_width_fe / self.half_width_hertz - 1.0

    @property
    def peak_pressure_error(self) -> float:
        return self.peak_pressure_fe / self.peak_pressure_hertz - 1.0


def hertz_reference(
    load: float, radius: float, seat_radius: float | None, modulus: float, poisson: float
) -> tuple[float, float]:
    """Hertz half-width b [m] and peak pressure p0 [Pa] of a line load P [N/m] (same materials)."""
    e_star = modulus / (2.0 * (1.0 - poisson**2))
    inv_r = 1.0 / radius - (0.0 if seat_radius is None else 1.0 / seat_radius)
    b = np.sqrt(4.0 * load / (inv_r * np.pi * e_star))
    return float(b), float(2.0 * load / (np.pi * b))


def cylinder_contact(
    radius: float = 3.5e-3,
    load: float = 2.5e5,
    seat_radius: float | None = None,
    elements_per_half_width: float = 10.0,
    modulus: float = 206e9,
    poisson: float = 0.3,
) -> HertzCheck:
    """Solve a cylinder on a flat (``seat_radius=None``) or in a seat by FE; compare with Hertz.

    Parameters
    ----------
    radius : float
        Cylinder radius R [m].
    load : float
        Line load P [N/m] (force per unit thickness on the whole cylinder).
    seat_radius : float, optional
        Radius of the concave seat Rg > R [m].
    elements_per_half_width : float
        Element size at the contact is b/this.
    modulus, poisson : float
        E [Pa] and ν of both bodies.
    """
    b, p0 = hertz_reference(load, radius, seat_radius, modulus, poisson)
    h = b / elements_per_half_width
    refine = Refinement([(0.0, 0.0)], h, 1.5 * b, radius / 6.0, 2.0 * radius)
    pin = Body(*mesh_half_disk(radius, refine), modulus, poisson)
    block = Body(*mesh_block(5.0 * radius, 5.0 * radius, refine, seat_radius), modulus, poisson)
    off_axis = lambda mid: mid[0] > 1e-3 * h  # noqa: E731
    slave = boundary_chain(pin, (0.0, 0.0), 4.0 * b, off_axis)
    master = boundary_chain(block, (0.0, 0.0), 6.0 * b, off_axis)
    bottom = np.abs(block.mesh.p[1] + 5.0 * radius) < 1e-9 * radius
    eq = [([(1, block.dof(n, c), 1.0)], 0.0) for n in np.flatnonzero(bottom) for c in (0, 1)]
    for i, body in enumerate((pin, block)):
        axis = (np.abs(body.mesh.p[0]) < 1e-9 * radius) & ~(bottom if i else False)
        eq += [([(i, body.dof(n, 0), 1.0)], 0.0) for n in np.flatnonzero(axis)]
    top = pin.nearest_node((0.0, 2.0 * radius))
    sol = solve_contact(
        [pin, block],
        [ContactPair(0, 1, slave, master)],
        equalities=eq,
        forces=[(0, pin.dof(top, 1), -load / 2.0)],
    )
    lam = sol.contact_force[0]
    xy = pin.mesh.p[:, slave]
    order = np.argsort(xy[0])
    xy, lam = xy[:, order], lam[order]
    # mirror the half model into the whole contact (the axis node carries both halves)
    full_xy = np.concatenate([xy[:, :0:-1] * [[-1.0], [1.0]], xy], axis=1)
    full_lam = np.concatenate([lam[:0:-1], [2.0 * lam[0]], lam[1:]])
    summary = summarize_contact(full_xy, full_lam)
    closed = lam > 0
    return HertzCheck(
        half_width_fe=summary.half_width,
        half_width_hertz=b,
        peak_pressure_fe=summary.peak_pressure,
        peak_pressure_hertz=p0,
        load=load,
        load_fe=float(2.0 * np.sum(sol.contact_force[0] * sol.normal[0][1])),
        elements_per_half_width=float(elements_per_half_width),
        nodes=pin.n_nodes + block.n_nodes,
        closed_nodes=int(closed.sum()),
    )
