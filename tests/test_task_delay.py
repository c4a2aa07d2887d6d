"""A task log whose torque channel lags by another delay than the identification logs'
(torquemap.task_delay): warned, naming the log's own delay; a task logged alike is not.

The 1-DoF motor of tests/test_identify_delay.py, swept with no delay and identified by the
whole-log fit; the task is the same back-and-forth motion under a constant external torque,
its torque channel reporting 120 ms late (a task logged over a host or a bus, the sweeps from
the drive's buffer). The external torque the estimate gives is scored against the one
simulated.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from test_identify_delay import ROBOT, simulate

from torquemap.estimate import estimate_forces
from torquemap.identify import identify_model
from torquemap.io import Log
from torquemap.model import Model
from torquemap.robot import robot_from_dict

# one worker runs the module, so its module fixture (a sweep's identification) is built once
pytestmark = pytest.mark.xdist_group("task_delay")

LOAD = 0.02  # [N m] constant external torque on the task (motor side, gear 1)
TASK_DELAY = 0.12  # [s]


@pytest.fixture(scope="module")
def model() -> Model:
    sweep = simulate(np.random.default_rng(1), delay=0.0)
    return identify_model(robot_from_dict(ROBOT), [sweep]).model


def task(delay: float) -> Log:
    log = simulate(np.random.default_rng(2), delay=delay)
    # the motor holds the load as well: the torque it reports carries it (the load pushes
    # the joint negative, the motor answers positive)
    return Log(
        t=log.t,
        q=log.q,
        motor_torque=log.motor_torque + LOAD,
        joint_names=log.joint_names,
        path="task.csv",
    )


def _error(model: Model, log: Log) -> tuple[float, list[str]]:
    est = estimate_forces(model, log)
    tau_ext = est.tau_ext[:, 0]
    ok = est.flag == 0
    # the estimate's sign: tau_ext is the external torque on the joint (the load, -LOAD)
    err = tau_ext[ok] + LOAD
    return float(np.sqrt(np.mean(err**2))), [w for w in est.warnings if "lags" in w]


def test_a_task_logged_with_another_delay_is_warned_naming_its_delay(model: Model) -> None:
    delay = float(model.notes["joints"]["m"]["channel_delay"])
    assert abs(delay) < 0.01  # the sweeps' own delay, 0
    matched, quiet = _error(model, task(0.0))
    late, said = _error(model, task(TASK_DELAY))
    assert quiet == []
    assert len(said) == 1
    found = re.search(r"lags its position by about (-?\d+) ms", said[0])
    assert found is not None and abs(int(found.group(1)) / 1000 - TASK_DELAY) <= 0.02
    assert "task.csv" not in said[0]  # the path is the CLI's to add
    # the harm the line speaks of: the external torque is off by several times its error
    # on the task logged alike
    assert late > 3.0 * matched


def test_no_line_when_the_delay_is_given_or_the_model_has_no_interval(model: Model) -> None:
    log = task(TASK_DELAY)
    est = estimate_forces(model, log, channel_delay={"m": TASK_DELAY})
    assert not [w for w in est.warnings if "lags" in w]
    notes = dict(model.notes, joints={"m": {"channel_delay": 0.0}})
    bare = Model(robot=model.robot, joints=model.joints, notes=notes)
    assert not [w for w in estimate_forces(bare, log).warnings if "lags" in w]


def _negated(log: Log) -> Log:
    """``log`` with its current's sign reversed (a drive or logger that flips it)."""
    return dataclasses.replace(log, motor_torque=-log.motor_torque)


def _flip_lines(model: Model, log: Log) -> list[str]:
    return [w for w in estimate_forces(model, log).warnings if "sign reversed" in w]


def test_a_task_logged_with_its_current_negated_is_warned(model: Model) -> None:
    right = task(0.0)
    negated = _negated(right)
    assert _flip_lines(model, right) == []
    said = _flip_lines(model, negated)
    assert len(said) == 1 and "negate i_m" in said[0]
    # the harm the line speaks of: the estimate off by about twice the model's torque, many
    # times the error of the task logged alike
    assert _error(model, negated)[0] > 10.0 * _error(model, right)[0]
    # a model without a delay interval (no delay line possible) still gets the sign line
    notes = dict(model.notes, joints={"m": {"channel_delay": 0.0}})
    bare = Model(robot=model.robot, joints=model.joints, notes=notes)
    assert len(_flip_lines(bare, negated)) == 1
    assert _flip_lines(bare, right) == []


def test_the_sign_is_checked_when_the_user_gives_the_delay(model: Model) -> None:
    late = task(TASK_DELAY)
    negated = _negated(late)
    given = {"m": TASK_DELAY}
    flips = [
        [
            w
            for w in estimate_forces(model, log, channel_delay=given).warnings
            if "sign reversed" in w
        ]
        for log in (late, negated)
    ]
    assert flips[0] == []
    assert len(flips[1]) == 1 and "negate i_m" in flips[1][0]
    # and still no delay line: the user's delay is the one undone
    est = estimate_forces(model, negated, channel_delay=given)
    assert not [w for w in est.warnings if "lags" in w]


def test_the_check_given_the_estimates_derivatives_is_the_one_that_differentiates(
    model: Model, monkeypatch: pytest.MonkeyPatch
) -> None:
    from torquemap import estimate as E
    from torquemap import filters
    from torquemap.sanitize import sanitize_log
    from torquemap.task_delay import task_delay_warnings

    window = E.model_window(model)
    for log in (task(TASK_DELAY), task(0.0)):
        own = task_delay_warnings(model, log, window=window, cutoff=2.0)
        _, _, _, acceleration = E._signal(model, log, window=window)
        velocity = E._signal(model, log, window=window)[2]
        modulation = model.robot.arm.inertia_modulation(log.q)
        with monkeypatch.context() as m:
            # given the derivatives, the check differentiates nothing
            def refuse(*args: object, **kwargs: object) -> None:
                raise AssertionError("differentiated again")

            m.setattr(E, "differentiate_rates", refuse)
            m.setattr(filters, "differentiate_rates", refuse)
            given = task_delay_warnings(
                model, log, window=window, cutoff=2.0, rates=(velocity, acceleration, modulation)
            )
        assert given == own
        # and the estimate (its own derivatives handed over) reports the line of its
        # sanitised piece's check, differentiated again
        piece = sanitize_log(log, window=window).pieces[0].log
        again = task_delay_warnings(model, piece, window=window, cutoff=2.0)
        assert [w for w in estimate_forces(model, log).warnings if "lags" in w] == again
    assert task_delay_warnings(model, task(TASK_DELAY), window=window, cutoff=2.0)
    # derivatives that are not the log's change the answer: they are what the check reads
    log = task(TASK_DELAY)
    zero = np.zeros_like(log.q)
    modulation = model.robot.arm.inertia_modulation(log.q)
    assert task_delay_warnings(
        model, log, window=window, cutoff=2.0, rates=(zero, zero, modulation)
    ) != task_delay_warnings(model, log, window=window, cutoff=2.0)
