"""Profile export for manufacturing: DXF (polyline and spline), SVG and CSV writers.

The geometry is :func:`cyclomesh.core.outline.disc_outline` (the whole modified disc profile,
adaptively sampled to a chord tolerance) and :func:`cyclomesh.core.outline.pin_layout` (the
pins at crank angle 0); this module only writes it. Files are in millimetres, in the
disc frame: the disc centre at the origin, tooth space 1's bottom on the +x axis
(``docs/export.md``).

* ``profile.dxf`` (ezdxf, DXF R2013, units mm): layer ``PROFILE`` one closed
  LWPOLYLINE through the vertices; layer ``PROFILE_SPLINE`` one cubic SPLINE per tooth
  space through the same vertices (tip to tip, with the exact tangents at the tips);
  layer ``PINS`` the pin-centre circle and the pins at crank angle 0.
* ``profile.svg``: the same (profile path, pins), 1 user unit = 1 mm, y upwards.
* ``profile.csv``: one row per vertex: tooth space, φ1 [deg], x, y [mm] and the outward
  unit normal.
* ``export.json``: datum, chord tolerance, vertex count, tip and root radii.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.core.outline import Outline, PinLayout, disc_outline, pin_layout
from cyclomesh.core.pair import Modification, PairDesign
from cyclomesh.exceptions import StudyError
from cyclomesh.output.folder import atomic_write, write_text

if TYPE_CHECKING:
    from cyclomesh.studyfile.schema import Study

__all__ = [
    "FORMATS",
    "DATUM",
    "parse_formats",
    "write_dxf",
    "write_svg",
    "write_csv",
    "export_profile",
    "export_study",
]

FORMATS = ("dxf", "svg", "csv")
DATUM = (
    "disc centre at the origin; tooth space 1 bottom on the +x axis, tooth space k at "
    "360*(k-1)/n2 deg counter-clockwise; pins at crank angle 0 (pin-centre circle centred "
    "at (-e, 0)); millimetres"
)
MM = 1e3  # m -> mm


def parse_formats(text: str | Sequence[str]) -> tuple[str, ...]:
    """``"dxf,svg"`` → ``("dxf", "svg")``; a one-line :class:`StudyError` for an unknown one."""
    items = text.split(",") if isinstance(text, str) else list(text)
    formats = tuple(dict.fromkeys(item.strip().lower() for item in items if item.strip()))
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise StudyError(
            f"--format: expected one or more of {', '.join(FORMATS)} separated by commas, "
            f"got {text if isinstance(text, str) else ','.join(text)!r}"
        )
    return formats


def _spaces(outline: Outline) -> Iterable[tuple[np.ndarray, np.ndarray | None]]:
    """Per tooth space the vertex indices from its first vertex to the next space's first
    (the point they share), with the exact tangents at both ends where the profile is
    smooth there (a tip), None at a corner (a rotation modification's crossings)."""
    n = len(outline.x)
    starts = np.flatnonzero(np.diff(outline.space, prepend=outline.space[-1]) != 0)
    if not len(starts):
        starts = np.array([0])
    for k, start in enumerate(starts):
        stop = starts[k + 1] if k + 1 < len(starts) else starts[0] + n
        if np.isclose(outline.phase[(stop - 1) % n], np.pi):  # a per-tooth step at this tip
            idx = np.arange(start, stop) % n
        else:  # up to the next space's first vertex, the point they share
            idx = np.arange(start, stop + 1) % n
        ends = idx[[0, -1]]
        smooth = np.all(np.isclose(np.abs(outline.phase[ends]), np.pi))
        tangents = np.stack([-outline.ny[ends], outline.nx[ends]], axis=-1) if smooth else None
        yield idx, tangents


def write_dxf(outline: Outline, pins: PinLayout, path: Path) -> Path:
    """Write the profile (polyline and splines) and the pins as a DXF file (mm).

    The file is a pure function of the geometry: ezdxf's fixed header dates (2000-01-01)
    and GUIDs are written instead of the clock and random GUIDs, so two exports of one
    study are byte-identical."""
    import ezdxf

    fixed = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True  # no clock, no random GUID
    try:
        return _write_dxf(ezdxf, outline, pins, path)
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = fixed


def _write_dxf(ezdxf: Any, outline: Outline, pins: PinLayout, path: Path) -> Path:
    doc = ezdxf.new("R2013", units=ezdxf.units.MM)
    doc.header["$MEASUREMENT"] = 1  # metric
    for name, color in (("PROFILE", 7), ("PROFILE_SPLINE", 5), ("PINS", 1)):
        doc.layers.add(name, color=color)
    msp = doc.modelspace()
    points = np.stack([outline.x, outline.y], axis=-1) * MM
    msp.add_lwpolyline(points.tolist(), format="xy", close=True, dxfattribs={"layer": "PROFILE"})
    for idx, tangents in _spaces(outline):
        msp.add_cad_spline_control_frame(
            points[idx].tolist(),
            tangents=None if tangents is None else tangents.tolist(),
            dxfattribs={"layer": "PROFILE_SPLINE"},
        )
    cx, cy = pins.circle_centre
    msp.add_circle((cx * MM, cy * MM), pins.circle_radius * MM, dxfattribs={"layer": "PINS"})
    for x, y in pins.centres:
        msp.add_circle((x * MM, y * MM), pins.pin_radius * MM, dxfattribs={"layer": "PINS"})
    stream = io.StringIO()
    doc.write(stream)
    with atomic_write(path) as tmp:
        tmp.write_bytes(doc.encode(_classes_by_name(stream.getvalue())))
    return path


def _classes_by_name(text: str) -> str:
    """The DXF text with its CLASSES section sorted by class name.

    ezdxf adds the classes a drawing needs from a set, in an order that follows Python's
    string hashing and so changes from one process to the next. Nothing in this file
    refers to a class by its position (no proxy objects), so sorting changes nothing a
    reader sees and makes the file a pure function of the geometry."""
    head = "  0\nSECTION\n  2\nCLASSES\n"
    start = text.find(head)
    if start < 0:
        return text
    body_start = start + len(head)
    end = text.find("  0\nENDSEC\n", body_start)
    lines = text[body_start:end].split("\n")[:-1]  # the body ends with a newline
    records: list[list[str]] = []
    for k in range(0, len(lines), 2):
        if lines[k].strip() == "0":
            records.append([])
        records[-1] += lines[k : k + 2]

    def name(record: list[str]) -> str:
        codes = [c.strip() for c in record[0::2]]
        return record[2 * codes.index("1") + 1] if "1" in codes else ""

    records.sort(key=name)
    body = "".join(line + "\n" for record in records for line in record)
    return text[:body_start] + body + text[end:]


def write_svg(outline: Outline, pins: PinLayout, path: Path, title: str = "") -> Path:
    """Write the profile and the pins as an SVG drawing (1 user unit = 1 mm, y up)."""
    x, y = outline.x * MM, -outline.y * MM  # SVG's y points down
    cx, cy = pins.circle_centre[0] * MM, -pins.circle_centre[1] * MM
    reach = pins.circle_radius * MM + abs(cx) + pins.pin_radius * MM + 2.0
    box = f"{-reach:.3f} {-reach:.3f} {2 * reach:.3f} {2 * reach:.3f}"
    path_d = "M" + " L".join(f"{a:.6f},{b:.6f}" for a, b in zip(x, y, strict=True)) + " Z"
    stroke = 'fill="none" vector-effect="non-scaling-stroke"'
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{2 * reach:.3f}mm" '
        f'height="{2 * reach:.3f}mm" viewBox="{box}">',
        f"<title>{_xml(title or 'cycloid disc profile')}</title>",
        f"<desc>{_xml(DATUM)}; chord tolerance {outline.chord_tolerance * 1e6:g} um</desc>",
        f'<g id="pins" stroke="#c0392b" stroke-width="1" {stroke}>',
        f'<circle cx="{cx:.6f}" cy="{cy:.6f}" r="{pins.circle_radius * MM:.6f}" '
        'stroke-dasharray="4 2"/>',
        *(
            f'<circle cx="{px * MM:.6f}" cy="{-py * MM:.6f}" r="{pins.pin_radius * MM:.6f}"/>'
            for px, py in pins.centres
        ),
        "</g>",
        f'<g id="profile" stroke="#000000" stroke-width="1" {stroke}>',
        f'<path d="{path_d}"/>',
        "</g>",
        "</svg>",
    ]
    return write_text(path, "\n".join(lines) + "\n")


def _xml(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def write_csv(outline: Outline, path: Path) -> Path:
    """Write one row per vertex: tooth space, φ1 [deg], x, y [mm], outward unit normal."""
    with atomic_write(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["tooth", "profile_angle_deg", "x_mm", "y_mm", "normal_x", "normal_y"])
        for row in zip(
            outline.space,
            np.degrees(outline.phase),
            outline.x * MM,
            outline.y * MM,
            outline.nx,
            outline.ny,
            strict=True,
        ):
            tooth, phase, x, y, nx, ny = row
            writer.writerow(
                [int(tooth), f"{phase:.9f}", f"{x:.9f}", f"{y:.9f}", f"{nx:.12f}", f"{ny:.12f}"]
            )
    return path


def _metadata(design: PairDesign, modification: Modification, outline: Outline) -> dict[str, Any]:
    a = design.pin_circle_radius + modification.pin_circle_radius
    rho = design.pin_radius + modification.pin_radius
    return {
        "datum": DATUM,
        "chord_tolerance_um": outline.chord_tolerance * 1e6,
        "vertices": int(len(outline.x)),
        "teeth": design.teeth,
        "tip_radius_mm": float(outline.radius.max() * MM),
        "root_radius_mm": float(outline.radius.min() * MM),
        "nominal_tip_radius_mm": (a + design.eccentricity - rho) * MM,
        "nominal_root_radius_mm": (a - design.eccentricity - rho) * MM,
        "per_tooth_deviation": bool(
            modification.profile is not None and modification.profile.per_tooth
        ),
        "layers": {
            "PROFILE": "closed LWPOLYLINE",
            "PROFILE_SPLINE": "one SPLINE per tooth space",
            "PINS": "pin-centre circle and pins at crank angle 0",
        },
    }


def export_profile(
    design: PairDesign,
    modification: Modification | None,
    out: str | Path,
    formats: str | Sequence[str] = FORMATS,
    chord_tolerance: float = 1e-7,
    title: str = "",
) -> dict[str, Path]:
    """Export the whole modified disc profile and the pins to ``out`` (a folder).

    Parameters
    ----------
    design, modification
        The pair and its modification (Δa, Δρ, tabulated deviation; Eqs. 1–3 of [1]).
    out : path
        Folder for ``profile.dxf``, ``profile.svg``, ``profile.csv`` and ``export.json``.
    formats : str or sequence
        Any of ``"dxf"``, ``"svg"``, ``"csv"`` (``"dxf,svg"`` also accepted).
    chord_tolerance : float
        Largest distance of the polyline from the exact profile [m] (default 0.1 µm).

    Returns
    -------
    dict
        Format → written path (``"json"`` for ``export.json``).
    """
    from cyclomesh.output.writers import write_json

    modification = modification or Modification()
    formats = parse_formats(formats)
    outline = disc_outline(design, modification, chord_tolerance)
    pins = pin_layout(design)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    if "dxf" in formats:
        files["dxf"] = write_dxf(outline, pins, out / "profile.dxf")
    if "svg" in formats:
        files["svg"] = write_svg(outline, pins, out / "profile.svg", title)
    if "csv" in formats:
        files["csv"] = write_csv(outline, out / "profile.csv")
    files["json"] = write_json(
        out / "export.json", _metadata(design, modification, outline) | {"title": title}
    )
    return files


def export_study(
    study: Study,
    out: str | Path,
    formats: str | Sequence[str] = FORMATS,
    chord_tolerance: float = 1e-7,
) -> dict[str, dict[str, Path]]:
    """Export the disc profile of every case of a study into ``out/<case>/``.

    Raises
    ------
    StudyError
        A case whose profile cannot be exported (rotation modification), naming the case.
    """
    from cyclomesh.exceptions import DesignError
    from cyclomesh.studyfile.schema import folder_name

    formats = parse_formats(formats)
    written = {}
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        try:
            written[case.name] = export_profile(
                inputs.design,
                inputs.modification,
                Path(out) / folder_name(case.name),
                formats,
                chord_tolerance,
                title=f"{study.title}: {case.name}",
            )
        except DesignError as exc:
            raise StudyError(f"{case.label}: {exc}") from None
    return written
