"""The runs at a log's ends (stop 41, F54): a motor that creeps below its table's fitted speeds
(but above its law's transition) at the start of a task while the load on it turns. Held, the
answer is the load where the motor leaves the run; with ``estimate.END_RUNS = "choose"`` the
run reads the friction law where its sigma is the smaller. The one-motor law, PDTV and
inertia are test_identify_whole's (the truth, read by the test only); the load is closed
form."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from test_identify_whole import LAW, LINES, J, robot, simulate

from torquemap import estimate as E
from torquemap.identify import identify_model
from torquemap.io import Log
from torquemap.model import Model, pdtv_torque

pytestmark = pytest.mark.xdist_group("identify_whole")


@pytest.fixture(scope="module")
def model() -> Model:
    # passes at 1, 3 and 8 rad/s: the band is half the slowest (0.19 rad/s measured), the law's
    # transition 4 w0 = 0.019 rad/s
    log = simulate(speeds=(1.0, 3.0, 8.0), seed=3)
    return identify_model(robot(), [log], max_order=20, friction="whole").model


def _task(load: Callable[[np.ndarray], np.ndarray], creep: float) -> tuple[Log, np.ndarray]:
    """12 s at 1 kHz: from rest to ``creep`` [rad/s] in 0.3 s, creeping to 4 s, then 4 rad/s
    (a 0.5 s smooth step); the true external torque ``load(t)`` [N m]; torque noise 5 mN m."""
    h = 1e-3
    t = np.arange(0.0, 12.0, h)

    def step(x: np.ndarray) -> np.ndarray:
        x = np.clip(x, 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    w = creep * step(t / 0.3) + (4.0 - creep) * step((t - 4.0) / 0.5)
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    tau = J * np.gradient(w, h) + LAW.torque(w) + pdtv_torque(theta, LINES) + load(t)
    tau += np.random.default_rng(4).normal(0.0, 0.005, t.size)
    q = np.round(theta * 8000 / (2 * np.pi)) * (2 * np.pi / 8000)
    log = Log(t=t, q=q[:, None], motor_torque=tau[:, None], joint_names=("m",), path="task.csv")
    return log, load(t)


def _estimate(model: Model, log: Log, mode: str) -> E.ForceEstimate:
    saved = E.END_RUNS
    try:
        E.END_RUNS = mode  # type: ignore[assignment]
        return E.estimate_forces(model, log)
    finally:
        E.END_RUNS = saved


def test_a_turning_load_in_a_creeping_start_reads_the_law(model: Model) -> None:
    # 0.1 rad/s for 4 s: inside the band (0.19 rad/s), five times the law's transition; the
    # load turns by 0.03 sin(0.6 t) N m meanwhile
    log, load = _task(lambda t: 0.03 * np.sin(0.6 * t), creep=0.1)
    run = log.t < 4.0
    errs, sigmas = {}, {}
    for mode in ("hold", "law", "choose"):
        est = _estimate(model, log, mode)
        err = -est.tau_ext[:, 0] - load  # tau_ext is the load's reaction
        errs[mode] = float(np.sqrt(np.mean(err[run] ** 2)))
        sigmas[mode] = est.tau_ext_sigma[:, 0]
        if mode == "choose":
            # its sigma covers its error in the run (measured: every sample within 2 sigma)
            assert np.mean(np.abs(err[run]) <= 2.0 * sigmas[mode][run]) >= 0.95
            # and nothing changes where the motor moves at speed
            assert np.sqrt(np.mean(err[log.t > 6.0] ** 2)) < 1e-3
    # measured: hold 8.8, law 5.2 mN m; the rule takes the law, whose sigma (21.7 mN m RMS)
    # is under the hold's (38.4 mN m: the neighbouring answer's slope times the time from it)
    assert errs["law"] < 0.7 * errs["hold"]
    assert errs["choose"] == pytest.approx(errs["law"], rel=1e-9)
    assert np.sqrt(np.mean(sigmas["choose"][run] ** 2)) < np.sqrt(np.mean(sigmas["hold"][run] ** 2))


def test_a_start_at_rest_is_held_as_before(model: Model) -> None:
    # no creep: the motor rests (inside the law's transition) until 4 s; nothing slides in the
    # run, so the rule has nothing to choose and the answer is main's hold, to the bit
    log, _load = _task(lambda t: 0.02 + 0.0 * t, creep=0.0)
    hold = _estimate(model, log, "hold")
    choose = _estimate(model, log, "choose")
    assert np.array_equal(hold.tau_ext, choose.tau_ext)
    assert np.array_equal(hold.tau_ext_sigma, choose.tau_ext_sigma)
