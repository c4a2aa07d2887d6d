"""Robust weighted least squares: iteratively reweighted (Huber) with a clustered covariance.

Identification regresses a torque on many columns over every sample of a log. Two things make
plain least squares wrong there: a few samples that the model cannot explain (a joint sticking,
a glitch) pull the fit, and neighbouring samples are not independent (the regression runs on
smoothed signals), so the textbook covariance ``s^2 (A^T A)^-1`` is far too optimistic.
:func:`robust_lstsq` answers the first with Huber weights (iteratively reweighted least squares
on a robust scale), the second with a cluster (sandwich) covariance over blocks of consecutive
samples: errors may be correlated within a block, and the covariance stays honest as long as
blocks are longer than the correlation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError

#: Huber's tuning constant: 95 % efficiency under Gaussian noise.
HUBER_K = 1.345


@dataclass(frozen=True, slots=True, eq=False)
class RobustFit:
    """Result of :func:`robust_lstsq`.

    Attributes
    ----------
    coef
        Coefficients, shape (p,).
    covariance
        Cluster-robust covariance of ``coef``, shape (p, p).
    weights
        Final Huber weights in [0, 1], shape (n,).
    residual
        ``y - a @ coef``, shape (n,).
    scale
        Robust standard deviation of the residual (1.4826 MAD).
    wrss
        Weighted residual sum of squares ``sum w r^2``.
    """

    coef: NDArray[np.float64]
    covariance: NDArray[np.float64]
    weights: NDArray[np.float64]
    residual: NDArray[np.float64]
    scale: float
    wrss: float


def robust_scale(residual: ArrayLike) -> float:
    """1.4826 times the median absolute deviation from the median (sigma for Gaussian noise).

    Examples
    --------
    >>> round(robust_scale([-1.0, 0.0, 1.0, 100.0]), 4)
    1.4826
    """
    r = np.asarray(residual, dtype=np.float64)
    if r.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(r - np.median(r))))


def exact_median(values: ArrayLike) -> float:
    """``numpy.median`` of ``values`` (flattened), selecting among the values near the median
    only.

    The two order statistics numpy averages (one for an odd count) lie between two bounds a
    sample of every 16th value suggests, six standard deviations of the sample's median apart;
    a count confirms it, and only the values between the bounds are partitioned (about a
    tenth of them; numpy copies and partitions all). Fewer than 4096 values, a NaN, or a
    count that falls short: numpy's median itself. Bit for bit numpy's but for the sign of a
    zero median (``-0.0 == 0.0`` ties may select either; tests/test_robust.py).

    Examples
    --------
    >>> x = np.random.default_rng(0).normal(size=100_001)
    >>> exact_median(x) == float(np.median(x))
    True
    """
    a = np.ravel(np.asarray(values, dtype=np.float64))
    n = a.size
    if n < 4096 or math.isnan(float(np.max(a))):
        return float(np.median(a))
    upper = n // 2  # numpy's order statistics: ``upper`` and, for an even count, ``upper - 1``
    lower = upper - 1 if n % 2 == 0 else upper
    sample = a[::16]
    m = sample.size
    # the sample's middle order statistic has a standard deviation of 0.5 / sqrt(m) in rank
    # share: 6 of them either side of the middle
    reach = math.ceil(3.0 * math.sqrt(m)) + 1
    j_lo, j_hi = max(m // 2 - reach, 0), min(m // 2 + reach, m - 1)
    picked = np.partition(sample, [j_lo, j_hi])
    lo, hi = picked[j_lo], picked[j_hi]
    below = int(np.count_nonzero(a < lo))
    window = a[(a >= lo) & (a <= hi)]
    if below > lower or below + window.size <= upper:
        return float(np.median(a))
    part = np.partition(window, [lower - below, upper - below])
    if lower == upper:
        return float(part[upper - below])
    return float(np.mean(part[lower - below : upper - below + 1]))  # numpy's mean of the two


def mad_scale(residual: ArrayLike) -> float:
    """:func:`robust_scale` by :func:`exact_median`: the same number, fewer values
    partitioned."""
    r = np.asarray(residual, dtype=np.float64)
    if r.size == 0:
        return 0.0
    return float(1.4826 * exact_median(np.abs(r - np.float64(exact_median(r)))))


def huber_weights(residual: NDArray[np.float64], scale: float) -> NDArray[np.float64]:
    """Huber weights ``min(1, k s / |r|)`` for residuals ``r`` at scale ``s``."""
    if scale <= 0:
        return np.ones(residual.size)
    u = np.abs(residual) / (HUBER_K * scale)
    return np.asarray(1.0 / np.maximum(u, 1.0), dtype=np.float64)


def cluster_medians(values: ArrayLike, clusters: ArrayLike) -> NDArray[np.float64]:
    """The median of each value's cluster, shape (n,) like ``values``.

    Parameters
    ----------
    values
        Values, shape (n,).
    clusters
        Integer cluster label of each value, shape (n,).

    Examples
    --------
    >>> cluster_medians([1.0, 5.0, 2.0, 10.0, 20.0], [0, 0, 0, 7, 7]).tolist()
    [2.0, 2.0, 2.0, 15.0, 15.0]
    """
    v = np.asarray(values, dtype=np.float64)
    c = np.asarray(clusters)
    if v.size and c.ndim == 1 and c.size == v.size and np.all(c[1:] >= c[:-1]):
        # clusters in order (blocks of consecutive rows): each one's values sorted alone
        from torquemap._fit_kernels import segment_medians

        starts = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
        stops = np.r_[starts[1:], c.size]
        return np.repeat(segment_medians(np.ascontiguousarray(v), starts, stops), stops - starts)
    labels, g = np.unique(c, return_inverse=True)
    g = g.ravel()
    if v.size == 0:
        return np.zeros(0)
    order = np.lexsort((v, g))
    sg, sv = g[order], v[order]
    starts = np.flatnonzero(np.r_[True, sg[1:] != sg[:-1]])
    stops = np.r_[starts[1:], sg.size]
    medians = np.zeros(labels.size)
    medians[sg[starts]] = 0.5 * (sv[(starts + stops - 1) // 2] + sv[(starts + stops) // 2])
    return np.asarray(medians[g], dtype=np.float64)


def weighted_solve(
    a: NDArray[np.float64], y: NDArray[np.float64], w: NDArray[np.float64], *, ridge: float = 1e-12
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weighted least squares by normal equations in column-scaled form.

    Returns ``(coef, bread)`` with ``bread = (A^T W A)^-1`` (pseudo-inverse, columns scaled to
    unit norm first for conditioning; a tiny ridge keeps an unexcited column at 0).
    """
    aw = a * w[:, None]
    ata = a.T @ aw
    d = np.sqrt(np.maximum(np.diag(ata), 0.0))
    d = np.where(d > 0, d, 1.0)
    scaled = ata / np.outer(d, d)
    scaled[np.diag_indices_from(scaled)] += ridge
    inv = np.linalg.pinv(scaled, rcond=1e-10, hermitian=True) / np.outer(d, d)
    coef = inv @ (aw.T @ y)
    return np.asarray(coef, dtype=np.float64), np.asarray(inv, dtype=np.float64)


def cluster_covariance(
    a: NDArray[np.float64],
    residual: NDArray[np.float64],
    w: NDArray[np.float64],
    bread: NDArray[np.float64],
    clusters: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Sandwich covariance ``B (sum_c s_c s_c^T) B`` with ``s_c = A_c^T W_c r_c`` per cluster.

    Scaled by ``G / (G - 1)`` for ``G`` clusters (the usual small-sample correction).
    """
    from torquemap._fit_kernels import group_sums

    score = np.ascontiguousarray(a * (w * residual)[:, None], dtype=np.float64)
    _, g = np.unique(clusters, return_inverse=True)
    ng = int(g.max()) + 1 if g.size else 1
    sums = group_sums(g.ravel().astype(np.intp), score, ng)
    meat = sums.T @ sums
    cov = bread @ meat @ bread * (ng / max(ng - 1, 1))
    return np.asarray(0.5 * (cov + cov.T), dtype=np.float64)


def cluster_jackknife_covariance(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    clusters: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Leave-one-cluster-out (jackknife, "CR3") covariance of weighted least squares
    ``y ~ a @ coef``: ``(G - 1) / G sum_g (b_g - mean b)(b_g - mean b)^T`` with ``b_g`` the fit
    without cluster ``g`` (normal equations downdated by that cluster's share).

    Unlike the sandwich (:func:`cluster_covariance`), it stays close to honest with few
    clusters and regressors that vary mostly between clusters (MacKinnon, Nielsen and Webb,
    "Cluster-robust inference: a guide to empirical practice", 2023): the sandwich's scores use
    residuals the fit has already pulled towards each cluster.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a = np.column_stack([np.ones(200), rng.normal(size=200)])
    >>> y = a @ [1.0, 2.0] + rng.normal(size=200)
    >>> cov = cluster_jackknife_covariance(a, y, np.ones(200), np.arange(200) // 10)
    >>> bool(0.03 < np.sqrt(cov[1, 1]) < 0.15)  # about 1 / sqrt(200)
    True
    """
    _, g = np.unique(clusters, return_inverse=True)
    ng = int(g.max()) + 1 if g.size else 0
    if ng < 2:
        return np.full((a.shape[1], a.shape[1]), np.inf)
    scale = np.sqrt(np.maximum(np.einsum("ij,ij,i->j", a, a, w), 0.0))
    a = a / np.where(scale > 0, scale, 1.0)  # unit columns for the pseudo-inverses
    aw = a * w[:, None]
    ata = a.T @ aw
    aty = aw.T @ y
    order = np.argsort(g, kind="stable")
    bounds = np.searchsorted(g[order], np.arange(ng + 1))
    k = a.shape[1]
    normal = np.empty((ng, k, k))
    right = np.empty((ng, k))
    for c in range(ng):
        rows = order[bounds[c] : bounds[c + 1]]
        part, wpart = a[rows], aw[rows]
        normal[c] = ata - part.T @ wpart
        right[c] = aty - wpart.T @ y[rows]
    # the pseudo-inverses in one stacked call (the same LAPACK per matrix as one call each,
    # without a Python round trip per cluster); each applied as before, bit for bit
    inverse = np.linalg.pinv(normal)
    betas = np.array([inverse[c] @ right[c] for c in range(ng)]).reshape(ng, k)
    d = (betas - betas.mean(axis=0)) / np.where(scale > 0, scale, 1.0)
    cov = (ng - 1) / ng * (d.T @ d)
    return np.asarray(0.5 * (cov + cov.T), dtype=np.float64)


def cluster_wald_pvalue(
    coef: NDArray[np.float64], cov: NDArray[np.float64], clusters: int
) -> float:
    """P-value of the Wald test that ``coef`` (m coefficients) is zero under a cluster-robust
    ``cov`` estimated from ``clusters`` clusters.

    The statistic ``W = c^T cov^+ c`` is referred to ``m F(m, G - 1)`` rather than to a
    chi-square with ``m`` degrees of freedom: a sandwich covariance summed over ``G`` clusters
    is itself estimated from ``G`` scores and is too small when ``G`` is small, so the
    chi-square reference over-rejects (Cameron, Gelbach and Miller, 2008; Cameron and Miller,
    "A practitioner's guide to cluster-robust inference", 2015, section VI). For many clusters
    both references agree.

    Examples
    --------
    >>> c, cov = np.array([1.0, 0.0]), np.eye(2) * 0.1  # W = 10
    >>> round(cluster_wald_pvalue(c, cov, 1000), 4), round(cluster_wald_pvalue(c, cov, 8), 4)
    (0.0069, 0.0448)
    """
    from scipy import stats

    m = int(coef.size)
    if m == 0:
        return 1.0
    wald = float(coef @ np.linalg.pinv(cov) @ coef)
    return float(stats.f.sf(wald / m, m, max(int(clusters) - 1, 1)))


def robust_lstsq(
    a: ArrayLike,
    y: ArrayLike,
    *,
    clusters: ArrayLike | None = None,
    iterations: int = 30,
    weights: ArrayLike | None = None,
) -> RobustFit:
    """Huber-weighted least squares ``y ~ a @ coef`` by iterative reweighting.

    Parameters
    ----------
    a
        Design matrix, shape (n, p).
    y
        Observations, shape (n,).
    clusters
        Integer block label per sample (blocks of consecutive samples longer than the errors'
        correlation), shape (n,); default every sample its own block (independent errors).
    iterations
        Most reweighting passes after the first (unweighted or ``weights``) solve; they stop
        once the fitted values move by less than 0.001 of the residual scale.
    weights
        Starting weights, shape (n,) (default 1).

    Returns
    -------
    RobustFit

    Raises
    ------
    InputError
        On fewer samples than columns or non-finite input.

    Examples
    --------
    >>> x = np.linspace(0.0, 1.0, 50)
    >>> y = 2.0 + 3.0 * x
    >>> y[7] = 1e6  # one wild sample
    >>> fit = robust_lstsq(np.c_[np.ones(50), x], y)
    >>> np.round(fit.coef, 6).tolist()
    [2.0, 3.0]
    """
    aa = np.asarray(a, dtype=np.float64)
    yy = np.asarray(y, dtype=np.float64)
    if aa.ndim != 2 or aa.shape[0] != yy.size:
        raise InputError("design matrix and observations disagree in length")
    n, p = aa.shape
    if n <= p:
        raise InputError(f"{n} samples cannot fit {p} unknowns")
    if not (np.all(np.isfinite(aa)) and np.all(np.isfinite(yy))):
        raise InputError("regression data hold NaN or inf")
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64).copy()
    coef, bread = weighted_solve(aa, yy, w)
    r = yy - aa @ coef
    scale = robust_scale(r)
    for _ in range(iterations):
        w = huber_weights(r, scale)
        new_coef, bread = weighted_solve(aa, yy, w)
        r = yy - aa @ new_coef
        step = float(np.max(np.abs((new_coef - coef) @ aa.T[:, :: max(1, n // 2000)])))
        coef = new_coef
        scale = robust_scale(r)
        if step <= 1e-3 * max(scale, 1e-300):
            break
    cl = np.arange(n) if clusters is None else np.asarray(clusters, dtype=np.int64)
    cov = cluster_covariance(aa, r, w, bread, cl)
    return RobustFit(
        coef=coef,
        covariance=cov,
        weights=w,
        residual=r,
        scale=scale,
        wrss=float(np.sum(w * r * r)),
    )
