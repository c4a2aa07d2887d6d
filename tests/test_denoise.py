"""Low-rank denoising of characterisation blocks against surfaces known in closed form."""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.linearize.collect import collect_characterisation
from torquemap.linearize.denoise import denoise_blocks, restore_misfit
from torquemap.linearize.motor import motor_spec
from torquemap.linearize.tables import build_tables, read_data
from torquemap.sim.family import paper_bench
from torquemap.sim.rig import SimRig


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


def _misfit_case(
    misfit: float, seed: int, sigma: float = 0.02
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """60 blocks x 64 levels (every 4th pulse width), a knee at 40, a low-rank fit that misses
    ``misfit`` [N m] on blocks 20 to 39 above level 120 (the truth there is fit + misfit),
    rows with noise ``sigma``. Returns levels, blocks, fit, truth and the rows."""
    rng = np.random.default_rng(seed)
    levels = np.tile(np.arange(0, 253, 4), 60)
    block = np.repeat(np.arange(60), 64)
    fit = np.maximum(levels - 40.0, 0.0) / 100.0
    truth = fit + misfit * ((block >= 20) & (block < 40) & (levels >= 120))
    return levels, block, fit, truth, truth + rng.normal(0.0, sigma, truth.size)


def test_restore_misfit_reaches_the_wiener_error() -> None:
    """Closed form: for a residual ``noise - m`` (noise sigma, misfit m) the best weight of the
    readings over the fit is ``m^2 / (m^2 + sigma^2)``, whose expected squared error is
    ``m^2 sigma^2 / (m^2 + sigma^2)``; the fit alone errs by ``m``, the readings by sigma."""
    sigma = 0.02
    for m in (sigma, 3 * sigma):
        levels, block, fit, truth, rows = _misfit_case(m, seed=3)
        out = restore_misfit(levels, rows, fit)
        inner = (block >= 22) & (block < 38) & (levels >= 136)  # the window inside the misfit
        rms = np.sqrt(np.mean((out.torque - truth)[inner] ** 2))
        wiener = m * sigma / np.hypot(m, sigma)
        # the weight is estimated from 21 cells (its own noise costs a little): within 15 % of
        # the optimum (over 20 noise draws at most 12 % above it at m = sigma, 9 % at 3 sigma)
        assert wiener <= rms * 1.02 and rms < 1.15 * wiener
        # the noise read from the censored readings (levels 0 to 40): 11 x 60 of them
        assert_allclose(out.noise, sigma, rtol=0.15)


def test_restore_misfit_keeps_a_right_fit() -> None:
    """Where the fit is the truth the rows stay near it: the residual is noise alone, and the
    weight is positive only where its pooled mean square exceeds sigma^2 by chance (over 20
    draws at most 0.32 sigma rms against sigma for the readings)."""
    sigma = 0.02
    levels, _, fit, truth, rows = _misfit_case(0.0, seed=4, sigma=sigma)
    out = restore_misfit(levels, rows, fit)
    assert np.sqrt(np.mean((out.torque - truth) ** 2)) < 0.35 * sigma
    # the censored rows (where the fit is zero) stay zero
    assert np.all(out.torque[fit == 0.0] == 0.0)


def test_restore_misfit_needs_blocks_and_censored_readings() -> None:
    levels, _, fit, _, rows = _misfit_case(0.0, seed=5)
    shuffled = restore_misfit(levels[::-1], rows[::-1], fit[::-1])
    assert_allclose(shuffled.torque, fit[::-1]) and shuffled.share == 0.0
    lifted = fit + 1.0  # no reading is censored: no noise sample
    out = restore_misfit(levels, rows + 1.0, lifted)
    assert_allclose(out.torque, lifted) and out.noise == 0.0


@pytest.mark.xdist_group("restore_rig")
def test_restored_rows_are_nearer_the_simulated_torque() -> None:
    """A member of the family (VR, 4 phases x 384 positions, narrow ramp, compliance that moves a
    block's top rows across the ramp's hand-overs) collected at the paper's settings twice: with
    the sensor's noise and without it (the same positions: the noise does not move the rig).
    The low-rank fit misses the torque at the top pulse widths by more than a row's noise; the
    restored rows are nearer the noise-free rows there than either, and no farther below."""
    bench = paper_bench(15)
    rig = bench.rig
    spec = rig.motor_spec(ramping=bench.ramping)
    twin = SimRig(rig.motor, rig.amplifier, dataclasses.replace(rig.settings, noise=0.0), rng=15)
    settings = dataclasses.replace(bench.settings, bias_open=True)
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for name, r in (("noisy", rig), ("exact", twin)):
            out = Path(tmp) / f"{name}.csv"
            collect_characterisation(r, spec, out, settings)
            rows.append(read_data(out, spec, kind="characterisation"))
    noisy, exact = rows
    assert np.array_equal(noisy.position, exact.position)
    assert np.array_equal(noisy.level, exact.level)
    # the exact rows less their own bias error: zero where the sensor reads no torque
    truth = exact.torque
    level = noisy.level
    fit = denoise_blocks(level, noisy.torque)
    out = restore_misfit(level, noisy.torque, fit.torque)
    top, low = level >= 160, (level < 96) & (truth > 0.0)

    def rms(v: np.ndarray, where: np.ndarray) -> float:
        return float(np.sqrt(np.mean(v[where] ** 2)))

    raw_top = rms(noisy.torque - truth, top)
    fit_top = rms(fit.torque - truth, top)
    new_top = rms(out.torque - truth, top)
    # measured on this draw: the fit 0.056 N m, the readings 0.025, restored 0.022 at the top
    # (below 96: the fit 0.0125, restored 0.0124)
    assert fit_top > 1.5 * raw_top
    assert new_top < raw_top
    # below, where the fit is good, restoring costs at most a quarter of a row's noise
    assert rms(out.torque - truth, low) < rms(fit.torque - truth, low) + 0.25 * raw_top
