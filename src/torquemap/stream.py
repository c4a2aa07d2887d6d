"""Force estimation in chunks and in real time: the batch estimator over overlapping blocks.

:func:`torquemap.estimate.estimate_forces` needs the whole log in memory. Its filters, though,
see only a bounded stretch around each sample: the differentiator its window, the reversal
bridges ``bridge_reversals``, and the zero-phase low-pass an impulse response that decays as
``exp(-2 pi cutoff cos(pi / 4) |t|)`` (the slowest pole of the order-2 Butterworth, run forwards
and backwards). So a sample's estimate computed from the log cut ``margin`` seconds either side
of it equals the batch estimate to ``tolerance`` of the low-pass's input when

    margin = ln(1 / tolerance) / (2 pi cutoff cos(pi / 4)) + bridge_reversals + 2 window

(:func:`settling_time`). :class:`ForceEstimator` keeps a buffer of the log, runs the batch
estimator on blocks of it that reach ``margin`` beyond the samples they answer (overlap-save:
each block is computed with its margins, only its centre is kept) and returns the samples whose
filters have settled. Memory is bounded by a block, and the latency by ``margin + hop``.

Not local, hence not reproduced in blocks: the ``paper`` method (it filters whole monotonic
passes, refused here), stretches of undetermined friction longer than ``hold`` (the batch
fills such a hold from both sides; a block that cuts it, from its one visible side: measured
1e-7 N m, at the samples within the low-pass's reach of such a hold), and the thresholds of
implausible samples (:func:`torquemap.sanitize.implausible_samples`, from each block's own
statistics).
"""

from __future__ import annotations

import collections
import dataclasses
import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.estimate import (
    FLAG_GAP,
    ForceEstimate,
    estimate_forces,
    identified_delays,
    model_window,
)
from torquemap.io import Log, LogChunk
from torquemap.model import Model
from torquemap.sanitize import max_gap_for

StreamMethod = Literal["model", "lowpass", "raw"]

#: Default tolerance of the chunked file path: blocks agree with the batch to rounding.
EXACT_TOLERANCE = 1e-12
#: Default tolerance of :class:`ForceEstimator`: the filters' tail beyond the margin is below
#: 1e-6 of their input, far below the noise of any estimate, at about half the latency.
STREAM_TOLERANCE = 1e-6
#: Most threads :func:`default_threads` gives: each thread holds a block's arrays (about
#: 300 MB more peak memory per thread for 2^19 samples of two joints, measured), and two were
#: all that was measured (a 2-core machine).
MAX_DEFAULT_THREADS = 2


def default_threads() -> int:
    """Blocks to estimate at once by default: the cores this process may run on, at most
    :data:`MAX_DEFAULT_THREADS`.

    Examples
    --------
    >>> 1 <= default_threads() <= MAX_DEFAULT_THREADS
    True
    """
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_DEFAULT_THREADS))


def settling_time(
    *,
    cutoff: float,
    window: float,
    bridge_reversals: float = 0.5,
    method: StreamMethod = "model",
    delay: float = 0.0,
    tolerance: float = EXACT_TOLERANCE,
    hold: float = 0.0,
) -> float:
    """The margin [s] a block needs on each side for its centre to equal the batch estimate.

    Parameters
    ----------
    cutoff
        Low-pass cut-off [Hz].
    window
        Differentiator window [s].
    bridge_reversals
        Longest bridged stretch of undetermined friction [s].
    method
        ``raw`` has no low-pass.
    delay
        Largest torque-channel delay undone [s].
    tolerance
        What the low-pass's impulse response has decayed to at the margin, relative to its
        peak (> 0, < 1).
    hold
        Longest hold [s] (a stretch of undetermined friction longer than ``bridge_reversals``)
        to be answered as in the batch: the batch fills a hold from both its sides, so a block
        must hold it whole to do the same.

    Returns
    -------
    float
        The margin [s].

    Examples
    --------
    >>> round(settling_time(cutoff=2.0, window=0.05, tolerance=1e-12), 3)
    3.71
    """
    if not (0 < tolerance < 1):
        raise InputError(f"tolerance must be in (0, 1), got {tolerance!r}")
    tail = 0.0
    if method != "raw":
        tail = math.log(1.0 / tolerance) / (2.0 * math.pi * cutoff * math.cos(math.pi / 4))
    return tail + max(bridge_reversals, hold, 0.0) + 2.0 * window + abs(delay)


_ROW_FIELDS = (
    "t",
    "q",
    "motor_angle",
    "velocity",
    "t_est",
    "filtered",
    "motor_external",
    "tau_ext",
    "force",
    "flag",
    "tau_ext_sigma",
    "force_sigma",
)


def _compact(est: ForceEstimate) -> ForceEstimate:
    """``est`` with its arrays copied: a slice must not keep its whole block's arrays alive."""
    copies: dict[str, Any] = {}
    for name in _ROW_FIELDS:
        value = getattr(est, name)
        copies[name] = None if value is None else np.array(value)
    return dataclasses.replace(est, **copies)


def _empty_like(est: ForceEstimate) -> ForceEstimate:
    return _compact(_slice(est, 0, 0))


def _slice(est: ForceEstimate, a: int, b: int) -> ForceEstimate:
    """Rows ``a:b`` of an estimate; passes clipped to them and renumbered."""
    passes = tuple(
        tuple(
            dataclasses.replace(p, start=max(p.start, a) - a, stop=min(p.stop, b) - a)
            for p in joint
            if p.stop > a and p.start < b
        )
        for joint in est.passes
    )

    def rows(x: NDArray[Any] | None) -> Any:
        return None if x is None else x[a:b]

    return dataclasses.replace(
        est,
        t=est.t[a:b],
        q=est.q[a:b],
        motor_angle=est.motor_angle[a:b],
        velocity=est.velocity[a:b],
        t_est=est.t_est[a:b],
        filtered=est.filtered[a:b],
        motor_external=est.motor_external[a:b],
        tau_ext=est.tau_ext[a:b],
        force=rows(est.force),
        flag=est.flag[a:b],
        passes=passes,
        tau_ext_sigma=rows(est.tau_ext_sigma),
        force_sigma=rows(est.force_sigma),
    )


def _gap_estimate(model: Model, log: Log, template: ForceEstimate | None) -> ForceEstimate:
    """NaN answers flagged ``FLAG_GAP`` for a block that holds no stretch long enough."""
    n, nj = log.t.size, len(model.robot.joints)
    nan = np.full((n, nj), np.nan)
    axes = model.robot.arm.wrench_axes
    force = np.full((n, len(axes)), np.nan) if axes else None
    return ForceEstimate(
        t=log.t,
        joint_names=model.robot.joint_names,
        q=log.q,
        motor_angle=nan,
        velocity=nan,
        t_est=nan,
        filtered=nan,
        motor_external=nan,
        tau_ext=nan,
        force=force,
        flag=np.full(n, FLAG_GAP, dtype=np.int64),
        passes=tuple(() for _ in range(nj)),
        method=template.method if template is not None else "model",
        cutoff=template.cutoff if template is not None else float("nan"),
        wrench_axes=axes if force is not None else (),
        tau_ext_sigma=nan,
        force_sigma=None if force is None else force.copy(),
    )


_NUMBER = re.compile(r"[-+]?\d[\d.,e+-]*%?")


@dataclass(slots=True, eq=False)
class _Job:
    """A block of the buffer to estimate (:meth:`ForceEstimator._plan`).

    ``log`` is the block (views of the buffer), ``a:b`` its rows answered, ``edges`` the
    stretches ``(from, to, gap length)`` [s] next to gaps just outside it, flagged
    ``FLAG_GAP``; ``whole``: the block is the whole log (its refusal is the batch's);
    ``call``: the call of ``_drain_groups`` that planned it; ``result``: the pool's future,
    when a pool computes it; ``first``: the first block planned (the one whose delay is
    checked against the model's, :mod:`torquemap.task_delay`).
    """

    log: Log
    a: int
    b: int
    edges: tuple[tuple[float, float, float], ...]
    whole: bool
    gap: float
    call: int
    result: Future[ForceEstimate | InputError] | None = None
    first: bool = False


class ForceEstimator:
    """Estimate external torques and forces from a log that arrives in pieces.

    ``update(t, q, i)`` appends samples and returns the estimates of every sample whose
    filters have settled (a :class:`~torquemap.estimate.ForceEstimate` of those rows, possibly
    empty); :meth:`finish` returns the rest at the end of the log. The answers equal those of
    :func:`~torquemap.estimate.estimate_forces` on the whole log to ``tolerance`` of the
    low-pass's input (module docstring), with the same sanitising (repeated stamps, implausible
    samples, gaps) and flags. Memory holds ``2 margin + hop`` seconds of log (at most
    ``max_rows`` answered per block).

    Parameters
    ----------
    model
        Identified model.
    method
        ``"model"`` (default), ``"lowpass"`` or ``"raw"`` (``paper`` filters whole passes
        and is refused).
    cutoff, window, bridge_reversals, reversal_band, min_sin_elbow, check_robot
        As :func:`~torquemap.estimate.estimate_forces`.
    tolerance, hold
        Decay of the low-pass's response at the margin and the longest hold answered as in
        the batch [s] (:func:`settling_time`).
    hop
        Fewest seconds of settled samples answered at once [s]: each block recomputes its
        margins, so blocks much shorter than the margin multiply the cost.
    max_rows
        Most samples answered per block.
    path
        Name of the log, for messages.
    threads
        Blocks estimated at once, each in its own thread (1: one after the other, in the
        caller's thread). The answers are the same bit for bit, in the same order; they come
        back once every earlier block's have, so up to ``threads`` blocks more are held (and
        the latency of a live log grows by as many blocks). The compiled kernels and numpy's
        and scipy's work on whole arrays run without Python's lock, so two threads take
        less wall time on two cores (docs/performance.md); :meth:`finish` (or :meth:`close`)
        stops the threads.

    Attributes
    ----------
    latency
        Log time [s] between a sample's arrival and its answer, at most: ``margin + hop``.
    margin
        Log time [s] each block reaches beyond the samples it answers.

    Examples
    --------
    >>> from torquemap.model import model_from_dict
    >>> m = model_from_dict({"robot": {"kinematics": "none"},
    ...                      "joints": {"m": {"gear_ratio": 10, "torque_constant": 0.5}}})
    >>> est = ForceEstimator(m, cutoff=5.0, hop=0.5)
    >>> t = np.arange(4000) * 1e-3
    >>> got = est.update(t, np.sin(t)[:, None], np.full((t.size, 1), 0.2))
    >>> done = est.finish()
    >>> got.t.size + done.t.size, round(float(done.tau_ext[-1, 0]), 6)
    (4000, -1.0)
    """

    def __init__(
        self,
        model: Model,
        *,
        method: StreamMethod = "model",
        cutoff: float = 2.0,
        window: float | None = None,
        bridge_reversals: float = 0.5,
        reversal_band: float | Mapping[str, float] | None = None,
        min_sin_elbow: float = 0.05,
        check_robot: bool = True,
        tolerance: float = STREAM_TOLERANCE,
        hold: float = 0.0,
        hop: float = 0.25,
        max_rows: int = 1 << 18,
        path: str = "<stream>",
        threads: int = 1,
    ) -> None:
        if method not in ("model", "lowpass", "raw"):
            raise InputError(
                f"method {method!r} cannot run in chunks or streaming (the paper method "
                "filters whole monotonic passes); use model, lowpass or raw"
            )
        if not (math.isfinite(cutoff) and cutoff > 0):
            raise InputError(f"cut-off must be a positive frequency, got {cutoff!r} Hz")
        if not (hop >= 0) or not (max_rows >= 1):
            raise InputError(f"hop must be >= 0 s and max_rows >= 1, got {hop!r}, {max_rows!r}")
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise InputError(f"threads must be a whole number >= 1, got {threads!r}")
        self.model = model
        self.path = path
        self.window = model_window(model) if window is None else float(window)
        self._options: dict[str, Any] = {
            "method": method,
            "cutoff": cutoff,
            "window": self.window,
            "bridge_reversals": bridge_reversals,
            "reversal_band": reversal_band,
            "min_sin_elbow": min_sin_elbow,
            "check_robot": check_robot,
        }
        delay = max((abs(v) for v in identified_delays(model).values()), default=0.0)
        self.margin = settling_time(
            cutoff=cutoff,
            window=self.window,
            bridge_reversals=bridge_reversals,
            method=method,
            delay=delay,
            tolerance=tolerance,
            hold=hold,
        )
        # the filters' support next to a gap, flagged there (as estimate_forces)
        self._support = self.window if method == "raw" else max(self.window, 1.0 / cutoff)
        self.hop = float(hop)
        self.max_rows = int(max_rows)
        nj = len(model.robot.joints)
        self._nj = nj
        self._t = np.empty(0)
        self._q = np.empty((0, nj))
        self._tau = np.empty((0, nj))
        self._parts: list[tuple[NDArray[np.float64], ...]] = []
        self._rows = 0  # rows in the buffer (parts included)
        self._emitted = 0  # buffer rows already answered
        self._t_next: float | None = None  # time of the first row not yet answered
        self._t_last: float | None = None
        self._template: ForceEstimate | None = None
        self._warnings: dict[str, list[Any]] = {}
        self._blocks = 0
        self._finished = False
        # answers are copied out of their block, so that one kept by the caller does not hold
        # the whole block in memory; a caller that writes and drops them turns this off
        self._copy_rows = True
        self.threads = threads
        self._planned = 0  # blocks planned (the first one may be the whole log)
        self._pending: collections.deque[_Job] = collections.deque()
        # answered rows not yet returned, with the call of _drain_groups that planned them
        self._answered: collections.deque[tuple[int, ForceEstimate]] = collections.deque()
        self._calls = 0
        self._pool: ThreadPoolExecutor | None = None
        if threads > 1:
            self._pool = ThreadPoolExecutor(threads, thread_name_prefix="torquemap-block")

    @property
    def latency(self) -> float:
        """Log time [s] from a sample's arrival to its answer, at most (``margin + hop``)."""
        return self.margin + self.hop

    @property
    def buffered(self) -> int:
        """Samples held (the margin behind and the samples not yet answered)."""
        return self._rows

    @property
    def blocks(self) -> int:
        """Blocks estimated so far."""
        return self._blocks

    @property
    def warnings(self) -> tuple[str, ...]:
        """Warnings of the blocks so far, each kind once (with the number of blocks it came
        from when more than one: its numbers are those of the first)."""
        out = []
        for text, count in self._warnings.values():
            out.append(text if count == 1 else f"{text} (in {count} of {self._blocks} blocks)")
        return tuple(out)

    def update(
        self,
        t: ArrayLike,
        q: ArrayLike,
        i: ArrayLike | None = None,
        *,
        motor_torque: ArrayLike | None = None,
    ) -> ForceEstimate:
        """Append samples; return the estimates of those whose filters have settled.

        Parameters
        ----------
        t
            Time [s], shape (m,) or a scalar, not before the previous samples.
        q
            Joint angles [rad], shape (m, n_joints) or (n_joints,).
        i
            Motor currents [A], shaped like ``q`` (times each joint's torque constant).
        motor_torque
            Motor-side torques [N m] instead of ``i``.

        Returns
        -------
        ForceEstimate
            The newly settled samples, in time order (possibly none).
        """
        tt = np.atleast_1d(np.asarray(t, dtype=np.float64))
        if tt.ndim != 1:
            raise InputError(f"t must be one time per sample, got shape {tt.shape}", path=self.path)
        qq = self._rows_of("q", q, tt.size)
        if i is not None and motor_torque is None:
            kt = np.array([j.torque_constant for j in self.model.robot.joints])
            tau = self._rows_of("i", i, tt.size) * kt
        elif motor_torque is not None and i is None:
            tau = self._rows_of("motor_torque", motor_torque, tt.size)
        else:
            raise InputError("give the motor currents i or the motor torques, one of them")
        return self._push(tt, qq, tau)

    def _rows_of(self, name: str, values: ArrayLike, m: int) -> NDArray[np.float64]:
        """``values`` as (m, n_joints); a refusal naming the shapes otherwise."""
        v = np.asarray(values, dtype=np.float64)
        if v.size != m * self._nj or (v.ndim == 2 and v.shape != (m, self._nj)) or v.ndim > 2:
            raise InputError(
                f"{name} has shape {v.shape} for {m} times of {self._nj} joints "
                f"({', '.join(self.model.robot.joint_names)}): give shape ({m}, {self._nj})",
                path=self.path,
            )
        return v.reshape(m, self._nj)

    def update_chunk(self, chunk: LogChunk | Log) -> ForceEstimate:
        """:meth:`update` with a chunk of a log file (:func:`torquemap.io.iter_log_chunks`)."""
        return self._push(chunk.t, chunk.q, chunk.motor_torque)

    def _update_chunk_groups(self, chunk: LogChunk | Log) -> list[ForceEstimate]:
        """:meth:`update_chunk`'s rows as :meth:`_drain_groups` gives them."""
        return self._push_groups(chunk.t, chunk.q, chunk.motor_torque)

    def _finish_groups(self) -> list[ForceEstimate]:
        """:meth:`finish`'s rows as :meth:`_drain_groups` gives them."""
        self._finished = True
        return self._drain_groups(final=True)

    def finish(self) -> ForceEstimate:
        """Estimate every sample not yet answered (the end of the log); the estimator is done.

        Raises
        ------
        InputError
            As :func:`~torquemap.estimate.estimate_forces`, when the whole log is too short.
        """
        self._finished = True
        return self._combine(self._drain_groups(final=True))

    # -- internals ----------------------------------------------------------------------

    def _push(
        self, t: NDArray[np.float64], q: NDArray[np.float64], tau: NDArray[np.float64]
    ) -> ForceEstimate:
        return self._combine(self._push_groups(t, q, tau))

    def _push_groups(
        self, t: NDArray[np.float64], q: NDArray[np.float64], tau: NDArray[np.float64]
    ) -> list[ForceEstimate]:
        if self._finished:
            raise InputError("the estimator has finished: no more samples")
        if t.size == 0:
            return self._drain_groups(final=False)
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q)) and np.all(np.isfinite(tau))):
            raise InputError("samples hold NaN or inf", path=self.path)
        if (self._t_last is not None and t[0] < self._t_last) or np.any(np.diff(t) < 0):
            raise InputError("time goes backwards", path=self.path)
        self._parts.append((t, q, tau))
        self._rows += t.size
        if self._t_next is None:
            self._t_next = float(t[0])
        self._t_last = float(t[-1])
        return self._drain_groups(final=False)

    def _consolidate(self) -> None:
        if self._parts:
            self._t = np.concatenate([self._t, *(p[0] for p in self._parts)])
            self._q = np.concatenate([self._q, *(p[1] for p in self._parts)])
            self._tau = np.concatenate([self._tau, *(p[2] for p in self._parts)])
            self._parts = []

    def _ready(self, final: bool) -> bool:
        if self._t_next is None or self._t_last is None or self._emitted >= self._rows:
            return False
        if final:
            return True
        settled = self._t_last - self.margin
        if settled < self._t_next:
            return False
        return settled - self._t_next >= self.hop or self._rows - self._emitted >= self.max_rows

    def _combine(self, groups: list[ForceEstimate]) -> ForceEstimate:
        if not groups:
            return self._empty()
        if len(groups) == 1:
            return groups[0]
        return _concatenate(groups)

    def _drain_groups(self, *, final: bool) -> list[ForceEstimate]:
        """Answer the blocks now settled; the rows answered, one estimate per call of this
        that planned blocks, in order (a pool's blocks come back in later calls, grouped as
        one thread would have given them: a table written per group is the same file)."""
        self._calls += 1
        while self._ready(final):
            self._consolidate()
            t = self._t
            e0 = self._emitted
            last = float(t[-1])
            if final:
                end = t.size
            else:
                end = int(np.searchsorted(t, last - self.margin, side="right"))
                settled_span = float(t[end - 1] - t[e0]) if end > e0 else -1.0
                if end <= e0 or (settled_span < self.hop and end - e0 < self.max_rows):
                    break
            end = min(end, e0 + self.max_rows)
            lo = int(np.searchsorted(t, t[e0] - self.margin, side="left"))
            hi = t.size if final else int(np.searchsorted(t, t[end - 1] + self.margin, "right"))
            if final and end < t.size:
                hi = int(np.searchsorted(t, t[end - 1] + self.margin, side="right"))
            job = self._plan(lo, hi, e0, end)
            if self._pool is None:
                self._answered.append((job.call, self._answer(job, self._compute(job))))
            else:
                job.result = self._pool.submit(self._compute, job)
                self._pending.append(job)
                while len(self._pending) > self.threads:  # the oldest, once the pool is full
                    self._collect()
            self._emitted = end
            self._t_next = float(t[end]) if end < t.size else None
            # keep what the next block's margin reaches back to
            keep = int(np.searchsorted(t, t[end - 1] - self.margin, side="left"))
            keep = max(keep - 1, 0)  # and the row before it, in case a gap lies between
            self._t, self._q, self._tau = t[keep:], self._q[keep:], self._tau[keep:]
            self._rows -= keep
            self._emitted -= keep
            if final and self._emitted >= self._rows:
                break
        while self._pending and (final or self._done(self._pending[0])):
            self._collect()  # in order: the blocks' answers, warnings and counts
        if final:
            self.close()
        # the calls whose blocks are all answered
        complete = self._pending[0].call if self._pending else self._calls + 1
        groups: list[ForceEstimate] = []
        while self._answered and self._answered[0][0] < complete:
            call = self._answered[0][0]
            parts = []
            while self._answered and self._answered[0][0] == call:
                parts.append(self._answered.popleft()[1])
            groups.append(parts[0] if len(parts) == 1 else _concatenate(parts))
        return groups

    def _plan(self, lo: int, hi: int, a: int, b: int) -> _Job:
        """The block of buffer rows ``lo:hi`` that answers rows ``a:b``, with the gaps just
        outside it (longer than the margin, so the block does not see them) whose rows next
        to them are flagged as the batch flags the filters' support by a gap."""
        t = self._t
        gap = max_gap_for(self.window)
        edges = []
        if lo > 0 and t[lo] - t[lo - 1] > gap:
            edges.append((float(t[lo]), float(t[lo]) + self._support, float(t[lo] - t[lo - 1])))
        if hi < t.size and t[hi] - t[hi - 1] > gap:
            last = float(t[hi - 1])
            edges.append((last - self._support, last, float(t[hi] - t[hi - 1])))
        log = Log(
            t=self._t[lo:hi],
            q=self._q[lo:hi],
            motor_torque=self._tau[lo:hi],
            joint_names=self.model.robot.joint_names,
            path=self.path,
        )
        first = self._planned == 0
        whole = first and lo == 0 and hi == self._rows
        self._planned += 1
        return _Job(
            log=log,
            a=a - lo,
            b=b - lo,
            edges=tuple(edges),
            whole=whole,
            gap=gap,
            call=self._calls,
            first=first,
        )

    def _compute(self, job: _Job) -> ForceEstimate | InputError:
        """The batch estimate of a block (run in the pool's threads when there is one); an
        ``InputError`` is returned, for :meth:`_answer` to judge in the blocks' order."""
        try:
            return estimate_forces(self.model, job.log, **self._options, check_delay=job.first)
        except InputError as exc:
            return exc

    @staticmethod
    def _done(job: _Job) -> bool:
        return job.result is not None and job.result.done()

    def _collect(self) -> None:
        """Answer the oldest pending block (waiting for it)."""
        job = self._pending.popleft()
        assert job.result is not None
        try:
            est = job.result.result()
        except BaseException:
            self.close()
            raise
        self._answered.append((job.call, self._answer(job, est)))

    def _answer(self, job: _Job, est: ForceEstimate | InputError) -> ForceEstimate:
        """A computed block's answered rows; its warnings counted (blocks in their order)."""
        if isinstance(est, InputError):
            if job.whole:
                raise est  # the whole log: as the batch estimator says
            if not est.message.startswith(("no stretch of the log", "log lasts")):
                raise est
            est = _gap_estimate(self.model, job.log, self._template)
        self._blocks += 1
        if self._template is None:
            self._template = _empty_like(est)
        for w in est.warnings:
            key = _NUMBER.sub("#", w)
            if key in self._warnings:
                self._warnings[key][1] += 1
            else:
                self._warnings[key] = [w, 1]
        part = _slice(est, job.a, job.b)
        if self._copy_rows:
            part = _compact(part)
        part = dataclasses.replace(part, warnings=())
        if not job.edges or part.t.size == 0:
            return part
        flag = part.flag.copy()
        for a, b, length in job.edges:
            flag[(part.t >= a) & (part.t <= b)] |= FLAG_GAP
            key = "gap in time"
            if key not in self._warnings:
                self._warnings[key] = [
                    f"gaps in time longer than {job.gap:.3g} s (the first {length:.3g} s): "
                    "the log is processed in pieces between them",
                    1,
                ]
        return dataclasses.replace(part, flag=flag)

    def close(self) -> None:
        """Stop the pool's threads (blocks not yet started are dropped); idempotent."""
        pool, self._pool = self._pool, None
        self._pending.clear()
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)

    def _empty(self) -> ForceEstimate:
        if self._template is not None:
            return self._template
        nj = self._nj
        axes = self.model.robot.arm.wrench_axes
        z = np.empty((0, nj))
        force = np.empty((0, len(axes))) if axes else None
        return ForceEstimate(
            t=np.empty(0),
            joint_names=self.model.robot.joint_names,
            q=z,
            motor_angle=z,
            velocity=z,
            t_est=z,
            filtered=z,
            motor_external=z,
            tau_ext=z,
            force=force,
            flag=np.empty(0, dtype=np.int64),
            passes=tuple(() for _ in range(nj)),
            method=self._options["method"],
            cutoff=float(self._options["cutoff"]),
            wrench_axes=axes if force is not None else (),
            tau_ext_sigma=z,
            force_sigma=force,
            window=self.window,
        )


def _concatenate(parts: list[ForceEstimate]) -> ForceEstimate:
    """Consecutive estimates as one."""
    first = parts[0]
    offsets = np.cumsum([0] + [p.t.size for p in parts])

    def cat(name: str) -> Any:
        values = [getattr(p, name) for p in parts]
        return None if values[0] is None else np.concatenate(values)

    passes = tuple(
        tuple(
            dataclasses.replace(p, start=p.start + int(off), stop=p.stop + int(off))
            for part, off in zip(parts, offsets, strict=False)
            for p in part.passes[k]
        )
        for k in range(len(first.passes))
    )
    return dataclasses.replace(first, **{name: cat(name) for name in _ROW_FIELDS}, passes=passes)


def estimate_in_chunks(
    model: Model,
    chunks: Iterable[LogChunk | Log],
    *,
    method: StreamMethod = "model",
    cutoff: float = 2.0,
    window: float | None = None,
    bridge_reversals: float = 0.5,
    reversal_band: float | Mapping[str, float] | None = None,
    min_sin_elbow: float = 0.05,
    rows: int = 1 << 19,
    tolerance: float = EXACT_TOLERANCE,
    hold: float = 5.0,
    path: str = "<chunks>",
    threads: int = 1,
) -> Iterator[ForceEstimate]:
    """Estimate forces over a log given in chunks, block by block (memory bounded by ``rows``).

    Each block answers ``rows`` samples from the log cut :func:`settling_time` beyond them on
    both sides, so every answer equals :func:`~torquemap.estimate.estimate_forces` on the
    whole log to rounding (module docstring for what is not local). A log of at most ``rows``
    samples is one block: the batch estimate itself.

    Parameters
    ----------
    model
        Identified model.
    chunks
        The log in consecutive pieces (:func:`torquemap.io.iter_log_chunks`, or logs).
    method, cutoff, window, bridge_reversals, reversal_band, min_sin_elbow
        As :func:`~torquemap.estimate.estimate_forces` (``paper`` refused).
    rows
        Samples answered per block.
    tolerance, hold
        :func:`settling_time`: with the defaults, answers equal the batch's to rounding
        except within the low-pass's reach of holds longer than 5 s.
    path
        The log's name, for messages.
    threads
        Blocks estimated at once (:class:`ForceEstimator`): the same answers.

    Yields
    ------
    ForceEstimate
        Consecutive rows, in order; the last one's ``warnings`` hold those of all blocks.
    """
    est = ForceEstimator(
        model,
        method=method,
        cutoff=cutoff,
        window=window,
        bridge_reversals=bridge_reversals,
        reversal_band=reversal_band,
        min_sin_elbow=min_sin_elbow,
        tolerance=tolerance,
        hold=hold,
        hop=math.inf,
        max_rows=rows,
        path=path,
        threads=threads,
    )
    try:
        for chunk in chunks:
            part = est.update_chunk(chunk)
            if part.t.size:
                yield part
        last = est.finish()
    finally:
        est.close()
    yield dataclasses.replace(last, warnings=est.warnings)


@dataclass(frozen=True, slots=True, eq=False)
class StreamSummary:
    """What :func:`estimate_to_file` wrote, for a one-line report.

    Attributes
    ----------
    samples
        Rows written.
    sound
        Rows with flag 0.
    joint_names
        Joint names.
    tau_ext_mean
        Mean of each ``tau_ext_<j>`` over the sound rows [N m], shape (n_joints,) (NaN when
        none).
    force_median
        Median of ``|F|`` over the sound rows [N] (None without an end effector or sound
        rows); from every ``stride``-th sound row.
    stride
        1 when ``force_median`` is exact; else the decimation of the rows it is taken from
        (at most 2**20 values are kept, whatever the log's length).
    warnings
        One line each.
    blocks
        Blocks the log was estimated in.
    stopped
        ``"end"`` (the file ended), or for a followed log ``"timeout"`` or ``"interrupt"``.
    """

    samples: int
    sound: int
    joint_names: tuple[str, ...]
    tau_ext_mean: NDArray[np.float64]
    force_median: float | None
    stride: int
    warnings: tuple[str, ...]
    blocks: int
    stopped: str = "end"


class _Decimated:
    """Every ``stride``-th value of a stream, at most ``cap`` kept (the stride doubles)."""

    def __init__(self, cap: int = 1 << 20) -> None:
        self.cap = cap
        self.stride = 1
        self.seen = 0
        self.parts: list[NDArray[np.float64]] = []
        self.kept = 0

    def add(self, values: NDArray[np.float64]) -> None:
        first = (-self.seen) % self.stride
        self._keep(values[first :: self.stride], values.size)

    def add_hypot(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """:meth:`add` of ``hypot(x, y)``, formed for the kept values only."""
        first = (-self.seen) % self.stride
        step = self.stride
        self._keep(np.hypot(x[first::step], y[first::step]), x.size)

    def _keep(self, part: NDArray[np.float64], size: int) -> None:
        self.parts.append(part)
        self.kept += part.size
        self.seen += size
        while self.kept > self.cap:
            kept = np.concatenate(self.parts)[::2]
            self.parts, self.kept = [kept], kept.size
            self.stride *= 2  # kept: the values whose index is a multiple of the stride

    def median(self) -> float | None:
        if not self.kept:
            return None
        return float(np.median(np.concatenate(self.parts)))


def estimate_to_file(
    model: Model,
    chunks: Iterable[LogChunk | Log],
    output: str | os.PathLike[str],
    *,
    method: StreamMethod = "model",
    cutoff: float = 2.0,
    window: float | None = None,
    reversal_band: float | Mapping[str, float] | None = None,
    rows: int = 1 << 19,
    follow: bool = False,
    path: str = "<chunks>",
    threads: int = 1,
) -> StreamSummary:
    """Estimate forces over a log in chunks and write them as they are answered.

    The table (``.csv`` or ``.parquet``, :func:`torquemap.estimate.forces_columns`) is written
    block by block into a temporary file and appears under ``output`` whole, at the end
    (:func:`torquemap.io.table_stream`). Memory is bounded by ``rows``; the answers are those of
    :func:`estimate_in_chunks`. With ``follow`` the chunks come from a growing log
    (:func:`torquemap.io.follow_log_chunks`): answers are written (and flushed, for CSV) as
    their filters settle, and Ctrl-C ends the log like its end would.

    Parameters
    ----------
    model
        Identified model.
    chunks
        The log in consecutive pieces.
    output
        ``.csv`` or ``.parquet``.
    method, cutoff, window, reversal_band
        As :func:`~torquemap.estimate.estimate_forces` (``paper`` refused).
    rows
        Samples answered per block.
    follow
        The log is growing: answer in small blocks (:class:`ForceEstimator`'s default hop
        and tolerance) instead of ``rows``.
    path
        The log's name, for messages.
    threads
        Blocks estimated at once (:class:`ForceEstimator`): the same table, byte for byte;
        the file is read and written in the caller's thread while the blocks compute.

    Returns
    -------
    StreamSummary
    """
    from torquemap.estimate import forces_columns
    from torquemap.io import table_stream

    estimator = ForceEstimator(
        model,
        method=method,
        cutoff=cutoff,
        window=window,
        reversal_band=reversal_band,
        tolerance=STREAM_TOLERANCE if follow else EXACT_TOLERANCE,
        hold=0.0 if follow else 5.0,
        hop=0.25 if follow else math.inf,
        max_rows=rows,
        path=path,
        threads=threads,
    )
    estimator._copy_rows = False  # each answer is written and dropped at once
    estimator._options["answers_only"] = True  # ``filtered`` is not in the table
    nj = len(model.robot.joints)
    totals = np.zeros(nj)
    counts = {"samples": 0, "sound": 0}
    magnitudes = _Decimated()
    stopped = "end"
    with table_stream(output, flush=follow) as append:

        def write(part: ForceEstimate) -> None:
            if not part.t.size:
                return
            append(forces_columns(part))
            ok = part.flag == 0
            counts["samples"] += part.t.size
            counts["sound"] += int(ok.sum())
            totals[:] += part.tau_ext[ok].sum(axis=0)
            if part.force is not None and part.force.shape[1] >= 2:
                magnitudes.add_hypot(part.force[ok, 0], part.force[ok, 1])

        def write_groups(groups: list[ForceEstimate]) -> None:
            # one table row group each, as one thread gives them; none kept past its writing
            # (an answer holds its whole block's arrays)
            while groups:
                write(groups.pop(0))

        try:
            try:
                for chunk in chunks:
                    write_groups(estimator._update_chunk_groups(chunk))
            except KeyboardInterrupt:
                if not follow:
                    raise
                stopped = "interrupt"
            write_groups(estimator._finish_groups())
        finally:
            estimator.close()
    if follow and stopped == "end":
        stopped = "timeout"
    sound = counts["sound"]
    has_force = bool(model.robot.arm.wrench_axes)
    return StreamSummary(
        samples=counts["samples"],
        sound=sound,
        joint_names=model.robot.joint_names,
        tau_ext_mean=totals / sound if sound else np.full(nj, np.nan),
        force_median=magnitudes.median() if has_force else None,
        stride=magnitudes.stride,
        warnings=estimator.warnings,
        blocks=estimator.blocks,
        stopped=stopped,
    )
