"""One standard deviation of an estimated external torque, from what identification recorded.

A whole-log identification (:mod:`torquemap.identify_whole`) stores, per joint, the names and
covariance of its linear parameters and the low-frequency level of its residual
(``[identification.joints.<j>.uncertainty]``, docs/formats.md). The estimate of the motor torque
that balances the external load is ``T_motor - J acc - f(v) - PDTV(theta)`` through the
low-pass, so its error has three parts, taken as independent:

1. the parameters' error ``G delta`` with ``G`` the regressor row of each sample (acceleration,
   the friction law's basis, the PDTV cosines and sines) through the same low-pass:
   variance ``g^T C g``;
2. the residual noise that passes the low-pass: its low-frequency PSD times the low-pass's
   equivalent noise bandwidth;
3. the sign of friction where the velocity does not tell it (at rest, at a reversal): with
   ``p`` the share of the positive branch at the measured velocity, friction is one branch or
   the other, standard deviation ``sqrt(p (1 - p)) |f+ - f-|`` (half the Coulomb band at rest).
   Neighbouring samples share that error, so it is low-passed as a level, not as noise.

Estimation adds the bridge's departure (:func:`bridge_departure`) and, on a planar arm, the
rigid-body coupling Eq 7 leaves in the answer (:func:`coupling_level`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.filters import lowpass
from torquemap.model import Model

#: Equivalent noise bandwidth of the forward-backward 2nd-order Butterworth low-pass, in units of
#: its cut-off: integral of 1 / (1 + x^4)^2 over x >= 0 = 3 pi / (8 sqrt 2).
LOWPASS_ENB = 3.0 * math.pi / (8.0 * math.sqrt(2.0))
#: Low-pass cut-off [Hz] at which the residual table of a pass-method model is measured.
RESIDUAL_CUTOFF = 2.0
#: Model-form uncertainty of a friction table, as a fraction of its level: what linear
#: interpolation in log speed between knots 1.8x apart and the transition's form leave
#: (tests/test_identify_whole.py: within 2-3 % over the swept speeds).
FORM_FRACTION = 0.0
#: Whether :func:`joint_sigma` propagates the parameters' covariance through estimation's
#: bridge (:func:`bridged_parameter_variance`) rather than bridging the unbridged variance.
BRIDGED_VARIANCE = False
#: Whether :func:`joint_sigma` adds the friction table's leave-one-pass-out interpolation
#: error (:func:`interpolation_sigma`) where the model records it.
INTERPOLATION = False
#: How :func:`joint_sigma` scales the parameters' covariance: ``"off"`` as identified;
#: ``"left-out"``: the friction table's block by :func:`covariance_scale` (its
#: leave-one-pass-out check) at speeds at or above the slowest steady pass, as identified below
#: it. Measured and not kept (stop 34, docs/estimation.md "Sigma calibration (stop 34)").
#: ``"gap"``: the friction block by :func:`gap_covariance_scale`, a factor per sample that
#: depends on the gap between the passes around its speed (stop 34, F41; measured, not kept).
COVARIANCE_CALIBRATION: Literal["off", "left-out", "gap"] = "off"
#: One-sided confidence [-] of the upper bound :func:`gap_scale` takes.
GAP_CONFIDENCE = 0.95
#: Whether :func:`gap_covariance_scale` regresses only the passes left out between two others
#: (not the slowest and fastest of a direction, whose left-out error is an extrapolation's).
GAP_INTERIOR = False
#: The friction law's sigma below the slowest steady pass (stop 42, F55): ``"parameters"``
#: (stop 41's), the parameters' covariance there (the knots below the observed speed hold
#: their prior's variance: random robot 389, 0.78 rad/s, 2.05 N m where the law errs 0.09)
#: plus the table's :func:`extrapolation_spread`; ``"extrapolation"``, the parameters'
#: variance of the law at the slowest pass plus the table's own extrapolation error beyond
#: it, ``c q / 2`` from its leave-one-pass-out curvature ``c``
#: (:func:`interpolation_sigma` below the slowest pass, :func:`below_extrapolation`), where
#: identification recorded one (else as ``"parameters"``). Measured, not the default: against
#: the simulator's true friction below the slowest pass the parameters' sigma holds 90-100 %
#: of the law's errors within 2 sigma on robots 261-280 and 381-400, the extrapolation sigma
#: 46-76 % (a rise towards rest that starts below the slowest pass is seen by no row);
#: dev 381-400 median ratio 2.20x -> 2.02x (389 5.58x -> 1.60x, 392 4.36x -> 15.54x), check
#: 261-280 worst 11.98x -> 30.04x (278); docs/estimation.md, "Stop 42 (F55)".
LAW_BELOW: Literal["parameters", "extrapolation"] = "parameters"
#: The share [-] of a speed table's departure from the chord between the steady passes around
#: each speed (:func:`torquemap.pass_chord.chord_spread`) that :func:`joint_sigma` adds as one
#: standard deviation, a level like the sign term; 0: off (the default). ``1 / sqrt 2``: the
#: RMS error of a table when the truth is the table or the chord alike. Measured, not the
#: default (stop 44, F69; docs/estimation.md "Stop 44 (F69)"): random robot 453 66.9 -> 96.2 %
#: of the force errors within 2 sigma and dev 390 87.5 -> 90.9 %, but held-out 441, 444, 454
#: and 468 leave [90, 99] % upwards (97.9 -> 100.0 % at most) and no held-out robot comes in.
CHORD_SPREAD = 0.0
#: Which chords :func:`torquemap.pass_chord.chord_spread` measures the table against:
#: ``"dry"`` (the dry level's) or ``"both"`` (the larger departure from the dry level's and
#: the whole level's).
CHORD_LEVELS: Literal["dry", "both"] = "dry"
#: Whether estimation widens each joint's sigma by the rigid-body coupling torque its answer
#: leaves in (:func:`coupling_level`, stop 34).
COUPLING = True
#: Speed bins of the residual table (log-spaced between the reversal band and the top speed).
RESIDUAL_BINS = 8
#: Which steady samples :func:`residual_table` measures by default (identification reads it):
#: ``"steady"`` every one; ``"representative"`` only those whose low-pass support holds speeds
#: of their own sign within :data:`REPRESENTATIVE_FACTOR` of theirs
#: (:func:`representative_samples`). Measured and not kept (stop 34, F40,
#: docs/estimation.md "The residual table (F40)").
RESIDUAL_SELECTION: Literal["steady", "representative"] = "steady"
#: Largest ratio [-] of speeds within a representative sample's low-pass support to its own.
REPRESENTATIVE_FACTOR = 2.0
#: Whether estimation counts only the white part of a log's noise beyond the model's
#: (:func:`white_noise_excess`: the smaller of its levels above 20 Hz and above an eighth of
#: the sampling rate) rather than its whole level above 20 Hz (:func:`noise_excess`). Stop 39
#: (Q47): measured, not kept (one robot more inside 90-99 % on each set, but held-out robot
#: 301, already under 90 %, 88.1 -> 85.6 %), docs/estimation.md "Sigma calibration, stop 39".
WHITE_EXCESS = False
#: The upper split [in units of the sampling rate] of :func:`white_noise_excess` (as
#: :func:`torquemap.arm_misfit.upper_split`).
WHITE_SPLIT = 0.125


def joint_uncertainty(model: Model, joint: str) -> Mapping[str, Any] | None:
    """The ``uncertainty`` table of a joint's notes, or None when the model has none."""
    joints = model.notes.get("joints", {})
    entry = joints.get(joint) if isinstance(joints, Mapping) else None
    table = entry.get("uncertainty") if isinstance(entry, Mapping) else None
    if not isinstance(table, Mapping):
        return None
    if table.get("kind") == "residual":
        return table if joint_uncertainty_table_ok(table) else None
    names = table.get("parameters")
    cov = table.get("covariance")
    if not isinstance(names, list) or not isinstance(cov, list):
        return None
    return table


def joint_uncertainty_table_ok(table: Mapping[str, Any]) -> bool:
    """Whether a residual table (:func:`residual_table`) has speeds and levels of one length."""
    speeds, rms = table.get("speeds"), table.get("rms")
    ok = isinstance(speeds, list) and isinstance(rms, list) and len(speeds) == len(rms)
    return bool(ok and speeds)


def regressor_columns(
    names: list[str],
    *,
    law: Any,
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The columns (n, p) of the named linear parameters at each sample (motor side)."""
    n = theta.size
    out = np.zeros((n, len(names)), order="F")  # filled and filtered a column at a time
    basis = law.basis(velocity) if any(s.startswith("friction.") for s in names) else None
    law_names = tuple(getattr(law, "linear_parameter_names", ()))
    pos, neg = velocity > 0, velocity < 0
    for i, name in enumerate(names):
        if name == "inertia.constant":
            out[:, i] = acceleration
        elif name == "inertia.cos_elbow":
            out[:, i] = acceleration * modulation
        elif name.startswith("friction."):
            key = name.split(".", 1)[1]
            if basis is not None and key in law_names:
                out[:, i] = basis[:, law_names.index(key)]
        elif name.startswith("pdtv."):
            body, part = name.rsplit(".", 1)
            order_text, direction = body[len("pdtv.") :].rsplit(".", 1)
            order = float(order_text)
            wave = np.cos(order * theta) if part == "a" else np.sin(order * theta)
            if direction == "positive":
                wave = wave * pos
            elif direction == "negative":
                wave = wave * neg
            out[:, i] = wave
    return out


def parameter_variance(
    names: list[str],
    covariance: NDArray[np.float64],
    *,
    law: Any,
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
    cutoff: float,
    rate: Literal["decimated", "full"] = "decimated",
    phasor: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> NDArray[np.float64]:
    """Variance [N^2 m^2] of the low-passed model torque from the parameters' covariance.

    ``g_i^T C g_i`` per sample, ``g_i`` the low-passed regressor row
    (:func:`regressor_columns` through :func:`torquemap.filters.lowpass`) and ``C``
    (p, p) the covariance of the parameters ``names``. Shape (n,).

    ``rate="decimated"`` (the default) runs the low-pass and the factor's product at a rate
    at least :data:`torquemap.multirate.DECIMATED_RATE` cut-offs (:mod:`torquemap.multirate`)
    where the log is fast enough (an odd factor ``m >= 3`` and enough samples), within
    :data:`torquemap.multirate.VARIANCE_RTOL` of the full rate (7.9e-5 relative at worst on
    the SCARA bench's circle); an irregular log on the grid :func:`torquemap.filters.lowpass`
    resamples it to (:func:`torquemap.multirate.resample_grid`), within the same bound of the
    direct formula; ``"full"`` at every sample. ``phasor``: ``(cos
    theta, sin theta)`` when the caller has them (the same numbers, computed once).

    Notes
    -----
    The low-pass ``L`` acts along time and ``C`` along the parameters, so with a factor
    ``C = W W^T`` (columns ``w_k``)::

        g_i^T C g_i = || W^T g_i ||^2 = sum_k ((L G w_k)_i)^2

    exactly: each combination ``G w_k`` is formed per sample before the low-pass, and the
    forward-backward passes run over all combinations of a sample side by side, keeping only
    the sum of squares (:func:`torquemap._kernels.lowpassed_variance`). ``W`` is lower
    triangular with the dense columns (inertia, PDTV) first and a friction table's (two
    knots per direction and sample) last (:func:`_triangular_factor`), so that a row costs
    a fraction of ``p^2``. Neither the (n, p) regressor, its low-passed copy nor its product
    with ``C`` is formed: one (n, p) array instead of four. At the full rate, equal to
    :func:`parameter_variance_direct` to rounding (1e-10 relative on the SCARA bench's
    model; tests/test_uncertainty.py); the covariance's negative eigenvalues (rounding) are
    taken as zero. On irregular time stamps not decimated (``rate="full"``, a slow or short
    log), a filter other than the order-2 Butterworth or non-finite inputs, the direct
    formula is used.
    """
    signals = {
        "t": t,
        "theta": theta,
        "velocity": velocity,
        "acceleration": acceleration,
        "modulation": modulation,
    }
    fast = _parameter_variance_by_directions(
        names,
        covariance,
        law=law,
        cutoff=cutoff,
        decimate=rate == "decimated",
        phasor=phasor,
        **signals,
    )
    if fast is not None:
        return fast
    return parameter_variance_direct(names, covariance, law=law, cutoff=cutoff, **signals)


def parameter_variance_direct(
    names: list[str],
    covariance: NDArray[np.float64],
    *,
    law: Any,
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
    cutoff: float,
) -> NDArray[np.float64]:
    """:func:`parameter_variance` by its definition: the (n, p) regressor, low-passed column
    by column, and ``g^T C g`` per sample through one matrix product."""
    g = regressor_columns(
        names,
        law=law,
        theta=theta,
        velocity=velocity,
        acceleration=acceleration,
        modulation=modulation,
    )
    if not g.shape[1]:
        return np.zeros(t.size)
    g = lowpass(t, g, cutoff=cutoff)
    return np.asarray(np.sum((g @ covariance) * g, axis=1), dtype=np.float64)


def bridge_columns(
    t: NDArray[np.float64],
    values: NDArray[np.float64],
    gaps: NDArray[np.bool_],
    *,
    support: float = 0.0,
    runs: Sequence[tuple[int, int]] | None = None,
) -> NDArray[np.float64]:
    """:func:`torquemap.estimate.bridge_gaps` (``longest=inf``, ``ends=True``) of every column
    of ``values`` (n, p) at once: each run of ``gaps`` replaced by the straight line between
    the means of the samples within ``support`` [s] before and after it (a run at an end of
    the log holds its one side's mean). Estimation bridges the model torque so over a whole
    fit's reversal band; the torque is linear in the parameters, so its regressor is bridged
    the same way, column by column.

    Examples
    --------
    >>> t = np.arange(6.0)
    >>> gaps = np.array([0, 1, 1, 0, 0, 1], bool)
    >>> x = np.array([[0.0, 9, 9, 3, 4, 9], [1.0, 7, 7, 1, 1, 7]]).T
    >>> bridge_columns(t, x, gaps).T.tolist()
    [[0.0, 1.0, 2.0, 3.0, 4.0, 4.0], [1.0, 1.0, 1.0, 1.0, 1.0, 1.0]]
    """
    from torquemap.estimate import _gap_runs

    out = np.array(values, dtype=np.float64, copy=True)
    if gaps.all():
        return out
    tie = 0.01 * float(t[-1] - t[0]) / max(t.size - 1, 1)
    for a, b in _gap_runs(gaps) if runs is None else runs:
        origin = t[a]
        sides_t: list[float] = []
        sides_v: list[NDArray[np.float64]] = []
        if a > 0:
            a0 = min(int(np.searchsorted(t, t[a - 1] - support - tie, side="left")), a - 1)
            keep = ~gaps[a0:a]
            sides_t.append(float((t[a0:a][keep] - origin).mean()))
            sides_v.append(values[a0:a][keep].mean(axis=0))
        if b < gaps.size:
            b1 = max(int(np.searchsorted(t, t[b] + support + tie, side="right")), b + 1)
            keep = ~gaps[b:b1]
            sides_t.append(float((t[b:b1][keep] - origin).mean()))
            sides_v.append(values[b:b1][keep].mean(axis=0))
        if len(sides_t) == 1:
            out[a:b] = sides_v[0]
            continue
        # np.interp's rule (clamped to the two sides' times), for every column at once
        span = max(sides_t[1] - sides_t[0], 1e-300)
        u = np.clip((t[a:b] - origin - sides_t[0]) / span, 0.0, 1.0)[:, None]
        out[a:b] = (1.0 - u) * sides_v[0] + u * sides_v[1]
    return out


def bridged_parameter_variance(
    names: list[str],
    covariance: NDArray[np.float64],
    *,
    law: Any,
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
    cutoff: float,
    bridged: NDArray[np.bool_],
    support: float = 0.0,
    runs: Sequence[tuple[int, int]] | None = None,
) -> NDArray[np.float64]:
    """Variance [N^2 m^2] of the low-passed model torque from the parameters' covariance when
    estimation bridges the torque over the runs of ``bridged`` before its low-pass (a whole
    fit's reversal band: :func:`torquemap.estimate.estimate_forces`).

    ``g_i^T C g_i`` with ``g_i`` the regressor row bridged as the torque is
    (:func:`bridge_columns`, ``support`` [s] as estimation's) and then low-passed: the exact
    propagation of ``C`` through estimation's linear steps. Without the bridge
    (:func:`parameter_variance`) the low-pass carries the regressor of the bridged samples,
    the friction table's knots below the speeds the logs hold (whose variance is the
    smoothness prior's alone), into the answered samples around them, although the answer
    never uses those knots. Shape (n,).

    Not yet used by :func:`joint_sigma` (docs/identification.md, "The parameters' variance of
    the bridged torque"): on the random family that leaked variance is what covers the
    bridge's own error over long slow stretches, which nothing else models yet.
    """
    g = regressor_columns(
        names,
        law=law,
        theta=theta,
        velocity=velocity,
        acceleration=acceleration,
        modulation=modulation,
    )
    if not g.shape[1]:
        return np.zeros(t.size)
    g = bridge_columns(t, g, bridged, support=support, runs=runs)
    g = lowpass(t, g, cutoff=cutoff)
    return np.asarray(np.sum((g @ covariance) * g, axis=1), dtype=np.float64)


def _parameter_variance_by_directions(
    names: list[str],
    covariance: NDArray[np.float64],
    *,
    law: Any,
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
    cutoff: float,
    decimate: bool,
    phasor: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> NDArray[np.float64] | None:
    """:func:`parameter_variance` by a triangular factor of the covariance (compiled
    kernels), or None where that does not apply (irregular time at the full rate, an invalid
    cut-off: the direct formula handles or refuses those)."""
    from torquemap import multirate
    from torquemap._kernels import decimated_variance, lowpassed_variance, max_abs
    from torquemap.filters import _butter_lowpass, _initial_state, regular_step
    from torquemap.friction_law import SpeedTableFriction

    n, p = t.size, len(names)
    if p == 0:
        return np.zeros(n)
    step = regular_step(t, rtol=1e-6) if n >= 2 else None
    grid: tuple[NDArray[Any], ...] = (np.empty(0, dtype=np.int64), np.empty(0))
    resampled = None
    if step is None and decimate and n >= 3:
        resampled = multirate.resample_grid(t)
        if resampled is not None:
            step, grid = resampled.step, (resampled.index, resampled.weight)
    if step is None or not (0 < cutoff < 0.5 / step):
        return None
    if not all(
        math.isfinite(max_abs(np.ascontiguousarray(x, dtype=np.float64)))
        for x in (theta, velocity, acceleration, modulation)
    ):
        return None  # the direct formula's low-pass refuses them
    sos, pad = _butter_lowpass(2, float(cutoff), 1.0 / step)
    size = grid[0].size if grid[0].size else n  # the samples the filter runs over
    if sos.shape[0] != 1 or size <= pad:
        return None
    m = multirate.decimation_factor(step, cutoff) if decimate else 1
    decimated = m >= 3 and pad <= 2 * m and (size - 3 * m) // m + 1 >= multirate.MIN_DECIMATED
    if grid[0].size and not decimated:
        return None  # irregular and not decimated: the direct formula
    directions, reach = _triangular_factor_cached(
        np.ascontiguousarray(covariance, dtype=np.float64).tobytes(), tuple(names)
    )
    index = {name: i for i, name in enumerate(names)}
    table = isinstance(law, SpeedTableFriction)
    law_names = tuple(getattr(law, "linear_parameter_names", ()))
    dense: list[NDArray[np.float64]] = []
    dense_index: list[int] = []
    if "inertia.constant" in index:
        dense.append(acceleration)
        dense_index.append(index["inertia.constant"])
    if "inertia.cos_elbow" in index:
        dense.append(acceleration * modulation)
        dense_index.append(index["inertia.cos_elbow"])
    friction = [
        (i, name.split(".", 1)[1]) for i, name in enumerate(names) if name.startswith("friction.")
    ]
    friction = [(i, key) for i, key in friction if key in law_names]
    if friction and not table:
        basis = law.basis(velocity)
        for i, key in friction:
            dense.append(basis[:, law_names.index(key)])
            dense_index.append(i)
    knots = np.log(np.asarray(law.speeds, dtype=np.float64)) if table and friction else np.empty(0)
    knot_positive = np.full(knots.size, -1, dtype=np.int64)
    knot_negative = np.full(knots.size, -1, dtype=np.int64)
    viscous = viscous_negative = -1
    if table and friction:
        for i, key in friction:
            if key.startswith("positive_"):
                knot_positive[int(key[len("positive_") :])] = i
            elif key.startswith("negative_"):
                knot_negative[int(key[len("negative_") :])] = i
            elif key == "viscous":
                viscous = i
            elif key == "viscous_negative":
                viscous_negative = i
    lines: dict[tuple[float, int], list[int]] = {}
    for i, name in enumerate(names):
        if not name.startswith("pdtv."):
            continue
        body, part = name.rsplit(".", 1)
        order_text, direction = body[len("pdtv.") :].rsplit(".", 1)
        sign = {"positive": 1, "negative": -1}.get(direction, 0)
        slot = lines.setdefault((float(order_text), sign), [-1, -1])
        slot[0 if part == "a" else 1] = i
    orders = np.array([order for order, _ in lines], dtype=np.float64)
    powers = np.array(
        [int(o) if o == math.floor(o) and 0 <= o <= 1 << 20 else -1 for o in orders],
        dtype=np.int64,
    )
    spec = (
        np.ascontiguousarray(np.array(dense, dtype=np.float64).reshape(len(dense), n)),
        np.array(dense_index, dtype=np.int64),
        np.ascontiguousarray(theta, dtype=np.float64),
        np.ascontiguousarray(velocity, dtype=np.float64),
        orders,
        powers,
        np.array([slot[0] for slot in lines.values()], dtype=np.int64),
        np.array([slot[1] for slot in lines.values()], dtype=np.int64),
        np.array([sign for _, sign in lines], dtype=np.int64),
        knots,
        knot_positive,
        knot_negative,
        viscous,
        viscous_negative,
        float(getattr(law, "zero_velocity", 1.0)),
        directions.copy(),  # writable: the kernels are compiled for one signature
        reach.copy(),
        *(
            (np.empty(0), np.empty(0))
            if phasor is None or not lines
            else (np.ascontiguousarray(phasor[0]), np.ascontiguousarray(phasor[1]))
        ),
    )
    zi = _initial_state(sos.tobytes())
    if decimated:
        plan = multirate.multirate_plan(sos.tobytes(), m)
        var, steps = decimated_variance(spec, np.ones(p), sos.copy(), zi.copy(), pad, plan, grid)
        if resampled is not None:
            var = multirate.variance_at(t, resampled.times, var, steps)
    else:
        var = lowpassed_variance(spec, np.ones(p), sos.copy(), zi.copy(), pad)
    return np.asarray(var, dtype=np.float64)


@functools.lru_cache(maxsize=16)
def _triangular_factor_cached(
    covariance: bytes, names: tuple[str, ...]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """:func:`_triangular_factor` once per joint's covariance (every piece of every block
    asks for the same one); the arrays are read-only."""
    p = len(names)
    directions, reach = _triangular_factor(np.frombuffer(covariance).reshape(p, p), list(names))
    directions.setflags(write=False)
    reach.setflags(write=False)
    return directions, reach


def _triangular_factor(
    covariance: NDArray[np.float64], names: list[str]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """``W`` (p, p) with ``W W^T = C`` (the covariance's negative eigenvalues, rounding,
    taken as 0), lower triangular in an order of the parameters with the friction's last, and
    per row the number of its leading nonzero columns.

    A regressor row is dense in the inertia and PDTV columns and sparse in a friction
    table's (two knots per direction): with those first, a dense column touches only the
    first few columns of ``W`` and ``g^T W`` costs a fraction of a full product.
    """
    p = len(names)
    order = sorted(range(p), key=lambda i: names[i].startswith("friction."))
    cov = covariance[np.ix_(order, order)]
    cov = 0.5 * (cov + cov.T)
    scale = np.sqrt(np.abs(np.diag(cov)))
    scale[scale == 0] = 1.0
    # C = D R D with R the correlation: R = B B^T, B = V sqrt(s), then B^T = Q T (QR) gives
    # R = T^T T with T upper triangular
    values, vectors = np.linalg.eigh(cov / np.outer(scale, scale))
    root = vectors * np.sqrt(np.maximum(values, 0.0))
    upper = np.linalg.qr(root.T).R
    factor = scale[:, None] * upper.T
    directions = np.empty((p, p))
    reach = np.empty(p, dtype=np.int64)
    for position, i in enumerate(order):
        directions[i] = factor[position]
        reach[i] = position + 1
    return directions, reach


def sign_sigma(law: Any, velocity: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    """Standard deviation [N m] of friction from not knowing the sign of motion.

    ``sqrt(p (1 - p)) |f+ - f-|`` with ``p = (1 + tanh(v / width)) / 2``: half the band between
    the two branches at rest, vanishing once the velocity is well above ``width``.

    Examples
    --------
    >>> from torquemap.friction_law import StribeckFriction
    >>> f = StribeckFriction(coulomb_positive=0.04, coulomb_negative=0.06)
    >>> sign_sigma(f, np.array([0.0, 1.0]), 0.01).round(6).tolist()
    [0.05, 0.0]
    """
    v = np.asarray(velocity, dtype=np.float64)
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    levels = getattr(law, "levels", None)
    if callable(levels):  # a law that gives its levels per speed (a table)
        g_up, g_down = levels(np.abs(v))
        return np.asarray(np.sqrt(p * (1.0 - p)) * np.abs(g_up + g_down), dtype=np.float64)
    up, down = law.static_levels()
    shape = np.ones_like(v)
    vs = getattr(law, "stribeck_velocity", None)
    ex = getattr(law, "stribeck_exponent", 2.0)
    cp, cn = getattr(law, "coulomb_positive", up), getattr(law, "coulomb_negative", down)
    if vs is not None:
        shape = np.exp(-((np.abs(v) / vs) ** ex))
        band = cp + cn + (up - cp + down - cn) * shape
    else:
        band = (up + down) * shape
    return np.asarray(np.sqrt(p * (1.0 - p)) * np.abs(band), dtype=np.float64)


def sliding_width(model: Model, joint: str) -> float:
    """Half width [rad/s] of the joint's friction transition through zero: its law's, or the
    velocity resolution identification measured when larger."""
    joints = model.notes.get("joints", {})
    entry = joints.get(joint, {}) if isinstance(joints, Mapping) else {}
    resolution = float(entry.get("velocity_resolution", 0.0)) if isinstance(entry, Mapping) else 0.0
    law = model.joints[joint].friction
    return max(float(getattr(law, "zero_velocity", 0.0)), resolution, 1e-9)


def noise_level(
    model: Model,
    joint: str,
    *,
    t: NDArray[np.float64],
    residual: NDArray[np.float64],
    velocity: NDArray[np.float64],
    step: float | None = None,
) -> float:
    """White-noise PSD [N^2 m^2/Hz] above the estimate's band of ``residual`` (the motor
    torque less the model's inertia, friction and PDTV on a log):
    :func:`torquemap.noise_level.high_band_psd` on the samples sliding faster than 4
    transition widths. Identification records it for its logs (``noise_high_psd``),
    estimation measures it on the log it is given (:func:`noise_excess`). ``step``: the
    median of ``diff(t)`` when the caller has it."""
    from torquemap.noise_level import high_band_psd

    use = np.abs(velocity) > 4.0 * sliding_width(model, joint)
    return high_band_psd(t, residual, use, step=step)


def _recorded_noise(model: Model, joint: str) -> float:
    """The joint's ``noise_high_psd`` [N^2 m^2/Hz] identification recorded; NaN if none."""
    table = joint_uncertainty(model, joint)
    return float(table.get("noise_high_psd", math.nan)) if table is not None else math.nan


def noise_excess(
    model: Model,
    joint: str,
    *,
    t: NDArray[np.float64],
    residual: NDArray[np.float64],
    velocity: NDArray[np.float64],
    step: float | None = None,
) -> float:
    """White-noise PSD [N^2 m^2/Hz] of ``residual`` above the model's own (:func:`noise_level`
    on this log less the recorded ``noise_high_psd``); 0 when the model records no level or
    this log's cannot be measured (too slow, too short), or when it is not higher."""
    own = _recorded_noise(model, joint)
    if not math.isfinite(own):
        return 0.0
    level = noise_level(model, joint, t=t, residual=residual, velocity=velocity, step=step)
    return max(level - own, 0.0) if math.isfinite(level) else 0.0


def white_noise_excess(
    model: Model,
    joint: str,
    *,
    t: NDArray[np.float64],
    residual: NDArray[np.float64],
    velocity: NDArray[np.float64],
    step: float | None = None,
) -> float:
    """White-noise PSD [N^2 m^2/Hz] of ``residual`` above the model's own, counting only what
    is white: :func:`noise_excess` with this log's level taken as the smaller of its levels
    above :data:`torquemap.noise_level.HIGH_BAND_SPLIT` (20 Hz) and above :data:`WHITE_SPLIT`
    times the sampling rate (:func:`torquemap.noise_level.high_band_psd` on the same sliding
    samples).

    The excess widens the sigma through the estimate's band (a few Hz) as if it were white,
    which holds for the noise a slower logger folds into every band (the same level above
    both splits). Content between 20 Hz and an eighth of the rate only (a resonance, a
    controller's oscillation, the task's own ripple) stays above the estimate's band, which
    the low-pass removes: the level above the upper split does not hold it. A log slower than
    8 times 20 Hz has no upper band above 20 Hz: its 20 Hz level stands (as
    :func:`noise_excess`)."""
    from torquemap.noise_level import HIGH_BAND_SPLIT, high_band_psd

    own = _recorded_noise(model, joint)
    if not math.isfinite(own):
        return 0.0
    level = noise_level(model, joint, t=t, residual=residual, velocity=velocity, step=step)
    if not math.isfinite(level) or level <= own:
        return 0.0
    if t.size > 1:
        dt = float(np.median(np.diff(t))) if step is None else step
        upper = WHITE_SPLIT / dt if dt > 0 else 0.0
        if upper > HIGH_BAND_SPLIT:
            use = np.abs(velocity) > 4.0 * sliding_width(model, joint)
            high = high_band_psd(t, residual, use, split=upper, step=dt)
            if math.isfinite(high):
                level = min(level, high)
    return max(level - own, 0.0)


def model_tones(model: Model, joint: str) -> tuple[Any, ...]:
    """The fixed-frequency lines identification found in a joint's torque residual
    (``uncertainty.tones``: ``[frequency Hz, amplitude N m]`` pairs, motor side) as
    :class:`torquemap.tones.Tone`; empty when the model records none."""
    from torquemap.tones import Tone

    table = joint_uncertainty(model, joint)
    raw = table.get("tones") if table is not None else None
    out = []
    for pair in raw if isinstance(raw, list) else []:
        if isinstance(pair, list) and len(pair) == 2:
            f, a = pair
            if all(isinstance(v, int | float) and math.isfinite(v) for v in (f, a)):
                if f > 0 and a > 0:
                    out.append(Tone(frequency=float(f), amplitude=float(a)))
    return tuple(out)


def joint_sigma(
    model: Model,
    joint: str,
    *,
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
    cutoff: float,
    bridged: NDArray[np.bool_] | None = None,
    phasor: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    extra_psd: float = 0.0,
    support: float = 0.0,
    terms: dict[str, Any] | None = None,
) -> NDArray[np.float64]:
    """One standard deviation [N m, motor side] of a joint's external-torque estimate.

    ``bridged`` marks the samples whose answer is bridged over (estimation's reversal band):
    there friction's sign is taken as unknown (half the band between the two branches).
    ``phasor``: ``(cos theta, sin theta)`` when the caller has them.
    ``extra_psd`` [N^2 m^2/Hz]: white noise this log holds beyond the identification logs'
    (:func:`noise_excess`), added to the model's residual PSD.
    ``support`` [s]: the window either side of a bridged run whose mean estimation's bridge
    takes (:func:`torquemap.estimate.bridge_gaps`), for the parameters' variance bridged as
    the torque is (:func:`bridged_parameter_variance`, :data:`BRIDGED_VARIANCE`).
    ``terms``: the terms that do not depend on ``bridged`` (the parameters' variance where it
    is not bridged, the table's levels), kept in it by a call with an empty dict and taken
    from it by a later call with the same arguments but ``bridged`` (the same numbers).

    NaN everywhere when the model holds no uncertainty for the joint (a model identified by
    the pass method, or written by hand).
    """
    table = joint_uncertainty(model, joint)
    n = t.size
    if table is None:
        return np.full(n, np.nan)
    law = model.joints[joint].friction
    if table.get("kind") == "residual":
        return _residual_sigma(
            table, law, t=t, velocity=velocity, cutoff=cutoff, acceleration=acceleration
        )
    names = [str(x) for x in table["parameters"]]
    cov = np.asarray(table["covariance"], dtype=np.float64)
    if cov.shape != (len(names), len(names)) or not np.all(np.isfinite(cov)):
        raise InputError(f"[identification.joints.{joint}.uncertainty] covariance is malformed")
    joints = model.notes.get("joints", {})
    entry = joints.get(joint, {}) if isinstance(joints, Mapping) else {}
    full_cov = cov
    if COVARIANCE_CALIBRATION == "left-out":
        scale = math.sqrt(covariance_scale(table))
        d = np.array([scale if x.startswith("friction.") else 1.0 for x in names])
        cov = cov * np.outer(d, d)
    from torquemap.estimate import _gap_runs, bridge_gaps

    # the regressor's inputs, the same for every propagation of a covariance below
    kw: dict[str, Any] = dict(
        law=law,
        t=t,
        theta=theta,
        velocity=velocity,
        acceleration=acceleration,
        modulation=modulation,
        cutoff=cutoff,
    )
    runs = _gap_runs(bridged) if bridged is not None else []
    exact = BRIDGED_VARIANCE and bool(runs)
    below_sd: NDArray[np.float64] | None = None
    if exact:
        # the answer is the torque bridged over the runs, then low-passed: so is the regressor
        # (the knots only the prior holds below the bridged speeds never reach an answer)
        assert bridged is not None
        var = bridged_parameter_variance(
            names, cov, bridged=bridged, support=support, runs=runs, **kw
        )
    elif terms is not None and "var" in terms:
        var = terms["var"]
        below_sd = terms.get("below_sd")
    else:
        var = parameter_variance(names, cov, phasor=phasor, **kw)
        slowest = _slowest(entry)
        if LAW_BELOW == "extrapolation":
            from torquemap.estimate import TRANSITION_SPAN

            w = sliding_width(model, joint)
            below_sd = below_extrapolation(
                table, entry, velocity=velocity, width=w, floor=TRANSITION_SPAN * w
            )
            below = np.abs(velocity) < slowest
            if below_sd is not None and below.any():
                # the law's parameters read at the slowest pass (where the rows fit them), its
                # form beyond it by the table's own leave-one-pass-out curvature
                at = np.where(below, np.where(velocity < 0, -slowest, slowest), velocity)
                var = parameter_variance(names, cov, phasor=phasor, **{**kw, "velocity": at})
            else:
                below_sd = None
        if COVARIANCE_CALIBRATION == "gap":
            var = _gap_scaled_variance(
                var,
                table,
                entry,
                names,
                cov,
                phasor=phasor,
                width=sliding_width(model, joint),
                **kw,
            )
        if cov is not full_cov and slowest > 0:
            # below the slowest pass the table is extrapolated: leaving passes out does not
            # check it, so the identified covariance stands there
            below = np.abs(velocity) < slowest
            if below.any():
                full = parameter_variance(names, full_cov, phasor=phasor, **kw)
                share = np.clip(lowpass(t, below.astype(np.float64), cutoff=cutoff), 0.0, 1.0)
                var = share * full + (1.0 - share) * var
        if terms is not None:
            terms["var"] = var
            terms["below_sd"] = below_sd
    psd = float(table.get("residual_psd", 0.0))
    extra = extra_psd if math.isfinite(extra_psd) and extra_psd > 0 else 0.0
    noise = np.full(n, (max(psd, 0.0) + extra) * LOWPASS_ENB * cutoff)
    measured = table.get("residual")
    if not (isinstance(measured, Mapping) and joint_uncertainty_table_ok(measured)):
        measured = None
    width = sliding_width(model, joint)
    misfit_level = None
    # the table's extrapolation spread, unless the extrapolation sigma stands for it
    spread_from = _slowest(entry) if below_sd is None else 0.0
    # the fused levels are shared between a piece's two estimates (E56), keyed by the speed
    # their extrapolation spread starts from (the extrapolation option sets it to 0)
    fused_key = f"fused@{spread_from!r}"
    if terms is not None and fused_key in terms:
        fused = terms[fused_key]
    else:
        fused = _table_levels(
            law,
            measured,
            t=t,
            velocity=velocity,
            cutoff=cutoff,
            width=width,
            slowest=spread_from,
            acceleration=acceleration,
        )
        if terms is not None:
            terms[fused_key] = fused
    if fused is not None:
        # misfit and sign levels side by side, as the low-pass below takes them
        level = fused[:, -1]
        if measured is not None:
            misfit_level = fused[:, 0]
    elif measured is not None:
        # what the model left on its own no-load logs at each speed (model-form error and
        # noise together, measured): the larger of it and the noise alone (low-passed below,
        # with the sign's level)
        misfit_level = _residual_level(
            measured, t=t, velocity=velocity, cutoff=cutoff, acceleration=acceleration
        )
    if fused is None:
        if callable(getattr(law, "levels", None)):
            level, spread, (up, down) = _table_sign_terms(law, velocity, width, spread_from)
            if FORM_FRACTION > 0:  # hypot(level, 0) is level: skip the pass
                # the table's own form error between and beyond its knots: FORM_FRACTION of
                # the level
                level = np.hypot(level, FORM_FRACTION * 0.5 * (np.abs(up) + np.abs(down)))
            level = np.hypot(level, spread)
        else:
            level = sign_sigma(law, velocity, width)
    form = _interpolation_level(table, entry, velocity=velocity, width=width)
    if form is not None:
        # the table's interpolation between its passes, measured by leaving each out
        level = np.hypot(level, form)
    chord = _chord_level(law, entry, velocity=velocity, width=width)
    if chord is not None:
        # the table's departure from the chord between the passes around the speed
        level = np.hypot(level, chord)
    if runs:
        # a bridged sample's answer is the line between its run's ends: friction does not
        # enter it, so neither do its sign nor the law's parameters; its variance is the line
        # between the ends' variances (the load's departure from a line is added by estimation)
        assert bridged is not None
        level = bridge_gaps(t, level, bridged, longest=math.inf, ends=True, runs=runs)
    if fused is not None and (runs or form is not None or chord is not None):
        if terms is not None:
            fused = fused.copy()  # the kept levels stay as they were
        fused[:, -1] = level
    if misfit_level is None:
        sign = lowpass(t, level, cutoff=cutoff)
    else:  # one call: the filter runs four signals side by side, one costs as much as two
        stacked = fused if fused is not None else np.column_stack((misfit_level, level))
        both = lowpass(t, stacked, cutoff=cutoff)
        noise = np.maximum(noise, np.maximum(both[:, 0], 0.0) ** 2)
        sign = both[:, 1]
    var = np.maximum(var, 0.0)
    if below_sd is not None:
        var = var + np.maximum(lowpass(t, below_sd, cutoff=cutoff), 0.0) ** 2
    if runs:
        # the exact propagation is already the bridged answer's; the rest is bridged here
        assert bridged is not None
        noise = bridge_gaps(t, noise, bridged, longest=math.inf, ends=True, runs=runs)
        if not exact:
            var = bridge_gaps(t, var, bridged, longest=math.inf, ends=True, runs=runs)
    var = var + noise
    out: NDArray[np.float64] = np.sqrt(var + np.maximum(sign, 0.0) ** 2)
    if not math.isfinite(float(np.max(out, initial=0.0))):
        out = np.where(np.isfinite(out), out, np.nan)
    return out


def covariance_scale(table: Mapping[str, Any], *, bound: bool = True) -> float:
    """Variance factor [-] for a joint's parameter covariance from its leave-one-pass-out
    record: ``mean(z^2)`` of the left-out errors over the left-out fits' posterior sd
    (``uncertainty.interpolation``: ``errors``, ``sigmas``), with ``bound`` its one-sided 95 %
    upper bound ``n mean(z^2) / chi2_0.05(n)``; at most 1 (never wider than identified);
    1 when the record has fewer than 2 usable passes."""
    record = table.get("interpolation")
    if not isinstance(record, Mapping):
        return 1.0
    errors = np.asarray(record.get("errors", []), dtype=np.float64)
    sds = np.asarray(record.get("sigmas", []), dtype=np.float64)
    if errors.shape != sds.shape:
        return 1.0
    use = np.isfinite(errors) & np.isfinite(sds) & (sds > 0)
    n = int(use.sum())
    if n < 2:
        return 1.0
    ratio = float(np.mean((errors[use] / sds[use]) ** 2))
    if bound:
        from scipy.stats import chi2

        ratio = ratio * n / float(chi2.ppf(0.05, n))
    return min(1.0, ratio)


#: Mean and variance of ``log z^2`` for a standard normal ``z``: ``psi(1/2) + log 2`` and
#: ``psi'(1/2) = pi^2 / 2``.
LOG_CHI2_MEAN = -1.2703628454614782
LOG_CHI2_VAR = math.pi**2 / 2.0


def gap_scale(
    gaps: NDArray[np.float64],
    z: NDArray[np.float64],
    at: NDArray[np.float64],
    *,
    confidence: float = 0.95,
) -> NDArray[np.float64]:
    """Variance factor [-] of a covariance at the gaps ``at`` from leave-one-out z-scores
    ``z`` (error over the left-out fit's own posterior sd) measured at the gaps ``gaps``
    (``q = |x - x_a| |x - x_b|`` in log speed, :func:`torquemap.identify_whole.interpolation_gap`).

    The factor's growth with the gap is a power law, ``E z^2 = exp(a + b log q)``: ``log z^2``
    less its mean under a normal ``z`` (:data:`LOG_CHI2_MEAN`) is regressed on ``log q`` by
    least squares, and at each ``at`` the factor is the one-sided ``confidence`` upper bound
    of the prediction with the log-chi-square's known variance (:data:`LOG_CHI2_VAR`),
    ``exp(a + b u + k_c sqrt(var (1/n + (u - mean u)^2 / S_uu)))``, at most 1 (never wider
    than identified). 1 where the bound exceeds 1, at a gap of 0 (at a pass), with fewer than
    3 usable points or gaps that do not vary (the slope unknown): few points, or a gap far
    from the measured ones, give no shrinkage.

    Examples
    --------
    >>> q = np.array([1.0, 1.0, 4.0, 4.0])
    >>> gap_scale(q, np.array([0.1, -0.1, 0.2, 0.2]), np.array([0.0, 2.0]), confidence=0.5)
    array([1.       , 0.0712429])
    """
    from scipy.stats import norm

    g = np.asarray(gaps, dtype=np.float64)
    zz = np.asarray(z, dtype=np.float64)
    out_at = np.asarray(at, dtype=np.float64)
    out = np.ones(out_at.shape)
    use = np.isfinite(g) & np.isfinite(zz) & (g > 0) & (zz != 0)
    n = int(use.sum())
    if n < 3:
        return out
    u = np.log(g[use])
    y = np.log(zz[use] ** 2) - LOG_CHI2_MEAN
    ubar = float(u.mean())
    suu = float(np.sum((u - ubar) ** 2))
    if not suu > 1e-12 * n:
        return out
    slope = float(np.sum((u - ubar) * (y - y.mean())) / suu)
    level = float(y.mean())
    k = float(norm.ppf(confidence))
    fine = np.isfinite(out_at) & (out_at > 0)
    x = np.log(out_at[fine])
    spread = np.sqrt(LOG_CHI2_VAR * (1.0 / n + (x - ubar) ** 2 / suu))
    upper = level + slope * (x - ubar) + k * spread
    out[fine] = np.exp(np.minimum(upper, 0.0))
    return out


def gap_covariance_scale(
    table: Mapping[str, Any],
    entry: Any,
    velocity: NDArray[np.float64],
    width: float,
    *,
    confidence: float = 0.95,
) -> NDArray[np.float64] | None:
    """Per-sample variance factor [-] of a joint's friction covariance from its
    leave-one-pass-out record (``uncertainty.interpolation``: ``gaps``, ``errors``,
    ``sigmas``): :func:`gap_scale` at the gap ``q`` between the joint's passes of each direction
    around the sample's speed (zero at a pass), each direction weighted by its share
    ``(1 + tanh(v / width)) / 2``; 1 below the slowest pass (extrapolated: leaving passes out
    does not check it). None when the record or the passes are missing."""
    from torquemap.identify_whole import interpolation_gaps

    record = table.get("interpolation")
    speeds = entry.get("speeds") if isinstance(entry, Mapping) else None
    if not (isinstance(record, Mapping) and isinstance(speeds, list)):
        return None
    gaps = np.asarray(record.get("gaps", []), dtype=np.float64)
    errors = np.asarray(record.get("errors", []), dtype=np.float64)
    sds = np.asarray(record.get("sigmas", []), dtype=np.float64)
    if not (gaps.shape == errors.shape == sds.shape) or gaps.size < 3:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(sds > 0, errors / sds, np.nan)
    passes = [float(x) for x in speeds if isinstance(x, int | float) and math.isfinite(x)]
    if not passes:
        return None
    held = np.asarray(record.get("speeds", []), dtype=np.float64)
    if GAP_INTERIOR and held.shape == gaps.shape:
        # a left-out pass between two of its direction's others: an interpolation
        inner = np.array(
            [
                min(abs(y) for y in held if y * s > 0)
                < abs(s)
                < max(abs(y) for y in held if y * s > 0)
                for s in held
            ],
            dtype=bool,
        )
        z = np.where(inner, z, np.nan)
    v = np.asarray(velocity, dtype=np.float64)
    x = np.log(np.maximum(np.abs(v), 1e-300))
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    out = np.zeros(v.shape)
    for sign, share in ((1, p), (-1, 1.0 - p)):
        anchors = sorted(math.log(abs(s)) for s in passes if s * sign > 0)
        if not anchors:
            anchors = sorted(math.log(abs(s)) for s in passes if s != 0)
        q = interpolation_gaps(x, anchors)
        factor = gap_scale(gaps, z, q, confidence=confidence)
        factor = np.where(x < anchors[0], 1.0, factor)
        out += share * factor
    return np.clip(out, 0.0, 1.0)


def _gap_scaled_variance(
    var: NDArray[np.float64],
    table: Mapping[str, Any],
    entry: Any,
    names: list[str],
    cov: NDArray[np.float64],
    *,
    width: float,
    **kw: Any,
) -> NDArray[np.float64]:
    """``var`` (the parameters' variance with ``cov``) with the friction block scaled by
    :func:`gap_covariance_scale`, low-passed like the estimate: the variance is
    ``k A + 2 sqrt(k) B + C`` in the block's factor ``k`` (``A`` the friction block's part,
    ``B`` the cross terms', ``C`` the rest), from the variances with the block's sd scaled by
    1, 0 and -1. ``var`` itself where every factor is 1."""
    factor = gap_covariance_scale(table, entry, kw["velocity"], width, confidence=GAP_CONFIDENCE)
    if factor is None or bool(np.all(factor >= 1.0)):
        return var
    k = np.clip(lowpass(kw["t"], factor, cutoff=kw["cutoff"]), 0.0, 1.0)
    d = np.array([1.0 if x.startswith("friction.") else 0.0 for x in names])
    rest = parameter_variance(names, cov * np.outer(1.0 - d, 1.0 - d), **kw)
    flipped = parameter_variance(names, cov * np.outer(1.0 - 2.0 * d, 1.0 - 2.0 * d), **kw)
    block = 0.5 * (var + flipped) - rest
    cross = 0.25 * (var - flipped)
    return np.asarray(k * block + 2.0 * np.sqrt(k) * cross + rest, dtype=np.float64)


def coupling_level(
    model: Model,
    *,
    t: NDArray[np.float64],
    q: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    cutoff: float,
) -> NDArray[np.float64] | None:
    """Magnitude [N m, motor side] of the rigid-body coupling torque a planar arm's estimate
    leaves in its answer, low-passed like the estimate; shape (n, 2). None for another arm or
    when the model knows no coupling.

    Eq 7 takes each joint's own inertia only (the first joint's with its ``cos q2``
    modulation); the planar two-link arm's other terms (:mod:`torquemap.robots.planar2r`)::

        c_1 = a2 (cos q2 qdd2 - sin q2 (2 qd1 qd2 + qd2^2)) + a3 qdd2
        c_2 = a2 (cos q2 qdd1 + sin q2 qd1^2) + a3 qdd1

    are part of the error. ``a2`` and ``a3`` [kg m^2] are the arm's base parameters when the
    robot file gives them; otherwise ``a2 = n_1^2 cos_elbow / 2`` from the first joint's
    identified inertia modulation (its ``2 a2 cos q2``, motor side) and ``a3 = 0`` (the
    second link's own inertia cannot be told from the second rotor's in single-joint sweeps:
    the term is then what the model knows, a lower estimate). ``velocity`` and
    ``acceleration`` [rad/s, rad/s^2, motor side] (n, 2) are the estimator's own; ``q``
    [rad] the joint angles (n, 2).
    """
    arm = model.robot.arm
    if getattr(arm, "kind", None) != "planar2r" or velocity.shape[1] != 2:
        return None
    gears = np.array([j.gear_ratio for j in model.robot.joints], dtype=np.float64)
    given = tuple(float(x) for x in getattr(arm, "base_parameters", (0.0, 0.0, 0.0)))
    if any(given):
        a2, a3 = given[1], given[2]
    else:
        first = model.joints[model.robot.joints[0].name].inertia
        a2, a3 = 0.5 * gears[0] ** 2 * float(first.cos_elbow), 0.0
    if not (math.isfinite(a2) and math.isfinite(a3)) or (a2 == 0.0 and a3 == 0.0):
        return None
    from torquemap._estimate_kernels import coupling_torques

    torque = np.empty((q.shape[0], 2))
    coupling_torques(
        np.ascontiguousarray(q[:, 1], dtype=np.float64),
        np.ascontiguousarray(velocity, dtype=np.float64),
        np.ascontiguousarray(acceleration, dtype=np.float64),
        gears,
        a2,
        a3,
        torque,
    )
    low = lowpass(t, torque, cutoff=cutoff)
    return np.asarray(np.abs(low) / gears, dtype=np.float64)


def _table_levels(
    law: Any,
    measured: Mapping[str, Any] | None,
    *,
    t: NDArray[np.float64],
    velocity: NDArray[np.float64],
    cutoff: float,
    width: float,
    slowest: float,
    acceleration: NDArray[np.float64] | None,
) -> NDArray[np.float64] | None:
    """A speed table's sign level and, with ``measured``, the residual table's level before
    the low-pass, side by side (n, 2; one column without ``measured``), in one compiled pass
    (:func:`torquemap._estimate_kernels.table_sigma_levels`): the numbers of
    :func:`_table_sign_terms` and :func:`_residual_level` to rounding. None for another law
    (the numpy path)."""
    from torquemap._estimate_kernels import table_sigma_levels
    from torquemap.friction_law import SpeedTableFriction

    if not isinstance(law, SpeedTableFriction):
        return None
    v = np.ascontiguousarray(velocity, dtype=np.float64)
    up0 = down0 = 0.0
    if slowest > 0:
        ups, downs = law.levels(np.array([slowest]))
        up0, down0 = float(ups[0]), float(downs[0])
    logs = np.empty(0)
    rms = np.empty(0)
    gain = per_acc = 0.0
    low = np.empty(0)
    if measured is not None:
        speeds = np.asarray(measured["speeds"], dtype=np.float64)
        rms = np.ascontiguousarray(measured["rms"], dtype=np.float64)
        if not (np.all(np.isfinite(speeds)) and np.all(np.isfinite(rms)) and np.all(rms >= 0)):
            raise InputError("[identification.joints.<j>.uncertainty] residual table is malformed")
        logs = np.log(speeds)
        reference = float(measured.get("reference_cutoff", RESIDUAL_CUTOFF))
        gain = math.sqrt(max(1.0, cutoff / max(reference, 1e-12)))
        per_acc = float(measured.get("acceleration_sigma", 0.0))
        if not (math.isfinite(per_acc) and per_acc > 0 and acceleration is not None):
            per_acc = 0.0
        else:
            low = np.ascontiguousarray(lowpass(t, acceleration, cutoff=cutoff), dtype=np.float64)
    out = np.empty((v.size, 2 if measured is not None else 1))
    table_sigma_levels(
        v,
        np.tanh(v / max(width, 1e-12)),
        np.log(np.maximum(np.abs(v), 1e-300)),
        np.log(np.asarray(law.speeds, dtype=np.float64)),
        np.asarray(law.positive, dtype=np.float64),
        np.asarray(law.negative, dtype=np.float64),
        float(law.viscous),
        float(law.viscous_negative),
        float(slowest),
        up0,
        down0,
        float(FORM_FRACTION),
        logs,
        rms,
        gain,
        per_acc,
        low,
        out,
    )
    return out


def _table_sign_terms(
    law: Any, velocity: NDArray[np.float64], width: float, slowest: float
) -> tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    tuple[NDArray[np.float64], NDArray[np.float64]],
]:
    """:func:`sign_sigma` and :func:`extrapolation_spread` of a law with ``levels`` (a
    speed table), and its levels at the speed: the branch share and the levels computed
    once for both (the same operations each does, so the same numbers)."""
    v = np.asarray(velocity, dtype=np.float64)
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    speed = np.abs(v)
    g_up, g_down = law.levels(speed)
    sign = np.asarray(np.sqrt(p * (1.0 - p)) * np.abs(g_up + g_down), dtype=np.float64)
    if not slowest > 0:
        return sign, np.zeros(v.shape), (g_up, g_down)
    # levels(min(|v|, S)): |v|'s own where it is at most S, the level at S beyond
    up0, down0 = law.levels(np.array([slowest]))
    beyond = speed > slowest
    s = np.minimum(speed, slowest)
    up = np.where(beyond, up0[0], g_up)
    down = np.where(beyond, down0[0], g_down)
    vu = float(getattr(law, "viscous", 0.0))
    vd = float(getattr(law, "viscous_negative", vu))
    spread_up = np.abs(up - vu * s - (up0[0] - vu * slowest))
    spread_down = np.abs(down - vd * s - (down0[0] - vd * slowest))
    spread = np.asarray(p * spread_up + (1.0 - p) * spread_down, dtype=np.float64)
    return sign, spread, (g_up, g_down)


def interpolation_sigma(
    velocity: NDArray[np.float64],
    width: float,
    pass_speeds: Sequence[float],
    curvature: float,
    *,
    floor: float = 0.0,
) -> NDArray[np.float64]:
    """Standard deviation [N m] of a friction table's interpolation between (and beyond) the
    steady passes it was fitted at, from its leave-one-pass-out curvature.

    ``curvature / 2 * |x - x_a| |x - x_b|`` per direction with ``x = log |v|`` and ``x_a``,
    ``x_b`` the nearest passes of that direction (signed ``pass_speeds`` [rad/s];
    :func:`torquemap.identify_whole.interpolation_gap`), each direction weighted by its share
    ``p = (1 + tanh(v / width)) / 2``. ``curvature`` [N m] is what identification measured by
    leaving each pass out in turn (:func:`torquemap.identify_whole.pass_interpolation_error`).
    Zero at a pass's speed, growing with the distance to the nearest passes; speeds below
    ``floor`` [rad/s] (the table's slowest fitted speed) are taken at ``floor``.

    Examples
    --------
    >>> v = np.array([1.0, np.exp(1.0), -np.exp(1.0)])
    >>> passes = [1.0, np.exp(2.0), -1.0, -np.exp(1.0)]
    >>> interpolation_sigma(v, 1e-3, passes, 2.0).round(6).tolist()
    [0.0, 1.0, 0.0]
    """
    from torquemap.identify_whole import interpolation_gaps

    v = np.asarray(velocity, dtype=np.float64)
    out = np.zeros(v.shape)
    if not (math.isfinite(curvature) and curvature > 0):
        return out
    x = np.log(np.maximum(np.abs(v), max(floor, 1e-300)))
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    for sign, share in ((1, p), (-1, 1.0 - p)):
        anchors = sorted(math.log(abs(s)) for s in pass_speeds if s * sign > 0)
        if not anchors:  # a direction never swept takes the other's
            anchors = sorted(math.log(abs(s)) for s in pass_speeds if s != 0)
        if not anchors:
            continue
        q = interpolation_gaps(x, anchors)
        out += share * 0.5 * curvature * q
    return out


def _chord_level(
    law: Any, entry: Any, *, velocity: NDArray[np.float64], width: float
) -> NDArray[np.float64] | None:
    """:data:`CHORD_SPREAD` times :func:`torquemap.pass_chord.chord_spread` of a joint's table
    between its passes (``entry["speeds"]``, signed); None when it is 0, the law is not a
    table or the notes hold no passes."""
    from torquemap.friction_law import SpeedTableFriction
    from torquemap.pass_chord import chord_spread

    speeds = entry.get("speeds") if isinstance(entry, Mapping) else None
    share = float(CHORD_SPREAD)
    if not (share > 0 and isinstance(law, SpeedTableFriction) and isinstance(speeds, list)):
        return None
    passes = [float(x) for x in speeds if isinstance(x, int | float) and math.isfinite(x)]
    if not passes:
        return None
    return share * chord_spread(law, velocity, width, passes, chords=CHORD_LEVELS)


def _interpolation_level(
    table: Mapping[str, Any], entry: Any, *, velocity: NDArray[np.float64], width: float
) -> NDArray[np.float64] | None:
    """:func:`interpolation_sigma` of a joint from its notes (the curvature identification
    recorded, ``uncertainty.interpolation``, and its passes' signed ``speeds``), or None when
    they hold none."""
    record = table.get("interpolation")
    speeds = entry.get("speeds") if isinstance(entry, Mapping) else None
    if not (INTERPOLATION and isinstance(record, Mapping) and isinstance(speeds, list)):
        return None
    curvature = float(record.get("curvature", 0.0))
    passes = [float(x) for x in speeds if isinstance(x, int | float) and math.isfinite(x)]
    if not (math.isfinite(curvature) and curvature > 0 and passes):
        return None
    floor = float(entry.get("friction_observed_speed", 0.0))
    return interpolation_sigma(velocity, width, passes, curvature, floor=floor)


def below_extrapolation(
    table: Mapping[str, Any],
    entry: Any,
    *,
    velocity: NDArray[np.float64],
    width: float,
    floor: float = 0.0,
) -> NDArray[np.float64] | None:
    """Standard deviation [N m] of a friction table's extrapolation below its slowest steady
    pass (``entry["speeds"]``), from the table's own leave-one-pass-out curvature ``c`` and the
    passes it left out (identification's ``uncertainty.interpolation``): ``c q / 2`` (:func:`interpolation_sigma`, no floor) at
    speeds below the slowest pass, ``q = |x - x_1| |x - x_2|`` in ``x = log |v|`` from the
    two slowest passes of the direction; 0 at and above it; speeds below ``floor`` [rad/s]
    (the law's transition, where the sign term stands) taken at ``floor``. None when the notes
    hold no curvature or no pass speeds.

    Leaving the slowest pass out measures what the table misses when it extrapolates from the
    passes above (the prior and the ramps set it there, as below every pass); ``c`` is the
    curvature that explains those misses, and a curve of that curvature departs from the
    table's continuation by ``c q / 2``.

    Examples
    --------
    >>> table = {"interpolation": {"curvature": 0.02, "speeds": [1.0, -1.0, np.e, -np.e]}}
    >>> entry = {"speeds": [1.0, -1.0, np.e, -np.e, np.e]}
    >>> v = np.array([np.exp(-1.0), 1.0, 2.0])
    >>> below_extrapolation(table, entry, velocity=v, width=1e-3).round(6).tolist()
    [0.02, 0.0, 0.0]
    """
    record = table.get("interpolation")
    if not isinstance(record, Mapping):
        return None
    # the passes as the curvature was measured on them (one per speed group and direction)
    speeds = record.get("speeds")
    if not isinstance(speeds, list | tuple):
        return None
    curvature = float(record.get("curvature", 0.0))
    passes = [float(x) for x in speeds if isinstance(x, int | float) and math.isfinite(x) and x]
    slowest = _slowest(entry)
    if not (math.isfinite(curvature) and curvature > 0 and passes and slowest > 0):
        return None
    v = np.asarray(velocity, dtype=np.float64)
    out = interpolation_sigma(v, width, passes, curvature, floor=min(max(floor, 0.0), slowest))
    return np.asarray(np.where(np.abs(v) < slowest, out, 0.0), dtype=np.float64)


def _slowest(entry: Any) -> float:
    """The slowest steady speed [rad/s] of a joint's identification notes (0 when none)."""
    speeds = entry.get("speeds") if isinstance(entry, Mapping) else None
    if not isinstance(speeds, list | tuple):
        return 0.0
    values = [abs(float(x)) for x in speeds if isinstance(x, int | float) and math.isfinite(x)]
    return min((x for x in values if x > 0), default=0.0)


def extrapolation_spread(
    law: Any, velocity: NDArray[np.float64], width: float, slowest: float
) -> NDArray[np.float64]:
    """How far a speed table's dry friction below the slowest steady speed departs from its
    value there [N m]: ``|g(s) - g(S)|`` with ``g`` the level less the viscous term, ``s`` the
    speed and ``S = slowest`` [rad/s], each direction weighted by its share at ``velocity``.

    Below the slowest steady pass only ramps, speed ripple and the table's prior set the
    table; a flat continuation of the slowest pass's level fits the same steady data, so the
    spread between the two extrapolations is uncertain by its own size. Zero at and above
    ``S``, and for laws without ``levels``.

    Examples
    --------
    >>> from torquemap.friction_law import SpeedTableFriction
    >>> f = SpeedTableFriction(speeds=(0.1, 1.0, 10.0), positive=(0.3, 0.2, 0.2),
    ...                        negative=(0.2, 0.2, 0.2), zero_velocity=0.01)
    >>> extrapolation_spread(f, np.array([0.1, -0.1, 2.0]), 0.01, 1.0).round(6).tolist()
    [0.1, 0.0, 0.0]
    """
    levels = getattr(law, "levels", None)
    v = np.asarray(velocity, dtype=np.float64)
    if not callable(levels) or not slowest > 0:
        return np.zeros(v.shape)
    s = np.minimum(np.abs(v), slowest)
    up, down = levels(s)
    up0, down0 = levels(np.array([slowest]))
    vu = float(getattr(law, "viscous", 0.0))
    vd = float(getattr(law, "viscous_negative", vu))
    spread_up = np.abs(up - vu * s - (up0[0] - vu * slowest))
    spread_down = np.abs(down - vd * s - (down0[0] - vd * slowest))
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    return np.asarray(p * spread_up + (1.0 - p) * spread_down, dtype=np.float64)


def _residual_sigma(
    table: Mapping[str, Any],
    law: Any,
    *,
    t: NDArray[np.float64],
    velocity: NDArray[np.float64],
    cutoff: float,
    acceleration: NDArray[np.float64] | None = None,
    sign: bool = True,
) -> NDArray[np.float64]:
    """Sigma [N m, motor side] from a residual table (:func:`residual_table`); without
    ``sign``, the table's level alone (no term for the sign of friction)."""
    level = _residual_level(table, t=t, velocity=velocity, cutoff=cutoff, acceleration=acceleration)
    if not sign:
        return np.asarray(np.maximum(lowpass(t, level, cutoff=cutoff), 0.0), dtype=np.float64)
    width = max(float(getattr(law, "zero_velocity", 0.0)), 1e-9)
    # both levels in one low-pass call (the filter runs four signals side by side)
    both = lowpass(t, np.column_stack((level, sign_sigma(law, velocity, width))), cutoff=cutoff)
    level, band = both[:, 0], both[:, 1]
    return np.asarray(np.sqrt(np.maximum(level, 0.0) ** 2 + np.maximum(band, 0.0) ** 2))


def _residual_level(
    table: Mapping[str, Any],
    *,
    t: NDArray[np.float64],
    velocity: NDArray[np.float64],
    cutoff: float,
    acceleration: NDArray[np.float64] | None,
) -> NDArray[np.float64]:
    """The residual table's level [N m, motor side] at each sample, before the low-pass."""
    speeds = np.asarray(table["speeds"], dtype=np.float64)
    rms = np.asarray(table["rms"], dtype=np.float64)
    if not (np.all(np.isfinite(speeds)) and np.all(np.isfinite(rms)) and np.all(rms >= 0)):
        raise InputError("[identification.joints.<j>.uncertainty] residual table is malformed")
    reference = float(table.get("reference_cutoff", RESIDUAL_CUTOFF))
    # measured at the reference cut-off: a wider low-pass lets more noise through (taken as if
    # all of it were noise), a narrower one keeps the systematic part (taken as if all of it
    # were systematic): conservative both ways
    level = np.interp(np.log(np.maximum(np.abs(velocity), 1e-12)), np.log(speeds), rms)
    level = level * math.sqrt(max(1.0, cutoff / max(reference, 1e-12)))
    per_acc = float(table.get("acceleration_sigma", 0.0))
    if math.isfinite(per_acc) and per_acc > 0 and acceleration is not None:
        level = np.hypot(level, per_acc * np.abs(lowpass(t, acceleration, cutoff=cutoff)))
    return np.asarray(level, dtype=np.float64)


def representative_samples(
    t: NDArray[np.float64], velocity: NDArray[np.float64], *, reach: float, factor: float
) -> NDArray[np.bool_]:
    """Samples whose speed stands for every sample within ``reach`` [s]: all of one sign, and
    within ``factor`` (> 1) of the sample's own speed (``t`` [s] increasing, ``velocity``
    any unit). A low-passed signal at such a sample is a mean over that one speed, not over a
    start from rest, a reversal or a ramp nearby.

    Examples
    --------
    >>> t = np.arange(9.0)
    >>> v = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 3.0, 3.0, -3.0])  # a step of 3x, a reversal
    >>> representative_samples(t, v, reach=1.0, factor=2.0).astype(int).tolist()
    [1, 1, 1, 1, 1, 0, 0, 0, 0]
    """
    v = np.asarray(velocity, dtype=np.float64)
    n = v.size
    left = np.searchsorted(t, t - reach, side="left")
    right = np.searchsorted(t, t + reach, side="right")  # exclusive
    # sparse tables of the minimum and maximum over runs of 2^k samples
    lows, highs = [v], [v]
    span = 1
    while 2 * span <= n:
        lows.append(np.minimum(lows[-1][:-span], lows[-1][span:]))
        highs.append(np.maximum(highs[-1][:-span], highs[-1][span:]))
        span *= 2
    k = np.floor(np.log2(np.maximum(right - left, 1))).astype(np.intp)
    lo = np.empty(n)
    hi = np.empty(n)
    for level in np.unique(k):
        at = np.flatnonzero(k == level)
        a, b = left[at], right[at] - (1 << int(level))
        lo[at] = np.minimum(lows[level][a], lows[level][b])
        hi[at] = np.maximum(highs[level][a], highs[level][b])
    up = (lo > 0) & (lo * factor >= v) & (hi <= factor * v)
    down = (hi < 0) & (hi * factor <= v) & (lo >= factor * v)
    return np.asarray(up | down)


def residual_table(
    t: list[NDArray[np.float64]],
    velocity: list[NDArray[np.float64]],
    acceleration: list[NDArray[np.float64]],
    residual: list[NDArray[np.float64]],
    *,
    band: float,
    selection: Literal["steady", "representative"] | None = None,
) -> dict[str, Any] | None:
    """The uncertainty table of a joint identified by the pass method (no covariance).

    On the no-load logs the estimate of the external torque should be zero: what the model
    leaves there (the Eq 7 residual minus the PDTV model, through the ``RESIDUAL_CUTOFF``
    low-pass) IS the estimate's error, friction misfit, inertia and noise together. Its RMS
    over the steady samples (low-passed acceleration below 5 % of its 99th percentile plus
    0.1 s^-1 times the speed), in ``RESIDUAL_BINS`` log-spaced bins of the motor speed above
    ``band`` (the reversal band: slower samples are flagged), is the table;
    :func:`joint_sigma` interpolates it in ``log |v|``. What the accelerating samples (ramps)
    add beyond it, per unit of low-passed acceleration (``sqrt(sum excess^2 / sum acc^2)``),
    is ``acceleration_sigma`` [N m s^2/rad]: an inertia or delay misfit.

    Parameters
    ----------
    t, velocity, acceleration, residual
        Per contiguous piece of the logs: time [s], motor velocity [rad/s], motor acceleration
        [rad/s^2] and the residual [N m, motor side], each shape (m,).
    band
        Reversal band [rad/s].
    selection
        ``"representative"``: the bins take only the steady samples whose low-pass support
        (``1 / RESIDUAL_CUTOFF`` either side) holds speeds of one sign within
        :data:`REPRESENTATIVE_FACTOR` of their own (:func:`representative_samples`): a start
        from rest, a reversal or a stretch of large speed ripple nearby does not enter a steady
        bin through the low-pass (the others count as ramps). None: :data:`RESIDUAL_SELECTION`.

    Returns
    -------
    dict or None
        ``{"kind": "residual", "speeds": [...], "rms": [...], "reference_cutoff": ...}``
        (bin centres [rad/s], RMS [N m]); None when too few moving samples.
    """
    picky = (RESIDUAL_SELECTION if selection is None else selection) == "representative"
    vs, rs, acs, steps, fits = [], [], [], [], []
    for tt, v, a, r in zip(t, velocity, acceleration, residual, strict=True):
        if tt.size < 20 or float(tt[-1] - tt[0]) < 2.0 / RESIDUAL_CUTOFF:
            continue
        try:
            low = lowpass(tt, r, cutoff=RESIDUAL_CUTOFF)
            acc = lowpass(tt, a, cutoff=RESIDUAL_CUTOFF)
        except InputError:
            continue
        vs.append(np.abs(v))
        steps.append(np.diff(tt))
        rs.append(low)
        acs.append(np.abs(acc))
        if picky:
            fits.append(
                representative_samples(
                    tt, v, reach=1.0 / RESIDUAL_CUTOFF, factor=REPRESENTATIVE_FACTOR
                )
            )
    if not vs:
        return None
    speed = np.concatenate(vs)
    spacing = float(np.median(np.concatenate(steps)))
    low = np.concatenate(rs)
    acc = np.concatenate(acs)
    lo = max(band, 1e-6)
    moving = speed > lo
    if int(moving.sum()) < 100:
        return None
    steady = acc < 0.05 * float(np.percentile(acc[moving], 99)) + 0.1 * speed
    if picky:
        steady &= np.concatenate(fits)
    ramps = moving & ~steady
    moving &= steady
    if int(moving.sum()) < 100:
        return None
    top = float(np.max(speed[moving]))
    edges = np.geomspace(lo, max(top, 1.01 * lo), RESIDUAL_BINS + 1)
    centres, values = [], []
    which = np.clip(np.searchsorted(edges, speed[moving]) - 1, 0, RESIDUAL_BINS - 1)
    low_moving = low[moving]  # once, not per bin
    for b in range(RESIDUAL_BINS):
        sel = low_moving[which == b]
        if sel.size < 50 or sel.size * spacing < 4.0 / RESIDUAL_CUTOFF:  # a few correlation times
            continue
        centres.append(float(math.sqrt(edges[b] * edges[b + 1])))
        values.append(float(np.sqrt(np.mean(sel**2))))
    if not centres:
        return None
    per_acc = 0.0
    if ramps.any():
        base = np.interp(np.log(speed[ramps]), np.log(centres), values)
        excess = np.maximum(low[ramps] ** 2 - base**2, 0.0)
        per_acc = float(math.sqrt(np.sum(excess) / max(float(np.sum(acc[ramps] ** 2)), 1e-300)))
    return {
        "kind": "residual",
        "speeds": centres,
        "rms": values,
        "acceleration_sigma": per_acc,
        "reference_cutoff": RESIDUAL_CUTOFF,
    }


def bridge_departure(
    t: NDArray[np.float64],
    estimate: NDArray[np.float64],
    bridged: NDArray[np.bool_],
    *,
    cutoff: float,
    runs: Sequence[tuple[int, int]] | None = None,
) -> NDArray[np.float64]:
    """Standard deviation [unit of ``estimate``] of the load's departure from the straight
    line a bridged run holds (``runs``: the runs of ``bridged`` when the caller has them).

    Over a run from ``ta`` to ``tb`` (``D = tb - ta``) the answer is the line between the
    estimates at its ends; a load whose slope goes from ``s1`` (just before) to ``s2`` (just
    after) departs from that chord as a parabola would, ``|s2 - s1| (t - ta) (tb - t) / (2 D)``
    (``|s2 - s1| D / 8`` at the middle). The slopes are those of ``estimate`` over the half run,
    at most ``1 / cutoff``, beyond each end. A run at an end of the log holds its one
    neighbour's value: there the departure is that neighbour's slope times the time from it.
    Zero outside the runs. ``t`` [s] increases (a piece of a log).

    Examples
    --------
    >>> t = np.linspace(0.0, 4.0, 401)
    >>> load = np.where(t < 2.0, 0.0, t - 2.0)          # a kink at t = 2 s: slopes 0, then 1
    >>> bridged = (t > 1.5) & (t < 2.5)
    >>> round(float(bridge_departure(t, load, bridged, cutoff=2.0).max()), 3)  # 1 * 1 / 8
    0.125
    """
    from torquemap._estimate_kernels import departure_runs
    from torquemap.estimate import _gap_runs

    out = np.zeros(t.size)
    span = 1.0 / max(cutoff, 1e-12)
    runs = _gap_runs(bridged) if runs is None else runs
    if not runs:
        return out
    # one compiled pass: the sides' slopes in closed form (np.polyfit's to an ulp or so)
    starts = np.array([a for a, _ in runs], dtype=np.int64)
    stops = np.array([b for _, b in runs], dtype=np.int64)
    values = np.ascontiguousarray(estimate, dtype=np.float64)
    mask = np.ascontiguousarray(bridged, dtype=np.bool_)
    times = np.ascontiguousarray(t, dtype=np.float64)
    if departure_runs(times, values, mask, starts, stops, span, out):
        return out
    # a side with a value that is not finite or with equal times: np.polyfit's answer
    return _bridge_departure_polyfit(t, estimate, bridged, span=span, runs=runs)


def _bridge_departure_polyfit(
    t: NDArray[np.float64],
    estimate: NDArray[np.float64],
    bridged: NDArray[np.bool_],
    *,
    span: float,
    runs: Sequence[tuple[int, int]],
) -> NDArray[np.float64]:
    """:func:`bridge_departure` by ``np.polyfit`` per side (the path before stop 44), for the
    cases the compiled pass leaves to it."""
    out = np.zeros(t.size)
    for a, b in runs:
        ta = float(t[a - 1]) if a > 0 else float(t[a])
        tb = float(t[b]) if b < t.size else float(t[b - 1])
        d = max(tb - ta, 1e-12)
        reach = min(0.5 * d, span)
        slopes = []
        for lo, hi in ((ta - reach, ta), (tb, tb + reach)):
            # the samples in [lo, hi] (time increases: a slice, not a mask of the whole log)
            i0 = int(np.searchsorted(t, lo, side="left"))
            i1 = int(np.searchsorted(t, hi, side="right"))
            sel = ~bridged[i0:i1]
            if int(sel.sum()) >= 3:
                times = t[i0:i1][sel]
                slopes.append(float(np.polyfit(times - lo, estimate[i0:i1][sel], 1)[0]))
        if not slopes:
            continue
        tt = t[a:b]
        if a > 0 and b < t.size and len(slopes) == 2:
            out[a:b] = abs(slopes[1] - slopes[0]) * (tt - ta) * (tb - tt) / (2.0 * d)
        else:  # a run at an end holds its one neighbour's value: the load may go on moving
            out[a:b] = abs(slopes[0]) * (tt - ta if b == t.size else tb - tt)
    return out
