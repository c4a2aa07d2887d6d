"""Undersampled cogging (torquemap.linearize.sampling): closed-form spectra, and a simulated rig
measured at the paper's every 4th position whose cogging repeats every 8 positions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.io import write_toml
from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.sampling import check_position_sampling
from torquemap.linearize.tables import build_tables, read_data
from torquemap.sim.motors import VariableReluctanceMotor
from torquemap.sim.rig import SimRig, variable_reluctance_rig

N = 128
PHASES = 4


def test_closed_form_spectrum() -> None:
    """Amplitudes of known sinusoids: the Nyquist one alternates at the measured positions."""
    p = np.arange(N)
    rng = np.random.default_rng(0)
    slow = 0.05 * np.sin(2 * np.pi * 3 * p / N)
    fast = 0.03 * np.sin(2 * np.pi * 16 * p / N + np.pi / 2)  # +-0.03 at every 4th position
    noise = 0.002 * rng.standard_normal(N)
    check = check_position_sampling(slow + fast + noise, p[::4], N, torque_per_count=0.1)
    assert check.undersampled and check.position_step == 4
    # the DFT's amplitude of a sinusoid at the measured positions is its amplitude; the noise
    # adds at most a few of its 0.002 / sqrt(32) per bin
    np.testing.assert_allclose(check.top_amplitude, 0.03, atol=0.002)
    assert "every 2nd position (position step 2)" in check.advice()
    # the same torque every 2nd position: 16 periods are 4 samples a period, well below the top
    assert not check_position_sampling(slow + fast, p[::2], N, torque_per_count=0.1).undersampled
    # at the limit but too small to matter (under a fifth of command 1's torque)
    small = check_position_sampling(slow + fast, p[::4], N, torque_per_count=0.2)
    assert not small.undersampled
    # noise alone at the top frequencies does not warn
    alone = check_position_sampling(slow + noise, p[::4], N, torque_per_count=0.001)
    assert not alone.undersampled
    # unevenly spaced positions are not checked
    uneven = np.array([0, 4, 8, 12, 14, 20, 24, 28, 40, 50, 60, 70])
    assert check_position_sampling(slow + fast, uneven, N, torque_per_count=0.1).position_step == 0


def _rig(cogging_periods: int) -> SimRig:
    """A 4-phase VR motor over 128 positions with cogging of 1 % of its peak torque, the
    phase put where every 4th position sees its full swing."""
    w = N / PHASES
    motor = VariableReluctanceMotor(
        positions_per_cycle=N,
        equilibrium=tuple(((k + 0.5) * w + N / 4.0) % N for k in range(PHASES)),
        phase_offset=(0.0, 1.0, -1.0, 0.5),
        phase_gain=(1.0, 0.95, 1.05, 1.0),
        peak_torque=40.0,
        cogging=0.4,
        cogging_periods=cogging_periods,
        cogging_phase=np.pi / 2,
    )
    return variable_reluctance_rig(
        rng=7, motor=motor, stiffness=20.0, friction=0.3, noise=0.15, bias_variation=0.5
    )


@pytest.fixture(scope="module")
def collected(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Characterisation data at the paper's settings (and every 2nd position)."""
    out = tmp_path_factory.mktemp("sampling")
    files = {}
    for name, periods, step in (("limit", 16, 4), ("dense", 16, 2), ("slow", 8, 4)):
        rig = _rig(periods)
        spec = rig.motor_spec(ramping="wide")
        settings = CollectionSettings.paper(position_step=step, bias_open=True, progress=False)
        path = out / f"{name}.csv"
        collect_characterisation(rig, spec, path, settings)
        files[name] = path
    spec = _rig(16).motor_spec(ramping="wide")
    motor = {
        "name": "vr-128",
        "phases": PHASES,
        "positions_per_cycle": N,
        "equilibrium_positions": list(spec.equilibrium_positions),
        "ramping": "wide",
    }
    write_toml(out / "motor.toml", {"motor": motor})
    files["motor"] = out / "motor.toml"
    return files


@pytest.mark.parametrize(("name", "warns"), [("limit", True), ("dense", False), ("slow", False)])
def test_simulated_rig(collected: dict[str, Path], name: str, warns: bool) -> None:
    """Cogging of 16 periods over 128 positions (two samples a period at every 4th position)
    warns; the same motor measured every 2nd position, or cogging of 8 periods, does not."""
    spec = _rig(16).motor_spec(ramping="wide")
    data = read_data(collected[name], spec, kind="characterisation")
    tables = build_tables(spec, data.position, data.level, data.torque)
    assert tables.surface  # the check reads the structured surface's torque at rest
    assert bool(tables.warnings) == warns
    if warns:
        assert "every 2nd position" in tables.warnings[0]


def test_build_warns_in_one_line(
    collected: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``linearize build`` writes the tables and says, in one line naming the file, what to
    collect instead."""
    data = collected["limit"]
    status = main(
        ["linearize", "build", str(collected["motor"]), str(data), "-o", f"{tmp_path}/t.npz"]
    )
    assert status == 0 and (tmp_path / "t.npz").exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"torquemap: warning: {data}: ")
    assert "measuring every 2nd position" in err[0]
