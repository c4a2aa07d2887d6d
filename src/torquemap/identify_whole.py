"""Whole-log identification of one joint: friction through zero, inertia, PDTV and delay.

Every sample of the no-load logs where the joint may be identified (the other joints still)
enters one regression, motor side::

    tau(t + d) = J(q) acc + f(v) + sum_n [a_n cos(n theta) + b_n sin(n theta)] + noise

with the friction law a table of dry friction against log speed per direction plus a viscous
slope per direction (:class:`torquemap.friction_law.SpeedTableFriction`): linear in all its
levels, so no friction shape is assumed (a Stribeck curve of any exponent, a LuGre law's steady
state and directions that differ in every term are all tables). Only two parameters are
searched outside the linear fit: the half width ``w0`` of the smooth transition through zero
(``b = (1 + tanh(v / w0)) / 2``) and the torque channel's delay ``d``.

Where the logs hold little information about the table (speeds only crossed on a ramp), a
Gaussian smoothness prior on its first and second differences in log speed holds it: the fit
is a penalised (Bayesian) least squares and its covariance is the posterior one, large where
the logs say little, so estimation's sigmas grow there. Between two steady passes far apart,
the knots that prior holds more than any row away from the passes (the sweep crosses those
speeds only on ramps whose window reaches rest) are redrawn through the passes' own knots by a
monotone cubic in log speed (:mod:`torquemap.between_passes`), and the difference from the
fit's knots enters the covariance as a model-form variance. Opt-in (:data:`STRIBECK_PRIOR`),
the smoothness prior is centred on a generalized Stribeck curve per direction, its velocity and
exponent searched outside the linear fit (:mod:`torquemap.friction_prior`).

The table is fitted on rows whose window stays above half the slowest pass, and on slower
rows where the motion is slow but steady (:data:`LOW_SPEED_ROWS`: a run of one direction above
the transition and the velocity's quantisation, the speed within the window spread by at most
two knot steps, a small inertial torque, not in a dip between two slips,
:data:`LOW_SPEED_DIPS`): slow ramps and slow stretches measure the law below the slowest pass;
a sweep's ramps from rest, which cross those speeds within a window, do not.

Both sides of the regression are seen through the same filter: the differentiated acceleration
is the true one smoothed by the differentiator's kernel ``K``, so the torque and every other
column are smoothed by ``K`` too. Neighbouring smoothed samples carry nearly the same
information, so the fit keeps ``ROWS_PER_WINDOW`` rows per differentiator window and smooths
only there (:class:`torquemap.smooth_rows.RowSmoother`). The fit is robust (Huber weights) and
its covariance clustered over blocks of about a second. Everything is linear in the number of
samples.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal, cast

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, sparse, stats

from torquemap.above_passes import redraw_above
from torquemap.between_passes import Method, redraw_law, redraw_law_by_direction
from torquemap.errors import InputError
from torquemap.filters import dilate, lowpass
from torquemap.friction_law import SpeedTableFriction, one_direction_note
from torquemap.friction_prior import (
    SPREAD,
    StribeckPrior,
    curve_precision,
    search_curve,
    stribeck_shape,
)
from torquemap.prior_choice import HELD_OUT_Z, PriorChoice, held_out_gain
from torquemap.robust import (
    cluster_covariance,
    cluster_medians,
    cluster_wald_pvalue,
    huber_weights,
    mad_scale,
)
from torquemap.smooth_rows import RowSmoother
from torquemap.uncertainty import LOWPASS_ENB, residual_table
from torquemap.whole_delay import (
    DelayProfile,
    confirms,
    delay_profile,
    huber_cost,
    interval_around,
    judge_delay,
)

__all__ = [
    "LOWPASS_ENB",
    "Piece",
    "WholeFit",
    "fit_joint_whole",
    "gravity_basis",
    "pdtv_basis",
    "table_speeds",
]

REFERENCE_CUTOFF = 2.0  # [Hz] the cut-off at which the residual's low-frequency level is measured
#: Rows of the fit per differentiator window (the smoothed signals change little within it).
ROWS_PER_WINDOW = 8
#: Ratio of neighbouring knot speeds of the friction table.
KNOT_RATIO = 1.8
#: The table spans at most this ratio of speeds below the top speed.
KNOT_SPAN = 1000.0
#: Smallest ratio between a knot put at a steady speed and its neighbours (closer steady
#: speeds share a knot).
ANCHOR_GAP = 1.25
#: Prior standard deviation of the table's second difference between neighbouring knots, in
#: units of the joint's friction level: a Stribeck drop of the whole level within two knots
#: (a factor 3.2 in speed) is one sigma.
CURVATURE_PRIOR = 0.05
#: Prior standard deviation of the table's first difference, in units of the friction level:
#: weak, it only keeps the table level where the logs tell nothing (friction flattens at rest).
SLOPE_PRIOR = 1.0
#: Shortest run of one sign of motion whose samples enter the fit [differentiator windows].
RUN_WINDOWS = 4.0

#: Rows that score the torque delay's trials at most (all of them below that): a trial costs
#: a normal matrix over its rows, and the search tries up to 26 delays per joint. Chosen as
#: :data:`torquemap.free_law.MAX_ROWS`; a single sweep stays below it (the bench's, 0.49 M
#: samples: about 20 000 rows per joint).
DELAY_ROWS = 60_000
#: How the whole fit tries the delay grid (:func:`torquemap.whole_delay.delay_profile`):
#: ``"refine"``, coarse to fine, tries the points its profile test reads (12-21 of 25 on the
#: benches), ``"grid"`` every one.
DELAY_SEARCH: Literal["grid", "refine"] = "refine"
#: Which rows score the delay's trials (stop 40, F52). ``"all"`` (before stop 40): every row,
#: the slow ones included (creep, the ramps' starts from rest, a slow pass): the most precise
#: profile where the table holds those rows. ``"check"``: that profile, checked by a second one
#: on the rows the friction table is fitted on (no sample of their window slower than half the
#: slowest pass; when they span at least :data:`DELAY_MIN_WINDOWS` windows); when the first's
#: delay lies outside the second's interval and the second's cost there is worse than its
#: profile accepts (:func:`~torquemap.whole_delay.confirms`), the slow rows' misfit moved it
#: and the second's delay is kept. ``"kept"``: the second profile alone (measured, not kept: its fewer rows
#: leave the delay a few ms less precise, and a few ms cost the force more than they seem:
#: random robot 342, joint b 56.9 ms against 55.3 and the truth 54, 1.50x -> 2.51x the oracle).
#: On random robot 330 the slowest pass (0.51 rad/s, a third of the log) was a stick-slip
#: cycle at 12 Hz that the table (held by its prior there) cannot follow: scored on every row
#: the cost swung with a period of 85 ms and its minimum fell at 12 ms, the true delay 45 ms
#: (docs/identification.md, "The delay checked on the rows the law is fitted on").
DELAY_WEIGHTS: Literal["all", "check", "kept"] = "check"
#: Fewest differentiator windows of kept rows that score the delay's check; fewer: no check.
DELAY_MIN_WINDOWS = 50
#: Prior standard deviation of the table's first difference below the slowest observed speed,
#: in units of the friction level: a Stribeck rise of half the level within a decade of
#: speed below the slowest pass is about one sigma.
FLAT_PRIOR = 0.25
#: Periods a PDTV line found in the whole fit's residual must go through within a typical run
#: of one direction to be told from friction that differs between runs.
MIN_PERIODS = 2.0
#: Viscous torque at the top speed, in units of the friction level, that is one sigma of the
#: viscous slopes' prior: loose (real viscous torques reach about the Coulomb level), it only
#: separates a slope from a level where the logs hold a single speed.
VISCOUS_PRIOR = 10.0
#: How the table is drawn between two steady speeds more than ``KNOT_RATIO`` apart
#: (:func:`torquemap.between_passes.redraw_law`): ``"pchip"``, ``"linear"`` or ``"fit"`` (the
#: fit's own knots, held there by the smoothness prior and the passes' speed ripple).
BETWEEN_PASSES = "pchip"
#: Whether each direction's table is redrawn between its own passes only
#: (:func:`torquemap.between_passes.redraw_law_by_direction`) rather than anchored at every
#: pass speed of either direction (random robot 332 joint b: no backward pass at 50 rad/s, the
#: backward knot there was kept as fitted, 3 mN m off the line between -11.7 and -64 rad/s).
REDRAW_BY_DIRECTION = True
#: Weight of the redrawn knots against the fit's own between two passes far apart: the two are
#: estimates with opposite failures (the fit's smooth curve misses a steep Stribeck drop, the
#: monotone cubic through the passes a dip below them), so the table takes their mean and
#: their difference enters the covariance (docs/identification.md).
REDRAWN_WEIGHT = 0.5
#: Whether the table's knots above each direction's fastest pass that holds its speed are
#: redrawn along the secant of the two fastest such passes, like those between passes far apart
#: (:mod:`torquemap.above_passes`; the fit's ``held_speeds``; docs/estimation.md, "Stop 44 (F72)").
ABOVE_PASSES = True
#: A knot between passes is redrawn when the rows away from the passes hold less than this
#: share of the prior's information on it (family sweeps, ramps whose window reaches rest:
#: 1e-24 to 0.13; slow ramps of 0.4 s: 0.24 under a quadratic drag, 4-8 under a steep
#: Stribeck drop).
MEASURED_SHARE = 0.1
#: Whether rows slower than half the slowest pass enter the fit where the motion is slow but
#: steady (:func:`_low_speed_rows`: slow ramps, slow stretches), and the observed speed (where
#: estimation starts to bridge) comes down to the slowest knot they determine
#: (:func:`determined_speed`). True (the default since stop 38: neutral on the family's
#: sweeps, whose ramps cross those speeds within half a window, and 1.8-27x better on the same
#: robots swept with slow ramps, docs/identification.md). False: every row whose window reaches
#: below half the slowest pass is left out, the table there is its prior's, and the observed
#: speed is half the slowest pass.
LOW_SPEED_ROWS = True
#: Blend half widths above which the smooth transition through zero has settled (``tanh(4)
#: = 0.9993``; :data:`torquemap.estimate.TRANSITION_SPAN`): below, friction is not the table's.
TRANSITION_WIDTHS = 4.0
#: Largest standard deviation of the friction velocity's quantisation error, relative to the
#: speed, that a low-speed row may carry, in steps of the table's knots (``log KNOT_RATIO``):
#: a third of a step, 20 %.
LOW_SPEED_ERROR = 1.0 / 3.0
#: Largest ratio of the fastest to the slowest friction speed within a low-speed row's window:
#: two knot steps (a ramp that crosses a decade of speed within a window, as a sweep's ramps
#: from rest do, tells the table's knots apart no better than the prior).
LOW_SPEED_SPREAD = KNOT_RATIO**2
#: Largest inertial torque (the fitted inertia times the row's acceleration) of a low-speed row,
#: in units of the joint's torque level: a 10 % inertia error then moves it by 1 % of the level
#: (random robot 6 of the family: rows inside a stick-slip pass at 100 rad/s^2 pulled the
#: table; random robot 1: ramp rows pulled the inertia by 2 standard errors).
LOW_SPEED_INERTIAL = 0.1
#: Whether a low-speed row is left out where it lies in a dip of the speed: a speed faster by
#: ``LOW_SPEED_SPREAD`` both before and after it within ``RUN_WINDOWS`` windows
#: (:func:`speed_dips`), the slow phase of a pass that sticks and slips. Friction with memory
#: (bristles, a LuGre law) lags its steady law there: random robot 434, joint b, reads 14-23 %
#: under its steady law at 0.07-0.28 rad/s in such phases, and the table fitted to them put
#: the force 14x the oracle's error off; left out, 2.40x (docs/estimation.md, "Stop 43
#: (F64)"). A slow ramp (a speed that only rises or only falls within the span) is kept. True
#: (the default since stop 43); False: every low-speed row as before.
LOW_SPEED_DIPS = True
#: Whether a run of low-speed rows (contiguous in a piece) is left out where any of its rows
#: reads friction that does not oppose the motion: the torque less the fit's other terms
#: (inertia, PDTV) of the sign opposite to the friction velocity's by more than
#: ``2`` residual scales (:func:`dissipative_runs`). No friction law is that (the fit holds
#: its table >= 0), so the run reads something the model lacks (a load, a lag, a stuck
#: servo), not the law: random robot 441, joint b, creeps at -0.55 rad/s for 0.2 s while its
#: torque ramps from -0.05 to +0.11 N m; five of those rows held the negative table at 0
#: below 1 rad/s (truth 0.10 N m motor side; docs/estimation.md, "Stop 44 (F68)"). True (the
#: default); False: the runs are kept as before.
LOW_SPEED_READING = True
#: Whether the table's smoothness prior is centred on a generalized Stribeck curve per
#: direction (:mod:`torquemap.friction_prior`) rather than on ``a + b log s``: True, False, or
#: ``"select"`` (the default since stop 39): per direction, the curve only where, with the
#: slowest steady pass left out, its fit predicts that pass better (:mod:`torquemap.prior_choice`;
#: the family's held-out robots 281-300 median 1.789x -> 1.484x the oracle, dev 261-280 worst
#: 16.03x -> 12.22x, the paper's bench 2.79 -> 2.80 % of 3.5 N; docs/identification.md).
STRIBECK_PRIOR: bool | Literal["select"] = "select"
#: Whether a direction whose prior is centred on a Stribeck curve is still redrawn between
#: passes far apart (:data:`BETWEEN_PASSES`). True: the table is the mean of the fit's knots,
#: which follow the curve, and the redrawn ones (the paper's bench, a dip between passes at 1.5
#: and 5 rad/s: 2.80 % of 3.5 N; 3.52 % with the curve alone). False: the curve alone draws it
#: (the family's dev robots: median 1.670x the oracle against 1.724x with the redraw).
REDRAW_CURVED = True
#: Whether, with :data:`STRIBECK_PRIOR` off, the table's knots that the prior holds between
#: passes far apart carry a model-form variance from a second estimate: the same fit with its
#: prior centred on a generalized Stribeck curve (:mod:`torquemap.friction_prior`), whose
#: distance from the table is one standard deviation, fully correlated along each direction.
#: The table itself is unchanged (random robot 242 of the family: a Stribeck drop between
#: passes 4.35x apart that the table and its redraw both miss, 56 % of the errors within 2
#: sigma; docs/estimation.md).
CURVE_FORM = True
#: The rows ``stribeck_prior="select"`` chooses the table's prior by
#: (:mod:`torquemap.prior_choice`): ``"slowest"``, each direction's slowest steady pass left
#: out of both fits (:func:`_choose_prior_slowest`: which prior extrapolates from the faster
#: passes down to it); ``"unfitted"``, the rows the fit leaves out (ramps and reversals below
#: half the slowest pass, :func:`_choose_prior`).
PRIOR_CHOICE_ROWS = "slowest"
#: With the slowest pass left out (:func:`_choose_prior_slowest`), where the smoothness prior
#: turns flat: ``"half"``, below half the next steady speed (as the whole fit does below half
#: the slowest pass); ``"cut"``, below the geometric mean of the two (measured on the
#: family's robots 261-280: robot 278 5.96x the oracle against 12.2x, but 89.6 % of its
#: errors within 2 sigma; docs/identification.md).
LEFT_OUT_OBSERVED = "half"
#: The PDTV lines handed down by the pass method (stop 41, F53): ``"all"`` (the default),
#: every handed-down line is refitted over every row; ``"hold"`` (an option), a line whose
#: whole-fit amplitude exceeds the pass method's beyond their combined standard error
#: (one-sided, at :data:`HANDED_FALSE_ALARM` shared among the handed-down lines;
#: :func:`_unearned_lines`) is held at the pass method's estimate (the fit on the rows that
#: resolve it) and not refitted: random robot 363 6.42x -> 3.03x the oracle on its steady
#: samples, 367 4.91x -> 4.69x, but held-out 383 2.16x -> 3.17x and the held-out worst
#: (391) 61.4x -> 62.1x, so not the default (docs/estimation.md, "Stop 41 (F53)");
#: ``"drop"``, the line left out (measured, not kept: random robot 325's true 27 CPR line,
#: 5.64 mN m, is 5.68 +- 0.01 in the whole fit and 5.62 +- 0.01 in the passes, and went:
#: 2.18x -> 3.02x).
HANDED_LINES: Literal["hold", "drop", "all"] = "all"
#: False-alarm level of the handed-down lines' tests, shared among them (that of the search
#: for missed lines, :func:`_missed_orders`, and of its Wald test, :func:`_held_lines`).
HANDED_FALSE_ALARM = 0.01


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
    friction_velocity
        Velocity [rad/s] friction is evaluated at (default: :func:`friction_velocity` over an
        eighth of the window, which does not smear a ramp's start).
    """

    t: NDArray[np.float64]
    theta: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    torque: NDArray[np.float64]
    elbow: NDArray[np.float64]
    use: NDArray[np.bool_]
    joint_angles: NDArray[np.float64]
    friction_velocity: NDArray[np.float64] | None = None


@dataclass(frozen=True, slots=True, eq=False)
class WholeFit:
    """Result of :func:`fit_joint_whole` (motor side).

    Attributes
    ----------
    names
        Parameter names, in the order of ``coef`` and ``covariance`` (``inertia.*``,
        ``pdtv.<order>.<direction>.a|b``, ``friction.<law parameter>``).
    coef
        Linear parameters, shape (p,).
    covariance
        Their covariance, shape (p, p): cluster-robust where the logs determine them, the
        prior's where they do not.
    law
        The friction law.
    stribeck
        Whether the table may vary with speed (False: ``stribeck="never"``, one level per
        direction).
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
        Samples in the logs' rows that were used (before keeping ``ROWS_PER_WINDOW`` rows per
        window).
    gravity_torque
        Peak-to-peak over the visited poses of the torque explained by the joint angles [N m]
        (a gravity-like term that PDTV of the motor angle cannot explain); 0 when not tested.
    gravity_significant
        Whether that term is statistically significant.
    delay_interval
        95 % profile confidence interval of the delay [s].
    residual
        What the model leaves on its own logs, low-passed, per speed
        (:func:`torquemap.uncertainty.residual_table`), or None.
    observed_speed
        The slowest speed [rad/s] the table was fitted at (half the slowest pass); below it the
        table holds its prior's extrapolation.
    warnings
        One line each.
    interpolation
        The table's leave-one-pass-out interpolation error (:func:`pass_interpolation_error`),
        or None when not measured.
    prior_curve
        The generalized Stribeck curve per direction the table's prior was centred on
        (:mod:`torquemap.friction_prior`), or None (:data:`STRIBECK_PRIOR` off, a flat table,
        fewer than two steady speeds).
    prior_choice
        With ``stribeck_prior="select"``, the choice between the plain and the curve-centred
        prior per direction and its held-out gains (:class:`torquemap.prior_choice.PriorChoice`),
        or None (not asked, or no curve found).
    held_lines
        Handed-down PDTV orders [CPR] held at the pass method's estimate, or left out
        (:data:`HANDED_LINES`).
    """

    names: tuple[str, ...]
    coef: NDArray[np.float64]
    covariance: NDArray[np.float64]
    law: SpeedTableFriction
    stribeck: bool
    delay: float
    orders: tuple[tuple[float, bool], ...]
    residual_scale: float
    residual_psd: float
    samples: int
    gravity_torque: float = 0.0
    gravity_significant: bool = False
    delay_interval: tuple[float, float] = (0.0, 0.0)
    residual: dict[str, object] | None = None
    observed_speed: float = 0.0
    warnings: tuple[str, ...] = field(default_factory=tuple)
    interpolation: dict[str, object] | None = None
    prior_curve: StribeckPrior | None = None
    prior_choice: PriorChoice | None = None
    held_lines: tuple[float, ...] = ()

    @property
    def zero_velocity(self) -> float:
        """Half width of the transition through zero [rad/s]."""
        return self.law.zero_velocity

    def value(self, name: str, default: float = 0.0) -> float:
        """The parameter called ``name`` (``default`` when not fitted)."""
        return float(self.coef[self.names.index(name)]) if name in self.names else default


def table_speeds(
    top_speed: float, resolution: float, anchors: Sequence[float] = ()
) -> tuple[float, ...]:
    """Knot speeds [rad/s] of the friction table: log-spaced by at most ``KNOT_RATIO`` from
    ``max(4 resolution, top_speed / KNOT_SPAN)`` up to ``top_speed``, with a knot at each of
    ``anchors`` (the steady speeds the logs hold, [rad/s]) that lies inside that span and at
    least ``ANCHOR_GAP`` from its neighbours.

    A knot at a steady speed takes that speed's friction straight from the data; between
    knots the table is linear in log speed, so a steady speed between two knots would set
    only a combination of them, and the curvature of the true law between them would leak
    into the knot below the slowest steady speed, which nothing else holds.

    Examples
    --------
    >>> s = table_speeds(10.0, 0.01)
    >>> round(s[0], 3), round(s[-1], 3), len(s)
    (0.04, 10.0, 11)
    >>> s = table_speeds(10.0, 0.01, anchors=(2.25, 3.5))
    >>> 2.25 in s and 3.5 in s, max(b / a for a, b in zip(s, s[1:])) <= KNOT_RATIO
    (True, True)
    """
    hi = max(float(top_speed), 1e-12)
    lo = min(max(4.0 * resolution, hi / KNOT_SPAN), hi / KNOT_RATIO)
    points = [lo]
    for x in sorted(float(a) for a in anchors if math.isfinite(a)):
        if x >= points[-1] * ANCHOR_GAP and x * ANCHOR_GAP <= hi:
            points.append(x)
    points.append(hi)
    out = [lo]
    for a, b in itertools.pairwise(points):
        count = max(1, math.ceil(math.log(b / a) / math.log(KNOT_RATIO) - 1e-9))
        out += [float(x) for x in np.geomspace(a, b, count + 1)[1:]]
    return tuple(out)


def pdtv_basis(
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    orders: Sequence[tuple[float, bool]],
) -> tuple[NDArray[np.float64], list[str]]:
    """PDTV columns: ``cos, sin`` of each order, or per direction for directional orders.

    Names are ``pdtv.<order>.<direction>.a`` / ``.b`` for ``a cos(n theta) + b sin(n theta)``.
    """
    names: list[str] = []
    out = np.empty((theta.size, sum(4 if directional else 2 for _, directional in orders)))
    j = 0
    for order, directional in orders:
        c, s = np.cos(order * theta), np.sin(order * theta)
        if directional:
            for mask, d in ((velocity > 0, "positive"), (velocity < 0, "negative")):
                np.multiply(c, mask, out=out[:, j])
                np.multiply(s, mask, out=out[:, j + 1])
                names += [f"pdtv.{order:g}.{d}.a", f"pdtv.{order:g}.{d}.b"]
                j += 2
        else:
            out[:, j], out[:, j + 1] = c, s
            names += [f"pdtv.{order:g}.both.a", f"pdtv.{order:g}.both.b"]
            j += 2
    return out, names


def gravity_basis(q: NDArray[np.float64], k: int, planar: bool) -> NDArray[np.float64]:
    """Joint-angle columns a gravity torque on joint ``k`` would excite: cos and sin of the
    absolute link angles from joint ``k`` on (planar chain) or of joint ``k``'s angle."""
    if planar:
        absolute = np.cumsum(q, axis=1)[:, k:]
    else:
        absolute = q[:, k : k + 1]
    return np.column_stack([np.cos(absolute), np.sin(absolute)])


@dataclass(slots=True)
class _Rows:
    """The rows of the fit: a few per window of every piece, and their smoothers."""

    pieces: Sequence[Piece]
    rows: list[NDArray[np.intp]]
    smoothers: list[RowSmoother]
    clusters: NDArray[np.int64]
    window: float
    #: Smoothed columns that do not change between the fit's trials and refits: the torque
    #: per delay [s], the PDTV columns per ``(order, directional)`` (read-only arrays).
    cache: dict[object, NDArray[np.float64]] = field(default_factory=dict)

    def subset(self, index: NDArray[np.intp]) -> _Rows:
        """The rows ``index`` (sorted, into the stacked rows) alone, with their own smoothers
        and cache: a row's smoothing does not depend on the other rows (the same numbers)."""
        edges = np.cumsum([0, *(r.size for r in self.rows)])
        rows = [
            r[index[(index >= a) & (index < b)] - a]
            for r, a, b in zip(self.rows, edges[:-1], edges[1:], strict=True)
        ]
        return _Rows(
            pieces=self.pieces,
            rows=rows,
            smoothers=[
                RowSmoother.build(p.t, r, self.window)
                for p, r in zip(self.pieces, rows, strict=True)
            ],
            clusters=self.clusters[index],
            window=self.window,
        )

    def at(self, get: Callable[[Piece], NDArray[np.float64]]) -> NDArray[np.float64]:
        """A raw per-sample quantity at the rows, stacked over pieces."""
        return np.concatenate([get(p)[r] for p, r in zip(self.pieces, self.rows, strict=True)])

    def smooth_once(
        self, key: object, make: Callable[[Piece, int, int], NDArray[np.float64]], width: int
    ) -> NDArray[np.float64]:
        """:meth:`smooth` of ``width`` <= 4 columns (one chunk), kept under ``key``.

        A column smoothed in one chunk equals that column smoothed in any other chunk (the
        smoother's centre and sums run down each column alone): the numbers do not depend on
        the cache.
        """
        if key not in self.cache:
            out = self.smooth(make, width)
            out.setflags(write=False)
            self.cache[key] = out
        return self.cache[key]

    def smooth(
        self, make: Callable[[Piece, int, int], NDArray[np.float64]], width: int, chunk: int = 4
    ) -> NDArray[np.float64]:
        """Columns ``make(piece, j0, j1)`` (n, j1 - j0) of ``width`` columns, smoothed by the
        differentiator's kernel at the rows, stacked over pieces; built ``chunk`` columns at a
        time (memory)."""
        out = []
        for piece, sm in zip(self.pieces, self.smoothers, strict=True):
            parts = [sm(make(piece, j, min(j + chunk, width))) for j in range(0, width, chunk)]
            out.append(np.hstack(parts) if parts else np.zeros((sm.operator.shape[0], 0)))
        return np.vstack(out)


def _unsteady(
    t: NDArray[np.float64], velocity: NDArray[np.float64], rest: float, window: float
) -> NDArray[np.bool_]:
    """Samples not to fit friction on: those within a window of a sample slower than ``rest``
    [rad/s], and those of a run of one sign of motion shorter than ``RUN_WINDOWS`` windows
    (a servo hunting or creeping while it holds: its torque is static friction, anywhere in
    its band, and its velocity is not the one friction answers to)."""
    sign = np.where(velocity > rest, 1, np.where(velocity < -rest, -1, 0))
    change = np.flatnonzero(np.diff(sign)) + 1
    starts = np.r_[0, change]
    stops = np.r_[change, sign.size]
    short = np.zeros(sign.size, dtype=bool)
    for a, b in zip(starts, stops, strict=True):
        if sign[a] == 0 or t[b - 1] - t[a] < RUN_WINDOWS * window:
            short[a:b] = True
    return dilate(t, short, window)


def low_speed_floor(resolution: float, zero_velocity: float) -> float:
    """Slowest speed [rad/s] a low-speed row may see anywhere in its window
    (:data:`LOW_SPEED_ROWS`): above the transition through zero (``TRANSITION_WIDTHS`` half
    widths ``zero_velocity`` [rad/s]), and where the friction velocity's quantisation error is
    at most ``LOW_SPEED_ERROR`` knot steps of the speed.

    The friction velocity (:func:`friction_velocity`) differences the angle over a quarter of
    the differentiator's window; each end is rounded to an encoder count, ``resolution`` times
    the window (``resolution``: one count per window [rad/s]), so its error has the standard
    deviation ``4 resolution / sqrt(6)``.

    Examples
    --------
    >>> round(low_speed_floor(0.01, 0.001), 4)
    0.0833
    >>> low_speed_floor(0.01, 0.1)
    0.4
    """
    sigma = 4.0 * max(resolution, 0.0) / math.sqrt(6.0)
    quantised = sigma / (LOW_SPEED_ERROR * math.log(KNOT_RATIO))
    return max(TRANSITION_WIDTHS * zero_velocity, quantised)


def _window_spread(p: Piece, r: NDArray[np.intp], window: float) -> NDArray[np.float64]:
    """Per row ``r`` of piece ``p``, the ratio of the fastest to the slowest friction speed in
    the row's differentiator window (``+-window / 2`` [s]); inf where it reaches 0."""
    if r.size == 0:
        return np.zeros(0)
    s = np.abs(_friction_speed(p))
    lo = np.searchsorted(p.t, p.t[r] - 0.5 * window, side="left")
    hi = np.maximum(np.searchsorted(p.t, p.t[r] + 0.5 * window, side="right"), lo + 1)
    pairs = np.column_stack((lo, hi)).ravel()
    padded = np.r_[s, 0.0]  # reduceat reads one past the last window's end
    top = np.maximum.reduceat(padded, pairs)[::2]
    bottom = np.minimum.reduceat(padded, pairs)[::2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(bottom > 0, top / np.where(bottom > 0, bottom, 1.0), np.inf)


def _friction_speed(p: Piece) -> NDArray[np.float64]:
    """The velocity [rad/s] friction is evaluated at on piece ``p``."""
    return p.friction_velocity if p.friction_velocity is not None else p.velocity


def speed_dips(
    t: NDArray[np.float64], speed: NDArray[np.float64], r: NDArray[np.intp], span: float
) -> NDArray[np.bool_]:
    """Per row ``r``, whether the speed there lies in a dip: within ``span`` [s] both before
    and after the row, ``|speed|`` [rad/s] exceeds ``LOW_SPEED_SPREAD`` times the row's.

    A slow phase between two slips of a pass that sticks and slips dips; a ramp, whose speed
    only rises or only falls, does not.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> ramp = 2.0 * t
    >>> speed_dips(t, ramp, np.array([20, 50]), 0.2).tolist()
    [False, False]
    >>> slip = 0.1 + 2.0 * (np.abs(t - 0.5) > 0.1)
    >>> speed_dips(t, slip, np.array([50, 90]), 0.2).tolist()
    [True, False]
    """
    if r.size == 0:
        return np.zeros(0, dtype=bool)
    s = np.abs(speed)
    padded = np.r_[s, 0.0]  # reduceat reads one past the last window's end
    lo = np.searchsorted(t, t[r] - span, side="left")
    hi = np.searchsorted(t, t[r] + span, side="right")
    before = np.maximum.reduceat(padded, np.column_stack((lo, r)).ravel())[::2]
    after = np.maximum.reduceat(padded, np.column_stack((r, np.maximum(hi, r + 1))).ravel())[::2]
    # reduceat over an empty range (lo == r: the row is the first) gives the row's own speed
    before = np.where(lo < r, before, s[r])
    limit = LOW_SPEED_SPREAD * s[r]
    return np.asarray((before > limit) & (after > limit), dtype=bool)


def _low_speed_rows(
    rows: _Rows, floor: float, window: float, inertial: NDArray[np.float64], limit: float
) -> NDArray[np.bool_]:
    """The rows that see friction below the slowest pass in slow, steady motion: in a run of
    one direction above ``floor`` [rad/s] lasting ``RUN_WINDOWS`` windows (of ``window`` [s];
    no sample within a window slower than ``floor``, by the differentiated or the friction
    velocity), the friction speed within the row's window spread by at most
    ``LOW_SPEED_SPREAD``, the row's ``inertial`` torque [N m] at most ``limit`` [N m], and
    (:data:`LOW_SPEED_DIPS`) the row not in a dip of the speed (:func:`speed_dips`)."""
    out = []
    for p, r in zip(rows.pieces, rows.rows, strict=True):
        slow = _unsteady(p.t, p.velocity, floor, window)
        slow |= dilate(p.t, np.abs(_friction_speed(p)) < floor, 0.5 * window)
        ok = ~slow[r] & (_window_spread(p, r, window) <= LOW_SPEED_SPREAD)
        if LOW_SPEED_DIPS:
            ok &= ~speed_dips(p.t, _friction_speed(p), r, RUN_WINDOWS * window)
        out.append(ok)
    return np.concatenate(out) & (inertial <= limit) if out else np.zeros(0, dtype=bool)


def dissipative_runs(
    velocity: NDArray[np.float64],
    reading: NDArray[np.float64],
    candidate: NDArray[np.bool_],
    tolerance: float,
) -> NDArray[np.bool_]:
    """``candidate`` (the rows of one piece, in order) without every run of consecutive
    candidate rows in which some row reads non-dissipative friction:
    ``sign(velocity) * reading < -tolerance`` (``velocity`` [rad/s], ``reading`` and
    ``tolerance`` [N m]: the torque less the fit's other terms, and its allowance for noise).

    Examples
    --------
    >>> v = -np.ones(8)
    >>> f = np.array([-1.0, -1.0, -1.0, 0.5, -1.0, -1.0, -1.0, -1.0])
    >>> c = np.array([1, 1, 1, 1, 1, 0, 1, 1], dtype=bool)
    >>> dissipative_runs(v, f, c, 0.1).astype(int).tolist()
    [0, 0, 0, 0, 0, 0, 1, 1]
    """
    out = np.asarray(candidate, dtype=bool).copy()
    if not out.any():
        return out
    wrong = np.sign(velocity) * reading < -tolerance
    edges = np.flatnonzero(np.diff(np.r_[0, out.astype(np.int8), 0]))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if wrong[a:b].any():
            out[a:b] = False
    return out


def _delay_rows(rows: _Rows, max_rows: int) -> NDArray[np.intp] | None:
    """The rows (indices into the stacked rows) that score the delay's trials: None (all of
    them) up to ``max_rows``; beyond, at most ``max_rows`` in contiguous stretches of the runs
    of one direction of motion (:func:`torquemap.free_law.select_stretches`: each run's first
    and last stretch, where its ramps are, and evenly spaced stretches between)."""
    from torquemap.free_law import select_stretches

    if rows.clusters.size <= max_rows:
        return None
    times, masks, places = [], [], []
    for p, r in zip(rows.pieces, rows.rows, strict=True):
        v, tr = p.velocity[r], p.t[r]
        # a run ends where the direction changes or rows were left out (more than a window)
        cut = np.r_[False, (np.sign(v[1:]) != np.sign(v[:-1])) | (np.diff(tr) > rows.window)]
        place = np.arange(r.size) + np.cumsum(cut)
        mask = np.zeros(r.size + int(cut.sum()), dtype=bool)
        mask[place] = True
        times.append(np.interp(np.arange(mask.size), place, tr) if r.size else np.zeros(0))
        masks.append(mask)
        places.append(place)
    chosen = select_stretches(times, masks, window=rows.window, max_rows=max_rows)
    out, offset = [], 0
    for place, mask, stretches in zip(places, masks, chosen, strict=True):
        keep = np.zeros(mask.size, dtype=bool)
        for a, b in stretches:
            keep[a:b] = True
        out.append(offset + np.flatnonzero(keep[place]))
        offset += place.size
    return np.concatenate(out).astype(np.intp)


def _delay_weights(keep: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The base weights of the delay's check over its rows: 1 on the rows the table is fitted
    on (``keep`` > 0), or None when they span fewer than :data:`DELAY_MIN_WINDOWS` windows
    or are every row (no check to make).

    Examples
    --------
    >>> _delay_weights(np.r_[np.ones(400), np.zeros(100)]).sum()
    np.float64(400.0)
    >>> _delay_weights(np.r_[np.ones(399), np.zeros(100)]) is None
    True
    """
    on = keep > 0
    if np.sum(on) < DELAY_MIN_WINDOWS * ROWS_PER_WINDOW or np.all(on):
        return None
    return on.astype(np.float64)


def _prepare_rows(pieces: Sequence[Piece], window: float, block: float, rest: float) -> _Rows:
    rows, smoothers, clusters = [], [], []
    offset = 0
    for piece in pieces:
        # a row whose window reaches a start from rest sees friction at velocities the
        # differentiator smears (the velocity's kink at the start lies inside its window, and
        # friction is steepest there): such rows would teach the law a relation between the
        # differentiated velocity and friction that holds only at such starts
        near = _unsteady(piece.t, piece.velocity, rest, window)
        r = np.flatnonzero(piece.use & ~near)
        h = float(np.median(np.diff(piece.t))) if piece.t.size > 1 else window
        stride = max(1, int(window / (ROWS_PER_WINDOW * h)))
        rf = r[::stride].astype(np.intp)
        rows.append(rf)
        smoothers.append(RowSmoother.build(piece.t, rf, window))
        block_id = np.floor((piece.t[rf] - piece.t[0]) / block).astype(np.int64)
        clusters.append(block_id + offset)
        offset += int(block_id.max()) + 1 if block_id.size else 0
    return _Rows(
        pieces=pieces,
        rows=rows,
        smoothers=smoothers,
        clusters=np.concatenate(clusters) if clusters else np.zeros(0, np.int64),
        window=window,
    )


def _fixed_columns(
    rows: _Rows, orders: Sequence[tuple[float, bool]], *, elbow_term: bool, inertia: bool
) -> tuple[NDArray[np.float64], list[str]]:
    """Inertia (the differentiated acceleration is already smoothed) and PDTV columns."""
    cols: list[NDArray[np.float64]] = []
    names: list[str] = []
    if inertia:
        acc = rows.at(lambda p: p.acceleration)
        cols.append(acc[:, None])
        names.append("inertia.constant")
        if elbow_term:
            cols.append((acc * np.cos(rows.at(lambda p: p.elbow)))[:, None])
            names.append("inertia.cos_elbow")
    _, pd_names = pdtv_basis(np.zeros(1), np.zeros(1), orders)
    # a line not yet smoothed (a candidate from the residual, or a log swept one way) both
    # ways at once: its cosine and sine formed inside the smoother, the same numbers as
    # pdtv_basis's columns smoothed (tests/test_identify_whole.py)
    _prepare_both_ways(rows, [o for o, d in orders if ("pdtv", o, d) not in rows.cache])
    for line in orders:  # one order's two (four) columns at a time, each smoothed once
        cols.append(rows.cache[("pdtv", *line)])
    names += pd_names
    n = sum(r.size for r in rows.rows)
    return (np.hstack(cols) if cols else np.zeros((n, 0))), names


def _prepare_both_ways(rows: _Rows, orders: Sequence[float]) -> None:
    """The PDTV columns of lines ``orders`` for both directions and per direction at once, and
    kept (:meth:`_Rows.smooth_once`'s keys): the direction test needs both, and the cosine and
    sine of a line cost more than smoothing its columns. The six columns (:func:`pdtv_basis`'s
    for both directions, then per direction) are formed sample by sample inside the smoother
    (:meth:`torquemap.smooth_rows.RowSmoother.both_ways`): the same numbers as one at a
    time."""
    for order in orders:
        if ("pdtv", order, False) in rows.cache or ("pdtv", order, True) in rows.cache:
            continue
        columns = np.vstack(
            [
                sm.both_ways(p.theta, p.velocity, order)
                for p, sm in zip(rows.pieces, rows.smoothers, strict=True)
            ]
        )
        for key, part in (
            (("pdtv", order, False), columns[:, :2]),
            (("pdtv", order, True), columns[:, 2:]),
        ):
            kept = part.copy()
            kept.setflags(write=False)
            rows.cache[key] = kept


def _friction_columns(
    rows: _Rows,
    speeds: tuple[float, ...],
    w0: float,
    only: Sequence[int] | None = None,
) -> NDArray[np.float64]:
    """The table law's basis (:meth:`SpeedTableFriction.basis`) smoothed at the rows; with
    ``only``, just those columns (each formed sample by sample inside the smoother,
    :meth:`torquemap.smooth_rows.RowSmoother.speed_table`)."""
    k = len(speeds)
    logs = np.log(np.asarray(speeds))
    which = np.array(list(range(2 * k + 2)) if only is None else list(only), dtype=np.int64)

    def columns(p: Piece, sm: RowSmoother) -> NDArray[np.float64]:
        """Piece ``p``'s columns at its rows, from what every column is made of."""
        v = _friction_speed(p)
        s = np.abs(v)
        b = 0.5 * (1.0 + np.tanh(v / w0))
        x = np.log(np.maximum(s, 1e-300))
        i = np.clip(np.searchsorted(logs, x, side="right") - 1, 0, k - 2)
        u = np.clip((x - logs[i]) / (logs[i + 1] - logs[i]), 0.0, 1.0)
        return sm.speed_table(s, b, -(1.0 - b), i.astype(np.int64), u, which, k)

    return np.vstack([columns(p, sm) for p, sm in zip(rows.pieces, rows.smoothers, strict=True)])


def friction_velocity(
    t: NDArray[np.float64], theta: NDArray[np.float64], span: float
) -> NDArray[np.float64]:
    """Velocity [rad/s] at each sample by a central difference over ``+-span`` [s] (the angle
    interpolated linearly, one-sided at the ends): exact for a quadratic, so a ramp's start
    and end are not smeared over a differentiator window.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> friction_velocity(t, t**2, 0.05)[[10, 50, 90]].round(6).tolist()
    [0.2, 1.0, 1.8]
    """
    lo = np.maximum(t - span, t[0])
    hi = np.minimum(t + span, t[-1])
    dt = np.maximum(hi - lo, 1e-300)
    return np.asarray((np.interp(hi, t, theta) - np.interp(lo, t, theta)) / dt, dtype=np.float64)


def _delayed(p: Piece, delay: float) -> NDArray[np.float64]:
    """Piece ``p``'s torque read ``delay`` [s] later (N m), shape (n,)."""
    from torquemap._fit_kernels import interp_increasing

    return p.torque if delay == 0 else interp_increasing(p.t + delay, p.t, p.torque)


def _torque(rows: _Rows, delay: float) -> NDArray[np.float64]:
    """The torque read ``delay`` [s] later, smoothed at the rows (once per delay)."""

    def make(p: Piece, j0: int, j1: int) -> NDArray[np.float64]:
        return _delayed(p, delay)[:, None]

    return rows.smooth_once(("torque", delay), make, 1)[:, 0]


def _prepare_torques(rows: _Rows, delays: NDArray[np.float64]) -> None:
    """:func:`_torque` of every delay in ``delays`` [s], smoothed four at a time (the smoother
    reads its weights once for four columns) and kept: the same numbers as one at a time."""
    from torquemap._fit_kernels import delayed_columns

    todo = [float(d) for d in delays if ("torque", float(d)) not in rows.cache]

    def make(p: Piece, j0: int, j1: int) -> NDArray[np.float64]:
        return delayed_columns(p.t, p.torque, np.array(todo[j0:j1], dtype=np.float64))

    out = rows.smooth(make, len(todo))
    for j, d in enumerate(todo):
        column = out[:, j : j + 1].copy()
        column.setflags(write=False)
        rows.cache[("torque", d)] = column


class _LocalTorques:
    """The torque read at trial delays and smoothed at a subset of the rows (the delay's
    trials on a long log, :func:`_delay_rows`), formed only on the samples the subset's
    windows reach.

    :meth:`_Rows.subset` would smooth each trial's torque over every sample of its piece (the
    smoother's double integral runs from the piece's start); here each piece's operator is
    the subset's own (the same weights on the same samples), re-indexed onto just the samples
    it reads, and the delayed torque is read at those samples from the whole piece
    (:func:`torquemap._fit_kernels.delayed_columns_at`: the values of the whole piece's,
    bit for bit). The double integral then runs over those samples only, jumping the samples
    between: that adds a constant and a slope in time to it on every window, to which the
    smoother's curvature is blind, so the smoothed torques are the whole piece's to rounding
    (not bit for bit: the smoother's centre and running sums differ). Trials of a log with
    at most :data:`DELAY_ROWS` rows do not come here (every row scores them, as before).
    """

    def __init__(self, rows: _Rows, index: NDArray[np.intp]) -> None:
        from torquemap._fit_kernels import run_starts

        edges = np.cumsum([0, *(r.size for r in rows.rows)])
        self.pieces: list[Piece] = []
        self.at: list[NDArray[np.intp]] = []
        self.smoothers: list[RowSmoother] = []
        for p, r, sm, a, b in zip(
            rows.pieces, rows.rows, rows.smoothers, edges[:-1], edges[1:], strict=True
        ):
            place = index[(index >= a) & (index < b)] - a
            mine = r[place]
            # the piece's smoother's weights of these rows (``build`` of them, bit for bit)
            whole = sm.subset(place, mine, rows.window)
            op = whole.operator
            read = np.zeros(p.t.size, dtype=bool)
            read[op.indices] = True
            at = np.flatnonzero(read)
            # each sample's place among those read (the operator's indices are sorted rows)
            local = (np.cumsum(read, dtype=np.intp) - 1)[op.indices].astype(op.indices.dtype)
            operator = sparse.csr_matrix((op.data, local, op.indptr), shape=(mine.size, at.size))
            self.pieces.append(p)
            self.at.append(at)
            self.smoothers.append(
                RowSmoother(
                    t=np.ascontiguousarray(p.t[at]),
                    operator=operator,
                    starts=run_starts(operator.indptr, operator.indices),
                )
            )
        self.cache: dict[float, NDArray[np.float64]] = {}

    def prepare(self, delays: NDArray[np.float64]) -> None:
        """The smoothed torques of ``delays`` [s], four at a time (:func:`_prepare_torques`)."""
        from torquemap._fit_kernels import delayed_columns_at

        todo = [float(d) for d in delays if float(d) not in self.cache]
        if not todo:
            return
        out = []
        for p, at, sm in zip(self.pieces, self.at, self.smoothers, strict=True):
            parts = [
                sm(delayed_columns_at(p.t, p.torque, at, np.array(todo[j : j + 4])))
                for j in range(0, len(todo), 4)
            ]
            out.append(np.hstack(parts))
        stacked = np.vstack(out)
        for j, d in enumerate(todo):
            column = stacked[:, j].copy()
            column.setflags(write=False)
            self.cache[d] = column

    def __call__(self, delay: float) -> NDArray[np.float64]:
        """The torque read ``delay`` [s] later, smoothed at the subset's rows."""
        self.prepare(np.array([delay]))
        return self.cache[float(delay)]


def _prior(
    speeds: Sequence[float], level: float, observed: float, *, flat: bool
) -> NDArray[np.float64]:
    """Precision (2k+2, 2k+2) [1/(N m)^2] of the table's smoothness prior, both directions,
    and a loose one of the viscous slopes [1/(N m s/rad)^2]. Below ``observed`` [rad/s] (where the table is not fitted)
    the first differences are held by ``FLAT_PRIOR``: friction levels off towards rest, and
    the posterior's variance there grows with the distance from the observed speeds."""
    k = len(speeds)
    out = np.zeros((2 * k + 2, 2 * k + 2))
    lev = max(level, 1e-12)
    below = np.asarray(speeds[1:]) <= observed
    tau1 = np.where(below, FLAT_PRIOR, SLOPE_PRIOR) * lev
    if flat:
        tau1 = np.full(k - 1, 1e-3 * lev)
    # below the observed speeds the curvature is free (so that the table levels off rather
    # than carrying the slope of its lowest observed knots on)
    tau2 = np.where(np.asarray(speeds[:-2]) < observed, SLOPE_PRIOR, CURVATURE_PRIOR) * lev
    # knots need not be evenly spaced (a knot at each steady speed): the level is a random
    # walk in log speed and so is its slope, per nominal step log(KNOT_RATIO) ``h``
    h = np.diff(np.log(np.asarray(speeds, dtype=np.float64))) / math.log(KNOT_RATIO)
    d1 = np.diff(np.eye(k), axis=0) / (tau1 * np.sqrt(h))[:, None]
    slopes = np.diff(np.eye(k), axis=0) / h[:, None]
    d2 = np.diff(slopes, axis=0) / (tau2 * np.sqrt(0.5 * (h[:-1] + h[1:])))[:, None]
    block = d1.T @ d1 + d2.T @ d2
    out[:k, :k] = block
    out[k : 2 * k, k : 2 * k] = block
    # the viscous slopes: a loose prior (their torque at the top speed within VISCOUS_PRIOR
    # times the level, one sigma) that only matters where the logs cannot tell a slope from a
    # level: logs at one steady speed, where the two columns are the same
    sigma_b = VISCOUS_PRIOR * lev / max(float(speeds[-1]), 1e-12)
    out[2 * k, 2 * k] = out[2 * k + 1, 2 * k + 1] = 1.0 / sigma_b**2
    return out


def _scaled_solve(matrix: NDArray[np.float64], vector: NDArray[np.float64]) -> NDArray[np.float64]:
    """``matrix^-1 vector`` of a symmetric positive (semi)definite ``matrix``, its rows and
    columns scaled to unit diagonal first (a tiny ridge keeps unexcited columns at 0)."""
    d = np.sqrt(np.maximum(np.diagonal(matrix), 1e-300))
    scaled = matrix / np.multiply.outer(d, d)
    scaled.flat[:: scaled.shape[0] + 1] += 1e-12  # the diagonal
    return np.asarray(np.linalg.solve(scaled, vector / d) / d)


def _curve_objective(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    weights: NDArray[np.float64],
    m: int,
    noise: float,
) -> Callable[[NDArray[np.float64]], tuple[float, NDArray[np.float64]]]:
    """The fit's penalised objective for a table precision (friction columns from ``m`` on),
    the design ``a``, torque ``y`` and ``weights`` held, in noise variances (``noise``
    [N^2 m^2]), and the fit's friction coefficients: what
    :func:`torquemap.friction_prior.search_curve` chooses the curve by."""
    normal = a.T @ (a * weights[:, None])
    rhs = a.T @ (weights * y)
    total = float(y @ (weights * y))

    def objective(table: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        full = normal.copy()
        full[m:, m:] += noise * table
        coef = _scaled_solve(full, rhs)
        # min_c |y - A c|_W^2 + c^T P c = y^T W y - b^T (N + P)^-1 b
        return (total - float(rhs @ coef)) / noise, coef[m:]

    return objective


@dataclass(slots=True)
class _Trial:
    coef: NDArray[np.float64]
    bread: NDArray[np.float64]
    residual: NDArray[np.float64]
    weights: NDArray[np.float64]
    prior: NDArray[np.float64]
    #: The design's product over the kept rows that :func:`_irls` built (another fit on the
    #: same design and rows reuses it)
    gram: _Gram | None = None

    @property
    def objective(self) -> float:
        """The penalised weighted sum of squares the fit minimised (formed when asked)."""
        r = self.residual
        return float(np.sum(self.weights * r * r) + self.coef @ self.prior @ self.coef)


def _psolve(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    prior: NDArray[np.float64],
) -> _Trial:
    """Weighted least squares with a quadratic penalty ``coef^T prior coef`` (normal equations,
    columns scaled for conditioning; a tiny ridge keeps unexcited columns at 0)."""
    return _Solver(a, w, prior)(y)


class _Gram:
    """``A^T diag(w) A`` of one design ``A`` for many weights ``w`` that equal the base weights
    ``b`` on most rows (Huber's weights are 1 on every row inside the threshold).

    ``A^T diag(b) A`` is formed once; each ``w`` then costs a product over the rows where it
    differs from ``b`` only: ``A^T diag(w) A = A^T diag(b) A - A_S^T diag(b_S - w_S) A_S``.
    Equal to the direct product to rounding; when ``b - w`` is small on a column's every row
    (weights near ``b``) the difference cancels to about ``1e-16`` of ``A^T diag(b) A``.
    """

    def __init__(self, a: NDArray[np.float64], base: NDArray[np.float64]) -> None:
        self.a, self.base = a, base
        on = np.flatnonzero(base)
        if on.size == base.size and np.all(base == 1.0):
            self.gram = a.T @ a
        elif np.all(base[on] == 1.0):  # weights 0 or 1 (sqrt(1) = 1: the same numbers)
            part = a[on]
            self.gram = part.T @ part
        else:
            part = a[on] * np.sqrt(base[on])[:, None]
            self.gram = part.T @ part

    def __call__(self, w: NDArray[np.float64]) -> NDArray[np.float64]:
        """``A^T diag(w) A`` (p, p)."""
        diff = self.base - w
        s = np.flatnonzero(diff)
        if 2 * s.size > w.size:  # most rows differ: the direct product is cheaper
            return self.a.T @ (self.a * w[:, None])
        if s.size == 0:
            return self.gram.copy()
        d = diff[s]
        part = np.take(self.a, s, axis=0)
        if np.all(d > 0):
            np.multiply(part, np.sqrt(d)[:, None], out=part)  # in place: the same numbers
            return self.gram - part.T @ part
        return self.gram - part.T @ (part * d[:, None])


class _Solver:
    """:func:`_psolve` of one design, weights and prior for any right-hand side ``y``: the
    normal equations are formed and inverted once (from ``gram``'s product when given)."""

    def __init__(
        self,
        a: NDArray[np.float64],
        w: NDArray[np.float64],
        prior: NDArray[np.float64],
        gram: _Gram | None = None,
    ) -> None:
        if gram is not None and gram.a is a:
            normal = gram(w) + prior
        else:
            normal = a.T @ (a * w[:, None]) + prior
        d = np.sqrt(np.maximum(np.diagonal(normal), 0.0))
        d = np.where(d > 0, d, 1.0)
        dd = np.multiply.outer(d, d)
        scaled = normal / dd
        scaled.flat[:: scaled.shape[0] + 1] += 1e-12  # the diagonal
        self.a, self.w, self.prior = a, w, prior
        self.bread = np.linalg.pinv(scaled, rcond=1e-12, hermitian=True) / dd

    def __call__(self, y: NDArray[np.float64]) -> _Trial:
        coef = self.coef(y)
        r = y - self.a @ coef
        return _Trial(coef=coef, bread=self.bread, residual=r, weights=self.w, prior=self.prior)

    def coef(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """The coefficients of :meth:`__call__`'s fit alone (the same numbers)."""
        return np.asarray(self.bread @ (self.a.T @ (self.w * y)), dtype=np.float64)


def _irls(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    prior: NDArray[np.float64],
    iterations: int = 8,
    *,
    keep: NDArray[np.float64],
    clusters: NDArray[np.int64],
    gram: _Gram | None = None,
) -> _Trial:
    """Huber reweighting of :func:`_psolve` on the rows with ``keep`` 1 (the others 0).

    Huber's weights are taken on each row's residual less the median of its cluster's
    (``clusters``: about a second of rows): a row is an outlier when it stands out of its
    neighbours (a glitch, a joint sticking), not when a whole stretch is misfitted. A steady
    pass whose level the table's smoothness prior pulls off the pass's own mean by more than
    Huber's threshold would otherwise lose the weight of all its rows, and the prior would
    pull it further (random robot 17 of the family, joint a: a pass at -1.83 rad/s weighted
    0.30, its table 1.5 mN m off the truth there; 0.73 mN m with the median taken out).

    ``gram``: an earlier fit's (:attr:`_Trial.gram`), used when it is of the same design
    ``a`` and ``keep`` (the same numbers as building it again); the fit returned carries its
    own.
    """
    if gram is None or gram.a is not a or not np.array_equal(gram.base, keep):
        gram = _Gram(a, keep)  # every weight is Huber's times ``keep``: 1 on most kept rows
    trial = _Solver(a, w * keep, prior, gram)(y)
    inside = keep > 0
    groups = clusters[inside]
    kept = trial.residual[inside]
    for _ in range(iterations):
        local = trial.residual.copy()
        local[inside] -= cluster_medians(kept, groups)
        scale = mad_scale(local[inside])
        new = _Solver(a, huber_weights(local, scale) * keep, prior, gram)(y)
        now = new.residual[inside]
        moved = float(np.max(np.abs(now - kept), initial=0.0))
        trial, kept = new, now
        if moved < 1e-3 * mad_scale(kept):
            break
    trial.gram = gram
    return trial


def _inflation(residual: NDArray[np.float64], clusters: NDArray[np.int64]) -> float:
    """How much correlation between neighbouring rows inflates the variance of sums over a
    cluster: ``sum_c (sum r)^2 / sum r^2`` over clusters, over the mean cluster size... i.e.
    the long-run to short-run variance ratio (>= 1)."""
    _, g = np.unique(clusters, return_inverse=True)
    sums = np.bincount(g.ravel(), weights=residual)
    total = float(np.sum(residual**2))
    return max(1.0, float(np.sum(sums**2)) / max(total, 1e-300)) if total > 0 else 1.0


def _scan_log(fun: Callable[[float], float], lo: float, hi: float, count: int) -> float:
    """Minimise ``fun`` over ``[lo, hi]``: a logarithmic grid, then a bounded search between
    the best point's neighbours."""
    grid = np.geomspace(lo, hi, count)
    vals = [fun(float(x)) for x in grid]
    i = int(np.argmin(vals))
    a_, b_ = grid[max(i - 1, 0)], grid[min(i + 1, count - 1)]
    if b_ > a_:
        res = optimize.minimize_scalar(
            lambda x: fun(math.exp(x)),
            bounds=(math.log(a_), math.log(b_)),
            method="bounded",
            options={"xatol": 0.03},
        )
        if float(res.fun) <= vals[i]:
            return math.exp(float(res.x))
    return float(grid[i])


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
    slowest_speed: float = 0.0,
    steady_speeds: Sequence[float] = (),
    held_inertia: tuple[float, float] | None = None,
    pass_speeds: Sequence[float] = (),
    held_speeds: Sequence[float] | None = None,
    low_speed_rows: bool | None = None,
    stribeck_prior: bool | Literal["select"] | None = None,
    handed: Mapping[float, tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None,
) -> WholeFit:
    """Fit one joint's friction table, inertia, PDTV and torque delay to whole logs.

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
        Highest motor speed in the logs [rad/s]: the table's last knot.
    elbow_term
        Fit ``inertia.cos_elbow`` too.
    stribeck
        ``"never"``: one friction level per direction (Coulomb and viscous only); otherwise
        (``"auto"``, ``"always"``) the table varies with speed.
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
        Level of the delay test.
    inertia
        Fit the inertia; False holds it at 0. A fitted inertia that comes out non-positive is
        dropped the same way, with a warning.
    directional
        Test PDTV lines for a difference between directions (only sensible when both
        directions were swept).
    max_order
        Highest PDTV order [CPR] to search in the residual for lines the given ``orders``
        miss (0: no search).
    slowest_speed
        Slowest steady motor speed of the logs [rad/s] (the pass method's slowest pass); the
        table is fitted on rows faster than half of it, and held by its prior below (0: every
        row).
    steady_speeds
        Motor speeds [rad/s] the logs hold steadily (the passes'): the table has a knot at
        each (:func:`table_speeds`).
    held_inertia
        ``(value, standard error)`` [kg m^2] of an inertia determined elsewhere (the pass
        method's, from its ramps), held when these logs do not determine the inertia; None
        holds it at 0 then. Setting an undetermined inertia to 0 hands the ramps' inertial
        torque to the friction table (a random bench: the friction 3 % off inside the swept
        speeds, the force 6x the oracle's error there).
    pass_speeds
        Signed motor speeds [rad/s] of the steady passes, for the leave-one-pass-out error of
        the table between passes (:func:`pass_interpolation_error`); empty: not measured.
    held_speeds
        Signed motor speeds [rad/s] of the passes that hold their speed
        (:func:`torquemap.above_passes.hold_share`): with :data:`ABOVE_PASSES`, the table above
        each direction's fastest one is redrawn (:func:`torquemap.above_passes.redraw_above`)
        where the table is redrawn between passes. None: not redrawn.
    low_speed_rows
        Fit the table also on the rows below half the slowest pass where the motion is slow
        but steady (slow ramps, slow stretches; docs/identification.md, "Friction below the
        slowest pass from slow, steady rows"), and let estimation bridge only below the
        slowest speed they determine. None: :data:`LOW_SPEED_ROWS` (on).
    stribeck_prior
        Centre the table's smoothness prior on a generalized Stribeck curve per direction
        (:mod:`torquemap.friction_prior`; needs two steady speeds at least ``ANCHOR_GAP``
        apart); between two passes far apart the fit's knots then follow it (and are redrawn
        as before unless :data:`REDRAW_CURVED` is off). ``"select"``: per direction, the
        curve-centred prior only where, with the slowest pass left out, its fit predicts that
        pass better (:mod:`torquemap.prior_choice`, :func:`_choose_prior_slowest`). None:
        :data:`STRIBECK_PRIOR` (``"select"``).
    handed
        The pass method's estimate of each of ``orders`` (both directions together): order
        [CPR] -> (cosine and sine coefficients [N m], shape (2,), their covariance, shape
        (2, 2)). A line the whole fit inflates beyond it (:func:`_unearned_lines`) is held at
        it (:data:`HANDED_LINES`); orders not in it are fitted untested. None: every order is
        fitted.

    Returns
    -------
    WholeFit

    Raises
    ------
    InputError
        When no piece holds a row to fit.
    """
    name = f"joint {joint}: " if joint else ""
    if low_speed_rows is None:
        low_speed_rows = LOW_SPEED_ROWS
    if stribeck_prior is None:
        stribeck_prior = STRIBECK_PRIOR
    warnings: list[str] = []
    block = max(1.0, 20.0 * window)
    pieces = [
        dataclasses.replace(p, friction_velocity=friction_velocity(p.t, p.theta, window / 8.0))
        if p.friction_velocity is None
        else p
        for p in pieces
    ]
    rows = _prepare_rows(pieces, window, block, 3.0 * max(resolution, 1e-9))
    n = int(rows.clusters.size)
    if n == 0:
        raise InputError(f"{name}no sample to fit")
    both = [(float(o), False) for o in orders]
    if directional:
        _prepare_both_ways(rows, [o for o, _ in both])
    fixed, fixed_names = _fixed_columns(rows, both, elbow_term=elbow_term, inertia=inertia)
    w0_lo = max(resolution, 1e-9)
    speeds = table_speeds(top_speed, w0_lo, anchors=[abs(x) for x in steady_speeds])
    k = len(speeds)
    # the table is fitted from half the slowest pass up: slower rows (creep while holding,
    # the transition through zero) only tell the transition's width, searched below
    observed = max(0.5 * slowest_speed, speeds[0]) if slowest_speed else speeds[0]
    # a row whose window reaches a slower sample sees the table there through the smoothing
    near = np.concatenate(
        [
            dilate(p.t, np.abs(p.velocity) < observed, window)[r]
            for p, r in zip(rows.pieces, rows.rows, strict=True)
        ]
    )
    keep = (~near).astype(np.float64)
    w0 = min(2.0 * w0_lo, 0.25 * observed)
    fric = _friction_columns(rows, speeds, w0)
    y0 = _torque(rows, 0.0)
    level = float(np.median(np.abs(y0[keep > 0]))) if keep.any() else 0.0
    level = level or 1e-12
    flat = stribeck == "never"
    precision = _prior(speeds, level, observed, flat=flat)

    def embed(m: int, noise: float) -> NDArray[np.float64]:
        out = np.zeros((m + 2 * k + 2, m + 2 * k + 2))
        out[m:, m:] = noise * precision
        return out

    a = np.hstack((fixed, fric))
    first = _psolve(a, y0, keep, embed(fixed.shape[1], (0.1 * level) ** 2))
    scale0 = mad_scale(first.residual[keep > 0])
    noise = scale0**2 * _inflation(first.residual * keep, rows.clusters)
    prior = embed(fixed.shape[1], noise)

    # the delay: each trial reweighted on its own and scored by Huber's loss at one scale (the
    # start's weights down-weight exactly the misaligned ramps that tell the delay)
    # every row, the ramps' starts from rest included: they are where the torque's timing
    # shows most (the table's slow knots take up their friction for the purpose); checked on
    # the rows the table is fitted on (:data:`DELAY_WEIGHTS`): slower rows (creep, a slow pass
    # that sticks and slips) may hold friction the table cannot follow, and a misfit there
    # that repeats in time pulls the delay to its own period
    # a long log's trials are scored on a bounded share of its rows (each trial costs a
    # normal matrix over them, and a log of 4 M samples has ~330 000)
    sub = _delay_rows(rows, DELAY_ROWS)
    at = a if sub is None else a[sub]
    local = None if sub is None else _LocalTorques(rows, sub)

    def scorer(base: NDArray[np.float64]) -> tuple[Callable[[float], float], float]:
        """The delay's cost over the rows ``base`` (0 or 1) holds, and its F test's degrees
        of freedom (a window's rows count as one)."""
        gram = _Gram(at, base)
        plain = _Solver(at, base, prior, gram)  # every trial's first solve
        on = base > 0

        @functools.cache
        def cost(d: float) -> float:
            y_ = _torque(rows, d) if local is None else local(d)
            trial = plain(y_)
            trial = _Solver(at, huber_weights(trial.residual, scale0) * base, prior, gram)(y_)
            return huber_cost(trial.residual[on], scale0)

        return cost, max(float(np.sum(on)) / ROWS_PER_WINDOW, 1.0)

    kept_rows = (
        None if DELAY_WEIGHTS == "all" else _delay_weights(keep if sub is None else keep[sub])
    )
    delay_cost, dof = scorer(
        np.ones(at.shape[0]) if kept_rows is None or DELAY_WEIGHTS == "check" else kept_rows
    )
    d = 0.0 if delay == "auto" else float(delay)
    delay_interval = (d, d)
    if delay == "auto":

        def prepare(delays: NDArray[np.float64]) -> None:
            if local is None:
                _prepare_torques(rows, delays)
            else:
                local.prepare(delays)

        # the grid tried coarse to fine: the points the profile test reads (the same profile
        # as the whole grid's unless the cost dips between tried points more sharply than it
        # bends at them)
        profile: DelayProfile = delay_profile(
            delay_cost, max_delay, dof=dof, search=DELAY_SEARCH, prepare=prepare
        )
        d, delay_interval, note = judge_delay(profile, reference_delay, max_delay)
        grid_step = float(profile.grid[1] - profile.grid[0])
        delay_interval = interval_around(delay_interval, d, grid_step, max_delay)
        if DELAY_WEIGHTS == "check" and kept_rows is not None:
            check_cost, check_dof = scorer(kept_rows)
            check = delay_profile(
                check_cost, max_delay, dof=check_dof, search=DELAY_SEARCH, prepare=prepare
            )
            d2, interval2, note2 = judge_delay(check, reference_delay, max_delay)
            interval2 = interval_around(interval2, d2, grid_step, max_delay)
            # the first delay outside the check's interval and worse on its rows than that
            # profile accepts (its coarse grid may step over a narrow minimum: random robot 368)
            if not confirms(check_cost, d, check, d2, interval2, check_dof):
                d, delay_interval, note = d2, interval2, note2
                delay_cost, dof = check_cost, check_dof
        warnings += note
        c0, cd = delay_cost(0.0), delay_cost(d)
        f = (c0 - cd) / max(cd / dof, 1e-300)
        if d != 0.0 and not f > stats.f.ppf(1.0 - 1e-6, 1, dof):
            d = 0.0
            delay_interval = (min(delay_interval[0], 0.0), max(delay_interval[1], 0.0))
    y = _torque(rows, d)
    fit = _irls(a, y, keep, prior, keep=keep, clusters=rows.clusters)

    # the transition's width, from every row (the slow ones included) with the fit held:
    # only the knots whose hats reach below a few widths change
    def with_width(x: float) -> NDArray[np.float64]:
        reach = 6.0 * max(x, w0)
        near = [j for j in range(k) if j == 0 or speeds[j - 1] < reach]
        cols = [*near, *(j + k for j in near), 2 * k, 2 * k + 1]
        out = fric.copy()
        out[:, cols] = _friction_columns(rows, speeds, x, only=cols)
        return out

    m0 = fixed.shape[1]
    rest_of_model = fixed @ fit.coef[:m0]
    scale1 = mad_scale(fit.residual[keep > 0])

    def width_cost(x: float) -> float:
        return huber_cost(y - rest_of_model - with_width(x) @ fit.coef[m0:], scale1)

    if float(np.mean(keep)) < 0.99:
        w0 = _scan_log(width_cost, w0_lo / 4.0, max(0.25 * observed, w0_lo / 2.0), 8)
        fric = with_width(w0)
        a = np.hstack((fixed, fric))
        fit = _irls(a, y, fit.weights, prior, keep=keep, clusters=rows.clusters)
    low_speed_rows = low_speed_rows and not flat
    low_floor = max(low_speed_floor(resolution, w0), speeds[0]) if low_speed_rows else observed
    if low_speed_rows:
        # rows below half the slowest pass where the motion is slow but steady (a slow ramp,
        # a slow stretch) see the law there; a window that reaches rest, the transition or
        # the quantisation's noise, a ramp that crosses those speeds within a window, or a
        # row whose torque is mostly inertial stays out (docs/identification.md)
        if low_floor < observed:
            inertial = np.zeros(keep.size)
            if inertia and fit.coef[0] > 0:
                inertial = fit.coef[0] * np.abs(rows.at(lambda p: p.acceleration))
            low = _low_speed_rows(rows, low_floor, window, inertial, LOW_SPEED_INERTIAL * level)
            if LOW_SPEED_READING:
                # a run of them whose torque, less the fit's other terms, does not oppose the
                # motion reads no friction law (docs/estimation.md, "Stop 44 (F68)")
                reading = y - fixed @ fit.coef[: fixed.shape[1]]
                tolerance = 2.0 * mad_scale(fit.residual[keep > 0])
                fv = rows.at(_friction_speed)
                low = low & ~(keep > 0)
                parts = np.cumsum([0, *(r.size for r in rows.rows)])
                low = np.concatenate(
                    [
                        dissipative_runs(fv[i:j], reading[i:j], low[i:j], tolerance)
                        for i, j in itertools.pairwise(parts)
                    ]
                )
            if np.any(low & (keep == 0)):
                keep = ((keep > 0) | low).astype(np.float64)
                fit = _irls(a, y, keep, prior, keep=keep, clusters=rows.clusters)

    curve = None
    m0 = fixed.shape[1]
    searched = None
    if stribeck_prior and not flat:
        # the table's prior centred on a generalized Stribeck curve per direction, its
        # velocity and exponent searched on a grid by the fit's penalised objective with the
        # weights held (torquemap.friction_prior)
        searched = _search_prior_curve(
            a, y, fit.weights, m0, noise, precision, speeds, level, steady_speeds
        )
    choice = None
    if searched is not None:
        plain_fit, plain_precision = fit, precision
        _, curve, precision = searched
        prior = embed(m0, noise)
        fit = _irls(a, y, fit.weights, prior, keep=keep, clusters=rows.clusters, gram=fit.gram)
        if stribeck_prior == "select" and any(v > 0 for v in curve.velocity):
            # per direction, the prior whose fit better predicts the rows it did not see
            floor = max(low_speed_floor(resolution, w0), speeds[0])
            if PRIOR_CHOICE_ROWS == "slowest":
                choice = _choose_prior_slowest(
                    a,
                    y,
                    rows,
                    keep,
                    plain_fit,
                    m0,
                    noise,
                    speeds,
                    level,
                    steady_speeds,
                    curve,
                )
            else:
                choice = _choose_prior(a, y, rows, keep, plain_fit, fit, curve, floor)
            if not any(choice.curved):
                curve, precision, fit = None, plain_precision, plain_fit
            elif not all(choice.curved):
                curve = _curve_on(curve, choice.curved)
                precision = _centred_precision(plain_precision, speeds, level, curve)
            prior = embed(m0, noise)
            if curve is not None and not all(choice.curved):
                fit = _irls(
                    a,
                    y,
                    plain_fit.weights,
                    prior,
                    keep=keep,
                    clusters=rows.clusters,
                    gram=plain_fit.gram,
                )
        plain_fit.gram = None
    # the Gram products were for the fits above: they hold this design, which later fits
    # replace
    fit.gram = None

    def refit(
        orders: Sequence[tuple[float, bool]],
        *,
        with_inertia: bool = inertia,
        elbow: bool = elbow_term,
    ) -> tuple[NDArray[np.float64], list[str], NDArray[np.float64], NDArray[np.float64], _Trial]:
        """The fixed columns, their names, the design, the prior and the fit over ``orders``."""
        f, names = _fixed_columns(rows, orders, elbow_term=elbow, inertia=with_inertia)
        design = np.hstack((f, fric))
        precision = embed(f.shape[1], noise)
        return (
            f,
            names,
            design,
            precision,
            _irls(design, y, fit.weights, precision, keep=keep, clusters=rows.clusters),
        )

    # the lines handed down by the pass method earn their place: refitted over every row, an
    # order the rows do not resolve where the joint moves fast (aliased at the log's samples)
    # takes up whatever else its columns correlate with (random robot 363: 0.1 mN m in the
    # passes, 2-6 mN m here)
    held_lines: list[float] = []
    held_names: list[str] = []
    held_coef: list[NDArray[np.float64]] = []
    held_cov: list[NDArray[np.float64]] = []
    if handed is not None and HANDED_LINES != "all" and both:
        tested = sum(1 for o, _ in both if o in handed)
        for _ in range(3):
            cov_h = cluster_covariance(a, fit.residual, fit.weights, fit.bread, rows.clusters)
            out = _unearned_lines(both, handed, fixed_names, fit.coef, cov_h, tested)
            if not out:
                break
            held_lines += out
            if HANDED_LINES == "hold":
                # the line's torque at the pass method's estimate leaves the torque fitted
                cols, names_o = _fixed_columns(
                    rows, [(o, False) for o in out], elbow_term=False, inertia=False
                )
                c = np.concatenate([np.asarray(handed[o][0], dtype=np.float64) for o in out])
                y = y - cols @ c
                held_names += names_o
                held_coef.append(c)
                held_cov += [np.asarray(handed[o][1], dtype=np.float64) for o in out]
            both = [(o, dd) for o, dd in both if o not in out]
            fixed, fixed_names, a, prior, fit = refit(both)
    # lines the pass method missed: the spectrum of the whole fit's residual over the motor
    # angle (every row, not only the passes)
    if max_order >= 1:
        theta = rows.at(lambda p: p.theta)
        inside = keep > 0
        # the rows sample the angle more coarsely than the log: search only the orders they
        # resolve (twice the motor angle's step between neighbouring rows per period)
        step = np.abs(np.diff(theta))
        step = step[step > 0]
        resolved = math.pi / (2.0 * float(np.percentile(step, 90))) if step.size else 0.0
        missed = _missed_orders(
            theta[inside],
            fit.residual[inside],
            [*(o for o, _ in both), *held_lines],
            min(max_order, resolved),
        )
        # a line that does not go through MIN_PERIODS periods within a typical run of one
        # direction is, inside each run, a slow trend: the fit cannot tell it from friction
        # that differs between runs (the passes' speeds), which binned over the motor angle
        # looks like low orders
        span = _run_revolutions(rows)
        missed = [o for o in missed if o * span >= MIN_PERIODS]
        if missed:
            trial = sorted([*both, *((o, False) for o in missed)])
            fixed_t, names_t, a_t, prior_t, fit_t = refit(trial)
            # a candidate found in the residual's spectrum stays only if the joint fit holds
            # it: a Wald test on its two columns with the rows' cluster covariance (the
            # residual of a whole fit is not white: misfit of the law, of the delay), at the
            # line picking's false-alarm level shared among the candidates
            cov_t = cluster_covariance(
                a_t, fit_t.residual, fit_t.weights, fit_t.bread, rows.clusters
            )
            held = _held_lines(trial, missed, names_t, fit_t.coef, cov_t)
            if len(held) == len(missed):  # every candidate held: the trial is the fit
                both = trial
                fixed, fixed_names, a, prior, fit = fixed_t, names_t, a_t, prior_t, fit_t
            elif held:
                both = sorted([*both, *((o, False) for o in held)])
                fixed, fixed_names, a, prior, fit = refit(both)
    final_orders = both
    if both and directional:
        final_orders = _directional_orders(
            rows,
            both,
            fit,
            fric,
            y,
            noise,
            embed,
            elbow_term,
            inertia,
            direction_significance,
            keep,
        )
        if any(dd for _, dd in final_orders):
            fixed, fixed_names, a, prior, fit = refit(final_orders)
    undetermined = False
    se = 0.0  # the fitted inertia's standard error (computed only for a positive fit)
    if inertia and fit.coef[0] > 0:
        # an inertia the logs do not determine (speed steps with no ramp, say) may come out
        # at any size, 1e6 kg m^2 included: kept only when it stands 2 standard errors above 0
        spread = cluster_covariance(a, fit.residual, fit.weights, fit.bread, rows.clusters)
        se = math.sqrt(max(float(spread[0, 0]), 0.0))
        undetermined = not fit.coef[0] > 2.0 * se
    pass_inertia = None
    if inertia and (fit.coef[0] <= 0 or undetermined):
        why = (
            f"the fitted inertia ({fit.coef[0]:.3g} +- {se:.2g} kg m^2) is not determined by "
            "the logs"
            if fit.coef[0] > 0
            else f"the fitted inertia is not positive ({fit.coef[0]:.3g} kg m^2)"
        )
        if held_inertia is not None and held_inertia[0] > 0:
            # the pass method's, with the larger of its and this fit's standard errors
            pass_inertia = (float(held_inertia[0]), max(float(held_inertia[1]), se))
            warnings.append(
                f"{why}: the whole fit's ramps do not separate it from the friction table; the "
                f"pass method's ({pass_inertia[0]:.3g} +- {pass_inertia[1]:.2g} kg m^2, from "
                "its ramps) is held (record sweeps with clear accelerations)"
            )
            y = y - pass_inertia[0] * rows.at(lambda p: p.acceleration)
        else:
            warnings.append(
                f"{why}: no ramp stands out of the speed ripple; inertia set to 0 (record sweeps "
                "with clear accelerations)"
            )
        fixed, fixed_names, a, prior, fit = refit(final_orders, with_inertia=False, elbow=False)
    m = fixed.shape[1]
    interpolation = pass_interpolation_error(
        a, y, fit, prior, m, speeds, rows, keep, pass_speeds, noise=noise
    )
    fit, bound_note = _dissipative(a, y, fit, prior, m, speeds, noise=noise)
    if bound_note:
        warnings.append(bound_note)
    scale = mad_scale(fit.residual[keep > 0])
    # covariance: the sandwich where the data speak, plus what the prior adds (the posterior
    # (N + L)^-1 = B N B + B L B with B = (N + L)^-1; B N B -> the cluster sandwich)
    cov = cluster_covariance(a, fit.residual, fit.weights, fit.bread, rows.clusters)
    cov = cov + noise * (fit.bread @ prior @ fit.bread)
    law, copy_note = _law(fit.coef[m:], speeds, w0, rows)
    if copy_note:
        warnings.append(copy_note)
    # with REDRAW_CURVED off, a direction whose prior is centred on a Stribeck curve has its
    # knots between passes far apart drawn by the curve's shape alone: it is not redrawn
    curved: tuple[bool, ...] = (
        (False, False) if curve is None or REDRAW_CURVED else tuple(v > 0 for v in curve.velocity)
    )
    if not flat and BETWEEN_PASSES != "fit" and not all(curved):
        # between two passes far apart the sweep crosses the speeds only on ramps: the knots
        # there are drawn through the passes' own knots (docs/identification.md)
        by_prior = _prior_held_knots(rows, a, fit.weights * keep, prior, m, speeds, steady_speeds)
        method = cast(Method, BETWEEN_PASSES)
        if REDRAW_BY_DIRECTION and pass_speeds:
            # each direction between its own passes (pass_speeds is signed)
            redrawn = redraw_law_by_direction(law, pass_speeds, method, held=by_prior)
        else:
            redrawn = redraw_law(law, [abs(x) for x in steady_speeds], method, held=by_prior)
        if ABOVE_PASSES and held_speeds is not None:
            # above the fastest pass that holds its speed the rows are transients (docs/
            # estimation.md, "Stop 44 (F72)")
            redrawn = redraw_above(redrawn, held_speeds)
        # the fit's own knots are a second estimate there: the table takes the weighted mean,
        # and the distance from it to either is a model-form variance, fully correlated along
        # each direction's table
        mean = law.with_linear_parameters(
            (1.0 - REDRAWN_WEIGHT) * law.linear_parameters()
            + REDRAWN_WEIGHT * redrawn.linear_parameters()
        )
        if any(curved):
            mean = dataclasses.replace(
                mean,
                positive=law.positive if curved[0] else mean.positive,
                negative=law.negative if curved[1] else mean.negative,
            )
        for fitted, drawn, start in (
            (law.positive, mean.positive, m),
            (law.negative, mean.negative, m + k),
        ):
            form = np.zeros(cov.shape[0])
            form[start : start + k] = np.asarray(fitted) - np.asarray(drawn)
            cov = cov + np.outer(form, form)
        law = mean
    if CURVE_FORM and curve is None and not flat and BETWEEN_PASSES != "fit":
        cov = cov + _curve_form_variance(
            a, y, fit, prior, precision, m, speeds, level, w0, rows, law, steady_speeds, noise
        )
    names = [*fixed_names, *(f"friction.{x}" for x in law.linear_parameter_names)]
    coef = np.r_[fit.coef[:m], law.linear_parameters()]
    if held_names:
        # the lines held at the pass method's estimate, with its covariance, after the fitted
        # parameters (uncorrelated with them)
        p0 = coef.size
        names += held_names
        coef = np.r_[coef, np.concatenate(held_coef)]
        cov = np.pad(cov, ((0, len(held_names)), (0, len(held_names))))
        for i, pass_cov in enumerate(held_cov):
            cov[p0 + 2 * i : p0 + 2 * i + 2, p0 + 2 * i : p0 + 2 * i + 2] = pass_cov
        final_orders = sorted([*final_orders, *((o, False) for o in held_lines)])
    if pass_inertia is not None:
        # the held inertia is a parameter of the model like the fitted ones, with its variance
        names.insert(0, "inertia.constant")
        coef = np.r_[pass_inertia[0], coef]
        cov = np.pad(cov, ((1, 0), (1, 0)))
        cov[0, 0] = pass_inertia[1] ** 2
    psd = _residual_psd(rows, fit.residual, scale, keep)
    table = residual_table(
        [p.t[r] for p, r in zip(rows.pieces, rows.rows, strict=True)],
        [p.velocity[r] for p, r in zip(rows.pieces, rows.rows, strict=True)],
        [p.acceleration[r] for p, r in zip(rows.pieces, rows.rows, strict=True)],
        _split(fit.residual, rows),
        band=4.0 * w0,
    )
    grav, grav_sig = 0.0, False
    if gravity_check is not None:
        grav, grav_sig = _gravity_test(rows, a, y, fit, prior, gravity_check, planar)
    return WholeFit(
        names=tuple(names),
        coef=coef,
        covariance=cov,
        law=law,
        stribeck=not flat,
        delay=float(d),
        orders=tuple(final_orders),
        residual_scale=scale,
        residual_psd=psd,
        samples=int(sum(int(p.use.sum()) for p in pieces)),
        gravity_torque=grav,
        gravity_significant=grav_sig,
        delay_interval=(float(delay_interval[0]), float(delay_interval[1])),
        residual=table,
        observed_speed=(
            determined_speed(
                a,
                fit.weights * keep,
                prior,
                m,
                speeds,
                observed,
                low_floor,
            )
            if low_speed_rows
            else float(observed)
        ),
        warnings=tuple(name + w for w in warnings),
        interpolation=interpolation,
        prior_curve=curve,
        prior_choice=choice,
        held_lines=tuple(sorted(held_lines)),
    )


def _choose_prior(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    rows: _Rows,
    keep: NDArray[np.float64],
    plain: _Trial,
    curved: _Trial,
    curve: StribeckPrior,
    floor: float,
) -> PriorChoice:
    """Per direction, whether the fit with the table's prior centred on ``curve`` (``curved``)
    predicts the rows neither fit saw better than the fit with the smoothness prior alone
    (``plain``): the rows with ``keep`` 0 (their window reaches below half the slowest pass:
    ramps, reversals) whose friction speed is at least ``floor`` [rad/s], by sign of their
    friction velocity; Huber's loss of the residuals at their robust scale under the plain fit,
    the gain's z score over the rows' clusters at least :data:`HELD_OUT_Z`
    (:func:`torquemap.prior_choice.held_out_gain`). A direction without a curve keeps the
    plain prior."""
    fv = rows.at(_friction_speed)
    held = (keep == 0) & (np.abs(fv) >= floor)
    r0 = y - a @ plain.coef
    r1 = y - a @ curved.coef
    scale = mad_scale(r0[held]) if held.any() else 0.0
    out: list[tuple[bool, float, float, int]] = []
    for side, mask in enumerate((held & (fv > 0), held & (fv < 0))):
        gain, z = held_out_gain(r0[mask], r1[mask], rows.clusters[mask], scale or None)
        take = curve.velocity[side] > 0 and z >= HELD_OUT_Z
        out.append((bool(take), gain, z, int(mask.sum())))
    return _choice(out, curve)


def _choose_prior_slowest(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    rows: _Rows,
    keep: NDArray[np.float64],
    plain: _Trial,
    m: int,
    noise: float,
    speeds: tuple[float, ...],
    level: float,
    steady_speeds: Sequence[float],
    curve: StribeckPrior,
) -> PriorChoice:
    """Per direction, whether the table's prior centred on a Stribeck curve extrapolates
    below the passes better than the smoothness prior alone, by the slowest steady pass left
    out: each direction's rows whose differentiator window reaches below the geometric mean
    of the slowest and the next steady speed are left out of both fits (the prior's observed
    speed raised to half the next steady speed, the curve searched again on the remaining
    rows), and the left-out rows of the slowest pass (friction speed within ``ANCHOR_GAP`` of
    it) predicted by each; Huber's loss at the plain fit's residual scale, the gain's z score
    over the rows' clusters at least :data:`HELD_OUT_Z`
    (:func:`torquemap.prior_choice.held_out_gain`). A direction without a curve (in the
    whole fit's search or the one without the slowest pass) keeps the plain prior."""
    k = len(speeds)
    steady = sorted({abs(float(x)) for x in steady_speeds if x})
    slowest = steady[0] if steady else 0.0
    rest = [x for x in steady if x > slowest * ANCHOR_GAP]
    fv = rows.at(_friction_speed)
    scale = mad_scale(plain.residual[keep > 0])
    zero = (False, 0.0, 0.0, 0)
    out: list[tuple[bool, float, float, int]] = [zero, zero]
    if len(rest) >= 2 and rest[-1] > rest[0] * ANCHOR_GAP:
        cut = math.sqrt(slowest * rest[0])
        reach = np.concatenate(
            [
                dilate(p.t, np.abs(p.velocity) < cut, rows.window)[r]
                for p, r in zip(rows.pieces, rows.rows, strict=True)
            ]
        )
        pass_rows = np.abs(np.log(np.maximum(np.abs(fv), 1e-300) / slowest)) < math.log(ANCHOR_GAP)
        seen = cut if LEFT_OUT_OBSERVED == "cut" else 0.5 * rest[0]
        table = _prior(speeds, level, max(seen, speeds[0]), flat=False)
        size = a.shape[1]

        def embedded(t: NDArray[np.float64]) -> NDArray[np.float64]:
            full = np.zeros((size, size))
            full[m:, m:] = noise * t
            return full

        for side, sign in enumerate((1.0, -1.0)):
            if not curve.velocity[side] > 0:
                continue
            mine = sign * fv > 0
            held = (keep > 0) & mine & pass_rows & reach
            if not held.any():
                continue
            kept = keep * ~(mine & reach)
            w = plain.weights * kept
            searched = _search_prior_curve(a, y, w, m, noise, table, speeds, level, rest)
            if searched is None or not searched[1].velocity[side] > 0:
                out[side] = (False, 0.0, 0.0, int(held.sum()))
                continue
            alt = searched[1]
            phi = stribeck_shape(np.asarray(speeds), alt.velocity[side], alt.exponent[side])
            shapes = (phi, np.zeros(k)) if side == 0 else (np.zeros(k), phi)
            centred = curve_precision(table, 0, k, shapes, SPREAD * max(level, 1e-12))
            shared = _Gram(a, kept)  # both fits' design and rows
            fits = [
                _irls(
                    a, y, plain.weights, embedded(t), keep=kept, clusters=rows.clusters, gram=shared
                )
                for t in (table, centred)
            ]
            r0, r1 = (y[held] - a[held] @ f.coef for f in fits)
            gain, z = held_out_gain(r0, r1, rows.clusters[held], scale or None)
            out[side] = (z >= HELD_OUT_Z, gain, z, int(held.sum()))
    return _choice(out, curve)


def _choice(out: Sequence[tuple[bool, float, float, int]], curve: StribeckPrior) -> PriorChoice:
    """:class:`PriorChoice` from each direction's (curved, gain, z, rows), positive first."""
    return PriorChoice(
        curved=(out[0][0], out[1][0]),
        gain=(out[0][1], out[1][1]),
        z=(out[0][2], out[1][2]),
        rows=(out[0][3], out[1][3]),
        velocity=(float(curve.velocity[0]), float(curve.velocity[1])),
    )


def _curve_on(curve: StribeckPrior, on: tuple[bool, bool]) -> StribeckPrior:
    """``curve`` with the directions not ``on`` set to no curve (velocity 0)."""
    return dataclasses.replace(
        curve,
        velocity=tuple(v if o else 0.0 for v, o in zip(curve.velocity, on, strict=True)),  # type: ignore[arg-type]
        exponent=tuple(e if o else 2.0 for e, o in zip(curve.exponent, on, strict=True)),  # type: ignore[arg-type]
    )


def _centred_precision(
    precision: NDArray[np.float64], speeds: Sequence[float], level: float, curve: StribeckPrior
) -> NDArray[np.float64]:
    """The smoothness prior's ``precision`` centred on ``curve``
    (:func:`torquemap.friction_prior.curve_precision`, as :func:`search_curve` builds it)."""
    x = np.asarray(speeds, dtype=np.float64)
    shapes = (
        stribeck_shape(x, curve.velocity[0], curve.exponent[0]),
        stribeck_shape(x, curve.velocity[1], curve.exponent[1]),
    )
    return curve_precision(precision, 0, len(speeds), shapes, SPREAD * max(level, 1e-12))


def determined_speed(
    a: NDArray[np.float64],
    w: NDArray[np.float64],
    prior: NDArray[np.float64],
    m: int,
    speeds: Sequence[float],
    observed: float,
    floor: float,
) -> float:
    """The slowest speed [rad/s] the logs determine the table at (:data:`LOW_SPEED_ROWS`):
    going down the knots ``speeds`` [rad/s] from ``observed`` [rad/s] (half the slowest pass),
    the last of the run of knots on which the rows (design ``a``, weights ``w``, the friction
    columns from ``m`` on) hold at least as much information (the weighted sum of squares of
    the knot's column) as the smoothness ``prior`` in both directions, not below ``floor``
    [rad/s]; ``observed`` when the first knot below it is the prior's."""
    if floor >= observed:
        return float(observed)
    k = len(speeds)
    enough = np.ones(k, dtype=bool)
    for start in (m, m + k):
        cols = a[:, start : start + k]
        info = np.einsum("i,ij,ij->j", w, cols, cols)
        enough &= info >= np.diag(prior)[start : start + k]
    lowest = float(observed)
    for j in range(k - 1, -1, -1):
        if speeds[j] > observed:
            continue
        if not enough[j] or speeds[j] < floor:
            break
        lowest = float(speeds[j])
    return lowest


def _search_prior_curve(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    weights: NDArray[np.float64],
    m: int,
    noise: float,
    precision: NDArray[np.float64],
    speeds: tuple[float, ...],
    level: float,
    steady_speeds: Sequence[float],
) -> (
    tuple[
        Callable[[NDArray[np.float64]], tuple[float, NDArray[np.float64]]],
        StribeckPrior,
        NDArray[np.float64],
    ]
    | None
):
    """The generalized Stribeck curve the table's prior is centred on
    (:func:`torquemap.friction_prior.search_curve` by :func:`_curve_objective`, the design
    ``a``, torque ``y`` and ``weights`` held, ``precision`` the smoothness prior's): the
    objective, the curve and the prior precision centred on it; None without two steady speeds
    at least ``ANCHOR_GAP`` apart."""
    steady = sorted(abs(float(x)) for x in steady_speeds if x)
    if len(steady) < 2 or not steady[-1] > steady[0] * ANCHOR_GAP:
        return None
    penalised = _curve_objective(a, y, weights, m, noise)
    curve, centred = search_curve(
        penalised, precision, 0, speeds, level, velocities=(steady[0], steady[-1])
    )
    return penalised, curve, centred


def _curve_form_variance(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    fit: _Trial,
    prior: NDArray[np.float64],
    precision: NDArray[np.float64],
    m: int,
    speeds: tuple[float, ...],
    level: float,
    w0: float,
    rows: _Rows,
    law: SpeedTableFriction,
    steady_speeds: Sequence[float],
    noise: float,
) -> NDArray[np.float64]:
    """Model-form covariance [N^2 m^2] of the table's prior-held knots between passes far
    apart (:data:`CURVE_FORM`): ``f f^T`` per direction, ``f`` the difference between the
    table (``law``) and the same fit's table with its prior centred on a generalized Stribeck
    curve (:func:`torquemap.friction_prior.search_curve`, the design ``a``, torque ``y`` and
    weights of ``fit`` held, ``precision`` the smoothness prior's), at the knots strictly
    between the direction's slowest and fastest steady speeds that the prior holds
    (:func:`_prior_held_knots`); zero elsewhere, and zero when no curve is taken. The
    covariance's shape is that of the fit's ``m`` fixed columns and the table's columns."""
    size = a.shape[1]
    out = np.zeros((size, size))
    searched = _search_prior_curve(
        a, y, fit.weights, m, noise, precision, speeds, level, steady_speeds
    )
    if searched is None:
        return out
    penalised, alt, alt_precision = searched
    steady = sorted(abs(float(x)) for x in steady_speeds if x)
    if not any(v > 0 for v in alt.velocity):
        return out
    _, coef = penalised(alt_precision)
    other, _ = _law(coef, speeds, w0, rows)
    held = _prior_held_knots(rows, a, fit.weights, prior, m, speeds, steady_speeds)
    k = len(speeds)
    knots = np.asarray(speeds, dtype=np.float64)
    # between the slowest and the fastest steady speed, away from every steady speed
    inside = (knots > steady[0] * ANCHOR_GAP) & (knots < steady[-1] / ANCHOR_GAP)
    for x in steady:
        inside &= np.abs(np.log(knots / x)) >= math.log(ANCHOR_GAP)
    # the two tables compared as friction (level plus viscous torque) at the knots: the
    # second fit may trade its viscous slope against its levels
    for sign, mask, start, used in (
        (1.0, held[0], m, alt.velocity[0] > 0),
        (-1.0, held[1], m + k, alt.velocity[1] > 0),
    ):
        if not used:
            continue
        gap = np.asarray(law.torque(sign * knots)) - np.asarray(other.torque(sign * knots))
        form = np.zeros(size)
        form[start : start + k] = np.where(inside & mask, sign * gap, 0.0)
        out += np.outer(form, form)
    return out


def _prior_held_knots(
    rows: _Rows,
    a: NDArray[np.float64],
    w: NDArray[np.float64],
    prior: NDArray[np.float64],
    m: int,
    speeds: Sequence[float],
    steady_speeds: Sequence[float],
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Per direction, the knots the smoothness prior holds more than the rows away from the
    steady passes do: the knot column's weighted sum of squares over the rows whose friction
    velocity lies more than ``ANCHOR_GAP`` from every steady speed, against the prior's
    precision on the knot (both in the penalised normal matrix's units).

    A knot between two passes far apart that only the passes' speed ripple reaches (through
    its hat) and ramps whose differentiator window reaches rest (left out of the fit) is
    held by the prior; slow ramps measure it."""
    k = len(speeds)
    fv = np.abs(
        rows.at(lambda p: p.velocity if p.friction_velocity is None else p.friction_velocity)
    )
    near = np.zeros(fv.size, dtype=bool)
    floor = np.maximum(fv, 1e-300)
    # each speed once (both directions' passes share their speeds): the same rows
    for x in dict.fromkeys(abs(float(x)) for x in steady_speeds if x):
        near |= np.abs(np.log(floor / x)) < math.log(ANCHOR_GAP)
    wa = w * ~near
    out = []
    for start in (m, m + k):
        cols = a[:, start : start + k]
        info = np.einsum("i,ij,ij->j", wa, cols, cols)
        out.append(info < MEASURED_SHARE * np.diag(prior)[start : start + k])
    return out[0], out[1]


def interpolation_gap(x: float, anchors: Sequence[float]) -> float:
    """``|x - x_a| |x - x_b|`` with ``x_a``, ``x_b`` the two anchors nearest ``x`` that bracket
    it, or the two nearest on its side beyond the outermost (all in log speed); with one
    anchor, ``d (d + log KNOT_RATIO)`` with ``d`` the distance to it; 0 without any.

    A curve of curvature ``c`` departs from its interpolant through the two anchors by at most
    ``c / 2`` times this product (between them) and by about as much beyond them.

    Examples
    --------
    >>> round(interpolation_gap(1.0, [0.0, 2.0]), 6), round(interpolation_gap(3.0, [0.0, 2.0]), 6)
    (1.0, 3.0)
    """
    if not anchors:
        return 0.0
    return float(interpolation_gaps(np.array([x], dtype=np.float64), anchors)[0])


def interpolation_gaps(x: NDArray[np.float64], anchors: Sequence[float]) -> NDArray[np.float64]:
    """:func:`interpolation_gap` of every ``x`` at once (``anchors`` not empty)."""
    xs = np.sort(np.asarray(anchors, dtype=np.float64))
    if xs.size == 1:
        d = np.abs(x - xs[0])
        return np.asarray(d * (d + math.log(KNOT_RATIO)), dtype=np.float64)
    i = np.clip(np.searchsorted(xs, x, side="left"), 1, xs.size - 1)
    return np.asarray(np.abs(x - xs[i - 1]) * np.abs(x - xs[i]), dtype=np.float64)


#: Rows a pass needs to be left out by :func:`pass_interpolation_error` (a tenth of a
#: second of rows at 8 per 50 ms window).
LOO_MIN_ROWS = 16


def pass_interpolation_error(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    fit: _Trial,
    prior: NDArray[np.float64],
    m: int,
    speeds: Sequence[float],
    rows: _Rows,
    keep: NDArray[np.float64],
    pass_speeds: Sequence[float],
    noise: float = 1.0,
) -> dict[str, object] | None:
    """Leave-one-pass-out error of the friction table between and beyond its passes.

    Between two steady passes the table's knots are held by the ramps and the smoothness
    prior only, and what the prior's curve misses there (a Stribeck drop between passes far
    apart) goes into the table, not into the residual: the posterior covariance does not know
    it. Here each steady pass of each direction (``pass_speeds``, signed [rad/s]; passes closer
    than ``ANCHOR_GAP`` together) is left out in turn, its rows (same direction, speeds within
    ``ANCHOR_GAP``) given weight 0, and the fit (design ``a``, torque ``y``, the weights of
    ``fit``, ``prior``, friction columns from ``m`` on, knots ``speeds``) solved again: at that
    speed the table is then what interpolation from the other passes gives. The change of
    friction ``g(S) = level(S) + viscous S`` [N m] against the full fit is that interpolation's
    error at a gap ``q = |x - x_a| |x - x_b|`` (:func:`interpolation_gap`, ``x = log S``, the
    nearest remaining passes of that direction). A curve of curvature ``c`` in log speed misses
    by ``c q / 2``: the least-squares ``c = 2 sqrt(sum e^2 / sum q^2)`` over the passes is the
    table's interpolation curvature [N m], from which estimation draws a model-form standard
    deviation ``c q / 2`` at any speed (:func:`torquemap.uncertainty.interpolation_sigma`).

    Returns ``{"curvature": c, "speeds": [...], "errors": [...], "gaps": [...]}`` (signed
    held-out speeds, errors [N m], gaps), or None when fewer than two passes of a direction
    could be left out.
    """
    signed = [float(s) for s in pass_speeds if math.isfinite(s) and s != 0.0]
    if len(signed) < 2:
        return None
    v = rows.at(_friction_speed)
    k = len(speeds)
    logs = np.log(np.asarray(speeds, dtype=np.float64))
    base = fit.weights * keep
    gram = _Gram(a, base)

    def friction_at(coef: NDArray[np.float64], speed: float, sign: int) -> float:
        lev = coef[m : m + k] if sign > 0 else coef[m + k : m + 2 * k]
        visc = coef[m + 2 * k] if sign > 0 else coef[m + 2 * k + 1]
        return float(np.interp(math.log(speed), logs, lev) + visc * speed)

    def functional(speed: float, sign: int) -> NDArray[np.float64]:
        """The row ``r`` with ``r @ coef = friction_at(coef, speed, sign)``."""
        row = np.zeros(a.shape[1])
        x = math.log(speed)
        i = int(np.clip(np.searchsorted(logs, x, side="right") - 1, 0, k - 2))
        u = float(np.clip((x - logs[i]) / (logs[i + 1] - logs[i]), 0.0, 1.0))
        at = m if sign > 0 else m + k
        row[at + i], row[at + i + 1] = 1.0 - u, u
        row[m + 2 * k + (0 if sign > 0 else 1)] = speed
        return row

    held_speeds: list[float] = []
    spreads: list[float] = []
    errors: list[float] = []
    gaps: list[float] = []
    for sign in (1, -1):
        groups: list[float] = []
        for s in sorted(abs(x) for x in signed if x * sign > 0):
            if groups and s < groups[-1] * ANCHOR_GAP:
                continue
            groups.append(s)
        if len(groups) < 2:
            continue
        for s in groups:
            held = (sign * v > s / ANCHOR_GAP) & (sign * v < s * ANCHOR_GAP) & (base > 0)
            if int(held.sum()) < LOO_MIN_ROWS:
                continue
            solver = _Solver(a, base * ~held, prior, gram)
            error = friction_at(solver.coef(y), s, sign) - friction_at(fit.coef, s, sign)
            row = functional(s, sign)
            spreads.append(math.sqrt(max(noise * float(row @ solver.bread @ row), 0.0)))
            others = [math.log(x) for x in groups if x != s]
            held_speeds.append(sign * s)
            errors.append(error)
            gaps.append(interpolation_gap(math.log(s), others))
    q = np.asarray(gaps)
    if q.size < 2 or not float(np.sum(q**2)) > 0:
        return None
    curvature = 2.0 * math.sqrt(float(np.sum(np.square(errors)) / np.sum(q**2)))
    return {
        "curvature": curvature,
        "speeds": held_speeds,
        "errors": errors,
        "gaps": gaps,
        "sigmas": spreads,
    }


def _split(values: NDArray[np.float64], rows: _Rows) -> list[NDArray[np.float64]]:
    """Stacked row values cut back into pieces."""
    edges = np.cumsum([r.size for r in rows.rows])[:-1]
    return list(np.split(values, edges))


def _directional_orders(
    rows: _Rows,
    both: Sequence[tuple[float, bool]],
    fit: _Trial,
    fric: NDArray[np.float64],
    y: NDArray[np.float64],
    noise: float,
    embed: Callable[[int, float], NDArray[np.float64]],
    elbow_term: bool,
    inertia: bool,
    level: float,
    keep: NDArray[np.float64],
) -> list[tuple[float, bool]]:
    """Orders whose line differs between directions (chi-square of the difference on the
    cluster covariance, Bonferroni over lines, and by more than 10 %)."""
    split = [(o, True) for o, _ in both]
    fixed_d, names_d = _fixed_columns(rows, split, elbow_term=elbow_term, inertia=inertia)
    a_d = np.hstack((fixed_d, fric))
    prior_d = embed(fixed_d.shape[1], noise)
    fit_d = _irls(a_d, y, fit.weights, prior_d, keep=keep, clusters=rows.clusters)
    cov_d = cluster_covariance(a_d, fit_d.residual, fit_d.weights, fit_d.bread, rows.clusters)
    crit = stats.chi2.ppf(1.0 - level / len(both), 2)
    chosen = []
    for o, _ in both:
        ip = names_d.index(f"pdtv.{o:g}.positive.a")
        ineg = names_d.index(f"pdtv.{o:g}.negative.a")
        diff = fit_d.coef[ip : ip + 2] - fit_d.coef[ineg : ineg + 2]
        sel = np.r_[ip, ip + 1, ineg, ineg + 1]
        c = cov_d[np.ix_(sel, sel)]
        cdiff = c[:2, :2] + c[2:, 2:] - c[:2, 2:] - c[2:, :2]
        chi = float(diff @ np.linalg.pinv(cdiff) @ diff)
        amp = max(np.hypot(*fit_d.coef[ip : ip + 2]), np.hypot(*fit_d.coef[ineg : ineg + 2]))
        excited = np.all(np.isfinite(cdiff)) and float(np.trace(cdiff)) > 0
        chosen.append((o, bool(excited and chi > crit and np.hypot(*diff) > 0.1 * amp)))
    return chosen


def _dissipative(
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    fit: _Trial,
    prior: NDArray[np.float64],
    m: int,
    speeds: Sequence[float],
    *,
    noise: float | None = None,
) -> tuple[_Trial, str]:
    """The fit with friction that opposes motion: ``g(s) >= 0`` at every knot, viscous >= 0.

    Dissipation asks the friction magnitude of each direction, ``g(s) = level(s) + viscous *
    s``, to be >= 0, not each of its parts: a law rising faster than linearly (drag growing
    with the square of the speed, say) is a large viscous slope over levels that fall below 0
    at the top knots, and is dissipative. So the constraint is on ``g`` at the knots (on the
    first knot's level itself, so that ``g`` stays >= 0 down to rest) and on the viscous
    slopes (so that it stays >= 0 above the top knot). Between two knots ``g`` lies at most
    6 % of ``viscous * s`` below the chord of its knot values (``s`` convex in log speed, the
    knots at most 1.8x apart). An unconstrained fit that breaks this is refitted by bounded
    least squares on the same (penalised, weighted) normal equations, in the coordinates
    ``g(s_i)``; the note says so when the bound moved a value by more than twice its standard
    deviation (the logs then hold something the law cannot be).
    """
    p = a.shape[1]
    k = len(speeds)
    # theta = to_table @ phi: phi holds g(s_i) at knots 1..k-1 in place of their levels
    to_table = np.eye(p)
    s = np.asarray(speeds, dtype=np.float64)
    for start, slope in ((m, m + 2 * k), (m + k, m + 2 * k + 1)):
        to_table[start + 1 : start + k, slope] = -s[1:]
    to_magnitude = np.linalg.inv(to_table)
    lower = np.full(p, -np.inf)
    lower[m:] = 0.0
    phi = to_magnitude @ fit.coef
    if np.all(phi >= lower - 1e-15):
        return fit, ""
    w = fit.weights
    normal = to_table.T @ (a.T @ (a * w[:, None]) + prior) @ to_table
    rhs = to_table.T @ (a.T @ (w * y))
    d = np.sqrt(np.maximum(np.diag(normal), 1e-300))
    scaled = normal / np.outer(d, d) + 1e-12 * np.eye(p)
    chol = np.linalg.cholesky(scaled)
    target = np.linalg.solve(chol, rhs / d)
    res = optimize.lsq_linear(chol.T, target, bounds=(lower * d, np.full(p, np.inf)))
    coef = to_table @ (res.x / d)
    r = y - a @ coef
    bounded = _Trial(
        coef=coef,
        bread=fit.bread,
        residual=r,
        weights=w,
        prior=prior,
    )
    # the posterior standard deviation (``noise``: the residual's variance with the rows'
    # correlation, as in the prior's scale)
    var = mad_scale(fit.residual) ** 2 if noise is None else noise
    sd = np.sqrt(np.maximum(np.diag(to_magnitude @ fit.bread @ to_magnitude.T), 0.0) * var)
    moved = (phi < 0) & (np.arange(p) >= m) & (-phi > 2.0 * sd)
    note = ""
    if moved.any():
        note = (
            "the unconstrained friction fit was not dissipative (friction at a knot speed or "
            f"a viscous slope below 0 by more than 2 sigma, as low as {float(phi[moved].min()):.3g}"
            "): friction was held at >= 0 there; the logs may hold a load the model lacks "
            "(gravity, a spring) or be misaligned"
        )
    return bounded, note


def _law(
    coef: NDArray[np.float64], speeds: tuple[float, ...], w0: float, rows: _Rows
) -> tuple[SpeedTableFriction, str]:
    """The table law of the fitted friction coefficients; a direction the logs never moved
    in takes the other's levels."""
    k = len(speeds)
    v = rows.at(lambda p: p.velocity)
    pos = int(np.sum(v > speeds[0]))
    neg = int(np.sum(v < -speeds[0]))
    up, down = list(coef[:k]), list(coef[k : 2 * k])
    vu, vd = float(coef[2 * k]), float(coef[2 * k + 1])
    note = ""
    if min(pos, neg) < 0.01 * max(pos, neg, 1):
        if pos >= neg:
            down, vd = up, vu
            note = one_direction_note("negative")
        else:
            up, vu = down, vd
            note = one_direction_note("positive")
    law = SpeedTableFriction(
        speeds=speeds,
        positive=tuple(up),
        negative=tuple(down),
        viscous=vu,
        viscous_negative=vd,
        zero_velocity=w0,
    )
    return law, note


def _residual_psd(
    rows: _Rows, residual: NDArray[np.float64], scale: float, keep: NDArray[np.float64]
) -> float:
    """Low-frequency PSD of the residual [N^2 m^2/Hz] (see :class:`WholeFit`), over the rows
    the table is fitted on (``keep`` > 0), each run of them low-passed on its own: the rows
    below the observed speeds (a joint creeping or held while another moves, where the table
    is its prior's) leave a residual the per-speed table (:func:`residual_table`) carries at
    those speeds; in the noise level it would inflate every sample's sigma."""
    values = []
    for p, r, res, kp in zip(
        rows.pieces, rows.rows, _split(residual, rows), _split(keep, rows), strict=True
    ):
        inside = np.flatnonzero(kp > 0)
        if inside.size == 0:
            continue
        cut = np.flatnonzero(np.diff(inside) > 1) + 1
        for run in np.split(inside, cut):
            if run.size < 50:
                continue
            tt = p.t[r[run]]
            ok = np.concatenate(([True], np.diff(tt) > 0))
            try:
                values.append(lowpass(tt[ok], res[run][ok], cutoff=REFERENCE_CUTOFF))
            except InputError:  # a run too short for the filter adds nothing
                continue
    if not values:
        return scale**2 / 50.0
    low = np.concatenate(values)
    var = mad_scale(low) ** 2
    return float(var / (LOWPASS_ENB * REFERENCE_CUTOFF))


def _gravity_test(
    rows: _Rows,
    a: NDArray[np.float64],
    y: NDArray[np.float64],
    fit: _Trial,
    prior: NDArray[np.float64],
    k: int,
    planar: bool,
) -> tuple[float, bool]:
    """Peak-to-peak torque explained by joint-angle harmonics, and whether it is significant."""
    width = gravity_basis(rows.pieces[0].joint_angles[:1], k, planar).shape[1]
    if width <= 4:  # formed inside the smoother (the same numbers)
        g = np.vstack(
            [
                sm.angle_harmonics(p.joint_angles, k, planar)
                for p, sm in zip(rows.pieces, rows.smoothers, strict=True)
            ]
        )
    else:
        g = rows.smooth(lambda p, j0, j1: gravity_basis(p.joint_angles, k, planar)[:, j0:j1], width)
    full = np.hstack((a, g))
    pr = np.zeros((full.shape[1], full.shape[1]))
    pr[: a.shape[1], : a.shape[1]] = prior
    trial = _psolve(full, y, fit.weights, pr)
    cov = cluster_covariance(full, trial.residual, fit.weights, trial.bread, rows.clusters)
    m = g.shape[1]
    c = trial.coef[-m:]
    cg = cov[-m:, -m:]
    torque = g @ c
    ptp = float(np.percentile(torque, 99.5) - np.percentile(torque, 0.5))
    groups = np.unique(rows.clusters).size
    return ptp, bool(cluster_wald_pvalue(c, cg, groups) < 1e-6)


def _held_lines(
    orders: Sequence[tuple[float, bool]],
    candidates: Sequence[float],
    names: Sequence[str],
    coef: NDArray[np.float64],
    cov: NDArray[np.float64],
    false_alarm: float = 0.01,
) -> list[float]:
    """The ``candidates`` [CPR] whose cosine and sine coefficients in a fit over ``orders``
    differ from zero (Wald test, chi-square with 2 degrees of freedom, at ``false_alarm``
    divided among the candidates); ``names`` are the fit's fixed columns (inertia, then two
    PDTV columns per order, four per directional one)."""
    from scipy import stats

    first = sum(1 for n in names if n.startswith("inertia."))
    per = [4 if d else 2 for _, d in orders]
    starts = first + np.concatenate(([0], np.cumsum(per)))
    limit = float(stats.chi2.ppf(1.0 - false_alarm / max(len(candidates), 1), 2))
    held: list[float] = []
    for i, (order, directional) in enumerate(orders):
        if directional or order not in candidates:
            continue
        j = int(starts[i])
        c = coef[j : j + 2]
        chi = float(c @ np.linalg.pinv(cov[j : j + 2, j : j + 2]) @ c)
        if chi > limit:
            held.append(order)
    return held


def _unearned_lines(
    orders: Sequence[tuple[float, bool]],
    handed: Mapping[float, tuple[NDArray[np.float64], NDArray[np.float64]]],
    names: Sequence[str],
    coef: NDArray[np.float64],
    cov: NDArray[np.float64],
    tested: int,
    false_alarm: float = HANDED_FALSE_ALARM,
) -> list[float]:
    """The handed-down ``orders`` [CPR] whose whole-fit amplitude exceeds the pass method's.

    A line (both directions together) with whole-fit amplitude ``A`` (standard error ``s``,
    ``cov`` along its coefficients' direction) and pass amplitude ``A_p`` (``handed[order]``:
    coefficients and covariance; standard error ``s_p`` the same way) is returned when
    ``(A - A_p) / sqrt(s^2 + s_p^2)`` exceeds the normal quantile at ``false_alarm`` divided
    among the ``tested`` handed-down lines (one-sided). One-sided because the failure it
    catches is a column that takes up something else (an order the rows do not resolve where
    the joint moves fast, aliased at the log's samples into a slow column), which inflates the
    line; a line the whole fit finds smaller is the whole fit's estimate. Orders not in
    ``handed``, and directional ones, are not returned. ``names`` are the fit's fixed columns
    (inertia, then two PDTV columns per order, four per directional one).
    """
    first = sum(1 for n in names if n.startswith("inertia."))
    per = [4 if d else 2 for _, d in orders]
    starts = first + np.concatenate(([0], np.cumsum(per)))
    limit = float(stats.norm.isf(false_alarm / max(tested, 1)))

    def amplitude(c: NDArray[np.float64], cc: NDArray[np.float64]) -> tuple[float, float]:
        amp = float(np.hypot(*c))
        u = c / amp if amp > 0 else np.full(2, math.sqrt(0.5))
        return amp, max(float(u @ cc @ u), 0.0)

    out: list[float] = []
    for i, (order, directional) in enumerate(orders):
        if directional or order not in handed:
            continue
        j = int(starts[i])
        amp, var = amplitude(coef[j : j + 2], cov[j : j + 2, j : j + 2])
        c_p, cov_p = handed[order]
        amp_p, var_p = amplitude(np.asarray(c_p, dtype=np.float64), np.asarray(cov_p))
        if (amp - amp_p) / math.sqrt(max(var + var_p, 1e-300)) > limit:
            out.append(order)
    return out


def _run_revolutions(rows: _Rows) -> float:
    """Motor revolutions of a typical run of one direction of motion among the rows: the
    row-weighted median of the runs' angle spans (0 when no row moves)."""
    spans, weights = [], []
    for p, r in zip(rows.pieces, rows.rows, strict=True):
        if r.size == 0:
            continue
        sign = np.sign(p.velocity[r])
        cuts = np.flatnonzero(np.diff(sign) != 0) + 1
        for run in np.split(np.arange(r.size), cuts):
            if run.size and sign[run[0]] != 0:
                th = p.theta[r[run]]
                spans.append(abs(float(th[-1] - th[0])) / (2.0 * math.pi))
                weights.append(run.size)
    if not spans:
        return 0.0
    order = np.argsort(spans)
    cum = np.cumsum(np.asarray(weights, dtype=np.float64)[order])
    return float(np.asarray(spans)[order][int(np.searchsorted(cum, 0.5 * cum[-1]))])


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
