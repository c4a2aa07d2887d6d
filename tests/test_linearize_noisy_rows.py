"""Rows noisier than the torque of one command count are reported (torquemap.linearize.tables).

Closed-form surface (the weak-phase test's: phases that add, torque growing with the square of
the actuation past a dead zone) plus seeded Gaussian noise of a known standard deviation per row.
"""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.linearize.motor import motor_spec, ramped_actuation
from torquemap.linearize.tables import NOISY_ROWS, build_tables

A = 255


@pytest.mark.parametrize("counts", [0.3, 5.0])
def test_rows_noisier_than_a_command_count_are_named(counts: float) -> None:
    # a sensor 5 times noisier than the family's left tables at 9x the floor with exit 0 and
    # no word (QA bench 326); the family's own noise is 0.1 to 1.2 counts and stays silent
    spec = motor_spec("t", phases=4, positions_per_cycle=128, equilibrium_positions=(0, 32, 64, 96))
    p, u = np.meshgrid(np.arange(0, 128, 4), np.arange(0, A + 1, 4), indexing="ij")
    a = ramped_actuation(u.astype(np.float64), p, spec.ramp).astype(np.float64)
    tau = np.sum(np.maximum(a - 20.0, 0.0) ** 2, axis=-1) / A**2
    count = float(tau.reshape(p.shape).max(axis=1).min()) / 127  # full scale over 127 counts
    sigma = counts * count
    noisy = tau + np.random.default_rng(0).normal(0.0, sigma, tau.shape)
    tables = build_tables(spec, p.ravel(), u.ravel(), noisy.ravel(), denoise=False)
    lines = [w for w in tables.warnings if w.startswith("the rows' noise")]
    if counts < NOISY_ROWS:
        assert lines == []
        return
    assert len(lines) == 1
    # the estimate (robust spread of the 32 rows at pulse width 0) within 30 % of the truth,
    # and the count its own (the built full scale within a few % of the closed form's)
    said = float(lines[0].split(" is ")[1].split(" times")[0])
    assert said == pytest.approx(counts, rel=0.3)
