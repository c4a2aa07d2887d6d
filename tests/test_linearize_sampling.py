"""Undersampled cogging (torquemap.linearize.sampling): closed-form spectra, a simulated rig
measured at the paper's every 4th position whose cogging repeats every 8 positions, and the
motor file's optional ``cogging_periods``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import write_table, write_toml
from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.motor import motor_from_dict, motor_spec, motor_to_dict, ramped_actuation
from torquemap.linearize.sampling import check_position_sampling, check_stated_cogging
from torquemap.linearize.tables import build_tables, read_data
from torquemap.sim.motors import VariableReluctanceMotor
from torquemap.sim.rig import SimRig, variable_reluctance_rig

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `collected`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("linearize_sampling")

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


def test_stated_cogging_closed_form() -> None:
    """The motor file's cogging periods against the position step: 128 / (4 x 16) = 2 samples a
    period warns and names step 2 (4 samples); 8 periods (4 samples) do not; 64 periods (2
    positions a period) cannot be held by any step."""
    every_4th = np.arange(0, N, 4)
    line = check_stated_cogging(16, every_4th, N)
    assert "2 measured positions a period" in line and "position step 2)" in line
    assert check_stated_cogging(8, every_4th, N) == ""
    assert check_stated_cogging(16, np.arange(0, N, 2), N) == ""
    assert "no table can hold" in check_stated_cogging(64, every_4th, N)
    assert check_stated_cogging(16, np.array([0, 4, 8, 20]), N) == ""  # uneven: not checked


def _closed_form_case(tmp_path: Path, cogging_periods: object | None) -> tuple[Path, Path]:
    """motor.toml (optionally stating the cogging) and noise-free data without cogging, every
    4th position and pulse width: only the file's statement can warn."""
    spec = _rig(16).motor_spec(ramping="wide")
    motor: dict[str, object] = {
        "name": "vr-128",
        "phases": PHASES,
        "positions_per_cycle": N,
        "equilibrium_positions": list(spec.equilibrium_positions),
        "ramping": "wide",
    }
    if cogging_periods is not None:
        motor["cogging_periods"] = cogging_periods
    write_toml(tmp_path / "motor.toml", {"motor": motor})
    p, w = np.meshgrid(np.arange(0, N, 4), np.arange(0, 256, 4), indexing="ij")
    act = ramped_actuation(w, p, spec.ramp)  # (targets, levels, m)
    torque = np.sum((1.0 + 0.2 * np.arange(PHASES)) * (act / 255.0) ** 2, axis=-1)
    write_table(
        tmp_path / "data.csv",
        {"position": p.ravel(), "pulse_width": w.ravel(), "torque": torque.ravel()},
    )
    return tmp_path / "motor.toml", tmp_path / "data.csv"


@pytest.mark.parametrize(("periods", "warns"), [(16, True), (8, False), (None, False)])
def test_build_warns_from_the_motor_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], periods: int | None, warns: bool
) -> None:
    motor, data = _closed_form_case(tmp_path, periods)
    status = main(["linearize", "build", str(motor), str(data), "-o", f"{tmp_path}/t.npz"])
    assert status == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == int(warns)
    if warns:
        assert err[0].startswith(f"torquemap: warning: {data}: the motor file states 16 cogging")
        assert "position step 2" in err[0]


def test_stated_cogging_key() -> None:
    """The optional key round-trips and is checked like the others."""
    spec = motor_spec(
        "m", phases=3, positions_per_cycle=96, equilibrium_positions=(1, 33, 65), cogging_periods=9
    )
    assert spec.cogging_periods == 9
    assert motor_from_dict(motor_to_dict(spec)).cogging_periods == 9
    plain = motor_to_dict(
        motor_spec("m", phases=3, positions_per_cycle=96, equilibrium_positions=(1, 33, 65))
    )
    assert "cogging_periods" not in plain["motor"]
    for bad in (0, 97, 2.5, "6"):
        document = motor_to_dict(spec)
        document["motor"]["cogging_periods"] = bad
        with pytest.raises(InputError, match="cogging_periods"):
            motor_from_dict(document)
