"""The whole fit's friction table with its prior centred on a generalized Stribeck curve
(``identify_model(..., stribeck_prior=True)``, :mod:`torquemap.friction_prior`), on a 1-DoF
motor simulated from a known law (tests/test_identify_whole.py's ``simulate``)."""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.testing import assert_allclose
from test_identify_whole import robot, simulate, write_motor_files

from torquemap.friction_law import StribeckFriction
from torquemap.identify import identify_model
from torquemap.model import load_model, save_model

# a Stribeck drop (Fc 0.04 / 0.05 N m, Fs 0.03 / 0.02 N m, vs 2 rad/s, exponent 2) swept at
# passes 3.0-3.3x apart with ramps of 20 ms: between the passes the sweep holds only ramps
# shorter than the differentiator window, so the table there is its prior's
LAW = StribeckFriction(
    coulomb_positive=0.04,
    coulomb_negative=0.05,
    viscous=0.0003,
    stribeck_positive=0.03,
    stribeck_negative=0.02,
    stribeck_velocity=2.0,
    stribeck_exponent=2.0,
    zero_velocity=0.05,
    transition="smooth",
)
BETWEEN = np.array([0.7, 1.0, 2.0, 2.7, 3.7, 7.0, 10.0])


def _between_error(model: object, law: StribeckFriction) -> float:
    """RMS relative error of the model's friction between the passes, both directions."""
    v = np.r_[BETWEEN, -BETWEEN]
    f = model.joints["m"].friction  # type: ignore[attr-defined]
    e = (f.torque(v) - law.torque(v)) / law.torque(v)
    return float(np.sqrt(np.mean(e**2)))


def test_the_curve_is_found_and_draws_the_table_between_passes(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # the curve's velocity within a grid step (1.25x) of the truth's in both directions, and
    # between the passes the table closer to the truth than without the curve (the smoothness
    # prior and the passes' redraw: 3.0 % RMS, seed 4): with the curve and the redraw
    # (REDRAW_CURVED, the flag's default) 1.6 %, with the curve alone 0.95 % (measured; seeds
    # 3 and 5: 2.1 % / 1.6 % and 2.0 % / 0.9 % against 3.0 % / 3.0 %). The exponent is the
    # grid's that the passes prefer (1.5 here), not recovered: between passes 3x apart drops
    # of exponent 1.5 and 2 pass through the same passes
    import torquemap.identify_whole as iw

    log = simulate(law=LAW, ramp=0.02, speeds=(0.5, 1.5, 5.0, 15.0), noise=3e-4, seed=4)
    plain = identify_model(robot(), [log], max_order=20, friction="whole").model
    curved = identify_model(
        robot(), [log], max_order=20, friction="whole", stribeck_prior=True
    ).model
    assert "friction_prior" not in plain.notes["joints"]["m"]
    prior = curved.notes["joints"]["m"]["friction_prior"]
    for v in prior["stribeck_velocity"]:
        assert 2.0 / 1.25 <= v <= 2.0 * 1.25
    off = _between_error(plain, LAW)
    assert _between_error(curved, LAW) < min(0.02, off)
    monkeypatch.setattr(iw, "REDRAW_CURVED", False)
    alone = identify_model(
        robot(), [log], max_order=20, friction="whole", stribeck_prior=True
    ).model
    assert _between_error(alone, LAW) < 0.5 * off


def test_another_exponent_is_drawn_closer_than_by_the_smoothness_prior() -> None:
    # exponent 2.7 (the family draws 0.6-3.0): 4.2 % RMS off between the passes against 5.2 %
    # with the smoothness prior and the redraw (measured, seed 4; the same with the curve
    # alone)
    law = dataclasses.replace(LAW, stribeck_exponent=2.7)
    log = simulate(law=law, ramp=0.02, speeds=(0.5, 1.5, 5.0, 15.0), noise=3e-4, seed=4)
    plain = identify_model(robot(), [log], max_order=20, friction="whole").model
    curved = identify_model(
        robot(), [log], max_order=20, friction="whole", stribeck_prior=True
    ).model
    assert _between_error(curved, law) < _between_error(plain, law) < 0.06


class Hump:
    """Friction of another form than a Stribeck curve: a hump of 0.012 N m around 3 rad/s
    (Gaussian in log speed) on a level of 0.04 N m, plus viscous 0.0005 N m s/rad."""

    def torque(self, v: np.ndarray) -> np.ndarray:
        v = np.asarray(v, dtype=np.float64)
        s = np.maximum(np.abs(v), 1e-9)
        return np.tanh(v / 0.05) * (0.04 + 0.012 * np.exp(-(np.log(s / 3.0) ** 2)) + 0.0005 * s)


def test_a_law_of_another_form_is_still_fitted_at_its_passes() -> None:
    # the curve cannot follow a hump; the deviation from it, held by the smoothness prior,
    # takes it: at the passes within 1 % (measured 0.37 %, the same as without the curve), and
    # between them (ramps of 0.4 s measure those speeds) within 2.5 % (measured 1.73 %, at
    # -5.6 rad/s; 0.80 % without the curve: on a law of another form the curve costs a little
    # between the passes)
    passes = np.array([0.5, 1.0, 2.0, 4.0, 8.0])
    between = np.array([0.7, 1.4, 2.8, 5.6])
    log = simulate(law=Hump(), speeds=tuple(passes), seed=3)
    model = identify_model(robot(), [log], max_order=20, friction="whole", stribeck_prior=True)
    f = model.model.joints["m"].friction
    assert "friction_prior" in model.model.notes["joints"]["m"]
    assert_allclose(f.torque(passes), Hump().torque(passes), rtol=0.01)
    assert_allclose(-f.torque(-passes), Hump().torque(passes), rtol=0.01)
    assert_allclose(f.torque(between), Hump().torque(between), rtol=0.025)
    assert_allclose(-f.torque(-between), Hump().torque(between), rtol=0.025)


def test_the_curve_survives_the_model_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    # model format is a contract: the curve is an added entry of the joint's notes, written
    # and read back as it was
    log = simulate(law=LAW, ramp=0.02, speeds=(0.5, 1.5, 5.0, 15.0), noise=3e-4, seed=4)
    model = identify_model(
        robot(), [log], max_order=20, friction="whole", stribeck_prior=True
    ).model
    save_model(tmp_path / "m.toml", model)
    back = load_model(tmp_path / "m.toml")
    written = model.notes["joints"]["m"]["friction_prior"]
    read = back.notes["joints"]["m"]["friction_prior"]
    assert read == written
    assert set(read) == {"stribeck_velocity", "stribeck_exponent"}
    assert all(len(x) == 2 for x in read.values())


def test_identify_stribeck_prior_option_reaches_the_fit(tmp_path) -> None:  # type: ignore[no-untyped-def]
    # `identify --stribeck-prior` is the keyword stribeck_prior=True: the model file records
    # the curve only with the flag
    from torquemap.cli.main import main

    log = simulate(law=LAW, ramp=0.02, speeds=(0.5, 1.5, 5.0, 15.0), noise=3e-4, seed=4)
    write_motor_files(tmp_path, log)
    seen = {}
    for extra in ([], ["--stribeck-prior"]):
        out = tmp_path / f"m{len(extra)}.toml"
        argv = [str(tmp_path / "robot.toml"), str(tmp_path / "sweep.csv"), "-o", str(out)]
        assert main(["--quiet", "identify", *argv, "--max-order", "20", *extra]) == 0
        seen[len(extra)] = load_model(out).notes["joints"]["m"].get("friction_prior")
    assert seen[0] is None
    assert seen[1] is not None and all(v > 0 for v in seen[1]["stribeck_velocity"])
