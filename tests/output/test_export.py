"""Profile export: the DXF/SVG/CSV re-read and held to the analytic profile (Eqs. 1–3)."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import ezdxf
import numpy as np
import pytest
from typer.testing import CliRunner

from cyclomesh import export_profile
from cyclomesh.cli import app
from cyclomesh.core.deviation import ProfileDeviation
from cyclomesh.core.outline import disc_outline, polar_radius, profile_frame
from cyclomesh.core.pair import TABLE1, Modification
from cyclomesh.core.profile import modified_profile
from cyclomesh.exceptions import DesignError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TPM = Modification(pin_circle_radius=-5e-6, pin_radius=8e-6)


def _per_tooth_deviation(teeth: int) -> ProfileDeviation:
    """A different smooth relief on both flanks of every tooth space (a measured disc)."""
    phi = np.linspace(-np.pi, np.pi, 73)
    rows = [
        (2.0 + 0.05 * j) * 1e-6 * (1.0 + np.cos(phi)) * (1.0 + 0.3 * np.sin(phi + j))
        for j in range(teeth)
    ]
    return ProfileDeviation(np.tile(phi, (teeth, 1)), np.array(rows))


def _read_dxf(path: Path) -> tuple[np.ndarray, list, list]:
    doc = ezdxf.readfile(path)
    msp = doc.modelspace()
    (poly,) = msp.query('LWPOLYLINE[layer=="PROFILE"]')
    assert poly.closed
    points = np.array([(x, y) for x, y, *_ in poly.get_points("xy")]) * 1e-3
    splines = list(msp.query('SPLINE[layer=="PROFILE_SPLINE"]'))
    circles = list(msp.query('CIRCLE[layer=="PINS"]'))
    assert doc.units == ezdxf.units.MM
    return points, splines, circles


def _chord_error(design, modification, points, phase, space, per_segment=24) -> float:
    """Largest distance of the exact profile from the polyline, each segment sampled."""
    n = len(points)
    nxt = (np.arange(n) + 1) % n
    u0, u1 = phase, phase[nxt].copy()
    same = space[nxt] == space
    u1[~same] = np.pi  # the segment into the next space ends on this space's tip
    s = np.linspace(0.0, 1.0, per_segment + 2)[1:-1]
    uu = u0[:, None] + (u1 - u0)[:, None] * s
    x, y, *_ = profile_frame(design, modification, uu, (space - 1)[:, None])
    a, b = points, points[nxt]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])[:, None]
    dist = np.abs(d[:, 0:1] * (y - a[:, 1:2]) - d[:, 1:2] * (x - a[:, 0:1])) / length
    return float(dist.max())


@pytest.mark.parametrize(
    "modification",
    [TPM, Modification(pin_radius=8e-6, profile=_per_tooth_deviation(TABLE1.teeth))],
    ids=["tpm", "per_tooth_deviation"],
)
def test_dxf_holds_the_analytic_profile_within_the_chord_tolerance(tmp_path, modification):
    tol = 0.1e-6
    files = export_profile(TABLE1, modification, tmp_path, "dxf,csv", chord_tolerance=tol)
    points, splines, circles = _read_dxf(files["dxf"])
    table = np.genfromtxt(files["csv"], delimiter=",", names=True)
    phase, space = np.radians(table["profile_angle_deg"]), table["tooth"].astype(int)
    assert len(points) == len(phase) > 1000
    assert sorted(set(space)) == list(range(1, TABLE1.teeth + 1))
    # every vertex lies on the exact profile (Eqs. 1–3 with the deviation of its space)
    x, y = modified_profile(TABLE1, modification, phase + 2 * np.pi * (space - 1))
    assert np.max(np.hypot(points[:, 0] - x, points[:, 1] - y)) < 1e-11
    # every point of the exact profile lies within the tolerance of its polyline segment
    error = _chord_error(TABLE1, modification, points, phase, space)
    assert tol / 4 < error <= tol  # adaptive: not grossly oversampled either
    # the splines (one per tooth space) stay within the tolerance of the exact curve
    assert len(splines) == TABLE1.teeth
    worst = 0.0
    for k, spline in enumerate(splines):
        sel = np.flatnonzero(space == k + 1)
        tool = spline.construction_tool()
        curve = np.array(list(tool.points(np.linspace(0, tool.max_t, 4001))))[:, :2]
        curve *= 1e-3
        # nearest exact point by Newton on the phase, started at the nearest vertex's
        near = sel[np.argmin(np.hypot(*(curve[:, None, :] - points[sel][None]).T), axis=0)]
        u = phase[near]
        for _ in range(6):
            px, py, nx, ny, _ = profile_frame(TABLE1, modification, u, k)
            qx, qy, *_ = profile_frame(TABLE1, modification, u + 1e-6, k)
            tx, ty = (qx - px) / 1e-6, (qy - py) / 1e-6
            u = u + ((curve[:, 0] - px) * tx + (curve[:, 1] - py) * ty) / (tx * tx + ty * ty)
            u = np.clip(u, -np.pi, np.pi)
        px, py, *_ = profile_frame(TABLE1, modification, u, k)
        worst = max(worst, float(np.max(np.hypot(curve[:, 0] - px, curve[:, 1] - py))))
    assert worst <= tol
    # the pins at crank angle 0: pin-centre circle about (-e, 0), pin 1 at (a - e, 0)
    assert len(circles) == TABLE1.pins + 1
    ring = max(circles, key=lambda c: c.dxf.radius)
    assert ring.dxf.radius == pytest.approx(82.0) and ring.dxf.center.x == pytest.approx(-1.5)
    pins = [c for c in circles if c is not ring]
    assert all(c.dxf.radius == pytest.approx(3.5) for c in pins)
    assert min(pins, key=lambda c: abs(c.dxf.center.y)).dxf.center.x == pytest.approx(80.5)


def test_radial_extremes_and_datum():
    o = disc_outline(TABLE1, TPM, 0.1e-6)
    a = TABLE1.pin_circle_radius + TPM.pin_circle_radius
    rho = TABLE1.pin_radius + TPM.pin_radius
    e = TABLE1.eccentricity
    assert o.radius.max() == pytest.approx(a + e - rho, abs=1e-12)
    assert o.radius.min() == pytest.approx(a - e - rho, abs=1e-12)
    # tooth space 1's bottom on +x; space k's bottom at 2π(k - 1)/n2
    bottoms = np.flatnonzero(o.phase == 0.0)
    assert len(bottoms) == TABLE1.teeth
    angles = np.arctan2(o.y[bottoms], o.x[bottoms]) % (2 * np.pi)
    expected = 2 * np.pi * (o.space[bottoms] - 1) / TABLE1.teeth
    assert np.allclose(angles, expected, atol=1e-14)
    # closed and counter-clockwise: the shoelace area is positive and below the tip circle's
    area = 0.5 * np.sum(o.x * np.roll(o.y, -1) - np.roll(o.x, -1) * o.y)
    assert math.pi * (a - e - rho) ** 2 < area < math.pi * (a + e - rho) ** 2


def test_normals_are_unit_outward_and_normal_to_the_curve():
    dev = _per_tooth_deviation(TABLE1.teeth)
    for modification in (TPM, Modification(profile=dev)):
        o = disc_outline(TABLE1, modification, 0.5e-6)
        assert np.allclose(np.hypot(o.nx, o.ny), 1.0, atol=1e-12)
        h = 1e-7
        x1, y1, *_ = profile_frame(TABLE1, modification, o.phase - h, o.space - 1)
        x2, y2, *_ = profile_frame(TABLE1, modification, o.phase + h, o.space - 1)
        tangent = np.stack([x2 - x1, y2 - y1]) / np.hypot(x2 - x1, y2 - y1)
        assert np.max(np.abs(tangent[0] * o.nx + tangent[1] * o.ny)) < 1e-6
        # outward: at tips and bottoms the normal points away from the centre
        ends = np.isin(o.phase, [0.0, np.pi, -np.pi])
        radial = (o.x * o.nx + o.y * o.ny) / o.radius
        assert np.all(radial[ends] > 0.999)


def test_tolerance_drives_the_sampling():
    coarse = disc_outline(TABLE1, TPM, 1e-6)
    fine = disc_outline(TABLE1, TPM, 0.01e-6)
    # chord error ∝ step², so 100 × tighter needs about 10 × the points
    assert 6 < len(fine.x) / len(coarse.x) < 12


def test_bad_tolerance_and_huge_rotation_are_refused():
    with pytest.raises(DesignError, match="chord tolerance"):
        disc_outline(TABLE1, TPM, 0.0)
    with pytest.raises(DesignError, match="rotation_urad"):
        disc_outline(TABLE1, Modification(rotation=0.01))
    with pytest.raises(DesignError, match="negative rotation"):
        disc_outline(TABLE1, Modification(rotation=-50e-6))


@pytest.mark.parametrize("delta", [500e-6, 30e-6])
def test_rotation_modification_is_the_intersection_of_the_turned_discs(tmp_path, delta):
    """δ turns the flanks φ1 < 0 by −δ and the others by +δ (modified_profile): the disc
    is the intersection of the disc turned both ways, r(θ) = min(R(θ + δ), R(θ − δ))."""
    base = Modification(pin_radius=5e-6)
    tol = 0.1e-6
    files = export_profile(
        TABLE1, replace(base, rotation=delta), tmp_path, "dxf,csv", chord_tolerance=tol
    )
    points, splines, _ = _read_dxf(files["dxf"])
    theta = np.arctan2(points[:, 1], points[:, 0])
    radius = np.hypot(points[:, 0], points[:, 1])

    def expected(t):
        return np.minimum(
            polar_radius(TABLE1, base, t + delta), polar_radius(TABLE1, base, t - delta)
        )

    assert np.max(np.abs(radius - expected(theta))) < 1e-11
    # away from the crossings every vertex is the turned point of its own flank
    table = np.genfromtxt(files["csv"], delimiter=",", names=True)
    phase, space = np.radians(table["profile_angle_deg"]), table["tooth"].astype(int)
    flank = np.abs(phase) > 0.05
    x, y = modified_profile(TABLE1, replace(base, rotation=delta), phase + 2 * np.pi * (space - 1))
    assert np.max(np.hypot(points[flank, 0] - x[flank], points[flank, 1] - y[flank])) < 1e-11
    # the exact curve within the tolerance of the polyline, every segment sampled
    n = len(points)
    nxt = (np.arange(n) + 1) % n
    step = np.angle(np.exp(1j * (theta[nxt] - theta)))
    assert np.all(step > 0)  # closed, counter-clockwise, one turn
    s = np.linspace(0.0, 1.0, 14)[1:-1]
    t = theta[:, None] + step[:, None] * s
    r = expected(t)
    px, py = r * np.cos(t), r * np.sin(t)
    a, d = points, points[nxt] - points
    dist = (
        np.abs(d[:, :1] * (py - a[:, 1:]) - d[:, 1:] * (px - a[:, :1]))
        / np.hypot(d[:, 0], d[:, 1])[:, None]
    )
    assert dist.max() <= tol
    # radial extremes: the root is kept, the tips are cut where the turned flanks meet
    a_, rho = TABLE1.pin_circle_radius, TABLE1.pin_radius + 5e-6
    assert radius.min() == pytest.approx(a_ - TABLE1.eccentricity - rho, abs=1e-12)
    tip = polar_radius(TABLE1, base, np.array([np.pi / TABLE1.teeth - abs(delta)]))[0]
    assert radius.max() == pytest.approx(tip, abs=1e-11)
    assert radius.max() < a_ + TABLE1.eccentricity - rho  # cut, by 0.6 nm at 30 µrad
    assert len(splines) == TABLE1.teeth


def test_svg_has_the_profile_and_the_pins(tmp_path):
    files = export_profile(TABLE1, TPM, tmp_path, ["svg"], chord_tolerance=1e-6)
    root = ET.parse(files["svg"]).getroot()
    ns = {"s": "http://www.w3.org/2000/svg"}
    path = root.find(".//s:g[@id='profile']/s:path", ns).get("d")
    vertices = path.count("L") + 1
    assert vertices == json.loads(files["json"].read_text())["vertices"]
    assert len(root.findall(".//s:g[@id='pins']/s:circle", ns)) == TABLE1.pins + 1
    assert "dxf" not in files and "csv" not in files


def test_cli_export(tmp_path):
    runner = CliRunner()
    out = tmp_path / "exp"
    result = runner.invoke(
        app,
        [
            "export",
            str(EXAMPLES / "table2.toml"),
            "--out",
            str(out),
            "--format",
            "dxf,csv",
            "--chord-tolerance-um",
            "0.5",
        ],
    )
    assert result.exit_code == 0, result.output
    meta = json.loads((out / "Case_1" / "export.json").read_text())
    assert meta["chord_tolerance_um"] == 0.5
    assert meta["tip_radius_mm"] == pytest.approx(82 + 1.5 - 3.5 - 0.008, abs=1e-9)
    assert (out / "Case_1" / "profile.dxf").exists() and not (
        out / "Case_1" / "profile.svg"
    ).exists()
    bad = runner.invoke(
        app, ["export", str(EXAMPLES / "table2.toml"), "-o", str(out), "--format", "step"]
    )
    assert bad.exit_code == 2 and "--format" in bad.output and "Traceback" not in bad.output


def test_export_is_byte_reproducible(tmp_path):
    """Two exports of one study, in two processes with different string hashing and at
    two moments: every file byte-identical (no clock, no random GUID, no set order)."""
    import os
    import subprocess
    import sys

    study = Path(__file__).resolve().parents[2] / "examples" / "table2.toml"
    folders = []
    for seed in ("1", "2"):
        out = tmp_path / f"out{seed}"
        subprocess.run(
            [sys.executable, "-m", "cyclomesh", "export", str(study), "--out", str(out), "-q"],
            check=True,
            env=dict(os.environ, PYTHONHASHSEED=seed),
        )
        folders.append(out)
    files = sorted(p.relative_to(folders[0]) for p in folders[0].rglob("*") if p.is_file())
    assert any(p.suffix == ".dxf" for p in files)
    for rel in files:
        if rel.name != ".cyclomesh.lock":
            assert (folders[0] / rel).read_bytes() == (folders[1] / rel).read_bytes(), rel
