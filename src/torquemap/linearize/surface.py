"""A structured model of the whole torque surface, fitted to every reading at once.

What the rig senses at table position ``p`` with base pulse width ``u`` is modelled as

``sensed(p, u) = max(o(p) + sum_k S_k(p) phi(a_k), 0) + b(p)``,  ``a_k = rint(r_k(p) u)``,

* ``phi`` the torque's rise with a phase's actuation (amplifier dead zone and curve, torque ~
  current squared or ~ current, saturation): one curve shared by every phase and position,
  ``phi(0) = 0``, ``phi(A) = 1``, non-decreasing, on knots every two pulse-width units with a
  penalty on its curvature; below the actuations that read torque it follows the onset law
  ``alpha max(a - d, 0)^n`` of :mod:`torquemap.linearize.onset` (the readings there are
  zero, and a free ``phi`` would trade with ``o``);
* ``S_k(p)`` phase ``k``'s torque at full actuation: smooth over the cycle (a penalty on its
  second difference), so that between measured positions, and where a phase's ramp switches
  on or off between them, it follows the neighbouring positions;
* ``o(p)`` the torque at rest less the friction: free at every measured position; between the
  measured positions a Fourier series of one or more harmonics (kept while their
  leave-one-out error falls: cogging repeats many times per cycle) plus the linear
  interpolation of what it misses;
* ``b(p)`` the error of the bias subtracted from the position's block, read where the model is
  below zero (the sensor's zero), weighed against the bias measurement;
* ``r_k(p)`` the ramp (known), and ``max(., 0)`` the sensor's zero below the friction;
* optionally (``coupling``) the phases' mutual saturation: each phase's term times
  ``1 - kappa sum_{j != k} phi(a_j)``, one ``kappa`` for the motor (``"checked"``: kept only
  where it lowers the cells' misfit beyond the fit's own spread, an F statistic against the
  fit without it).

It is fitted by alternating least squares (``S`` and ``o`` given ``phi``, then ``phi`` given
them by non-negative least squares, then ``b``) until the residual sum of squares changes by
less than a thousandth (at most 40 rounds). What the model misses at the measured cells
(the phases' mutual saturation, the residual shape) is added back by the table builder,
interpolated between the measured cells, so the surface passes through the data where it was
measured and takes its shape between from the physics.

This module never imports the simulator.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.optimize import nnls
from scipy.sparse.linalg import spsolve
from scipy.stats import f as f_distribution

from torquemap.linearize.detent import loo_press
from torquemap.linearize.gaps import check_gaps, fourier_design
from torquemap.linearize.onset import onset_psi

#: Most alternating least-squares rounds.
ROUNDS = 40
#: The rounds stop when the residual sum of squares changes by less than this fraction.
TOLERANCE = 1e-3
# the fitted coupling is kept only where it lowers the cells' misfit by more than this F
# statistic. Not F(1, dof)'s 9 (three standard errors): the coupled and the plain fit each stop
# where an alternating round changes the misfit by under TOLERANCE, not at the same optimum, and
# on a closed-form surface without coupling (tests/test_linearize_coupling.py, sensor noise
# 0.05 to 0.2 N m, 60 draws) the statistic spread from -33 to +37 (sd about 17): 50 is three
# of those spreads
COUPLING_F = 50.0
#: The level of :func:`hidden_wave`'s F test (the Nyquist wave between the anchors).
NYQUIST_LEVEL = 1e-3
#: Pulse-width units between the knots of ``phi``.
PHI_KNOT_STEP = 2


@dataclass(frozen=True, slots=True, eq=False)
class SurfaceFit:
    """The structured surface.

    Attributes
    ----------
    phi
        ``phi`` at every actuation ``0 .. A``, shape (A + 1,).
    gain
        ``S_k(p)`` [N m], shape (P, m).
    rest
        ``o(p)`` [N m], shape (P,).
    rms
        Root-mean-square residual of the fitted cells [N m].
    offset
        The sensor's offset left in each position's readings (the bias error of its block)
        [N m], shape (P,): read where the model is below zero.
    series
        How ``o`` was carried between the measured positions (its harmonics, and where the
        data could not hold one it asked for).
    coupling
        ``kappa``, the phases' mutual saturation (0 unless fitted and kept).
    coupling_f
        The F statistic of the coupling term (0 unless ``coupling="checked"``): the fall in the cells' sum of
        squared misfits from the fit without it, over the coupled fit's residual variance;
        ``kappa`` is kept only where it exceeds :data:`COUPLING_F`, else the fit without it.
    nyquist_f, nyquist_dof
        With ``nyquist``: the F statistic of the Nyquist wave between the anchors (its two
        columns of :func:`rest_basis`) given the final ``phi``, against the fit without them,
        and the data's degrees of freedom (:func:`hidden_wave`); 0 otherwise.
    nyquist_amplitude
        With ``nyquist``: the wave's amplitude between the anchors [N m]; 0 otherwise.
    """

    phi: NDArray[np.float64]
    gain: NDArray[np.float64]
    rest: NDArray[np.float64]
    rms: float
    offset: NDArray[np.float64]
    series: RestSeries | None = None
    coupling: float = 0.0
    coupling_f: float = 0.0
    nyquist_f: float = 0.0
    nyquist_dof: int = 0
    nyquist_amplitude: float = 0.0


def _second_difference(n: int) -> sp.csr_matrix:
    i = np.arange(n)
    rows = np.concatenate([i, i, i])
    cols = np.concatenate([(i - 1) % n, i, (i + 1) % n])
    vals = np.concatenate([np.ones(n), -2 * np.ones(n), np.ones(n)])
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


#: A Fourier term of the torque at rest is kept only while the series' prediction at every
#: table position has at most this variance, in units of one measured position's: a
#: prediction between measured positions twice as uncertain as a measurement (in standard
#: deviation) is not what the measured positions hold.
LEVERAGE_MAX = 4.0


@dataclass(frozen=True, slots=True, eq=False)
class RestSeries:
    """``o`` on every position, the harmonics of its Fourier part (amplitudes [N m]) and the
    median amplitude of a harmonic fitted to noise alone; :meth:`unheld_at` tells where the
    measured positions do not hold the ripple."""

    rest: NDArray[np.float64]
    harmonics: tuple[int, ...]
    amplitudes: tuple[float, ...]
    noise_amplitude: float

    def unheld_at(
        self, anchors: NDArray[np.int64], *, matters: float
    ) -> tuple[NDArray[np.bool_], float]:
        """The positions inside the widest gaps between measured positions when the torque at
        rest's interpolation across them errs by ``matters`` [N m] or more, at a stated
        false-alarm rate (:func:`torquemap.linearize.gaps.check_gaps`), and the shortest
        period of the series [table positions]."""
        n = self.rest.size
        test = check_gaps(self.rest, anchors, self.harmonics, n, matters=matters)
        period = n / max(self.harmonics) if self.harmonics else 2.0 * test.width
        return test.unheld, float(period)


class _Columns:
    """The columns of :func:`torquemap.linearize.gaps.fourier_design` over positions ``p`` for
    the harmonics 1 .. ``top``, computed once (the same products and cosines, element for
    element): :meth:`design` is ``fourier_design(p, harmonics, n)`` bit for bit, without the
    trigonometry of every trial's design again."""

    def __init__(self, p: NDArray[np.float64], top: int, n: int) -> None:
        table = fourier_design(p, range(1, top + 1), n)
        self.ones = table[:, :1]
        self.cos = table[:, 1 : top + 1]
        self.sin = table[:, top + 1 :]

    def design(self, harmonics: list[int]) -> NDArray[np.float64]:
        """``fourier_design(p, harmonics, n)``."""
        h = np.asarray(harmonics, dtype=np.int64) - 1
        return np.concatenate([self.ones, self.cos[:, h], self.sin[:, h]], axis=1)


def _leverage(columns: _Columns, harmonics: list[int], every: _Columns) -> NDArray[np.float64]:
    """Variance of the series' prediction at every position, in units of one sample's
    (``columns``: the anchors', ``every``: every position's)."""
    design = columns.design(harmonics)
    at_every = every.design(harmonics)
    inverse = np.linalg.pinv(design.T @ design)
    out: NDArray[np.float64] = np.einsum("ij,jk,ik->i", at_every, inverse, at_every)
    return out


def _interpolate_rest(rest: NDArray[np.float64], anchors: NDArray[np.int64], n: int) -> RestSeries:
    """``o`` between the anchors: harmonics kept while their leave-one-out error falls (one
    fundamental and its multiples first, as cogging repeats), the rest linear.

    The leave-one-out error sees the anchors only. On unevenly spaced anchors (an adaptive
    collection, a grid with positions missing) the dense stretches can fix a set of harmonics
    that a wide gap does not: the series then swings freely inside the gap (seed 11 of the
    family, an adaptive collection: 1.9 N m four positions from a measured one, where the
    ripple is 0.4 N m peak to peak). A harmonic is therefore kept only while the series'
    prediction variance stays below ``LEVERAGE_MAX`` times one sample's at every position;
    the next best by fit is tried instead."""
    x = anchors.astype(np.float64)
    y = rest[anchors]
    top = (anchors.size - 1) // 2
    kept: list[int] = []
    best, coef = loo_press(np.ones((x.size, 1)), y)
    columns = _Columns(x, top, n)
    every = _Columns(np.arange(n, dtype=np.float64), top, n)
    while 2 * len(kept) + 3 < anchors.size:
        trials = []
        for h in range(1, top + 1):
            if h in kept:
                continue
            d = columns.design([*kept, h])
            sol, *_ = np.linalg.lstsq(d, y, rcond=None)
            rr = y - d @ sol
            trials.append((float(rr @ rr), h))
        chosen = None
        for _, h in sorted(trials):
            lev = _leverage(columns, [*kept, h], every)
            if lev.max() <= LEVERAGE_MAX:
                chosen = h
                break
        if chosen is None:
            break
        press, sol = loo_press(columns.design([*kept, chosen]), y)
        if not press < best:
            break
        best, coef = press, sol
        kept.append(chosen)
    allp = np.arange(n, dtype=np.float64)
    smooth = fourier_design(allp, kept, n) @ coef
    resid = y - fourier_design(x, kept, n) @ coef
    ext = np.concatenate([anchors - n, anchors, anchors + n])
    out = smooth + np.interp(allp, ext, np.tile(resid, 3))
    out[anchors] = y
    pairs = coef[1:].reshape(2, -1) if kept else np.zeros((2, 0))
    amplitude = np.hypot(pairs[0], pairs[1])
    # the median amplitude of a harmonic fitted to noise alone (Rayleigh, scale
    # sigma sqrt(2 / K)), sigma from the leave-one-out residuals
    noise = 1.177 * np.sqrt(best / y.size) * np.sqrt(2.0 / y.size)
    return RestSeries(out, tuple(kept), tuple(amplitude.tolist()), float(noise))


def carried_shape(rest: NDArray[np.float64], anchors: NDArray[np.int64]) -> NDArray[np.float64]:
    """``o`` less its cyclic linear interpolation through the anchors: zero at the anchors, the
    shape its series carries between them (``fit_surface``'s ``carried``), shape (P,).

    Examples
    --------
    >>> np.round(carried_shape(np.array([0.0, 1.0, 0.0, -1.0]), np.array([0, 2])), 6).tolist()
    [0.0, 1.0, 0.0, -1.0]
    """
    n = rest.size
    ext = np.concatenate([anchors - n, anchors, anchors + n])
    out: NDArray[np.float64] = rest - np.interp(np.arange(n), ext, np.tile(rest[anchors], 3))
    return out


def rest_basis(anchors: NDArray[np.int64], n: int) -> sp.csr_matrix | None:
    """``o`` on every position from its values at the ``K`` anchors and one more harmonic.

    Columns ``0 .. K - 1``: the linear interpolation (cyclic) of the anchors' values; columns
    ``K, K + 1``: the cosine and the sine of the anchors' Nyquist harmonic (``K / 2`` periods per
    cycle, two anchors a period) less their own interpolation, so zero at every anchor. The
    anchors alone see the sine at zero and the cosine as an alternation; the rows the rig's
    compliance moved between them read both.

    Parameters
    ----------
    anchors
        The measured positions, ascending, shape (K,).
    n
        Positions per cycle.

    Returns
    -------
    scipy.sparse.csr_matrix or None
        Shape (n, K + 2); None unless the anchors are evenly spaced with ``K`` even and at
        least 4.

    Examples
    --------
    >>> b = rest_basis(np.arange(0, 16, 4), 16).toarray()
    >>> b.shape, b[4].tolist()
    ((16, 6), [0.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    >>> np.round(b[2], 6).tolist()  # half way: the mean of two anchors, the sine at its peak
    [0.5, 0.5, 0.0, 0.0, 0.0, 1.0]
    """
    k = anchors.size
    if k < 4 or k % 2 or n % k:
        return None
    if not np.array_equal(anchors, anchors[0] + np.arange(k) * (n // k)):
        return None
    step = n // k
    p = np.arange(n)
    j = ((p - anchors[0]) % n) // step
    frac = ((p - anchors[0]) % n - j * step) / step
    rows = np.r_[p, p]
    cols = np.r_[j, (j + 1) % k]
    vals = np.r_[1 - frac, frac]
    lin = sp.csr_matrix((vals, (rows, cols)), shape=(n, k))
    x = 2 * np.pi * (k // 2) * p / n
    wave = np.c_[np.cos(x), np.sin(x)]
    wave = wave - lin @ wave[anchors]
    return sp.hstack([lin, sp.csr_matrix(wave)], format="csr")


def _lift(
    kx: NDArray[np.float64], d: float, n: float, join: float, curve: float = 0.0
) -> NDArray[np.float64]:
    """Knot values from non-negative parameters: ``alpha`` times the onset law up to the
    join, then ``alpha`` plus the running sum of non-negative steps."""
    low = kx <= join
    out = np.zeros((kx.size, 1 + int((~low).sum())))
    if curve == 0.0:
        law = (np.maximum(kx - d, 0.0) / max(join - d, 1e-9)) ** n
    else:
        top = float(kx[-1])
        law = onset_psi(kx, d, n, top, curve) / max(
            float(onset_psi(np.array([join]), d, n, top, curve)[0]), 1e-300
        )
    out[:, 0] = np.where(low, law, 1.0)
    free = np.flatnonzero(~low)
    for i, j in enumerate(free):
        out[j:, 1 + i] = 1.0
    return out


def _hat(
    a: NDArray[np.float64], step: int, knots: int
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Left knot index and weight of the right knot for piecewise-linear interpolation."""
    x = np.clip(a / step, 0, knots - 1 - 1e-9)
    j = np.floor(x).astype(np.int64)
    return j, x - j


def _fit_once(
    grid: NDArray[np.float64],
    levels: NDArray[np.float64],
    ramp: NDArray[np.float64],
    *,
    actuation_max: int,
    readable: float,
    dead_zone: float,
    exponent: float,
    curve: float = 0.0,
    bias_weight: float = 10.0,
    smoothness: float = 1.0,
    anchors: NDArray[np.int64] | None = None,
    nyquist: bool = False,
    carried: NDArray[np.float64] | None = None,
    coupling: bool = False,
) -> SurfaceFit:
    """One fit of the structured surface (:func:`fit_surface`), ``kappa`` free or 0."""
    n, m = ramp.shape
    cp, cj = np.nonzero(np.isfinite(grid))
    y = grid[cp, cj]
    u = levels[cj]
    r = ramp[cp]
    a = np.rint(r * u[:, None])  # (cells, m)
    top = float(actuation_max)
    knots = int(np.ceil(top / PHI_KNOT_STEP)) + 1
    kx = np.minimum(np.arange(knots) * PHI_KNOT_STEP, top)
    # start from the onset law over the whole range
    if curve == 0.0:
        phi_k = (np.maximum(kx - dead_zone, 0.0) / max(top - dead_zone, 1.0)) ** exponent
    else:
        phi_k = onset_psi(kx, dead_zone, exponent, top, curve)
    targets = np.unique(cp)
    anchors = np.flatnonzero(np.isfinite(grid[:, 0])) if anchors is None else anchors
    indicator = sp.csr_matrix((np.ones(cp.size), (np.arange(cp.size), cp)), shape=(cp.size, n))
    nf = n
    basis = rest_basis(anchors, n) if nyquist else None
    fixed = np.zeros(cp.size)
    if basis is not None:
        if carried is not None:
            fixed = indicator @ carried
        indicator = (indicator @ basis).tocsr()
        nf = basis.shape[1]
    d2 = _second_difference(n)
    # the penalty in units of the data: a cell weighs 1, S_k's curvature weighs smoothness
    scale = float(np.median(np.bincount(cp)[targets]))
    pen_s = sp.kron(d2, sp.identity(m), format="csr") * np.sqrt(smoothness * scale)
    jj, ww = _hat(a, PHI_KNOT_STEP, knots)

    def phi_at(values: NDArray[np.float64]) -> NDArray[np.float64]:
        return values[jj] * (1 - ww) + values[np.minimum(jj + 1, knots - 1)] * ww

    # the penalty rows below the data (the same in every round): S_k's curvature, o's ridge
    pen = sp.hstack([pen_s, sp.csr_matrix((n * m, nf))], format="csr")
    ridge = sp.hstack(
        [sp.csr_matrix((nf, n * m)), sp.identity(nf, format="csr") * 1e-6], format="csr"
    )
    penalties = sp.vstack([pen, ridge], format="csr")
    gain = np.zeros((n, m))
    kappa = 0.0
    coef_o = np.zeros(nf)
    pred = np.zeros_like(y)
    offset = np.zeros(n)
    last = np.inf
    for _ in range(ROUNDS):
        y_adj = y - offset[cp]
        use = (y_adj > 0.0) | (pred > 0)
        target = y_adj
        f = phi_at(phi_k)  # (cells, m)
        # the phases' mutual saturation: each phase's torque times 1 - kappa (the others' phi)
        share = 1.0 - kappa * (f.sum(axis=1, keepdims=True) - f)
        f = f * share
        # S and o given phi: columns p * m + k, then o at every position
        idx = np.flatnonzero(use)
        rows = np.repeat(np.arange(idx.size), m)
        cols = (cp[idx, None] * m + np.arange(m)[None, :]).ravel()
        vals = f[idx].ravel()
        design_s = sp.csr_matrix((vals, (rows, cols)), shape=(idx.size, n * m))
        design = sp.hstack([design_s, indicator[idx]], format="csr")
        full = sp.vstack([design, penalties], format="csc")
        rhs = np.concatenate([target[idx] - fixed[idx], np.zeros(n * m + nf)])
        lhs = (full.T @ full).tocsc()
        lhs = lhs + sp.identity(lhs.shape[0], format="csc") * 1e-9
        sol = spsolve(lhs, full.T @ rhs)
        gain = sol[: n * m].reshape(n, m)
        coef_o = sol[n * m :]
        o_cells = indicator @ coef_o + fixed
        # phi given S and o: each cell touches two knots per active phase
        g = gain[cp] * share  # (cells, m)
        dphi = np.zeros((idx.size, knots))
        for k in range(m):
            np.add.at(dphi, (np.arange(idx.size), jj[idx, k]), g[idx, k] * (1 - ww[idx, k]))
            np.add.at(
                dphi,
                (np.arange(idx.size), np.minimum(jj[idx, k] + 1, knots - 1)),
                g[idx, k] * ww[idx, k],
            )
        # phi below the join follows the onset law alpha max(a - d, 0)^n (the readings there
        # are censored, and would trade with o); above it rises freely but never falls:
        # phi = lift @ theta with theta >= 0 (non-negative least squares)
        contribution = target[idx] - o_cells[idx]
        held = contribution > readable
        lowest = float(np.percentile(a[idx][held].max(axis=1), 2)) if held.any() else top / 2
        lift = _lift(kx, dead_zone, exponent, max(dead_zone + 8.0, lowest), curve)
        dth = dphi @ lift
        s2 = float(np.mean(g[idx] ** 2 * (a[idx] > 0))) * m  # phi's penalty in N m^2
        d2p = (np.diff(np.eye(knots), 2, axis=0) @ lift) * np.sqrt(smoothness * scale * s2)
        stacked = np.vstack([dth, d2p])
        rhs_p = np.concatenate([target[idx] - o_cells[idx], np.zeros(d2p.shape[0])])
        phi_k = lift @ nnls(stacked, rhs_p, maxiter=50 * stacked.shape[1])[0]
        norm = phi_k[-1] if phi_k[-1] > 0 else 1.0
        phi_k = phi_k / norm
        gain = gain * norm
        f = phi_at(phi_k)
        others = f.sum(axis=1, keepdims=True) - f
        if coupling:
            # kappa given S, phi and o: least squares over the cells two phases drive
            lin = o_cells + np.sum(gain[cp] * f, axis=1)
            x = np.sum(gain[cp] * f * others, axis=1)
            xi = x[idx]
            if float(xi @ xi) > 0:
                kappa = float(np.clip((lin[idx] - target[idx]) @ xi / (xi @ xi), 0.0, 0.5))
        pred = o_cells + np.sum(gain[cp] * f * (1.0 - kappa * others), axis=1)
        # the offset outside the sensor's zero: the readings where the model is below zero
        below = pred <= 0
        weight = np.bincount(cp[below], minlength=n) + bias_weight
        total = np.bincount(cp[below], weights=y[below], minlength=n)
        offset = np.where(weight > 0, total / np.maximum(weight, 1e-300), 0.0)
        fitted = pred[idx] - target[idx]
        sse = float(fitted @ fitted)
        if abs(last - sse) <= TOLERANCE * sse:
            break
        last = sse
    wave_f, wave_dof, wave_amp = 0.0, 0, 0.0
    if basis is not None:
        wave_f, wave_dof = _wave_f(full, rhs, sol, idx.size)
        wave_amp = float(np.hypot(coef_o[-2], coef_o[-1]))
        # the series through the anchors as without the term, plus the term between them
        k = anchors.size
        series = _interpolate_rest(np.asarray(basis @ coef_o), anchors, n)
        wave = np.asarray(basis[:, k:] @ coef_o[k:])
        series = dataclasses.replace(series, rest=series.rest + wave)
    else:
        series = _interpolate_rest(coef_o, anchors, n)
    res = np.maximum(pred, 0.0) - (y - offset[cp])
    phi_all = np.interp(np.arange(actuation_max + 1, dtype=np.float64), kx, phi_k)
    return SurfaceFit(
        phi=phi_all,
        gain=gain,
        rest=series.rest,
        rms=float(np.sqrt(np.mean(res**2))),
        offset=offset,
        series=series,
        coupling=kappa,
        nyquist_f=wave_f,
        nyquist_dof=wave_dof,
        nyquist_amplitude=wave_amp,
    )


def _wave_f(
    full: sp.csc_matrix, rhs: NDArray[np.float64], sol: NDArray[np.float64], cells: int
) -> tuple[float, int]:
    """F statistic of the last two columns (the Nyquist wave of :func:`rest_basis`) in the
    penalised least squares ``full @ x = rhs`` whose first ``cells`` rows are the data: the
    fall in the penalised sum of squares from the fit without them, per column, over the data
    rows' residual variance with them; and that variance's degrees of freedom (the cells less
    the columns, at least half the cells: the gains' columns are penalised)."""
    keep = full[:, :-2]
    lhs = (keep.T @ keep).tocsc() + sp.identity(keep.shape[1], format="csc") * 1e-9
    without = spsolve(lhs, keep.T @ rhs)
    sse_with = float(np.sum((full @ sol - rhs) ** 2))
    sse_without = float(np.sum((keep @ without - rhs) ** 2))
    data = full[:cells] @ sol - rhs[:cells]
    dof = max(cells - full.shape[1], cells // 2, 1)
    return (sse_without - sse_with) / 2.0 / max(float(data @ data) / dof, 1e-300), dof


def hidden_wave(fit: SurfaceFit) -> bool:
    """Whether a fit with ``nyquist`` holds a wave between the anchors beyond its noise: its F
    statistic above the F(2, dof) distribution's quantile at :data:`NYQUIST_LEVEL`.

    Examples
    --------
    >>> z = np.zeros(1)
    >>> hidden_wave(SurfaceFit(z, z[:, None], z, 0.0, z, nyquist_f=40.0, nyquist_dof=2000))
    True
    >>> hidden_wave(SurfaceFit(z, z[:, None], z, 0.0, z, nyquist_f=4.0, nyquist_dof=2000))
    False
    """
    if fit.nyquist_dof < 1:
        return False
    return bool(fit.nyquist_f > f_distribution.ppf(1.0 - NYQUIST_LEVEL, 2, fit.nyquist_dof))


def fit_surface(
    grid: NDArray[np.float64],
    levels: NDArray[np.float64],
    ramp: NDArray[np.float64],
    *,
    actuation_max: int,
    readable: float,
    dead_zone: float,
    exponent: float,
    curve: float = 0.0,
    bias_weight: float = 10.0,
    smoothness: float = 1.0,
    anchors: NDArray[np.int64] | None = None,
    nyquist: bool = False,
    carried: NDArray[np.float64] | None = None,
    coupling: bool | Literal["checked"] = False,
) -> SurfaceFit:
    """Fit the structured surface to the measured cells of a (position, level) grid.

    Parameters
    ----------
    grid
        Sensed torque [N m], shape (P, J); NaN where not measured.
    levels
        Base pulse width of each column, shape (J,).
    ramp
        The ramping function, shape (P, m).
    actuation_max
        Full-scale pulse width ``A``.
    readable
        Smallest torque the rig reads reliably [N m].
    dead_zone, exponent
        The onset law ``max(a - d, 0)^n`` (:mod:`torquemap.linearize.onset`) that ``phi``
        follows below the actuations that read torque.
    curve
        The onset law's amplifier curve ``c`` (:func:`torquemap.linearize.onset.onset_psi`;
        0: the power law above).
    bias_weight
        Weight, in readings, of each block's bias measurement against the readings that
        measure its error (where the model is below zero).
    smoothness
        Weight of the second-difference penalties, relative to one cell.
    anchors
        The measured positions (default: those with a reading at the first level).
    nyquist
        Between the anchors, ``o`` is their linear interpolation plus the anchors' Nyquist
        harmonic (:func:`rest_basis`), fitted with every row (those the rig's compliance moved
        between the anchors read it), instead of free at every position with a reading and
        carried by the anchors' series. For cogging the anchors sample twice a period or
        less (:func:`torquemap.linearize.sampling.check_position_sampling`); ignored unless
        the anchors are evenly spaced and even in number.
    carried
        With ``nyquist``: a shape of ``o`` between the anchors held fixed inside the fit (zero
        at the anchors), shape (P,): the series a fit without the wave carried between them
        (:func:`carried_shape`), so that the wave, and :func:`hidden_wave`'s test of it, hold
        only what that series misses. None: the anchors' linear interpolation alone.
    coupling
        Also fit the phases' mutual saturation: phase ``k``'s torque is
        ``S_k phi(a_k) (1 - kappa sum_{j != k} phi(a_j))`` (shared iron: two phases on give
        less than the sum of each alone), with one ``kappa`` in ``0 .. 0.5`` read by least
        squares from the cells two phases drive, between the rounds. ``"checked"``: also
        fitted without it, and ``kappa`` kept only where it lowers the cells' sum of squared misfits by more than :data:`COUPLING_F` times the
        coupled fit's residual variance (an F test of the one parameter; the residual
        variance over the cells less the fit's parameters, a measured position's gains and
        offset and ``phi``'s knots). Off: ``kappa = 0``.

    Returns
    -------
    SurfaceFit
        The fitted ``phi``, ``S`` and ``o``.
    """
    kwargs: dict[str, Any] = dict(
        actuation_max=actuation_max,
        readable=readable,
        dead_zone=dead_zone,
        exponent=exponent,
        curve=curve,
        bias_weight=bias_weight,
        smoothness=smoothness,
        anchors=anchors,
        nyquist=nyquist,
        carried=carried,
    )
    if coupling != "checked":
        return _fit_once(grid, levels, ramp, coupling=bool(coupling), **kwargs)
    plain = _fit_once(grid, levels, ramp, coupling=False, **kwargs)
    coupled = _fit_once(grid, levels, ramp, coupling=True, **kwargs)
    measured = np.isfinite(grid)
    cells = int(measured.sum())
    knots = int(np.ceil(actuation_max / PHI_KNOT_STEP)) + 1
    params = int(measured.any(axis=1).sum()) * (ramp.shape[1] + 1) + knots + 1
    dof = max(cells - params, cells // 2, 1)
    sse_plain, sse_coupled = cells * plain.rms**2, cells * coupled.rms**2
    f_stat = (sse_plain - sse_coupled) / max(sse_coupled / dof, 1e-300)
    kept = coupled if coupled.coupling > 0.0 and f_stat > COUPLING_F else plain
    return dataclasses.replace(kept, coupling_f=float(f_stat))


def surface_prediction(
    fit: SurfaceFit, ramp: NDArray[np.float64], u: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The model's uncensored torque at base pulse widths ``u`` (shape (U,)), shape (P, U)."""
    a = np.rint(ramp[:, None, :] * u[None, :, None]).astype(np.int64)
    a = np.clip(a, 0, fit.phi.size - 1)
    f = fit.phi[a]
    if fit.coupling:
        f = f * (1.0 - fit.coupling * (f.sum(axis=-1, keepdims=True) - f))
    out: NDArray[np.float64] = fit.rest[:, None] + np.einsum("pum,pm->pu", f, fit.gain)
    return out
