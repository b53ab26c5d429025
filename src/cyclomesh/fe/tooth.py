"""Tooth compliance of the cycloid disc along its profile by FE, against Eq. 20.

One elastic pin (radius ρp, centre node embedded) touches the modified profile at
generating angle φ1 and is pushed into the disc along the profile normal by a line
load F [N/m] at its centre; the pin's tangential motion and rotation are held by zero
tangential displacement of its centre and of its far-side node (both carry no load on
a frictionless circle). The whole disc is meshed, its bore of radius r_b is fixed.

The tooth's approach is the displacement of the disc's surface at the centre of the
contact, along the inward normal, relative to the fixed bore: δdisc = −n·u_disc. Its
compliance per unit length δdisc/F [m²/N] is compared with the disc's term of the
contact laws of :mod:`cyclomesh.core.hertz` per unit length:

* ``paper`` (Eq. 20 of [1]):       (2/π)·c·(ln(4|ρc|/b) − ½)
* ``half_plane`` (Johnson 5.41):  (2/π)·c·(ln(2d/b) − ν/(2(1 − ν))), d = |r_contact|
  (the law of the core) and d = |r_contact| − r_b (the depth to this model's bore)

with c = (1 − ν²)/E of the disc and b the Hertz half-width of pin and tooth (Eq. 22).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.hertz import effective_modulus, half_width, pin_tooth_radius
from cyclomesh.core.pair import Modification, PairDesign
from cyclomesh.core.profile import curvature_radius, generating_radii, locus, modified_profile
from cyclomesh.fe.mesh import Refinement, mesh_disk, mesh_profile_disc
from cyclomesh.fe.solve import Body, ContactPair, boundary_chain, solve_contact, summarize_contact

__all__ = ["ToothCompliance", "tooth_compliance", "disc_outline", "profile_point"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ToothCompliance:
    """Disc (tooth) compliance per unit length at each profile angle [m²/N]."""

    profile_angle_deg: FloatArray
    curvature_radius: FloatArray
    contact_radius: FloatArray
    fe: FloatArray
    paper: FloatArray
    half_plane: FloatArray
    half_plane_bore: FloatArray
    half_width_fe: FloatArray
    half_width_hertz: FloatArray
    peak_pressure_fe: FloatArray
    peak_pressure_hertz: FloatArray
    nodes: NDArray


def profile_point(
    design: PairDesign, modification: Modification, phi1: float
) -> tuple[FloatArray, FloatArray]:
    """Profile point (2,) [m] and outward unit normal (2,) at generating angle φ1 [rad]."""
    x, y = modified_profile(design, modification, phi1)
    a, _ = generating_radii(design, modification)
    _, _, dx, dy, _, _ = locus(phi1 / design.teeth, a, design.eccentricity, design.pins)
    n = np.array([dy, -dx]) / np.hypot(dx, dy)
    return np.array([float(x), float(y)]), n


def disc_outline(
    design: PairDesign,
    modification: Modification,
    contacts: FloatArray,
    per_tooth: int = 48,
    local_span: float = 0.02,
    local_points: int = 41,
) -> tuple[FloatArray, NDArray]:
    """Outline points (2, K) of the whole disc [m] and the indices of the contacts.

    Uniform in φ1 with ``per_tooth`` points a tooth, plus ``local_points`` points within
    ±``local_span`` rad of φ1 around each contact so the splines follow the profile's
    curvature closely where it matters.
    """
    n2 = design.teeth
    total = 2.0 * np.pi * n2
    phi = np.linspace(0.0, total, per_tooth * n2, endpoint=False)
    contacts = np.mod(np.asarray(contacts, float), total)
    local = (contacts[:, None] + np.linspace(-local_span, local_span, local_points)).ravel()
    keep = np.all(
        np.abs(np.angle(np.exp(1j * (phi[:, None] - contacts[None]) / n2))) * n2 > 1.5 * local_span,
        axis=1,
    )
    phi = np.unique(np.concatenate([phi[keep], np.mod(local, total), contacts]))
    x, y = modified_profile(design, modification, phi)
    breaks = np.searchsorted(phi, contacts)
    return np.stack([x, y]), breaks


def tooth_compliance(
    design: PairDesign,
    modification: Modification | None,
    profile_angles_deg: FloatArray,
    line_load: float = 4e4,
    bore_radius: float = 30e-3,
    elements_per_half_width: float = 10.0,
    far_size: float = 1.5e-3,
) -> ToothCompliance:
    """Measure the tooth compliance along the profile by FE (see the module docstring).

    Parameters
    ----------
    design, modification
        The pair (Table 1 of [1] for the paper's example).
    profile_angles_deg : array_like
        Generating angles φ1 of the contacts [deg] (the loaded flank is φ1 ∈ (−180°, 0)).
    line_load : float
        F per unit face width [N/m].
    bore_radius : float
        Radius of the fixed bore [m].
    elements_per_half_width : float
        Mesh size at the contact is b/this.
    far_size : float
        Mesh size far from the contact [m].
    """
    modification = modification or Modification()
    pin_m, disc_m = design.pin_material, design.disc_material
    rp = design.pin_radius
    e_star = effective_modulus(pin_m.compliance, disc_m.compliance)
    angles = np.atleast_1d(np.asarray(profile_angles_deg, float))
    out: dict[str, list[float]] = {k: [] for k in ("fe", "b", "p", "nodes")}
    rho_c = curvature_radius(np.deg2rad(angles) / design.teeth, design, modification)
    r_c = []
    for phi_deg, rc in zip(angles, rho_c, strict=True):
        phi1 = np.deg2rad(phi_deg)
        point, normal = profile_point(design, modification, phi1)
        r_c.append(float(np.hypot(*point)))
        b = float(half_width(line_load, pin_tooth_radius(rp, rc), e_star, 1.0))
        h = b / elements_per_half_width
        refine = Refinement([tuple(point)], h, 1.5 * b, far_size, 4e-3)
        outline, breaks = disc_outline(design, modification, np.array([phi1]))
        disc = Body(
            *mesh_profile_disc(outline, bore_radius, refine, breaks),
            disc_m.youngs_modulus,
            disc_m.poisson_ratio,
        )
        centre = point + rp * normal
        far = centre + rp * normal
        pin = Body(
            *mesh_disk(tuple(centre), rp, refine, embed=[tuple(centre)]),
            pin_m.youngs_modulus,
            pin_m.poisson_ratio,
        )
        slave = boundary_chain(pin, tuple(point), 4.0 * b)
        master = boundary_chain(disc, tuple(point), 6.0 * b)
        tangent = np.array([-normal[1], normal[0]])
        eq = []
        bore = np.flatnonzero(np.abs(np.hypot(*disc.mesh.p) - bore_radius) < 1e-6 * bore_radius)
        eq += [([(1, disc.dof(n, c), 1.0)], 0.0) for n in bore for c in (0, 1)]
        for node in (pin.nearest_node(tuple(centre)), pin.nearest_node(tuple(far))):
            eq.append(([(0, pin.dof(node, 0), tangent[0]), (0, pin.dof(node, 1), tangent[1])], 0.0))
        c_node = pin.nearest_node(tuple(centre))
        sol = solve_contact(
            [pin, disc],
            [ContactPair(0, 1, slave, master)],
            equalities=eq,
            forces=[
                (0, pin.dof(c_node, 0), -line_load * normal[0]),
                (0, pin.dof(c_node, 1), -line_load * normal[1]),
            ],
        )
        summary = summarize_contact(pin.mesh.p[:, slave], sol.contact_force[0])
        # disc displacement at the contact centre, interpolated along the master chain
        xm = disc.mesh.p[:, master]
        um = sol.displacements[1][:, master]
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xm, axis=1)))])
        k = int(np.argmin(np.hypot(*(xm - summary.centre[:, None]))))
        s_c = s[k] + np.dot(summary.centre - xm[:, k], _chord(xm, k))
        u_c = np.array([np.interp(s_c, s, um[0]), np.interp(s_c, s, um[1])])
        out["fe"].append(float(-normal @ u_c / line_load))
        out["b"].append(summary.half_width)
        out["p"].append(summary.peak_pressure)
        out["nodes"].append(pin.n_nodes + disc.n_nodes)
    r_c = np.asarray(r_c)
    rho_star = pin_tooth_radius(rp, rho_c)
    b_h = half_width(line_load, rho_star, e_star, 1.0)
    c, nu = disc_m.compliance, disc_m.poisson_ratio
    tail = nu / (2.0 * (1.0 - nu))
    return ToothCompliance(
        profile_angle_deg=angles,
        curvature_radius=rho_c,
        contact_radius=r_c,
        fe=np.asarray(out["fe"]),
        paper=2.0 / np.pi * c * (np.log(4.0 * np.abs(rho_c) / b_h) - 0.5),
        half_plane=2.0 / np.pi * c * (np.log(2.0 * r_c / b_h) - tail),
        half_plane_bore=2.0 / np.pi * c * (np.log(2.0 * (r_c - bore_radius) / b_h) - tail),
        half_width_fe=np.asarray(out["b"]),
        half_width_hertz=b_h,
        peak_pressure_fe=np.asarray(out["p"]),
        peak_pressure_hertz=2.0 * line_load / (np.pi * b_h),
        nodes=np.asarray(out["nodes"]),
    )


def _chord(xm: FloatArray, k: int) -> FloatArray:
    j = k + 1 if k + 1 < xm.shape[1] else k - 1
    d = xm[:, j] - xm[:, k]
    d = d / np.hypot(*d)
    return d if j > k else -d
