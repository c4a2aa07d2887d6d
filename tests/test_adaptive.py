"""Adaptive collection (torquemap.linearize.adaptive): level and position choice, budget, resume."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from torquemap.errors import InputError
from torquemap.linearize.adaptive import (
    choose_levels,
    collect_adaptive,
    grid_readings,
    position_scores,
)
from torquemap.linearize.collect import CollectionSettings
from torquemap.sim.rig import SimRig, sim_rig

SETTINGS = CollectionSettings(readings=4, position_step=16, level_step=32, progress=False)


def test_choose_levels_keeps_the_kink_and_drops_the_straight_parts() -> None:
    # a dead zone to 40 then a straight line: linear interpolation is exact everywhere except
    # across the kink, so exactly 0, 40 and the end survive
    lv = np.arange(0, 256, 8)
    curve = np.maximum(lv - 40.0, 0.0)
    assert choose_levels(curve[None, :], lv, tolerance=0.01).tolist() == [0, 40, 248]


def test_position_scores_peak_at_the_kink() -> None:
    # torque |p - 64| sampled every 16 positions on a cycle of 256: the second difference is
    # nonzero only at 64 (and at the far side, 192, where the cyclic triangle turns)
    p = np.arange(0, 256, 16)
    torque = 10.0 + np.minimum(np.abs(p - 64), 256 - np.abs(p - 64))
    score = position_scores(p, torque[:, None].astype(float), 256)
    top = set(np.argsort(-score)[:4].tolist())
    assert top == {3, 4, 11, 12}  # the gaps either side of 64 and of 192


def _rig(seed: int = 0) -> SimRig:
    rig = sim_rig("bldc", rng=seed)
    return SimRig(rig.motor, rig.amplifier, dataclasses.replace(rig.settings, noise=0.0), rng=seed)


def test_budget_is_respected_and_resume_loses_nothing(tmp_path: Path) -> None:
    rig = _rig()
    spec = rig.motor_spec()
    whole = collect_adaptive(rig, spec, tmp_path / "whole.csv", SETTINGS, fraction=0.9)
    assert whole.readings <= whole.budget == int(grid_readings(spec, SETTINGS) * 0.9)
    assert whole.positions > 13  # the coarse pass's 13, then refined

    class Interrupted(Exception):
        pass

    class Flaky(SimRig):
        reads = 0

        def read_torque(self) -> float:
            Flaky.reads += 1
            if Flaky.reads == 300:
                raise Interrupted
            return super().read_torque()

    base = _rig()
    flaky = Flaky(base.motor, base.amplifier, base.settings, rng=0)
    out = tmp_path / "cut.csv"
    with pytest.raises(Interrupted):
        collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.9)
    resumed = collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.9)
    assert resumed.resumed_blocks > 0
    assert resumed.blocks == whole.blocks and resumed.rows == whole.rows
    a = np.loadtxt(tmp_path / "whole.csv", delimiter=",", skiprows=1)
    b = np.loadtxt(out, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(a[:, :2], b[:, :2])  # the same positions and pulse widths
    np.testing.assert_allclose(a[:, 2], b[:, 2], atol=1e-9)  # noise-free: the same torques


def test_bad_input(tmp_path: Path) -> None:
    rig = _rig()
    spec = rig.motor_spec()
    with pytest.raises(InputError, match="budget fraction"):
        collect_adaptive(rig, spec, tmp_path / "x.csv", SETTINGS, fraction=1.5)
    with pytest.raises(InputError, match="does not cover the coarse pass"):
        collect_adaptive(rig, spec, tmp_path / "x.csv", SETTINGS, fraction=0.1)
    grid = tmp_path / "grid.csv"
    grid.write_text("position,pulse_width,torque\n0,0,0.0\n")
    with pytest.raises(InputError, match="without its record"):
        collect_adaptive(rig, spec, grid, SETTINGS)


def test_cli_collect_adaptive(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from torquemap.cli.main import main
    from torquemap.io import write_toml
    from torquemap.linearize.motor import motor_to_dict

    motor = tmp_path / "motor.toml"
    write_toml(motor, motor_to_dict(sim_rig("bldc", rng=0).motor_spec()))
    out = tmp_path / "data.csv"
    args = ["linearize", "collect", str(motor), "--sim", "bldc", "-o", str(out), "--adaptive"]
    small = ["--position-step", "16", "--step", "32", "--readings", "4", "--no-progress"]
    assert main([*args, *small, "--budget", "0.9"]) == 0
    assert "of the grid's" in capsys.readouterr().out
    assert out.with_name("data.csv.adaptive.json").exists()
    assert main([*args, *small, "--budget", "0.05"]) == 2
    assert "does not cover the coarse pass" in capsys.readouterr().err
