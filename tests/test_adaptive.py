"""Adaptive collection (torquemap.linearize.adaptive): level and position choice, budget, resume."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from torquemap.errors import InputError
from torquemap.linearize.adaptive import (
    choose_levels,
    coarse_readings,
    collect_adaptive,
    grid_readings,
    position_scores,
    refine_levels,
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


def test_refine_levels_bounds_the_interpolation_error() -> None:
    # f(x) = 10 + (x / 16)^2 on levels 32 apart: linear interpolation misses by h^2 f'' / 8 =
    # 32^2 (2 / 256) / 8 = 1 N m, 10 % of the smallest torque; the refined levels must bring
    # the error of every gap within tolerance of the torque at its ends (closed form, checked
    # on the true curve sampled at every integer level)
    def f(x: np.ndarray) -> np.ndarray:
        return 10.0 + (x / 16.0) ** 2

    lv = np.arange(0, 129, 32)
    tol = 0.01

    def worst(levels: np.ndarray) -> float:
        x = np.arange(0, 129, dtype=np.float64)
        err = np.abs(f(x) - np.interp(x, levels, f(levels.astype(np.float64))))
        gap = np.searchsorted(levels, x, side="right").clip(1, levels.size - 1)
        return float(np.max(err / f(levels[gap - 1].astype(np.float64))))

    assert worst(lv) > tol  # the coarse grid misses (so the test can fail)
    refined = refine_levels(f(lv.astype(np.float64))[None, :], lv, tolerance=tol, finest=2)
    assert set(lv.tolist()) <= set(refined.tolist())
    assert worst(refined) <= tol
    # a straight curve needs nothing more
    line = refine_levels((5.0 + lv)[None, :].astype(np.float64), lv, tolerance=tol, finest=2)
    assert line.tolist() == lv.tolist()


def test_coarse_readings_spends_at_most_half_the_budget() -> None:
    # closed form: 20 positions x (9 rows + the bias of 10 rows' worth) = 380 readings per
    # reading a row; half of 4000 is 2000 -> 5 readings a row (1900), 6 would be 2280
    s = CollectionSettings(readings=10, position_step=4, level_step=4, progress=False)
    assert coarse_readings(20, 9, s, 4000) == 5
    assert coarse_readings(20, 9, s, 100_000) == 10  # never more than the settings'
    assert coarse_readings(20, 9, s, 10) == 1


def test_default_rows_leave_half_the_budget_to_the_passes(tmp_path: Path) -> None:
    rig = _rig()
    spec = rig.motor_spec()
    out = tmp_path / "d.csv"
    result = collect_adaptive(rig, spec, out, SETTINGS, fraction=0.9)
    record = json.loads(out.with_name("d.csv.adaptive.json").read_text())["blocks"]
    # the coarse pass visits its positions in increasing order; the passes then start over
    starts = [b[0] for b in record]
    count = next(i for i in range(1, len(starts)) if starts[i] < starts[i - 1])
    coarse = record[:count]
    first = coarse[0][1]
    per_row = coarse_readings(len(coarse), len(first), SETTINGS, result.budget)
    assert per_row < SETTINGS.readings  # the rule is active here
    bias = max(1, round(SETTINGS.bias_count * per_row / SETTINGS.readings))
    assert sum(c * per_row + bias for _, _, c in coarse) <= result.budget / 2
    assert result.readings <= result.budget and result.row_readings == per_row
    assert len(record) > len(coarse)  # the passes got blocks


def _rig(seed: int = 0) -> SimRig:
    rig = sim_rig("bldc", rng=seed)
    return SimRig(rig.motor, rig.amplifier, dataclasses.replace(rig.settings, noise=0.0), rng=seed)


class Interrupted(Exception):
    """The collection cut by :func:`_interrupted_rig`."""


def _interrupted_rig() -> SimRig:
    """The test rig, cut (:class:`Interrupted`) at its 300th reading."""

    class Flaky(SimRig):
        reads = 0

        def read_torque(self) -> float:
            Flaky.reads += 1
            if Flaky.reads == 300:
                raise Interrupted
            return super().read_torque()

    base = _rig()
    return Flaky(base.motor, base.amplifier, base.settings, rng=0)


def test_budget_is_respected_and_resume_loses_nothing(tmp_path: Path) -> None:
    rig = _rig()
    spec = rig.motor_spec()
    whole = collect_adaptive(
        rig, spec, tmp_path / "whole.csv", SETTINGS, fraction=0.9, row_readings=4
    )
    assert whole.readings <= whole.budget == int(grid_readings(spec, SETTINGS) * 0.9)
    assert whole.positions > 13  # the coarse pass's 13, then refined

    flaky = _interrupted_rig()
    out = tmp_path / "cut.csv"
    with pytest.raises(Interrupted):
        collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.9, row_readings=4)
    resumed = collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.9, row_readings=4)
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
    # --budget without --adaptive collected the whole grid without a word (QA bench 305)
    grid = ["linearize", "collect", str(motor), "--sim", "bldc", "-o", str(tmp_path / "g.csv")]
    assert main([*grid, *small, "--budget", "0.5"]) == 2
    assert "--budget is the adaptive collection's" in capsys.readouterr().err
    assert not (tmp_path / "g.csv").exists()


def test_resume_refuses_other_settings_or_another_ramp(tmp_path: Path) -> None:
    # a run cut after its first blocks and resumed with other readings (QA bench 316: 64 blocks
    # at 5 readings a row, the rest at 11, the record rewritten to say 11) or through a motor
    # file with another ramp (wide blocks, then narrow ones) mixed both into one file, exit 0:
    # the recorded blocks were the plan's under either. The record now holds the settings and
    # the motor, and a resume that differs is refused naming what differs.
    flaky = _interrupted_rig()
    spec = flaky.motor_spec()
    out = tmp_path / "cut.csv"
    with pytest.raises(Interrupted):
        collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.9)
    lines = out.read_text()
    more = dataclasses.replace(SETTINGS, readings=8)
    with pytest.raises(InputError, match=r"cut\.csv: cannot resume: .*readings \(this run 8"):
        collect_adaptive(flaky, spec, out, more, fraction=0.9)
    with pytest.raises(InputError, match=r"budget \(this run 0\.8, the file's 0\.9\)"):
        collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.8)
    narrow = flaky.motor_spec(ramping="narrow")
    with pytest.raises(InputError, match=r"cannot resume: .*motor ramp \(differs\)"):
        collect_adaptive(flaky, narrow, out, SETTINGS, fraction=0.9)
    assert out.read_text() == lines  # nothing written by the refused runs
    resumed = collect_adaptive(flaky, spec, out, SETTINGS, fraction=0.9)
    assert resumed.resumed_blocks > 0


def test_a_grid_and_an_adaptive_collection_are_not_resumed_as_each_other(tmp_path: Path) -> None:
    # QA bench 316: the grid's collection on an adaptive file read "two blocks for target
    # position 136 (line 2654); was the file collected with other settings?", and the adaptive
    # one on a grid file "without its record": each now names the other's record
    from torquemap.linearize.collect import collect_characterisation

    rig = _rig()
    spec = rig.motor_spec()
    adaptive = tmp_path / "a.csv"
    collect_adaptive(rig, spec, adaptive, SETTINGS, fraction=0.9, row_readings=4)
    with pytest.raises(InputError, match=r"a\.csv: cannot resume: the file is an adaptive collect"):
        collect_characterisation(rig, spec, adaptive, SETTINGS)
    grid = tmp_path / "g.csv"
    collect_characterisation(rig, spec, grid, SETTINGS)
    with pytest.raises(InputError, match=r"g\.csv.collect\.json is a grid collection's"):
        collect_adaptive(rig, spec, grid, SETTINGS, fraction=0.9, row_readings=4)
