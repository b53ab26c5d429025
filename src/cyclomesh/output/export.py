"""Profile export for manufacturing: DXF (polyline and spline), SVG and CSV writers.

The geometry is :func:`cyclomesh.core.outline.disc_outline` (the whole modified disc profile,
adaptively sampled to a chord tolerance) and :func:`cyclomesh.core.outline.pin_layout` (the
pins at crank angle 0); this module only writes it. Files are in millimetres, in the
disc frame: the disc centre at the origin, tooth space 1's bottom on the +x axis
(``docs/export.md``).

* ``profile.dxf`` (ezdxf, DXF R2013, units mm): layer ``PROFILE`` one closed
  LWPOLYLINE through the vertices; layer ``PROFILE_SPLINE`` one cubic SPLINE per tooth
  space through the same vertices (tip to tip, with the exact tangents at the tips);
  layer ``PINS`` the pin-centre circle and the pins at crank angle 0; when the study gives
  them (``[design.disc]``), layer ``CRANK_HOLES`` the crank holes and ``BORE`` the
  central bore; layer ``CENTRE`` centre marks at the disc centre and each hole's centre.
* ``profile.svg``: the same (profile path, pins, holes, bore), 1 user unit = 1 mm, y up.
* ``profile.csv``: one row per vertex: tooth space, φ1 [deg], x, y [mm] and the outward
  unit normal.
* ``export.json``: datum, chord tolerance, vertex count, tip and root radii.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from cyclomesh.core.outline import Outline, PinLayout, disc_outline, pin_layout
from cyclomesh.core.pair import CrankHoles, Modification, PairDesign
from cyclomesh.exceptions import StudyError
from cyclomesh.output.folder import atomic_write, write_text
from cyclomesh.units import MM_PER_M

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
    "profile_key",
    "export_summary",
    "DiscFeatures",
]

FORMATS = ("dxf", "svg", "csv")
DATUM = (
    "disc centre at the origin; tooth space 1 bottom on the +x axis, tooth space k at "
    "360*(k-1)/n2 deg counter-clockwise; pins at crank angle 0 (pin-centre circle centred "
    "at (-e, 0)); millimetres"
)
MM = MM_PER_M  # m -> mm (units.py)
CENTRE_MARK = 1.25
"""Half-length of a centre mark as a fraction of its circle's radius (a cross that
reaches past the circle, as drawings mark a hole's centre) [-]."""


class DiscFeatures(NamedTuple):
    """What the disc has besides its profile (``[design.disc]``), in the disc frame [m].

    ``holes``: the crank holes (hole k at polar angle 2πk/N), or None; ``bore_radius``:
    the central bore's radius, or None; ``root_radius``: a − e − ρp, which sizes the
    disc centre's mark when there is no bore.
    """

    holes: CrankHoles | None = None
    bore_radius: float | None = None
    root_radius: float = 0.0

    def marks(self) -> list[tuple[float, float, float]]:
        """Centre marks (x, y, half-length) [m]: the disc centre, then each hole's."""
        centre = self.bore_radius if self.bore_radius else 0.1 * self.root_radius
        out = [(0.0, 0.0, CENTRE_MARK * centre)]
        if self.holes is not None:
            out += [(x, y, CENTRE_MARK * self.holes.radius) for x, y in self.holes.centres]
        return out

    def circles(self) -> list[tuple[str, float, float, float]]:
        """(layer, x, y, radius) [m] of the bore and the crank holes."""
        out = [("BORE", 0.0, 0.0, self.bore_radius)] if self.bore_radius else []
        if self.holes is not None:
            out += [("CRANK_HOLES", x, y, self.holes.radius) for x, y in self.holes.centres]
        return out


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


def write_dxf(
    outline: Outline, pins: PinLayout, path: Path, features: DiscFeatures | None = None
) -> Path:
    """Write the profile (polyline and splines), the pins and the disc's ``features``
    (crank holes, bore, centre marks; :class:`DiscFeatures`) as a DXF file (mm).

    The file is a pure function of the geometry: ezdxf's fixed header dates (2000-01-01)
    and GUIDs are written instead of the clock and random GUIDs, so two exports of one
    study are byte-identical."""
    import ezdxf

    fixed = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True  # no clock, no random GUID
    try:
        return _write_dxf(ezdxf, outline, pins, path, features or DiscFeatures())
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = fixed


def _write_dxf(
    ezdxf: Any, outline: Outline, pins: PinLayout, path: Path, features: DiscFeatures
) -> Path:
    doc = ezdxf.new("R2013", units=ezdxf.units.MM)
    doc.header["$MEASUREMENT"] = 1  # metric
    layers = [("PROFILE", 7), ("PROFILE_SPLINE", 5), ("PINS", 1)]
    layers += [("CRANK_HOLES", 3)] if features.holes is not None else []
    layers += [("BORE", 4)] if features.bore_radius else []
    for name, color in (*layers, ("CENTRE", 8)):
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
    for layer, x, y, radius in features.circles():
        msp.add_circle((x * MM, y * MM), radius * MM, dxfattribs={"layer": layer})
    for x, y, half in features.marks():
        for dx, dy in ((half, 0.0), (0.0, half)):
            start, end = ((x - dx) * MM, (y - dy) * MM), ((x + dx) * MM, (y + dy) * MM)
            msp.add_line(start, end, dxfattribs={"layer": "CENTRE"})
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


def write_svg(
    outline: Outline,
    pins: PinLayout,
    path: Path,
    title: str = "",
    features: DiscFeatures | None = None,
) -> Path:
    """Write the profile, the pins and the disc's ``features`` as an SVG drawing (1 user
    unit = 1 mm, y up)."""
    features = features or DiscFeatures()
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
        *_svg_features(features, stroke),
        f'<g id="profile" stroke="#000000" stroke-width="1" {stroke}>',
        f'<path d="{path_d}"/>',
        "</g>",
        "</svg>",
    ]
    return write_text(path, "\n".join(lines) + "\n")


def _svg_features(features: DiscFeatures, stroke: str) -> list[str]:
    """SVG groups of the bore, the crank holes and the centre marks (y flipped)."""
    out = []
    for layer in ("BORE", "CRANK_HOLES"):
        circles = [c for c in features.circles() if c[0] == layer]
        if circles:
            out.append(f'<g id="{layer.lower()}" stroke="#1f6f3f" stroke-width="1" {stroke}>')
            out += [
                f'<circle cx="{x * MM:.6f}" cy="{-y * MM:.6f}" r="{r * MM:.6f}"/>'
                for _, x, y, r in circles
            ]
            out.append("</g>")
    out.append(f'<g id="centre" stroke="#7f7f7f" stroke-width="0.5" {stroke}>')
    for x, y, h in features.marks():
        cx, cy, h = x * MM, -y * MM, h * MM
        out.append(
            f'<path d="M{cx - h:.6f},{cy:.6f} L{cx + h:.6f},{cy:.6f} '
            f'M{cx:.6f},{cy - h:.6f} L{cx:.6f},{cy + h:.6f}"/>'
        )
    out.append("</g>")
    return out


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


def _metadata(
    design: PairDesign, modification: Modification, outline: Outline, features: DiscFeatures
) -> dict[str, Any]:
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
            **(
                {"CRANK_HOLES": "one CIRCLE per crank hole, hole k at 360*k/N deg"}
                if features.holes is not None
                else {}
            ),
            **({"BORE": "the central bore, one CIRCLE"} if features.bore_radius else {}),
            "CENTRE": "centre marks (two LINEs) at the disc centre and each crank hole",
        },
        **(
            {
                "crank_holes": features.holes.count,
                "crank_hole_circle_radius_mm": _mm(features.holes.circle_radius),
                "crank_hole_radius_mm": _mm(features.holes.radius),
            }
            if features.holes is not None
            else {}
        ),
        **({"bore_radius_mm": _mm(features.bore_radius)} if features.bore_radius else {}),
    }


def _mm(metres: float) -> float:
    """A size in millimetres as the study file gives it (the round-off of mm → m → mm
    dropped: 12 significant digits)."""
    return float(f"{metres * MM:.12g}")


def export_profile(
    design: PairDesign,
    modification: Modification | None,
    out: str | Path,
    formats: str | Sequence[str] = FORMATS,
    chord_tolerance: float = 1e-7,
    title: str = "",
    crank_holes: CrankHoles | None = None,
    bore_radius: float | None = None,
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
    title : str
        Title of the SVG drawing and of ``export.json``.
    crank_holes : CrankHoles, optional
        The disc's crank holes, drawn on layer ``CRANK_HOLES`` with their centre marks.
    bore_radius : float, optional
        Radius of the disc's central bore [m], drawn on layer ``BORE``.

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
    root = design.pin_circle_radius - design.eccentricity - design.pin_radius
    features = DiscFeatures(crank_holes, bore_radius, root)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    if "dxf" in formats:
        files["dxf"] = write_dxf(outline, pins, out / "profile.dxf", features)
    if "svg" in formats:
        files["svg"] = write_svg(outline, pins, out / "profile.svg", title, features)
    if "csv" in formats:
        files["csv"] = write_csv(outline, out / "profile.csv")
    files["json"] = write_json(
        out / "export.json",
        _metadata(design, modification, outline, features) | {"title": title},
    )
    return files


def profile_key(
    design: PairDesign,
    modification: Modification,
    crank_holes: CrankHoles | None = None,
    bore_radius: float | None = None,
) -> tuple:
    """What the exported drawing depends on: two cases with equal keys give the same
    files (the profile of Eqs. 1–3, the pins at crank angle 0, holes and bore), whatever
    their other keys (torque, errors, materials, width, analysis)."""
    profile = modification.profile
    table = None if profile is None else (profile.angle.tobytes(), profile.deviation.tobytes())
    holes = None if crank_holes is None else tuple(crank_holes.__dict__.values())
    return (
        design.pins,
        design.pin_circle_radius,
        design.pin_radius,
        design.eccentricity,
        modification.pin_circle_radius,
        modification.pin_radius,
        modification.rotation,
        table,
        holes,
        bore_radius,
    )


def export_study(
    study: Study,
    out: str | Path,
    formats: str | Sequence[str] = FORMATS,
    chord_tolerance: float = 1e-7,
) -> tuple[dict[str, dict[str, Path]], dict[str, str]]:
    """Export the disc profile of every case of a study into ``out/<case>/``, once per
    distinct drawing: cases that differ only in keys the drawing does not depend on
    (:func:`profile_key`) share the folder of the first of them.

    Returns
    -------
    written : dict
        Case name → format → path, for the cases whose folder was written.
    same : dict
        Case name → name of the earlier case whose folder holds its (identical) files.

    Raises
    ------
    StudyError
        A case whose profile cannot be exported (rotation modification), naming the case.
    """
    from cyclomesh.exceptions import DesignError
    from cyclomesh.studyfile.schema import folder_name

    formats = parse_formats(formats)
    groups: dict[tuple, list[tuple[Any, Any, float | None]]] = {}
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        bore_mm = case.design.disc.bore_radius_mm
        bore = None if bore_mm is None else bore_mm * 1e-3
        key = profile_key(inputs.design, inputs.modification, inputs.crank_holes, bore)
        groups.setdefault(key, []).append((case, inputs, bore))
    written: dict[str, dict[str, Path]] = {}
    same: dict[str, str] = {}
    for members in groups.values():
        case, inputs, bore = members[0]
        names = ", ".join(c.name for c, _, _ in members)
        try:
            written[case.name] = export_profile(
                inputs.design,
                inputs.modification,
                Path(out) / folder_name(case.name),
                formats,
                chord_tolerance,
                title=f"{study.title}: {names}",
                crank_holes=inputs.crank_holes,
                bore_radius=bore,
            )
        except DesignError as exc:
            raise StudyError(f"{case.label}: {exc}") from None
        same.update({other.name: case.name for other, _, _ in members[1:]})
    return written, same


def export_summary(study: Study, same: dict[str, str]) -> dict[str, Any]:
    """The export's ``summary.json`` entries: each case's folder, and the cases whose
    drawing is that of an earlier case (written once, in that case's folder)."""
    from cyclomesh.studyfile.schema import folder_name

    folders = {case.name: folder_name(same.get(case.name, case.name)) for case in study.cases}
    return {
        "title": study.title,
        "study_file": study.path.name,
        "case_folders": folders,
        "same_profile": {
            name: f"the drawing of {first!r}, written once in {folder_name(first)}/"
            for name, first in same.items()
        },
    }
