"""Anti-cogging: quasi-static calibration from holds, then verification on the simulated stand.

Independent checks: the simulator's true PDTV lines (recovery of known parameters) and the
true disturbance left after the map the simulator applied (truth the estimators never see).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.cogging import verify_cogging
from torquemap.errors import InputError
from torquemap.io import Log, log_from_columns, write_table
from torquemap.model import Model, save_model
from torquemap.pdtv_map import pdtv_map
from torquemap.quasistatic import identify_quasi_static
from torquemap.robot import Robot, robot_from_dict
from torquemap.sim.actuator import (
    Actuator,
    ActuatorRun,
    log_columns,
    robot_document,
    simulate_holds,
    simulate_sweep,
)

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `stand`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("cogging")


@dataclass(frozen=True)
class Stand:
    robot: Robot
    holds: Log
    model: Model
    before: ActuatorRun
    after: ActuatorRun


@pytest.fixture(scope="module")
def stand() -> Stand:
    robot = robot_from_dict(robot_document())
    holds = log_from_columns(log_columns(simulate_holds(rng=1)), robot)
    model = identify_quasi_static(robot, [holds]).model
    table = pdtv_map(model, "a", bins=1024).torque
    before = simulate_sweep(rng=2)
    after = simulate_sweep(rng=2, compensation=table)
    return Stand(robot, holds, model, before, after)


def test_holds_recover_the_true_lines(stand: Stand) -> None:
    truth = {h.order: h for h in Actuator().axis.pdtv}
    lines = {ln.order: ln for ln in stand.model.joints["a"].pdtv}
    # every true line found, nothing else (false alarm 1 % per joint)
    assert sorted(lines) == sorted(truth)
    for order, h in truth.items():
        # 256 holds with ~0.3 mN m scatter: amplitude SE ~0.03 mN m; the creep through the
        # stiction band scales the holding torque by 0.99-1.02 (sim/actuator.py): 5 % + 0.1 mN m
        np.testing.assert_allclose(lines[order].amplitude, h.amplitude, rtol=0.05, atol=1e-4)
        assert abs(np.angle(np.exp(1j * (lines[order].phase - h.phase)))) < 0.1


def test_the_identified_map_removes_the_ripple_in_the_simulator(stand: Stand) -> None:
    def disturbance(run: ActuatorRun) -> float:
        cruise = np.abs(run.velocity) > 2.0
        return float(np.std((run.pdtv - run.compensation)[cruise]))

    # truth: the torque ripple the servo fights, before and after the map
    assert disturbance(stand.after) < 0.05 * disturbance(stand.before)
    log_after = log_from_columns(log_columns(stand.after), stand.robot)
    log_before = log_from_columns(log_columns(stand.before), stand.robot)
    res = verify_cogging(stand.model, log_after, log_before)
    assert res.before_source == "log" and not res.warnings
    assert res.speed_removed > 0.8 and res.torque_removed > 0.9
    # the torque "before" measured in the sweep agrees with the identified lines
    for ln in res.lines:
        model_amp = max(x.amplitude for x in stand.model.joints["a"].pdtv if x.order == ln.order)
        np.testing.assert_allclose(ln.torque_before, model_amp, rtol=0.3, atol=2e-4)


def test_a_map_with_the_wrong_sign_is_caught(stand: Stand) -> None:
    table = pdtv_map(stand.model, "a", bins=1024).torque
    wrong = log_from_columns(log_columns(simulate_sweep(rng=2, compensation=-table)), stand.robot)
    before = log_from_columns(log_columns(stand.before), stand.robot)
    res = verify_cogging(stand.model, wrong, before)
    assert res.speed_removed < 0
    assert any("speed ripple at the map's orders grew" in w for w in res.warnings)


def test_cli_loop_identify_quasi_static_then_verify(
    stand: Stand, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from torquemap.io import write_toml

    write_toml(tmp_path / "robot.toml", robot_document())
    write_table(tmp_path / "holds.csv", log_columns(simulate_holds(positions=64, rng=3)))
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv")]
    assert main([*argv, "--quasi-static", "-o", str(tmp_path / "m.toml")]) == 0
    out = capsys.readouterr().out
    assert "128 holds at 64 positions per revolution, orders searched up to 31 CPR" in out
    save_model(tmp_path / "model.toml", stand.model)
    write_table(tmp_path / "after.csv", log_columns(stand.after))
    write_table(tmp_path / "before.csv", log_columns(stand.before))
    verify = ["cogging", "verify", str(tmp_path / "model.toml"), str(tmp_path / "after.csv")]
    assert main([*verify, str(tmp_path / "before.csv"), "--require", "80"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].startswith("order_cpr,torque_before_nm")
    assert out.splitlines()[2].startswith("2,")  # the largest line first
    # the same check fails when more is required than the map removes
    assert main([*verify, str(tmp_path / "before.csv"), "--require", "99.9"]) == 1
    assert "check failed" in capsys.readouterr().out


def test_verify_refuses_what_it_cannot_check(
    stand: Stand, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(InputError, match="verification needs a sweep"):
        verify_cogging(stand.model, stand.holds)
    plain = Model(robot=stand.robot, joints={"a": type(stand.model.joints["a"])()})
    with pytest.raises(InputError, match="name the joint to verify"):
        verify_cogging(plain, stand.holds)
    save_model(tmp_path / "plain.toml", plain)
    write_table(tmp_path / "after.csv", log_columns(stand.after))
    argv = ["cogging", "verify", str(tmp_path / "plain.toml"), str(tmp_path / "after.csv")]
    assert main([*argv, "--joint", "a"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plain.toml: joint a: the model holds no PDTV line" in err
    # a percentage outside 0 .. 100 always failed (200) or always passed (-1)
    for bad in ("200", "-1"):
        with pytest.raises(SystemExit):
            main([*argv, "--joint", "a", "--require", bad])
        assert "argument --require: must be a number in [0, 100]" in capsys.readouterr().err


def test_quasi_static_refuses_a_sweep(stand: Stand) -> None:
    sweep = log_from_columns(log_columns(stand.before), stand.robot)
    with pytest.raises(InputError, match="needs position holds"):
        identify_quasi_static(stand.robot, [sweep])


def test_report_shows_the_holds_against_the_model(stand: Stand, tmp_path: Path) -> None:
    from torquemap.io import write_toml

    write_toml(tmp_path / "robot.toml", robot_document())
    save_model(tmp_path / "model.toml", stand.model)
    write_table(tmp_path / "holds.csv", log_columns(simulate_holds(positions=64, rng=4)))
    out = tmp_path / "r.html"
    assert (
        main(["report", str(tmp_path / "model.toml"), str(tmp_path / "holds.csv"), "-o", str(out)])
        == 0
    )
    text = out.read_text(encoding="utf-8")
    assert "joint a: holding torque over one motor revolution" in text
    # an independent set of holds: the model identified from other holds explains its ripple
    explained = re.search(r"<td>128</td><td>[^<]*</td><td>[^<]*</td><td>([\d.]+) %</td>", text)
    assert explained is not None and float(explained.group(1)) > 95.0
    assert "the model holds no friction" in text
