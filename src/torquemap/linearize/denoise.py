"""Low-rank denoising of characterisation data, block by block (beyond the Adept II paper).

The collection loop (:mod:`torquemap.linearize.collect`, the paper's Fig 12) measures one block
of rows per target position: levels ``0, k, 2k, ...`` in order, each row the mean of a few noisy
sensor readings. Stacked as a matrix (blocks x levels), the motor's torque is smooth in both
directions and of low rank, while the sensor noise is spread over every singular value: a
truncated SVD keeps the torque and drops most of the noise. The rank is the smallest whose
residual holds no structure (neighbouring residuals uncorrelated), so no smoothing width is
chosen by hand.

What the sensor reads is not the motor's torque but ``max(torque - friction, 0)``: zero until
the torque overcomes the dead band and the friction, a knee whose pulse width moves from block
to block, which no matrix of low rank holds. So the fit is censored (a Tobit model): a reading
where the fit is negative only says that the torque there is at most zero, and is imputed like
a level a block did not reach (the sensor saturated), by iterating the truncated SVD with the
other readings held fixed; the rows get the fit clipped at zero. The knee then follows from the
low-rank torque of every block instead of from the few noisy rows around it, which is where the
relative deviation of the low commands is decided. The censored readings also measure the error
of the bias subtracted from their block (the torque there is zero): each block is re-zeroed on
them, weighed against the bias measurement, in the same iteration.

The blocks are recognised from the row order of DATA.csv, which the collection writes: every
block starts at level 0 and its levels increase. Data without that structure (rows shuffled,
repeats, levels off a common grid) is returned unchanged.

Where the matrix is not of low rank (the rig's compliance moves a block's top rows across a
narrow ramp's hand-overs) the fit is biased; :func:`restore_misfit` gives back, cell by cell,
the share of the readings' residual that exceeds their noise (a Wiener weight from the
residual's mean square around the cell against the noise of the censored readings).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import uniform_filter

from torquemap.robust import robust_scale

#: Fewest blocks and levels for which a low-rank fit is meaningful.
MIN_BLOCKS = 8
MIN_LEVELS = 8


@dataclass(frozen=True, slots=True, eq=False)
class Denoised:
    """Result of :func:`denoise_blocks`.

    Attributes
    ----------
    torque
        Torque of every row [N m], shape (n,): the low-rank fit where denoising applied, else
        the input.
    rank
        Singular values kept; 0 when the data was left unchanged.
    blocks
        Blocks recognised (0 when the row order has no block structure).
    reason
        Why the data was left unchanged ("" when it was denoised).
    """

    torque: NDArray[np.float64]
    rank: int
    blocks: int
    reason: str = ""


def _blocks(level: NDArray[np.int64]) -> NDArray[np.int64] | None:
    """Block index of every row, or None when the rows are not blocks of increasing levels
    each starting at 0."""
    if level.size == 0 or level[0] != 0:
        return None
    block = np.cumsum(level == 0) - 1
    same = block[1:] == block[:-1]
    if np.any(same & (np.diff(level) <= 0)):
        return None
    return block.astype(np.int64)


def _truncate(matrix: NDArray[np.float64], rank: int) -> NDArray[np.float64]:
    """The best rank-``rank`` approximation of ``matrix`` (the truncated SVD), by projecting
    onto the leading eigenvectors of its smaller Gram matrix (a few times faster than an SVD)."""
    tall = matrix.shape[0] >= matrix.shape[1]
    a = matrix if tall else matrix.T
    v = np.linalg.eigh(a.T @ a)[1][:, -rank:]  # eigenvalues ascending
    low: NDArray[np.float64] = (a @ v) @ v.T
    return low if tall else low.T


def _impute(
    matrix: NDArray[np.float64],
    measured: NDArray[np.bool_],
    estimate: NDArray[np.float64],
    rank: int,
    iterations: int,
    tol: float,
    bias_weight: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Rank-``rank`` fit with the unmeasured and the censored entries imputed and every block
    re-zeroed (hard impute, warm started). Returns (fit, estimate, block offsets).

    A measured entry whose fit is negative is censored: the sensor reads zero force until the
    motor's torque overcomes the dead band and the friction, so such a reading only says that
    the torque there is at most zero, and the fit is free to go below it. The censored readings
    of a block read its bias error (the torque there is zero); the block's offset is their sum
    over their count plus ``bias_weight``, and the fit is made to the readings minus it."""
    low = estimate
    offset = np.zeros(matrix.shape[0])
    for _ in range(iterations):
        low = _truncate(estimate, rank)
        zero = measured & (low < 0.0)
        total, weight = np.where(zero, matrix, 0.0).sum(axis=1), zero.sum(axis=1) + bias_weight
        offset = np.divide(total, weight, out=np.zeros_like(total), where=weight > 0)
        new = np.where(measured & ~zero, matrix - offset[:, None], low)
        change = float(np.linalg.norm(new - estimate))
        estimate = new
        if change <= tol * float(np.linalg.norm(estimate)):
            break
    return low, estimate, offset


def level_correlation(residual: NDArray[np.float64]) -> tuple[float, int]:
    """Lag-one correlation of a (blocks x levels) residual along its last axis (NaN =
    unmeasured), and the number of neighbouring pairs it rests on.

    Examples
    --------
    >>> r = np.array([[1.0, 1.0, 1.0, 1.0], [-1.0, -1.0, -1.0, -1.0]])
    >>> level_correlation(r)
    (1.0, 6)
    """
    a, b = residual[:, :-1], residual[:, 1:]
    ok = np.isfinite(a) & np.isfinite(b)
    den = float(np.sqrt(np.sum(a[ok] ** 2) * np.sum(b[ok] ** 2)))
    return (float(np.sum(a[ok] * b[ok])) / den if den > 0 else 0.0), int(ok.sum())


def denoise_blocks(
    level: ArrayLike,
    torque: ArrayLike,
    *,
    iterations: int = 10,
    polish: int = 20,
    bias_weight: float = 10.0,
    tol: float = 1e-6,
) -> Denoised:
    """Replace each row's torque by the low-rank fit of the (block x level) matrix.

    The rank grows from 1 until the residual holds no structure: sensor noise leaves residuals
    uncorrelated from one level to the next and from one block to the next, while torque the
    fit misses is smooth in both and correlates neighbours positively (a spectrum alone cannot
    tell signal from noise near the noise level, for example the sharp phase hand-over of
    narrow ramping). The first rank whose lag-one correlations along the levels and along the
    blocks are both below ``2 / sqrt(pairs)`` is kept; when none up to half the matrix's short
    side qualifies, the rows are left as measured. Readings where the fit is negative are
    censored (module docstring), every block is re-zeroed on its censored readings
    (``bias_weight``), and the fit is clipped at zero.

    Parameters
    ----------
    level
        Level of each row (base pulse width or command), in file order, shape (n,).
    torque
        Measured torque of each row [N m], shape (n,).
    iterations
        Most imputation rounds per rank tried (levels above a block's saturation and censored
        readings are imputed); each rank starts from the previous one's estimate.
    polish
        Further imputation rounds at the rank kept.
    bias_weight
        The bias measurement's weight, in rows (``bias_readings / readings`` of the collection,
        whose default is 10). Each block's censored readings measure its bias error, because
        the torque there is zero; the block is shifted by their sum over their count plus
        ``bias_weight`` (the two estimates of the bias combined; ``inf``: not at all).
    tol
        Stop imputing when the estimate changes by less than this, relative to its norm.

    Returns
    -------
    Denoised
        The torques and the rank kept.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> levels = np.tile(np.arange(0, 64, 4), 20)
    >>> gain = np.repeat(1.0 + 0.3 * np.sin(np.arange(20)), 16)
    >>> clean = gain * (levels / 63.0) ** 2
    >>> out = denoise_blocks(levels, clean + rng.normal(0, 0.02, clean.size))
    >>> out.rank, out.blocks, bool(np.std(out.torque - clean) < 0.01)
    (1, 20, True)
    """
    lv = np.asarray(level).astype(np.int64)
    tau = np.asarray(torque, dtype=np.float64)
    block = _blocks(lv)
    if block is None:
        return Denoised(tau.copy(), 0, 0, "rows are not blocks of increasing levels from 0")
    grid, col = np.unique(lv, return_inverse=True)
    nb = int(block[-1]) + 1
    if nb < MIN_BLOCKS or grid.size < MIN_LEVELS:
        return Denoised(tau.copy(), 0, nb, f"fewer than {MIN_BLOCKS} blocks or levels")
    matrix = np.full((nb, grid.size), np.nan)
    matrix[block, col] = tau
    measured = np.isfinite(matrix)
    fill = np.nanmean(matrix, axis=0)
    estimate = np.where(measured, matrix, np.where(np.isfinite(fill), fill, 0.0)[None, :])
    for rank in range(1, min(estimate.shape) // 2 + 1):
        low, estimate, offset = _impute(
            matrix, measured, estimate, rank, iterations, tol, bias_weight
        )
        fit = np.maximum(low, 0.0)
        residual = np.where(measured, matrix - offset[:, None] - fit, np.nan)
        along_levels = level_correlation(residual)
        along_blocks = level_correlation(residual.T)
        if all(n and rho <= 2.0 / np.sqrt(n) for rho, n in (along_levels, along_blocks)):
            low, _, _ = _impute(matrix, measured, estimate, rank, polish, tol, bias_weight)
            return Denoised(np.maximum(low, 0.0)[block, col], rank, nb)
    return Denoised(tau.copy(), 0, nb, "the residual stays structured at every rank tried")


#: Blocks x levels over which :func:`restore_misfit` pools a cell's residual to estimate what
#: the low-rank fit misses there: 21 cells, so the pooled mean square has a relative standard
#: deviation of ``sqrt(2 / 21)`` (31 %) where the residual is noise alone, while the window
#: spans one measured position on either side and 12 pulse widths either way at the paper's
#: step of 4 (the fit's misfit, where the compliance moves a block's rows across a ramp's
#: hand-over, is local in both).
MISFIT_WINDOW = (3, 7)
#: Fewest censored readings (the noise's own sample) for :func:`restore_misfit` to act.
MIN_CENSORED = 10


@dataclass(frozen=True, slots=True, eq=False)
class Restored:
    """Result of :func:`restore_misfit`.

    Attributes
    ----------
    torque
        Torque of every row [N m], shape (n,).
    noise
        One row's noise read from the censored readings [N m] (0 when not estimated).
    share
        Mean weight of the readings over the fit, over the uncensored rows (0: the fit as it
        was; 1: the readings).
    """

    torque: NDArray[np.float64]
    noise: float
    share: float


def restore_misfit(
    level: ArrayLike,
    torque: ArrayLike,
    fitted: ArrayLike,
    *,
    bias_weight: float = 10.0,
) -> Restored:
    """Give back to the low-rank fit what it misses beyond the noise (a Wiener shrinkage).

    A truncated SVD keeps the torque where the (block x level) matrix is of low rank; where it
    is not (the rig's compliance moves a block's top rows across a narrow ramp's hand-over)
    the fit is biased, and there the readings, noise and all, are nearer the torque: on the
    family's seed 15 (VR 4 x 384, narrow ramp) the fit errs by 0.056 N m rms at the top pulse
    widths where a row's noise is 0.024 N m. Each uncensored reading ``y`` gets
    ``fit + alpha (y - b - fit)``, ``b`` its block's bias error (as :func:`denoise_blocks`
    re-zeroes it), with ``alpha = max(0, 1 - sigma^2 / MS)``: ``MS`` the mean square of the
    residual over the :data:`MISFIT_WINDOW` around the cell (noise plus misfit, ``sigma^2 +
    m^2``), ``sigma`` one row's noise from the censored readings (their spread about zero).
    For a residual ``noise - m`` this weight is the one that minimises the expected squared
    error of ``fit + alpha (y - b - fit)``, ``m^2 / (m^2 + sigma^2)``, with ``m^2`` read as
    ``MS - sigma^2``. Where the fit is right (``MS ~ sigma^2``) the rows stay the fit.

    Parameters
    ----------
    level
        Level of each row, in file order, shape (n,).
    torque
        Measured torque of each row [N m], shape (n,).
    fitted
        :func:`denoise_blocks`'s torque of each row [N m], shape (n,).
    bias_weight
        As for :func:`denoise_blocks`.

    Returns
    -------
    Restored
        The torques (``fitted`` unchanged when the rows are not blocks or fewer than
        :data:`MIN_CENSORED` readings are censored).

    Examples
    --------
    A fit that misses a bump of 0.2 N m on blocks 8 to 11 at the top levels, rows with noise
    0.02 N m: the bump comes back, the noise elsewhere stays out.

    >>> rng = np.random.default_rng(0)
    >>> levels = np.tile(np.arange(0, 64, 4), 20)
    >>> block = np.repeat(np.arange(20), 16)
    >>> truth = np.maximum(levels - 12.0, 0.0) / 50.0
    >>> truth = truth + 0.2 * ((block >= 8) & (block < 12) & (levels >= 40))
    >>> fit = np.maximum(levels - 12.0, 0.0) / 50.0
    >>> out = restore_misfit(levels, truth + rng.normal(0, 0.02, truth.size), fit)
    >>> bump = (block >= 8) & (block < 12) & (levels >= 40)
    >>> bool(np.abs(out.torque - truth)[bump].mean() < 0.03)
    True
    >>> bool(np.abs(out.torque - truth)[~bump & (block < 5)].mean() < 0.01)
    True
    """
    lv = np.asarray(level).astype(np.int64)
    tau = np.asarray(torque, dtype=np.float64)
    fit_rows = np.asarray(fitted, dtype=np.float64)
    block = _blocks(lv)
    if block is None or fit_rows.shape != tau.shape:
        return Restored(fit_rows.copy(), 0.0, 0.0)
    grid, col = np.unique(lv, return_inverse=True)
    nb = int(block[-1]) + 1
    raw = np.full((nb, grid.size), np.nan)
    raw[block, col] = tau
    fit = np.zeros((nb, grid.size))
    fit[block, col] = fit_rows
    measured = np.isfinite(raw)
    censored = measured & (fit <= 0.0)
    if int(censored.sum()) < MIN_CENSORED:
        return Restored(fit_rows.copy(), 0.0, 0.0)
    # the block's bias error, read on its censored readings and weighed against the bias
    # measurement, as denoise_blocks re-zeroes it
    total = np.where(censored, raw, 0.0).sum(axis=1)
    offset = total / (censored.sum(axis=1) + bias_weight)
    residual = np.where(measured, raw - offset[:, None] - fit, 0.0)
    zero = residual[censored]
    sigma = robust_scale(zero)
    use = measured & ~censored
    if sigma <= 0.0 or not use.any():
        return Restored(fit_rows.copy(), sigma, 0.0)
    square = uniform_filter(np.where(use, residual**2, 0.0), size=MISFIT_WINDOW, mode="nearest")
    count = uniform_filter(use.astype(np.float64), size=MISFIT_WINDOW, mode="nearest")
    mean_square = np.where(count > 0, square / np.maximum(count, 1e-12), 0.0)
    alpha = np.where(mean_square > sigma**2, 1.0 - sigma**2 / np.maximum(mean_square, 1e-300), 0.0)
    out = np.where(use, np.maximum(fit + alpha * residual, 0.0), fit)
    return Restored(out[block, col], sigma, float(alpha[use].mean()))
