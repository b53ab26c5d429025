"""The explorer's JSON API (no browser): the same pipeline, messages and numbers as
``cyclomesh run``, and the disc drawn where the physics puts it."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("uvicorn", reason="the explore extra (uvicorn) is not installed")

from cyclomesh.explore.session import Session  # noqa: E402

from .conftest import LiveApp  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
STEP = {"analysis.crank_step_deg": 2.0}


@pytest.fixture(scope="module")
def table2():
    app = LiveApp(EXAMPLES / "table2.toml")
    yield app
    app.close()


@pytest.fixture(scope="module")
def requirements():
    app = LiveApp(EXAMPLES / "requirements.toml")
    yield app
    app.close()


def _analyse(client, **body):
    body.setdefault("overrides", {})
    body["overrides"] = {**STEP, **body["overrides"]}
    response = client.post("/api/analyse", json=body)
    assert response.status_code == 200, response.text
    return response.json()


def _cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "cyclomesh", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
    )


def test_health_and_page_are_served_offline(table2):
    assert table2.get("/api/health").json()["status"] == "ok"
    page = table2.get("/").text
    # every script and style sheet comes from this server (the page works offline)
    for src in ("/static/plotly.min.js", "/static/explore.js", "/static/explore.css"):
        assert src in page
        response = table2.get(src)
        assert response.status_code == 200 and len(response.content) > 1000
    assert "http://" not in page and "https://" not in page


def test_defaults_take_a_revolution_of_360_steps(table2):
    defaults = table2.get("/api/defaults").json()
    assert defaults["cases"] == ["Case 1", "Case 2", "Case 3", "Case 4"]
    # the study's 0.1° step (3600 angles) is replaced by 1° for the explorer
    assert defaults["study_step_deg"] == 0.1
    assert defaults["overrides"]["analysis.crank_step_deg"] == 1.0
    assert defaults["overrides"]["modification.pin_radius_um"] == 8.0
    data = _analyse(table2, overrides={"analysis.crank_step_deg": 1.0})
    assert len(data["plots"]["crank_angle_deg"]) == 360


def test_a_larger_pin_radius_modification_loads_fewer_pins_harder(table2):
    small = _analyse(table2, overrides={"modification.pin_radius_um": 4.0})
    large = _analyse(table2, overrides={"modification.pin_radius_um": 16.0})
    assert large["summary"]["max_contacts"] < small["summary"]["max_contacts"]
    assert large["summary"]["max_contact_stress_mpa"] > small["summary"]["max_contact_stress_mpa"]
    assert set(small["summary"]) >= {"max_contact_stress_mpa", "te_pp_arcsec", "min_contacts"}
    assert small["units"]["max_contact_stress_mpa"] == "MPa"


def test_reverse_torque_mirrors_the_peak_stress_of_a_symmetric_pair(table2):
    """No errors and no rotation modification: the pair is mirror-symmetric, so the
    reverse flanks carry the same peak stress as the forward ones."""
    fwd = _analyse(table2, overrides={"load.torque_nm": 250.0})["summary"]
    rev = _analyse(table2, overrides={"load.torque_nm": -250.0})["summary"]
    assert rev["max_contact_stress_mpa"] == pytest.approx(fwd["max_contact_stress_mpa"], rel=1e-9)


def test_a_bad_value_gets_the_one_line_message_of_cyclomesh_check(table2, tmp_path):
    response = table2.post(
        "/api/analyse", json={"overrides": {"modification.pin_radius_um": "abc"}}
    )
    assert response.status_code == 422
    body = response.json()
    assert body["key"] == "modification.pin_radius_um"
    # the same study value through the command line: the same line
    study = tmp_path / "bad.toml"
    text = (
        (EXAMPLES / "table2.toml")
        .read_text()
        .replace("pin_radius_um = 8.0", 'pin_radius_um = "abc"')
    )
    study.write_text(text)
    out = _cli("check", study)
    assert out.returncode == 2
    assert out.stderr.strip() == f"error: {body['error']}"
    assert "\n" not in body["error"]


@pytest.mark.parametrize(
    "body, key",
    [
        ({"overrides": {"modification.bogus_um": 1.0}}, "modification.bogus_um"),
        ({"overrides": {"load.torque_nm": 0.0}}, "load.torque_nm"),
        ({"overrides": {"design.discs": 2.5}}, "design.discs"),
        ({"pin_errors": {"mode": "scaled", "factor": "x"}}, "pin_errors.factor"),
        ({"pin_errors": {"mode": "drawn"}}, "pin_errors.mode"),  # no [tolerance] in table2
        ({"case": "Case 9"}, "case"),
    ],
)
def test_refused_values_name_their_key(table2, body, key):
    response = table2.post("/api/analyse", json=body)
    assert response.status_code == 422
    assert response.json()["key"] == key
    assert response.json()["error"].startswith(key) or key in response.json()["error"]


def test_invalid_json_is_refused_in_one_line(table2):
    response = table2.post("/api/analyse", content=b"{not json")
    assert response.status_code == 422 and "invalid JSON" in response.json()["error"]


def test_the_downloaded_study_reproduces_the_numbers_through_cyclomesh_run(requirements, tmp_path):
    body = {
        "overrides": {**STEP, "modification.pin_radius_um": 6.5, "load.torque_nm": -300.0},
        "pin_errors": {"mode": "scaled", "factor": 1.5},
    }
    shown = requirements.post("/api/analyse", json=body).json()
    text = requirements.post("/api/study", json=body).text
    assert text == shown["study_toml"]
    study = tmp_path / "explored.toml"
    study.write_text(text)
    out = _cli("run", study, "--out", tmp_path / "out", "--figures", "none", "-q")
    assert out.returncode == 0, out.stderr
    record = json.loads((tmp_path / "out" / "summary.json").read_text())["cases"][0]
    for name, value in shown["summary"].items():
        assert record[name] == value, name
    assert record["checks"]["counts"] == shown["checks"]["counts"]


def test_pin_errors_scaled_and_drawn(requirements, tmp_path):
    own = tomllib.loads(_analyse(requirements)["study_toml"])
    assert "random" in own["errors"]  # the study's own keys kept as written
    session = Session(EXAMPLES / "requirements.toml")
    try:
        errors = session.study.inputs[0].errors_um
    finally:
        session.close()
    for factor in (0.0, 2.0):
        data = _analyse(requirements, pin_errors={"mode": "scaled", "factor": factor})
        written = tomllib.loads(data["study_toml"])["errors"]
        for key in ("radial_um", "angular_urad", "pin_radius_um"):
            assert written[key] == list(factor * errors[key])
    zero = _analyse(requirements, pin_errors={"mode": "scaled", "factor": 0.0})
    assert not zero["warnings"] or all("error" not in w for w in zero["warnings"])
    # an error-free Table 1 pair with this modification: forward and reverse alike
    rev = _analyse(
        requirements,
        overrides={"load.torque_nm": -250.0},
        pin_errors={"mode": "scaled", "factor": 0.0},
    )
    assert rev["summary"]["max_contact_stress_mpa"] == pytest.approx(
        zero["summary"]["max_contact_stress_mpa"], rel=1e-9
    )


def test_pin_errors_drawn_from_tolerance_with_a_seed():
    from cyclomesh.tolerance.sampling import draw_ring_errors

    session = Session(EXAMPLES / "tolerance.toml")
    try:
        study = session.study
        spec = study.tolerance
        base = {"overrides": STEP}
        texts = {}
        for seed in (3, 4):
            body = {**base, "pin_errors": {"mode": "drawn", "factor": 1.0, "seed": seed}}
            texts[seed] = tomllib.loads(session.study_text(body))["errors"]
        design = study.inputs[0].design
        ring = draw_ring_errors(
            spec.model_copy(update={"seed": 3}), design.pins, design.pin_circle_radius, [0]
        )
        own = study.inputs[0].errors_um
        np.testing.assert_array_equal(texts[3]["radial_um"], own["radial_um"] + ring.radial_um[0])
        assert texts[3]["radial_um"] != texts[4]["radial_um"]
    finally:
        session.close()


def test_cases_are_explored_one_at_a_time(table2):
    one = _analyse(table2, case="Case 1")
    three = _analyse(table2, case="Case 3")  # no TPM: every loaded-side pin touches at once
    assert three["summary"]["max_contacts"] > one["summary"]["max_contacts"]
    table = tomllib.loads(three["study_toml"])
    assert "cases" not in table and table["modification"]["pin_radius_um"] == 0.0


def _distance_to_polyline(px, py, x, y):
    """Distance from points (px, py) to the closed polyline (x, y) [same units]."""
    ax, ay, bx, by = x[:-1], y[:-1], x[1:], y[1:]
    dx, dy = bx - ax, by - ay
    t = ((px[:, None] - ax) * dx + (py[:, None] - ay) * dy) / (dx * dx + dy * dy)
    t = np.clip(t, 0.0, 1.0)
    cx, cy = ax + t * dx, ay + t * dy
    return np.hypot(px[:, None] - cx, py[:, None] - cy).min(axis=1)


@pytest.mark.parametrize("angle", [0.0, 37.0, 200.0])
def test_the_disc_is_drawn_where_the_loaded_pins_touch_it(table2, angle):
    """To scale, a loaded pin touches the drawn disc (its centre one pin radius from the
    profile, up to the µm contact deformation and the drawing's chord tolerance) and no
    pin cuts into it: the disc's position and turn of Eq. 25 in the fixed frame."""
    data = _analyse(table2, crank_angle_deg=angle, overrides={"analysis.crank_step_deg": 1.0})
    s = data["scene"]
    x, y = np.asarray(s["disc_x_mm"]), np.asarray(s["disc_y_mm"])
    px, py = np.asarray(s["pin_x_mm"]), np.asarray(s["pin_y_mm"])
    gap = _distance_to_polyline(px, py, x, y) - np.asarray(s["pin_radius_mm"])  # mm
    loaded = np.asarray(data["at_angle"]["pin_load_n"]) > 0
    assert data["crank_angle_deg"] == angle
    assert loaded.sum() >= 3
    assert np.all(np.abs(gap[loaded]) < 0.010)  # 10 µm: deformation + chord tolerance
    assert np.all(gap > -0.010)
    # the deformation exaggerated: the loaded pins cut into the disc (µm × 500)
    big = _analyse(table2, crank_angle_deg=angle, exaggeration=500.0)["scene"]
    gap_big = _distance_to_polyline(
        np.asarray(big["pin_x_mm"]),
        np.asarray(big["pin_y_mm"]),
        np.asarray(big["disc_x_mm"]),
        np.asarray(big["disc_y_mm"]),
    ) - np.asarray(big["pin_radius_mm"])
    assert gap_big.min() < -0.05


def test_torsion_curve_on_request(table2):
    plain = _analyse(table2)
    assert "torsion" not in plain
    data = _analyse(table2, torsion=True)
    t = data["torsion"]
    assert np.all(np.diff(t["rotation_arcsec"]) > 0) or np.all(np.diff(t["rotation_arcsec"]) < 0)
    assert t["summary"]["torsional_rigidity_nm_per_arcmin_mean"] > 0
    assert t["units"]["lost_motion_arcmin_mean"] == "arcmin"
