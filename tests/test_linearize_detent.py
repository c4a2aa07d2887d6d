"""The torque at rest between measured positions (torquemap.linearize.detent).

Surfaces in closed form: four phases with smooth gains, a torque linear in the actuation past a
dead zone, and a cogging torque of known period; measured every 4th position.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from torquemap.linearize.detent import detent_correction, fit_detent
from torquemap.linearize.metrics import apmd_report
from torquemap.linearize.motor import MotorSpec, motor_spec, ramped_actuation
from torquemap.linearize.tables import build_tables

A = 255
N = 128


def _spec() -> MotorSpec:
    return motor_spec("t", phases=4, positions_per_cycle=N, equilibrium_positions=(0, 32, 64, 96))


def _torque(
    spec: MotorSpec, p: NDArray[np.int64], u: NDArray[np.float64], cogging: float
) -> NDArray[np.float64]:
    """Phases G_k(p) max(a_k - 10, 0) / A plus cogging of 12 periods per cycle, minus 0.2."""
    a = ramped_actuation(u, p, spec.ramp).astype(np.float64)
    k = np.arange(spec.phases)
    gain = 10.0 * (1.5 + np.sin(2 * np.pi * (p[..., None] - 32 * k) / N + 1.0))
    rest = cogging * np.sin(2 * np.pi * 12 * p / N + 0.7)
    out: NDArray[np.float64] = np.sum(gain * np.maximum(a - 10.0, 0.0), axis=-1) / A
    return np.maximum(out + rest - 0.2, 0.0)


def _measured(spec: MotorSpec, cogging: float) -> NDArray[np.float64]:
    mean = np.full((N, 64), np.nan)
    p = np.arange(0, N, 4)[:, None]
    mean[::4] = _torque(spec, p, np.arange(0.0, 256.0, 4.0)[None, :], cogging)
    return mean


def test_fit_finds_the_cogging_period_and_its_shape() -> None:
    spec = _spec()
    fit = fit_detent(_measured(spec, 0.4), np.asarray(spec.ramp), np.arange(0, N, 4))
    assert fit.harmonics[0] == 12  # 12 periods per cycle, sampled 2.7 times per period
    truth = 0.4 * np.sin(2 * np.pi * 12 * np.arange(N) / N + 0.7)
    anchors = np.arange(0, N, 4)
    got = detent_correction(fit.torque, anchors)
    want = detent_correction(truth, anchors)
    assert np.all(got[anchors] == 0.0)
    # what the linear interpolation misses (up to 0.24 N m here) is restored within 0.05 N m
    assert np.abs(want).max() > 0.2
    assert np.abs(got - want).max() < 0.05


def test_no_cogging_no_correction_that_matters() -> None:
    spec = _spec()
    anchors = np.arange(0, N, 4)
    fit = fit_detent(_measured(spec, 0.0), np.asarray(spec.ramp), anchors)
    assert fit.equations >= 6
    # the friction's share of the offsets (1 - g) F is not modelled: noise-free, it is taken
    # for harmonics of the phase pattern, of a negligible size (measured 0.0004 N m against a
    # torque of 25 N m)
    assert np.abs(detent_correction(fit.torque, anchors)).max() < 1e-3


def test_tables_with_the_detent_are_closer_to_linear() -> None:
    spec = _spec()
    p, w = np.meshgrid(np.arange(0, N, 4), np.arange(0, A + 1, 4), indexing="ij")
    tau = _torque(spec, p.ravel(), w.ravel().astype(np.float64), 0.4)

    def apmd(detent: bool) -> float:
        t = build_tables(spec, p.ravel(), w.ravel(), tau, denoise=False, onset=False, detent=detent)
        assert (t.detent_harmonics[:1] == (12,)) == detent
        act = np.moveaxis(t.phases[:, :, : t.command_max + 1], 0, -1)  # (P, C + 1, m)
        k = np.arange(spec.phases)
        pp = np.arange(N)[:, None]
        gain = 10.0 * (1.5 + np.sin(2 * np.pi * (pp[..., None] - 32 * k) / N + 1.0))
        rest = 0.4 * np.sin(2 * np.pi * 12 * pp / N + 0.7)
        got = np.maximum(np.sum(gain * np.maximum(act - 10.0, 0.0), axis=-1) / A + rest - 0.2, 0)
        pc, cc = np.meshgrid(np.arange(N), np.arange(t.command_max + 1), indexing="ij")
        return apmd_report(
            pc.ravel(), cc.ravel(), got.ravel(), command_max=t.command_max, positions_per_cycle=N
        ).apmd

    with_detent, without = apmd(True), apmd(False)
    assert with_detent < 0.8 * without  # measured 2.54 % against 3.37 %
