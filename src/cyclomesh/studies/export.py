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
from cyclomesh.studies.execute import CommandSteps, StudyKind

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


def _before(options: Any) -> dict[str, Any]:
    """``--format`` and ``--chord-tolerance-um`` as :func:`compute_export` takes them."""
    import math

    from cyclomesh.exceptions import StudyError
    from cyclomesh.output.export import parse_formats

    formats = parse_formats(options["format"])
    chord_um = options["chord_tolerance_um"]
    if not (math.isfinite(chord_um) and chord_um >= 0.001):
        raise StudyError(
            f"--chord-tolerance-um: expected a number of at least 0.001, got {chord_um}"
        )
    return {"formats": formats, "chord_tolerance": chord_um * 1e-6}


def _preflight(study: Any) -> None:
    """The profile of every case must be drawable (:func:`check_exportable`)."""
    from cyclomesh.core.outline import check_exportable
    from cyclomesh.exceptions import DesignError, StudyError

    for case, inputs in zip(study.cases, study.inputs, strict=True):
        try:
            check_exportable(inputs.design, inputs.modification)
        except DesignError as exc:
            raise StudyError(f"{case.label}: {exc}") from None


def _output(study: Any, options: Any) -> Any:
    from cyclomesh.publish.pipeline import OutputOptions

    return OutputOptions(figures=())


def _show(result: ExportResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_export

    # the kind records the files relative to its (staged) folder: here in ``out``
    written = {
        case: {key: Path(out) / rel for key, rel in files.items()}
        for case, files in result.written.items()
    }
    print_export(written, options["chord_tolerance_um"], result.same)


EXPORT = StudyKind(
    command="export",
    title="",
    compute=compute_export,
    write=lambda result, out, options: write_export(result, out),
    figures=lambda result, early: [],
    sections=lambda result: [],
    report_name=None,
    preflight=_preflight,
    steps=CommandSteps(before=_before, output=_output, show=_show),
)
