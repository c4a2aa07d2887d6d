"""``torquemap demo``: the whole main job end to end, its files, its numbers, its report."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from test_browser import CHROMIUM, loaded_figures

from torquemap.cli.main import main


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("demo")
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["demo", "--out", str(out), "--quiet"]) == 0
    return out, buf.getvalue()


def _rms(text: str, label: str) -> float:
    m = re.search(rf"{re.escape(label)}\s+([0-9.]+)", text)
    assert m, label
    return float(m.group(1))


def test_demo_files(demo: tuple[Path, str]) -> None:
    out, _ = demo
    for name in (
        "report.html",
        "scara/model.toml",
        "scara/forces_model.csv",
        "scara/forces_paper.csv",
        "rig_vr/TABLES.npz",
        "rig_vr/verify.csv",
        "rig_bldc/TABLES.npz",
    ):
        assert (out / name).is_file(), name


def test_demo_summary_numbers(demo: tuple[Path, str]) -> None:
    _, text = demo
    # the order the paper's stages promise, and the model method below the paper's
    assert _rms(text, "paper (notches per pass)") < _rms(text, "low-pass only")
    assert _rms(text, "model (default)") < _rms(text, "paper (notches per pass)")
    # linearisation: verified APMD far below the uncompensated one, for both motors
    for motor in ("variable-reluctance", "brushless DC"):
        m = re.search(rf"{motor}\s+before\s+([0-9.]+) %\s+after\s+([0-9.]+) %", text)
        assert m, motor
        assert float(m.group(2)) < 0.1 * float(m.group(1))
    assert "76.1/58.3" in text  # the paper's numbers are printed beside ours


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed")
def test_demo_report_opens_in_chromium(demo: tuple[Path, str], tmp_path: Path) -> None:
    out, _ = demo
    loaded, total = loaded_figures(out / "report.html", tmp_path / "profile")
    assert total >= 12
    assert loaded == total
