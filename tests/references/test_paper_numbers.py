"""The numbers Li, Tang, He, Sun (Machines 2022, 10, 672) state in their text, asserted.

Source of every number: ``/work/shared/spec/paper-numbers.md`` (section and figure of the
paper in each test). Design: Table 1 (``TABLE1``), E = 206 GPa, ν = 0.3, T = 250 N·m, the
paper's contact law (Eq. 20, ``contact_law="paper"``) unless a test says otherwise. The
paper does not state its crank step; here one mesh cycle (0–9°) at 0.5° (under Eq. 20 the
TE peak-to-peak and the ratio ripple depend on the step; README, "The contact law").

Tolerances: a value the paper reads off a figure ("about 868 MPa") is taken within 2 %
(a figure's reading); a mean TE stated to 4 digits within 3 % (how far an independent
implementation of the same equations lands when the paper leaves its discretisation
unstated); a TE peak-to-peak within 25 % (it depends on the step). Where the model does
not reproduce a number at that tolerance the assert stays as the paper states it, marked
``xfail(strict=True)`` with the value the model gives: the gap is recorded, and a change
that closes it makes the test fail until the mark is removed.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification, PinErrors
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.units import RAD_PER_ARCSEC

TPM = Modification(pin_radius=8e-6)  # Table 1: Δρ = 8 µm
CYCLE = np.deg2rad(np.arange(0.0, 9.0, 0.5))  # one mesh cycle, 360°/40 = 9°
FIGURE = 0.02  # a value read off a figure ("about"): ±2 %
TE_MEAN = 0.03  # a mean TE stated to 4 digits: ±3 %
TE_PP = 0.25  # a TE peak-to-peak (step-dependent under Eq. 20): ±25 %

# Table 2 (§4.1): case → (modification, pin-groove deformation δp)
TABLE2 = {1: (TPM, False), 2: (TPM, True), 3: (None, False), 4: (None, True)}


@cache
def table2(case: int, law: str = "paper"):
    modification, groove = TABLE2[case]
    return solve_ltca(TABLE1, modification, None, 250.0, CYCLE, groove, law)


def te_arcsec(result) -> np.ndarray:
    return result.transmission_error / RAD_PER_ARCSEC


def peak_stress_mpa(result) -> float:
    return float(result.contact_stress.max() * 1e-6)


# --- §4.1, Fig. 9: peak pin-tooth contact stress -------------------------------------


@pytest.mark.xfail(strict=True, reason="the model gives 818 MPa (−5.8 %), paper law, 0.5°")
def test_peak_contact_stress_without_tpm_is_about_868_mpa():
    # Li 2022 §4.1, Fig. 9: case 3 (no TPM, no δp) "about 868 MPa"; tolerance ±2 % (figure)
    assert peak_stress_mpa(table2(3)) == pytest.approx(868.0, rel=FIGURE)


def test_peak_contact_stress_with_tpm_is_about_1017_mpa():
    # Li 2022 §4.1, Fig. 9 and §5 item 2: case 1 (TPM, no δp) "about 1017 MPa";
    # tolerance ±2 % (figure)
    assert peak_stress_mpa(table2(1)) == pytest.approx(1017.0, rel=FIGURE)


@pytest.mark.xfail(strict=True, reason="the model gives +214 MPa (1032 − 818), paper law, 0.5°")
def test_tpm_raises_the_peak_stress_by_149_mpa():
    # Li 2022 §5 item 2: "increases to 149 MPa" = case 1 − case 3; tolerance: the two
    # ±2 % readings, ±37 MPa
    rise = peak_stress_mpa(table2(1)) - peak_stress_mpa(table2(3))
    assert rise == pytest.approx(149.0, abs=FIGURE * (868.0 + 1017.0))


@pytest.mark.xfail(strict=True, reason="δp lowers the peak here: case 2 1022 < case 1 1032 MPa")
def test_groove_deformation_raises_the_peak_stress_a_little():
    # Li 2022 §4.1, Fig. 9: "cases 2 and 4 a little higher than cases 1 and 3" (qualitative)
    assert peak_stress_mpa(table2(2)) > peak_stress_mpa(table2(1))
    assert peak_stress_mpa(table2(4)) > peak_stress_mpa(table2(3))


# --- §4.1, Fig. 10 and §4.2, Fig. 14: loaded transmission error ----------------------


@pytest.mark.xfail(strict=True, reason="the model gives −4.07″ (−14 %), paper law, 0.5°")
def test_te_mean_without_tpm_current_model_is_minus_4_745_arcsec():
    # Li 2022 §4.1, Fig. 10: case 3 mean −4.745″; tolerance ±3 %
    assert te_arcsec(table2(3)).mean() == pytest.approx(-4.745, rel=TE_MEAN)


@pytest.mark.xfail(strict=True, reason="the model gives −5.08″ (−16 %), paper law, 0.5°")
def test_te_mean_without_tpm_improved_model_is_minus_6_023_arcsec():
    # Li 2022 §4.1, Fig. 10 and §4.2 case 1, Fig. 14: case 4 mean −6.023″; tolerance ±3 %
    assert te_arcsec(table2(4)).mean() == pytest.approx(-6.023, rel=TE_MEAN)


def test_te_mean_with_tpm_is_minus_37_89_arcsec():
    # Li 2022 §4.2 case 2, Fig. 14 (= Table 2 case 2): mean −37.89″; tolerance ±3 %
    assert te_arcsec(table2(2)).mean() == pytest.approx(-37.89, rel=TE_MEAN)


def test_te_peak_to_peak_with_tpm_is_0_21_arcsec():
    # Li 2022 §4.2 case 2, Fig. 14: peak-to-peak 0.21″; tolerance ±25 % (step-dependent)
    assert np.ptp(te_arcsec(table2(2))) == pytest.approx(0.21, rel=TE_PP)


@pytest.mark.xfail(strict=True, reason="the model gives 0.063″ and 0.074″ (×2.9, ×4.1) at 0.5°")
def test_te_peak_to_peak_without_tpm_is_0_022_and_0_018_arcsec():
    # Li 2022 §4.1, Fig. 10: case 3 0.022″, case 4 0.018″; tolerance ±25 % (step-dependent)
    assert np.ptp(te_arcsec(table2(3))) == pytest.approx(0.022, rel=TE_PP)
    assert np.ptp(te_arcsec(table2(4))) == pytest.approx(0.018, rel=TE_PP)


def test_te_means_under_the_default_law_land_within_3_percent_of_the_paper():
    # The same statements (§4.1 Fig. 10, §4.2 Fig. 14) under the project's default
    # half-plane law (docs/contact-law.md): −4.745″, −6.023″, −37.89″; tolerance ±3 %
    for case, stated in ((3, -4.745), (4, -6.023), (2, -37.89)):
        mean = te_arcsec(table2(case, "half_plane")).mean()
        assert mean == pytest.approx(stated, rel=TE_MEAN), case


def test_tpm_and_groove_deformation_grow_the_te():
    # Li 2022 §4.1, Fig. 10: with TPM the mean and peak-to-peak grow; with δp the absolute
    # mean grows (qualitative); §5 item 2: "about 30″" more with TPM (−6.0″ → −37.9″),
    # tolerance ±3″ (the rounding of "about 30")
    te = {case: te_arcsec(table2(case)) for case in TABLE2}
    assert abs(te[1].mean()) > abs(te[3].mean()) and np.ptp(te[1]) > np.ptp(te[3])
    assert abs(te[2].mean()) > abs(te[1].mean()) and abs(te[4].mean()) > abs(te[3].mean())
    assert abs(te[2].mean() - te[4].mean()) == pytest.approx(30.0, abs=3.0)


# --- §4.2, Fig. 16 and §4.1, Fig. 8: pins in contact ---------------------------------


def test_without_tpm_19_to_20_pins_are_in_contact():
    # Li 2022 §4.2 case 1, Fig. 16 and §4.1, Fig. 8 ("almost half of the pins (20)"):
    # 19 and 20 alternate over the mesh cycle; exact (a count)
    assert set(table2(4).contacts.tolist()) == {19, 20}
    assert set(table2(3).contacts.tolist()) == {19, 20}


@pytest.mark.xfail(strict=True, reason="the paper law gives 8–9 at 0.5° (the default law 9–10)")
def test_with_tpm_9_to_10_pins_are_in_contact():
    # Li 2022 §4.2 case 2, Fig. 16 and §5 item 2 ("decreases from 20 to 9"): 9 and 10
    # alternate; exact (a count)
    assert set(table2(2).contacts.tolist()) == {9, 10}


def test_with_tpm_9_to_10_pins_are_in_contact_under_the_default_law():
    # The same statement (§4.2, Fig. 16) under the default half-plane law; exact
    assert set(table2(2, "half_plane").contacts.tolist()) == {9, 10}


# --- §4.2 case 3: TPM and random pin position errors (one unpublished draw) -----------


@cache
def error_rings():
    """Eight draws within the paper's bounds (±0.05 mrad angular, ±4 µm radial), a
    revolution at 0.5°: the paper's one draw is not tabulated, so its numbers are
    checked against the spread of these draws."""
    rng = np.random.default_rng(2022)
    errors = PinErrors(
        radial=rng.uniform(-4e-6, 4e-6, (8, TABLE1.pins)),
        angular=rng.uniform(-5e-5, 5e-5, (8, TABLE1.pins)),
    )
    phi = np.deg2rad(np.arange(0.0, 360.0, 0.5))
    return solve_ltca(TABLE1, TPM, errors, 250.0, phi, True, "paper")


def within_draws(stated: float, values: np.ndarray) -> bool:
    return float(values.min()) <= stated <= float(values.max())


def test_error_case_bands_hold_the_papers_draw():
    # Li 2022 §4.2 case 3, Figs. 13, 14, 16 and §5 item 3: TE peak-to-peak 5.83″ (or the
    # conclusions' 5.38″), pin-tooth 1887 MPa, pin-groove 44 MPa, fewest pins in contact
    # 4; tolerance: the paper's value lies within the range of our eight draws
    r = error_rings()
    te = te_arcsec(r)
    assert within_draws(5.83, np.ptp(te, axis=-1)) and within_draws(5.38, np.ptp(te, axis=-1))
    assert within_draws(1887.0, r.contact_stress.max(axis=(-2, -1)) * 1e-6)
    assert within_draws(44.0, r.groove_stress.max(axis=(-2, -1)) * 1e-6)
    assert within_draws(4, r.contacts.min(axis=-1))
    # and the errors make the contact irregular: fewer pins than without errors (9)
    assert np.all(r.contacts.min(axis=-1) < 9)


@pytest.mark.xfail(strict=True, reason="our draws give −32.0″ to −34.8″ and 1873–2818 N")
def test_error_case_te_mean_and_peak_load_lie_within_the_draws():
    # Li 2022 §4.2 case 3, Figs. 12 and 14: TE mean −38.26″, peak pin load 1722 N;
    # tolerance: within the range of our eight draws
    r = error_rings()
    assert within_draws(-38.26, te_arcsec(r).mean(axis=-1))
    assert within_draws(1722.0, r.pin_load.max(axis=(-2, -1)))
