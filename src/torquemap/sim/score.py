"""Scoring estimated forces against the simulator's truth (benchmarks, demo and tests only).

Nothing in the estimation path imports this module: it is where the hidden truth of a simulated
run meets an estimate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: The spring force of Simpson et al.'s experiment [N].
PAPER_FORCE = 3.5


@dataclass(frozen=True, slots=True, eq=False)
class ForceScore:
    """RMS error of an estimated force.

    Attributes
    ----------
    rms
        Root mean square of ``|F_est - F_true|`` over the scored samples [N].
    percent
        ``rms`` in percent of ``reference`` [%].
    max_abs
        Largest ``|F_est - F_true|`` over the scored samples [N].
    samples
        Number of samples scored.
    """

    rms: float
    percent: float
    max_abs: float
    samples: int


def force_error(
    force: ArrayLike,
    true_force: ArrayLike,
    *,
    mask: ArrayLike | None = None,
    reference: float = PAPER_FORCE,
) -> ForceScore:
    """RMS of the force error vector over the samples in ``mask`` (and finite).

    Parameters
    ----------
    force, true_force
        Estimated and true force [N], shape (n, 2).
    mask
        Samples to score, shape (n,); default all finite ones.
    reference
        Force the percentage refers to [N] (the paper's 3.5 N).

    Examples
    --------
    >>> force_error([[1.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]]).rms.__round__(6)
    0.707107
    """
    f = np.asarray(force, dtype=np.float64)
    g = np.asarray(true_force, dtype=np.float64)
    err = np.hypot(f[:, 0] - g[:, 0], f[:, 1] - g[:, 1])
    ok = np.isfinite(err)
    if mask is not None:
        ok &= np.asarray(mask, dtype=bool)
    if not ok.any():
        return ForceScore(rms=math.nan, percent=math.nan, max_abs=math.nan, samples=0)
    rms = float(np.sqrt(np.mean(err[ok] ** 2)))
    return ForceScore(
        rms=rms,
        percent=100.0 * rms / reference,
        max_abs=float(err[ok].max()),
        samples=int(ok.sum()),
    )


def common_mask(flags: Sequence[NDArray[np.int64]]) -> NDArray[np.bool_]:
    """Samples no estimate flagged: the same samples score every method."""
    out = np.ones(flags[0].shape, dtype=bool)
    for f in flags:
        out &= np.asarray(f) == 0
    return out
