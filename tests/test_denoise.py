"""Low-rank denoising of characterisation blocks against surfaces known in closed form."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from torquemap.linearize.denoise import denoise_blocks
from torquemap.linearize.motor import motor_spec
from torquemap.linearize.tables import build_tables


def _blocks(
    rng: np.random.Generator, *, noise: float, blocks: int = 64, top: int = 252
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A collection run in file order: per block, levels 0, 4, ... up to saturation."""
    pos, lev, clean = [], [], []
    for b in range(blocks):
        p = 2 * b
        gain = 1.0 + 0.4 * np.cos(2 * np.pi * p / 128) + 0.1 * np.sin(6 * np.pi * p / 128)
        levels = np.arange(0, top + 1, 4)
        torque = gain * 10.0 * (levels / top) ** 2
        keep = torque <= 12.0  # the sensor saturates above 12 N m: blocks end early
        pos += [p] * int(keep.sum())
        lev += list(levels[keep])
        clean += list(torque[keep])
    c = np.array(clean)
    return np.array(pos), np.array(lev), c, c + rng.normal(0.0, noise, c.size)


def test_blocks_are_denoised_and_saturated_tails_imputed() -> None:
    rng = np.random.default_rng(1)
    _, lev, clean, noisy = _blocks(rng, noise=0.05)
    out = denoise_blocks(lev, noisy)
    assert out.blocks == 64 and out.rank >= 1 and out.reason == ""
    # 64 blocks x 64 levels, a surface of rank 1: the error falls far below the noise
    assert np.sqrt(np.mean((out.torque - clean) ** 2)) < 0.3 * 0.05


def test_rows_without_block_structure_are_left_alone() -> None:
    rng = np.random.default_rng(2)
    _, lev, _, noisy = _blocks(rng, noise=0.05)
    order = rng.permutation(lev.size)
    out = denoise_blocks(lev[order], noisy[order])
    assert out.rank == 0 and "blocks" in out.reason
    assert_allclose(out.torque, noisy[order])
    few = denoise_blocks(lev[:100], noisy[:100])  # two blocks: nothing to threshold
    assert few.rank == 0


def test_denoised_tables_deliver_the_true_torque_better() -> None:
    rng = np.random.default_rng(3)
    spec = motor_spec(
        "m", phases=1, positions_per_cycle=128, equilibrium_positions=(0,), actuation_max=255
    )
    pos, lev, _, noisy = _blocks(rng, noise=0.08, top=255)

    def true_torque(p: np.ndarray, a: np.ndarray) -> np.ndarray:
        gain = 1.0 + 0.4 * np.cos(2 * np.pi * p / 128) + 0.1 * np.sin(6 * np.pi * p / 128)
        return gain * 10.0 * (a / 255) ** 2

    def error(tables: object) -> float:
        # mean relative deviation of the true torque through the tables at the measured
        # positions, commands 1 .. 127: what Eq 1 measures, without a sensor
        p = np.unique(pos)[:, None]
        c = np.arange(1, 128)[None, :]
        got = true_torque(p, tables.phases[0][p, c].astype(float))  # type: ignore[attr-defined]
        want = c * tables.torque_per_count  # type: ignore[attr-defined]
        return float(np.mean(np.abs(got - want) / want))

    plain = build_tables(spec, pos, lev, noisy, denoise=False)
    cleaned = build_tables(spec, pos, lev, noisy)
    assert plain.denoise_rank == 0 and cleaned.denoise_rank >= 1
    assert error(cleaned) < 0.7 * error(plain)


def test_structure_above_the_noise_spectrum_is_kept() -> None:
    # a smooth surface plus a small step (5x the noise) at a different level in every block,
    # like narrow ramping's phase hand-over: its singular values sink into the noise bulk; the
    # rank must grow until the residual is free of structure, and the fit must beat the rows
    rng = np.random.default_rng(4)
    levels = np.arange(0, 256, 4)
    centre = rng.uniform(40, 220, 64)
    clean = np.concatenate(
        [3.0 * (levels / 255) ** 2 + 0.1 / (1 + np.exp(-(levels - c) / 6.0)) for c in centre]
    )
    noisy = clean + rng.normal(0.0, 0.02, clean.size)
    out = denoise_blocks(np.tile(levels, 64), noisy)
    rms = lambda x: float(np.sqrt(np.mean((x - clean) ** 2)))  # noqa: E731
    assert rms(out.torque) < 0.7 * rms(noisy)


def test_friction_knee_is_fitted_as_censored_data() -> None:
    # the sensor reads zero until the motor's torque overcomes a friction of 1 N m, a knee
    # whose pulse width moves from block to block (no low-rank matrix has such a kink); the
    # torque before the knee is low rank, and the zero readings only bound it from above
    rng = np.random.default_rng(4)
    blocks, levels = 64, np.arange(0, 256, 4)
    gain = 1.0 + 0.4 * np.cos(2 * np.pi * np.arange(blocks) / blocks)
    motor = gain[:, None] * 10.0 * (levels[None, :] / 252.0) ** 2
    clean = np.maximum(motor - 1.0, 0.0)
    noisy = clean + rng.normal(0.0, 0.05, clean.shape)
    out = denoise_blocks(np.tile(levels, blocks), noisy.ravel())
    fit = out.torque.reshape(blocks, levels.size)
    assert out.rank == 2  # motor torque minus friction: rank 2 once the knee is censored
    assert fit.min() >= 0.0
    knee = (clean > 0.0) & (clean < 1.0)  # the low commands, where relative errors count
    # a plain rank-3 fit of the readings leaves 0.44 to 0.50 of the noise here (seeds 4 to 9)
    assert np.sqrt(np.mean((fit - clean)[knee] ** 2)) < 0.4 * 0.05


def test_truncation_equals_the_truncated_svd() -> None:
    from torquemap.linearize.denoise import _truncate

    rng = np.random.default_rng(5)
    for shape in ((96, 40), (30, 70)):
        signal = np.outer(rng.normal(size=shape[0]), rng.normal(size=shape[1])) * 5.0
        a = signal + rng.normal(size=shape)
        u, s, vt = np.linalg.svd(a, full_matrices=False)
        for rank in (1, 4, 12):
            assert_allclose(_truncate(a, rank), (u[:, :rank] * s[:rank]) @ vt[:rank], atol=1e-9)


def test_blocks_are_re_zeroed_on_their_censored_readings() -> None:
    # each block's rows carry the error of the bias subtracted from them, here as large as a
    # row's noise (the bias measured with as many readings as a row: bias_weight 1); the zero
    # readings before the knee measure it, and the fit must remove it
    rng = np.random.default_rng(7)
    blocks, levels = 64, np.arange(0, 256, 4)
    gain = 1.0 + 0.4 * np.cos(2 * np.pi * np.arange(blocks) / blocks)
    clean = np.maximum(gain[:, None] * 10.0 * (levels[None, :] / 252.0) ** 2 - 1.0, 0.0)
    bias_error = rng.normal(0.0, 0.05, blocks)
    noisy = clean + rng.normal(0.0, 0.05, clean.shape) - bias_error[:, None]
    out = denoise_blocks(np.tile(levels, blocks), noisy.ravel(), bias_weight=1.0)
    assert out.rank >= 1
    fit = out.torque.reshape(blocks, levels.size)
    knee = (clean > 0.0) & (clean < 1.0)
    rms = lambda x: float(np.sqrt(np.mean((x - clean)[knee] ** 2)))  # noqa: E731
    assert rms(noisy) > 1.3 * 0.05  # the rows: noise and bias error
    assert rms(fit) < 0.75 * 0.05  # seeds 6 to 11: 0.35 to 0.68 of one row's noise
    # the bias measurement ignored (weight 0): blocks without censored readings stay put
    alone = denoise_blocks(np.tile(levels, blocks), noisy.ravel(), bias_weight=0.0)
    assert alone.rank >= 1 and np.isfinite(alone.torque).all()
