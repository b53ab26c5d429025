"""Friction results of a run: per-pin losses, per-angle efficiency, the case's power table.

:func:`efficiency_variables` labels the friction fields of a :class:`~cyclomesh.drive.solve.Drive`
(forward drive) and the back-driving solve of the same case as Dataset variables;
:func:`efficiency_record` reduces them to the ``summary.json`` numbers of
:data:`EFFICIENCY_METRICS` and the loss table ``power_loss_w`` (path → W).

Powers at the input speed ω (``[load] input_speed_rpm``): output power P_out = |T|·ω/n2,
loss P_loss = Σ μ_eff·F·|v_d·t|·ω over the pins (pin–tooth or pin–groove, whichever
slides, :mod:`cyclomesh.core.friction`), forward efficiency η = P_out/(P_out + P_loss),
back-driving efficiency η_b = (P_out − P_loss,b)/P_out (the output supplies P_out). The
input power is P_out + P_loss; the input torque from the moment balance of the crank
(``input_torque``) gives T_in·ω, equal to it up to the power of the elastic approach of a
non-conjugate profile, whose mean over a revolution vanishes. Means over the analysed
crank angles are ratios of mean powers (energies).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.quantities import QUANTITIES, select
from cyclomesh.results.metrics import Metric

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.drive.solve import Drive

__all__ = [
    "EFFICIENCY_METRICS",
    "LOSS_PATHS",
    "efficiency_variables",
    "efficiency_record",
    "friction_attrs",
]

EFFICIENCY_METRICS: dict[str, Metric] = select(
    "efficiency",
    "backdrive_efficiency",
    "input_power_w",
    "output_power_w",
    "input_speed_rpm",
    "power_loss_w",
    "film_parameter_min",
    "film_parameter_mean",
)
"""Headline numbers of a run with ``[friction]`` (rows of :data:`cyclomesh.quantities.QUANTITIES`);
``power_loss_w`` is a table path → W; the film parameters with a lubricant only."""

LOSS_PATHS = {
    "pin_tooth": "power_loss_tooth",
    "pin_groove": "power_loss_groove",
    "crank_bearings": "power_loss_bearing",
}
"""Loss paths modelled → variable (per pin, per disc for the bearings). The output
mechanism is not modelled (``null`` in ``power_loss_w``)."""

_PIN_VARS = (
    "friction_force",
    "sliding_velocity_tooth",
    "sliding_velocity_groove",
    "power_loss_tooth",
    "power_loss_groove",
    "friction_coefficient",
)


def _attrs(name: str) -> dict[str, str]:
    """``units`` and ``long_name`` from the registry (:data:`cyclomesh.quantities.QUANTITIES`)."""
    return {"units": QUANTITIES[name].unit, "long_name": QUANTITIES[name].long_name}


def efficiency_variables(
    forward: Drive, backward: Drive, teeth: int, speed: float, torque_dim: bool
) -> dict[str, tuple]:
    """Dataset variables (``(dims, values, attrs)``) of the friction results.

    Parameters
    ----------
    forward, backward : Drive
        The same case driven by the crank and driving it back (``solve_drive(...,
        friction=..., backdrive=...)``), at most one ring axis.
    teeth : int
        n2.
    speed : float
        Input speed ω [rad/s].
    torque_dim : bool
        Keep the torque axis (a list of torques).
    """
    discs = forward.contacts.shape[-1]
    ring = ("ring",) * (forward.transmission_error.ndim - 2)
    keep = ("torque",) if torque_dim else ()
    stack = ("disc",) if discs > 1 else ()
    f, b = forward.friction, backward.friction

    def angle(value: np.ndarray) -> np.ndarray:  # (..., Q, A)
        return value if torque_dim else value[..., 0, :]

    def pin(value: np.ndarray) -> np.ndarray:  # (..., Q, A, N, n1)
        value = value if torque_dim else value[..., 0, :, :, :]
        return value[..., 0, :] if discs == 1 else value

    data: dict[str, tuple] = {}
    lubricated = bool(np.any(f["film_parameter"] > 0))
    for name in _PIN_VARS + (("film_parameter",) if lubricated else ()):
        data[name] = (
            (*ring, *keep, "crank_angle", *stack, "pin"),
            pin(f[name]) * QUANTITIES[name].scale,
            _attrs(name),
        )
    sign = np.sign(forward.torque)[:, None]
    p_out = np.abs(forward.torque)[:, None] * speed / teeth * np.ones_like(forward.loaded_rotation)
    loss = np.sum(f["power_loss_tooth"] + f["power_loss_groove"], axis=(-2, -1))
    loss = loss + np.sum(f["power_loss_bearing"], axis=-1)
    loss_b = np.sum(b["power_loss_tooth"] + b["power_loss_groove"], axis=(-2, -1))
    loss_b = loss_b + np.sum(b["power_loss_bearing"], axis=-1)
    bearing = f["power_loss_bearing"] if torque_dim else f["power_loss_bearing"][..., 0, :, :]
    data["power_loss_bearing"] = (
        (*ring, *keep, "crank_angle", *stack),
        bearing if discs > 1 else bearing[..., 0],
        _attrs("power_loss_bearing"),
    )
    t_in = np.sum(f["input_torque"], axis=-1)
    t_in_b = np.sum(b["input_torque"], axis=-1)
    angle_dims = (*ring, *keep, "crank_angle")
    for name, value in (
        ("input_torque", t_in),
        ("backdrive_input_torque", t_in_b),
        ("output_power", p_out),
        ("power_loss", loss),
        ("backdrive_power_loss", loss_b),
        ("input_power", p_out + loss),
        ("moment_input_power", t_in * sign * speed),
        ("instantaneous_efficiency", p_out / (p_out + loss)),
        ("instantaneous_backdrive_efficiency", (p_out - loss_b) / p_out),
    ):
        data[name] = (angle_dims, angle(value), _attrs(name))
    return data


def efficiency_record(ds: xr.Dataset) -> dict[str, Any]:
    """The ``summary.json`` numbers of a run with friction (a list per torque for a
    ``torque`` dimension): :data:`EFFICIENCY_METRICS` and ``power_loss_w`` (path → W;
    ``null`` for a path not modelled)."""

    def mean(name: str) -> Any:
        return _plain(ds[name].mean("crank_angle").values)

    p_out, loss, loss_b = (
        np.asarray(mean(n)) for n in ("output_power", "power_loss", "backdrive_power_loss")
    )

    def path(var: str) -> Any:
        over = [d for d in ("disc", "pin") if d in ds[var].dims]
        return _plain(ds[var].sum(over).mean("crank_angle").values)

    record = {
        "efficiency": _plain(p_out / (p_out + loss)),
        "backdrive_efficiency": _plain((p_out - loss_b) / p_out),
        "input_power_w": _plain(p_out + loss),
        "output_power_w": _plain(p_out),
        "input_speed_rpm": ds.attrs["input_speed_rpm"],
        "power_loss_w": {
            **{name: path(var) for name, var in LOSS_PATHS.items()},
            "output_mechanism": None,
        },
    }
    if "film_parameter" in ds:  # a lubricant: the film parameter of the loaded contacts
        lam = ds["film_parameter"]
        over = [d for d in lam.dims if d != "torque"]
        loaded = lam.where(lam > 0)
        record["film_parameter_min"] = _plain(loaded.min(over).values)
        record["film_parameter_mean"] = _plain(loaded.mean(over).values)
    return record


def _plain(value: np.ndarray) -> Any:
    """A 0-d array as its number, else a list (plain JSON values)."""
    return np.asarray(value).tolist()


def friction_attrs(friction: Any) -> dict[str, Any]:
    """Dataset attributes recording a :class:`~cyclomesh.core.friction.Friction`."""
    attrs = {
        "friction_mesh_coefficient": float(friction.mesh),
        "friction_groove_coefficient": float(friction.groove),
        "friction_bearing_coefficient": float(friction.bearing),
        "friction_bearing_diameter_mm": float(friction.bearing_diameter * 1e3),
        "friction_pins": friction.pins,
        "input_speed_rpm": float(friction.speed * 60.0 / (2.0 * np.pi)),
    }
    if friction.lubricant is not None:
        lub = friction.lubricant
        attrs.update(
            lubricant_viscosity_40c_cst=float(lub.viscosity_40),
            lubricant_viscosity_100c_cst=float(lub.viscosity_100),
            lubricant_temperature_c=float(lub.temperature),
            lubricant_viscosity_cst=lub.viscosity,
            lubricant_roughness_um=float(lub.roughness * 1e6),
            lubricant_composite_roughness_um=float(lub.sigma * 1e6),
            lubricant_pressure_viscosity_per_gpa=float(lub.pressure_viscosity * 1e9),
            lubricant_density_kg_m3=float(lub.density),
        )
    return attrs
