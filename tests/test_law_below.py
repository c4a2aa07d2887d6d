"""The friction law's sigma below the slowest steady pass (stop 42, F55): with
``uncertainty.LAW_BELOW = "extrapolation"`` the law's parameters are read at the slowest pass
and the table's form beyond it by its own leave-one-pass-out curvature, instead of the prior's
variance of the knots the rows do not reach (the default, ``"parameters"``). The one-motor
rig of tests/test_end_runs.py (passes at 1, 3 and 8 rad/s; the truth's law, PDTV and inertia
are test_identify_whole's, read by the test only; the load is closed form)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from test_end_runs import _task
from test_identify_whole import robot, simulate

from torquemap import estimate as E
from torquemap import uncertainty as U
from torquemap.identify import identify_model
from torquemap.model import Model

pytestmark = pytest.mark.xdist_group("identify_whole")


@pytest.fixture(scope="module")
def model() -> Model:
    log = simulate(speeds=(1.0, 3.0, 8.0), seed=3)
    return identify_model(robot(), [log], max_order=20, friction="whole").model


@pytest.fixture()
def settings() -> Iterator[None]:
    saved = (E.END_RUNS, U.LAW_BELOW)
    try:
        yield
    finally:
        E.END_RUNS, U.LAW_BELOW = saved


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def test_the_extrapolation_sigma_is_zero_at_and_above_the_slowest_pass(model: Model) -> None:
    table = U.joint_uncertainty(model, "m")
    assert table is not None
    entry = model.notes["joints"]["m"]
    slowest = U._slowest(entry)
    assert slowest == pytest.approx(1.0, rel=1e-3)
    v = np.array([-8.0, -slowest, slowest, 3.0, 0.5, -0.5, 0.1, 1e-6])
    width = U.sliding_width(model, "m")
    sd = U.below_extrapolation(table, entry, velocity=v, width=width, floor=0.02)
    assert sd is not None
    assert np.all(sd[:4] == 0.0)
    # below it, c q / 2 from the two slowest passes of the direction (1 and 3 rad/s), q in log
    # speed (closed form); the floor holds the speeds inside the transition
    c = float(table["interpolation"]["curvature"])
    for speed, got in zip((0.5, 0.5, 0.1, 0.02), sd[4:], strict=True):
        x = np.log(speed)
        assert got == pytest.approx(0.5 * c * abs(x) * abs(x - np.log(3.0)), rel=1e-3)


def test_a_creeping_start_under_the_extrapolation_sigma(model: Model, settings: None) -> None:
    # 0.1 rad/s for 4 s from the start (an end run: inside the band, 0.19 rad/s, a tenth of the
    # slowest pass, five times the law's transition); the load turns by 0.03 sin(0.6 t) N m
    log, load = _task(lambda t: 0.03 * np.sin(0.6 * t), creep=0.1)
    run = log.t < 4.0
    fast = log.t > 6.0
    out = {}
    for below in ("parameters", "extrapolation"):
        U.LAW_BELOW = below  # type: ignore[assignment]
        for mode in ("hold", "law", "choose"):
            E.END_RUNS = mode  # type: ignore[assignment]
            est = E.estimate_forces(model, log)
            out[below, mode] = (-est.tau_ext[:, 0] - load, est.tau_ext_sigma[:, 0])
    err, sigma = out["extrapolation", "law"]
    # measured: the law errs 3.22 mN m RMS over the run; its sigma 4.95 mN m, 1.5 times the
    # error (the default's: 21.19 mN m, 6.6 times, from the prior's variance of the knots the
    # rows do not reach and the extrapolation spread); every sample within 2 sigma
    assert np.mean(np.abs(err[run]) <= 2.0 * sigma[run]) >= 0.95
    assert _rms(sigma[run]) < 2.0 * _rms(err[run])
    assert _rms(sigma[run]) < 0.5 * _rms(out["parameters", "law"][1][run])
    # the choice takes the law, whose true error is the smaller (hold: 8.84 mN m)
    chosen = out["extrapolation", "choose"][0]
    assert _rms(chosen[run]) == pytest.approx(_rms(err[run]), rel=1e-9)
    assert _rms(err[run]) < 0.5 * _rms(out["extrapolation", "hold"][0][run])
    # at 4 rad/s (above the slowest pass) nothing changes
    for mode in ("hold", "law", "choose"):
        np.testing.assert_allclose(
            out["extrapolation", mode][1][fast], out["parameters", mode][1][fast], rtol=1e-9
        )
        np.testing.assert_array_equal(
            out["extrapolation", mode][0][fast], out["parameters", mode][0][fast]
        )
