"""``torquemap report`` on the simulated bench: summary, charts, thin data, sigma bands, errors."""

from __future__ import annotations

import dataclasses
import html
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.io import read_log, read_table, write_table
from torquemap.model import JointModel, load_model
from torquemap.user_report import sweep_views


def _charts(text: str) -> list[dict[str, Any]]:
    found = re.findall(r'<script type="application/json" id="chart\d+">(.*?)</script>', text)
    return [json.loads(c.replace("<\\/", "</")) for c in found]


def test_report_of_model_sweep_and_circle(
    scara_bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report.html"
    model = scara_bench / "truth.toml"
    argv = ["report", str(model), str(scara_bench / "sweep.csv"), str(scara_bench / "circle.csv")]
    assert main([*argv, "-o", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    # summary first, then the model, then one section per log
    headings = re.findall(r"<h2>(.*?)</h2>", text)
    assert headings[:2] == ["Summary", "Model: " + html.escape(load_model(model).robot.name)]
    assert len(headings) == 4
    charts = _charts(text)
    titles = [c["title"] for c in charts]
    for joint in ("a", "b"):
        assert f"joint {joint}: cogging map (PDTV) over one motor revolution" in titles
        assert f"joint {joint}: friction against speed" in titles
        assert f"joint {joint}: residual spectrum before and after the model" in titles
        assert f"joint {joint}: torque ripple before and after compensation" in titles
    assert {"tau_ext_a [N m]", "tau_ext_b [N m]", "fx [N]", "fy [N]"} <= set(titles)
    assert "not treated as an identification sweep" in text  # the circle
    # resting and reversing are reported, not alarmed about
    assert not re.search(r'class="warning">[^<]*at or near zero velocity', text)
    assert "pdtv-map" in text  # the next step
    assert "wrote" in capsys.readouterr().out


def test_sweep_views_against_the_truth(scara_bench: Path) -> None:
    truth = load_model(scara_bench / "truth.toml")
    log = read_log(scara_bench / "sweep.csv", truth.robot)
    views = {v.name: v for v in sweep_views(truth, log)}
    b = views["b"]
    assert b.map_value is not None and b.map_model is not None
    # the log's binned ripple follows the true PDTV: it explains nearly all of it (noise and
    # the slow passes' speed ripple are the rest)
    assert b.explained > 0.95
    # a model without PDTV explains nothing: after == before exactly
    flat = dataclasses.replace(
        truth,
        joints={
            **truth.joints,
            "b": JointModel(truth.joints["b"].inertia, truth.joints["b"].friction),
        },
    )
    b0 = {v.name: v for v in sweep_views(flat, log)}["b"]
    assert b0.explained == pytest.approx(0.0, abs=1e-12)
    # the pass torques sit on the true friction law within a few per cent of Coulomb
    assert b.friction_rms < 0.05 * truth.joints["b"].friction.coulomb_positive


def test_sigma_band_drawn_when_the_estimator_gives_one(
    scara_bench: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import torquemap.estimate as est

    plain = est.forces_columns

    def with_sigma(e: Any) -> dict[str, Any]:
        cols = plain(e)
        cols["fx_sigma"] = np.full(e.t.size, 0.25)
        return cols

    monkeypatch.setattr(est, "forces_columns", with_sigma)
    out = tmp_path / "r.html"
    assert (
        main(
            [
                "report",
                str(scara_bench / "truth.toml"),
                str(scara_bench / "circle.csv"),
                "-o",
                str(out),
            ]
        )
        == 0
    )
    charts = {c["title"]: c for c in _charts(out.read_text(encoding="utf-8"))}
    fx = charts["fx [N]"]["series"][0]
    assert "hi" in fx and "sigma" in fx["name"]
    lo, hi = np.array(fx["lo"], float), np.array(fx["hi"], float)
    np.testing.assert_allclose(hi - lo, 0.5, atol=1e-4)  # 6 significant digits in the JSON
    assert "hi" not in charts["fy [N]"]["series"][0]


def test_thin_sweep_is_warned_about(scara_bench: Path, tmp_path: Path) -> None:
    # the first pass of joint a alone: one direction, and few samples per revolution kept
    sweep = read_table(scara_bench / "sweep.csv")
    keep = slice(0, 60000, 3)
    write_table(tmp_path / "thin.csv", {k: np.asarray(v)[keep] for k, v in sweep.items()})
    out = tmp_path / "thin.html"
    assert (
        main(
            ["report", str(scara_bench / "truth.toml"), str(tmp_path / "thin.csv"), "-o", str(out)]
        )
        == 0
    )
    text = out.read_text(encoding="utf-8")
    assert "constant-speed passes; friction needs at least 2 per direction" in text


def test_bad_input_one_line_no_output(
    scara_bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "r.html"
    bad = tmp_path / "bad.csv"
    bad.write_text("t,q_a\n0,1\n")
    assert main(["report", str(scara_bench / "truth.toml"), str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.csv" in err and "Traceback" not in err
    assert not out.exists()
