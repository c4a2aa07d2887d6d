"""A self-contained HTML report: sections of text, tables, warnings and embedded figures.

Figures are embedded as base64 PNG data URIs and the style sheet is inline, so the file opens
anywhere with no network. A small inline script counts the figures the browser decoded and writes
the count into ``<body data-figures-loaded=...>`` (the browser test reads it).
"""

from __future__ import annotations

import base64
import html
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from torquemap.io import atomic_output
from torquemap.plots.chart import CHART_SCRIPT, Chart, chart_json

if TYPE_CHECKING:  # matplotlib is imported only when a figure is embedded
    from matplotlib.figure import Figure


@dataclass(frozen=True, slots=True, eq=False)
class EmbeddedFigure:
    """A figure rendered to PNG.

    Attributes
    ----------
    caption
        Text under the figure.
    png
        The PNG bytes.
    """

    caption: str
    png: bytes


@dataclass(frozen=True, slots=True, eq=False)
class Table:
    """A table of text cells.

    Attributes
    ----------
    header
        Column titles.
    rows
        Rows of cells (already formatted as text).
    caption
        Optional caption.
    """

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    caption: str = ""


@dataclass(frozen=True, slots=True, eq=False)
class Section:
    """One section of a report.

    Attributes
    ----------
    heading
        Section title.
    paragraphs
        Plain-text paragraphs (escaped on output).
    tables, figures
        Tables and figures, in order.
    warnings
        One line each, shown highlighted.
    charts
        Interactive charts (:mod:`torquemap.plots.chart`), after the tables, before figures.
    items
        A bulleted list (for example the next steps), after the paragraphs.
    """

    heading: str
    paragraphs: tuple[str, ...] = ()
    tables: tuple[Table, ...] = ()
    figures: tuple[EmbeddedFigure, ...] = ()
    warnings: tuple[str, ...] = ()
    charts: tuple[Chart, ...] = ()
    items: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class Report:
    """A whole report.

    Attributes
    ----------
    title
        Page title.
    sections
        The sections, in order.
    subtitle
        A line under the title.
    """

    title: str
    sections: tuple[Section, ...] = field(default_factory=tuple)
    subtitle: str = ""


def embed(fig: Figure, caption: str, *, dpi: int = 90) -> EmbeddedFigure:
    """Render a matplotlib figure to PNG (Agg, no pyplot) for the report.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> fig = Figure(figsize=(2, 1))
    >>> _ = fig.add_subplot().plot([0, 1], [1, 0])
    >>> embed(fig, "a line").png[:4]
    b'\\x89PNG'
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return EmbeddedFigure(caption=caption, png=buf.getvalue())


def table(header: Sequence[str], rows: Sequence[Sequence[object]], caption: str = "") -> Table:
    """A :class:`Table` from any cells (formatted with ``str``; floats with 4 significant digits)."""

    def cell(v: object) -> str:
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)

    return Table(
        header=tuple(str(h) for h in header),
        rows=tuple(tuple(cell(v) for v in row) for row in rows),
        caption=caption,
    )


_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 1100px; color: #222; line-height: 1.45; padding: 0 1em; }
h1 { margin-bottom: 0.1em; } .subtitle { color: #666; margin-top: 0; }
h2 { border-bottom: 1px solid #ddd; padding-bottom: 0.2em; margin-top: 2em; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td:first-child, th:first-child { text-align: left; }
caption { caption-side: bottom; color: #666; font-size: 0.9em; padding-top: 0.3em; }
figure { margin: 1.2em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { color: #555; font-size: 0.9em; }
.warning { background: #fff4e5; border-left: 4px solid #f0a020; padding: 0.3em 0.8em;
           margin: 0.3em 0; }
nav ul { columns: 2; } footer { color: #888; font-size: 0.85em; margin-top: 3em; }
div.chart { width: 100%; min-height: 320px; border: 1px solid #eee; cursor: grab;
            user-select: none; }
.hint { color: #777; font-size: 0.85em; }
"""

_SCRIPT = """
window.addEventListener("load", function () {
  var imgs = document.querySelectorAll("img.figure");
  var ok = 0;
  imgs.forEach(function (im) { if (im.complete && im.naturalWidth > 0) { ok += 1; } });
  document.body.setAttribute("data-figures-loaded", String(ok));
  document.body.setAttribute("data-figures-total", String(imgs.length));
});
"""


def _anchor(k: int) -> str:
    return f"s{k + 1}"


def render_html(report: Report) -> str:
    """The report as one HTML document (every text escaped, figures inline)."""
    e = html.escape
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{e(report.title)}</title>",
        f"<style>{_STYLE}</style>",
        f"<script>{_SCRIPT}</script>",
        f"<script>{CHART_SCRIPT}</script>",
        "</head><body>",
        f"<h1>{e(report.title)}</h1>",
    ]
    if report.subtitle:
        out.append(f'<p class="subtitle">{e(report.subtitle)}</p>')
    if len(report.sections) > 1:
        out.append("<nav><ul>")
        for k, s in enumerate(report.sections):
            out.append(f'<li><a href="#{_anchor(k)}">{e(s.heading)}</a></li>')
        out.append("</ul></nav>")
    n_fig = 0
    n_chart = 0
    if any(s.charts for s in report.sections):
        out.append(
            '<p class="hint">Charts: mouse wheel zooms the horizontal axis, drag pans, '
            "double click resets.</p>"
        )
    for k, s in enumerate(report.sections):
        out.append(f'<section id="{_anchor(k)}"><h2>{e(s.heading)}</h2>')
        for w in s.warnings:
            out.append(f'<p class="warning">&#9888; {e(w)}</p>')
        for p in s.paragraphs:
            out.append(f"<p>{e(p)}</p>")
        if s.items:
            out.append("<ul>" + "".join(f"<li>{e(i)}</li>" for i in s.items) + "</ul>")
        for t in s.tables:
            out.append("<table>")
            if t.caption:
                out.append(f"<caption>{e(t.caption)}</caption>")
            out.append("<tr>" + "".join(f"<th>{e(h)}</th>" for h in t.header) + "</tr>")
            for row in t.rows:
                out.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>")
            out.append("</table>")
        for c in s.charts:
            n_fig += 1
            n_chart += 1
            out.append(
                f'<figure><div class="chart" data-src="chart{n_chart}"></div>'
                f'<script type="application/json" id="chart{n_chart}">{chart_json(c)}</script>'
                f"<noscript>This chart needs JavaScript.</noscript>"
                f"<figcaption>Figure {n_fig}: {e(c.caption or c.title)}</figcaption></figure>"
            )
        for f in s.figures:
            n_fig += 1
            data = base64.b64encode(f.png).decode("ascii")
            out.append(
                f'<figure><img class="figure" alt="{e(f.caption)}" '
                f'src="data:image/png;base64,{data}"><figcaption>Figure {n_fig}: '
                f"{e(f.caption)}</figcaption></figure>"
            )
        out.append("</section>")
    out.append("<footer>Written by torquemap. Self-contained: no network needed.</footer>")
    out.append("</body></html>")
    return "\n".join(out)


def write_report(path: str | os.PathLike[str], report: Report) -> None:
    """Write the report atomically (a temporary file renamed onto ``path``)."""
    text = render_html(report)
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
