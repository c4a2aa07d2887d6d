"""Whole-log identification of one joint: friction through zero, inertia, PDTV and delay.

Every sample of the no-load logs where the joint may be identified (the other joints still)
enters one regression, motor side::

    tau(t + d) = J(q) acc + f(v) + sum_n [a_n cos(n theta) + b_n sin(n theta)] + noise

with the friction law (:func:`friction_basis`) linear in Coulomb per direction, Stribeck
break-away per direction and viscous once its nonlinear parameters are fixed: the Stribeck
velocity ``vs``, the Stribeck exponent, the half width ``w0`` of the smooth transition through
zero (``p = (1 + tanh(v / w0)) / 2``) and the torque channel's delay ``d``. Those are searched
outside the linear fit (variable projection): a scan on a logarithmic grid then a bounded
refinement, each trial a weighted linear least-squares fit.

Both sides of the regression are seen through the same filter: the differentiated acceleration
is the true one smoothed by the differentiator's kernel ``K``
(:func:`torquemap.filters.smooth_as_acceleration`), so the torque and every other column are
smoothed by ``K`` too. The fit is robust (Huber weights, :mod:`torquemap.robust`) and its
covariance is clustered over blocks of about a second, so it stays honest although smoothed
neighbours are correlated. Everything here is linear in the number of samples.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, sparse, stats

from torquemap.errors import InputError
from torquemap.filters import lowpass, smooth_as_acceleration
from torquemap.robust import (
    HUBER_K,
    cluster_covariance,
    huber_weights,
    robust_scale,
    weighted_solve,
)

#: Equivalent noise bandwidth of the forward-backward 2nd-order Butterworth low-pass, in units of
#: its cut-off: integral of 1 / (1 + x^4)^2 over x >= 0 = 3 pi / (8 sqrt 2).
LOWPASS_ENB = 3.0 * math.pi / (8.0 * math.sqrt(2.0))
REFERENCE_CUTOFF = 2.0  # [Hz] the cut-off at which the residual's low-frequency level is measured
EXPONENTS = (0.5, 1.0, 2.0)


@dataclass(frozen=True, slots=True, eq=False)
class Piece:
    """One contiguous stretch of a log for one joint (all arrays shape (n,)).

    Attributes
    ----------
    t
        Time [s].
    theta
        Measured motor angle [rad].
    velocity, acceleration
        Differentiated motor velocity [rad/s] and acceleration [rad/s^2].
    torque
        Motor torque [N m].
    elbow
        Elbow angle [rad] (planar2r first joint), else zeros.
    use
        Samples that enter the fit (the other joints still, sound).
    joint_angles
        Joint angles [rad] of the whole robot, shape (n, nj) (for the gravity check).
    """

    t: NDArray[np.float64]
    theta: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    torque: NDArray[np.float64]
    elbow: NDArray[np.float64]
    use: NDArray[np.bool_]
    joint_angles: NDArray[np.float64]


@dataclass(frozen=True, slots=True, eq=False)
class WholeFit:
    """Result of :func:`fit_joint_whole` (motor side).

    Attributes
    ----------
    names
        Parameter names, in the order of ``coef`` and ``covariance``.
    coef
        Linear parameters, shape (p,).
    covariance
        Their cluster-robust covariance, shape (p, p).
    stribeck_velocity, stribeck_exponent, zero_velocity
        Nonlinear friction parameters [rad/s], [-], [rad/s].
    stribeck
        Whether the Stribeck terms are in the model.
    delay
        Torque channel delay [s] (0 when not significant).
    orders
        PDTV orders [CPR] and whether each is directional: ``(order, directional)``.
    residual_scale
        Robust standard deviation of the (smoothed) residual [N m].
    residual_psd
        Low-frequency one-sided power spectral density of the residual [N^2 m^2 / Hz]: its
        variance after a forward-backward 2nd-order low-pass at ``REFERENCE_CUTOFF`` divided by
        that filter's noise bandwidth.
    samples
        Samples used.
    gravity_torque
        Peak-to-peak over the visited poses of the torque explained by the joint angles [N m]
        (a gravity-like term that PDTV of the motor angle cannot explain); 0 when not tested.
    gravity_significant
        Whether that term is statistically significant.
    delay_interval
        95 % profile confidence interval of the delay [s] (spanning every candidate when the
        logs do not tell the delay apart).
    warnings
        One line each.
    """

    names: tuple[str, ...]
    coef: NDArray[np.float64]
    covariance: NDArray[np.float64]
    stribeck_velocity: float
    stribeck_exponent: float
    zero_velocity: float
    stribeck: bool
    delay: float
    orders: tuple[tuple[float, bool], ...]
    residual_scale: float
    residual_psd: float
    samples: int
    gravity_torque: float = 0.0
    gravity_significant: bool = False
    delay_interval: tuple[float, float] = (0.0, 0.0)
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def value(self, name: str, default: float = 0.0) -> float:
        """The parameter called ``name`` (``default`` when not fitted)."""
        return float(self.coef[self.names.index(name)]) if name in self.names else default


def transition(velocity: NDArray[np.float64], zero_velocity: float) -> NDArray[np.float64]:
    """Share of the positive branch: ``(1 + tanh(v / w0)) / 2``.

    Examples
    --------
    >>> transition(np.array([-1.0, 0.0, 1.0]), 1e-3).tolist()
    [0.0, 0.5, 1.0]
    """
    return np.asarray(0.5 * (1.0 + np.tanh(velocity / zero_velocity)), dtype=np.float64)


def friction_basis(
    velocity: NDArray[np.float64],
    *,
    stribeck_velocity: float,
    stribeck_exponent: float,
    zero_velocity: float,
    stribeck: bool = True,
    split_viscous: bool = False,
) -> NDArray[np.float64]:
    """Columns of the friction law, linear parameters in this order: ``coulomb_positive,
    coulomb_negative, viscous[, stribeck_positive, stribeck_negative][, viscous_negative]``.

    ``f = p (c+ + s+ e) - (1 - p) (c- + s- e) + b v`` with ``p`` the smooth transition
    (:func:`transition`) and ``e = exp(-(|v| / vs)^exponent)``; with ``split_viscous`` the
    viscous term is ``(p b + (1 - p) b-) v`` (a slope per direction).
    """
    v = np.asarray(velocity, dtype=np.float64)
    p = transition(v, zero_velocity)
    cols = [p, -(1.0 - p), p * v if split_viscous else v]
    if stribeck:
        e = np.exp(-((np.abs(v) / stribeck_velocity) ** stribeck_exponent))
        cols += [p * e, -(1.0 - p) * e]
    if split_viscous:
        cols.append((1.0 - p) * v)
    return np.column_stack(cols)


FRICTION_NAMES = (
    "friction.coulomb_positive",
    "friction.coulomb_negative",
    "friction.viscous",
    "friction.stribeck_positive",
    "friction.stribeck_negative",
)


def pdtv_basis(
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    orders: Sequence[tuple[float, bool]],
) -> tuple[NDArray[np.float64], list[str]]:
    """PDTV columns: ``cos, sin`` of each order, or per direction for directional orders.

    Names are ``pdtv.<order>.<direction>.a`` / ``.b`` for ``a cos(n theta) + b sin(n theta)``.
    """
    cols: list[NDArray[np.float64]] = []
    names: list[str] = []
    pos, neg = velocity > 0, velocity < 0
    for order, directional in orders:
        c, s = np.cos(order * theta), np.sin(order * theta)
        if directional:
            for mask, d in ((pos, "positive"), (neg, "negative")):
                cols += [c * mask, s * mask]
                names += [f"pdtv.{order:g}.{d}.a", f"pdtv.{order:g}.{d}.b"]
        else:
            cols += [c, s]
            names += [f"pdtv.{order:g}.both.a", f"pdtv.{order:g}.both.b"]
    if not cols:
        return np.zeros((theta.size, 0)), names
    return np.column_stack(cols), names


def gravity_basis(q: NDArray[np.float64], k: int, planar: bool) -> NDArray[np.float64]:
    """Joint-angle columns a gravity torque on joint ``k`` would excite: cos and sin of the
    absolute link angles from joint ``k`` on (planar chain) or of joint ``k``'s angle."""
    if planar:
        absolute = np.cumsum(q, axis=1)[:, k:]
    else:
        absolute = q[:, k : k + 1]
    return np.column_stack([np.cos(absolute), np.sin(absolute)])


@dataclass(slots=True)
class _Prepared:
    """Smoothed fixed columns and torque of all pieces, rows that enter the fit."""

    fixed: NDArray[np.float64]  # (n, m) smoothed inertia + PDTV columns
    fixed_names: list[str]
    velocity: list[NDArray[np.float64]]  # per piece, raw velocity (friction is recomputed)
    t: list[NDArray[np.float64]]
    torque_smooth: list[NDArray[np.float64]]  # per piece K * torque
    rows: list[NDArray[np.intp]]  # per piece, rows used
    clusters: NDArray[np.int64]
    window: float
    search: list[NDArray[np.intp]]  # per piece, rows of the nonlinear search (a subset of rows)
    search_pos: NDArray[np.intp]  # their positions in the stacked rows
    smoothers: list[RowSmoother]  # per piece, the smoothing at the search rows


def _prepare(
    pieces: Sequence[Piece],
    orders: Sequence[tuple[float, bool]],
    *,
    window: float,
    elbow_term: bool,
    block: float,
    inertia: bool = True,
) -> _Prepared:
    fixed, vel, ts, tq, rows, clusters, search, pos = [], [], [], [], [], [], [], []
    names: list[str] = []
    offset = 0
    stacked = 0
    for piece in pieces:
        cols = [piece.acceleration[:, None]] if inertia else []
        names = ["inertia.constant"] if inertia else []
        if elbow_term and inertia:
            cols.append((piece.acceleration * np.cos(piece.elbow))[:, None])
            names.append("inertia.cos_elbow")
        pd, pd_names = pdtv_basis(piece.theta, piece.velocity, orders)
        if pd.shape[1]:
            cols.append(smooth_as_acceleration(piece.t, pd, window=window))
        names += pd_names
        full = np.hstack(cols) if cols else np.zeros((piece.t.size, 0))
        r = np.flatnonzero(piece.use)
        fixed.append(full[r])
        vel.append(piece.velocity)
        ts.append(piece.t)
        tq.append(smooth_as_acceleration(piece.t, piece.torque, window=window))
        rows.append(r)
        # the smoothed signals change little within a quarter window: one row per quarter
        # window carries nearly all the information for the nonlinear search
        h = float(np.median(np.diff(piece.t))) if piece.t.size > 1 else window
        stride = max(1, int(window / (4.0 * h)))
        k = np.arange(0, r.size, stride)
        search.append(r[k])
        pos.append(k + stacked)
        stacked += r.size
        block_id = np.floor((piece.t[r] - piece.t[0]) / block).astype(np.int64)
        clusters.append(block_id + offset)
        offset += int(block_id.max()) + 1 if block_id.size else 0
    return _Prepared(
        fixed=np.vstack(fixed),
        fixed_names=names,
        velocity=vel,
        t=ts,
        torque_smooth=tq,
        rows=rows,
        clusters=np.concatenate(clusters),
        window=window,
        search=search,
        search_pos=np.concatenate(pos).astype(np.intp),
        smoothers=[RowSmoother.build(t, rs, window) for t, rs in zip(ts, search, strict=True)],
    )


@dataclass(frozen=True, slots=True, eq=False)
class RowSmoother:
    """:func:`torquemap.filters.smooth_as_acceleration` evaluated at some rows only.

    The smoothed signal at row ``i`` is the differentiator's acceleration (a local quadratic
    least-squares fit over the window of ``i``, :func:`torquemap.filters.differentiate`) of the
    signal's double integral; that fit is a fixed linear combination of the window's samples,
    precomputed here once per time axis. Evaluating it at one row per quarter window costs
    about four operations per sample, whatever the window holds, where smoothing every sample
    costs the window's length per sample: the nonlinear search's trials use this.

    Attributes
    ----------
    t
        Time [s] of the whole piece, shape (n,).
    operator
        The rows' weights on the double integral, sparse (rows, n).
    """

    t: NDArray[np.float64]
    operator: sparse.csr_matrix

    @classmethod
    def build(cls, t: NDArray[np.float64], rows: NDArray[np.intp], window: float) -> RowSmoother:
        """The smoother of time axis ``t`` [s] at ``rows`` for a window of ``window`` [s]."""
        from torquemap.filters import MIN_WINDOW_SAMPLES, uniform_step

        n = t.size
        h = uniform_step(t)
        half = math.floor(window / (2 * h) + 1e-9)
        if half >= 2 and 2 * half + 1 <= n and np.allclose(np.diff(t), h, rtol=1e-9, atol=0.0):
            length = 2 * half + 1
            lo = np.clip(rows - half, 0, n - length)
            hi = lo + length
        else:
            start = np.clip(t[rows] - window / 2, t[0], t[-1] - window)
            lo = np.searchsorted(t, start, side="left")
            hi = np.searchsorted(t, start + window * (1 + 1e-12), side="right")
            short = (hi - lo) < MIN_WINDOW_SAMPLES
            if short.any():
                i = rows[short]
                left = np.clip(i - MIN_WINDOW_SAMPLES // 2, 0, n - MIN_WINDOW_SAMPLES)
                lo[short] = np.minimum(lo[short], left)
                hi[short] = np.maximum(hi[short], left + MIN_WINDOW_SAMPLES)
        width = int((hi - lo).max()) if rows.size else 1
        offsets = np.arange(width)
        index = np.minimum(lo[:, None] + offsets, n - 1)
        inside = (lo[:, None] + offsets) < hi[:, None]
        scale = np.maximum(0.5 * (t[hi - 1] - t[lo]), 1e-300)
        sc = np.where(inside, (t[index] - t[rows][:, None]) / scale[:, None], 0.0)
        m = inside.astype(np.float64)
        basis = np.stack([m, m * sc, m * sc * sc], axis=-1)  # (rows, L, 3)
        normal = np.einsum("rli,rlj->rij", basis, basis)
        # the curvature's row of (S^T S)^-1 S^T, times 2 / scale^2 (acceleration)
        unit = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (rows.size, 3))[:, :, None]
        e = np.linalg.solve(normal, unit)[:, :, 0]
        weight = 2.0 * np.einsum("rlj,rj->rl", basis, e) / (scale**2)[:, None]
        operator = sparse.csr_matrix(
            (weight.ravel(), index.ravel(), np.arange(0, weight.size + 1, width)),
            shape=(rows.size, n),
        )
        return cls(t=t, operator=operator)

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The smoothed ``x`` (n, m) at the rows, shape (rows, m)."""
        mean = np.mean(x, axis=0)
        out = self.operator @ _double_integral(self.t, x - mean) + mean
        return np.asarray(out, dtype=np.float64)


def _double_integral(t: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Twice the cumulative trapezoidal integral of ``x`` (n, m) over ``t`` [s], from 0."""
    dt = np.diff(t)[:, None]
    out = np.zeros_like(x)
    out[1:] = np.cumsum(0.5 * (x[1:] + x[:-1]) * dt, axis=0)
    second = np.zeros_like(x)
    second[1:] = np.cumsum(0.5 * (out[1:] + out[:-1]) * dt, axis=0)
    return second


def _friction_columns(
    prep: _Prepared,
    vs: float,
    exponent: float,
    w0: float,
    stribeck: bool,
    *,
    search: bool = False,
    split: bool = False,
) -> NDArray[np.float64]:
    out = []
    for i, (t, v, r) in enumerate(zip(prep.t, prep.velocity, prep.rows, strict=True)):
        basis = friction_basis(
            v,
            stribeck_velocity=vs,
            stribeck_exponent=exponent,
            zero_velocity=w0,
            stribeck=stribeck,
            split_viscous=split,
        )
        if search:
            out.append(prep.smoothers[i](basis))
        else:
            out.append(smooth_as_acceleration(t, basis, window=prep.window)[r])
    return np.vstack(out)


def _torque(prep: _Prepared, delay: float, *, search: bool = False) -> NDArray[np.float64]:
    out = []
    for t, y, r, rs in zip(prep.t, prep.torque_smooth, prep.rows, prep.search, strict=True):
        rr = rs if search else r
        out.append(y[rr] if delay == 0 else np.interp(t[rr] + delay, t, y))
    return np.concatenate(out)


@dataclass(slots=True)
class _Trial:
    coef: NDArray[np.float64]
    bread: NDArray[np.float64]
    residual: NDArray[np.float64]
    wrss: float


def _solve(a: NDArray[np.float64], y: NDArray[np.float64], w: NDArray[np.float64]) -> _Trial:
    coef, bread = weighted_solve(a, y, w)
    r = y - a @ coef
    return _Trial(coef=coef, bread=bread, residual=r, wrss=float(np.sum(w * r * r)))


def fit_joint_whole(
    pieces: Sequence[Piece],
    orders: Sequence[float],
    *,
    window: float,
    resolution: float,
    top_speed: float,
    elbow_term: bool,
    stribeck: str = "auto",
    delay: float | str = "auto",
    max_delay: float = 0.25,
    reference_delay: float | None = None,
    joint: str = "",
    gravity_check: int | None = None,
    planar: bool = False,
    direction_significance: float = 0.001,
    significance: float = 0.001,
    inertia: bool = True,
    directional: bool = True,
    max_order: float = 0.0,
) -> WholeFit:
    """Fit one joint's friction, inertia, PDTV and torque delay to whole logs.

    Parameters
    ----------
    pieces
        Contiguous stretches of the logs (:class:`Piece`).
    orders
        PDTV orders [CPR] (from the pass method's line picking).
    window
        Differentiator window [s] (the smoothing kernel ``K``).
    resolution
        Velocity resolution [rad/s] (one encoder count per window): the narrowest transition.
    top_speed
        Highest motor speed in the logs [rad/s]: the widest Stribeck velocity searched.
    elbow_term
        Fit ``inertia.cos_elbow`` too.
    stribeck
        ``"auto"`` (kept when an F test at ``significance`` says so), ``"never"``, ``"always"``.
    delay
        ``"auto"``: searched in ``[-max_delay, max_delay]`` and kept when significant; or a
        fixed delay [s].
    max_delay
        Search range of the delay [s].
    reference_delay
        The pass method's delay [s] (:func:`torquemap.delay.estimate_delay`), a cross-check:
        it picks among equally good delays and is reported when it disagrees.
    joint
        Joint name (messages).
    gravity_check
        Index of this joint in the robot, to test for a torque that depends on the joint angles
        (a vertical arm); None skips the test.
    planar
        The robot is a planar chain (absolute link angles are sums of joint angles).
    direction_significance
        Level of the test that a PDTV line differs between directions (Bonferroni over lines).
    significance
        Level of the Stribeck and delay tests.
    directional
        Test PDTV lines for a difference between directions (only sensible when both
        directions were swept).
    max_order
        Highest PDTV order [CPR] to search in the residual for lines the given ``orders``
        miss (0: no search).
    inertia
        Fit the inertia; False holds it at 0 (no ramp stands out of the speed ripple, so the
        acceleration is ripple correlated with the PDTV and would bias it). A fitted inertia
        that comes out non-positive is dropped the same way, with a warning.

    Returns
    -------
    WholeFit
    """
    name = f"joint {joint}: " if joint else ""
    warnings: list[str] = []
    block = max(1.0, 20.0 * window)
    both = [(float(o), False) for o in orders]
    prep = _prepare(
        pieces, both, window=window, elbow_term=elbow_term, block=block, inertia=inertia
    )
    n = prep.fixed.shape[0]
    sub = prep.search_pos
    fixed_sub = prep.fixed[sub]
    w0_lo = max(resolution, 1e-9)
    vs_lo, vs_hi = 2.0 * w0_lo, max(top_speed, 4.0 * w0_lo)
    cache: dict[tuple[float, float, float, bool], NDArray[np.float64]] = {}

    def design_sub(vs: float, ex: float, w0: float, st: bool) -> NDArray[np.float64]:
        key = (vs, ex, w0, st)
        if key not in cache:
            if len(cache) > 64:
                cache.clear()
            cache[key] = np.hstack(
                (
                    fixed_sub,
                    _friction_columns(prep, vs, ex, w0, st, search=True, split=directional),
                )
            )
        return cache[key]

    def design(vs: float, ex: float, w0: float, st: bool) -> NDArray[np.float64]:
        return np.hstack((prep.fixed, _friction_columns(prep, vs, ex, w0, st, split=directional)))

    # starting point: no Stribeck, transition at twice the resolution, no delay; Huber weights
    # from it, held fixed through the search
    w0 = 2.0 * w0_lo
    first = _solve(
        design_sub(1.0, 2.0, w0, False), _torque(prep, 0.0, search=True), np.ones(sub.size)
    )
    ws = huber_weights(first.residual, robust_scale(first.residual))

    def cost(vs: float, ex: float, w0: float, st: bool, d: float) -> float:
        return _solve(design_sub(vs, ex, w0, st), _torque(prep, d, search=True), ws).wrss

    # the delay moves which rows are outliers (a misaligned ramp is one): each delay is scored
    # by Huber's loss at one common scale after its own reweighting, not with the weights of
    # the start, which down-weight exactly the ramps that tell the delay
    scale0 = robust_scale(first.residual)

    def delay_cost(vs: float, ex: float, w0: float, st: bool, d: float) -> float:
        a_ = design_sub(vs, ex, w0, st)
        y_ = _torque(prep, d, search=True)
        trial = _solve(a_, y_, ws)
        trial = _solve(a_, y_, huber_weights(trial.residual, scale0))
        return huber_cost(trial.residual, scale0)

    # about four search rows per differentiator window: neighbours share most of their data
    delay_dof = max(sub.size / 4.0, 1.0)
    profile: DelayProfile | None = None

    def scan_log(f: object, lo: float, hi: float, count: int) -> float:
        fun = f
        grid = np.geomspace(lo, hi, count)
        vals = [fun(float(x)) for x in grid]  # type: ignore[operator]
        i = int(np.argmin(vals))
        a_, b_ = grid[max(i - 1, 0)], grid[min(i + 1, count - 1)]
        if b_ > a_:
            res = optimize.minimize_scalar(
                lambda x: fun(math.exp(x)),  # type: ignore[operator]
                bounds=(math.log(a_), math.log(b_)),
                method="bounded",
                options={"xatol": 0.03},
            )
            if float(res.fun) <= vals[i]:
                return math.exp(float(res.x))
        return float(grid[i])

    d = 0.0 if delay == "auto" else float(delay)
    use_st = stribeck != "never"
    vs, ex = math.sqrt(vs_lo * vs_hi), 2.0
    for rnd in range(2):
        if use_st:
            best = (math.inf, vs, ex)
            scanned: dict[float, tuple[float, float]] = {}
            for e in EXPONENTS if rnd == 0 else (ex,):
                # a Stribeck dip narrower than the transition through zero trades off with it
                # (huge opposite terms that cancel): the Stribeck velocity stays above 2 w0
                v_best = scan_log(
                    lambda x, e=e, w0=w0, d=d: cost(x, e, w0, True, d),
                    min(max(vs_lo, 2.0 * w0), 0.5 * vs_hi),
                    vs_hi,
                    8,
                )
                c = cost(v_best, e, w0, True, d)
                scanned[e] = (c, v_best)
                if c < best[0]:
                    best = (c, v_best, e)
            # the Gaussian form (exponent 2) stays unless another exponent fits significantly
            # better (F test at 5 %, four search rows per window counted as one)
            if 2.0 in scanned and best[2] != 2.0:
                c2, v2 = scanned[2.0]
                if c2 - best[0] < stats.f.ppf(0.95, 1, delay_dof) * best[0] / delay_dof:
                    best = (c2, v2, 2.0)
            _, vs, ex = best
        w0 = scan_log(
            lambda x, vs=vs, ex=ex, d=d: cost(vs, ex, x, use_st, d),
            w0_lo / 4.0,
            max(0.5 * vs, w0_lo / 2.0) if use_st else max(vs_hi, w0_lo),
            8,
        )
        if delay != "auto":
            break
        profile = delay_profile(
            functools.partial(delay_cost, vs, ex, w0, use_st), max_delay, dof=delay_dof
        )
        d_new = profile.best
        moved = abs(d_new - d)
        d = d_new
        if moved < 0.1 * window:
            break
    delay_interval = (d, d)
    if profile is not None:
        d, delay_interval, note = _judge_delay(profile, reference_delay, max_delay)
        warnings += note
    # the Stribeck test (nested F test on the search rows, about independent after smoothing)
    st_used = use_st
    ysub = _torque(prep, d, search=True)
    if stribeck == "auto":
        with_st = _solve(design_sub(vs, ex, w0, True), ysub, ws)
        without = _solve(design_sub(vs, ex, w0, False), ysub, ws)
        dof = max(sub.size - with_st.coef.size, 1)
        f = ((without.wrss - with_st.wrss) / 2.0) / max(with_st.wrss / dof, 1e-300)
        i_st = fixed_sub.shape[1] + 3  # after the Coulomb pair and the (positive) viscous
        st_used = bool(
            f > stats.f.ppf(1.0 - significance, 2, dof)
            and with_st.coef[i_st] > 0
            and with_st.coef[i_st + 1] > 0
        )
    if use_st and not st_used:
        # the width was bounded by a Stribeck velocity that is not kept
        w0 = scan_log(
            lambda x, vs=vs, ex=ex, d=d: cost(vs, ex, x, False, d),
            w0_lo / 4.0,
            max(vs_hi, w0_lo),
            8,
        )
    if delay == "auto" and d != 0.0:
        zero = _solve(design_sub(vs, ex, w0, st_used), _torque(prep, 0.0, search=True), ws)
        best_d = _solve(design_sub(vs, ex, w0, st_used), ysub, ws)
        dof = max(sub.size - best_d.coef.size - 1, 1)
        f = (zero.wrss - best_d.wrss) / max(best_d.wrss / dof, 1e-300)
        if not f > stats.f.ppf(1.0 - 1e-6, 1, dof):
            d = 0.0
            delay_interval = (min(delay_interval[0], 0.0), max(delay_interval[1], 0.0))
    y = _torque(prep, d)
    first_full = _solve(design(vs, ex, w0, st_used), y, np.ones(n))
    weights = huber_weights(first_full.residual, robust_scale(first_full.residual))
    # lines the pass method missed: the spectrum of the whole fit's residual over the motor
    # angle (every sample, not only the passes)
    if max_order >= 1:
        theta = np.concatenate([p.theta[r] for p, r in zip(pieces, prep.rows, strict=True)])
        missed = _missed_orders(theta, first_full.residual, [o for o, _ in both], max_order)
        if missed:
            both = sorted([*both, *((o, False) for o in missed)])
            prep = _prepare(
                pieces, both, window=window, elbow_term=elbow_term, block=block, inertia=inertia
            )
            first_full = _solve(design(vs, ex, w0, st_used), y, np.ones(n))
            weights = huber_weights(first_full.residual, robust_scale(first_full.residual))
    # directional PDTV lines: fit both directions separately and test their difference
    final_orders = both
    if both and directional:
        split = [(o, True) for o, _ in both]
        prep_d = _prepare(
            pieces, split, window=window, elbow_term=elbow_term, block=block, inertia=inertia
        )
        a_d = np.hstack((prep_d.fixed, _friction_columns(prep_d, vs, ex, w0, st_used)))
        fit_d = _irls(a_d, y, weights)
        cov_d = cluster_covariance(a_d, fit_d.residual, weights, fit_d.bread, prep_d.clusters)
        crit = stats.chi2.ppf(1.0 - direction_significance / len(both), 2)
        chosen = []
        for o, _ in both:
            ip = prep_d.fixed_names.index(f"pdtv.{o:g}.positive.a")
            ineg = prep_d.fixed_names.index(f"pdtv.{o:g}.negative.a")
            diff = fit_d.coef[ip : ip + 2] - fit_d.coef[ineg : ineg + 2]
            sel = np.r_[ip, ip + 1, ineg, ineg + 1]
            c = cov_d[np.ix_(sel, sel)]
            cdiff = c[:2, :2] + c[2:, 2:] - c[:2, 2:] - c[2:, :2]
            chi = float(diff @ np.linalg.pinv(cdiff) @ diff)
            amp = max(np.hypot(*fit_d.coef[ip : ip + 2]), np.hypot(*fit_d.coef[ineg : ineg + 2]))
            excited = np.all(np.isfinite(cdiff)) and float(np.trace(cdiff)) > 0
            chosen.append((o, bool(excited and chi > crit and np.hypot(*diff) > 0.1 * amp)))
        final_orders = chosen
        if any(dd for _, dd in chosen):
            prep = _prepare(
                pieces, chosen, window=window, elbow_term=elbow_term, block=block, inertia=inertia
            )
    # a viscous slope per direction (only when both directions were swept): kept when the
    # difference of the two slopes is significant (Wald test, cluster covariance)
    split_visc = False
    if directional:
        a_v = np.hstack((prep.fixed, _friction_columns(prep, vs, ex, w0, st_used, split=True)))
        fit_v = _irls(a_v, y, weights)
        cov_v = cluster_covariance(a_v, fit_v.residual, fit_v.weights, fit_v.bread, prep.clusters)
        iv, ivn = prep.fixed.shape[1] + 2, a_v.shape[1] - 1
        dv = float(fit_v.coef[iv] - fit_v.coef[ivn])
        var = float(cov_v[iv, iv] + cov_v[ivn, ivn] - 2.0 * cov_v[iv, ivn])
        split_visc = bool(
            var > 0
            and dv * dv / var > stats.chi2.ppf(1.0 - significance, 1)
            and min(fit_v.coef[iv], fit_v.coef[ivn]) > 0
            # and, like a directional PDTV line, by more than 10 %
            and abs(dv) > 0.1 * max(fit_v.coef[iv], fit_v.coef[ivn])
        )
    a = np.hstack((prep.fixed, _friction_columns(prep, vs, ex, w0, st_used, split=split_visc)))
    fit = _irls(a, y, weights)
    if inertia and fit.coef[0] <= 0:
        warnings.append(
            f"the fitted inertia is not positive ({fit.coef[0]:.3g} kg m^2): no ramp stands "
            "out of the speed ripple; inertia set to 0 (record sweeps with clear accelerations)"
        )
        prep = _prepare(
            pieces, final_orders, window=window, elbow_term=False, block=block, inertia=False
        )
        a = np.hstack((prep.fixed, _friction_columns(prep, vs, ex, w0, st_used, split=split_visc)))
        fit = _irls(a, y, weights)
    cov = cluster_covariance(a, fit.residual, fit.weights, fit.bread, prep.clusters)
    names = [*prep.fixed_names, *FRICTION_NAMES[: 5 if st_used else 3]]
    if split_visc:
        names.append("friction.viscous_negative")
    scale = robust_scale(fit.residual)
    psd = _residual_psd(prep, fit.residual, scale)
    grav, grav_sig = 0.0, False
    if gravity_check is not None:
        grav, grav_sig = _gravity_test(pieces, prep, a, y, fit.weights, gravity_check, planar)
    return WholeFit(
        names=tuple(names),
        coef=fit.coef,
        covariance=cov,
        stribeck_velocity=float(vs),
        stribeck_exponent=float(ex),
        zero_velocity=float(w0),
        stribeck=st_used,
        delay=float(d),
        orders=tuple(final_orders),
        residual_scale=scale,
        residual_psd=psd,
        samples=n,
        gravity_torque=grav,
        gravity_significant=grav_sig,
        delay_interval=(float(delay_interval[0]), float(delay_interval[1])),
        warnings=tuple(name + w for w in warnings),
    )


def _judge_delay(
    profile: DelayProfile, reference: float | None, max_delay: float
) -> tuple[float, tuple[float, float], list[str]]:
    """The delay to keep, its interval and warnings: an ambiguous profile takes the candidate
    nearest the pass method's delay ``reference`` (when given) and says so; a minimum at the
    search's bound is reported; a pass method's delay outside the interval is reported."""
    notes: list[str] = []
    d = profile.best
    interval = (profile.low, profile.high)
    step = float(profile.grid[1] - profile.grid[0])
    if len(profile.candidates) > 1:
        listed = ", ".join(f"{1000 * c:.0f}" for c in profile.candidates)
        if reference is not None:
            d = min(profile.candidates, key=lambda c: abs(c - reference))
        notes.append(
            f"the torque channel's delay is not identifiable from these logs (the fit is "
            f"about as good at {listed} ms); {1000 * d:.0f} ms kept"
            + (" (nearest the pass method's)" if reference is not None else "")
            + "; record sweeps with clear accelerations (ramps) so that the delay shows"
        )
        lo = min(profile.candidates) - 0.5 * step
        hi = max(profile.candidates) + 0.5 * step
        interval = (max(min(lo, profile.low), -max_delay), min(max(hi, profile.high), max_delay))
    elif abs(d) > max_delay - step:
        notes.append(
            f"the torque channel's delay found ({1000 * d:.0f} ms) lies at the bound of the "
            f"search ({1000 * max_delay:.0f} ms): the logs may be misaligned by more"
        )
    elif reference is not None and not interval[0] - step <= reference <= interval[1] + step:
        notes.append(
            f"the pass method's delay ({1000 * reference:.0f} ms) lies outside the whole-log "
            f"fit's 95 % interval ({1000 * interval[0]:.0f} to {1000 * interval[1]:.0f} ms); "
            f"the whole-log delay ({1000 * d:.0f} ms) is kept"
        )
    return d, interval, notes


@dataclass(slots=True)
class _Irls:
    coef: NDArray[np.float64]
    bread: NDArray[np.float64]
    residual: NDArray[np.float64]
    weights: NDArray[np.float64]


def _irls(
    a: NDArray[np.float64], y: NDArray[np.float64], w: NDArray[np.float64], iterations: int = 8
) -> _Irls:
    trial = _solve(a, y, w)
    for _ in range(iterations):
        w_new = huber_weights(trial.residual, robust_scale(trial.residual))
        new = _solve(a, y, w_new)
        moved = float(np.max(np.abs(new.residual - trial.residual)))
        trial, w = new, w_new
        if moved < 1e-3 * robust_scale(trial.residual):
            break
    return _Irls(coef=trial.coef, bread=trial.bread, residual=trial.residual, weights=w)


@dataclass(frozen=True, slots=True, eq=False)
class DelayProfile:
    """The whole-log fit's cost against the torque channel's delay.

    Attributes
    ----------
    grid, cost
        Delays tried [s] and the robust cost of the fit at each.
    best
        The cost-minimising delay (grid, refined by a parabola) [s].
    low, high
        The 95 % profile confidence interval [s] (the delays whose cost is not significantly
        worse than at ``best``; correlated neighbours counted once per window).
    candidates
        Separate local minima of the cost within that threshold (``best`` first) [s]: more than
        one means the logs do not tell the delay apart.
    """

    grid: NDArray[np.float64]
    cost: NDArray[np.float64]
    best: float
    low: float
    high: float
    candidates: tuple[float, ...]


def delay_profile(
    cost: Callable[[float], float], max_delay: float, *, dof: float, steps: int = 25
) -> DelayProfile:
    """Scan ``cost`` over delays in ``[-max_delay, max_delay]`` (grid, then a parabola through
    the best three) and bound the delay by a profile F test at 95 % with ``dof`` degrees of
    freedom.

    Examples
    --------
    >>> p = delay_profile(lambda d: 100.0 + 1e6 * (d - 0.05) ** 2, 0.25, dof=100.0)
    >>> round(p.best, 4), p.low < 0.05 < p.high, p.candidates == (p.best,)
    (0.05, True, True)
    """
    grid = np.linspace(-max_delay, max_delay, steps)
    vals = np.array([cost(float(x)) for x in grid])
    k = int(np.argmin(vals))
    best, c_best = float(grid[k]), float(vals[k])
    if 0 < k < grid.size - 1:
        y0, y1, y2 = vals[k - 1], vals[k], vals[k + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            step = float(grid[1] - grid[0])
            trial = float(grid[k] + 0.5 * step * (y0 - y2) / den)
            c_trial = cost(trial)
            if c_trial <= y1:
                best, c_best = trial, c_trial
    dof = max(dof, 1.0)
    limit = c_best * (1.0 + float(stats.f.ppf(0.95, 1, dof)) / dof)
    inside = vals <= limit
    # the interval: the grid points around the best within the limit, half a step beyond
    half = 0.5 * float(grid[1] - grid[0])
    lo_k = hi_k = k
    while lo_k > 0 and inside[lo_k - 1]:
        lo_k -= 1
    while hi_k < grid.size - 1 and inside[hi_k + 1]:
        hi_k += 1
    low = max(float(grid[lo_k]) - half, -max_delay)
    high = min(float(grid[hi_k]) + half, max_delay)
    # other local minima within the limit, outside that interval
    others = [
        float(grid[i])
        for i in range(grid.size)
        if inside[i]
        and (i < lo_k or i > hi_k)
        and (i == 0 or vals[i] <= vals[i - 1])
        and (i == grid.size - 1 or vals[i] <= vals[i + 1])
    ]
    return DelayProfile(
        grid=grid,
        cost=vals,
        best=best,
        low=low,
        high=high,
        candidates=(best, *others),
    )


def huber_cost(residual: NDArray[np.float64], scale: float) -> float:
    """Sum of Huber's loss of ``residual`` at ``scale`` (k = 1.345), in squared units.

    Examples
    --------
    >>> huber_cost(np.array([0.0, 1.0, 10.0]), 1.0) == 0.5 + 1.345 * 10 - 0.5 * 1.345**2
    True
    """
    if scale <= 0:
        return float(0.5 * np.sum(residual**2))
    k = HUBER_K * scale
    a = np.abs(residual)
    return float(np.sum(np.where(a <= k, 0.5 * a * a, k * a - 0.5 * k * k)))


def _residual_psd(prep: _Prepared, residual: NDArray[np.float64], scale: float) -> float:
    """Low-frequency PSD of the residual [N^2 m^2/Hz] (see :class:`WholeFit`)."""
    values = []
    start = 0
    for t, r in zip(prep.t, prep.rows, strict=True):
        m = r.size
        res = residual[start : start + m]
        start += m
        if m < 50:
            continue
        tt = t[r]
        keep = np.concatenate(([True], np.diff(tt) > 0))
        try:
            values.append(lowpass(tt[keep], res[keep], cutoff=REFERENCE_CUTOFF))
        except InputError:  # a piece too short for the filter adds nothing
            continue
    if not values:
        return scale**2 / 50.0
    low = np.concatenate(values)
    var = robust_scale(low) ** 2
    return float(var / (LOWPASS_ENB * REFERENCE_CUTOFF))


def _gravity_test(
    pieces: Sequence[Piece],
    prep: _Prepared,
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    k: int,
    planar: bool,
) -> tuple[float, bool]:
    """Peak-to-peak torque explained by joint-angle harmonics, and whether it is significant."""
    cols = []
    for piece, r in zip(pieces, prep.rows, strict=True):
        g = gravity_basis(piece.joint_angles, k, planar)
        cols.append(smooth_as_acceleration(piece.t, g, window=prep.window)[r])
    g = np.vstack(cols)
    full = np.hstack((a, g))
    trial = _solve(full, y, w)
    cov = cluster_covariance(full, trial.residual, w, trial.bread, prep.clusters)
    m = g.shape[1]
    c = trial.coef[-m:]
    cg = cov[-m:, -m:]
    chi = float(c @ np.linalg.pinv(cg) @ c)
    torque = g @ c
    ptp = float(np.percentile(torque, 99.5) - np.percentile(torque, 0.5))
    return ptp, bool(chi > stats.chi2.ppf(1.0 - 1e-6, m))


def _missed_orders(
    theta: NDArray[np.float64],
    residual: NDArray[np.float64],
    known: Sequence[float],
    max_order: float,
    false_alarm: float = 0.01,
) -> list[float]:
    """Orders [CPR] whose line stands out of the residual's position spectrum, not in ``known``."""
    from torquemap.pdtv import discrete_position_signal, pick_lines, position_spectrum

    nb = int(2 ** math.ceil(math.log2(2 * (math.floor(max_order) + 1))))
    signal = discrete_position_signal(theta, residual, bin_width=2 * math.pi / nb)
    if signal.value.size / nb < 0.5:
        return []
    picks = pick_lines(position_spectrum(signal, max_order=max_order), false_alarm=false_alarm)
    have = {round(float(o), 6) for o in known}
    return sorted({float(o) for o in picks.order if round(float(o), 6) not in have and o > 0})
