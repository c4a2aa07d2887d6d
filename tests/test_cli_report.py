"""CLI: ``torquemap report`` on the simulated bench; thin-data warnings; one-line errors."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.io import read_table, write_table


def test_report_of_model_sweep_and_circle(
    scara_bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report.html"
    model = scara_bench / "truth.toml"
    argv = ["report", str(model), str(scara_bench / "sweep.csv"), str(scara_bench / "circle.csv")]
    assert main([*argv, "-o", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    # model section, a spectrum per joint for the sweep, one estimate figure per log
    assert text.count("<section") == 3
    assert len(re.findall(r'src="data:image/png;base64,', text)) == 4
    assert "not treated as an identification sweep" in text  # the circle
    assert "wrote" in capsys.readouterr().out


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
