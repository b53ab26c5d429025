"""The profile export as a kind of study (``cyclomesh export``; ``docs/export.md``).

No computation: the kind writes, through :func:`cyclomesh.output.export.export_study`,
the whole modified disc profile of every case (DXF, SVG, CSV, ``export.json``) into
``<out>/<case>/``, and runs like every other kind through
:func:`cyclomesh.studies.execute.execute` (the output folder locked, files written
atomically, ``summary.json`` last); it has no figures and no report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cyclomesh.output.export import FORMATS, export_study, export_summary
from cyclomesh.studies.execute import StudyKind

__all__ = ["ExportResult", "EXPORT", "compute_export"]


@dataclass
class ExportResult:
    """What to export (``study``, ``formats``, ``chord_tolerance`` [m]) and, once
    written, the files per case and format (``written``, relative to the output folder:
    the files are written into a staging folder and moved into it at the end)."""

    study: Any
    formats: tuple[str, ...]
    chord_tolerance: float
    written: dict[str, dict[str, Path]] = field(default_factory=dict)
    same: dict[str, str] = field(default_factory=dict)
    """Case → the earlier case whose folder holds its (identical) drawing."""


def compute_export(
    study: Any,
    *,
    backend: Any = None,
    progress: Any = None,
    formats: Any = FORMATS,
    chord_tolerance: float = 1e-7,
) -> ExportResult:
    """The export of ``study`` (nothing is computed or written here)."""
    return ExportResult(study, tuple(formats), chord_tolerance)


def write_export(result: ExportResult, out: Path) -> list[Path]:
    """Write the profile files of every case, once per distinct drawing, and the
    ``summary.json`` entries saying which cases share a folder; the paths written."""
    from cyclomesh.output.writers import write_json

    staged, same = export_study(result.study, out, result.formats, result.chord_tolerance)
    result.same.update(same)
    write_json(out / "summary.json", export_summary(result.study, same))  # written last
    result.written.update(
        {
            case: {k: path.relative_to(out) for k, path in files.items()}
            for case, files in staged.items()
        }
    )
    return [path for files in staged.values() for path in files.values()]


EXPORT = StudyKind(
    command="export",
    title="",
    compute=compute_export,
    write=lambda result, out, options: write_export(result, out),
    figures=lambda result, early: [],
    sections=lambda result: [],
    report_name=None,
)
