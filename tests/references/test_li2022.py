"""What Li, Tang, He, Sun (Machines 2022, 10, 672) publish about the Table 1 example,
each assert with its source and tolerance.

The paper gives its results as figures, not tables of numbers; these are the values and
behaviours it states in the text (as restated in the project's model, ``model.md``,
sections 1 and 5). Each test names the statement it checks. Tolerances are those the
statements carry ("about" is taken as the last digit given).
"""

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification, analyse
from cyclomesh.core.profile import curvature_radius

TPM = Modification(pin_radius=8e-6)  # Table 1: Δρ = 8 µm
ANGLES = np.arange(0.0, 9.0, 0.25)  # one mesh cycle, 360°/40 = 9° of crank angle


def _run(modification: Modification):
    return analyse(
        TABLE1,
        modification,
        None,
        torque=250.0,
        crank_angles_deg=ANGLES,
        groove_deformation=True,
        contact_law="paper",
    )


def test_tooth_space_bottom_is_concave_with_radius_about_3_7_mm():
    # Li 2022, Eq. 4 and Section 2 (model.md §1): "the tooth-space bottom is concave,
    # radius about 3.7 mm" on the Table 1 design; tolerance: ±0.05 mm (last digit given).
    rho = curvature_radius(np.array([0.0]), TABLE1, Modification())[0]
    assert rho < 0
    assert abs(rho) == pytest.approx(3.7e-3, abs=0.05e-3)


def test_flanks_are_convex_with_radii_of_about_4_to_4_6_mm():
    # Li 2022, Section 2 (model.md §1): "the flanks convex, about 4-4.6 mm". The flank
    # radius grows without bound towards the inflection point, so the statement is read
    # as: the convex flank next to the bottom passes through 4-4.6 mm; tolerance 0.05 mm.
    theta = np.linspace(0.0, np.pi, 20001)[1:] / TABLE1.teeth
    rho = curvature_radius(theta, TABLE1, Modification())
    convex = rho[(rho > 0) & (rho < 1.0)]
    assert convex.size
    assert np.any(np.abs(convex - 4.0e-3) < 0.05e-3)
    assert np.any(np.abs(convex - 4.6e-3) < 0.05e-3)


def test_without_modification_about_half_of_the_pins_carry_load_and_all_touch_at_once():
    # Li 2022, Section 4.1 (model.md §5): "with no TPM and no errors every loaded-side
    # pin touches at once (zero backlash) and about half of the pins carry load";
    # tolerance: 40 pins / 2 ± 1; backlash of the loaded pins below 0.001 arcsec (the
    # last pin to enter the load zone has a few 1e-5 arcsec).
    ds = _run(Modification())
    contacts = ds["contacts"].values
    assert np.all(np.abs(contacts - TABLE1.pins / 2) <= 1)
    loaded = ds["pin_load"].values > 0
    assert np.all(ds["backlash"].values[loaded] == pytest.approx(0.0, abs=1e-3))


def test_modification_cuts_the_loaded_pins_sharply_and_raises_the_peak_load():
    # Li 2022, Section 4.1, Table 2 cases 2 and 4 (model.md §5): "TPM opens backlash and
    # cuts the number of loaded pins sharply, raising the peak load and stress".
    # "Sharply": at least a third fewer loaded pins (the paper's figures show 5-7 of ~20).
    plain, modified = _run(Modification()), _run(TPM)
    assert modified["contacts"].max() <= 2 / 3 * plain["contacts"].min()
    assert modified["pin_load"].max() > 1.5 * plain["pin_load"].max()
    assert modified["contact_stress"].max() > plain["contact_stress"].max()


def test_transmission_error_repeats_with_the_mesh_period():
    # Li 2022, Section 4.1 (model.md §5): "TE and the contact pattern repeat with the mesh
    # period 360°/n1 of crank angle"; tolerance: round-off of the solver (1e-9 arcsec).
    angles = np.array([1.5, 1.5 + 9.0, 1.5 + 18.0, 1.5 + 180.0])
    ds = analyse(
        TABLE1,
        TPM,
        None,
        torque=250.0,
        crank_angles_deg=angles,
        groove_deformation=True,
        contact_law="paper",
    )
    te = ds["transmission_error"].values
    assert np.allclose(te, te[0], atol=1e-9)
    assert np.all(ds["contacts"].values == ds["contacts"].values[0])
