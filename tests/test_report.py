"""The HTML report assembler: escaping, embedded figures, atomic writes."""

from __future__ import annotations

import base64
import re
from pathlib import Path

import pytest
from matplotlib.figure import Figure

from torquemap.report import Report, Section, embed, render_html, table, write_report


def _figure() -> Figure:
    fig = Figure(figsize=(3, 2))
    fig.add_subplot().plot([0, 1, 2], [1, 0, 1])
    return fig


def test_figures_are_embedded_png_and_text_is_escaped(tmp_path: Path) -> None:
    report = Report(
        title="R <&> 'x'",
        sections=(
            Section(
                "first <b>",
                paragraphs=("a < b & c",),
                tables=(table(("k", "v"), [("pi", 3.14159265), ("<i>", 2)]),),
                figures=(embed(_figure(), "cap <1>"), embed(_figure(), "cap 2")),
                warnings=("thin <data>",),
            ),
        ),
    )
    text = render_html(report)
    assert "<b>" not in text.replace("<body", "")  # escaped everywhere
    assert "a &lt; b &amp; c" in text and "thin &lt;data&gt;" in text
    assert "3.142" in text and "&lt;i&gt;" in text
    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    assert len(uris) == 2
    assert all(base64.b64decode(u)[:8] == b"\x89PNG\r\n\x1a\n" for u in uris)
    # self-contained: nothing fetched from anywhere (the SVG namespace URI is a name, not a fetch)
    assert not re.search(
        r"(src|href)\s*=\s*[\"']?\s*(https?:)?//|url\(\s*[\"']?(https?:)?//|@import", text
    )
    assert text.count("http") == text.count('"http://www.w3.org/2000/svg"')
    path = tmp_path / "r.html"
    write_report(path, report)
    assert path.read_text(encoding="utf-8") == text


def test_write_is_atomic(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "r.html"
    path.write_text("old")

    def boom(report: Report) -> str:
        raise RuntimeError("render failed")

    monkeypatch.setattr("torquemap.report.render_html", boom)
    with pytest.raises(RuntimeError):
        write_report(path, Report(title="t"))
    assert path.read_text() == "old"
    assert list(tmp_path.iterdir()) == [path]
