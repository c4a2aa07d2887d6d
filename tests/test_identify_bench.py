"""identify on the simulated SCARA bench's sweeps, against the simulator's true parameters.

The simulator (torquemap.sim) integrates the dynamics at the servo rate with a PD controller,
quantised encoders, current noise and inverter ripple; identify sees only sweep.csv and
robot.toml. truth.toml holds what the simulator used. The model forms differ where the
simulator is richer than the identified model (its Coulomb friction is blended over a
0.05 rad/s band, its inertia of joint a depends on the elbow, the servo adds ripple), so the
tolerances below allow a few per cent of modelling error on friction and inertia, and are tight
on the PDTV lines, whose form is the same on both sides.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import WHOLE_MODEL
from numpy.testing import assert_allclose

from torquemap.model import Model, load_model


@pytest.fixture(scope="module")
def identified(scara_passes: Path, scara_bench: Path) -> tuple[Model, Model]:
    """The model ``torquemap identify --friction passes`` wrote from sweep.csv (shared by the
    session), the truth."""
    model = load_model(scara_passes)
    return model, load_model(scara_bench / "truth.toml")


@pytest.mark.parametrize("joint", ["a", "b"])
def test_friction_against_truth(identified: tuple[Model, Model], joint: str) -> None:
    got = identified[0].joints[joint].friction
    true = identified[1].joints[joint].friction
    # every sample of the sweeps in one robust fit (samples at rest left out: static friction
    # is undetermined there); the law's form is the simulator's but for the transition through
    # zero (tanh against a linear blend), so Coulomb and viscous come out at 1 % and 3 %
    assert_allclose(got.coulomb_positive, true.coulomb_positive, rtol=0.01)
    assert_allclose(got.coulomb_negative, true.coulomb_negative, rtol=0.01)
    assert_allclose(got.viscous, true.viscous, rtol=0.03)
    # the Stribeck hump: the slow passes and every ramp through low speed: 3 %
    assert_allclose(got.stribeck_positive, true.stribeck_positive, rtol=0.03)
    assert_allclose(got.stribeck_negative, true.stribeck_negative, rtol=0.03)
    assert_allclose(got.stribeck_velocity, true.stribeck_velocity, rtol=0.03)


@pytest.mark.parametrize("joint", ["a", "b"])
def test_inertia_against_truth(identified: tuple[Model, Model], joint: str) -> None:
    got = identified[0].joints[joint].inertia
    true = identified[1].joints[joint].inertia
    # only the trapezoids' ramps carry J*acc, against servo ripple; every column is smoothed
    # with the differentiator's own acceleration kernel, so the ramps' edges do not bias it: 3 %
    assert_allclose(got.constant, true.constant, rtol=0.03)


@pytest.mark.parametrize("joint", ["a", "b"])
def test_pdtv_lines_against_truth(identified: tuple[Model, Model], joint: str) -> None:
    got = {ln.order: ln for ln in identified[0].joints[joint].pdtv}
    true = {ln.order: ln for ln in identified[1].joints[joint].pdtv}
    assert sorted(got) == sorted(true)  # every true line, no spurious one
    for order, ln in true.items():
        # the smallest line (0.8 mN m) stands ~10x above its amplitude standard error
        assert_allclose(got[order].amplitude, ln.amplitude, rtol=0.05)
        d = np.angle(np.exp(1j * (got[order].phase - ln.phase)))
        assert abs(d) < 0.05, f"{joint} {order} CPR phase off by {d:.3f} rad"


@WHOLE_MODEL
@pytest.mark.parametrize("joint", ["a", "b"])
def test_whole_fit_records_its_uncertainty(scara_model: Path, joint: str) -> None:
    model = load_model(scara_model)  # identify --friction whole
    notes = model.notes["joints"][joint]
    assert notes["friction_fit"] == "whole"
    table = notes["uncertainty"]
    names = table["parameters"]
    cov = np.array(table["covariance"])
    assert cov.shape == (len(names), len(names))
    assert np.all(np.linalg.eigvalsh(cov) > -1e-12 * np.abs(cov).max())
    got = model.joints[joint].friction
    # the simulator blends over 0.05 rad/s; the identified smooth transition is of that order
    assert 0.01 < got.zero_velocity < 0.3
    assert table["residual_psd"] > 0
