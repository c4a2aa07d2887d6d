"""Position-dependent torque variations (PDTV): the position-domain signal and its filters.

Simpson, Cook & Li sample the torque residual at fixed motor-angle intervals (the "discrete
position signal"), so that a torque ripple tied to the motor angle becomes a fixed frequency in
cycles per motor revolution (CPR, Eq 4), whatever the speed. Orders are in CPR throughout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True, eq=False)
class PositionSignal:
    """A signal sampled in the position domain: one value per motor-angle bin.

    Attributes
    ----------
    angle
        Bin centres, absolute (unwrapped) motor angle [rad], increasing, shape (nb,).
    value
        Mean of the samples in each bin; empty bins linearly interpolated, shape (nb,).
    count
        Samples per bin (0: empty, value interpolated), shape (nb,).
    bin_width
        [rad].
    """

    angle: NDArray[np.float64]
    value: NDArray[np.float64]
    count: NDArray[np.int64]
    bin_width: float

    @property
    def samples_per_rev(self) -> float:
        """Position sampling rate [samples per motor revolution]."""
        return TWO_PI / self.bin_width


def discrete_position_signal(
    motor_angle: ArrayLike, values: ArrayLike, *, bin_width: float
) -> PositionSignal:
    """The paper's discrete-position signal: ``values`` averaged in motor-angle bins.

    Bin ``k`` covers ``[k, k + 1) * bin_width`` of the absolute motor angle, so bins line up
    with the encoder zero and with whole revolutions when ``bin_width`` divides 2 pi. Bins run
    from the lowest to the highest angle the samples reach; bins no sample falls in are
    linearly interpolated from their neighbours (and flagged by ``count == 0``).

    Parameters
    ----------
    motor_angle
        Unwrapped motor angle [rad], shape (n,), in any order (both directions allowed).
    values
        The signal (for example the torque residual [N m]), shape (n,).
    bin_width
        Bin width [rad] > 0.

    Returns
    -------
    PositionSignal
        Bin centres, means, counts.

    Raises
    ------
    InputError
        On mismatched shapes, no samples, or non-finite input.

    Examples
    --------
    >>> s = discrete_position_signal([0.1, 0.2, 2.1], [1.0, 3.0, 5.0], bin_width=1.0)
    >>> s.value.tolist(), s.count.tolist()
    ([2.0, 3.5, 5.0], [2, 0, 1])
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if theta.ndim != 1 or theta.shape != v.shape:
        raise InputError(
            f"motor angle and values must be 1-D of equal length, got {theta.shape} and {v.shape}"
        )
    if theta.size == 0:
        raise InputError("no samples to bin")
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(v))):
        raise InputError("motor angle or values hold NaN or inf")
    bw = float(bin_width)
    if not (math.isfinite(bw) and bw > 0):
        raise InputError(f"bin width must be positive, got {bin_width!r} rad")
    k = np.floor(theta / bw + 1e-9).astype(np.int64)
    k0 = int(k.min())
    nb = int(k.max()) - k0 + 1
    idx = k - k0
    count = np.bincount(idx, minlength=nb).astype(np.int64)
    total = np.bincount(idx, weights=v, minlength=nb)
    angle = (np.arange(nb, dtype=np.float64) + (k0 + 0.5)) * bw
    full = count > 0
    value = np.empty(nb)
    value[full] = total[full] / count[full]
    if not full.all():
        value[~full] = np.interp(angle[~full], angle[full], value[full])
    return PositionSignal(angle=angle, value=value, count=count, bin_width=bw)


def notch_quality(order: float, width: float) -> float:
    """Quality factor Q of the single-pass notch whose forward-backward response has ``width``.

    A second-order notch ``(s^2 + w0^2) / (s^2 + B s + w0^2)`` has its -3 dB band exactly ``B``
    wide; applied forward and backward its gain is squared, so the single pass needs
    ``B = width * sqrt(sqrt(2) - 1)`` for the combined -3 dB band to be ``width`` wide.
    """
    return order / (width * math.sqrt(math.sqrt(2.0) - 1.0))


def notch_position_signal(
    signal: PositionSignal, *, orders: Sequence[float], width: float = 0.5
) -> NDArray[np.float64]:
    """Remove position-frequency lines with zero-phase notch filters.

    Parameters
    ----------
    signal
        A position-domain signal (:func:`discrete_position_signal`).
    orders
        Orders to remove [CPR]. The position sampling rate is ``2 pi / bin_width`` samples per
        motor revolution; orders at or above its Nyquist (half of it) are skipped.
    width
        -3 dB bandwidth [CPR] of each notch (forward-backward response).

    Returns
    -------
    ndarray
        The filtered values, shape (nb,).

    Raises
    ------
    InputError
        If ``width`` is not positive.

    Notes
    -----
    Each notch is ``scipy.signal.iirnotch`` applied forward and backward (``filtfilt``); see
    :func:`notch_quality`. A narrow notch rings for about ``1 / (pi * width)`` revolutions, so
    when the bins divide a revolution and cover at least one, the signal is first extended by
    whole revolutions (PDTV is periodic in the motor angle) and the extension cut off after
    filtering; otherwise Gustafsson's initial conditions are used and the ends keep a
    transient.

    Examples
    --------
    >>> theta = (np.arange(3600) + 0.5) * (2 * np.pi / 360)
    >>> s = discrete_position_signal(theta, 1.0 + np.cos(12 * theta), bin_width=2 * np.pi / 360)
    >>> y = notch_position_signal(s, orders=[12.0])
    >>> bool(np.abs(y - 1.0).max() < 0.01)
    True
    """
    from scipy import signal as sps

    if not (math.isfinite(width) and width > 0):
        raise InputError(f"notch width must be positive, got {width!r} CPR")
    fs = signal.samples_per_rev
    y = np.array(signal.value, dtype=np.float64)
    active = [float(f) for f in orders if 0 < float(f) < fs / 2]
    if not active or y.size < 3:
        return y
    per_rev = round(fs)
    periodic = abs(fs - per_rev) < 1e-6 * fs and y.size >= per_rev
    if periodic:
        # PDTV repeats every revolution: extend by whole revolutions so the notch's long
        # start-up transient (about 1 / (pi * width) revolutions) settles outside the data.
        pad = min(math.ceil(8.0 / (math.pi * width * 0.6436)) * per_rev, 50 * y.size)
        cycle = (y.size // per_rev) * per_rev
        j = np.arange(-pad, y.size + pad)
        head = np.mod(j, cycle)
        tail = y.size - cycle + np.mod(j - (y.size - cycle), cycle)
        y = y[np.where(j < 0, head, np.where(j >= y.size, tail, j))]
    for f0 in active:
        b, a = sps.iirnotch(f0, notch_quality(f0, width), fs=fs)
        if periodic:
            y = sps.filtfilt(b, a, y, padlen=0)
        else:
            y = sps.filtfilt(b, a, y, method="gust")
    if periodic:
        y = y[pad : y.size - pad]
    return np.asarray(y, dtype=np.float64)


@dataclass(frozen=True, slots=True, eq=False)
class Spectrum:
    """Position-frequency spectrum of a position-domain signal.

    Attributes
    ----------
    order
        Position frequency [CPR], shape (m,), from ``1 / revolutions`` up.
    amplitude
        Line amplitude [signal unit]: a line ``A cos(order * theta + phase)`` shows ``A``.
    phase
        [rad], referred to motor angle 0.
    revolutions
        Motor revolutions the spectrum was computed over (its resolution is 1 / revolutions).
    """

    order: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    phase: NDArray[np.float64]
    revolutions: float = 1.0


def position_spectrum(signal: PositionSignal, *, max_order: float | None = None) -> Spectrum:
    """Spectrum in CPR of a position-domain signal over a whole number of motor revolutions.

    The first ``floor(revolutions)`` revolutions are used, so that every integer order falls
    exactly on a frequency bin (no leakage). A signal covering less than one revolution but at
    least half of one is used whole (resolution ``1 / revolutions`` CPR, a little coarser
    than 1).

    Parameters
    ----------
    signal
        From :func:`discrete_position_signal`; ``2 pi / bin_width`` should be an integer.
    max_order
        Highest order to return [CPR]; default: every order below the position Nyquist.

    Returns
    -------
    Spectrum
        Orders, amplitudes and phases (``value ~ sum A cos(order * theta + phase)``).

    Raises
    ------
    InputError
        If the signal covers less than half a motor revolution.

    Examples
    --------
    >>> bw = 2 * np.pi / 64
    >>> theta = (np.arange(128) + 0.5) * bw
    >>> s = discrete_position_signal(theta, 0.3 * np.cos(5 * theta + 1.0), bin_width=bw)
    >>> sp = position_spectrum(s)
    >>> k = int(np.argmax(sp.amplitude))
    >>> float(sp.order[k]), round(float(sp.amplitude[k]), 6), round(float(sp.phase[k]), 6)
    (5.0, 0.3, 1.0)
    """
    per_rev = signal.samples_per_rev
    nb = signal.value.size
    revs = nb / per_rev
    if revs < 0.5:
        raise InputError(
            f"position signal covers {revs:.3g} motor revolutions; at least half of one is "
            "needed for a spectrum"
        )
    whole = math.floor(revs + 1e-9)
    m = round(whole * per_rev) if whole >= 1 else nb
    m = min(m, nb)
    span = m / per_rev
    x = np.fft.rfft(signal.value[:m]) / m
    k = np.arange(x.size)
    order = k / span
    amplitude = 2.0 * np.abs(x)
    phase = np.angle(x) - order * signal.angle[0]
    keep = (k >= 1) & (2 * k < m)  # the Nyquist bin cannot tell amplitude from phase
    if max_order is not None:
        keep &= order <= max_order + 1e-9
    phase = np.mod(phase + np.pi, TWO_PI) - np.pi
    return Spectrum(
        order=order[keep].astype(np.float64),
        amplitude=amplitude[keep],
        phase=phase[keep],
        revolutions=span,
    )


def noise_floor(spectrum: Spectrum, *, window: int = 101) -> NDArray[np.float64]:
    """Robust local noise floor of a spectrum: the Rayleigh scale sigma at every order.

    A running median over ``window`` neighbouring orders, divided by ``sqrt(2 ln 2)`` (the
    median of a Rayleigh variable of scale 1). Sparse lines barely move a median, so this
    follows coloured noise without being lifted by the lines it must reveal.

    Returns
    -------
    ndarray
        Rayleigh scale [signal unit] per order, shape (m,).
    """
    from scipy.ndimage import median_filter

    a = spectrum.amplitude
    if a.size == 0:
        return np.zeros(0)
    w = max(3, min(window, a.size) | 1)
    med = median_filter(a, size=w, mode="reflect")
    floor = np.asarray(med / math.sqrt(2.0 * math.log(2.0)), dtype=np.float64)
    tiny = np.finfo(np.float64).tiny
    return np.maximum(floor, max(float(np.median(floor)) * 1e-3, tiny))


def fractional_floor(spectrum: Spectrum, *, window: int = 101) -> NDArray[np.float64]:
    """The noise floor of each non-integer order from the orders of its own fractional part.

    A spectrum over ``R`` whole revolutions has orders ``m / R``; those with the same
    ``m mod R`` (the same fractional part) form a class. Noise need not be the same in every
    class: what repeats in time rather than in angle does. At a constant speed the samples of
    a log fall every ``v T`` radians, an order of ``2 pi / (v T)`` CPR that is in general not
    an integer (25132.74 CPR at 0.5 rad/s and 2 kHz); it beats with the encoder's counts and
    the position bins, and lifts the noise at that fractional part of EVERY order (measured:
    twice the floor at ``k + 0.74`` CPR, a comb of dozens of spurious lines once fractional
    orders are searched). A running median over all orders does not see such a comb (it is
    ``1 / R`` of its window); one over the class's own orders does. Integer orders (class 0)
    keep the floor of all orders: a comb there is a PDTV line's own harmonics.

    Returns
    -------
    ndarray
        Rayleigh scale per order (:func:`noise_floor` of each class's orders), 0 at the
        integer orders, shape (m,).
    """
    from scipy.ndimage import median_filter

    a = spectrum.amplitude
    out = np.zeros(a.size)
    revs = round(spectrum.revolutions)
    if a.size == 0 or revs < 2 or abs(spectrum.revolutions - revs) > 1e-6:
        return out
    cls = np.round(spectrum.order * revs).astype(np.int64) % revs
    for c in range(1, revs):
        idx = np.flatnonzero(cls == c)
        if idx.size < 3:
            continue
        w = max(3, min(window, idx.size) | 1)
        med = median_filter(a[idx], size=w, mode="reflect")
        out[idx] = med / math.sqrt(2.0 * math.log(2.0))
    return out


def rayleigh_threshold(candidates: int, *, false_alarm: float = 0.01) -> float:
    """Multiple of the Rayleigh scale that pure noise exceeds with ``false_alarm`` probability.

    Over ``candidates`` independent orders: ``P(A > t sigma) = exp(-t^2 / 2)`` per order, so
    ``t = sqrt(2 ln(candidates / false_alarm))``.

    Examples
    --------
    >>> round(rayleigh_threshold(1000), 3)
    4.799
    """
    return math.sqrt(2.0 * math.log(max(candidates, 1) / false_alarm))


@dataclass(frozen=True, slots=True, eq=False)
class LinePicks:
    """Lines picked from a spectrum by :func:`pick_lines`.

    Attributes
    ----------
    order
        Picked orders [CPR], shape (p,), strongest first.
    amplitude
        Their spectrum amplitudes, shape (p,).
    floor
        Noise floor (Rayleigh scale) at every spectrum order, shape (m,).
    threshold
        Detection threshold at every spectrum order [signal unit], shape (m,).
    multiple
        The threshold in multiples of the floor.
    """

    order: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    floor: NDArray[np.float64]
    threshold: NDArray[np.float64]
    multiple: float


def pick_lines(
    spectrum: Spectrum,
    *,
    false_alarm: float = 0.01,
    fractional: Literal["auto", "never", "always"] = "auto",
    floor_window: int = 101,
) -> LinePicks:
    """Pick the significant lines of a spectrum automatically.

    A line is an order whose amplitude exceeds ``t`` times the local noise floor
    (:func:`noise_floor`), ``t = rayleigh_threshold(m, false_alarm)`` for the ``m`` orders
    searched, so that pure noise yields a spurious line with probability ``false_alarm`` per
    spectrum; and that is a local maximum of the amplitude. Non-integer orders are kept only
    when the spectrum resolves them (``fractional="auto"``: at least 4 revolutions, so the
    resolution is 0.25 CPR or finer); otherwise only orders at an integer are searched.

    Parameters
    ----------
    spectrum
        From :func:`position_spectrum`.
    false_alarm
        Probability that noise alone produces one or more picked lines.
    fractional
        ``"auto"``, ``"never"`` (integers only) or ``"always"``.
    floor_window
        Running-median window of the floor [orders].

    Returns
    -------
    LinePicks
        The orders, strongest first, and the floor and threshold used.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> bw = 2 * np.pi / 512
    >>> theta = (np.arange(512 * 4) + 0.5) * bw
    >>> y = 0.5 * np.cos(7 * theta) + 0.2 * np.cos(30 * theta + 1) + rng.normal(0, 0.1, theta.size)
    >>> pick_lines(position_spectrum(discrete_position_signal(theta, y, bin_width=bw))).order
    array([ 7., 30.])
    """
    order = spectrum.order
    amp = spectrum.amplitude
    floor = noise_floor(spectrum, window=floor_window)
    integer = np.abs(order - np.round(order)) < 0.5 / max(spectrum.revolutions, 1.0)
    integer_only = not (
        fractional == "always" or (fractional == "auto" and spectrum.revolutions >= 4.0)
    )
    if not integer_only:
        floor = np.maximum(floor, fractional_floor(spectrum, window=floor_window))
    if integer_only:
        searched = integer
    else:
        searched = np.ones(order.size, dtype=bool)
    multiple = rayleigh_threshold(int(searched.sum()), false_alarm=false_alarm)
    threshold = multiple * floor
    left = np.concatenate(([-np.inf], amp[:-1]))
    right = np.concatenate((amp[1:], [-np.inf]))
    is_peak = (amp >= left) & (amp >= right)
    if not (fractional == "always" or searched.all()):
        is_peak = np.ones(order.size, dtype=bool)
    hit = searched & is_peak & (amp > threshold)
    picked = order[hit]
    if integer_only:
        # a spectrum of under a whole number of revolutions puts integer orders slightly off
        # its bins (order k / revolutions); the lines of a motor-angle PDTV are at integers
        picked = np.round(picked)
    rank = np.argsort(-amp[hit], kind="stable")
    return LinePicks(
        order=picked[rank].astype(np.float64),
        amplitude=amp[hit][rank],
        floor=floor,
        threshold=threshold,
        multiple=multiple,
    )


@dataclass(frozen=True, slots=True, eq=False)
class HarmonicFit:
    """Least-squares fit of ``sum_k A_k cos(order_k theta + phase_k)`` plus group offsets.

    Attributes
    ----------
    order, amplitude, phase
        Per line [CPR], [signal unit], [rad]; shape (p,).
    amplitude_se
        Standard error of each amplitude (white-noise assumption), shape (p,).
    cos_sin
        Coefficients ``(a_k, b_k)`` of ``a cos + b sin``, shape (p, 2).
    covariance
        Covariance of ``(a_k, b_k)`` per line, shape (p, 2, 2).
    offsets
        Fitted offset per group, shape (g,).
    residual_rms
        RMS of the residual [signal unit].
    extra, extra_se
        Coefficients of the ``extra`` regressors and their standard errors, shape (e,).
    """

    order: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    phase: NDArray[np.float64]
    amplitude_se: NDArray[np.float64]
    cos_sin: NDArray[np.float64]
    covariance: NDArray[np.float64]
    offsets: NDArray[np.float64]
    residual_rms: float
    extra: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    extra_se: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))


def fit_harmonics(
    motor_angle: ArrayLike,
    values: ArrayLike,
    *,
    orders: Sequence[float],
    groups: ArrayLike | None = None,
    extra: ArrayLike | None = None,
    chunk: int = 20000,
) -> HarmonicFit:
    """Fit harmonics of the motor angle to all samples by linear least squares.

    Unlike averaging in bins, every sample counts with its exact angle, so no resolution is
    lost to the bin width and noise averages over all samples.

    Parameters
    ----------
    motor_angle
        Motor angle [rad], shape (n,).
    values
        Signal, shape (n,).
    orders
        Orders to fit [CPR], distinct and positive.
    groups
        Integer group label per sample (for example the pass it comes from), shape (n,); each
        group gets its own offset. Default: one offset for all.
    extra
        Further regressors fitted jointly, shape (n, e) (for example a torque rate whose
        coefficient is a measurement lag).
    chunk
        Rows per block when accumulating the normal equations (bounds memory).

    Returns
    -------
    HarmonicFit
        Amplitudes, phases, their standard errors, offsets.

    Raises
    ------
    InputError
        On mismatched shapes or fewer samples than unknowns.

    Examples
    --------
    >>> theta = np.linspace(0.0, 20.0, 2000)
    >>> fit = fit_harmonics(theta, 2.0 + 0.5 * np.cos(3 * theta - 0.4), orders=[3.0])
    >>> round(float(fit.amplitude[0]), 6), round(float(fit.phase[0]), 6), round(float(fit.offsets[0]), 6)
    (0.5, -0.4, 2.0)
    """
    normals = harmonic_normals(
        motor_angle, values, orders=orders, groups=groups, extra=extra, chunk=chunk
    )
    return solve_harmonics(normals)


@dataclass(frozen=True, slots=True, eq=False)
class HarmonicNormals:
    """Normal equations of :func:`fit_harmonics`, accumulated in one pass over the samples.

    For a set of orders, per part of a split of the samples (for example the direction of
    motion), so that :func:`solve_harmonics` fits any subset of the orders to any subset of
    the parts from them, without another pass. The regressors are the cosine and sine of
    each order and the extra regressors ("rows"); the group offsets' columns are one-hot, so
    their products are per-group sums.

    Attributes
    ----------
    orders
        The orders [CPR], shape (p,).
    xx
        Products of the rows, shape (s, 2 p + e, 2 p + e), per part.
    xg, xy
        The rows summed per group, shape (s, 2 p + e, g), and times the values, (s, 2 p + e).
    gy, counts
        The values summed per group, and the samples per group, shape (s, g).
    yy
        Sum of squared values per part, shape (s,).
    n_extra
        Extra regressors (e).
    samples
        ``(theta, values, group ranks, extra, part)``: the inputs, kept (not copied) for an
        exact second pass where the normal equations' residual would lose precision.
    chunk
        Rows per block of that pass.
    """

    orders: NDArray[np.float64]
    xx: NDArray[np.float64]
    xg: NDArray[np.float64]
    xy: NDArray[np.float64]
    gy: NDArray[np.float64]
    counts: NDArray[np.float64]
    yy: NDArray[np.float64]
    n_extra: int
    samples: tuple[NDArray[Any], ...] = ()
    chunk: int = 20000


def harmonic_normals(
    motor_angle: ArrayLike,
    values: ArrayLike,
    *,
    orders: Sequence[float],
    groups: ArrayLike | None = None,
    extra: ArrayLike | None = None,
    split: ArrayLike | None = None,
    chunk: int = 20000,
) -> HarmonicNormals:
    """Accumulate the normal equations of :func:`fit_harmonics` (solve: :func:`solve_harmonics`).

    Parameters
    ----------
    motor_angle, values, orders, groups, extra, chunk
        As :func:`fit_harmonics`.
    split
        Part of each sample, integers 0 .. s - 1, shape (n,); default one part.

    Returns
    -------
    HarmonicNormals

    Raises
    ------
    InputError
        On mismatched shapes or orders that are not positive and distinct.
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    if theta.ndim != 1 or theta.shape != y.shape:
        raise InputError("motor angle and values must be 1-D of equal length")
    ords = np.asarray(list(orders), dtype=np.float64)
    if ords.size and (np.any(ords <= 0) or np.unique(ords).size != ords.size):
        raise InputError("harmonic orders must be positive and distinct")
    if groups is None:
        g = np.zeros(theta.size, dtype=np.int64)
    else:
        labels = np.asarray(groups).ravel()
        if labels.size and labels.dtype.kind in "iub" and bool(np.all(labels[1:] >= labels[:-1])):
            # in runs, in order (passes one after another): the ranks without a sort
            g = np.concatenate(([0], np.cumsum(labels[1:] != labels[:-1]))).astype(np.int64)
        else:
            _, g = np.unique(labels, return_inverse=True)
            g = g.astype(np.int64).ravel()
    if g.size != theta.size:
        raise InputError("groups must have one label per sample")
    ng = int(g.max()) + 1 if g.size else 1
    ex = np.zeros((theta.size, 0)) if extra is None else np.asarray(extra, dtype=np.float64)
    if ex.ndim == 1:
        ex = ex[:, None]
    if ex.shape[0] != theta.size:
        raise InputError("extra regressors must have one row per sample")
    part = (
        np.zeros(theta.size, dtype=np.int64)
        if split is None
        else np.asarray(split, dtype=np.int64).ravel()
    )
    if part.size != theta.size or (part.size and part.min() < 0):
        raise InputError("split must give a part >= 0 for every sample")
    ns = int(part.max()) + 1 if part.size else 1
    nx = 2 * ords.size + ex.shape[1]
    xx = np.zeros((ns, nx, nx))
    xg = np.zeros((ns, nx, ng))
    xy = np.zeros((ns, nx))
    gy = np.zeros((ns, ng))
    counts = np.zeros((ns, ng))
    yy = np.zeros(ns)

    def add(k: int, x: NDArray[np.float64], gc: NDArray[np.int64], yc: NDArray[np.float64]) -> None:
        xx[k] += x @ x.T
        xy[k] += x @ yc
        if gc.size and bool(np.all(gc[1:] >= gc[:-1])):
            # groups in runs (passes one after another): sums over each run
            starts = np.flatnonzero(np.r_[True, gc[1:] != gc[:-1]])
            which = gc[starts]
            xg[k][:, which] += np.add.reduceat(x, starts, axis=1)
            gy[k][which] += np.add.reduceat(yc, starts)
            counts[k][which] += np.diff(np.r_[starts, gc.size])
        else:
            for r in range(nx):
                xg[k][r] += np.bincount(gc, weights=x[r], minlength=ng)
            gy[k] += np.bincount(gc, weights=yc, minlength=ng)
            counts[k] += np.bincount(gc, minlength=ng)
        yy[k] += float(yc @ yc)

    for s in range(0, theta.size, chunk):
        x = _rows(theta[s : s + chunk], ords, ex[s : s + chunk])
        gc, yc, pc = g[s : s + chunk], y[s : s + chunk], part[s : s + chunk]
        if pc.size and pc.min() == pc.max():
            add(int(pc[0]), x, gc, yc)
        else:
            for k in np.unique(pc):
                m = pc == k
                add(int(k), x[:, m], gc[m], yc[m])
    return HarmonicNormals(
        orders=ords,
        xx=xx,
        xg=xg,
        xy=xy,
        gy=gy,
        counts=counts,
        yy=yy,
        n_extra=ex.shape[1],
        samples=(theta, y, g, ex, part),
        chunk=chunk,
    )


def solve_harmonics(
    normals: HarmonicNormals,
    *,
    orders: Sequence[float] | None = None,
    parts: Sequence[int] | None = None,
) -> HarmonicFit:
    """The least-squares fit of :func:`fit_harmonics` from accumulated normal equations.

    Parameters
    ----------
    normals
        From :func:`harmonic_normals`.
    orders
        A subset of ``normals.orders`` [CPR]; default all.
    parts
        The parts of the split fitted; default all. Only the groups with samples in them
        get an offset.

    Returns
    -------
    HarmonicFit
        As :func:`fit_harmonics` on those orders and samples (equal to rounding: the same
        sums, grouped otherwise).

    Raises
    ------
    InputError
        On an order not accumulated, or fewer samples than unknowns.
    """
    all_orders = normals.orders
    if orders is None:
        idx = np.arange(all_orders.size)
    else:
        idx = np.array(
            [
                int(np.flatnonzero(all_orders == float(o))[0])
                if np.any(all_orders == float(o))
                else -1
                for o in orders
            ],
            dtype=np.int64,
        )
        if idx.size and idx.min() < 0:
            raise InputError("an order was not in the accumulated normal equations")
    chosen = (
        np.arange(normals.xx.shape[0]) if parts is None else np.asarray(list(parts), dtype=np.int64)
    )
    xx = normals.xx[chosen].sum(axis=0)
    xg = normals.xg[chosen].sum(axis=0)
    xy = normals.xy[chosen].sum(axis=0)
    gy = normals.gy[chosen].sum(axis=0)
    counts = normals.counts[chosen].sum(axis=0)
    yy = float(normals.yy[chosen].sum())
    present = np.flatnonzero(counts > 0)
    p = idx.size
    ne = normals.n_extra
    ng = present.size
    rows = np.concatenate(
        (np.stack([2 * idx, 2 * idx + 1], axis=1).ravel(), 2 * all_orders.size + np.arange(ne))
    ).astype(np.int64)
    ncol = 2 * p + ng + ne
    n = int(counts.sum())
    if n < ncol + 1:
        raise InputError(f"{n} samples cannot fit {ncol} unknowns")
    h, e = rows[: 2 * p], rows[2 * p :]
    ata = np.zeros((ncol, ncol))
    ata[: 2 * p, : 2 * p] = xx[np.ix_(h, h)]
    ata[: 2 * p, 2 * p : 2 * p + ng] = xg[np.ix_(h, present)]
    ata[: 2 * p, 2 * p + ng :] = xx[np.ix_(h, e)]
    ata[2 * p : 2 * p + ng, 2 * p : 2 * p + ng] = np.diag(counts[present])
    ata[2 * p : 2 * p + ng, 2 * p + ng :] = xg[np.ix_(e, present)].T
    ata[2 * p + ng :, 2 * p + ng :] = xx[np.ix_(e, e)]
    upper = np.triu(ata, 1)
    ata = np.triu(ata) + upper.T
    aty = np.concatenate((xy[h], gy[present], xy[e]))
    inv = np.linalg.pinv(ata)
    coef = inv @ aty
    # the residual's sum of squares from the normal equations (no second pass over the
    # samples); it loses about yy / ss of relative precision to cancellation, so where the
    # model explains nearly all of y it is summed over the samples instead
    ss = yy - 2.0 * float(coef @ aty) + float(coef @ ata @ coef)
    if not ss > 1e-6 * yy:
        ss = _residual_sum(normals, idx, chosen, present, coef)
    dof = max(n - ncol, 1)
    sigma2 = ss / dof
    ab = coef[: 2 * p].reshape(p, 2)
    cov = np.empty((p, 2, 2))
    for k in range(p):
        cov[k] = sigma2 * inv[2 * k : 2 * k + 2, 2 * k : 2 * k + 2]
    amplitude = np.hypot(ab[:, 0], ab[:, 1])
    phase = np.arctan2(-ab[:, 1], ab[:, 0])
    se = np.sqrt(np.maximum(0.5 * (cov[:, 0, 0] + cov[:, 1, 1]), 0.0))
    return HarmonicFit(
        order=all_orders[idx],
        amplitude=amplitude,
        phase=phase,
        amplitude_se=se,
        cos_sin=ab,
        covariance=cov,
        offsets=coef[2 * p : 2 * p + ng],
        residual_rms=math.sqrt(ss / n),
        extra=coef[2 * p + ng :],
        extra_se=np.sqrt(np.maximum(sigma2 * np.diag(inv)[2 * p + ng :], 0.0)),
    )


def _residual_sum(
    normals: HarmonicNormals,
    idx: NDArray[np.int64],
    chosen: NDArray[np.int64],
    present: NDArray[np.int64],
    coef: NDArray[np.float64],
) -> float:
    """The residual's sum of squares summed over the samples (no cancellation)."""
    theta, y, g, ex, part = normals.samples
    p, ng = idx.size, present.size
    offset = np.zeros(int(g.max()) + 1 if g.size else 1)
    offset[present] = coef[2 * p : 2 * p + ng]
    cx = np.concatenate((coef[: 2 * p], coef[2 * p + ng :]))
    ords = normals.orders[idx]
    use = np.isin(part, chosen)
    ss = 0.0
    for s in range(0, theta.size, normals.chunk):
        m = use[s : s + normals.chunk]
        x = _rows(theta[s : s + normals.chunk][m], ords, ex[s : s + normals.chunk][m])
        fitted = cx @ x + offset[g[s : s + normals.chunk][m]]
        ss += float(np.sum((y[s : s + normals.chunk][m] - fitted) ** 2))
    return ss


#: Integer orders up to this are raised as powers of ``exp(i theta)`` by :func:`phasors`.
POWER_ORDERS = 1 << 20


def phasors(motor_angle: ArrayLike, orders: ArrayLike) -> NDArray[np.complex128]:
    """``exp(i * order * motor_angle)`` for every order and sample, shape (p, n).

    A sine and a cosine cost tens of nanoseconds each; the integer orders (the lines of a
    motor-angle PDTV) are powers of ``z = exp(i theta)`` instead, by repeated squaring from
    one sine and one cosine per sample (a complex product costs a few nanoseconds). Order
    ``k`` then carries a relative rounding error of about ``k`` units in the last place,
    while ``cos(k * theta)`` carries ``k |theta|`` of them (the product's rounding): the
    powers are at least as accurate. Other orders are evaluated directly.

    Parameters
    ----------
    motor_angle
        Motor angle [rad], shape (n,).
    orders
        Orders [CPR], shape (p,).

    Returns
    -------
    ndarray
        Complex, shape (p, n): one row per order.

    Examples
    --------
    >>> theta = np.array([0.3, 2.0])
    >>> bool(np.allclose(phasors(theta, [3.0, 0.5]), np.exp(1j * np.outer([3.0, 0.5], theta))))
    True
    """
    theta = np.asarray(motor_angle, dtype=np.float64).ravel()
    ords = np.asarray(orders, dtype=np.float64).ravel()
    out = np.empty((ords.size, theta.size), dtype=np.complex128)
    integer = (ords == np.round(ords)) & (ords >= 1) & (ords <= POWER_ORDERS)
    if integer.any():
        z = np.empty(theta.size, dtype=np.complex128)
        z.real = np.cos(theta)
        z.imag = np.sin(theta)
        # a plain function, not a closure that calls itself: such a closure is a reference
        # cycle that would keep every power alive until the garbage collector runs
        powers: dict[int, NDArray[np.complex128]] = {1: z}
        for j in np.flatnonzero(integer):
            out[j] = _power(powers, int(ords[j]))
    for j in np.flatnonzero(~integer):
        arg = ords[j] * theta
        out[j].real = np.cos(arg)
        out[j].imag = np.sin(arg)
    return out


def _power(powers: dict[int, NDArray[np.complex128]], k: int) -> NDArray[np.complex128]:
    """``z ** k`` by repeated squaring, ``powers`` holding ``{1: z}`` and those made so far."""
    if k not in powers:
        half = _power(powers, k // 2)
        powers[k] = half * half if k % 2 == 0 else half * half * powers[1]
    return powers[k]


def _rows(
    theta: NDArray[np.float64], orders: NDArray[np.float64], extra: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Regressors as rows, shape (2 p + e, m): cos and sin of each order, the extra ones."""
    x = np.empty((2 * orders.size + extra.shape[1], theta.size))
    if orders.size:
        wave = phasors(theta, orders)
        x[0 : 2 * orders.size : 2] = wave.real
        x[1 : 2 * orders.size : 2] = wave.imag
    x[2 * orders.size :] = extra.T
    return x


def bins_per_revolution(samples_per_rev: float, *, margin: float = 1.5) -> int:
    """Largest power of two of bins per motor revolution the data fills.

    ``samples_per_rev / margin`` rounded down to a power of two: with ``margin`` samples per bin
    on average, speed ripple leaves few bins empty. The position Nyquist is half of it.

    Examples
    --------
    >>> bins_per_revolution(14700.0)
    8192
    """
    n = samples_per_rev / margin
    if n < 4:
        return 2
    return int(2 ** math.floor(math.log2(n)))
