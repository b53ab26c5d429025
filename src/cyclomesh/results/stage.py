"""Labelled results of the RV stage: the Dataset variables and the catalogue data sheet.

Thin layer over :mod:`cyclomesh.stage` (SI inside): :func:`stage_dataset` turns a
:class:`~cyclomesh.stage.solve.Stage` into xarray variables with units (dims
``crank_angle``, ``disc``, ``crank``), :func:`data_sheet` computes the catalogue-style
numbers of a stage at its rated torque and output speed (rigidity and lost motion of the
stage from one solve of mesh, bearings and springs, beside the mesh alone; L10 of the
weakest crank bearing; peak contact stress), :data:`STAGE_METRICS` names them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.core.transmission import gear_ratio
from cyclomesh.quantities import QUANTITIES, select
from cyclomesh.results.metrics import STAGE_METRICS, Metric
from cyclomesh.stage.solve import (
    Stage,
    StageDesign,
    bearing_life,
    solve,
    stage_torsion,
)
from cyclomesh.units import M_PER_UM, RAD_PER_ARCMIN, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "STAGE_METRICS",
    "STAGE_STIFFNESS_METRICS",
    "SHEET_ANGLES",
    "stage_dataset",
    "data_sheet",
    "sheet_angles",
    "solve_case",
    "stage_torsion_variables",
    "stage_mesh",
    "STAGE_MESH_VARIABLES",
]

ARCSEC = RAD_PER_ARCSEC
ARCMIN = RAD_PER_ARCMIN

SHEET_ANGLES = 360
"""At most this many crank angles (evenly subsampled from the case's) for the data sheet."""


def sheet_angles(crank_angles: np.ndarray) -> np.ndarray:
    """The case's crank angles [rad] subsampled evenly to at most :data:`SHEET_ANGLES`."""
    step = max(1, int(math.ceil(crank_angles.size / SHEET_ANGLES)))
    return crank_angles[::step]


def stage_dataset(result: Stage, stage: StageDesign, pins: int) -> xr.Dataset:
    """The stage variables of a run with units; a ``torque`` dimension for several torques.

    Variables: ``crank_bearing_load`` [N], ``crank_bearing_load_angle`` [deg] (force of the
    disc on the crank pin, counter-clockwise from x), ``crank_bearing_deflection`` [um],
    ``max_roller_load`` [N] (crank_angle, disc, crank); ``disc_translation_x/_y`` [um],
    ``stage_pin_load`` [N], ``stage_groove_stress`` [MPa] (…, pin);
    ``stage_transmission_error`` [arcsec] (the output's);
    ``crank_bearing_equivalent_load`` [N] and ``crank_bearing_l10`` [h] (disc, crank).
    """
    import xarray as xr

    q = result.torque.size
    squeeze = q == 1
    deg = np.degrees(result.crank_angle)

    def var(values: np.ndarray, dims: tuple[str, ...], name: str):
        """The variable ``name`` (units and long name from the quantity registry)."""
        values = values[0] if squeeze else values
        q = QUANTITIES[name]
        return (
            (dims if squeeze else ("torque", *dims)),
            values,
            {"units": q.unit, "long_name": q.long_name},
        )

    data = {
        "crank_bearing_load": var(
            result.bearing_load, ("crank_angle", "disc", "crank"), "crank_bearing_load"
        ),
        "crank_bearing_load_angle": var(
            np.degrees(result.bearing_load_angle),
            ("crank_angle", "disc", "crank"),
            "crank_bearing_load_angle",
        ),
        "crank_bearing_deflection": var(
            result.bearing_deflection * 1e6,
            ("crank_angle", "disc", "crank"),
            "crank_bearing_deflection",
        ),
        "disc_translation_x": var(
            result.disc_translation_x * 1e6, ("crank_angle", "disc"), "disc_translation_x"
        ),
        "disc_translation_y": var(
            result.disc_translation_y * 1e6, ("crank_angle", "disc"), "disc_translation_y"
        ),
        "stage_pin_load": var(result.pin_load, ("crank_angle", "disc", "pin"), "stage_pin_load"),
        "stage_groove_stress": var(
            result.groove_stress * 1e-6, ("crank_angle", "disc", "pin"), "stage_groove_stress"
        ),
        "stage_opposite_pin_load": var(
            result.opposite_pin_load, ("crank_angle", "disc", "pin"), "stage_opposite_pin_load"
        ),
        "stage_transmission_error": var(
            result.transmission_error / ARCSEC, ("crank_angle",), "stage_transmission_error"
        ),
    }
    if stage.bearing is not None:
        data["max_roller_load"] = var(
            result.max_roller_load, ("crank_angle", "disc", "crank"), "max_roller_load"
        )
        p, _, hours = bearing_life(result, stage, pins)
        data["crank_bearing_equivalent_load"] = var(
            p, ("disc", "crank"), "crank_bearing_equivalent_load"
        )
        data["crank_bearing_l10"] = var(hours, ("disc", "crank"), "crank_bearing_l10")
    from cyclomesh.core.transmission import is_full_revolution

    orders = None
    if is_full_revolution(result.crank_angle):  # the output's ripple by orders
        from cyclomesh.results.datasheet import order_spectrum

        top = 3 * pins
        te = np.moveaxis(order_spectrum(result.transmission_error, -1, top), 0, -1)
        share = np.moveaxis(order_spectrum(result.torque_share, -2, top), 0, -2)
        orders = np.arange(te.shape[-1])
        data["stage_te_order_amplitude"] = var(
            te / ARCSEC, ("crank_order",), "stage_te_order_amplitude"
        )
        data["torque_share_order_amplitude"] = var(
            share, ("crank_order", "disc"), "torque_share_order_amplitude"
        )
    coords = {
        "crank_angle": ("crank_angle", deg, {"units": "deg"}),
        "disc": np.arange(1, result.pin_load.shape[-2] + 1),
        "crank": np.arange(1, stage.holes.count + 1),
        "pin": np.arange(1, result.pin_load.shape[-1] + 1),
    }
    if not squeeze:
        coords["torque"] = ("torque", result.torque, {"units": "N·m"})
    if orders is not None:
        coords["crank_order"] = ("crank_order", orders, {"long_name": "order of the crank speed"})
        coords["output_order"] = (
            "crank_order",
            orders * (pins - 1),
            {"long_name": "order of the output speed"},
        )
    ds = xr.Dataset(data, coords=coords)
    ds.attrs["stage_output_speed_rpm"] = float(stage.output_speed)
    return ds


def data_sheet(inputs: Any, rated_torque: float) -> dict[str, Any]:
    """Catalogue-style numbers of a case's stage at ``rated_torque`` [N·m] (JSON values).

    ``inputs``: the case's core inputs (a study's ``CaseInputs``: design, stage,
    modification, errors, crank_angles, groove_deformation, discs, contact_law).

    One :func:`~cyclomesh.stage.solve.stage_torsion_curve` (±3 %, ±50 %, ±100 % of the
    rated torque) on at most :data:`SHEET_ANGLES` of the case's crank angles gives the
    rigidity and lost motion of the stage and of the mesh alone (means over the angles,
    and the largest stage lost motion and smallest stage rigidity that the requirements
    check, as ``cyclomesh stiffness`` does);
    the +100 % solve gives the bearing loads, L10h of the weakest bearing and the peak
    contact stress (with friction: the crank driving the rated torque, a solve of its own;
    the torsion curve is then the loop's mid curve, its backlash the loop's width at zero).
    """
    stage = inputs.stage
    phi = sheet_angles(np.asarray(inputs.crank_angles, float))
    curve = stage_torsion(
        inputs.case().replace(torque=rated_torque, crank_angles=phi), stage_model(inputs), points=2
    )
    result = curve.stage
    at = int(np.flatnonzero(result.torque == rated_torque)[0])
    if curve.hysteresis is not None:  # friction: loads and life of the crank driving T_r
        result = solve(
            inputs.case().replace(torque=[rated_torque], crank_angles=phi), stage_model(inputs)
        )
        at = 0
    sheet: dict[str, Any] = {
        "stage_rated_torque_nm": float(rated_torque),
        "stage_output_speed_rpm": float(stage.output_speed),
        "stage_torsional_rigidity_nm_per_arcmin": float(np.mean(curve.torsional_rigidity) * ARCMIN),
        "mesh_torsional_rigidity_nm_per_arcmin": float(
            np.mean(curve.mesh_torsional_rigidity) * ARCMIN
        ),
        "stage_lost_motion_arcmin": float(np.mean(curve.lost_motion) / ARCMIN),
        # the requirements' definitions (docs/requirements.md), as cyclomesh stiffness
        "stage_lost_motion_arcmin_max": float(np.max(curve.lost_motion) / ARCMIN),
        "stage_torsional_rigidity_nm_per_arcmin_min": float(
            np.min(curve.torsional_rigidity) * ARCMIN
        ),
        "mesh_lost_motion_arcmin": float(np.mean(curve.mesh_lost_motion) / ARCMIN),
        "stage_max_contact_stress_mpa": float(np.max(result.contact_stress[at]) / 1e6),
        "stage_max_crank_bearing_load_n": float(np.max(result.bearing_load[at])),
    }
    shaft = stage.crankshaft
    if shaft is not None:  # the support bearings' radial loads (statics of the beam)
        angle = result.bearing_load_angle[at]
        force = result.bearing_load[at][..., None] * np.stack([np.cos(angle), np.sin(angle)], -1)
        loads = shaft.support_loads(np.moveaxis(force, 1, 2))  # (A, C, D, 2) -> (A, C, 2)
        sheet["stage_max_support_bearing_load_n"] = float(np.max(loads))
        if shaft.support_stiffness is not None:
            sheet["stage_support_bearing_stiffness_n_per_um"] = float(
                shaft.support_stiffness * M_PER_UM
            )
        if shaft.support_bearing is not None:
            sheet["stage_support_bearing_linear_limit_n"] = float(
                shaft.support_bearing.linear_limit()
            )
    if stage.bearing is not None:
        p, _, hours = bearing_life(result, stage, inputs.design.pins)
        sheet.update(
            stage_l10_h_min=float(np.min(hours[at])),
            stage_equivalent_load_n_max=float(np.max(p[at])),
            stage_dynamic_load_rating_kn=float(stage.bearing.rating() / 1e3),
            stage_max_roller_load_n=float(np.max(result.max_roller_load[at])),
        )
    sheet.update(_catalogue_extras(inputs, rated_torque, phi, curve))
    out = {name: sheet[name] for name in STAGE_METRICS if name in sheet}
    for key in ("compliance_share", "stage_te_orders", "torque_share_orders"):
        if key in sheet:
            out[key] = sheet[key]
    return out


def _duty_sheet(inputs: Any, phi: np.ndarray) -> dict[str, Any]:
    """L10h of the weakest crank bearing over the duty cycle, the catalogue's equivalent
    torque and speed, and the life at that single point (:mod:`cyclomesh.stage.duty`)."""
    import dataclasses

    from cyclomesh.stage.duty import cycle_life

    stage = inputs.stage
    cycle = stage.duty_cycle
    t_eq, n_eq = cycle.equivalent()
    torques = sorted(set(cycle.torque) | {t_eq})
    result = solve(inputs.case().replace(torque=torques, crank_angles=phi), stage_model(inputs))
    loads = {t: result.bearing_load[i] for i, t in enumerate(torques)}
    rating = stage.bearing.rating()
    _, hours = cycle_life(cycle, [loads[t] for t in cycle.torque], rating, inputs.design.pins)
    point = dataclasses.replace(stage, output_speed=n_eq)
    _, _, at_eq = bearing_life(result, point, inputs.design.pins)
    return {
        "stage_duty_equivalent_torque_nm": t_eq,
        "stage_duty_equivalent_speed_rpm": n_eq,
        "stage_duty_l10_h_min": float(np.min(hours)),
        "stage_l10_h_at_equivalent_torque": float(np.min(at_eq[torques.index(t_eq)])),
    }


def _catalogue_extras(inputs: Any, rated_torque: float, phi: np.ndarray, curve: Any) -> dict:
    """Backlash of stage and mesh (width at ±0.1 % of T_r) and the compliance budget at
    +T_r (:mod:`cyclomesh.results.datasheet`)."""
    from cyclomesh.results.datasheet import BACKLASH_FRACTION, compliance_share

    model = stage_model(inputs)
    pair = [-BACKLASH_FRACTION * rated_torque, BACKLASH_FRACTION * rated_torque]
    if curve.hysteresis is None:
        small = solve(inputs.case().replace(torque=pair, crank_angles=phi), model)
        te, mesh = small.transmission_error, small.mesh_transmission_error
    else:  # the loop's width at zero: rising from −T_r at −0.1 %, falling from +T_r at +0.1 %
        te, mesh = [], []
        for value, loading in zip(pair, (1.0, -1.0), strict=True):
            one = solve(
                inputs.case().replace(torque=[value], crank_angles=phi), model, 0.0, loading
            )
            te.append(one.transmission_error[0])
            mesh.append(one.mesh_transmission_error[0])
    result = curve.stage
    at = int(np.flatnonzero(result.torque == rated_torque)[0])
    extra: dict[str, Any] = {}
    if inputs.stage.duty_cycle is not None:
        extra.update(_duty_sheet(inputs, phi))
    from cyclomesh.core.transmission import is_full_revolution
    from cyclomesh.results.datasheet import order_spectrum, top_orders

    if is_full_revolution(phi):  # the output's ripple by orders at the rated torque
        teeth = inputs.design.pins - 1
        amp = order_spectrum(result.transmission_error[at], orders=3 * inputs.design.pins)
        extra["stage_te_orders"] = top_orders(amp / ARCSEC, 3, teeth)
        share = order_spectrum(result.torque_share[at], orders=3 * inputs.design.pins)
        extra["torque_share_orders"] = top_orders(np.max(share, axis=-1), 3, teeth)
    return extra | {
        "stage_backlash_arcmin": float(np.mean(te[0] - te[1]) / ARCMIN),
        "mesh_backlash_arcmin": float(np.mean(mesh[0] - mesh[1]) / ARCMIN),
        "compliance_share": compliance_share(
            {k: v[at] for k, v in result.work.items()}, rated_torque, result.twist[at]
        ),
    }


STAGE_MESH_VARIABLES = (
    "pin_load",
    "groove_load",
    "contact_stress",
    "groove_stress",
    "transmission_error",
    "gear_ratio",
    "contacts",
    "mesh_force",
    "mesh_force_angle",
    "torque_share",
)
"""The mesh variables of a run that, with ``[stage]``, are the stage solve's (discs on
their crank bearings) instead of the mesh on rigid bearings."""


def stage_mesh(ds: xr.Dataset, result: Stage, teeth: int) -> xr.Dataset:
    """``ds`` (a run's mesh on rigid bearings) with :data:`STAGE_MESH_VARIABLES` replaced by
    those of the stage solve ``result`` (same dims, units and names; the long name says
    "RV stage"): loads and stresses of the loaded flanks, the output's TE (Eq. 25 sign)
    and its gear ratio (Eq. 26), contacts, mesh force and torque split. The mesh on
    rigid bearings keeps its TE as ``rigid_bearing_transmission_error`` [arcsec]."""
    import xarray as xr

    te = result.transmission_error  # (Q, A) [rad]
    values = {
        "pin_load": (result.pin_load, 1.0),
        "groove_load": (result.groove_load, 1.0),
        "contact_stress": (result.contact_stress, 1e-6),
        "groove_stress": (result.groove_stress, 1e-6),
        "transmission_error": (te, 1.0 / ARCSEC),
        "gear_ratio": (gear_ratio(te, result.crank_angle, teeth), 1.0),
        "contacts": (result.contacts, 1),
        "mesh_force": (result.mesh_force, 1.0),
        "mesh_force_angle": (np.degrees(result.mesh_force_angle), 1.0),
        "torque_share": (result.torque_share, 1.0),
    }
    names = {4: ("torque", "crank_angle", "disc", "pin"), 3: ("torque", "crank_angle", "disc")}
    out = ds.assign(
        rigid_bearing_transmission_error=ds["transmission_error"].assign_attrs(
            long_name="loaded TE of the mesh on rigid bearings"
        )
    )
    for name in STAGE_MESH_VARIABLES:
        if name not in ds:
            continue
        value, scale = values[name]
        dims = names.get(value.ndim, ("torque", "crank_angle"))
        arr = xr.DataArray(value * scale, dims=dims)
        for dim in ("torque", "disc"):
            if dim in arr.dims and dim not in ds[name].dims:
                arr = arr.isel({dim: 0}, drop=True)
        arr = arr.transpose(*ds[name].dims)
        attrs = dict(ds[name].attrs)
        attrs["long_name"] = f"{attrs.get('long_name', name)} (RV stage)"
        out[name] = (ds[name].dims, arr.values.astype(ds[name].dtype), attrs)
    return out


def stage_model(inputs: Any) -> Any:
    """The :class:`~cyclomesh.core.case.Model` of a case's stage: ``disc_body = "fe"``
    resolved to the free disc (the crank-hole centres free,
    :func:`cyclomesh.fe.influence.free_influence`, from the cache or computed once)."""
    model = inputs.model()
    if isinstance(model.disc_body, str) and model.disc_body == "fe":
        from cyclomesh.results.dataset import resolve_disc_body

        body = resolve_disc_body(
            "fe", inputs.design, inputs.modification, inputs.crank_holes, stage=True
        )
        model = model.replace(disc_body=body)
    return model


def solve_case(inputs: Any) -> Stage:
    """The stage of a run case at its torque(s) and crank angles (with ``[friction]``: the
    crank driving every torque)."""
    return solve(inputs.case(), stage_model(inputs))


def stage_efficiency_variables(
    inputs: Any, forward: Stage, torque_dim: bool, discs: int
) -> dict[str, tuple]:
    """The friction variables of a run (:func:`cyclomesh.results.efficiency.
    efficiency_variables`, the same names, dims and units) from the stage's solves: the
    crank driving every torque (``forward``, :func:`solve_case`) and every torque driving
    the crank back (a second solve). The crank bearings' loss is summed over the crank
    pins of each disc; the input torque is the stage's total, ±sgn(T)·P_in/ω (− back-driving,
    the crank turning the other way), P_in from the crank pins' forces
    (:mod:`cyclomesh.stage.friction`)."""
    from types import SimpleNamespace

    from cyclomesh.results.efficiency import efficiency_variables

    friction = inputs.friction
    back = solve(inputs.case(), stage_model(inputs), motion=-1.0)

    def view(result: Stage, motion: float) -> SimpleNamespace:
        fr = dict(result.friction)
        fr["power_loss_bearing"] = np.sum(fr["power_loss_bearing"], axis=-1)
        sign = motion * np.sign(result.torque)[:, None]  # the crank's turn: T_in·ω = P_in
        fr["input_torque"] = (sign * fr["input_power"] / friction.speed)[..., None]
        return SimpleNamespace(
            contacts=result.contacts if discs > 1 else result.contacts[..., :1],
            transmission_error=result.transmission_error,
            loaded_rotation=result.transmission_error,
            torque=result.torque,
            friction=fr,
        )

    return efficiency_variables(
        view(forward, 1.0), view(back, -1.0), inputs.design.teeth, friction.speed, torque_dim
    )


def stage_torsion_variables(
    inputs: Any, rated_torque: float, points: int, crank_angles: np.ndarray
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The stage's torsion curve for a stiffness study: Dataset variables and summary keys.

    Variables (same ``torque`` and ``crank_angle`` as ``stiffness.nc``): ``stage_rotation``
    [arcsec], ``stage_lost_motion`` [arcmin], ``stage_torsional_rigidity`` [N m/arcmin],
    ``crank_bearing_load`` [N] (torque, crank_angle, disc, crank). Summary:
    ``stage_lost_motion_arcmin_mean``/``_max``, ``stage_torsional_rigidity_nm_per_arcmin_
    mean``/``_min`` and, with a bearing, ``stage_l10_h_min`` at +T_r.
    """
    model = stage_model(inputs)
    if model.friction is not None and model.friction.lubricant is not None:
        # a torsion test is at rest: no film, the boundary coefficients (as the mesh's)
        import dataclasses

        model = model.replace(friction=dataclasses.replace(model.friction, lubricant=None))
    curve = stage_torsion(
        inputs.case().replace(torque=rated_torque, crank_angles=crank_angles),
        model,
        points=points,
    )
    data: dict[str, Any] = {
        "stage_rotation": (
            ("torque", "crank_angle"),
            curve.rotation / ARCSEC,
            {"units": "arcsec", "long_name": "output rotation of the RV stage (TE sign)"},
        ),
        "stage_lost_motion": (
            ("crank_angle",),
            curve.lost_motion / ARCMIN,
            {"units": "arcmin", "long_name": "lost motion of the RV stage"},
        ),
        "stage_torsional_rigidity": (
            ("crank_angle",),
            curve.torsional_rigidity * ARCMIN,
            {"units": "N·m/arcmin", "long_name": "torsional rigidity of the RV stage"},
        ),
        "crank_bearing_load": (
            ("torque", "crank_angle", "stage_disc", "crank"),
            curve.stage.bearing_load,
            {"units": "N", "long_name": "crank bearing load"},
        ),
    }
    if curve.hysteresis is not None:  # friction: the loop's branches and width
        for name in ("rotation_ascending", "rotation_descending"):
            q = QUANTITIES[f"stage_{name}"]
            data[f"stage_{name}"] = (
                ("torque", "crank_angle"),
                getattr(curve, name) / ARCSEC,
                {"units": q.unit, "long_name": q.long_name},
            )
        q = QUANTITIES["stage_hysteresis"]
        data["stage_hysteresis"] = (
            ("crank_angle",),
            curve.hysteresis / ARCMIN,
            {"units": q.unit, "long_name": q.long_name},
        )
    summary = {
        "stage_lost_motion_arcmin_mean": float(np.mean(curve.lost_motion) / ARCMIN),
        "stage_lost_motion_arcmin_max": float(np.max(curve.lost_motion) / ARCMIN),
        "stage_torsional_rigidity_nm_per_arcmin_mean": float(
            np.mean(curve.torsional_rigidity) * ARCMIN
        ),
        "stage_torsional_rigidity_nm_per_arcmin_min": float(
            np.min(curve.torsional_rigidity) * ARCMIN
        ),
    }
    if curve.hysteresis is not None:
        summary["stage_hysteresis_arcmin_mean"] = float(np.mean(curve.hysteresis) / ARCMIN)
        summary["stage_hysteresis_arcmin_max"] = float(np.max(curve.hysteresis) / ARCMIN)
    if inputs.stage.bearing is not None:
        at = int(np.flatnonzero(curve.torque == rated_torque)[0])
        loaded = curve.stage
        if curve.hysteresis is not None:  # friction: the crank driving T_r (as data_sheet)
            loaded = solve(
                inputs.case().replace(torque=[rated_torque], crank_angles=crank_angles), model
            )
            at = 0
        _, _, hours = bearing_life(loaded, inputs.stage, inputs.design.pins)
        summary["stage_l10_h_min"] = float(np.min(hours[at]))
    return data, summary


STAGE_STIFFNESS_METRICS: dict[str, Metric] = select(
    "stage_lost_motion_arcmin_mean",
    "stage_lost_motion_arcmin_max",
    "stage_torsional_rigidity_nm_per_arcmin_mean",
    "stage_torsional_rigidity_nm_per_arcmin_min",
    "stage_hysteresis_arcmin_mean",
    "stage_hysteresis_arcmin_max",
    "stage_l10_h_min",
    "measured_torsional_rigidity_nm_per_arcmin",
    "measured_lost_motion_arcmin",
    "measured_backlash_arcmin",
    "reconciling_compliance_arcmin_per_knm",
    "reconciling_stiffness_nm_per_arcmin",
    "lost_motion_difference_arcmin",
)
