"""What the bias column of DATA.csv holds: the sensor's own bias, and the torque at rest.

The collection reads a bias at each target with all phases off and subtracts it from every row
of the target's block (:mod:`torquemap.linearize.collect`); DATA.csv keeps it in its ``bias``
column. Read on an open contact it is the sensor's own bias ``s(p)``: gravity and preload,
which change with the secondary joint's configuration slowly over the cycle. Read at rest (the
paper's procedure, the default), it is

``b(p) = s(p) + c(p)``,  ``c(p) = max(T0(p) - F, 0)``,

where ``T0`` is the motor's torque at zero current (cogging) and ``F`` the contact's static
friction: where cogging alone pushes the contact beyond its friction, the contact is loaded at
rest and that load ``c`` is read as bias, subtracted from the whole block, and the tables never
see it. Where friction holds the cogging (``T0 <= F``), ``c = 0``: the contact is not loaded.

So ``c`` is never negative and is zero over part of the cycle, while ``s`` is smooth. The check:

1. The standard error of one block's bias, ``sigma_b``, from the rows at zero pulse width
   (they read the same state as the bias: ``var = sigma^2 (1 / R + 1 / B)``, and the bias
   weighs ``B / R = bias_weight`` rows), ``sigma_b = sd(rows at 0) / sqrt(1 + bias_weight)``,
   ``sd`` the root mean square of those below zero (with the bias read on an open contact, the
   rows at 0 hold the load where there is one; it only adds). Every test below counts that
   estimate's own scatter: a chi-square in units of ``sigma_b**2`` over its degrees of freedom
   is tested as F-distributed, with as many degrees of freedom in the denominator as rows went
   into ``sd``.
2. The drift ``s``: a Fourier series over the cycle, fitted to the blocks it does not call
   loaded (a block is loaded while it lies more than ``Z`` standard errors above the fit: a
   load only adds), its harmonics added one at a time while each explains significantly more
   of those blocks (chi-square of 2 degrees of freedom against ``sigma_b``, level
   :data:`ALPHA`). It must then leave the blocks below it within ``sigma_b`` (their chi-square,
   level :data:`ALPHA`): a block below the drift is the drift and its noise, while loads too
   small to single out may lie above it. Else the load cannot be told from the drift. The unloaded blocks must be at least half: cogging averages zero over its
   period and exceeds the friction over less than half of it (a fit that keeps fewer has sunk
   to the lowest blocks of a drift it does not follow).
3. The bias varies beyond its noise when the chi-square of every block about the drift is
   beyond what ``sigma_b`` explains (level :data:`ALPHA`) and some block lies above it (a
   load's signature).

Each block's bias's excess over the drift, ``b - s`` (the load ``c`` where loaded, the bias's
own error elsewhere), is then added back to the block's rows: they become the readings less the
drift, what a collection with the bias on an open contact would have recorded with the drift in
place of each block's own, noisier, bias. On the family's seeds 101 to 110 (docs/linearize.md)
that re-zeroing helps whether the bias varies or not: with the bias read at rest, restoring the
loaded blocks alone (an earlier fit of the drift) left the tables at 1.95x the floor (median) and
3.37x (worst), restoring every block only when the bias varies at 1.95x and 3.58x, re-zeroing
every block on the drift at 1.84x and 3.20x (the bias read on an open contact, rows as measured:
1.95x and 3.21x). A warning goes with it only when the bias
varies beyond its noise. This module never imports the simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import f as f_distribution

from torquemap.linearize.gaps import fourier_design

#: Significance level of the chi-square tests (the drift's order, and whether the bias varies
#: beyond its noise).
ALPHA = 1e-3
#: A block is loaded while its bias lies more than this many standard errors above the drift.
Z = 3.0
#: Relative precision of a bias written with ten significant digits: the standard error is
#: never taken below it (a noise-free rig).
PRECISION = 1e-9
#: Degrees of freedom of a standard error known exactly (the precision above).
KNOWN = 1e12


@dataclass(frozen=True, slots=True, eq=False)
class BiasCheck:
    """What the bias column holds.

    Attributes
    ----------
    position
        Each block's position (its lowest level's row, where the bias was read), ascending,
        shape (k,).
    bias
        Each block's bias [N m], shape (k,).
    drift
        The sensor's own bias, the smooth part, at each block [N m], shape (k,).
    loaded
        Blocks whose bias lies above the drift beyond its noise, shape (k,).
    standard_error
        Of one block's bias [N m].
    harmonics
        Fourier harmonics of the drift (0: a constant).
    chi_square
        Of every block's bias about the drift, in units of ``standard_error**2``.
    dof
        Its degrees of freedom.
    p_value
        Of ``chi_square`` under a bias that is drift and noise alone.
    varies
        The bias varies beyond what its noise and a smooth drift explain.
    separated
        The drift was found (some ``K`` fitted the unloaded blocks within their noise); when
        False, the load cannot be told from the drift and nothing is restored.
    restore
        Torque to add to each row [N m], shape (n,): its block's bias less the drift there
        (0 everywhere when the drift could not be separated).
    """

    position: NDArray[np.int64]
    bias: NDArray[np.float64]
    drift: NDArray[np.float64]
    loaded: NDArray[np.bool_]
    standard_error: float
    harmonics: int
    chi_square: float
    dof: int
    p_value: float
    varies: bool
    separated: bool
    restore: NDArray[np.float64]

    def load(self) -> NDArray[np.float64]:
        """The load at each block: its bias's excess over the drift where loaded, else 0 [N m]."""
        out: NDArray[np.float64] = np.where(self.loaded, self.bias - self.drift, 0.0)
        return out

    def advice(self, *, restored: bool, bias_open: bool = False) -> str:
        """One line for the user: what the bias holds and what to do.

        ``bias_open``: the collection read the bias on an open contact (its record says so),
        which holds no load: what lies above the drift is the sensor's bias changing faster
        than the drift follows, or a contact that did not open, and reading it open again is
        no remedy.
        """
        load = self.load()
        if bias_open:
            return (
                f"the bias read on an open contact varies over the cycle beyond its noise "
                f"(chi-square {self.chi_square:.3g} for {self.dof} degrees of freedom beside a "
                f"smooth drift of {self.harmonics} harmonic(s); standard error "
                f"{self.standard_error:.3g} N m): at {int(self.loaded.sum())} of "
                f"{self.loaded.size} positions it lies up to {float(load.max(initial=0.0)):.3g} "
                "N m above the drift, which an open contact does not load: the sensor's bias "
                "changes faster than the drift follows, or the contact did not open"
                + ("; those positions' rows re-zeroed on the drift" if restored else "")
            )
        what = (
            f"the bias read at rest varies over the cycle beyond its noise (chi-square "
            f"{self.chi_square:.3g} for {self.dof} degrees of freedom beside a smooth drift of "
            f"{self.harmonics} harmonic(s); standard error {self.standard_error:.3g} N m): at "
            f"{int(self.loaded.sum())} of {self.loaded.size} positions it holds up to "
            f"{float(load.max(initial=0.0)):.3g} N m more, the torque at rest where cogging alone "
            "loads the contact beyond its friction"
        )
        if restored:
            return (
                what + "; restored to those positions' rows from the bias column. Reading the "
                "bias on an open contact (linearize collect --bias-open) measures it directly"
            )
        return (
            what + "; the tables do not see it. Collect again with the bias read on an open "
            "contact (linearize collect --bias-open)"
        )


def _fourier(p: NDArray[np.float64], harmonics: int, n: int) -> NDArray[np.float64]:
    """The series of harmonics 1 .. ``harmonics`` (:func:`torquemap.linearize.gaps.fourier_design`)."""
    return fourier_design(p, range(1, harmonics + 1), n)


def _lower_fit(
    design: NDArray[np.float64], b: NDArray[np.float64], sigma: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Fit ``b`` on the blocks not above the fit by more than ``Z sigma``, until the set holds."""
    base = np.ones(b.size, dtype=bool)
    fit = np.zeros_like(b)
    for _ in range(50):
        coef, *_ = np.linalg.lstsq(design[base], b[base], rcond=None)
        fit = design @ coef
        new = b - fit <= Z * sigma
        if (new == base).all() or new.sum() < design.shape[1] + 1:
            break
        base = new
    return fit, base


def _blocks(
    position: NDArray[np.int64], level: NDArray[np.float64], bias: NDArray[np.float64]
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """One entry per block (rows sharing one bias), by position: its position at its lowest
    level, its bias, and each row's block."""
    values, inverse = np.unique(bias, return_inverse=True)
    order = np.lexsort((level, inverse))  # by block, then level
    first = order[np.unique(inverse[order], return_index=True)[1]]
    at = position[first].astype(np.int64)
    by_position = np.argsort(at, kind="stable")
    rank = np.empty_like(by_position)
    rank[by_position] = np.arange(by_position.size)
    return at[by_position], values[by_position], rank[inverse].astype(np.int64)


def _standard_error(
    level: NDArray[np.float64], torque: NDArray[np.float64], bias_weight: float, scale: float
) -> tuple[float, float]:
    """The bias's standard error and the degrees of freedom of its estimate."""
    # the rows at level 0 below zero: a load at rest (in the rows of a collection with the bias
    # read on an open contact) only adds, so those are the noise alone, half-normal
    zero = torque[level == 0]
    low = zero[zero < 0]
    sd = math.sqrt(float(np.mean(low**2))) if low.size >= 4 else 0.0
    sigma = sd / math.sqrt(1.0 + bias_weight)
    floor = max(PRECISION * scale, 1e-300)
    return (sigma, float(low.size)) if sigma > floor else (floor, KNOWN)


def _p(chi_square: float, dof: float, dof_sigma: float) -> float:
    """P-value of a chi-square in units of an estimated variance: ``(chi_square / dof)`` is
    F-distributed with ``(dof, dof_sigma)`` degrees of freedom (the estimate's own scatter
    counted; with few rows at level 0 it is far from exact)."""
    return float(f_distribution.sf(chi_square / dof, dof, dof_sigma))


def _rss(design: NDArray[np.float64], b: NDArray[np.float64], rows: NDArray[np.bool_]) -> float:
    coef, *_ = np.linalg.lstsq(design[rows], b[rows], rcond=None)
    r = b[rows] - design[rows] @ coef
    return float(r @ r)


def _drift(
    at: NDArray[np.int64], b: NDArray[np.float64], sigma: float, dof_sigma: float, n: int
) -> tuple[NDArray[np.float64], NDArray[np.bool_], int, bool]:
    """The drift at each block, the blocks it does not call loaded, its harmonics, and whether
    it leaves the blocks below it within their noise (else the load cannot be told from it)."""
    k = b.size
    top = max(0, (k // 4 - 1) // 2)  # at least four blocks a coefficient
    x = at.astype(np.float64)
    fit, keep = _lower_fit(_fourier(x, 0, n), b, sigma)
    h = 0
    while h < top:
        design = _fourier(x, h + 1, n)
        fit_next, keep_next = _lower_fit(design, b, sigma)
        if int(keep_next.sum()) <= design.shape[1]:
            break
        # the next harmonic is kept while it explains significantly more of the unloaded
        # blocks (chi-square of 2 degrees of freedom), or while the fit sank below the drift
        # to the lowest blocks (fewer than half kept)
        gain = (_rss(_fourier(x, h, n), b, keep_next) - _rss(design, b, keep_next)) / sigma**2
        if 2 * keep.sum() >= k and _p(gain, 2.0, dof_sigma) >= ALPHA:
            break
        fit, keep, h = fit_next, keep_next, h + 1
    # a load only adds: the blocks below the drift are its noise alone (half-normal, and the
    # fit took about half of its coefficients' degrees of freedom from them)
    below = b - fit < 0
    dof = max(float(below.sum()) - (h + 0.5), 1.0)
    held = _p(float(np.sum(((b - fit)[below] / sigma) ** 2)), dof, dof_sigma) >= ALPHA
    return fit, keep, h, bool(held and 2 * keep.sum() >= k)


def check_bias(
    position: ArrayLike,
    pulse_width: ArrayLike,
    torque: ArrayLike,
    bias: ArrayLike,
    *,
    positions_per_cycle: int,
    bias_weight: float = 10.0,
) -> BiasCheck:
    """Split the bias column into the sensor's smooth drift and the load at rest.

    Parameters
    ----------
    position
        Table position of each row, shape (n,).
    pulse_width
        Base pulse width of each row, shape (n,).
    torque
        Torque of each row, the bias subtracted [N m], shape (n,).
    bias
        The bias subtracted from each row [N m], shape (n,): one value per block.
    positions_per_cycle
        ``P``: the drift is a Fourier series over ``0 .. P``.
    bias_weight
        The bias's readings over a row's (``bias_readings / readings``, 10 by default).

    Returns
    -------
    BiasCheck
        The drift, the loaded blocks, the test and the torque to restore to each row.

    Examples
    --------
    >>> p = np.repeat(np.arange(0, 64, 2), 2)
    >>> w = np.tile([0, 10], 32)
    >>> load = np.maximum(np.sin(2 * np.pi * 4 * p / 64) - 0.5, 0.0)  # cogging beyond friction
    >>> b = 1.0 + 0.3 * np.cos(2 * np.pi * p / 64) + load
    >>> check = check_bias(p, w, w / 10.0, b, positions_per_cycle=64)
    >>> check.varies, check.harmonics
    (True, 1)
    >>> bool(np.allclose(check.restore, load)), int(check.loaded.sum())
    (True, 12)
    """
    pos = np.asarray(position, dtype=np.int64)
    pw = np.asarray(pulse_width, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    b_row = np.asarray(bias, dtype=np.float64)
    n = int(positions_per_cycle)
    at, b, block = _blocks(pos, pw, b_row)
    scale = float(np.max(np.abs(b_row), initial=0.0))
    sigma, dof_sigma = _standard_error(pw, tau, bias_weight, scale)
    k = b.size
    drift, base, harmonics, separated = _drift(at, b, sigma, dof_sigma, n)
    dof = max(k - (2 * harmonics + 1), 1)
    total = float(np.sum(((b - drift) / sigma) ** 2))
    p_value = _p(total, dof, dof_sigma)
    # beyond the noise, and with the signature of a load: blocks above the drift
    varies = k > 2 * harmonics + 1 and p_value < ALPHA and not base.all()
    loaded = ~base if varies else np.zeros(k, dtype=bool)
    restore = (b - drift)[block] if separated else np.zeros(pos.size)
    return BiasCheck(
        position=at,
        bias=b,
        drift=drift,
        loaded=loaded,
        standard_error=sigma,
        harmonics=harmonics,
        chi_square=total,
        dof=dof,
        p_value=p_value,
        varies=bool(varies),
        separated=separated,
        restore=restore,
    )
