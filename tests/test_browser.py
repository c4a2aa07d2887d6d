"""The report in a real browser: headless Chromium loads it and decodes every figure.

Skipped only where no Chromium is installed (.ci/run installs it from the system packages).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from matplotlib.figure import Figure

from torquemap.report import Report, Section, embed, write_report

CHROMIUM = (
    shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
)


def loaded_figures(page: Path, profile: Path) -> tuple[int, int]:
    """(figures decoded, figures on the page) as the page's own script counted them."""
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
    loaded = re.search(r'data-figures-loaded="(\d+)"', body.group(0))
    total = re.search(r'data-figures-total="(\d+)"', body.group(0))
    assert loaded and total, body.group(0)
    return int(loaded.group(1)), int(total.group(1))


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
