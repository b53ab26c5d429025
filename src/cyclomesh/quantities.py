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

_SI_SCALE = {
    "N": 1.0,
    "MPa": 1e-6,
    "arcsec": ARCSEC_PER_RAD,
    "deg": DEG_PER_RAD,
    "mm": 1e3,
    "um": 1e6,
    "urad": 1e6,
    "1": 1.0,
    "N·m": 1.0,
    "h": 1.0,
    "m/s": 1.0,
    "W": 1.0,
}
"""The scale from SI of a variable (a row with dims) by its unit; a metric's is 1.0 (its
value is computed in its unit)."""

_OTHER_SCALE = {"contacts": 1, "max_contact_stress": 1e-6}
"""Rows whose scale is not the rule of :data:`_SI_SCALE`: the pin count stays an integer;
the torsion curve's peak stress is an SI field of no dims."""

_DIMS = {
    "pin": PIN,
    "angle": ANGLE,
    "disc": DISC,
    "stage_pin": STAGE_PIN,
    "crank": CRANK,
    "torsion": TORSION,
    "pins": ("pin",),
    "disc_crank": ("disc", "crank"),
    "order": ("crank_order",),
    "order_disc": ("crank_order", "disc"),
    "-": (),
}

_TABLE = """
# name | unit | dims (_DIMS) | parity | label | reduce: source how | long name
# ("-": none; an indented line continues the long name of the row above)
# --- a run, per pin (Dataset of cyclomesh.analyse)
pin_load | N | pin | + | pin load | - | pin-tooth contact force Fc
groove_load | N | pin | + | groove load | - | pin-groove contact force Fp
contact_stress | MPa | pin | + | σH tooth | - | max. Hertzian pressure, pin-tooth
groove_stress | MPa | pin | + | σH groove | - | max. Hertzian pressure, pin-groove
backlash | arcsec | pin | + | backlash | - | unloaded backlash φbl (inf: unreachable)
overlap | arcsec | pin | + | overlap | - | interference with the unloaded flank
profile_angle | deg | pin | - | φ1 | - | generating angle φ1 of contact
contact_radius | mm | pin | + | contact radius | - | radius of the contact point on the disc
moment_arm | mm | pin | + | moment arm | - | moment arm of the line of action
curvature_radius | mm | pin | + | ρc | - | signed profile curvature radius ρc
force_angle | deg | pin | - | force angle | - | direction of the pin force on the disc, from x
pin_radial_error | um | pins | + | radial error | - | εa,i
pin_angular_error | urad | pins | + | angular error | - | εψ,i
pin_radius_error | um | pins | + | pin radius error | - | ερ,i
# --- a run, per crank angle
transmission_error | arcsec | angle | - | TE | - | loaded TE
gear_ratio | 1 | angle | + | gear ratio | - | instantaneous gear ratio
contacts | 1 | angle | + | pins in contact | - | number of pins in contact: load above 0.1 % of
    the largest pin load at the angle
loaded_rotation | arcsec | angle | - | Δφc | - | disc rotation under load Δφc
rest_rotation | arcsec | angle | - | rest position | - | unloaded rest position φc − φt
play | arcsec | angle | + | play | - | angular play between the flanks at zero load
# --- a run, per disc
mesh_force | N | disc | + | mesh force | - | resultant of the pin forces on the disc (crank
    bearing load)
mesh_force_angle | deg | disc | - | mesh force angle | - | direction of the mesh force, from x
torque_share | N·m | disc | - | disc torque | - | torque carried by the disc
# --- the RV stage of a run
crank_bearing_load | N | crank | + | bearing load | - | crank bearing load
crank_bearing_load_angle | deg | crank | + | bearing load angle | - | direction of the disc's
    force on the crank pin, from x
crank_bearing_deflection | um | crank | + | bearing deflection | - | displacement of the crank
    hole against its crank pin (clearance included)
max_roller_load | N | crank | + | max Q | - | load of the most loaded needle roller
crank_bearing_equivalent_load | N | disc_crank | + | P | - | equivalent dynamic load over the
    crank angles (p = 10/3)
crank_bearing_l10 | h | disc_crank | + | L10h | - | basic rating life L10h (ISO 281) at the
    output speed
disc_translation_x | um | disc | + | ux | - | disc translation x
disc_translation_y | um | disc | + | uy | - | disc translation y
stage_pin_load | N | stage_pin | + | pin load | - | pin load in the stage
stage_groove_stress | MPa | stage_pin | + | σH groove | - | pin-groove contact stress in the
    stage (loaded flank, Eq. 24)
stage_opposite_pin_load | N | stage_pin | + | opposite pin load | - | pin load on the opposite
    flank (closed by the disc's translation)
rigid_bearing_transmission_error | arcsec | angle | - | TE, rigid bearings | - | loaded TE of
    the mesh on rigid bearings
stage_transmission_error | arcsec | angle | - | stage TE | - | TE of the output (carrier), mesh,
    bearings and springs
stage_te_order_amplitude | arcsec | order | + | stage TE by order | - | amplitude of the
    output's TE by order of the crank revolution (output order = crank order x (n1 - 1))
torque_share_order_amplitude | N·m | order_disc | + | disc torque by order | - | amplitude of
    each disc's torque share by order
# --- a torsion curve (cyclomesh.stiffness)
rotation | arcsec | torsion | - | rotation | - | disc rotation from theoretical (TE sign)
max_contact_stress | MPa | - | + | max σH | - | max. Hertzian pressure, pin-tooth
lost_motion | arcmin | - | + | lost motion | - | lost motion TE(-3 %) - TE(+3 %) of rated
torsional_rigidity | N·m/arcmin | - | + | rigidity | - | torsional rigidity, 50-100 % of rated
drive_rotation | arcsec | torsion | - | drive rotation | - | whole-drive rotation (mesh + series
    stiffness)
drive_lost_motion | arcmin | - | + | drive lost motion | - | whole-drive lost motion
drive_torsional_rigidity | N·m/arcmin | - | + | drive rigidity | - | whole-drive torsional
    rigidity
stage_rotation | arcsec | torsion | - | stage rotation | - | output rotation of the RV stage (TE
    sign)
stage_lost_motion | arcmin | - | + | stage lost motion | - | lost motion of the RV stage
stage_torsional_rigidity | N·m/arcmin | - | + | stage rigidity | - | torsional rigidity of the
    RV stage
rotation_ascending | arcsec | torsion | - | rising | - | disc rotation, rising torque (friction
    loop)
rotation_descending | arcsec | torsion | - | falling | - | disc rotation, falling torque
    (friction loop)
hysteresis | arcmin | - | + | hysteresis | - | largest width of the friction loop
stage_rotation_ascending | arcsec | torsion | - | stage rising | - | output rotation of the RV
    stage, rising torque (friction loop)
stage_rotation_descending | arcsec | torsion | - | stage falling | - | output rotation of the RV
    stage, falling torque (friction loop)
stage_hysteresis | arcmin | - | + | stage hysteresis | - | largest width of the stage's friction
    loop
# --- metrics of a run (summary.json, tolerance rings, CLI tables)
te_mean_arcsec | arcsec | - | + | TE mean | transmission_error mean | mean loaded transmission
    error (Eq. 25)
te_pp_arcsec | arcsec | - | + | TE p-p | transmission_error peak_to_peak | peak-to-peak loaded
    transmission error
max_pin_load_n | N | - | + | max pin load | pin_load max | largest pin load Fc
max_groove_load_n | N | - | + | max groove load | groove_load max | largest groove load Fp
max_contact_stress_mpa | MPa | - | + | max σH tooth | contact_stress max | peak contact stress,
    pin-tooth (Eq. 24)
max_groove_stress_mpa | MPa | - | + | max σH groove | groove_stress max | peak contact stress,
    pin-groove (Eq. 24)
min_contacts | 1 | - | + | min pins in contact | contacts min | fewest pins in contact
max_contacts | 1 | - | + | max pins in contact | contacts max | most pins in contact
gear_ratio_ripple_pct | % | - | + | ratio ripple | gear_ratio ripple_pct | gear-ratio ripple,
    peak-to-peak in % of n2 (Eq. 26)
max_overlap_arcsec | arcsec | - | + | max overlap | overlap max | largest interference with an
    unloaded-side pin
any_overlap | 1 | - | + | overlap | overlap positive | any interference with an unloaded-side
    pin (0/1)
play_arcsec_mean | arcsec | - | + | play | - | mean play between the flanks at zero load
play_arcsec_max | arcsec | - | + | max play | - | largest play between the flanks
max_mesh_force_n | N | - | + | max mesh force | - | largest mesh force on a disc (crank bearing
    load)
min_torque_share_nm | N·m | - | + | min disc torque | - | smallest torque carried by one disc
max_torque_share_nm | N·m | - | + | max disc torque | - | largest torque carried by one disc
rated_torque_nm | N·m | - | + | rated torque | - | rated torque T_r of the torsion curve
gear_ratio_step_deg | deg | - | + | ratio step | - | crank step of the gear ratio (Eq. 26)
# --- metrics of a torsion curve (cyclomesh stiffness)
play_arcmin_mean | arcmin | - | + | play | - | mean play at zero load
play_arcmin_max | arcmin | - | + | max play | - | largest play at zero load
lost_motion_arcmin_mean | arcmin | - | + | mesh lost motion | - | mean lost motion, TE(-3 %) -
    TE(+3 %) of rated
lost_motion_arcmin_max | arcmin | - | + | max mesh lost motion | - | largest lost motion
torsional_rigidity_nm_per_arcmin_mean | N·m/arcmin | - | + | mesh rigidity | - | mean torsional
    rigidity of the mesh, secant 50-100 % of rated
torsional_rigidity_nm_per_arcmin_min | N·m/arcmin | - | + | min mesh rigidity | - | smallest
    torsional rigidity of the mesh
drive_lost_motion_arcmin_mean | arcmin | - | + | drive lost motion | - | mean lost motion of the
    whole drive (mesh + series stiffness)
drive_lost_motion_arcmin_max | arcmin | - | + | max drive lost motion | - | largest lost motion
    of the whole drive
drive_torsional_rigidity_nm_per_arcmin_mean | N·m/arcmin | - | + | drive rigidity | - | mean
    torsional rigidity of the whole drive (mesh + series stiffness)
drive_torsional_rigidity_nm_per_arcmin_min | N·m/arcmin | - | + | min drive rigidity | - | smallest
    torsional rigidity of the whole drive
hysteresis_arcmin_mean | arcmin | - | + | hysteresis | - | mean width of the friction loop (with
    [friction])
hysteresis_arcmin_max | arcmin | - | + | max hysteresis | - | largest width of the friction loop
# --- friction (docs/efficiency.md): a run's variables, per pin, disc or angle
friction_force | N | pin | + | friction | - | tangential (friction) force at the pin contact
sliding_velocity_tooth | m/s | pin | + | sliding tooth | - | sliding velocity, pin-tooth
sliding_velocity_groove | m/s | pin | + | sliding groove | - | sliding velocity, pin-groove
power_loss_tooth | W | pin | + | loss pin-tooth | - | friction power loss, pin-tooth
power_loss_groove | W | pin | + | loss pin-groove | - | friction power loss, pin-groove
friction_coefficient | 1 | pin | + | μ | - | friction coefficient acting on the disc
film_parameter | 1 | pin | + | λ | - | film parameter h_c/sigma at the sliding interface (0: pin
    unloaded)
power_loss_bearing | W | disc | + | loss bearing | - | friction power loss of the crank bearing
input_torque | N·m | angle | - | T in | - | input torque, moment balance of the crank (forward)
backdrive_input_torque | N·m | angle | - | T in back | - | input torque, moment balance
    (back-driving)
output_power | W | angle | + | P out | - | output power |T|·ω/n2
power_loss | W | angle | + | P loss | - | friction power loss, all paths (forward)
backdrive_power_loss | W | angle | + | P loss back | - | friction power loss, all paths
    (back-driving)
input_power | W | angle | + | P in | - | input power P_out + P_loss (forward)
moment_input_power | W | angle | + | T in·ω | - | T_in·ω from the moment balance
instantaneous_efficiency | 1 | angle | + | η | - | forward efficiency
instantaneous_backdrive_efficiency | 1 | angle | + | η back | - | back-driving efficiency
# --- friction: metrics of a run (summary.json)
efficiency | 1 | - | + | efficiency | - | forward efficiency, P_out/P_in over the angles
backdrive_efficiency | 1 | - | + | back-drive eff. | - | back-driving efficiency over the angles
input_power_w | W | - | + | P in | - | mean input power (forward)
output_power_w | W | - | + | P out | - | mean output power (forward)
input_speed_rpm | rpm | - | + | n in | - | input (crank) speed
film_parameter_min | 1 | - | + | λ min | - | smallest film parameter of the loaded contacts
film_parameter_mean | 1 | - | + | λ mean | - | mean film parameter of the loaded contacts
power_loss_w | W | - | + | P loss | - | mean friction power loss per path (table path -> W;
    null: not modelled)
# --- friction: an efficiency map (cyclomesh efficiency, summary.json)
peak_efficiency | 1 | - | + | peak efficiency | - | largest forward efficiency of the map
peak_torque_nm | N·m | - | + | at torque | - | output torque of the peak efficiency
peak_speed_rpm | rpm | - | + | at input speed | - | input speed of the peak efficiency
rated_speed_rpm | rpm | - | + | rated speed | - | input speed of the rated point
rated_efficiency | 1 | - | + | rated efficiency | - | forward efficiency at the rated point
rated_backdrive_efficiency | 1 | - | + | rated back-driving | - | back-driving efficiency at the
    rated point
rated_input_power_w | W | - | + | rated input power | - | input power at the rated point
rated_power_loss_w | W | - | + | rated losses | - | power loss per path at the rated point
    (table path -> W; null: not modelled)
efficiency_min | 1 | - | + | min efficiency | - | smallest forward efficiency of the map
backdrive_efficiency_min | 1 | - | + | min back-drive eff. | - | smallest back-driving efficiency
    of the map
# --- metrics of the RV stage
stage_rated_torque_nm | N·m | - | + | rated torque | - | rated torque of the data sheet
stage_output_speed_rpm | rpm | - | + | speed | - | output speed of the rated life
stage_l10_h_min | h | - | + | bearing L10h | - | L10h of the weakest crank bearing (ISO 281)
stage_equivalent_load_n_max | N | - | + | P max | - | largest equivalent dynamic load of a crank
    bearing over the revolution
stage_dynamic_load_rating_kn | kN | - | + | C_r | - | basic dynamic load rating C_r of a crank
    bearing
stage_torsional_rigidity_nm_per_arcmin | N·m/arcmin | - | + | stage rigidity | - | torsional
    rigidity of the stage (mesh, bearings, crankshafts, carrier), b/a 50-100 % of rated
    (catalogue)
mesh_torsional_rigidity_nm_per_arcmin | N·m/arcmin | - | + | mesh rigidity | - | torsional
    rigidity of the mesh alone (rigid bearings)
stage_lost_motion_arcmin | arcmin | - | + | stage lost motion | - | lost motion of the stage:
    twist between the loop's mid-points at -3 % and +3 %
mesh_lost_motion_arcmin | arcmin | - | + | mesh LM | - | lost motion of the mesh alone
stage_backlash_arcmin | arcmin | - | + | stage backlash | - | backlash of the stage: width of
    the loop at zero torque (at ±0.1 %)
mesh_backlash_arcmin | arcmin | - | + | mesh backlash | - | backlash of the mesh alone
stage_duty_equivalent_torque_nm | N·m | - | + | T_eq | - | equivalent torque of the duty cycle
    (cubic mean, exponent 10/3)
stage_duty_equivalent_speed_rpm | rpm | - | + | n_eq | - | mean output speed of the duty cycle
stage_duty_l10_h_min | h | - | + | L10h cycle | - | L10h of the weakest crank bearing over the
    duty cycle (ISO 281, variable load)
stage_l10_h_at_equivalent_torque | h | - | + | L10h at T_eq | - | L10h of the weakest crank
    bearing at T_eq and n_eq
compliance_share | 1 | - | + | compliance share | - | share of the output twist at rated torque
    by part of the stage (virtual work): mesh, crank bearings, crankshafts, carrier, hole
    errors
stage_te_orders | arcsec | - | + | stage TE orders | - | three largest orders of the output TE
    at rated torque: [crank order, output order, amplitude]
torque_share_orders | N·m | - | + | disc torque orders | - | three largest orders of the disc
    torque share at rated torque: [crank order, output order, amplitude of the largest disc]
stage_max_contact_stress_mpa | MPa | - | + | max σH | - | peak pin-tooth contact stress at rated
    torque
stage_max_crank_bearing_load_n | N | - | + | max bearing load | - | largest crank bearing load
    at rated torque
stage_max_roller_load_n | N | - | + | max Q | - | largest needle roller load at rated torque
stage_max_support_bearing_load_n | N | - | + | max support load | - | largest radial load of a
    crankshaft's support bearing at rated torque
stage_support_bearing_stiffness_n_per_um | N/um | - | + | support k_r | - | radial stiffness of
    each support bearing (given, or the tangent of the preloaded tapered roller bearing)
stage_support_bearing_linear_limit_n | N | - | + | support limit | - | radial load up to which
    the support bearing's tangent stiffness holds (no roller unloaded)
stage_lost_motion_arcmin_mean | arcmin | - | + | stage LM | - | mean lost motion of the stage
stage_lost_motion_arcmin_max | arcmin | - | + | max stage lost motion | - | largest lost motion
    of the stage
stage_torsional_rigidity_nm_per_arcmin_mean | N·m/arcmin | - | + | stage rigidity | - | mean
    torsional rigidity of the stage
stage_torsional_rigidity_nm_per_arcmin_min | N·m/arcmin | - | + | min stage rigidity | - | smallest
    torsional rigidity of the stage
stage_hysteresis_arcmin_mean | arcmin | - | + | stage hysteresis | - | mean width of the stage's
    friction loop (with [friction])
stage_hysteresis_arcmin_max | arcmin | - | + | max stage hysteresis | - | largest width of the
    stage's friction loop (with [friction])
measured_torsional_rigidity_nm_per_arcmin | N·m/arcmin | - | + | measured rigidity | - | measured
    torsional rigidity (b/a, 50-100 % of rated)
measured_lost_motion_arcmin | arcmin | - | + | measured lost motion | - | measured lost motion
    (±3 %)
measured_backlash_arcmin | arcmin | - | + | measured backlash | - | measured backlash (width at
    0)
reconciling_compliance_arcmin_per_knm | arcmin/kN·m | - | + | reconciling compliance | - | series
    compliance that would take the model to the measured rigidity (not applied)
reconciling_stiffness_nm_per_arcmin | N·m/arcmin | - | + | reconciling stiffness | - | series
    stiffness that would take the model to the measured rigidity (not applied)
lost_motion_difference_arcmin | arcmin | - | + | LM difference | - | measured lost motion less
    the model's
# --- metrics of a design map (cyclomesh design)
feasible | 1 | - | + | feasible | - | feasible
reason | - | - | + | reason | - | why the candidate is infeasible (text)
play_arcmin | arcmin | - | + | max play | - | largest unloaded play
min_play_arcmin | arcmin | - | + | min play | - | smallest unloaded play
lost_motion_arcmin | arcmin | - | + | lost motion | - | lost motion TE(-3 % T) - TE(+3 % T)
loss_fraction | 1 | - | + | loss fraction | - | power loss over input power, 1 - efficiency
    (with friction)
# --- metrics of an FE check (cyclomesh fe)
fe_max_pin_load_n | N | - | + | FE max pin load | - | largest pin load, FE
fe_max_contact_stress_mpa | MPa | - | + | FE max σH | - | peak contact stress, pin-tooth, FE
fe_rotation_arcsec_mean | arcsec | - | + | FE rotation | - | mean loaded disc position, FE (TE
    convention, Eq. 25)
ltca_paper_max_pin_load_n | N | - | + | paper | - | largest pin load, LTCA (paper law)
ltca_paper_pin_load_rms_pct | % | - | + | paper RMS dev. | - | RMS of LTCA (paper law) minus FE
    pin loads, % of the FE peak
ltca_paper_rotation_arcsec_mean | arcsec | - | + | paper rotation | - | mean loaded disc
    position, LTCA (paper law)
ltca_half_plane_max_pin_load_n | N | - | + | half_plane | - | largest pin load, LTCA (half_plane
    law)
ltca_half_plane_pin_load_rms_pct | % | - | + | half_plane RMS dev. | - | RMS of LTCA (half_plane
    law) minus FE pin loads, % of the FE peak
ltca_half_plane_rotation_arcsec_mean | arcsec | - | + | half_plane rotation | - | mean loaded
    disc position, LTCA (half_plane law)
ltca_max_pin_load_n | N | - | + | LTCA | - | largest pin load, LTCA of the study ([analysis]:
    contact law, disc body)
ltca_pin_load_rms_pct | % | - | + | LTCA RMS dev. | - | RMS of LTCA of the study minus FE pin
    loads, % of the FE peak
ltca_rotation_arcsec_mean | arcsec | - | + | LTCA rotation | - | mean loaded disc position, LTCA
    of the study
"""


def _rows(table: str) -> tuple[Quantity, ...]:
    """The rows of ``table`` (the format of :data:`_TABLE`)."""
    lines: list[str] = []
    for line in table.strip().splitlines():
        if line.startswith("#"):
            continue
        if line.startswith(" "):
            lines[-1] += " " + line.strip()
        else:
            lines.append(line)
    rows = []
    for line in lines:
        name, unit, dims, parity, label_, reduce, long_name = (
            x.strip() for x in line.split("|", 6)
        )
        unit = "" if unit == "-" else unit
        scale = _SI_SCALE[unit] if _DIMS[dims] else 1.0
        rows.append(
            Quantity(
                name,
                unit,
                long_name,
                label_,
                _OTHER_SCALE.get(name, scale),
                _DIMS[dims],
                1 if parity == "+" else -1,
                None if reduce == "-" else tuple(reduce.split()),
            )
        )
    return tuple(rows)


_ROWS = _rows(_TABLE)

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
