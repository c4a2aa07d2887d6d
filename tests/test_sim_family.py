"""The family of random simulated benches (torquemap.sim.family) and its CLI."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import read_table
from torquemap.linearize.motor import load_motor
from torquemap.sim.family import paper_bench, random_bench
from torquemap.sim.motors import Amplifier, amplifier_current, motor_torque, torque_at
from torquemap.sim.rig import SimRig


def test_family_spans_the_kinds_and_is_deterministic() -> None:
    benches = [random_bench(s) for s in range(40)]
    assert {b.kind for b in benches} == {"vr", "bldc"}
    assert {b.rig.phases for b in benches} == {3, 4}
    assert {b.ramping for b in benches} == {"narrow", "wide"}
    assert len({b.rig.positions_per_cycle for b in benches}) >= 4
    readings = [b.settings.readings for b in benches]
    assert min(readings) < 15 and max(readings) > 30  # the paper's 10 up to dense
    again = random_bench(7)
    assert again.rig.motor.phase_gain == benches[7].rig.motor.phase_gain
    assert again.rig.settings.friction == benches[7].rig.settings.friction
    paper = paper_bench(7).settings
    assert (paper.readings, paper.position_step, paper.level_step) == (10, 4, 4)
    with pytest.raises(InputError, match="random seed must be a non-negative integer"):
        random_bench(-1)


def test_friction_and_equilibria_as_drawn() -> None:
    for seed in range(12):
        b = random_bench(seed)
        motor, amp = b.rig.motor, b.rig.amplifier
        # friction 0 .. 3 % of one phase's full torque, found here by a brute-force scan
        x = np.arange(0.0, motor.positions_per_cycle, 0.25)
        full = 0.0
        for k in range(b.rig.phases):
            cur = np.zeros(b.rig.phases)
            cur[k] = float(amplifier_current(255, amp))
            full = max(full, float(np.abs(motor_torque(motor, x, cur)).max()))
        assert 0.0 <= b.rig.settings.friction <= 0.03 * full * (1 + 1e-6)
        assert 0.0 <= amp.dead_band <= 0.15 * 255
        # each phase's equilibrium from the physics is where it was drawn (nominal + offset);
        # without the cogging, which moves the zero by its torque over the slope
        drawn = np.asarray(motor.equilibrium) + np.asarray(motor.phase_offset)
        plain = SimRig(dataclasses.replace(motor, cogging=0.0), amp, b.rig.settings)
        found = np.asarray(plain.equilibrium_positions())
        n = motor.positions_per_cycle
        miss = (found - drawn + n / 2) % n - n / 2
        assert np.abs(miss).max() <= 0.5 + 1e-9, (seed, found, drawn)


def test_scalar_torque_matches_the_array_law() -> None:
    g = np.random.default_rng(0)
    for seed in range(10):
        b = random_bench(seed)
        m = b.rig.phases
        for _ in range(20):
            x = float(g.uniform(0, b.rig.positions_per_cycle))
            cur = g.uniform(0, 10, m) * (g.random(m) < 0.7)
            assert torque_at(b.rig.motor, x, cur.tolist()) == pytest.approx(
                float(motor_torque(b.rig.motor, x, cur)), rel=1e-12, abs=1e-12
            )


def test_amplifier_onset_and_soft_limit_closed_form() -> None:
    amp = Amplifier(dead_band=20.0, curve=0.0, current_max=10.0, onset=10.0, soft_limit=4.0)
    span = 255.0 - 20.0
    # below the onset width the drive is d^2 / (2 w); above it d - w / 2 (linear curve)
    raw = np.array([0.0, 5.0**2 / 20.0, 30.0 - 5.0]) * 10.0 / span
    soft = raw / (1 + (raw / amp.current_limit) ** 4) ** 0.25
    assert_allclose(amplifier_current([20.0, 25.0, 50.0], amp), soft, rtol=1e-12)
    hard = Amplifier(dead_band=20.0, curve=0.0)
    assert float(amplifier_current(255, hard)) == hard.current_limit


def test_simulate_rig_random_and_collect_on_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bench"
    fast = ["--readings", "2", "--position-step", "32", "--pulse-step", "64", "--no-progress"]
    assert main(["simulate", "rig", "--random", "3", "--out", str(out), *fast]) == 0
    printed = capsys.readouterr().out
    bench = random_bench(3)
    assert bench.describe() in printed
    # --ramping overrides the draw: the printed line says the ramp collected, not the draw's
    other = "narrow" if bench.ramping == "wide" else "wide"
    again = ["simulate", "rig", "--random", "3", "--out", str(tmp_path / "b2"), *fast]
    assert main([*again, "--ramping", other]) == 0
    assert f"{other} ramp" in capsys.readouterr().out
    assert load_motor(tmp_path / "b2" / "motor.toml").ramping == other
    spec = load_motor(out / "motor.toml")
    assert spec.phases == bench.rig.phases
    assert spec.positions_per_cycle == bench.rig.positions_per_cycle
    assert spec.ramping == bench.ramping
    data = read_table(out / "data.csv")
    assert np.unique(data["pulse_width"]).tolist() == [0, 64, 128, 192, 255]
    argv = ["linearize", "collect", str(out / "motor.toml"), "-o", str(tmp_path / "c.csv")]
    assert main([*argv, "--random", "3", "--step", "64", *fast[:4], "--no-progress"]) == 0
    # 384 positions and 4 phases: build bridges gaps of 24 positions, not 31 (fast, not built)
    assert "a position step of 32 leaves gaps of up to 31" in capsys.readouterr().err
    # a motor file for another bench of the family is refused in one line
    other = next(s for s in range(100) if random_bench(s).rig.phases != bench.rig.phases)
    status = main([*argv, "--random", str(other), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 2 and f"random motor {other} has" in err and err.count("\n") == 1
    # and one of the same shape (phases, positions, full scale) too: it was collected
    # under this file, exit 0 (QA: bench 304's file with --random 321)
    shape = (bench.rig.phases, bench.rig.positions_per_cycle)
    twin = next(
        s
        for s in range(4, 200)
        if (random_bench(s).rig.phases, random_bench(s).rig.positions_per_cycle) == shape
    )
    status = main([*argv, "--random", str(twin), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1
    assert f"the motor file is 'random-3' (simulate rig --random 3); the random motor {twin}" in err


def test_simulate_rig_random_paper_settings_on_a_dense_draw(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a bench whose draw targets the ramp's transitions can still be collected at the paper's
    # settings (evenly spaced targets alone): --no-transitions overrides the draw
    from torquemap.linearize.collect import collection_targets

    seed = next(s for s in range(100) if random_bench(s).settings.transitions)
    out = tmp_path / "bench"
    fast = ["--readings", "2", "--position-step", "32", "--pulse-step", "255", "--no-progress"]
    argv = ["simulate", "rig", "--random", str(seed), "--out", str(out), *fast]
    assert main([*argv, "--no-transitions"]) == 0
    spec = load_motor(out / "motor.toml")
    data = read_table(out / "data.csv")
    blocks = int(np.sum(np.asarray(data["pulse_width"]) == 0))
    evenly = collection_targets(spec, positions=spec.positions_per_cycle // 32)
    assert blocks == evenly.size
    assert evenly.size < collection_targets(spec, positions=evenly.size, transitions=True).size
    capsys.readouterr()
