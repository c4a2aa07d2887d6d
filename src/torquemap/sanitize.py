"""Logs as real controllers write them: repeated stamps, implausible samples, gaps, segments.

Before anything is differentiated or filtered, :func:`sanitize_log`

1. drops samples whose time stamp repeats the previous one (a host that polled twice before the
   drive updated; one warning);
2. finds implausible samples per channel: a torque (current) or a joint angle that leaves the
   running median of its neighbours by far more than the signal ever moves between samples (a
   corrupted current of 1e6 A, an encoder glitch) for at most ``GLITCH_DURATION`` (10 ms, one
   to four samples; longer excursions are motion, judged in time, not in samples). Such a value is replaced, for the filters, by
   the straight line between its sound neighbours, so that it spoils nothing around it; the
   sample is flagged;
3. cuts the log where the time between two samples exceeds what the filters can bridge
   (``max_gap``), and where a joint angle jumps by more than the robot moves between two
   samples (:func:`angle_jumps`: an encoder glitch that persists, a re-zeroing; the sample
   after the jump is flagged implausible): each piece is processed on its own and nothing
   leaks across a cut.

A joint whose current (torque) is the same at every sample while it moves gets a warning: no
real current is that still, the log holds no current for it. So do time stamps rounded to a
decimal that is a large part of the time step (:func:`torquemap.log_quirks.coarse_time_warning`).

The result keeps the original rows (for the output) and the pieces (for the filters).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.io import Log
from torquemap.log_quirks import coarse_time_warning

#: A sample is implausible when it leaves the running median of its neighbours by more than
#: this many robust standard deviations of that deviation (and by more than the largest step
#: the channel makes in normal operation, see :func:`implausible_samples`).
SPIKE_SIGMAS = 50.0
#: The longest running median [samples]: it removes excursions of up to 4 samples.
MEDIAN_SPAN = 9
#: An excursion from the neighbours that lasts at most this long [s] (and at most
#: ``MEDIAN_SPAN // 2`` samples) is a glitch (a corrupted reading, an encoder error, or a
#: torque pulse too short for the log to resolve), longer ones are motion or torque the robot
#: really had (the acceleration pulse of a 14 ms speed ramp): the running median spans twice
#: this in time (:func:`median_span_for`), so that a ramp's pulse is judged alike at 281 Hz and
#: at 2 kHz. From 400 Hz up the span is the 9 samples it always was.
GLITCH_DURATION = 10e-3


@dataclass(frozen=True, slots=True, eq=False)
class Piece:
    """A stretch of a log between gaps, with the rows it came from.

    Attributes
    ----------
    log
        The stretch as a log (repeated stamps dropped, implausible values bridged).
    rows
        Row of the original log of each sample, shape (m,).
    """

    log: Log
    rows: NDArray[np.int64]


@dataclass(frozen=True, slots=True, eq=False)
class CleanLog:
    """Result of :func:`sanitize_log`.

    Attributes
    ----------
    log
        The original log.
    pieces
        Stretches between gaps long enough to process, in time order.
    repeated
        Rows dropped because their time stamp repeats the previous row's, shape (n,).
    implausible
        Rows holding an implausible value in some channel, shape (n,).
    unprocessed
        Rows in no piece (repeated stamps, stretches between gaps too short to process).
    gaps
        ``(t_before, t_after)`` of each gap (or angle jump) the log was cut at [s].
    warnings
        One line each.
    """

    log: Log
    pieces: tuple[Piece, ...]
    repeated: NDArray[np.bool_]
    implausible: NDArray[np.bool_]
    unprocessed: NDArray[np.bool_]
    gaps: tuple[tuple[float, float], ...]
    warnings: tuple[str, ...]


def median_span_for(t: NDArray[np.float64]) -> int:
    """The running median's span [samples] for a log stamped ``t`` [s]: ``2 h + 1`` where ``h``
    samples last ``GLITCH_DURATION`` at the median time step, at least 1 (a single sample is
    the shortest excursion a log shows) and at most 4 (``MEDIAN_SPAN``).

    A running median of ``2 h + 1`` removes excursions of up to ``h`` samples: those are judged
    by :func:`implausible_samples`, longer ones follow the median and are never flagged. A span
    fixed at 9 samples judged by the sampling rate instead of the motion: a 14 ms acceleration
    pulse is 4 samples at 281 Hz (removed by a median of 9, flagged) and 28 at 2 kHz (kept);
    with a span of 5 at 281 Hz only excursions of up to 2 samples (7 ms) stand out. At 400 Hz
    and above the span is 9, as before.

    Examples
    --------
    >>> [median_span_for(np.arange(50) / rate) for rate in (100.0, 281.0, 340.0, 400.0, 2e3)]
    [3, 5, 7, 9, 9]
    """
    if t.size < 2:
        return 3
    step = float(np.median(np.diff(t)))
    if not step > 0:
        return MEDIAN_SPAN
    h = int(min(MEDIAN_SPAN // 2, max(1, math.floor(GLITCH_DURATION / step * (1 + 1e-9)))))
    return 2 * h + 1


def implausible_samples(x: NDArray[np.float64], *, span: int = MEDIAN_SPAN) -> NDArray[np.bool_]:
    """Samples of one channel that leave the running median of their neighbours implausibly far.

    The deviation from a running median over ``span`` samples (odd, 3 to ``MEDIAN_SPAN``;
    :func:`median_span_for` the log's time step) follows steps and ramps of the signal and
    excursions longer than half the span, so only excursions of at most ``span // 2`` samples
    stand out. A sample is implausible when its
    deviation exceeds both ``SPIKE_SIGMAS`` robust standard deviations of all deviations and
    ten times the 99th percentile of the channel's sample-to-sample change (what the signal does
    in normal operation) and ten times its typical nonzero step (an encoder count).

    Examples
    --------
    >>> x = np.sin(np.linspace(0.0, 6.0, 400))
    >>> x[100] = 1e6
    >>> np.flatnonzero(implausible_samples(x)).tolist()
    [100]
    """
    from torquemap._kernels import max_abs

    if span % 2 == 0 or not 3 <= span <= MEDIAN_SPAN:
        raise ValueError(f"span must be odd, 3 to {MEDIAN_SPAN}, not {span}")
    v = np.ascontiguousarray(x, dtype=np.float64)
    if v.size < MEDIAN_SPAN:
        return np.zeros(v.size, dtype=bool)
    # the median of the deviations is taken in a scaled space so 1e300 does not overflow
    big = max_abs(v)
    if not math.isfinite(big) or big == 0.0:
        return np.zeros(v.size, dtype=bool)
    if _none_beyond(v, big, max(10.0 * _median_at_least(v, big), 1e-12), span):
        return np.zeros(v.size, dtype=bool)
    u = v / big
    du = np.abs(np.diff(u))
    moves = du[du > 0]
    typical = float(np.median(moves)) if moves.size else 0.0
    from scipy.ndimage import median_filter  # 0.6 s to import: only for a suspect channel

    med = median_filter(u, size=span, mode="nearest")
    dev = np.abs(u - med)
    scale = 1.4826 * float(np.median(dev))
    step = float(np.percentile(np.abs(np.diff(med)), 99))
    floor = max(SPIKE_SIGMAS * scale, 10.0 * step, 10.0 * typical, 1e-12)
    bad = dev > floor
    if bad.any() and bad.mean() > 0.2:  # not isolated excursions: leave the channel alone
        return np.zeros(v.size, dtype=bool)
    return np.asarray(bad, dtype=bool)


def _median_at_least(v: NDArray[np.float64], big: float) -> float:
    """A value at most the median of the nonzero steps ``|diff(v / big)|``, close to it.

    The median of every 64th nonzero step, less 10 %, when a count shows that at least half
    the nonzero steps reach it (then the median does); else the median itself. A bound for
    :func:`_none_beyond` without a sort of every sample (the counts in one compiled pass,
    :func:`torquemap._kernels.step_counts`, without the steps' array).
    """
    from torquemap._kernels import step_counts

    at = np.arange(0, v.size - 1, 64)
    moves = np.abs(v[at + 1] / big - v[at] / big)
    moves = moves[moves > 0]
    if moves.size >= 16:
        guess = 0.9 * float(np.median(moves))
        m, reach = step_counts(v, big, guess) if guess > 0 else (0, 0)
        if m and reach >= m - (m - 1) // 2:
            return guess
    du = np.abs(np.diff(v / big))
    every = du[du > 0]
    return float(np.median(every)) if every.size else 0.0


def _none_beyond(v: NDArray[np.float64], big: float, bound: float, span: int) -> bool:
    """Whether no sample of ``u = v / big`` leaves the running median of ``span`` (3 to
    ``MEDIAN_SPAN``) by more than ``bound``.

    A cheap exact test before the running median of every sample. The median of a window of
    ``2 h + 1`` values lies between the smallest and the largest of ANY ``h + 1`` of them
    (at most ``h`` values lie strictly above the median, and at most ``h`` below), so a
    sample leaves it by at most its distance to the farthest of ``h + 1`` samples of the
    window including itself; the 5 samples centred on it hold such a set for every ``h <= 4``
    (one compiled pass, :func:`torquemap._kernels.median_reach_suspects`). Only the
    samples where that distance exceeds ``bound`` get their median computed.
    """
    from torquemap._kernels import median_reach_suspects

    half = span // 2
    suspect = median_reach_suspects(v, big, bound)
    if suspect.size > v.size // 100:
        # a fast ramp: every sample is far from its neighbours, but where its window is
        # monotone the median is the sample itself (a deviation of 0)
        suspect = suspect[~_monotone_windows(v, suspect, half)]
    if suspect.size == 0:
        return True
    if suspect.size > v.size // 100:
        return False  # many: the full running median is as cheap
    window = np.clip(suspect[:, None] + np.arange(-half, half + 1)[None, :], 0, v.size - 1)
    u = v[window] / big
    local = np.median(u, axis=1)  # ``mode="nearest"``: the ends repeat
    return bool(np.all(np.abs(v[suspect] / big - local) <= bound))


def _monotone_windows(
    v: NDArray[np.float64], at: NDArray[np.int64], half: int
) -> NDArray[np.bool_]:
    """Whether the running median's window of each sample ``at`` (``2 half + 1`` samples of
    ``v``, the ends repeated as ``mode="nearest"`` repeats them) is monotone (non-decreasing
    or non-increasing): its median is then the sample itself, whatever its size (the sorted
    window is the window, or the window reversed). A stretch at a time (memory)."""
    out = np.zeros(at.size, dtype=bool)
    lags = np.arange(-half, half + 1)
    for a in range(0, at.size, 1 << 16):
        idx = np.clip(at[a : a + (1 << 16), None] + lags[None, :], 0, v.size - 1)
        steps = np.diff(v[idx], axis=1)
        out[a : a + idx.shape[0]] = np.all(steps >= 0, axis=1) | np.all(steps <= 0, axis=1)
    return out


#: A step of a joint angle between two samples is a jump when it exceeds this many times both
#: the 99th percentile of the channel's steps and the 99th percentile of its speed.
JUMP_FACTOR = 20.0


def angle_jumps(t: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Steps of one joint angle beyond the robot's speed: True at sample ``i`` when the angle
    jumps between samples ``i - 1`` and ``i`` by more than ``JUMP_FACTOR`` times the largest
    steps the channel makes (99th percentile), at more than ``JUMP_FACTOR`` times its largest
    speeds (an encoder glitch that persists, a re-zeroing). A step across a long time interval
    at the usual speed is no jump, nor a short interval with a usual step (jitter).

    Examples
    --------
    >>> t = np.arange(400) * 1e-3
    >>> q = np.sin(t)
    >>> q[250:] += 1.0
    >>> np.flatnonzero(angle_jumps(t, q)).tolist()
    [250]
    """
    out = np.zeros(t.size, dtype=bool)
    if t.size < MEDIAN_SPAN:
        return out
    from torquemap._kernels import angle_step_summary, count_at_least

    tc = np.ascontiguousarray(t, dtype=np.float64)
    qc = np.ascontiguousarray(q, dtype=np.float64)
    ok, top = angle_step_summary(tc, qc)
    if not ok:
        return out
    # no step exceeds 20 times the 99th percentile when enough steps reach a twentieth of the
    # largest (then that percentile does): exact, and it spares two percentiles (sorts)
    reach = top / (JUMP_FACTOR * (1.0 - 1e-9))
    need = (t.size - 1) - math.floor(0.99 * (t.size - 2))
    if count_at_least(qc, reach) >= need:
        return out
    dq = np.abs(np.diff(q))
    dt = np.diff(t)
    speed = dq / dt
    step_top = top_percentile(dq, 99.0)
    speed_top = top_percentile(speed, 99.0)
    jump = (dq > JUMP_FACTOR * max(step_top, 1e-12)) & (speed > JUMP_FACTOR * max(speed_top, 1e-12))
    if jump.mean() > 0.005:  # not isolated: the channel's nature, leave it
        return out
    out[1:] = jump
    return out


def top_percentile(x: NDArray[np.float64], q: float) -> float:
    """``numpy.percentile(x, q)`` (its default, linear interpolation) of a high percentile
    without selecting among every value: the two order statistics it interpolates lie
    among the values at or above a bound that a sample of every 64th value suggests and a
    count confirms; only those are partitioned (the full array when the count falls short,
    or ``x`` is short or holds NaN). Bit for bit numpy's (tests/test_sanitize.py).

    Examples
    --------
    >>> x = np.random.default_rng(0).normal(size=100_000)
    >>> top_percentile(x, 99.0) == float(np.percentile(x, 99))
    True
    """
    a = np.ravel(x)
    n = a.size
    qq = float(np.true_divide(q, 100))
    if n < 4096 or not 0.5 <= qq <= 1.0 or math.isnan(float(np.max(a))):
        return float(np.percentile(a, q))  # short, low, or NaN (numpy's max propagates it)
    virtual = (n - 1) * qq
    below = math.floor(virtual)
    above = min(below + 1, n - 1)
    need = n - below  # values at or above the lower order statistic
    # a bound at about twice the needed share's quantile of a sample, then counted
    sample = a[::64]
    share = min(1.0, 2.0 * need / n + 64.0 / n)
    bound = float(np.quantile(sample, max(0.0, 1.0 - share)))
    top = a[a >= bound]
    if top.size < need:
        return float(np.percentile(a, q))
    offset = n - top.size  # top's rank 0 is the array's rank ``offset``
    part = np.partition(top, [below - offset, above - offset])
    lo, hi = float(part[below - offset]), float(part[above - offset])
    gamma = virtual - below
    # numpy's _lerp, the same operations
    diff = hi - lo
    return hi - diff * (1.0 - gamma) if gamma >= 0.5 else lo + diff * gamma


def max_gap_for(window: float) -> float:
    """The longest time between two samples [s] the filters bridge: 2.5 differentiator windows."""
    return 2.5 * float(window)


def no_stretch_message(t: NDArray[np.float64], window: float) -> str:
    """What to say when no stretch of a log between gaps lasts the differentiator window.

    When the median time step is itself a gap, the time is likely not in seconds (a log in
    milliseconds looks 1000 times sparser), or the window is shorter than the sampling period.
    When a fifth of the steps or more repeat a stamp, ``t`` was written with too few digits
    (Unix time in seconds through ``%.10g`` advances in whole seconds: before, stop 39, the
    refusal said only "record without gaps").
    """
    limit = max_gap_for(window)
    head = (
        f"no stretch of the log between gaps in time lasts the {window:.3g} s differentiator window"
    )
    text = f"{head}; record without gaps longer than {limit:.3g} s"
    steps = np.diff(t)
    if steps.size and float(np.max(steps)) <= limit:
        # no gap at all: the log itself is short (an arm's identification asks 4 windows)
        return (
            f"{head}: the log lasts {float(t[-1] - t[0]):.3g} s in all, without a gap; record "
            "a longer motion"
        )
    repeats = float(np.mean(steps <= 0)) if steps.size else 0.0
    advances = steps[steps > 0]
    if repeats >= 0.2 and advances.size:
        # stamps written with too few digits (Unix time through %g): most rows repeat one
        return text + (
            f" (t repeats the previous stamp on {repeats:.1%} of its steps and advances in "
            f"steps of {float(np.median(advances)):.3g} s: 't' was written with too few "
            "digits; write t with all its digits, or in seconds from the log's start)"
        )
    step = float(np.median(steps)) if t.size > 1 else 0.0
    if step > limit:
        text += (
            f" (its median time step is {step:.3g} s: 't' must be in seconds, not ms, us or ns; "
            f"else the --window must be at least {step / 2.5:.3g} s)"
        )
    return text


def slow_time_warning(t: NDArray[np.float64], window: float = 0.05) -> str | None:
    """A warning when a log's median time step is longer than the filters bridge, else None.

    Such a log is either sampled slower than ``1 / max_gap_for(window)`` (8 Hz with the default
    0.05 s window) or, far more often, stamped in ms or us: it then reads as 1000 times slower,
    every stretch of motion as a hold.

    Examples
    --------
    >>> slow_time_warning(np.arange(10) * 0.25)[:40]
    'its median time step is 0.25 s (4 Hz): i'
    >>> slow_time_warning(np.arange(10) * 0.001) is None
    True
    """
    if t.size < 2:
        return None
    step = float(np.median(np.diff(t)))
    if not step > max_gap_for(window):
        return None
    return (
        f"its median time step is {step:.3g} s ({1 / step:.3g} Hz): if 't' is in ms or us, "
        "convert it to seconds (read as it is, motion looks like position holds)"
    )


def sanitize_log(log: Log, *, window: float, min_piece: float | None = None) -> CleanLog:
    """Drop repeated stamps, bridge implausible samples and cut the log at gaps.

    Parameters
    ----------
    log
        The log as read (non-decreasing time).
    window
        The differentiator window [s]; gaps longer than :func:`max_gap_for` it cut the log.
    min_piece
        Shortest piece kept [s] (default: the window); shorter stretches are unprocessed.

    Returns
    -------
    CleanLog
    """
    t = log.t
    n = t.size
    warnings: list[str] = []
    repeated = np.zeros(n, dtype=bool)
    if n > 1:
        repeated[1:] = np.diff(t) <= 0
    if repeated.any():
        count = int(repeated.sum())
        first = float(t[int(np.argmax(repeated))])
        what = "1 sample repeats" if count == 1 else f"{count} samples repeat"
        line = f"{what} the previous time stamp (first at t = {first:.6g} s): dropped"
        if count >= 0.2 * n:
            moved = (np.diff(log.q, axis=0) != 0).any(axis=1) | (
                np.diff(log.motor_torque, axis=0) != 0
            ).any(axis=1)
            if float(np.mean(moved[repeated[1:]])) > 0.5:  # new readings, not polled twice
                advances = np.diff(t)[np.diff(t) > 0]
                step = float(np.median(advances)) if advances.size else 0.0
                line += (
                    f"; they hold new readings: 't' was written with too few digits (it "
                    f"advances in steps of {step:.3g} s), so {count / n:.0%} of the samples "
                    "are lost; write t with all its digits"
                )
        warnings.append(line)
    keep = np.flatnonzero(~repeated)
    if not any("too few digits" in w for w in warnings):
        coarse = coarse_time_warning(t[keep])
        if coarse is not None:
            warnings.append(coarse)
    # no repeated stamp: the log's own arrays, copied only when a sample is bridged (bridging
    # writes into them); else the kept rows (a gather: copies already)
    own = keep.size == n
    if own:
        tk, q, tau = t, log.q, log.motor_torque
    else:
        tk, q, tau = t[keep], log.q[keep], log.motor_torque[keep]
    for k in range(q.shape[1]):
        # a real current is never exactly constant while its joint moves: no channel
        if tau.shape[0] > 1 and np.ptp(tau[:, k]) == 0 and np.ptp(q[:, k]) > 0:
            name = log.joint_names[k] if k < len(log.joint_names) else str(k)
            warnings.append(
                f"joint {name}: the current (torque) is {tau[0, k]:.6g} N m at every sample "
                "while the joint moves: no current was recorded (a wrong or unset column?); "
                "what is computed from it is not the robot's"
            )
    bad_any = np.zeros(keep.size, dtype=bool)
    span = median_span_for(tk)
    for k in range(q.shape[1]):
        for what in ("torque", "angle"):
            arr = tau if what == "torque" else q
            bad = np.zeros(tk.size, dtype=bool)
            for _ in range(4):  # a wild value hides lesser ones: look again once it is bridged
                new = implausible_samples(arr[:, k], span=span) & ~bad
                if not new.any():
                    break
                if own and (arr is log.q or arr is log.motor_torque):
                    arr = arr.copy()  # the first bridged sample of this array: a copy
                    if what == "torque":
                        tau = arr
                    else:
                        q = arr
                bad |= new
                good = ~bad
                arr[bad, k] = np.interp(tk[bad], tk[good], arr[good, k])
            if bad.any():
                bad_any |= bad
                name = log.joint_names[k] if k < len(log.joint_names) else str(k)
                warnings.append(
                    f"joint {name}: {int(bad.sum())} implausible {what} samples (far outside "
                    "what the signal does between samples): bridged from their neighbours and "
                    "flagged"
                )
    jumps = np.zeros(keep.size, dtype=bool)
    for k in range(q.shape[1]):
        jk = angle_jumps(tk, q[:, k])
        if jk.any():
            name = log.joint_names[k] if k < len(log.joint_names) else str(k)
            i = int(np.flatnonzero(jk)[0])
            at = np.flatnonzero(jk)
            steps = np.abs(q[at, k] - q[at - 1, k])
            # every jump a whole turn: an angle wrapped to (-pi, pi], as ROS JointState
            # publishes a continuous joint (before: "an encoder glitch or re-zeroing?")
            turn = bool(np.all(np.abs(steps - 2.0 * np.pi) < 0.05 * np.pi))
            cause = (
                "an angle wrapped to one turn (a continuous joint as ROS publishes it?): unwrap "
                "it (numpy.unwrap) before"
                if turn
                else "an encoder glitch or re-zeroing?"
            )
            warnings.append(
                f"joint {name}: the angle jumps {int(jk.sum())} times between two samples by "
                f"more than the robot moves (first at t = {tk[i]:.6g} s, by "
                f"{q[i, k] - q[i - 1, k]:+.4g} rad): {cause}. The log "
                "is cut there and the samples flagged"
            )
            jumps |= jk
    bad_any |= jumps
    implausible = np.zeros(n, dtype=bool)
    implausible[keep[bad_any]] = True
    gap_limit = max_gap_for(window)
    cuts = np.flatnonzero((np.diff(tk) > gap_limit) | jumps[1:]) + 1
    edges = np.concatenate(([0], cuts, [tk.size]))
    shortest = float(window) if min_piece is None else float(min_piece)
    pieces: list[Piece] = []
    unprocessed = repeated.copy()
    for a, b in itertools.pairwise(edges):
        rows = keep[a:b]
        if b - a < 5 or tk[b - 1] - tk[a] < shortest:
            unprocessed[rows] = True
            continue
        sub = dataclasses.replace(log, t=tk[a:b], q=q[a:b], motor_torque=tau[a:b])
        pieces.append(Piece(log=sub, rows=rows.astype(np.int64)))
    gaps = tuple((float(tk[c - 1]), float(tk[c])) for c in cuts)
    in_time = [(a, b) for a, b in gaps if b - a > gap_limit]
    if in_time:
        longest = max(b - a for a, b in in_time)
        warnings.append(
            f"{len(in_time)} gaps in time longer than {gap_limit:.3g} s (the longest "
            f"{longest:.3g} s): the log is processed in {len(pieces)} pieces between them"
        )
    short = unprocessed & ~repeated
    if short.any():
        warnings.append(
            f"{int(short.sum())} samples lie in stretches between gaps shorter than "
            f"{shortest:.3g} s: not estimated (flagged)"
        )
    return CleanLog(
        log=log,
        pieces=tuple(pieces),
        repeated=repeated,
        implausible=implausible,
        unprocessed=unprocessed,
        gaps=gaps,
        warnings=tuple(warnings),
    )
