"""Position-dependent torque variations (PDTV): the position-domain signal and its filters.

Simpson, Cook & Li sample the torque residual at fixed motor-angle intervals (the "discrete
position signal"), so that a torque ripple tied to the motor angle becomes a fixed frequency in
cycles per motor revolution (CPR, Eq 4), whatever the speed. Orders are in CPR throughout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

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
