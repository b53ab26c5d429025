"""Labelled results: run :func:`cyclomesh.core.ltca.solve_ltca` and return an xarray Dataset.

This is the notebook entry point. The numbers come from the SI core; here they are
converted to the units a gear engineer reads (N, MPa, arcsec, degrees, mm), labelled
with ``crank_angle`` (degrees) and ``pin`` (1 … n1), and the inputs recorded as
attributes. :func:`summarize` reduces a result to the headline numbers of a study
(:mod:`cyclomesh.results.metrics`); :func:`ltca_metrics` does the same straight from the core's
result, without a Dataset (tolerance studies). xarray is imported only when a Dataset
is built, so the variable tables below can be read by worker processes cheaply.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.case import Case, Model
from cyclomesh.core.ltca import CONTACT_LOAD_FRACTION, LTCA
from cyclomesh.core.pair import Modification, PairDesign, PinErrors
from cyclomesh.drive.solve import Drive, check_torques, drive
from cyclomesh.exceptions import DesignError
from cyclomesh.execution.runtime import version
from cyclomesh.quantities import QUANTITIES
from cyclomesh.results.arrays import nan_reduce
from cyclomesh.results.frame import Frame, Var
from cyclomesh.results.metrics import DRIVE_METRICS, METRICS, summary_metrics

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "analyse",
    "analyse_frame",
    "drive_dataset",
    "drive_frame",
    "drive_result_frame",
    "to_dataset",
    "drive_to_dataset",
    "summarize",
    "ltca_metrics",
    "drive_metrics",
]


def _table(*names: str) -> dict[str, tuple[float, str, str]]:
    """name (a core field) → (scale from SI, units, long name), from the quantity registry."""
    return {n: (QUANTITIES[n].scale, QUANTITIES[n].unit, QUANTITIES[n].long_name) for n in names}


_PER_PIN = _table(
    "pin_load",
    "groove_load",
    "contact_stress",
    "groove_stress",
    "backlash",
    "overlap",
    "profile_angle",
    "contact_radius",
    "moment_arm",
    "curvature_radius",
)
NONFINITE = {
    "backlash": "inf: the pin lies above the tip circle of the modified profile and cannot "
    "touch the loaded flank",
    "curvature_radius": "inf: the contact point is an inflection point of the profile "
    "(straight, ρc → ∞)",
}
"""What a non-finite value means in a variable (its ``nonfinite`` attribute); no other
variable holds one."""
_PER_ANGLE = _table(
    "transmission_error", "gear_ratio", "contacts", "loaded_rotation", "rest_rotation"
)
# drive-level results (cyclomesh.drive.solve): per pin, per disc, per crank angle only
_DRIVE_PER_PIN = _table("force_angle")
_PER_DISC = _table("mesh_force", "mesh_force_angle", "torque_share")
_PLAY = ("play", *_table("play")["play"])


_METRIC_SOURCES = {metric.reduce[0] for metric in METRICS.values()}
"""The variables :data:`METRICS` reduce."""
_METRIC_PIN_SOURCES = tuple(name for name in _PER_PIN if name in _METRIC_SOURCES)
_PIN_MAX_SOURCES = frozenset(
    name
    for name in _METRIC_PIN_SOURCES
    if all(m.reduce[1] in ("max", "positive") for m in METRICS.values() if m.reduce[0] == name)
)
"""Per-pin sources that :data:`METRICS` only reduce by their largest value (``max``,
``positive``): :func:`drive_metrics` may take each crank angle's largest first."""


def to_dataset(
    result: LTCA,
    design: PairDesign,
    modification: Modification,
    torque: float,
    groove_deformation: bool,
) -> xr.Dataset:
    """Label an :class:`~cyclomesh.core.ltca.LTCA` result (SI) as a Dataset in engineering units."""
    import xarray as xr

    ring_dims = ("ring",) if result.transmission_error.ndim == 2 else ()
    if result.transmission_error.ndim > 2:
        raise ValueError("to_dataset supports at most one ring axis")
    dims_pin = (*ring_dims, "crank_angle", "pin")
    dims_angle = (*ring_dims, "crank_angle")
    data = {}
    for dims, table in ((dims_pin, _PER_PIN), (dims_angle, _PER_ANGLE)):
        for name, (scale, units, long_name) in table.items():
            attrs = {"units": units, "long_name": long_name}
            attrs.update({"nonfinite": NONFINITE[name]} if name in NONFINITE else {})
            data[name] = (dims, getattr(result, name) * scale, attrs)
    coords = {
        "crank_angle": ("crank_angle", np.degrees(result.crank_angle), {"units": "deg"}),
        "pin": ("pin", np.arange(1, design.pins + 1), {"units": "1"}),
    }
    if ring_dims:
        coords["ring"] = ("ring", np.arange(result.transmission_error.shape[0]))
    attrs = result_attrs(result.crank_angle, design, modification, torque, groove_deformation)
    data["contacts"][2]["load_threshold_fraction"] = CONTACT_LOAD_FRACTION
    return xr.Dataset(data, coords=coords, attrs=attrs)


def result_attrs(
    phi: np.ndarray,
    design: PairDesign,
    modification: Modification,
    torque: float | None,
    groove_deformation: bool,
) -> dict:
    """Attributes of a result Dataset: the inputs with unit-suffixed names."""
    step = np.degrees(np.diff(phi))
    attrs = {
        "title": "cyclomesh loaded tooth contact analysis",
        "source": "Li, Tang, He, Sun, Machines 2022, 10, 672, doi:10.3390/machines10080672",
        "cyclomesh_version": version(),
        "pins": design.pins,
        "teeth": design.teeth,
        "pin_circle_radius_mm": design.pin_circle_radius * 1e3,
        "pin_radius_mm": design.pin_radius * 1e3,
        "groove_radius_mm": design.groove_radius * 1e3,
        "eccentricity_mm": design.eccentricity * 1e3,
        "width_mm": design.width * 1e3,
        "pin_youngs_modulus_gpa": design.pin_material.youngs_modulus * 1e-9,
        "pin_poisson_ratio": design.pin_material.poisson_ratio,
        "disc_youngs_modulus_gpa": design.disc_material.youngs_modulus * 1e-9,
        "disc_poisson_ratio": design.disc_material.poisson_ratio,
        "ring_youngs_modulus_gpa": design.ring_material.youngs_modulus * 1e-9,
        "ring_poisson_ratio": design.ring_material.poisson_ratio,
        "modification_pin_circle_radius_um": modification.pin_circle_radius * 1e6,
        "modification_pin_radius_um": modification.pin_radius * 1e6,
        "modification_rotation_urad": modification.rotation * 1e6,
        "groove_deformation": int(bool(groove_deformation)),
        "gear_ratio_step_deg": float(step[0]) if step.size else 0.0,
        "sign_convention": (
            "crank counter-clockwise; disc turns by -phi/n2; TE positive in the disc's "
            "direction of motion (a lagging disc has negative TE)"
        ),
    }
    if torque is not None:
        attrs["torque_nm"] = float(torque)
    return attrs


def drive_to_dataset(
    result: Drive,
    design: PairDesign,
    modification: Modification,
    groove_deformation: bool,
    torque_dim: bool,
) -> xr.Dataset:
    """Label a :class:`~cyclomesh.drive.solve.Drive` result (SI) as a Dataset in engineering
    units: :func:`drive_frame` as an :class:`xarray.Dataset`."""
    return drive_frame(result, design, modification, groove_deformation, torque_dim).to_xarray()


def drive_frame(
    result: Drive,
    design: PairDesign,
    modification: Modification,
    groove_deformation: bool,
    torque_dim: bool,
) -> Frame:
    """Label a :class:`~cyclomesh.drive.solve.Drive` result (SI) in engineering units, as
    a :class:`~cyclomesh.results.frame.Frame` (no xarray).

    Dimensions ``ring`` (one ring axis at most), ``torque`` [N·m] (if ``torque_dim``, else
    the one torque is the attribute ``torque_nm``), ``crank_angle`` [deg], ``disc`` (1 … N,
    only for a stack of more than one disc) and ``pin``.
    """
    lead = result.transmission_error.ndim - 2
    if lead > 1:
        raise ValueError("drive_to_dataset supports at most one ring axis")
    discs = result.contacts.shape[-1]
    ring = ("ring",) * lead
    keep = ("torque",) if torque_dim else ()
    stack = ("disc",) if discs > 1 else ()

    trailing = {"pin": 3, "disc": 2, "angle": 1}  # axes after the torque axis

    def select(value: np.ndarray, per: str) -> np.ndarray:
        """Drop the torque axis of a single torque and the disc axis of a single disc."""
        if not torque_dim:
            value = np.take(value, 0, axis=-1 - trailing[per])
        if discs == 1 and per != "angle":
            value = np.take(value, 0, axis=-2 if per == "pin" else -1)
        return value

    pin_dims = (*ring, *keep, "crank_angle", *stack, "pin")
    disc_dims = (*ring, *keep, "crank_angle", *stack)
    angle_dims = (*ring, *keep, "crank_angle")
    # the variables of to_dataset first, in its order, then the drive's own
    tables = (
        (pin_dims, "pin", _PER_PIN),
        *(
            (disc_dims, "disc", {k: v}) if k == "contacts" else (angle_dims, "angle", {k: v})
            for k, v in _PER_ANGLE.items()
        ),
        (pin_dims, "pin", _DRIVE_PER_PIN),
        (disc_dims, "disc", _PER_DISC),
    )
    data = {}
    for dims, per, table in tables:
        for name, (scale, units, long_name) in table.items():
            if name == "torque_share" and discs == 1:
                continue
            value = select(getattr(result, name), per)
            attrs = {"units": units, "long_name": long_name}
            attrs.update({"nonfinite": NONFINITE[name]} if name in NONFINITE else {})
            data[name] = Var(dims, value * scale, attrs)
    name, scale, units, long_name = _PLAY
    data[name] = Var(
        (*ring, "crank_angle"),
        result.play * scale,
        {"units": units, "long_name": long_name},
    )
    coords = {
        "crank_angle": Var("crank_angle", np.degrees(result.crank_angle), {"units": "deg"}),
        "pin": Var("pin", np.arange(1, design.pins + 1), {"units": "1"}),
    }
    if torque_dim:
        coords["torque"] = Var("torque", result.torque, {"units": "N·m", "long_name": "torque"})
    if stack:
        coords["disc"] = Var("disc", np.arange(1, discs + 1), {"units": "1"})
    if ring:
        coords["ring"] = Var("ring", np.arange(result.transmission_error.shape[0]))
    single = None if torque_dim else float(result.torque[0])
    attrs = result_attrs(result.crank_angle, design, modification, single, groove_deformation)
    attrs["discs"] = int(discs)
    data["contacts"].attrs["load_threshold_fraction"] = CONTACT_LOAD_FRACTION
    return Frame(data, coords, attrs)


def resolve_crank_angles(
    crank_angles: ArrayLike | None, crank_angles_deg: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """The crank angles of an API call given in [rad] or in [deg] (not both; neither: a
    revolution at 1°): (φin [rad], the degrees as given, kept exactly as the
    ``crank_angle`` coordinate, or None when they were given in radians)."""
    if crank_angles_deg is not None:
        if crank_angles is not None:
            raise TypeError("give crank_angles [rad] or crank_angles_deg, not both")
        degrees = np.atleast_1d(np.asarray(crank_angles_deg, float))
    elif crank_angles is None:
        degrees = np.arange(360.0)
    else:
        return np.atleast_1d(np.asarray(crank_angles, float)), None
    return np.deg2rad(degrees), degrees


def analyse(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: float | ArrayLike = 250.0,
    crank_angles: ArrayLike | None = None,
    groove_deformation: bool = True,
    *,
    crank_angles_deg: ArrayLike | None = None,
    discs: int = 1,
    contact_law: str = "half_plane",
    disc_body: Any = "rigid",
    crank_holes: Any = None,
    cache_dir: Any = None,
    friction: Any = None,
) -> xr.Dataset:
    """Loaded tooth contact analysis of a cycloid-pin pair as a labelled Dataset.

    Parameters
    ----------
    design : PairDesign
        Geometry and materials (SI).
    modification : Modification, optional
        Tooth profile modification (Eq. 3 of [1]).
    errors : PinErrors, optional
        Pin ring errors (Eq. 5 of [1]); one leading axis gives a ``ring`` dimension.
    torque : float or list of float
        Torque on the disc (on the stack of discs) [N·m]; positive loads the forward
        flanks (the disc lags, TE < 0), negative the reverse flanks (TE > 0); 0 is refused.
        A list adds a ``torque`` dimension.
    crank_angles : array_like, optional
        Crank angles [rad]; default a revolution at 1°.
    groove_deformation : bool
        "Improved model" (True) or "current model" (False).
    crank_angles_deg : array_like, optional
        Crank angles [deg], instead of ``crank_angles``; they become the ``crank_angle``
        coordinate exactly as given, so ``ds.sel(crank_angle=60.0)`` finds them.
    discs : int
        Number N of identical discs on the ring, disc k's eccentric at φ + (k − 1)·360°/N;
        they share one rotation and split the torque by their stiffness.
    contact_law : {"paper", "half_plane"}
        Tooth term of the contact law (see :mod:`cyclomesh.core.hertz`); recorded in the
        ``contact_law`` attribute.
    disc_body : "rigid", "fe" or DiscBody
        The disc body (:func:`cyclomesh.core.ltca.solve_ltca`): ``"fe"`` takes the influence
        coefficients of :func:`cyclomesh.fe.influence.influence` (the fe extra; computed
        once per design, then loaded from ``cache_dir``, default the per-user cache), the
        disc held at its ``crank_holes`` (a :class:`~cyclomesh.core.pair.CrankHoles`) or,
        without them, at the bore. Recorded in the ``disc_body`` attribute.
    friction : Friction, optional
        Friction at the pin contacts (:class:`cyclomesh.core.friction.Friction`), in the
        equilibrium: the loaded contact is that of the crank driving the torque, and the
        Dataset gains the friction variables of :mod:`cyclomesh.results.efficiency` (the
        back-driving efficiency from a second solve). None or all coefficients 0: the
        frictionless model, bit for bit.

    Returns
    -------
    xarray.Dataset
        Dimensions ``crank_angle`` [deg] and ``pin`` (1 … n1), plus ``ring`` for several
        rings, ``torque`` [N·m] for a list of torques and ``disc`` (1 … N) for N > 1;
        variables carry a ``units`` attribute (see :mod:`cyclomesh.results.dataset` and
        ``docs/drive.md``). Besides the loaded contact: ``play`` [arcsec] per crank angle,
        ``mesh_force`` [N] and ``mesh_force_angle`` [deg] per disc, ``force_angle`` [deg]
        per pin, ``torque_share`` [N·m] per disc of a stack.

    References
    ----------
    [1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672.
    """
    return analyse_frame(
        design,
        modification,
        errors,
        torque,
        crank_angles,
        groove_deformation,
        crank_angles_deg=crank_angles_deg,
        discs=discs,
        contact_law=contact_law,
        disc_body=disc_body,
        crank_holes=crank_holes,
        cache_dir=cache_dir,
        friction=friction,
    ).to_xarray()


def analyse_frame(
    design: PairDesign,
    modification: Modification | None = None,
    errors: PinErrors | None = None,
    torque: float | ArrayLike = 250.0,
    crank_angles: ArrayLike | None = None,
    groove_deformation: bool = True,
    *,
    crank_angles_deg: ArrayLike | None = None,
    discs: int = 1,
    contact_law: str = "half_plane",
    disc_body: Any = "rigid",
    crank_holes: Any = None,
    cache_dir: Any = None,
    friction: Any = None,
) -> Frame:
    """:func:`analyse` as a :class:`~cyclomesh.results.frame.Frame`: the same variables,
    coordinates and attributes, without importing xarray (``cyclomesh run``)."""
    modification = modification or Modification()
    crank_angles, degrees = resolve_crank_angles(crank_angles, crank_angles_deg)
    torque_dim = np.ndim(torque) > 0
    torques = check_torques(torque)
    body = resolve_disc_body(disc_body, design, modification, crank_holes, cache_dir)
    case = Case(design, modification, errors, torques, crank_angles)
    model = Model(contact_law, groove_deformation, body, discs, friction=friction)
    return drive_result_frame(drive(case, model), case, model, torque_dim, degrees)


def drive_dataset(
    result: Drive,
    case: Case,
    model: Model,
    torque_dim: bool,
    degrees: ArrayLike | None = None,
) -> xr.Dataset:
    """The Dataset of :func:`analyse` from a :class:`~cyclomesh.drive.solve.Drive` of ``case``
    and ``model``: :func:`drive_result_frame` as an :class:`xarray.Dataset`."""
    return drive_result_frame(result, case, model, torque_dim, degrees).to_xarray()


def drive_result_frame(
    result: Drive,
    case: Case,
    model: Model,
    torque_dim: bool,
    degrees: ArrayLike | None = None,
) -> Frame:
    """The :class:`~cyclomesh.results.frame.Frame` of :func:`analyse_frame` from a
    :class:`~cyclomesh.drive.solve.Drive` of ``case`` and ``model`` (its disc body
    resolved): :func:`drive_frame` with the model's
    ``contact_law`` and ``disc_body`` attributes, and the crank angles in [deg] as given.
    With friction (``result.friction``) the friction variables of
    :mod:`cyclomesh.results.efficiency` are added, the back-driving ones from a second solve
    of the same case and model."""
    modification = case.modification or Modification()
    ds = drive_frame(result, case.design, modification, model.groove_deformation, torque_dim)
    if result.friction is not None:
        from cyclomesh.results.efficiency import efficiency_variables, friction_attrs

        friction = model.friction
        back = drive(case, model, backdrive=True)
        ds = ds.assign(
            efficiency_variables(result, back, case.design.teeth, friction.speed, torque_dim)
        )
        ds.attrs.update(friction_attrs(friction))
    ds.attrs["contact_law"] = model.contact_law
    body = model.disc_body
    ds.attrs["disc_body"] = "rigid" if isinstance(body, str) else "fe"
    if not isinstance(body, str):
        ds.attrs["disc_body_key"] = body.key
    if degrees is not None:
        ds = ds.assign_coords(crank_angle=Var("crank_angle", np.asarray(degrees), {"units": "deg"}))
    return ds


def summarize(ds: xr.Dataset | Frame) -> xr.Dataset:
    """Headline numbers of a result, reduced over crank angle and pin (ring kept).

    Returns a Dataset with the metrics of :data:`cyclomesh.results.metrics.METRICS`
    (``te_mean_arcsec``, ``te_pp_arcsec``, ``max_pin_load_n``, ``max_groove_load_n``,
    ``max_contact_stress_mpa``, ``max_groove_stress_mpa``, ``min_contacts``,
    ``max_contacts``, ``gear_ratio_ripple_pct`` (peak-to-peak of the instantaneous ratio
    in % of n2, over the step ``gear_ratio_step_deg``), ``max_overlap_arcsec`` and
    ``any_overlap``), each with its ``units`` and ``long_name``, and those of
    :data:`cyclomesh.results.metrics.DRIVE_METRICS` the result has (``play_arcsec_mean``,
    ``play_arcsec_max``, ``max_mesh_force_n``). A ``torque`` dimension (a list of
    torques) is kept; a ``disc`` dimension (a stack) is reduced with the pins (per-disc
    contacts with the crank angles).
    """
    return summary_frame(ds).to_xarray()


def summary_frame(ds: xr.Dataset | Frame) -> Frame:
    """:func:`summarize` of a Dataset or a :class:`~cyclomesh.results.frame.Frame` as a
    Frame (no xarray imported for a Frame)."""
    order = [d for d in ds["pin_load"].dims if d not in ("crank_angle", "disc", "pin")]
    stack = ("disc",) if "disc" in ds.dims else ()

    def merged(name: str, dims: tuple[str, ...]) -> np.ndarray:
        """``ds[name]`` over ``(*order, *dims)``, the last two of dims merged if stacked."""
        present = tuple(d for d in dims if d in ds[name].dims)
        values = ds[name].transpose(*order, *present).values
        extra = len(present) - (2 if present[-1] == "pin" else 1)
        return values.reshape(*values.shape[: values.ndim - extra - 1], -1) if extra else values

    values = summary_metrics(
        {
            "transmission_error": merged("transmission_error", ("crank_angle",)),
            "gear_ratio": merged("gear_ratio", ("crank_angle",)),
            "contacts": merged("contacts", ("crank_angle", *stack)),
            **{name: merged(name, ("crank_angle", *stack, "pin")) for name in _METRIC_PIN_SOURCES},
        },
        ds.attrs["teeth"],
    )
    coords = {d: Var(d, ds[d].values, ds[d].attrs) for d in order if d in ds.coords}
    data = {name: Var(order, values[name]) for name in METRICS}

    def reduced(name: str, how: str, over: tuple[str, ...]) -> Var:
        keep = [d for d in order if d in ds[name].dims]  # play has no torque dimension
        return Var(keep, nan_reduce(ds[name], how, over, keep))

    if "play" in ds:
        data["play_arcsec_mean"] = reduced("play", "mean", ("crank_angle",))
        data["play_arcsec_max"] = reduced("play", "max", ("crank_angle",))
    if "mesh_force" in ds:
        data["max_mesh_force_n"] = reduced("mesh_force", "max", ("crank_angle", *stack))
    if "torque_share" in ds:
        data["min_torque_share_nm"] = reduced("torque_share", "min", ("crank_angle", *stack))
        data["max_torque_share_nm"] = reduced("torque_share", "max", ("crank_angle", *stack))
    for name, var in data.items():
        metric = METRICS.get(name) or DRIVE_METRICS[name]
        var.attrs = {"units": metric.unit, "long_name": metric.long_name}
    return Frame(data, coords, {"gear_ratio_step_deg": ds.attrs.get("gear_ratio_step_deg", 0.0)})


def ltca_metrics(result: LTCA, teeth: int) -> dict[str, NDArray]:
    """The metrics of :data:`cyclomesh.results.metrics.METRICS` straight from a core result (SI).

    The same numbers as ``summarize(to_dataset(result, ...))``, bit for bit (same unit
    scales, same reductions), without building a Dataset; leading ring axes are kept.
    """
    scaled = {
        name: getattr(result, name) * table[name][0]
        for table in (_PER_PIN, _PER_ANGLE)
        for name in table
        if name in _METRIC_SOURCES
    }
    return summary_metrics(scaled, teeth)


def drive_metrics(result: Drive, teeth: int) -> dict[str, NDArray]:
    """The metrics of ``summarize(analyse(...))`` straight from a one-torque core result.

    :data:`cyclomesh.results.metrics.METRICS` (per-pin ones reduced over the discs and pins,
    contacts per disc), ``max_mesh_force_n`` (largest mesh force on a disc [N]) and, for a
    stack, ``min_torque_share_nm`` / ``max_torque_share_nm`` (range of the torque one
    disc carries [N·m]); bit for bit those of :func:`summarize`, leading ring axes kept.
    """
    angles, discs, pins = result.pin_load.shape[-3:]

    def per_pin(name: str) -> NDArray:
        value = getattr(result, name)[..., 0, :, :, :]
        scale = _PER_PIN[name][0]
        if name in _PIN_MAX_SOURCES and scale > 0:
            # the largest over the crank angles, discs and pins first (one pass over each
            # ring's values), then the unit: fl(s·x) is monotone in x for s > 0, so
            # max(s·x) = s·max(x), bit for bit
            whole = value.reshape(*value.shape[:-3], 1, angles * discs * pins)
            return np.max(whole, axis=-1, keepdims=True) * scale
        value = value * scale
        return value.reshape(*value.shape[:-2], discs * pins)

    out = summary_metrics(
        {
            "transmission_error": result.transmission_error[..., 0, :]
            * _PER_ANGLE["transmission_error"][0],
            "gear_ratio": result.gear_ratio[..., 0, :],
            "contacts": result.contacts[..., 0, :, :].reshape(*result.contacts.shape[:-3], -1),
            **{name: per_pin(name) for name in _METRIC_PIN_SOURCES},
        },
        teeth,
    )
    out["max_mesh_force_n"] = np.max(result.mesh_force[..., 0, :, :], axis=(-2, -1))
    if discs > 1:
        share = result.torque_share[..., 0, :, :]
        out["min_torque_share_nm"] = np.min(share, axis=(-2, -1))
        out["max_torque_share_nm"] = np.max(share, axis=(-2, -1))
    return out


FE_EXTRA_MESSAGE = (
    'disc_body = "fe" needs the fe extra: pip install "cyclomesh[fe]" (scikit-fem and gmsh)'
)


def fe_extra_available() -> bool:
    """Whether the ``fe`` extra (scikit-fem, gmsh and its system libraries) loads."""
    try:
        import gmsh  # noqa: F401
        import skfem  # noqa: F401
    except (ImportError, OSError):
        return False
    return True


def resolve_disc_body(
    disc_body: Any,
    design: PairDesign,
    modification: Modification | None = None,
    crank_holes: Any = None,
    cache_dir: Any = None,
    stage: bool = False,
) -> Any:
    """``"rigid"``, or the :class:`~cyclomesh.core.discbody.DiscBody` of ``disc_body="fe"``
    (from the cache, computed on a miss), or a DiscBody passed through. ``stage``: the RV
    stage's body, the :class:`~cyclomesh.core.discbody.FreeDiscBody` with the crank-hole
    centres free (:func:`cyclomesh.fe.influence.free_influence`).

    Raises
    ------
    DesignError
        For ``"fe"`` without the fe extra (one line naming it).
    """
    if not (isinstance(disc_body, str) and disc_body == "fe"):
        return disc_body
    if not fe_extra_available():
        raise DesignError(FE_EXTRA_MESSAGE)
    if stage:
        from cyclomesh.fe.influence import free_influence

        return free_influence(design, modification, crank_holes, cache_dir)
    from cyclomesh.fe.influence import influence

    return influence(design, modification, crank_holes, cache_dir)
