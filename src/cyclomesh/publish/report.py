"""Self-contained HTML reports: one page, figures embedded, stamped with the version.

A report is a title, a few stamp lines (version, study file hash, ...) and a list of
:class:`Section`; each section has a heading and an HTML fragment and/or figures. Any
layer (a study run, a tolerance study) builds its sections and calls
:func:`write_report`. Figures are embedded as base64 PNG (``<img src="data:...">``) or
as inline SVG, so the page needs no other file.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

from cyclomesh.execution.runtime import version

__all__ = [
    "Section",
    "cyclomesh_version",
    "figure_html",
    "table_html",
    "render_report",
    "write_report",
    "table_cell",
    "metrics_table",
    "description_html",
    "warning_sections",
]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px;
       color: #222; line-height: 1.4; padding: 0 1em; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th:first-child, td:first-child, th.t { text-align: left; }
th { background: #f3f3f3; }
figure { margin: 1em 0; } figure img, figure svg { max-width: 100%; height: auto; }
figcaption { font-size: 0.9em; color: #444; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
.stamp { color: #555; font-size: 0.9em; }
tr.fail td, td.fail { background: #fbe3e3; } tr.warn td, td.warn { background: #fff4d6; }
td.note { text-align: left; font-size: 0.9em; color: #444; } td.t { text-align: left; }
"""


@dataclass
class Section:
    """One section of a report.

    Attributes
    ----------
    heading : str
        Plain text.
    html : str
        An HTML fragment, inserted as is (escape user text with :func:`html.escape`
        or build tables with :func:`table_html`).
    figures : sequence of (figure, caption)
        Embedded after ``html``; a figure is a matplotlib Figure, PNG bytes or SVG text.
    """

    heading: str
    html: str = ""
    figures: Sequence[tuple[Any, str]] = field(default_factory=list)


cyclomesh_version = version
"""The installed cyclomesh version, or ``"unknown"``
(:func:`cyclomesh.execution.runtime.version`)."""


def figure_html(
    fig: Any, caption: str = "", embed: Literal["png", "svg"] = "png", dpi: int = 110
) -> str:
    """A figure as a ``<figure>`` element, embedded as base64 PNG or inline SVG.

    ``fig`` is a matplotlib Figure (rendered as ``embed`` says), PNG bytes, or SVG text.
    """
    if isinstance(fig, bytes | str):
        image = fig
    else:
        buffer = io.BytesIO()
        fig.savefig(buffer, format=embed, dpi=dpi)
        image = buffer.getvalue() if embed == "png" else buffer.getvalue().decode("utf-8")
    if isinstance(image, str):
        content = image[image.index("<svg") :]
    else:
        data = base64.b64encode(image).decode("ascii")
        content = f'<img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
    caption_html = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return f"<figure>{content}{caption_html}</figure>"


def table_html(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """An HTML table; cells are escaped text (floats shown with 4 significant digits)."""

    def cell(value: Any) -> str:
        if isinstance(value, float):
            return html.escape(f"{value:.4g}")
        return html.escape("" if value is None else str(value))

    def td(value: Any) -> str:  # text left, numbers right
        text = cell(value)
        try:
            float(text.replace("–", "-").split(" / ")[0] or "0")
        except ValueError:
            return f'<td class="t">{text}</td>'
        return f"<td>{text}</td>"

    head = "".join(f"<th>{cell(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(td(v) for v in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def render_report(
    title: str,
    sections: Sequence[Section],
    stamp: Mapping[str, str] | None = None,
    embed: Literal["png", "svg"] = "png",
) -> str:
    """The HTML page of a report.

    Parameters
    ----------
    title : str
    sections : sequence of Section
    stamp : mapping, optional
        Lines shown under the title, e.g. ``{"SHA-256 of the study file": ...}``; the
        cyclomesh version and the creation time (UTC) are always added.
    embed : {"png", "svg"}
        How figures are embedded.
    """
    lines = {
        "cyclomesh version": cyclomesh_version(),
        "created (UTC)": datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S"),
        **(stamp or {}),
    }
    stamp_html = "<br>".join(
        f"{html.escape(k)}: <code>{html.escape(str(v))}</code>" for k, v in lines.items()
    )
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f'<meta name="generator" content="cyclomesh {html.escape(cyclomesh_version())}">',
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f'<p class="stamp">{stamp_html}</p>',
    ]
    for section in sections:
        parts.append(f"<section><h2>{html.escape(section.heading)}</h2>{section.html}")
        parts.extend(figure_html(fig, caption, embed) for fig, caption in section.figures)
        parts.append("</section>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_report(
    path: str | Path,
    title: str,
    sections: Sequence[Section],
    stamp: Mapping[str, str] | None = None,
    embed: Literal["png", "svg"] = "png",
) -> Path:
    """Write :func:`render_report` to ``path`` (UTF-8) and return the path."""
    path = Path(path)
    from cyclomesh.output.folder import write_text

    return write_text(path, render_report(title, sections, stamp, embed))


def table_cell(value: Any) -> Any:
    """A summary value as a table cell: booleans, per-torque lists and path tables as text."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):  # one value per torque of a torque list
        return " / ".join(f"{v:.4g}" if isinstance(v, float) else str(table_cell(v)) for v in value)
    if isinstance(value, dict):  # a table such as the loss per path (path -> W)
        return "; ".join(
            f"{k.replace('_', '-')}: " + ("not modelled" if v is None else str(table_cell(v)))
            if not isinstance(v, float)
            else f"{k.replace('_', '-')}: {v:.4g}"
            for k, v in value.items()
        )
    return value


_OTHER_LABELS = {
    "torque_nm": "torque [N·m]",
    "rated_torque_nm": "rated torque [N·m]",
    "discs": "discs",
    "gear_ratio_step_deg": "ratio taken over [deg]",
}


def metrics_table(records: dict[str, dict[str, Any]], metrics: dict[str, Any]) -> str:
    """HTML table of summary records: one row per metric (short label with its unit,
    long name on hover), one column per case, so that it fits a laptop screen."""
    names = list(records)
    keys = list(dict.fromkeys(k for record in records.values() for k in record))
    rows = []
    for key in keys:
        m = metrics.get(key)
        label = (
            _OTHER_LABELS.get(key, key)
            if m is None
            else m.label + ("" if m.unit == "1" else f" [{m.unit}]")
        )
        rows.append([label, *(table_cell(records[n].get(key)) for n in names)])
    table = table_html(["metric", *names], rows)
    for key in keys:  # the long name as a tooltip on its label
        m = metrics.get(key)
        if m is not None:
            label = html.escape(m.label + ("" if m.unit == "1" else f" [{m.unit}]"))
            table = table.replace(
                f'<td class="t">{label}</td>',
                f'<td class="t" title="{html.escape(m.long_name)} ({key})">{label}</td>',
                1,
            )
    return table


def description_html(study: Any) -> str:
    """The study's description as a report paragraph ('' without one)."""
    return f"<p>{html.escape(study.description)}</p>" if study.description else ""


def warning_sections(warnings: list[str]) -> list[Section]:
    """A "Warnings" report section listing ``warnings`` (none if there are none)."""
    if not warnings:
        return []
    items = "".join(f"<li>{html.escape(w)}</li>" for w in warnings)
    return [Section("Warnings", f"<ul>{items}</ul>")]
