"""FE contact solver on the Hertz classics (optional ``fe`` extra: scikit-fem, gmsh)."""

import numpy as np
import pytest

try:  # the fe extra; gmsh's wheel also needs X11/OpenGL client libraries (see .ci/run)
    import gmsh  # noqa: F401
    import skfem  # noqa: F401
except (ImportError, OSError) as exc:
    pytest.skip(f"fe extra not usable here: {exc}", allow_module_level=True)

from cyclomesh.fe.hertz_check import cylinder_contact, hertz_reference  # noqa: E402

SEAT = 1.5 * 3.5e-3


@pytest.mark.parametrize("seat", [None, SEAT], ids=["flat", "seat"])
def test_hertz_half_width_and_peak_pressure_within_2_percent(seat):
    r = cylinder_contact(seat_radius=seat, elements_per_half_width=10)
    assert abs(r.half_width_error) < 0.02
    assert abs(r.peak_pressure_error) < 0.02
    # the contact carries the applied load (vertical equilibrium of the pin)
    assert r.load_fe == pytest.approx(r.load, rel=1e-9)
    # at least 10 elements on the half-width: about 10 closed nodes on the half model
    assert r.closed_nodes >= 10


@pytest.mark.parametrize("seat", [None, SEAT], ids=["flat", "seat"])
def test_mesh_converged_from_5_to_20_elements_per_half_width(seat):
    coarse, fine = (cylinder_contact(seat_radius=seat, elements_per_half_width=n) for n in (5, 20))
    for r in (coarse, fine):
        assert abs(r.half_width_error) < 0.01
        assert abs(r.peak_pressure_error) < 0.01
    assert abs(fine.half_width_error) <= abs(coarse.half_width_error)


def test_seat_widens_the_contact_as_hertz_says():
    flat, seat = cylinder_contact(), cylinder_contact(seat_radius=SEAT)
    ratio = seat.half_width_fe / flat.half_width_fe
    expected = (
        hertz_reference(1.0, 3.5e-3, SEAT, 1.0, 0.3)[0]
        / hertz_reference(1.0, 3.5e-3, None, 1.0, 0.3)[0]
    )
    assert expected == pytest.approx(np.sqrt(3.0))
    assert ratio == pytest.approx(expected, rel=0.01)
