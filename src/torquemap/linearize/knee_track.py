"""The knee per position: where the sensed torque leaves zero, tracked over the cycle.

The force sensor reads ``max(z, 0)``: nothing until the motor's torque overcomes the rig's
static friction at the knee ``kappa(p)`` (a base pulse width), then ``z``. The structured surface
(:mod:`torquemap.linearize.surface`) reaches its knee through the torque at rest ``o(p)``,
which trades with the rise ``phi`` and the gains below the readings; between measured positions
the residual carried at a fixed pulse width (:mod:`torquemap.linearize.knee`) cannot move a
knee that shifts by many pulse widths across a block (a narrow ramp's leading share falls from
1 to 0.5 within a few positions, and the knee rises as its inverse). The forward model there
rises too early and too softly: the tables switch the motor on early.

Here the knee is a parameter of its own:

1. At each measured position with a knee in the data, :func:`knee_at` fits the hinge
   ``s max(u - kappa, 0)`` to the rows as read (the cell means before the low-rank denoiser,
   which smooths the knee over the blocks) from level 0 up to just past the first two readings
   above three rows' noise: the censored readings below the knee weigh against an early knee,
   those above against a late one.
2. :func:`knee_between` carries it over the cycle in the surface's drive
   ``D(p, u) = sum_k S_k(p) phi(r_k(p) u)`` (the torque above the torque at rest, through the
   ramp's shares): the drive at the knee, ``theta = D(a, kappa_a)`` (the friction less the
   cogging, which change slowly with the position), linear between the measured positions
   (cyclic), and ``kappa(p)`` where ``D(p, .)`` reaches it. Given the true knees at the
   measured positions, on the family's seeds 68, 53, 81 and 13 (narrow ramps; the surface
   fitted to the rig's rows) this places the knee between them within 2.5, 1.4, 1.7 and 0.4
   pulse widths rms, against 2.8, 1.7, 2.3 and 0.7 for the leading phase's actuation
   ``kappa max_k r_k`` linear and 3.1, 1.5, 2.3 and 0.7 for ``kappa`` linear
   (docs/linearize.md, "The knee per position").
3. :func:`cut_below_knee` holds the forward model at zero below ``kappa(p)`` (a model whose
   own knee is later is left as it is).

This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def knee_at(
    sensed: NDArray[np.float64], levels: NDArray[np.float64], *, noise: float
) -> NDArray[np.float64]:
    """The base pulse width where each position's sensed torque leaves zero.

    Parameters
    ----------
    sensed
        Readings per (position, level) cell [N m], shape (P, J); NaN where not measured.
    levels
        Base pulse width of each column, ascending, shape (J,).
    noise
        One row's noise [N m].

    Returns
    -------
    ndarray
        The knee [pulse-width units], shape (P,): the hinge ``s max(u - kappa, 0)`` fitted by
        least squares to the readings from level 0 up to the level after the first two in a
        row above three rows' noise (censored below the knee: the rig reads 0 there, so every
        reading below it weighs against an early knee, every one above against a late one),
        ``kappa`` searched on a grid of a tenth of the level step; NaN where the readings from
        level 0 are not all measured or never rise above three rows' noise twice in a row, or
        already do at level 0 (no knee: the rest torque loads the contact).

    Examples
    --------
    ``0.1 (u - 18)`` read every 4th pulse width: the knee at 18.

    >>> u = np.arange(0.0, 40.0, 4.0)
    >>> knee_at(np.maximum(0.1 * (u - 18.0), 0.0)[None], u, noise=0.01).round(6).tolist()
    [18.0]
    """
    out = np.full(sensed.shape[0], np.nan)
    bar = 3.0 * noise
    for p in range(sensed.shape[0]):
        y = sensed[p]
        up = np.isfinite(y) & (y > bar)
        twice = up[:-1] & up[1:]
        if not twice.any():
            continue
        k = int(np.argmax(twice))
        last = min(k + 2, levels.size - 1)
        if k == 0 or not np.isfinite(y[: last + 1]).all():
            continue
        x, v = levels[: last + 1], y[: last + 1]
        step = float(np.min(np.diff(x))) / 10.0
        grid = np.arange(float(x[0]), float(x[k]) + step / 2, step)
        ramp = np.maximum(x[None, :] - grid[:, None], 0.0)
        slope = (ramp @ v) / np.maximum(np.sum(ramp**2, axis=1), 1e-300)
        sse = np.sum((v[None, :] - slope[:, None] * ramp) ** 2, axis=1)
        sse[slope <= 0] = np.inf
        out[p] = float(grid[int(np.argmin(sse))])
    return out


def knee_between(
    knee: NDArray[np.float64], anchors: NDArray[np.int64], drive: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The knee on every position from the measured positions' knees, carried in the drive.

    Parameters
    ----------
    knee
        Knee [pulse-width units], shape (P,); read at ``anchors`` (NaN: no knee there).
    anchors
        The measured positions, ascending, shape (K,).
    drive
        What overcomes the friction at every base pulse width ``0 .. A``, non-decreasing along
        it, shape (P, A + 1): the surface's torque above its torque at rest
        ``sum_k S_k(p) phi(r_k(p) u)`` [N m] (or, without a surface, the leading phase's
        actuation ``max_k r_k(p) u``).

    Returns
    -------
    ndarray
        Shape (P,): where each position's drive reaches ``theta(p)``, the drive at the knee
        (``drive(a, knee_a)``) linear (cyclic) between the anchors with a knee; the anchors'
        own knees at the anchors; NaN everywhere when fewer than two anchors have one, between
        two anchors when either has none, and where the drive never reaches ``theta``.

    Examples
    --------
    A leading share falling from 1 to 0.5 over four positions, the leading actuation at the
    knee 40 throughout: the knee doubles from 40 to 80.

    >>> share = np.r_[1.0, 0.875, 0.75, 0.625, 0.5, 0.75, 1.0, 1.0]
    >>> drive = share[:, None] * np.arange(101.0)[None, :]
    >>> kappa = np.where(np.arange(8) % 4 == 0, 40.0 / share, np.nan)
    >>> knee_between(kappa, np.array([0, 4]), drive)[:5].round(3).tolist()
    [40.0, 45.714, 53.333, 64.0, 80.0]
    """
    n, width = drive.shape
    u = np.arange(width, dtype=np.float64)
    ok = anchors[np.isfinite(knee[anchors])]
    out = np.full(n, np.nan)
    if ok.size < 2:
        return out
    theta = np.array([np.interp(knee[a], u, drive[a]) for a in ok])
    ext = np.concatenate([ok - n, ok, ok + n]).astype(np.float64)
    level = np.interp(np.arange(n, dtype=np.float64), ext, np.tile(theta, 3))
    for p in range(n):
        row = drive[p]
        j = int(np.argmax(row >= level[p]))
        if not row[j] >= level[p]:
            continue
        if j == 0:
            out[p] = 0.0
            continue
        rise = float(row[j] - row[j - 1])
        out[p] = j - 1 + (float(level[p] - row[j - 1]) / rise if rise > 0 else 1.0)
    # between two anchors of which one has no knee (the rest torque loads the contact): none
    valid = np.isfinite(knee[anchors])
    for i, a in enumerate(anchors):
        if valid[i] and valid[(i + 1) % anchors.size]:
            continue
        b = anchors[(i + 1) % anchors.size]
        span = np.arange(a, a + ((b - a) % n or n) + 1) % n
        out[span] = np.nan
    out[ok] = knee[ok]
    return out


def cut_below_knee(forward: NDArray[np.float64], knee: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each position's forward model held at zero below its knee.

    Parameters
    ----------
    forward
        Sensed torque on every base pulse width ``0 .. A`` [N m], shape (P, A + 1),
        non-decreasing along the pulse width; NaN where unknown.
    knee
        The knee on every position [pulse-width units], shape (P,) (:func:`knee_between`);
        NaN: the position is left as it is.

    Returns
    -------
    ndarray
        Shape (P, A + 1): zero at the pulse widths below ``knee``, ``forward`` from it on
        (a model whose own knee is later is unchanged).

    Examples
    --------
    >>> f = np.maximum(np.arange(8.0) - 2.0, 0.0)[None]  # leaves zero at 2
    >>> cut_below_knee(f, np.array([4.5])).tolist()
    [[0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 4.0, 5.0]]
    >>> cut_below_knee(f, np.array([np.nan])).tolist() == f.tolist()
    True
    """
    u = np.arange(forward.shape[1], dtype=np.float64)
    below = u[None, :] < np.where(np.isfinite(knee), knee, -np.inf)[:, None]
    out: NDArray[np.float64] = np.where(below & np.isfinite(forward), 0.0, forward)
    return out
