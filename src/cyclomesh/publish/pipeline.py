"""The last stages every kind of study shares: figures and the report.

A kind of study computes its results, writes its result files (:mod:`cyclomesh.output.writers`),
describes its figures as :class:`~cyclomesh.figures.render.FigureJob` items and its
report as :class:`~cyclomesh.publish.report.Section` items; :func:`publish` then renders the
figures in the requested formats (a process pool when it pays), puts each figure into
the section its job names, lists the files and writes ``report.html``. The stages are
separate functions so that the CLI can show progress and the benchmark can time each
(``benchmarks/bench_pipeline.py``). See ``docs/pipeline.md``.
"""

from __future__ import annotations

import html
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from cyclomesh.figures.render import FigureJob, FigurePool, RenderedFigure
    from cyclomesh.publish.report import Section
    from cyclomesh.studyfile.schema import Study

FORMATS = ("png", "svg", "pdf")
"""Figure file formats (:data:`cyclomesh.figures.render.FORMATS` is this tuple)."""

__all__ = [
    "OutputOptions",
    "Published",
    "parse_figure_formats",
    "parse_figures",
    "publish",
    "attach_figures",
]


@dataclass(frozen=True)
class OutputOptions:
    """What to write besides the results that are always written.

    Attributes
    ----------
    figures : tuple of {"png", "svg", "pdf"}
        Formats of the figure files; empty: no figures (nor in the report).
    dpi : int
        Resolution of PNG figures and of the report's images [dots/inch].
    csv : bool
        Also write the full pin-level CSV (``results.csv``; off by default, the same
        numbers are in ``results.parquet`` and ``results.nc``).
    figure_workers : int or None
        Processes that draw the figures (None: decide by the number of figures).
    figure_set : {"overview", "all"}
        Which figures of a run study (:data:`cyclomesh.figures.sets.SETS`): the one
        overview figure (default) or every figure; other kinds draw all theirs.
    """

    figures: tuple[str, ...] = ("png",)
    dpi: int = 150
    csv: bool = False
    figure_workers: int | None = None
    figure_set: str = "overview"

    @classmethod
    def from_study(
        cls, study: Study, figures: str | None = None, csv: bool = False, **more: Any
    ) -> OutputOptions:
        """Options from the study's ``[figures]`` section, ``figures`` (the ``--figures``
        option, e.g. ``"png,svg"``, ``"all"`` or ``"none"``: :func:`parse_figures`)
        overriding its formats."""
        settings = study.figures
        figure_set = "overview"
        if figures is not None:
            formats, figure_set = parse_figures(figures, tuple(settings.formats))
        elif settings.enabled:
            formats = tuple(settings.formats)
        else:
            formats = ()
        return cls(figures=formats, dpi=settings.dpi, csv=csv, figure_set=figure_set, **more)


def parse_figure_formats(text: str) -> tuple[str, ...]:
    """``"png,svg"`` → ``("png", "svg")``; ``"none"`` → ``()``; a figure set
    (``"all"``) is no format (:func:`parse_figures`).

    Raises
    ------
    StudyError
        An unknown format.
    """
    return parse_figures(text)[0]


def parse_figures(text: str, default: tuple[str, ...] = ("png",)) -> tuple[tuple[str, ...], str]:
    """The ``--figures`` option: (formats, figure set). Formats and at most one set of
    :data:`cyclomesh.figures.sets.SETS`, comma-separated: ``"png,svg"`` →
    ``(("png", "svg"), "overview")``; ``"all"`` → ``(default, "all")`` (every figure,
    in the study's formats); ``"all,svg"``; ``"none"`` → ``((), "overview")``.

    Raises
    ------
    StudyError
        An unknown word, or two sets.
    """
    from cyclomesh.exceptions import StudyError
    from cyclomesh.figures.sets import FORMATS, SETS

    parts = [p.strip().lower() for p in text.split(",") if p.strip()]
    if parts == ["none"]:
        return (), "overview"
    bad = [p for p in parts if p not in FORMATS and p not in SETS]
    sets = list(dict.fromkeys(p for p in parts if p in SETS))
    if bad or not parts or len(sets) > 1:
        what = f"unknown format {bad[0]!r}" if bad else f"{text!r}"
        raise StudyError(
            f"--figures: {what}; expected a comma-separated list of {', '.join(FORMATS)} "
            f"and at most one of {', '.join(SETS)} (which figures), or none"
        )
    formats = tuple(dict.fromkeys(p for p in parts if p in FORMATS)) or tuple(default)
    return formats, (sets[0] if sets else "overview")


@dataclass
class Published:
    """Files written by :func:`publish` and the seconds each stage took."""

    files: list[Path]
    figures: list[RenderedFigure] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def attach_figures(sections: Sequence[Section], figures: Sequence[RenderedFigure]) -> list[Section]:
    """Put every figure into the section whose heading its job named (a new section at
    the end, in job order, if none has it)."""
    from cyclomesh.publish.report import Section

    out = [Section(s.heading, s.html, list(s.figures)) for s in sections]
    by_heading = {s.heading: s for s in out}
    for fig in figures:
        heading = fig.section or fig.name
        if heading not in by_heading:
            by_heading[heading] = Section(heading)
            out.append(by_heading[heading])
        by_heading[heading].figures.append((fig.png, fig.caption))
    return out


def publish(
    out: Path,
    title: str,
    sections: Sequence[Section],
    jobs: Sequence[FigureJob],
    files: Sequence[Path],
    options: OutputOptions,
    stamp: dict[str, str] | None = None,
    report_name: str = "report.html",
    closing: Sequence[Section] = (),
    pool: FigurePool | None = None,
) -> Published:
    """Render the figures into ``out/figures``, then write ``out/report_name``.

    Parameters
    ----------
    out : Path
        Output folder (exists: the result files are already in it).
    title : str
        Title of the report.
    sections : sequence of Section
        The study's sections, in order; figures are attached by heading.
    jobs : sequence of FigureJob
        Figures (ignored when ``options.figures`` is empty).
    files : sequence of Path
        Files already written (listed in the report).
    options : OutputOptions
    stamp : dict, optional
        Lines under the title (study file, hash, ...).
    report_name : str
        File name of the report.
    closing : sequence of Section
        Sections after the figures (before the file list).
    pool : FigurePool, optional
        Figure workers started before the study computed (see
        :class:`~cyclomesh.figures.render.FigurePool`).
    """
    from cyclomesh.publish.report import Section, write_report

    seconds = {}
    start = time.perf_counter()
    rendered: list[RenderedFigure] = []
    if options.figures and jobs:
        from cyclomesh.figures.render import render_figures

        rendered = render_figures(
            jobs, out / "figures", options.figures, options.dpi, options.figure_workers, pool
        )
    seconds["figures"] = time.perf_counter() - start
    start = time.perf_counter()
    written = list(files) + [p for fig in rendered for p in fig.files]
    report = out / report_name
    listing = [p.relative_to(out).as_posix() for p in written] + [report_name]
    items = "".join(f"<li><code>{html.escape(name)}</code></li>" for name in listing)
    page = attach_figures(sections, rendered) + list(closing)
    page.append(Section("Files", f"<ul>{items}</ul>"))
    written.append(write_report(report, title, page, stamp))
    seconds["report"] = time.perf_counter() - start
    return Published(written, rendered, seconds)


def study_stamp(study: Study) -> dict[str, str]:
    """Stamp lines of a report on ``study``: the study file and its SHA-256."""
    return {"study file": study.path.name, "SHA-256 of the study file": study.sha256}


def case_attrs(study: Study, case: Any) -> dict[str, str]:
    """Attributes every result Dataset of a case carries: the case and the study file it
    came from (name, description, inputs as JSON, title, file name, SHA-256)."""
    import json

    return {
        "case_name": case.name,
        "case_description": case.description,
        "case_inputs_json": json.dumps(case.model_dump(mode="json"), ensure_ascii=False),
        "study_title": study.title,
        "study_file": study.path.name,
        "study_sha256": study.sha256,
    }


def summary_document(
    study: Study, units: dict[str, str], cases: list[dict[str, Any]], **extra: Any
) -> dict[str, Any]:
    """The ``summary.json`` of a kind of study: the study's stamp (title, file, SHA-256,
    cyclomesh version), ``extra`` keys, the ``units`` of the metrics and one record per
    case."""
    from cyclomesh.publish.report import cyclomesh_version

    return {
        "title": study.title,
        "study_file": study.path.name,
        "study_sha256": study.sha256,
        "cyclomesh_version": cyclomesh_version(),
        **extra,
        "units": units,
        "cases": cases,
    }
