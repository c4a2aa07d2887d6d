"""pdtv: position signal, spectrum, line picking, harmonic fit, notches."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.pdtv import (
    discrete_position_signal,
    fit_harmonics,
    harmonic_normals,
    noise_floor,
    notch_position_signal,
    phasors,
    pick_lines,
    position_spectrum,
    rayleigh_threshold,
    solve_harmonics,
)

BW = 2 * np.pi / 1024


def test_binning_means_and_empty_bins() -> None:
    s = discrete_position_signal([0.1, 0.2, 3.4, 3.6], [1.0, 3.0, 7.0, 9.0], bin_width=1.0)
    # bins [0,1) [1,2) [2,3) [3,4): means 2 and 8, two empty bins interpolated linearly
    assert_allclose(s.value, [2.0, 4.0, 6.0, 8.0])
    assert s.count.tolist() == [2, 0, 0, 2]
    assert_allclose(s.angle, [0.5, 1.5, 2.5, 3.5])
    with pytest.raises(InputError, match="bin width must be positive"):
        discrete_position_signal([0.0], [0.0], bin_width=0.0)
    with pytest.raises(InputError, match="equal length"):
        discrete_position_signal([0.0, 1.0], [0.0], bin_width=1.0)


def test_spectrum_recovers_orders_amplitudes_phases() -> None:
    theta = (np.arange(1024 * 3) + 0.5) * BW
    truth = [(2.0, 0.4, 0.3), (7.0, 0.1, -1.2), (36.0, 0.05, 2.5)]
    y = sum(a * np.cos(o * theta + p) for o, a, p in truth)
    sp = position_spectrum(discrete_position_signal(theta, y, bin_width=BW))
    assert sp.revolutions == 3.0
    for o, a, p in truth:
        k = int(np.argmin(abs(sp.order - o)))
        # integer orders on 3 whole revolutions fall on exact FFT bins: exact to rounding
        assert_allclose([sp.order[k], sp.amplitude[k], sp.phase[k]], [o, a, p], atol=1e-9)
    with pytest.raises(InputError, match="half of one"):
        position_spectrum(discrete_position_signal(theta[:100], y[:100], bin_width=BW))


def test_picking_finds_true_lines_and_none_on_noise() -> None:
    rng = np.random.default_rng(4)
    theta = np.sort(rng.uniform(0.0, 4 * 2 * np.pi, 40000))
    truth = {3.0: 0.05, 12.0: 0.03, 84.0: 0.02}
    clean = sum(a * np.cos(o * theta + o) for o, a in truth.items())
    y = clean + rng.normal(0.0, 0.2, theta.size)
    picks = pick_lines(position_spectrum(discrete_position_signal(theta, y, bin_width=BW)))
    assert set(picks.order.tolist()) == set(truth)
    false = 0
    for seed in range(50):
        noise = np.random.default_rng(100 + seed).normal(0.0, 0.2, theta.size)
        s = position_spectrum(discrete_position_signal(theta, noise, bin_width=BW))
        false += pick_lines(s).order.size > 0
    # designed false-alarm rate 1 % per spectrum; the floor is itself estimated (a running
    # median of 101 orders), which measured ~3 % over 100 spectra: allow 4 in 50 (P ~ 0.05)
    assert false <= 4


def test_a_comb_at_one_fractional_part_is_not_picked_but_real_fractional_lines_are() -> None:
    # 8 revolutions: orders every 1/8 CPR are searched. Noise that repeats in time rather than
    # in angle lifts one fractional part of every order (a comb at k + 0.75 here, each line of
    # Rayleigh amplitude 2.5 times the white floor); real lines at 5 and 12.5 CPR (a gear
    # stage) stand well above the white floor
    rng = np.random.default_rng(11)
    bw = 2 * np.pi / 512
    theta = (np.arange(512 * 8) + 0.5) * bw
    sigma = 0.1
    white = sigma * np.sqrt(2.0 / theta.size)  # Rayleigh scale of white noise's amplitudes
    y = rng.normal(0.0, sigma, theta.size)
    y += 0.05 * np.cos(5.0 * theta + 0.3) + 0.04 * np.cos(12.5 * theta - 1.0)
    comb = np.arange(1, 200) + 0.75
    y += sum(
        a * np.cos(o * theta + p)
        for o, a, p in zip(
            comb,
            rng.rayleigh(2.5 * white, comb.size),
            rng.uniform(-np.pi, np.pi, comb.size),
            strict=True,
        )
    )
    spectrum = position_spectrum(discrete_position_signal(theta, y, bin_width=bw))
    picks = pick_lines(spectrum)
    assert sorted(picks.order.tolist()) == [5.0, 12.5]
    # the floor of all orders alone would have picked part of the comb: the test can fail
    alone = spectrum.amplitude > rayleigh_threshold(spectrum.order.size) * noise_floor(spectrum)
    assert np.sum(alone & np.isin(spectrum.order, comb)) >= 3


def test_phasors_are_the_exponentials() -> None:
    # powers of exp(i theta) for integer orders, direct for the others; the closed form
    # exp(i k theta) loses k |theta| units in the last place in its argument (1e-9 rad at
    # 48 x 2e4 rad), the powers about k: both within 1e-9 of each other
    theta = np.random.default_rng(2).uniform(-2e4, 2e4, 1000)
    orders = [1.0, 2.0, 3.0, 21.0, 48.0, 0.75, 12.5]
    got = phasors(theta, orders)
    assert got.shape == (len(orders), theta.size)
    assert_allclose(got, np.exp(1j * np.outer(orders, theta)), rtol=0, atol=1e-9)


def test_harmonic_fit_on_noisy_samples() -> None:
    rng = np.random.default_rng(5)
    theta = rng.uniform(0.0, 20.0, 20000)
    groups = (theta > 10).astype(int)
    y = 0.3 * np.cos(5 * theta + 0.7) + np.where(groups == 1, 1.0, -1.0)
    y = y + rng.normal(0.0, 0.05, theta.size)
    fit = fit_harmonics(theta, y, orders=[5.0], groups=groups)
    # standard error ~ 0.05*sqrt(2/20000) = 5e-4: 5 sigma
    assert_allclose(fit.amplitude, [0.3], atol=2.5e-3)
    assert_allclose(fit.phase, [0.7], atol=1e-2)
    assert_allclose(fit.offsets, [-1.0, 1.0], atol=2.5e-3)
    assert_allclose(fit.amplitude_se, 0.05 * np.sqrt(2 / 20000), rtol=0.1)


@settings(max_examples=20, deadline=None)
@given(order=st.integers(5, 100), far=st.integers(150, 400))
def test_notch_kills_its_order_and_passes_others(order: int, far: int) -> None:
    theta = (np.arange(1024 * 8) + 0.5) * BW
    s = discrete_position_signal(theta, np.cos(order * theta) + np.cos(far * theta), bin_width=BW)
    y = notch_position_signal(s, orders=[float(order)], width=0.5)
    # ~0 gain at the order, ~1 far from it (periodic extension leaves no end transient)
    assert_allclose(y, np.cos(far * s.angle), atol=0.02)


def test_notch_skips_orders_above_nyquist() -> None:
    theta = (np.arange(1024) + 0.5) * BW
    s = discrete_position_signal(theta, np.cos(3 * theta), bin_width=BW)
    assert_allclose(notch_position_signal(s, orders=[600.0]), s.value)
    with pytest.raises(InputError, match="notch width"):
        notch_position_signal(s, orders=[3.0], width=0.0)


def test_harmonic_fit_is_the_same_for_groups_in_runs_and_shuffled() -> None:
    # groups in runs take per-run sums, shuffled ones per-label counts: the same normal
    # equations summed in another order (1e-12: rounding)
    rng = np.random.default_rng(6)
    theta = rng.uniform(0.0, 30.0, 50000)
    groups = np.repeat([2, 5, 9, 40], 12500)
    y = 0.2 * np.cos(3 * theta) + 0.1 * np.sin(7 * theta) + groups * 0.01
    y = y + rng.normal(0.0, 0.1, theta.size)
    runs = fit_harmonics(theta, y, orders=[3.0, 7.0], groups=groups, chunk=7000)
    perm = rng.permutation(theta.size)
    mixed = fit_harmonics(theta[perm], y[perm], orders=[3.0, 7.0], groups=groups[perm])
    assert_allclose(runs.cos_sin, mixed.cos_sin, rtol=0, atol=1e-12)
    assert_allclose(runs.offsets, mixed.offsets, rtol=0, atol=1e-12)
    assert_allclose(runs.residual_rms, mixed.residual_rms, rtol=1e-12)
    assert_allclose(runs.offsets, [0.02, 0.05, 0.09, 0.40], atol=5e-3)  # 5 sigma of 1e-3


def test_one_pass_of_normal_equations_fits_every_subset() -> None:
    # identify fits all picked orders, then the kept ones, then each direction: from one
    # accumulation, each equals a fit of its own (the same sums grouped otherwise: 1e-12)
    rng = np.random.default_rng(9)
    theta = np.concatenate([np.linspace(0.0, 40.0, 30000), np.linspace(40.0, 0.0, 30000)])
    groups = np.repeat([0, 1, 2, 3], 15000)
    up = np.repeat([1, 1, 0, 0], 15000)
    y = 0.3 * np.cos(2 * theta + 0.5) + np.where(up == 1, 0.05, 0.08) * np.cos(9 * theta)
    y = y + groups * 0.01 + rng.normal(0.0, 0.05, theta.size)
    normals = harmonic_normals(theta, y, orders=[2.0, 5.0, 9.0], groups=groups, split=up)
    for orders, part in (
        ([2.0, 5.0, 9.0], None),
        ([2.0, 9.0], None),
        ([9.0, 2.0], [1]),
        ([2.0, 9.0], [0]),
    ):
        got = solve_harmonics(normals, orders=orders, parts=part)
        use = np.ones(theta.size, bool) if part is None else np.isin(up, part)
        ref = fit_harmonics(theta[use], y[use], orders=orders, groups=groups[use])
        assert_allclose(got.order, orders)
        assert_allclose(got.cos_sin, ref.cos_sin, rtol=0, atol=1e-12)
        assert_allclose(got.covariance, ref.covariance, rtol=1e-9, atol=0)
        assert_allclose(got.offsets, ref.offsets, rtol=0, atol=1e-12)
        assert_allclose(got.residual_rms, ref.residual_rms, rtol=1e-9)
    # the directions' own amplitudes of order 9 (0.05 up, 0.08 down), 5 standard errors
    up_fit = solve_harmonics(normals, orders=[9.0], parts=[1])
    down_fit = solve_harmonics(normals, orders=[9.0], parts=[0])
    assert_allclose([up_fit.amplitude[0], down_fit.amplitude[0]], [0.05, 0.08], atol=3e-3)
    with pytest.raises(InputError, match="not in the accumulated"):
        solve_harmonics(normals, orders=[3.0])
