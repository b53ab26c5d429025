"""The one-line error of a pin ring that jams the disc names the deepest overlap: its
pin, its crank angle and its depth, the same on both kernels and with a tabulated profile."""

import re

import numpy as np
import pytest

from cyclomesh import TABLE1, DesignError, Modification, PinErrors
from cyclomesh.core.contact import unloaded_contact
from cyclomesh.core.deviation import ProfileDeviation
from cyclomesh.core.profile import generating_radii

PHI = np.deg2rad(np.arange(0.0, 360.0, 5.0))
PLAIN = Modification(-2e-6, 6e-6)  # the clearance of the constant table below
TABLE = Modification(
    -2e-6, 0.0, profile=ProfileDeviation(np.deg2rad(np.linspace(-180, 0, 19)), np.full(19, 6e-6))
)
KERNELS = ["numpy", pytest.param("numba", marks=pytest.mark.filterwarnings("ignore"))]


def refusal(mod: Modification, oversize: dict[int, float]) -> tuple[int, float, float]:
    """(pin, depth [µm], crank angle [deg]) the refusal names; pins numbered from 1."""
    radius = np.zeros(TABLE1.pins)
    for pin, extra in oversize.items():
        radius[pin - 1] = extra
    with pytest.raises(DesignError, match="overlaps the disc") as refused:
        unloaded_contact(TABLE1, mod, PinErrors(pin_radius=radius), PHI)
    got = re.search(
        r"pin (\d+) overlaps .* by ([\d.e+-]+) µm at crank angle ([\d.e+-]+)°", str(refused.value)
    )
    assert got, str(refused.value)
    return int(got[1]), float(got[2]), float(got[3])


def deepest(mod: Modification, oversize: dict[int, float]) -> tuple[int, float]:
    """The deepest overlap by hand: a − e + (r_p − ρ) − |w| over the pins and angles of
    the undeviated profile (the bottom of the tooth space at distance a − e + s)."""
    a, rho = generating_radii(TABLE1, mod)
    psi = np.arange(TABLE1.pins) * TABLE1.pitch
    wx = TABLE1.pin_circle_radius * np.cos(psi) - TABLE1.eccentricity * np.cos(PHI[:, None])
    wy = TABLE1.pin_circle_radius * np.sin(psi) - TABLE1.eccentricity * np.sin(PHI[:, None])
    extra = np.array([oversize.get(i + 1, 0.0) for i in range(TABLE1.pins)])
    overlap = a - TABLE1.eccentricity + TABLE1.pin_radius + extra - rho - np.hypot(wx, wy)
    angle, pin = np.unravel_index(np.argmax(overlap), overlap.shape)
    return int(pin) + 1, float(overlap[angle, pin]) * 1e6


@pytest.mark.parametrize("kernel", KERNELS)
def test_the_deepest_of_several_jammed_pins_is_named_with_its_own_depth(kernel, monkeypatch):
    if kernel == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", kernel)
    shallow, deep = {7: 10e-6}, {31: 16e-6}
    both = refusal(PLAIN, shallow | deep)
    # pin 7 comes first in every order of the arrays, but pin 31 overlaps deeper
    assert both == refusal(PLAIN, deep)
    pin, depth = deepest(PLAIN, shallow | deep)
    assert both[0] == pin == 31
    assert both[1] == pytest.approx(depth, rel=2e-3)  # printed to 3 significant digits
    alone = refusal(PLAIN, shallow)
    assert alone[0] == 7 and alone[1] < both[1]


def test_a_tabulated_profile_names_the_same_overlap_as_its_equidistant_twin():
    """A constant deviation table is the equidistant modification (test_modification):
    its refusal names the same pin, depth and crank angle, |Q| at the tooth-space bottom
    against |w|."""
    oversize = {7: 10e-6, 31: 16e-6}
    assert refusal(TABLE, oversize) == refusal(PLAIN, oversize)
