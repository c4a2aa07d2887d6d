"""The report in a real browser: headless Chromium loads it and decodes every figure.

Skipped only where no Chromium is installed (.ci/run installs it from the system packages).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from torquemap.plots.chart import Chart, series
from torquemap.report import Report, Section, embed, write_report

CHROMIUM = (
    shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
)


def _body(page: Path, profile: Path) -> str:
    """The ``<body>`` tag of the page after Chromium ran its scripts."""
    assert CHROMIUM is not None
    result = subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            f"--user-data-dir={profile}",
            "--virtual-time-budget=10000",
            "--dump-dom",
            page.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    body = re.search(r"<body[^>]*>", result.stdout)
    assert body is not None, result.stdout[:500]
    return body.group(0)


def loaded_figures(page: Path, profile: Path) -> tuple[int, int]:
    """(figures decoded, figures on the page) as the page's own script counted them."""
    body = _body(page, profile)
    loaded = re.search(r'data-figures-loaded="(\d+)"', body)
    total = re.search(r'data-figures-total="(\d+)"', body)
    assert loaded and total, body
    return int(loaded.group(1)), int(total.group(1))


def drawn_charts(page: Path, profile: Path) -> tuple[int, int]:
    """(charts drawn, charts on the page) as the chart script counted them."""
    body = _body(page, profile)
    drawn = re.search(r'data-charts-drawn="(\d+)"', body)
    total = re.search(r'data-charts-total="(\d+)"', body)
    assert drawn and total, body
    return int(drawn.group(1)), int(total.group(1))


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed")
def test_every_figure_loads_in_chromium(tmp_path: Path) -> None:
    figs = []
    for k in range(3):
        fig = Figure(figsize=(3, 2))
        fig.add_subplot().plot([0, 1], [k, 1 - k])
        figs.append(embed(fig, f"figure {k}"))
    page = tmp_path / "report.html"
    write_report(page, Report(title="browser", sections=(Section("s", figures=tuple(figs)),)))
    assert loaded_figures(page, tmp_path / "profile") == (3, 3)


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed")
def test_a_broken_figure_is_detected(tmp_path: Path) -> None:
    # the check can fail: a corrupt image does not decode
    page = tmp_path / "bad.html"
    fig = Figure(figsize=(2, 2))
    fig.add_subplot()
    good = embed(fig, "good")
    write_report(page, Report(title="b", sections=(Section("s", figures=(good, good)),)))
    text = page.read_text()
    head, _, tail = text.partition("base64,")
    page.write_text(head + "base64,AAAA" + tail[tail.index('"') :])
    assert loaded_figures(page, tmp_path / "profile") == (1, 2)


def _charts() -> tuple[Chart, ...]:
    t = np.linspace(0.0, 60.0, 120001)  # a long log: decimated, zoomable
    return (
        Chart(
            "force",
            "time [s]",
            "fx [N]",
            (series("fx", t, np.sin(t), sigma=0.1 + 0 * t),),
            spans=((1.0, 2.0),),
        ),
        Chart(
            "spectrum",
            "order [CPR]",
            "amplitude [N m]",
            (
                series("before", np.arange(1.0, 200.0), 1.0 / np.arange(1.0, 200.0)),
                series("lines", [2.0, 21.0], [0.5, 0.05], style="markers"),
            ),
            x_log=True,
            y_log=True,
        ),
        Chart(
            "points",
            "v [rad/s]",
            "torque [N m]",
            (series("p", [-1.0, 1, 0.5], [0, 1, 2], style="points"),),
        ),
    )


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed")
def test_every_chart_is_drawn_in_chromium(tmp_path: Path) -> None:
    page = tmp_path / "charts.html"
    write_report(page, Report(title="charts", sections=(Section("s", charts=_charts()),)))
    assert drawn_charts(page, tmp_path / "profile") == (3, 3)


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed")
def test_a_broken_chart_is_detected(tmp_path: Path) -> None:
    # the check can fail: a chart whose data does not parse is counted as not drawn
    page = tmp_path / "bad.html"
    write_report(page, Report(title="b", sections=(Section("s", charts=_charts()[:2]),)))
    text = page.read_text()
    page.write_text(text.replace('id="chart2">{', 'id="chart2">{{', 1))
    assert drawn_charts(page, tmp_path / "profile") == (1, 2)
