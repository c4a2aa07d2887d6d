"""``torquemap demo``: the whole main job end to end, its files, its numbers, its report."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import DemoRun
from test_browser import CHROMIUM, loaded_figures

# one worker runs the demo for both files (conftest.py)
pytestmark = pytest.mark.xdist_group("demo")


@pytest.fixture(scope="module")
def demo(demo_run: DemoRun) -> tuple[Path, str]:
    return demo_run.folder / "demo-out", demo_run.out


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
        "arm/model.toml",
        "arm/forces.csv",
        "arm/truth.csv",
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
    # the MuJoCo Panda: the identified arm near the true one, far better than its URDF
    identified = _rms(text, "identified, acceleration")
    assert identified < 1.5 * _rms(text, "oracle (true arm), acceleration")
    assert identified < _rms(text, "URDF as given, acceleration") / 20


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed")
def test_demo_report_opens_in_chromium(demo: tuple[Path, str], tmp_path: Path) -> None:
    out, _ = demo
    loaded, total = loaded_figures(out / "report.html", tmp_path / "profile")
    assert total >= 12
    assert loaded == total


def test_demo_reports_each_step_once_when_piped(demo_run: DemoRun) -> None:
    # stderr is not a terminal here: plain lines, one per step (the fixture reports every step,
    # however short; a step with steps inside ends on a line of its own), none per item of a
    # step, and nothing but progress
    lines = demo_run.err.splitlines()
    step = re.compile(r"torquemap: (.+?)( \.\.\.( done \(\d+\.\d s\))?|: done \(\d+\.\d s\))")
    assert lines and all(step.fullmatch(ln) for ln in lines), lines
    labels = [m.group(1) for m in map(step.fullmatch, lines) if m]
    assert "identify friction, inertia and PDTV" in labels
    assert "write the report" in labels
    assert labels.count("write the report") == 1
    assert len(lines) < 30  # the rig collections advance hundreds of times: not a line each
