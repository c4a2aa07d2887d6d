"""The §5.6 limit cycle (torquemap.sim.oscillation), with tables built by hand in the test."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.linearize.motor import MotorSpec
from torquemap.sim.oscillation import oscillation_figure, pressing_study, simulate_pressing
from torquemap.sim.rig import SimRig, variable_reluctance_rig


@pytest.fixture(scope="module")
def rig() -> SimRig:
    return variable_reluctance_rig(rng=0)


def _phases(inverse: np.ndarray, spec: MotorSpec) -> dict[str, np.ndarray]:
    return {
        f"phase_{k + 1}": np.rint(inverse * spec.ramp[:, k : k + 1]).astype(np.int64)
        for k in range(spec.phases)
    }


def _tables(spec: MotorSpec, *, dips: float) -> tuple[np.ndarray, np.ndarray]:
    """A smooth monotone inverse model with sparse dips, and its monotonic filtering.

    The filter is written here (paper §5.6): scanning commands upward at each position, an
    entry smaller than the previous one is replaced by the previous one.
    """
    rng = np.random.default_rng(1)
    c = np.arange(128)
    inverse = np.zeros((spec.positions_per_cycle, 256))
    positive = np.tile(20 + 1.8 * c, (spec.positions_per_cycle, 1))
    hit = rng.random(positive.shape) < dips
    hit[:, 0] = False
    positive[hit] -= 25
    inverse[:, :128] = np.clip(np.rint(positive), 0, 255)
    filtered = inverse.copy()
    filtered[:, :128] = np.maximum.accumulate(inverse[:, :128], axis=1)
    return inverse, filtered


def test_smooth_monotone_table_settles(rig: SimRig) -> None:
    spec = rig.motor_spec()
    smooth, _ = _tables(spec, dips=0.0)
    study = pressing_study(
        _phases(smooth, spec),
        spec,
        rig,
        commands=range(20, 120, 20),
        base_positions=np.arange(0, 512, 64.5),
        stiffness=15.0,
        steps=300,
    )
    # the torque changes slowly with position (slope << stiffness): a stable fixed point
    assert study.fraction_oscillating == 0.0


def test_dips_cause_limit_cycle_and_filter_reduces_it(rig: SimRig) -> None:
    spec = rig.motor_spec()
    raw, filtered = _tables(spec, dips=0.05)
    kw = {
        "commands": range(20, 120, 5),
        "base_positions": np.arange(0, 512, 17.3),
        "stiffness": 15.0,
        "steps": 400,
    }
    before = pressing_study(_phases(raw, spec), spec, rig, **kw)  # type: ignore[arg-type]
    after = pressing_study(_phases(filtered, spec), spec, rig, **kw)  # type: ignore[arg-type]
    assert before.fraction_oscillating > 0.01
    assert after.fraction_oscillating < 0.5 * before.fraction_oscillating
    # a limit cycle toggles between adjacent table positions (paper: one table increment)
    j = int(np.argmax(before.amplitude))
    run = simulate_pressing(
        _phases(raw, spec),
        spec,
        rig,
        command=int(before.commands[j]),
        stiffness=15.0,
        steps=400,
        base_position=float(before.base_positions[j]),
    )
    assert run.oscillating and run.position_amplitude == 1
    assert run.toggle_fraction > 0.05 and run.amplitude > 0.1
    fig = oscillation_figure({"raw": run}, studies={"raw": before, "monotonic filter": after})
    assert len(fig.axes) == 3


def test_figure_saves(rig: SimRig, tmp_path: Path) -> None:
    spec = rig.motor_spec()
    smooth, _ = _tables(spec, dips=0.0)
    run = simulate_pressing(
        _phases(smooth, spec), spec, rig, command=60, stiffness=15.0, steps=50, base_position=90.0
    )
    assert not run.oscillating and run.position.shape == (50,)
    fig = oscillation_figure({"smooth": run})
    fig.savefig(tmp_path / "osc.png")
    assert (tmp_path / "osc.png").stat().st_size > 1000


def test_wrong_table_shape(rig: SimRig) -> None:
    spec = rig.motor_spec()
    tables = {f"phase_{k}": np.zeros((512, 128), dtype=np.int64) for k in (1, 2, 3)}
    with pytest.raises(ValueError, match="expected \\(512, 256\\)"):
        simulate_pressing(tables, spec, rig, command=10, stiffness=15.0, steps=5)
