"""The few filter designs of ``scipy.signal`` torquemap uses, without importing it.

``import scipy.signal`` costs about 1.6 s of CPU per process with scipy 1.17 (it parses the
docstrings of every function it wraps, and imports ``scipy.stats``), paid by every command that
filters, where the estimate needs two small designs: the Butterworth low-pass and its initial
state (the Savitzky-Golay weights are torquemap's own closed forms, ``filters._savgol_lags``).
These are scipy's own algorithms (scipy 1.17.1, ``scipy/signal/_filter_design.py`` and
``_signaltools.py``; BSD-3-Clause, Copyright (c) 2001-2002 Enthought, Inc. and 2003-2024 SciPy
Developers), restricted to the cases torquemap asks for and written with the same numpy
operations in the same order, so that they give scipy's coefficients bit for bit
(tests/test_signal_design.py checks them against ``scipy.signal``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray


def butter_lowpass_sos(order: int, cutoff: float, fs: float) -> NDArray[np.float64]:
    """``scipy.signal.butter(order, cutoff, btype="low", fs=fs, output="sos")``.

    Parameters
    ----------
    order
        Butterworth order, >= 1.
    cutoff
        Cut-off frequency [Hz] (-3 dB), in ``(0, fs / 2)``.
    fs
        Sampling rate [Hz].

    Returns
    -------
    ndarray
        Second-order sections, shape (ceil(order / 2), 6).

    Examples
    --------
    >>> butter_lowpass_sos(2, 10.0, 1000.0).shape
    (1, 6)
    """
    if order < 1 or int(order) != order:
        raise ValueError(f"order must be a positive integer, not {order}")
    wn = np.asarray(cutoff, dtype=np.float64) / (float(fs) / 2)
    if not 0.0 < float(wn) < 1.0:
        raise ValueError(f"cut-off {cutoff} Hz must be in (0, {float(fs) / 2}) Hz")
    # buttap: the analogue prototype's poles on the unit circle's left half
    m = np.arange(-order + 1, order, 2, dtype=np.float64)
    p = -np.exp(1j * np.pi * m / (2 * order))
    # iirfilter: the cut-off pre-warped for the bilinear transform at fs = 2
    warped = 2 * 2.0 * np.tan(np.pi * wn / 2.0)
    # lp2lp_zpk: poles scaled to the cut-off; no zeros, so the gain by wo ** order
    wo = float(warped)
    p = wo * p
    k = 1.0 * wo**order
    # bilinear_zpk: every zero at z = -1
    fs2 = 2.0 * 2.0
    p_z = (fs2 + p) / (fs2 - p)
    z_z = np.concatenate((np.asarray([], dtype=np.float64), -np.ones(order)))
    k_z = k * np.real(np.prod(fs2 - np.asarray([], dtype=np.float64)) / np.prod(fs2 - p))
    return _zpk2sos_nearest(z_z, p_z, k_z)


def _zpk2sos_nearest(
    z: NDArray[np.float64], p: NDArray[np.complex128], k: float
) -> NDArray[np.float64]:
    """``scipy.signal.zpk2sos(z, p, k)`` of a digital filter (``pairing="nearest"``) whose zeros
    are real and no more than its poles (a low-pass Butterworth's)."""
    z = np.concatenate((z, np.zeros(max(len(p) - len(z), 0))))
    n_sections = (len(p) + 1) // 2
    if len(p) % 2 == 1:
        p = np.concatenate((p, [0.0]))
        z = np.concatenate((z, [0.0]))
    z = np.concatenate(_cplxreal(z))
    p = np.concatenate(_cplxreal(p))
    sos = np.zeros((n_sections, 6))
    for si in range(n_sections - 1, -1, -1):
        p1_idx = np.argmin(np.abs(1 - np.abs(p)))  # the pole nearest the unit circle
        p1 = p[p1_idx]
        p = np.delete(p, p1_idx)
        if np.isreal(p1) and np.isreal(p).sum() == 0:
            z1_idx = _nearest_real_complex_idx(z, p1, "real")
            z1 = z[z1_idx]
            z = np.delete(z, z1_idx)
            sos[si] = _single_zpksos([z1, 0], [p1, 0])
        elif (
            len(p) + 1 == len(z)
            and not np.isreal(p1)
            and np.isreal(p).sum() == 1
            and np.isreal(z).sum() == 1
        ):
            z1_idx = _nearest_real_complex_idx(z, p1, "complex")
            z1 = z[z1_idx]
            z = np.delete(z, z1_idx)
            sos[si] = _single_zpksos([z1, z1.conj()], [p1, p1.conj()])
        else:
            if np.isreal(p1):
                prealidx = np.flatnonzero(np.isreal(p))
                p2_idx = prealidx[np.argmin(np.abs(1 - np.abs(p[prealidx])))]
                p2 = p[p2_idx]
                p = np.delete(p, p2_idx)
            else:
                p2 = p1.conj()
            if len(z) == 0:
                sos[si] = _single_zpksos([], [p1, p2])
                continue
            z1_idx = _nearest_real_complex_idx(z, p1, "any")
            z1 = z[z1_idx]
            z = np.delete(z, z1_idx)
            if not np.isreal(z1):
                sos[si] = _single_zpksos([z1, z1.conj()], [p1, p2])
            elif len(z) > 0:
                z2_idx = _nearest_real_complex_idx(z, p1, "real")
                z2 = z[z2_idx]
                z = np.delete(z, z2_idx)
                sos[si] = _single_zpksos([z1, z2], [p1, p2])
            else:
                sos[si] = _single_zpksos([z1], [p1, p2])
    if len(p) or len(z):
        raise AssertionError("zpk2sos: poles or zeros left unpaired")
    sos[0][:3] *= np.asarray(k).real
    return sos


def _cplxreal(z: NDArray[Any]) -> tuple[NDArray[Any], NDArray[Any]]:
    """``scipy.signal._filter_design._cplxreal``: the complex roots (one of each conjugate
    pair, imaginary part positive, averaged with its conjugate) and the real roots, each
    sorted by real part."""
    z = np.atleast_1d(z)
    if z.size == 0:
        return z, z
    tol = 100 * np.finfo((1.0 * z).dtype).eps
    z = z[np.lexsort((abs(z.imag), z.real))]
    real_indices = abs(z.imag) <= tol * abs(z)
    zr = z[real_indices].real
    if len(zr) == len(z):
        return np.array([]), zr
    z = z[~real_indices]
    zp = z[z.imag > 0]
    zn = z[z.imag < 0]
    if len(zp) != len(zn):
        raise ValueError("Array contains complex value with no matching conjugate.")
    same_real = np.diff(zp.real) <= tol * abs(zp[:-1])
    diffs = np.diff(np.concatenate(([0], same_real, [0])))
    run_starts = np.nonzero(diffs > 0)[0]
    run_stops = np.nonzero(diffs < 0)[0]
    for i in range(len(run_starts)):
        start = run_starts[i]
        stop = run_stops[i] + 1
        for chunk in (zp[start:stop], zn[start:stop]):
            chunk[...] = chunk[np.lexsort([abs(chunk.imag)])]
    if any(abs(zp - zn.conj()) > tol * abs(zn)):
        raise ValueError("Array contains complex value with no matching conjugate.")
    zc = (zp + zn.conj()) / 2
    return zc, zr


def _nearest_real_complex_idx(fro: NDArray[Any], to: complex, which: str) -> int:
    """``scipy.signal._filter_design._nearest_real_complex_idx``."""
    order = np.argsort(np.abs(fro - to))
    if which == "any":
        return int(order[0])
    mask = np.isreal(fro[order])
    if which == "complex":
        mask = ~mask
    return int(order[np.nonzero(mask)[0][0]])


def _single_zpksos(z: list[complex], p: list[complex]) -> NDArray[np.float64]:
    """``scipy.signal._filter_design._single_zpksos(z, p, 1)``: one section's coefficients."""
    sos = np.zeros(6)
    zz, pp = np.asarray(z), np.asarray(p)
    k = np.asarray(1, dtype=np.result_type(np.real(zz), np.real(pp), 1))
    if np.issubdtype(k.dtype, np.integer):
        k = k.astype(np.float64)
    b = np.multiply(np.atleast_1d(k), _poly(zz))
    a = np.atleast_1d(_poly(pp))
    sos[3 - len(b) : 3] = b
    sos[6 - len(a) : 6] = a
    return sos


def _poly(zeros: NDArray[Any]) -> NDArray[Any]:
    """``scipy.signal._polyutils.poly``: a polynomial's coefficients from its roots (real
    where the roots come in conjugate pairs)."""
    zeros = np.atleast_1d(np.asarray(zeros))
    if zeros.shape[0] == 0:
        return np.asarray(1.0, dtype=np.real(zeros).dtype)
    a = np.ones((1,), dtype=zeros.dtype)
    one = np.ones_like(zeros[0])
    for zero in zeros:
        a = np.convolve(a, np.stack((one, -zero)), mode="full")
    if np.iscomplexobj(a):
        roots = np.asarray(zeros, dtype=np.complex128)
        if np.all(np.sort(np.imag(roots)) == np.sort(np.imag(np.conj(roots)))):
            a = np.array(np.real(a), copy=True)
    return a


def sosfilt_zi(sos: NDArray[np.float64]) -> NDArray[np.float64]:
    """``scipy.signal.sosfilt_zi(sos)``: each section's initial state for the steady state of a
    unit step, shape (n_sections, 2).

    Examples
    --------
    >>> sos = butter_lowpass_sos(2, 10.0, 1000.0)
    >>> zi = sosfilt_zi(sos)
    >>> zi.shape
    (1, 2)
    """
    sos = np.asarray(sos, dtype=np.float64)
    if sos.ndim != 2 or sos.shape[1] != 6:
        raise ValueError("sos must be shape (n_sections, 6)")
    zi = np.empty((sos.shape[0], 2), dtype=sos.dtype)
    scale = 1.0
    for section in range(sos.shape[0]):
        b = sos[section, :3]
        a = sos[section, 3:]
        zi[section, ...] = scale * _lfilter_zi(b, a)
        scale *= np.sum(b) / np.sum(a)
    return zi


def _lfilter_zi(b: NDArray[np.float64], a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``scipy.signal.lfilter_zi(b, a)`` of one second-order section (b and a of length 3)."""
    while a.shape[0] > 1 and a[0] == 0.0:
        a = a[1:]
    if a.size < 1:
        raise ValueError("There must be at least one nonzero `a` coefficient.")
    if a[0] != 1.0:
        b = b / a[0]
        a = a / a[0]
    n = max(a.shape[0], b.shape[0])
    if a.shape[0] < n:
        a = np.concatenate((a, np.zeros(n - a.shape[0], dtype=a.dtype)))
    elif b.shape[0] < n:
        b = np.concatenate((b, np.zeros(n - b.shape[0], dtype=b.dtype)))
    # scipy.linalg.companion(a): first row -a[1:] / a[0], ones below the diagonal
    companion = np.zeros((n - 1, n - 1), dtype=np.result_type(1.0 * a[0]))
    companion[0] = -a[1:] / (1.0 * a[0:1])
    companion[list(range(1, n - 1)), list(range(0, n - 2))] = 1
    minus = np.asarray(np.eye(n - 1) - companion.T, dtype=np.result_type(a, b))
    rhs = b[1:] - a[1:] * b[0]
    return np.asarray(np.linalg.solve(minus, rhs), dtype=np.float64)
