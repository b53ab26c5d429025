"""The one registry of result quantities: name, unit, long name, label, scale, dims, parity.

Every number cyclomesh writes is a row of :data:`QUANTITIES`: the per-pin, per-angle and
per-disc variables of a run's Dataset, the variables of the stage and of the torsion
curve, and the headline metrics of ``summary.json``, the tolerance and design-map files,
the CSV/Parquet headers and the terminal tables. The Datasets (``cyclomesh.results``),
the metric tables (:mod:`cyclomesh.results.metrics`), the design-map metrics
(:mod:`cyclomesh.designspace.sweep`), the requirement checks and the console read
their units, long names and labels here; ``tests/test_quantities.py`` checks that every
Dataset variable and every summary key is a row.

A quantity has

* ``name``: the variable or key as written (a metric carries its unit suffix,
  ``max_contact_stress_mpa``);
* ``unit``: the unit as written in files, one spelling per unit (``N·m``,
  ``N·m/arcmin``, ``arcsec``, ``MPa``; ``1`` for a count or a ratio; ``""`` for text);
* ``long_name`` (files, report) and ``label`` (tables, axes);
* ``scale``: the factor from SI to ``unit`` (a Dataset variable is the core's SI field
  times ``scale``);
* ``dims``: the dimensions of a run's variable (``()`` for a metric of a case);
* ``parity``: +1 or −1, the sign the quantity takes in the mirror image that maps the
  forward flanks onto the reverse ones (:mod:`cyclomesh.drive.solve`);
* ``reduce``: for a metric, ``(source, how)``: the quantity it reduces and how
  (:data:`REDUCTIONS`), read by :func:`cyclomesh.results.metrics.summary_metrics`.

Adding a per-contact quantity: a row here (and the field in the core,
:func:`cyclomesh.core.fields.contact_fields`); a metric of it is one more row with
``reduce`` (docs/pipeline.md, "Add a quantity").
"""

from __future__ import annotations

from dataclasses import dataclass

from cyclomesh.units import ARCSEC_PER_RAD, DEG_PER_RAD

__all__ = ["Quantity", "QUANTITIES", "REDUCTIONS", "quantity", "label", "select"]


@dataclass(frozen=True)
class Quantity:
    """One result quantity (module doc): name, unit, long name, label, SI scale, dims,
    mirror parity and the reduction that makes it a metric."""

    name: str
    unit: str
    long_name: str
    label: str
    scale: float = 1.0
    dims: tuple[str, ...] = ()
    parity: int = 1
    reduce: tuple[str, str] | None = None


REDUCTIONS = ("max", "min", "mean", "peak_to_peak", "ripple_pct", "positive")
"""How a metric reduces its source over the crank angles (and pins): the largest, the
smallest, the mean, max − min, max − min in % of n2 (a gear ratio), any value > 0."""

PIN = ("crank_angle", "pin")
ANGLE = ("crank_angle",)
DISC = ("crank_angle", "disc")
STAGE_PIN = ("crank_angle", "disc", "pin")
CRANK = ("crank_angle", "disc", "crank")
TORSION = ("torque", "crank_angle")

_ROWS = (
    # --- a run, per pin (Dataset of cyclomesh.analyse) ------------------------------
    Quantity("pin_load", "N", "pin-tooth contact force Fc", "pin load", 1.0, PIN),
    Quantity("groove_load", "N", "pin-groove contact force Fp", "groove load", 1.0, PIN),
    Quantity("contact_stress", "MPa", "max. Hertzian pressure, pin-tooth", "σH tooth", 1e-6, PIN),
    Quantity("groove_stress", "MPa", "max. Hertzian pressure, pin-groove", "σH groove", 1e-6, PIN),
    Quantity(
        "backlash",
        "arcsec",
        "unloaded backlash φbl (inf: unreachable)",
        "backlash",
        ARCSEC_PER_RAD,
        PIN,
    ),
    Quantity(
        "overlap",
        "arcsec",
        "interference with the unloaded flank",
        "overlap",
        ARCSEC_PER_RAD,
        PIN,
    ),
    Quantity(
        "profile_angle",
        "deg",
        "generating angle φ1 of contact",
        "φ1",
        DEG_PER_RAD,
        PIN,
        parity=-1,
    ),
    Quantity(
        "contact_radius",
        "mm",
        "radius of the contact point on the disc",
        "contact radius",
        1e3,
        PIN,
    ),
    Quantity("moment_arm", "mm", "moment arm of the line of action", "moment arm", 1e3, PIN),
    Quantity("curvature_radius", "mm", "signed profile curvature radius ρc", "ρc", 1e3, PIN),
    Quantity(
        "force_angle",
        "deg",
        "direction of the pin force on the disc, from x",
        "force angle",
        DEG_PER_RAD,
        PIN,
        parity=-1,
    ),
    Quantity("pin_radial_error", "um", "εa,i", "radial error", 1e6, ("pin",)),
    Quantity("pin_angular_error", "urad", "εψ,i", "angular error", 1e6, ("pin",)),
    Quantity("pin_radius_error", "um", "ερ,i", "pin radius error", 1e6, ("pin",)),
    # --- a run, per crank angle -------------------------------------------------------
    Quantity("transmission_error", "arcsec", "loaded TE", "TE", ARCSEC_PER_RAD, ANGLE, parity=-1),
    Quantity("gear_ratio", "1", "instantaneous gear ratio", "gear ratio", 1.0, ANGLE),
    Quantity(
        "contacts",
        "1",
        "number of pins in contact: load above 0.1 % of the largest pin load at the angle",
        "pins in contact",
        1,
        ANGLE,
    ),
    Quantity(
        "loaded_rotation",
        "arcsec",
        "disc rotation under load Δφc",
        "Δφc",
        ARCSEC_PER_RAD,
        ANGLE,
        parity=-1,
    ),
    Quantity(
        "rest_rotation",
        "arcsec",
        "unloaded rest position φc − φt",
        "rest position",
        ARCSEC_PER_RAD,
        ANGLE,
        parity=-1,
    ),
    Quantity(
        "play",
        "arcsec",
        "angular play between the flanks at zero load",
        "play",
        ARCSEC_PER_RAD,
        ANGLE,
    ),
    # --- a run, per disc ----------------------------------------------------------------
    Quantity(
        "mesh_force",
        "N",
        "resultant of the pin forces on the disc (crank bearing load)",
        "mesh force",
        1.0,
        DISC,
    ),
    Quantity(
        "mesh_force_angle",
        "deg",
        "direction of the mesh force, from x",
        "mesh force angle",
        DEG_PER_RAD,
        DISC,
        parity=-1,
    ),
    Quantity(
        "torque_share", "N·m", "torque carried by the disc", "disc torque", 1.0, DISC, parity=-1
    ),
    # --- the RV stage of a run ------------------------------------------------------------
    Quantity("crank_bearing_load", "N", "crank bearing load", "bearing load", 1.0, CRANK),
    Quantity(
        "crank_bearing_load_angle",
        "deg",
        "direction of the disc's force on the crank pin, from x",
        "bearing load angle",
        DEG_PER_RAD,
        CRANK,
    ),
    Quantity(
        "crank_bearing_deflection",
        "um",
        "displacement of the crank hole against its crank pin (clearance included)",
        "bearing deflection",
        1e6,
        CRANK,
    ),
    Quantity("max_roller_load", "N", "load of the most loaded needle roller", "max Q", 1.0, CRANK),
    Quantity(
        "crank_bearing_equivalent_load",
        "N",
        "equivalent dynamic load over the crank angles (p = 10/3)",
        "P",
        1.0,
        ("disc", "crank"),
    ),
    Quantity(
        "crank_bearing_l10",
        "h",
        "basic rating life L10h (ISO 281) at the output speed",
        "L10h",
        1.0,
        ("disc", "crank"),
    ),
    Quantity("disc_translation_x", "um", "disc translation x", "ux", 1e6, ("crank_angle", "disc")),
    Quantity("disc_translation_y", "um", "disc translation y", "uy", 1e6, ("crank_angle", "disc")),
    Quantity("stage_pin_load", "N", "pin load in the stage", "pin load", 1.0, STAGE_PIN),
    Quantity(
        "stage_groove_stress",
        "MPa",
        "pin-groove contact stress in the stage (loaded flank, Eq. 24)",
        "σH groove",
        1e-6,
        STAGE_PIN,
    ),
    Quantity(
        "stage_opposite_pin_load",
        "N",
        "pin load on the opposite flank (closed by the disc's translation)",
        "opposite pin load",
        1.0,
        STAGE_PIN,
    ),
    Quantity(
        "rigid_bearing_transmission_error",
        "arcsec",
        "loaded TE of the mesh on rigid bearings",
        "TE, rigid bearings",
        ARCSEC_PER_RAD,
        ANGLE,
        parity=-1,
    ),
    Quantity(
        "stage_transmission_error",
        "arcsec",
        "TE of the output (carrier), mesh, bearings and springs",
        "stage TE",
        ARCSEC_PER_RAD,
        ANGLE,
        parity=-1,
    ),
    Quantity(
        "stage_te_order_amplitude",
        "arcsec",
        "amplitude of the output's TE by order of the crank revolution "
        "(output order = crank order x (n1 - 1))",
        "stage TE by order",
        ARCSEC_PER_RAD,
        ("crank_order",),
    ),
    Quantity(
        "torque_share_order_amplitude",
        "N·m",
        "amplitude of each disc's torque share by order",
        "disc torque by order",
        1.0,
        ("crank_order", "disc"),
    ),
    # --- a torsion curve (cyclomesh.stiffness) --------------------------------------------
    Quantity(
        "rotation",
        "arcsec",
        "disc rotation from theoretical (TE sign)",
        "rotation",
        ARCSEC_PER_RAD,
        TORSION,
        parity=-1,
    ),
    Quantity("max_contact_stress", "MPa", "max. Hertzian pressure, pin-tooth", "max σH", 1e-6),
    Quantity("lost_motion", "arcmin", "lost motion TE(-3 %) - TE(+3 %) of rated", "lost motion"),
    Quantity(
        "torsional_rigidity",
        "N·m/arcmin",
        "torsional rigidity, 50-100 % of rated",
        "rigidity",
    ),
    Quantity(
        "drive_rotation",
        "arcsec",
        "whole-drive rotation (mesh + series stiffness)",
        "drive rotation",
        ARCSEC_PER_RAD,
        TORSION,
        parity=-1,
    ),
    Quantity("drive_lost_motion", "arcmin", "whole-drive lost motion", "drive lost motion"),
    Quantity(
        "drive_torsional_rigidity",
        "N·m/arcmin",
        "whole-drive torsional rigidity",
        "drive rigidity",
    ),
    Quantity(
        "stage_rotation",
        "arcsec",
        "output rotation of the RV stage (TE sign)",
        "stage rotation",
        ARCSEC_PER_RAD,
        TORSION,
        parity=-1,
    ),
    Quantity("stage_lost_motion", "arcmin", "lost motion of the RV stage", "stage lost motion"),
    Quantity(
        "stage_torsional_rigidity",
        "N·m/arcmin",
        "torsional rigidity of the RV stage",
        "stage rigidity",
    ),
    Quantity(
        "rotation_ascending",
        "arcsec",
        "disc rotation, rising torque (friction loop)",
        "rising",
        ARCSEC_PER_RAD,
        TORSION,
        parity=-1,
    ),
    Quantity(
        "rotation_descending",
        "arcsec",
        "disc rotation, falling torque (friction loop)",
        "falling",
        ARCSEC_PER_RAD,
        TORSION,
        parity=-1,
    ),
    Quantity("hysteresis", "arcmin", "largest width of the friction loop", "hysteresis"),
    # --- metrics of a run (summary.json, tolerance rings, CLI tables) ------------------------
    Quantity(
        "te_mean_arcsec",
        "arcsec",
        "mean loaded transmission error (Eq. 25)",
        "TE mean",
        reduce=("transmission_error", "mean"),
    ),
    Quantity(
        "te_pp_arcsec",
        "arcsec",
        "peak-to-peak loaded transmission error",
        "TE p-p",
        reduce=("transmission_error", "peak_to_peak"),
    ),
    Quantity(
        "max_pin_load_n", "N", "largest pin load Fc", "max pin load", reduce=("pin_load", "max")
    ),
    Quantity(
        "max_groove_load_n",
        "N",
        "largest groove load Fp",
        "max groove load",
        reduce=("groove_load", "max"),
    ),
    Quantity(
        "max_contact_stress_mpa",
        "MPa",
        "peak contact stress, pin-tooth (Eq. 24)",
        "max σH tooth",
        reduce=("contact_stress", "max"),
    ),
    Quantity(
        "max_groove_stress_mpa",
        "MPa",
        "peak contact stress, pin-groove (Eq. 24)",
        "max σH groove",
        reduce=("groove_stress", "max"),
    ),
    Quantity(
        "min_contacts",
        "1",
        "fewest pins in contact",
        "min pins in contact",
        reduce=("contacts", "min"),
    ),
    Quantity(
        "max_contacts",
        "1",
        "most pins in contact",
        "max pins in contact",
        reduce=("contacts", "max"),
    ),
    Quantity(
        "gear_ratio_ripple_pct",
        "%",
        "gear-ratio ripple, peak-to-peak in % of n2 (Eq. 26)",
        "ratio ripple",
        reduce=("gear_ratio", "ripple_pct"),
    ),
    Quantity(
        "max_overlap_arcsec",
        "arcsec",
        "largest interference with an unloaded-side pin",
        "max overlap",
        reduce=("overlap", "max"),
    ),
    Quantity(
        "any_overlap",
        "1",
        "any interference with an unloaded-side pin (0/1)",
        "overlap",
        reduce=("overlap", "positive"),
    ),
    Quantity("play_arcsec_mean", "arcsec", "mean play between the flanks at zero load", "play"),
    Quantity("play_arcsec_max", "arcsec", "largest play between the flanks", "max play"),
    Quantity(
        "max_mesh_force_n",
        "N",
        "largest mesh force on a disc (crank bearing load)",
        "max mesh force",
    ),
    Quantity(
        "min_torque_share_nm", "N·m", "smallest torque carried by one disc", "min disc torque"
    ),
    Quantity("max_torque_share_nm", "N·m", "largest torque carried by one disc", "max disc torque"),
    Quantity("rated_torque_nm", "N·m", "rated torque T_r of the torsion curve", "rated torque"),
    Quantity("gear_ratio_step_deg", "deg", "crank step of the gear ratio (Eq. 26)", "ratio step"),
    # --- metrics of a torsion curve (cyclomesh stiffness) ------------------------------------
    Quantity("play_arcmin_mean", "arcmin", "mean play at zero load", "play"),
    Quantity("play_arcmin_max", "arcmin", "largest play at zero load", "max play"),
    Quantity(
        "lost_motion_arcmin_mean",
        "arcmin",
        "mean lost motion, TE(-3 %) - TE(+3 %) of rated",
        "mesh lost motion",
    ),
    Quantity("lost_motion_arcmin_max", "arcmin", "largest lost motion", "max mesh lost motion"),
    Quantity(
        "torsional_rigidity_nm_per_arcmin_mean",
        "N·m/arcmin",
        "mean torsional rigidity of the mesh, secant 50-100 % of rated",
        "mesh rigidity",
    ),
    Quantity(
        "torsional_rigidity_nm_per_arcmin_min",
        "N·m/arcmin",
        "smallest torsional rigidity of the mesh",
        "min mesh rigidity",
    ),
    Quantity(
        "drive_lost_motion_arcmin_mean",
        "arcmin",
        "mean lost motion of the whole drive (mesh + series stiffness)",
        "drive lost motion",
    ),
    Quantity(
        "drive_lost_motion_arcmin_max",
        "arcmin",
        "largest lost motion of the whole drive",
        "max drive lost motion",
    ),
    Quantity(
        "drive_torsional_rigidity_nm_per_arcmin_mean",
        "N·m/arcmin",
        "mean torsional rigidity of the whole drive (mesh + series stiffness)",
        "drive rigidity",
    ),
    Quantity(
        "drive_torsional_rigidity_nm_per_arcmin_min",
        "N·m/arcmin",
        "smallest torsional rigidity of the whole drive",
        "min drive rigidity",
    ),
    Quantity(
        "hysteresis_arcmin_mean",
        "arcmin",
        "mean width of the friction loop (with [friction])",
        "hysteresis",
    ),
    Quantity(
        "hysteresis_arcmin_max",
        "arcmin",
        "largest width of the friction loop",
        "max hysteresis",
    ),
    # --- friction (docs/efficiency.md): a run's variables, per pin, disc or angle -----------
    Quantity(
        "friction_force",
        "N",
        "tangential (friction) force at the pin contact",
        "friction",
        1.0,
        PIN,
    ),
    Quantity(
        "sliding_velocity_tooth", "m/s", "sliding velocity, pin-tooth", "sliding tooth", 1.0, PIN
    ),
    Quantity(
        "sliding_velocity_groove", "m/s", "sliding velocity, pin-groove", "sliding groove", 1.0, PIN
    ),
    Quantity("power_loss_tooth", "W", "friction power loss, pin-tooth", "loss pin-tooth", 1.0, PIN),
    Quantity(
        "power_loss_groove", "W", "friction power loss, pin-groove", "loss pin-groove", 1.0, PIN
    ),
    Quantity("friction_coefficient", "1", "friction coefficient acting on the disc", "μ", 1.0, PIN),
    Quantity(
        "film_parameter",
        "1",
        "film parameter h_c/sigma at the sliding interface (0: pin unloaded)",
        "λ",
        1.0,
        PIN,
    ),
    Quantity(
        "power_loss_bearing",
        "W",
        "friction power loss of the crank bearing",
        "loss bearing",
        1.0,
        DISC,
    ),
    Quantity(
        "input_torque",
        "N·m",
        "input torque, moment balance of the crank (forward)",
        "T in",
        1.0,
        ANGLE,
        parity=-1,
    ),
    Quantity(
        "backdrive_input_torque",
        "N·m",
        "input torque, moment balance (back-driving)",
        "T in back",
        1.0,
        ANGLE,
        parity=-1,
    ),
    Quantity("output_power", "W", "output power |T|·ω/n2", "P out", 1.0, ANGLE),
    Quantity("power_loss", "W", "friction power loss, all paths (forward)", "P loss", 1.0, ANGLE),
    Quantity(
        "backdrive_power_loss",
        "W",
        "friction power loss, all paths (back-driving)",
        "P loss back",
        1.0,
        ANGLE,
    ),
    Quantity("input_power", "W", "input power P_out + P_loss (forward)", "P in", 1.0, ANGLE),
    Quantity("moment_input_power", "W", "T_in·ω from the moment balance", "T in·ω", 1.0, ANGLE),
    Quantity("instantaneous_efficiency", "1", "forward efficiency", "η", 1.0, ANGLE),
    Quantity(
        "instantaneous_backdrive_efficiency", "1", "back-driving efficiency", "η back", 1.0, ANGLE
    ),
    # --- friction: metrics of a run (summary.json) -----------------------------------------
    Quantity("efficiency", "1", "forward efficiency, P_out/P_in over the angles", "efficiency"),
    Quantity(
        "backdrive_efficiency", "1", "back-driving efficiency over the angles", "back-drive eff."
    ),
    Quantity("input_power_w", "W", "mean input power (forward)", "P in"),
    Quantity("output_power_w", "W", "mean output power (forward)", "P out"),
    Quantity("input_speed_rpm", "rpm", "input (crank) speed", "n in"),
    Quantity("film_parameter_min", "1", "smallest film parameter of the loaded contacts", "λ min"),
    Quantity("film_parameter_mean", "1", "mean film parameter of the loaded contacts", "λ mean"),
    Quantity(
        "power_loss_w",
        "W",
        "mean friction power loss per path (table path -> W; null: not modelled)",
        "P loss",
    ),
    # --- friction: an efficiency map (cyclomesh efficiency, summary.json) ---------------------
    Quantity("peak_efficiency", "1", "largest forward efficiency of the map", "peak efficiency"),
    Quantity("peak_torque_nm", "N·m", "output torque of the peak efficiency", "at torque"),
    Quantity("peak_speed_rpm", "rpm", "input speed of the peak efficiency", "at input speed"),
    Quantity("rated_speed_rpm", "rpm", "input speed of the rated point", "rated speed"),
    Quantity("rated_efficiency", "1", "forward efficiency at the rated point", "rated efficiency"),
    Quantity(
        "rated_backdrive_efficiency",
        "1",
        "back-driving efficiency at the rated point",
        "rated back-driving",
    ),
    Quantity("rated_input_power_w", "W", "input power at the rated point", "rated input power"),
    Quantity(
        "rated_power_loss_w",
        "W",
        "power loss per path at the rated point (table path -> W; null: not modelled)",
        "rated losses",
    ),
    Quantity("efficiency_min", "1", "smallest forward efficiency of the map", "min efficiency"),
    Quantity(
        "backdrive_efficiency_min",
        "1",
        "smallest back-driving efficiency of the map",
        "min back-drive eff.",
    ),
    # --- metrics of the RV stage -------------------------------------------------------------
    Quantity("stage_rated_torque_nm", "N·m", "rated torque of the data sheet", "rated torque"),
    Quantity("stage_output_speed_rpm", "rpm", "output speed of the rated life", "speed"),
    Quantity("stage_l10_h_min", "h", "L10h of the weakest crank bearing (ISO 281)", "bearing L10h"),
    Quantity(
        "stage_equivalent_load_n_max",
        "N",
        "largest equivalent dynamic load of a crank bearing over the revolution",
        "P max",
    ),
    Quantity(
        "stage_dynamic_load_rating_kn",
        "kN",
        "basic dynamic load rating C_r of a crank bearing",
        "C_r",
    ),
    Quantity(
        "stage_torsional_rigidity_nm_per_arcmin",
        "N·m/arcmin",
        "torsional rigidity of the stage (mesh, bearings, crankshafts, carrier), b/a "
        "50-100 % of rated (catalogue)",
        "stage rigidity",
    ),
    Quantity(
        "mesh_torsional_rigidity_nm_per_arcmin",
        "N·m/arcmin",
        "torsional rigidity of the mesh alone (rigid bearings)",
        "mesh rigidity",
    ),
    Quantity(
        "stage_lost_motion_arcmin",
        "arcmin",
        "lost motion of the stage: twist between the loop's mid-points at -3 % and +3 %",
        "stage lost motion",
    ),
    Quantity("mesh_lost_motion_arcmin", "arcmin", "lost motion of the mesh alone", "mesh LM"),
    Quantity(
        "stage_backlash_arcmin",
        "arcmin",
        "backlash of the stage: width of the loop at zero torque (at ±0.1 %)",
        "stage backlash",
    ),
    Quantity("mesh_backlash_arcmin", "arcmin", "backlash of the mesh alone", "mesh backlash"),
    Quantity(
        "stage_duty_equivalent_torque_nm",
        "N·m",
        "equivalent torque of the duty cycle (cubic mean, exponent 10/3)",
        "T_eq",
    ),
    Quantity(
        "stage_duty_equivalent_speed_rpm", "rpm", "mean output speed of the duty cycle", "n_eq"
    ),
    Quantity(
        "stage_duty_l10_h_min",
        "h",
        "L10h of the weakest crank bearing over the duty cycle (ISO 281, variable load)",
        "L10h cycle",
    ),
    Quantity(
        "stage_l10_h_at_equivalent_torque",
        "h",
        "L10h of the weakest crank bearing at T_eq and n_eq",
        "L10h at T_eq",
    ),
    Quantity(
        "compliance_share",
        "1",
        "share of the output twist at rated torque by part of the stage (virtual work): "
        "mesh, crank bearings, crankshafts, carrier, hole errors",
        "compliance share",
    ),
    Quantity(
        "stage_te_orders",
        "arcsec",
        "three largest orders of the output TE at rated torque: [crank order, output order, "
        "amplitude]",
        "stage TE orders",
    ),
    Quantity(
        "torque_share_orders",
        "N·m",
        "three largest orders of the disc torque share at rated torque: [crank order, output "
        "order, amplitude of the largest disc]",
        "disc torque orders",
    ),
    Quantity(
        "stage_max_contact_stress_mpa",
        "MPa",
        "peak pin-tooth contact stress at rated torque",
        "max σH",
    ),
    Quantity(
        "stage_max_crank_bearing_load_n",
        "N",
        "largest crank bearing load at rated torque",
        "max bearing load",
    ),
    Quantity("stage_max_roller_load_n", "N", "largest needle roller load at rated torque", "max Q"),
    Quantity(
        "stage_lost_motion_arcmin_mean", "arcmin", "mean lost motion of the stage", "stage LM"
    ),
    Quantity(
        "stage_lost_motion_arcmin_max",
        "arcmin",
        "largest lost motion of the stage",
        "max stage lost motion",
    ),
    Quantity(
        "stage_torsional_rigidity_nm_per_arcmin_mean",
        "N·m/arcmin",
        "mean torsional rigidity of the stage",
        "stage rigidity",
    ),
    Quantity(
        "stage_torsional_rigidity_nm_per_arcmin_min",
        "N·m/arcmin",
        "smallest torsional rigidity of the stage",
        "min stage rigidity",
    ),
    Quantity(
        "measured_torsional_rigidity_nm_per_arcmin",
        "N·m/arcmin",
        "measured torsional rigidity (b/a, 50-100 % of rated)",
        "measured rigidity",
    ),
    Quantity(
        "measured_lost_motion_arcmin",
        "arcmin",
        "measured lost motion (±3 %)",
        "measured lost motion",
    ),
    Quantity(
        "measured_backlash_arcmin", "arcmin", "measured backlash (width at 0)", "measured backlash"
    ),
    Quantity(
        "reconciling_compliance_arcmin_per_knm",
        "arcmin/kN·m",
        "series compliance that would take the model to the measured rigidity (not applied)",
        "reconciling compliance",
    ),
    Quantity(
        "reconciling_stiffness_nm_per_arcmin",
        "N·m/arcmin",
        "series stiffness that would take the model to the measured rigidity (not applied)",
        "reconciling stiffness",
    ),
    Quantity(
        "lost_motion_difference_arcmin",
        "arcmin",
        "measured lost motion less the model's",
        "LM difference",
    ),
    # --- metrics of a design map (cyclomesh design) -------------------------------------------
    Quantity("feasible", "1", "feasible", "feasible"),
    Quantity("reason", "", "why the candidate is infeasible (text)", "reason"),
    Quantity("play_arcmin", "arcmin", "largest unloaded play", "max play"),
    Quantity("min_play_arcmin", "arcmin", "smallest unloaded play", "min play"),
    Quantity("lost_motion_arcmin", "arcmin", "lost motion TE(-3 % T) - TE(+3 % T)", "lost motion"),
    Quantity(
        "loss_fraction",
        "1",
        "power loss over input power, 1 - efficiency (with friction)",
        "loss fraction",
    ),
    # --- metrics of an FE check (cyclomesh fe) -----------------------------------------------
    Quantity("fe_max_pin_load_n", "N", "largest pin load, FE", "FE max pin load"),
    Quantity("fe_max_contact_stress_mpa", "MPa", "peak contact stress, pin-tooth, FE", "FE max σH"),
    Quantity(
        "fe_rotation_arcsec_mean",
        "arcsec",
        "mean loaded disc position, FE (TE convention, Eq. 25)",
        "FE rotation",
    ),
    *(
        row
        for law in ("paper", "half_plane")
        for row in (
            Quantity(f"ltca_{law}_max_pin_load_n", "N", f"largest pin load, LTCA ({law} law)", law),
            Quantity(
                f"ltca_{law}_pin_load_rms_pct",
                "%",
                f"RMS of LTCA ({law} law) minus FE pin loads, % of the FE peak",
                f"{law} RMS dev.",
            ),
            Quantity(
                f"ltca_{law}_rotation_arcsec_mean",
                "arcsec",
                f"mean loaded disc position, LTCA ({law} law)",
                f"{law} rotation",
            ),
        )
    ),
    Quantity(
        "ltca_max_pin_load_n",
        "N",
        "largest pin load, LTCA of the study ([analysis]: contact law, disc body)",
        "LTCA",
    ),
    Quantity(
        "ltca_pin_load_rms_pct",
        "%",
        "RMS of LTCA of the study minus FE pin loads, % of the FE peak",
        "LTCA RMS dev.",
    ),
    Quantity(
        "ltca_rotation_arcsec_mean",
        "arcsec",
        "mean loaded disc position, LTCA of the study",
        "LTCA rotation",
    ),
)

QUANTITIES: dict[str, Quantity] = {q.name: q for q in _ROWS}
"""Every result quantity by name, in the order of tables and files."""
assert len(QUANTITIES) == len(_ROWS), "a quantity is named twice"


def quantity(name: str) -> Quantity:
    """The row of ``name``; a KeyError names the registry when there is none."""
    try:
        return QUANTITIES[name]
    except KeyError:
        raise KeyError(f"{name!r} is not a row of cyclomesh.quantities.QUANTITIES") from None


def label(name: str) -> str:
    """``long name [unit]`` for axes and tables (no unit for dimensionless quantities)."""
    q = quantity(name)
    return q.long_name if q.unit == "1" else f"{q.long_name} [{q.unit}]"


def select(*names: str) -> dict[str, Quantity]:
    """The rows of ``names``, in that order (a metric table of a kind of study)."""
    return {name: quantity(name) for name in names}
