"""Whole cycloid disc and its pins by FE at one crank angle, beside the LTCA.

Model (2-D, plane strain, linear elastic, small deformation, frictionless), built in
the disc frame at the disc's unloaded rest position (Eq. 11), so the pins' gaps are
their exact backlashes:

* the disc: its whole modified profile (splines through the exact profile, broken at
  every potential contact so the contact point is a node) with a bore of radius
  ``bore_radius`` whose nodes are tied to a rigid centre that may rotate by θ (its
  translation is held by the crank bearing) and carries the torque T/B;
* each pin that the LTCA loads, or whose gap is within reach of the loaded approach:
  an elastic disk, contact with the disc unilateral (:func:`solve_contact`);
* each pin's groove: the ring's term of the Hertz law of Eq. 21 as a spring between the
  ground and the mean normal displacement of the pin's groove side (weighted by the
  Hertzian pressure of half-width b_pg over the nodes it covers), acting along the
  line of action through the pin centre (frictionless: the groove's reaction passes
  through the centres). The pin's own deformation is the FE's. The spring's secant
  stiffness depends on the load through b_pg; it is updated until the loads settle.

The mesh is refined at each contact to ``elements_per_half_width`` elements on the Hertz
half-width of the LTCA load.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.contact import unloaded_contact
from cyclomesh.core.hertz import (
    CONTACT_LAWS,
    effective_modulus,
    half_width,
    max_pressure,
    pin_groove_radius,
    pin_tooth_radius,
)
from cyclomesh.core.ltca import rest_position, solve_ltca
from cyclomesh.core.pair import Modification, PairDesign
from cyclomesh.core.profile import modified_profile
from cyclomesh.exceptions import ConvergenceError
from cyclomesh.fe.mesh import Refinement, mesh_disk, mesh_profile_disc
from cyclomesh.fe.solve import Body, ContactPair, boundary_chain, solve_contact, summarize_contact
from cyclomesh.fe.tooth import disc_outline

__all__ = ["DiscFE", "solve_disc_fe"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DiscFE:
    """FE and LTCA results at one crank angle (SI; per pin arrays of length n1).

    Attributes
    ----------
    pin_load_fe, pin_load_ltca : ndarray
        Pin–tooth force [N] (on the face width B).
    contact_stress_fe, contact_stress_ltca : ndarray
        Peak pin–tooth contact pressure [Pa]. FE: recovered from the nodal pressures
        where the contact is resolved (``stress_resolved``), else the Hertz pressure of
        the FE load (Eq. 24 with the FE force).
    stress_resolved : ndarray
        Pins whose FE peak pressure is recovered from at least three closed nodes
        within b/2 (bool); a pin without load counts as resolved (0 Pa).
    rotation_fe, rotation_ltca : float
        Loaded rotation Δφc of the disc [rad].
    rest_rotation : float
        φc − φt of the unloaded disc [rad].
    modelled : ndarray
        Pins in the FE model (bool).
    nodes : int
        Nodes of the FE model.
    groove_iterations : int
        Updates of the projections and the groove springs together.
    """

    pin_load_fe: FloatArray
    pin_load_ltca: FloatArray
    contact_stress_fe: FloatArray
    contact_stress_ltca: FloatArray
    rotation_fe: float
    rotation_ltca: float
    rest_rotation: float
    modelled: NDArray
    nodes: int
    groove_iterations: int
    ltca_by_law: dict[str, tuple[FloatArray, FloatArray, float]]
    """Per contact law of :data:`cyclomesh.core.hertz.CONTACT_LAWS`: (pin load [N], contact
    stress [Pa], loaded rotation [rad]) of the LTCA."""
    stress_resolved: NDArray
    torque_fe: float = np.nan
    """Moment of the FE contact forces on the disc about its centre [N·m] (the torque
    they balance)."""
    penetration: float = np.nan
    """Largest penetration of an open contact node, relative to the largest pin
    displacement (≤ 1e-8, else the solve raises)."""


def solve_disc_fe(
    design: PairDesign,
    modification: Modification | None,
    torque: float,
    crank_angle: float,
    bore_radius: float = 30e-3,
    elements_per_half_width: float = 8.0,
    far_size: float = 1.5e-3,
    contact_law: str = "half_plane",
    reach: float = 2.0,
    groove_tolerance: float = 1e-7,
    disc_body: object = "rigid",
) -> DiscFE:
    """Solve the whole disc with its pins by FE at one crank angle [rad]; LTCA beside it.

    Parameters
    ----------
    design, modification
        The pair.
    torque : float
        T [N·m].
    crank_angle : float
        φin [rad].
    bore_radius : float
        Radius of the bore tied to the rigid centre [m].
    elements_per_half_width : float
        Mesh size at each contact: b/this, b the Hertz half-width at the LTCA load.
    far_size : float
        Mesh size far from the contacts [m].
    contact_law : str
        Contact law of the LTCA beside it.
    reach : float
        Pins whose unloaded gap is below ``reach`` times the largest LTCA approach are
        modelled (the others cannot be reached).
    disc_body : "rigid" or DiscBody
        The disc body of the LTCA beside the FE under ``contact_law`` (the
        ``ltca_by_law`` entries stay rigid-disc).
    groove_tolerance : float
        The projections of the gaps and the groove stiffness are updated together
        until no contact force changes by more than this fraction of the largest, no gap
        by more than this fraction of the closure and no groove stiffness by more than
        this fraction of itself.

    Raises
    ------
    ConvergenceError
        If the contact or the groove update does not converge, or the solution fails its
        checks (penetration, tensile contact force, torque balance).
    """
    modification = modification or Modification()
    phi = np.atleast_1d(float(crank_angle))
    by_law = {}
    for law in CONTACT_LAWS:
        r = solve_ltca(design, modification, None, torque, phi, True, law)
        by_law[law] = (r.pin_load[0], r.contact_stress[0], float(r.loaded_rotation[0]))
        if law == contact_law:
            ltca = r
            if not isinstance(disc_body, str):
                ltca = solve_ltca(design, modification, None, torque, phi, True, law, disc_body)
    geo = unloaded_contact(design, modification, None, phi)
    rest = float(rest_position(geo.rotation, geo.moment_arm)[0])
    n1, n2, rp = design.pins, design.teeth, design.pin_radius
    pin_m, disc_m, ring_m = design.pin_material, design.disc_material, design.ring_material
    load_ltca = ltca.pin_load[0]
    with np.errstate(invalid="ignore"):  # pins without contact: nan rotation, arm 0
        gap = (geo.rotation[0] - rest) * geo.moment_arm[0]
    approach = float(
        np.max(np.where(load_ltca > 0, ltca.loaded_rotation[0] * geo.moment_arm[0], 0))
    )
    modelled = (load_ltca > 0) | (
        np.isfinite(gap) & (gap < reach * approach) & (geo.moment_arm[0] > 0)
    )
    pins = np.flatnonzero(modelled)

    # the disc frame at rest: pin centres q_i = R(−φc)·(C_i − O2)
    phi_c = -phi[0] / n2 + rest
    ang = np.arange(n1) * design.pitch
    wx = design.pin_circle_radius * np.cos(ang) - design.eccentricity * np.cos(phi[0])
    wy = design.pin_circle_radius * np.sin(ang) - design.eccentricity * np.sin(phi[0])
    c, s = np.cos(-phi_c), np.sin(-phi_c)
    q = np.stack([c * wx - s * wy, s * wx + c * wy])
    u_nom = n2 * ang + phi[0]
    phi1 = 2.0 * np.pi * np.round(u_nom / (2.0 * np.pi)) + geo.profile_angle[0]

    width = design.width
    e_pc = effective_modulus(pin_m.compliance, disc_m.compliance)
    e_pg = effective_modulus(pin_m.compliance, ring_m.compliance)
    nominal = np.where(load_ltca > 0, load_ltca, 0.2 * load_ltca.max()) / width  # N/m
    b_pc = half_width(nominal, pin_tooth_radius(rp, geo.curvature_radius[0]), e_pc, 1.0)
    rho_pg = pin_groove_radius(rp, design.groove_radius)
    b_pg = half_width(nominal, rho_pg, e_pg, 1.0)

    outline, breaks = disc_outline(design, modification, phi1[pins])
    px, py = modified_profile(design, modification, phi1[pins])
    points = np.stack([px, py])
    # each contact refined to its own half-width (they differ by 10x and more without
    # TPM, where pins near the inflection points have a large ρc and a wide contact)
    refine = Refinement(
        [tuple(p) for p in points.T],
        list(b_pc[pins] / elements_per_half_width),
        list(1.5 * b_pc[pins]),
        far_size,
        4e-3,
    )
    disc = Body(
        *mesh_profile_disc(outline, bore_radius, refine, breaks),
        disc_m.youngs_modulus,
        disc_m.poisson_ratio,
    )
    bodies = [disc]
    pairs, eq, weights, normals = [], [], [], []
    n_pins = pins.size
    for k, i in enumerate(pins):
        p_i = points[:, k]
        n_i = (q[:, i] - p_i) / np.hypot(*(q[:, i] - p_i))
        t_i = np.array([-n_i[1], n_i[0]])
        g_i = q[:, i] + rp * n_i
        h_i = float(b_pc[i]) / elements_per_half_width
        pin_refine = Refinement(
            [tuple(p_i)], h_i, 1.5 * float(b_pc[i]), min(far_size, rp / 6), 3e-3
        )
        pin = Body(
            *mesh_disk(tuple(q[:, i]), rp, pin_refine, embed=[tuple(q[:, i])]),
            pin_m.youngs_modulus,
            pin_m.poisson_ratio,
        )
        bodies.append(pin)
        body = k + 1
        slave = boundary_chain(pin, tuple(p_i), 2.5 * float(b_pc[i]))
        master = boundary_chain(disc, tuple(p_i), 4.0 * float(b_pc[i]))
        pairs.append(ContactPair(body, 0, slave, master))
        # groove side: Hertzian weights over the nodes within b_pg of g_i
        side = boundary_chain(pin, tuple(g_i), max(float(b_pg[i]), 2.5 * rp / 6))
        xy = pin.mesh.p[:, side]
        dist = np.hypot(*(xy - g_i[:, None]))
        bw = max(float(b_pg[i]), 1.01 * float(np.sort(dist)[1]))
        w = np.sqrt(np.clip(1.0 - (dist / bw) ** 2, 0.0, None))
        w = w / w.sum()
        weights.append((side, w))
        normals.append(n_i)
        # w_k (extra unknown 1 + k) = Σ ω n·u ;  Σ ω t·u = 0 ; t·u(centre) = 0
        eq.append(
            (
                [
                    (body, pin.dof(side, 0), w * n_i[0]),
                    (body, pin.dof(side, 1), w * n_i[1]),
                    (-1, 1 + k, -1.0),
                ],
                0.0,
            )
        )
        eq.append(
            ([(body, pin.dof(side, 0), w * t_i[0]), (body, pin.dof(side, 1), w * t_i[1])], 0.0)
        )
        centre = pin.nearest_node(tuple(q[:, i]))
        eq.append(([(body, pin.dof(centre, 0), t_i[0]), (body, pin.dof(centre, 1), t_i[1])], 0.0))
    # bore tied to the rigid centre (extra unknown 0 = θ): u = θ × x
    bore = np.flatnonzero(np.abs(np.hypot(*disc.mesh.p) - bore_radius) < 1e-6 * bore_radius)
    for node in bore:
        x, y = disc.mesh.p[:, node]
        eq.append(([(0, disc.dof(node, 0), 1.0), (-1, 0, y)], 0.0))
        eq.append(([(0, disc.dof(node, 1), 1.0), (-1, 0, -x)], 0.0))

    ring_c = ring_m.compliance
    extra_forces = np.zeros(1 + n_pins)
    extra_forces[0] = torque / width
    floor = 1e-6 * nominal.max()

    def groove_stiffness(loads: FloatArray) -> FloatArray:
        # secant stiffness of the ring's term of Eq. 21: δ = (2F/π)·c_g·(ln(4ρg/b) − ½)
        b = half_width(np.maximum(loads, floor), rho_pg, e_pg, 1.0)
        k = 1.0 / (2.0 / np.pi * ring_c * (np.log(4.0 * design.groove_radius / b) - 0.5))
        return np.concatenate([[0.0], k])

    # the groove stiffness is updated with the projections until both settle
    sol = solve_contact(
        bodies,
        pairs,
        equalities=eq,
        n_extra=1 + n_pins,
        extra_forces=extra_forces,
        extra_stiffness=groove_stiffness(nominal[pins]),
        stiffness_update=lambda lam: groove_stiffness(np.array([x.sum() for x in lam])),
        projection_tolerance=groove_tolerance,
    )
    iteration = sol.projections
    moment, penetration = _check_disc(sol, pairs, bodies, pins, torque / width)
    load_fe = np.zeros(n1)
    stress_fe = np.zeros(n1)
    resolved = np.ones(n1, bool)
    for k, i in enumerate(pins):
        summary = summarize_contact(
            bodies[k + 1].mesh.p[:, pairs[k].slave_nodes], sol.contact_force[k]
        )
        load_fe[i] = summary.load * width
        if summary.load > 0 and not np.isfinite(summary.peak_pressure):
            # too light for the contact mesh: the Hertz pressure of the FE load (Eq. 24)
            resolved[i] = False
            rho = pin_tooth_radius(rp, geo.curvature_radius[0, i])
            stress_fe[i] = max_pressure(load_fe[i], rho, e_pc, width)
        else:
            stress_fe[i] = summary.peak_pressure
    return DiscFE(
        pin_load_fe=load_fe,
        pin_load_ltca=load_ltca,
        contact_stress_fe=stress_fe,
        contact_stress_ltca=ltca.contact_stress[0],
        rotation_fe=float(sol.extra[0]),
        rotation_ltca=float(ltca.loaded_rotation[0]),
        rest_rotation=rest,
        modelled=modelled,
        nodes=int(sum(b.n_nodes for b in bodies)),
        groove_iterations=iteration,
        ltca_by_law=by_law,
        stress_resolved=resolved,
        torque_fe=-moment * width,
        penetration=penetration,
    )


def _check_disc(sol, pairs, bodies, pins, torque_per_width) -> tuple[float, float]:
    """The disc's torque balance from the pin loads, and no penetration at any contact.

    Each contact force acts on the pin along the disc's normal at the node's foot on
    the disc; the moment of the forces on the disc about the rigid centre (in the
    undeformed configuration, that of the small-deformation equilibrium) must balance
    the torque to 1e-6. Returns (moment [N], largest penetration / largest pin
    displacement).
    """
    moment = 0.0
    closure = 0.0
    worst = 0.0
    for k, _ in enumerate(pins):
        lam, normal = sol.contact_force[k], sol.normal[k]
        seg, t = sol.master_point[k]
        master = bodies[0].mesh.p[:, pairs[k].master_nodes]
        xy = (1 - t) * master[:, seg] + t * master[:, seg + 1]
        # force on the disc: −λ·n at the contact point
        moment += float(np.sum(-lam * (xy[0] * normal[1] - xy[1] * normal[0])))
        worst = min(worst, float(sol.gap[k].min()))
        closure = max(closure, float(np.abs(sol.displacements[k + 1]).max()))
    if (
        not np.isfinite(moment)
        or abs(moment + torque_per_width) > 1e-6 * abs(torque_per_width)
        or any(lam.min() < 0 for lam in sol.contact_force)
        or worst < -1e-8 * closure
    ):
        raise ConvergenceError(
            f"FE: solution fails its checks (moment {moment:.6g} against torque "
            f"{torque_per_width:.6g} N; largest penetration {-worst:.2g} m)"
        )
    return moment, -worst / closure
