"""A phase much weaker than the others is reported (torquemap.linearize.tables).

Closed-form surface: phases that add, each with a torque growing with the square of its
actuation past a dead zone and its own gain; one phase's gain scaled down.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from torquemap.linearize.motor import MotorSpec, motor_spec, ramped_actuation
from torquemap.linearize.tables import WEAK_PHASE, build_tables

A = 255


def _spec() -> MotorSpec:
    return motor_spec("t", phases=4, positions_per_cycle=128, equilibrium_positions=(0, 32, 64, 96))


def _rows(
    scale: tuple[float, ...],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Every 4th position and pulse width of ``sum_k scale_k max(a_k - 20, 0)^2 / A^2``."""
    spec = _spec()
    p, u = np.meshgrid(np.arange(0, 128, 4), np.arange(0, A + 1, 4), indexing="ij")
    a = ramped_actuation(u.astype(np.float64), p, spec.ramp).astype(np.float64)
    tau = np.sum(np.asarray(scale) * np.maximum(a - 20.0, 0.0) ** 2, axis=-1) / A**2
    return p.ravel(), u.ravel(), tau.ravel()


@pytest.mark.parametrize(
    ("scale", "weak"),
    [
        ((1.0, 1.0, 1.0, 1.0), None),
        ((1.0, 0.85, 1.15, 1.0), None),  # the simulated family's spread of gains
        ((1.0, 1.0, 0.2, 1.0), 3),  # a failing phase: a fifth of its peak torque
    ],
)
def test_a_weak_phase_is_named(scale: tuple[float, ...], weak: int | None) -> None:
    p, u, tau = _rows(scale)
    tables = build_tables(_spec(), p, u, tau, denoise=False)
    lines = [w for w in tables.warnings if "at most" in w and "full scale" in w]
    if weak is None:
        assert lines == []
        return
    # phases are numbered from 1, as in phase_1 .. phase_m and every other message (the third
    # was named "phase 2", beside the strongest "phase 0")
    assert len(lines) == 1 and lines[0].startswith(f"phase {weak} reaches")
    assert "of phase 0's" not in lines[0]
    # the peak of a phase is (A - 20)^2 / A^2 times its gain: 0.2 of the others'
    share = float(lines[0].split("(")[1].split("%")[0]) / 100.0
    assert abs(share - 0.2) < 0.02 and share < WEAK_PHASE
    # and the tables' full scale is the weak phase's
    assert abs(tables.torque_max - 0.2 * (A - 20.0) ** 2 / A**2) < 0.05 * tables.torque_max
