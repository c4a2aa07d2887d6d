"""The paper's Figs 3-8 from the simulated bench: every figure drawn, the right data in it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import Ran

from torquemap.cli.main import main
from torquemap.io import read_table
from torquemap.model import load_model


def test_simulate_figures_writes_figs_3_to_8(
    scara_bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "figs"
    argv = ["simulate", "figures", str(scara_bench), "--out", str(out)]
    assert main([*argv, "--model", str(scara_bench / "truth.toml")]) == 0
    names = sorted(p.name for p in out.glob("*.png"))
    assert names == [
        "fig3_joint_torques.png",
        "fig4_spectrum.png",
        "fig5_time_domain_a.png",
        "fig6_time_domain_b.png",
        "fig7_position_domain_a.png",
        "fig8_position_domain_b.png",
    ]
    assert all((out / n).stat().st_size > 20_000 for n in names)
    assert "fig8_position_domain_b.png" in capsys.readouterr().out


def test_fig3_is_eq3_of_the_spring_force(scara_bench: Path, scara_identified: Ran) -> None:
    from torquemap.sim.paper_figures import paper_figures

    # the model identify wrote from the sweeps (shared by the session; model=None would
    # identify the same sweeps again)
    model = load_model(scara_identified.folder / "bench" / "model.toml")
    result = paper_figures(scara_bench, model=model)
    fig = result.figures["fig3_joint_torques"]
    truth = read_table(scara_bench / "truth.csv")
    for ax, name in zip(fig.axes, ("a", "b"), strict=True):
        y = ax.lines[0].get_ydata()
        np.testing.assert_allclose(y, truth[f"tau_ext_{name}"])
    # Fig 4 marks the identified lines; the B axis is dominated by 2 CPR (the paper's Fig 4)
    spectrum_ax = result.figures["fig4_spectrum"].axes[0]
    marked = [ln.get_xdata()[0] for ln in spectrum_ax.lines if ln.get_marker() == "v"]
    assert 2.0 in marked


def test_not_a_bench_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "figures", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "robot.toml is missing" in err and err.count("\n") == 1
