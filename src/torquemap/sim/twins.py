"""A second motor of the same type: the manufacturing spread of motors and amplifiers (§6.2).

Two joints with the same motor type differ by their phases' strengths and equilibria, the
magnetic details (saturation, harmonics, cogging) and their amplifiers (dead band, curve,
current limit). :func:`sibling` draws such a second motor around a first one; the relative
spreads are chosen to be those of one production line (a few per cent), not of another design.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from torquemap.sim.motors import Amplifier, BrushlessDcMotor, Motor, VariableReluctanceMotor


def sibling(
    motor: Motor,
    amplifier: Amplifier,
    *,
    rng: np.random.Generator | int | None = None,
    spread: float = 1.0,
) -> tuple[Motor, Amplifier]:
    """A motor and amplifier of the same type as ``motor`` and ``amplifier``, drawn around them.

    Parameters
    ----------
    motor, amplifier
        The first joint's.
    rng
        Random source.
    spread
        Multiplies every spread (1: phase gains +-5 %, equilibria +-3 table positions for 512
        per cycle, peak torque +-8 %, dead band +-4 pulse widths, curve +-0.2, current limit
        +-3 %, saturation and harmonics +-10 %, all as standard deviations).

    Returns
    -------
    (Motor, Amplifier)
        The second joint's.

    Examples
    --------
    >>> from torquemap.sim.motors import VariableReluctanceMotor, Amplifier
    >>> m, a = sibling(VariableReluctanceMotor(), Amplifier(), rng=0)
    >>> m.positions_per_cycle, len(m.phase_gain)
    (512, 3)
    """
    g = np.random.default_rng(rng)
    s = float(spread)
    m = len(motor.equilibrium)

    def rel(value: float, sd: float) -> float:
        return float(value * (1.0 + s * sd * g.standard_normal()))

    gains = tuple(rel(v, 0.05) for v in motor.phase_gain)
    offsets = tuple(
        float(v + s * 3.0 * motor.positions_per_cycle / 512 * g.standard_normal())
        for v in motor.phase_offset
    )
    assert len(gains) == m
    common = {
        "phase_gain": gains,
        "phase_offset": offsets,
        "peak_torque": rel(motor.peak_torque, 0.08),
        "mutual_saturation": rel(motor.mutual_saturation, 0.1),
    }
    new: Motor
    if isinstance(motor, VariableReluctanceMotor):
        new = dataclasses.replace(
            motor,
            saturation_current=rel(motor.saturation_current, 0.1),
            second_harmonic=rel(motor.second_harmonic, 0.1),
            **common,  # type: ignore[arg-type]
        )
    else:
        assert isinstance(motor, BrushlessDcMotor)
        new = dataclasses.replace(
            motor,
            harmonics=(rel(motor.harmonics[0], 0.1), rel(motor.harmonics[1], 0.1)),
            cogging=rel(motor.cogging, 0.1),
            cogging_phase=float(motor.cogging_phase + s * 0.2 * g.standard_normal()),
            **common,  # type: ignore[arg-type]
        )
    amp = dataclasses.replace(
        amplifier,
        dead_band=max(0.0, float(amplifier.dead_band + s * 4.0 * g.standard_normal())),
        curve=float(amplifier.curve + s * 0.2 * g.standard_normal()),
        current_limit=min(amplifier.current_max, rel(amplifier.current_limit, 0.03)),
    )
    return new, amp
