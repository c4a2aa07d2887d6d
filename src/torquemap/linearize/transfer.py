"""Tables for a second joint of the same motor type from a handful of measurements (§6.2).

The Adept II paper (§6.2) suggests collecting "a handful of characteristic parameters from a new
motor (e.g., phase equilibrium positions, and the torques at the middle of the three transition
regions and at the middle of the single phase regions)" and applying them "to modify the
existing data of the same motor type by means of systematic scaling". Here the scaling is:

``T2(p, w) = a(p) T1(p, v(w))``

* ``T1`` is the first joint's torque surface: its full characterisation, denoised
  (:func:`torquemap.linearize.denoise.denoise_blocks`), averaged per (position, pulse width)
  cell, made monotone in pulse width and interpolated linearly in pulse width and (cyclically)
  in position.
* ``v(w) = alpha + W (beta u + gamma u (1 - u))``, ``u = w / W``, absorbs the amplifiers'
  differences (dead band, gain, curve), common to every phase and position.
* ``a(p) = sum_k g_k w_k(p)`` is the torque ratio: one gain per phase, weighted by each phase's
  share of the torque at ``p`` (:func:`phase_shares`).

The phases' equilibria are not registered (an earlier release sampled ``T1`` at
``p + s(p)``, ``s`` the two motor files' equilibria apart): ``T1`` is the torque along the
ramp, whose hand-overs sit at the same table positions on both joints, and shifting the
surface moved them with the phases; on the random benches 101 to 110 that cost 2.6 points of
median APMD (docs/linearize-transfer.md).

The handful is ordinary collection data (``position, pulse_width, torque``) of the second joint
at a few positions and pulse widths (``2 m`` targets, pulse widths every 64): with the standard
ramps the ``2 m`` evenly spaced targets are the middles of the single-phase and transition
regions, the paper's suggestion. The phase gains are a linear least-squares fit for given
``alpha, beta, gamma``; the three are found by minimising the profile residual within bounds
(``|alpha| <= 0.15 W``, ``0.8 <= beta <= 1.25``, ``|gamma| <= 0.3``) with a weak prior towards
the first joint's amplifier (where torque is linear in current, gain and pulse-width scale
trade off).

Which scaling is written is the handful's choice (:func:`held_out_error`): the first joint's
characterisation unchanged, its phase gains alone, or gains and the amplifier law, each scored
on every position of the handful with the scaling fitted to the other positions; the simplest
within ``TIE`` of the best wins, and an amplifier law fitted onto a bound of its box (the
handful pushes it beyond a plausible amplifier: a gain traded against a pulse-width scale) is
not a candidate. When the unchanged characterisation wins, its rows are written as they are
(scaled by one common factor, to which the tables are blind) with a warning.

The result is the first joint's rows, re-scaled: DATA.csv for the second joint, which
:func:`torquemap.linearize.tables.build_tables` turns into tables like any other.

This module never imports the simulator.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import isotonic_regression, minimize

from torquemap.errors import InputError
from torquemap.linearize.denoise import denoise_blocks
from torquemap.linearize.homing import circular_difference
from torquemap.linearize.motor import MotorSpec
from torquemap.linearize.tables import LinearizeData, fill_voids

#: Weight of the prior on the amplifier law, relative to the handful's torque energy (1e-3: a
#: tie-break; 0.05 measured worse on the BLDC siblings of benchmarks/transfer.py).
PRIOR = 1e-3
#: The scalings, simplest first: the first joint's surface unchanged (one common scale), its
#: phases' gains (weighted by the phases' shares), gains and the amplifier law.
Scaling = Literal["unchanged", "gains", "full"]
MODELS: tuple[Scaling, ...] = ("unchanged", "gains", "full")
#: A richer scaling is taken only when its held-out error is below the simplest's within this
#: fraction of the best.
TIE = 0.05
#: Readings below this fraction of the handful's largest torque are not scored (a relative
#: error there is the sensor's noise).
READABLE = 0.02
#: Held-out error (:func:`held_out_error`) of the chosen scaling beyond which no scaling of the
#: first joint describes the second, and a warning says so. Chosen on the QA benches 301 to 330
#: (siblings, ``sim.twins.sibling``: 1.1 to 8.1 %; another bench of the same shape: 8.2 to 41 %,
#: 9 of 10 above), checked on 101 to 140 (siblings 1.4 to 9.7 % but 108, 12.9 %, whose
#: transferred tables an earlier QA measured at 22.9 % APMD against 11.8 % unchanged; other
#: benches 13.4 to 144 %, 10 of 10 above); docs/linearize-transfer.md.
MISFIT = 0.10
#: A phase's gain is fitted from the handful's rows where it carries torque: below this share
#: of the torque (:func:`phase_shares`) at every position measured above pulse width 0, the
#: handful does not see the phase and its least-squares gain is 0 (QA: a handful of 3
#: positions of one phase's region wrote a phase gain of 0.000, exit 0).
HANDFUL_SHARE = 0.25


@dataclass(frozen=True, slots=True, eq=False)
class TransferResult:
    """Characterisation data of a second joint transferred from a first one.

    Attributes
    ----------
    position, pulse_width, torque
        The transferred rows (the first joint's positions and pulse widths, in its row order),
        shape (n,) each; torque [N m].
    gain
        Torque ratio ``g_k`` of the second joint's phase to the first's, shape (m,).
    pulse_offset, pulse_scale, pulse_curve
        ``alpha`` [pulse width], ``beta`` and ``gamma``: the first joint's pulse width that gives
        the torque the second joint's amplifier gives at ``w`` is
        ``alpha + W (beta u + gamma u (1 - u))`` with ``u = w / W``, ``W`` the full scale.
    position_shift
        First joint's equilibrium minus the second's, per phase [table positions], shape (m,)
        (from the motor files; reported, not applied).
    residual
        RMS misfit of the handful after the fit, relative to its RMS torque.
    residual_unchanged
        The same for the first joint's surface taken unchanged (``a = 1``, ``alpha = 0``,
        ``beta = 1``, no registration).
    measurements
        Rows of the handful used.
    model
        The scaling written: ``"unchanged"``, ``"gains"`` or ``"full"`` (:data:`MODELS`).
    held_out
        Each scaling's held-out error on the handful (:func:`held_out_error`); infinite for
        an amplifier law fitted onto a bound.
    warnings
        One line each: the handful predicts the first joint's characterisation unchanged as
        well as any scaling of it, within ``TIE`` (the rows are then written unchanged).
    """

    position: NDArray[np.int64]
    pulse_width: NDArray[np.int64]
    torque: NDArray[np.float64]
    gain: NDArray[np.float64]
    pulse_offset: float
    pulse_scale: float
    pulse_curve: float
    position_shift: NDArray[np.float64]
    residual: float
    residual_unchanged: float
    measurements: int
    model: Scaling = "full"
    held_out: dict[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()


class _Surface:
    """The first joint's torque ``T1(p, w)``: monotone in ``w``, linear in ``w`` and ``p``."""

    def __init__(self, spec: MotorSpec, data: LinearizeData) -> None:
        tau = denoise_blocks(data.level, data.torque).torque
        self.levels, col = np.unique(data.level, return_inverse=True)
        n = spec.positions_per_cycle
        shape = (n, self.levels.size)
        flat = data.position * shape[1] + col
        count = np.bincount(flat, minlength=shape[0] * shape[1]).reshape(shape)
        total = np.bincount(flat, weights=tau, minlength=shape[0] * shape[1]).reshape(shape)
        grid = np.full(shape, np.nan)
        for p in np.flatnonzero(count.sum(axis=1)):
            have = count[p] > 0
            grid[p, have] = isotonic_regression(
                total[p, have] / count[p, have], weights=count[p, have]
            ).x
        grid = fill_voids(grid, levels=self.levels)
        grid = np.fmax.accumulate(grid, axis=1)
        self.grid = np.where(np.isnan(grid), 0.0, grid)
        self.positions = np.arange(n)
        self.period = n

    def __call__(
        self, position: NDArray[np.float64], pulse_width: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        return self.at_positions(position)(pulse_width)

    def at_positions(
        self, position: NDArray[np.float64]
    ) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
        """``T1(position, .)``: the positions' interpolation done once, for a fit that
        evaluates the surface at the same positions many times (the scaling's search)."""
        knots = np.concatenate([self.positions, [self.positions[0] + self.period]])
        p = np.mod(position, self.period)
        p = np.where(p < knots[0], p + self.period, p)
        i = np.clip(np.searchsorted(knots, p, side="right") - 1, 0, knots.size - 2)
        fp = (p - knots[i]) / (knots[i + 1] - knots[i])
        i1 = (i + 1) % self.positions.size

        def of(pulse_width: NDArray[np.float64]) -> NDArray[np.float64]:
            w = np.clip(pulse_width, self.levels[0], self.levels[-1])
            j = np.clip(np.searchsorted(self.levels, w, side="right") - 1, 0, self.levels.size - 2)
            fw = (w - self.levels[j]) / (self.levels[j + 1] - self.levels[j])

            def at(r: NDArray[np.int64]) -> NDArray[np.float64]:
                out: NDArray[np.float64] = self.grid[r, j] * (1 - fw) + self.grid[r, j + 1] * fw
                return out

            result: NDArray[np.float64] = at(i) * (1 - fp) + at(i1) * fp
            return result

        return of


def transfer_characterisation(
    first_spec: MotorSpec,
    first: LinearizeData,
    second_spec: MotorSpec,
    few: LinearizeData,
    *,
    scaling: Scaling | Literal["auto"] = "auto",
) -> TransferResult:
    """Characterisation data for a second joint: the first joint's, scaled to a handful.

    Parameters
    ----------
    first_spec
        The first joint's motor file.
    first
        The first joint's full characterisation (DATA.csv rows, in collection order).
    second_spec
        The second joint's motor file (its equilibria weigh the phases' shares); same phases,
        positions per cycle and full-scale pulse width as the first.
    few
        The second joint's handful: characterisation rows at a few positions (at least 2,
        better ``2 m``) and a few pulse widths (at least 2 above zero).
    scaling
        ``"auto"``: the handful chooses (:func:`held_out_error`); or one of :data:`MODELS`.

    Returns
    -------
    TransferResult
        The transferred rows and the fitted scaling.

    Raises
    ------
    InputError
        Motors of another type (phases, cycle, full scale) or ramp, a handful too small to
        fit, or one that leaves a phase unmeasured (:data:`HANDFUL_SHARE`).

    Examples
    --------
    See docs/linearize-transfer.md.
    """
    a_spec, b_spec = first_spec, second_spec
    if (a_spec.phases, a_spec.positions_per_cycle, a_spec.actuation_max) != (
        b_spec.phases,
        b_spec.positions_per_cycle,
        b_spec.actuation_max,
    ):
        raise InputError(
            "the second joint's motor is not of the first's type (phases, positions per cycle "
            "or full-scale pulse width differ)",
            path=b_spec.path,
        )
    if not np.array_equal(np.asarray(a_spec.ramp), np.asarray(b_spec.ramp)):
        # the output is the first joint's rows, base pulse widths through the first's ramp: built
        # with another (QA: narrow rows under a wide SECOND.toml) its tables were 86.9 % APMD
        raise InputError(
            f"the second joint's ramp ({b_spec.ramping}) is not the first's ({a_spec.ramping}): "
            "the transferred rows are the first's pulse widths through its ramp; give both "
            "motor files the same ramping",
            path=b_spec.path,
        )
    n = a_spec.positions_per_cycle
    blocks = np.unique(few.position)
    if blocks.size < 2 or np.unique(few.level[few.level > 0]).size < 2:
        raise InputError(
            "the handful needs at least 2 positions and 2 pulse widths above zero", path=few.path
        )
    e1 = np.asarray(a_spec.equilibrium_positions, dtype=np.float64)
    e2 = np.asarray(b_spec.equilibrium_positions, dtype=np.float64)
    ramp = np.asarray(b_spec.ramp, dtype=np.float64)
    lit = few.position[few.level > 0].astype(np.float64)
    reach = phase_shares(lit, ramp, e2, n).max(axis=0)
    unseen = np.flatnonzero(reach < HANDFUL_SHARE)
    if unseen.size:
        k = int(unseen[0])
        raise InputError(
            f"the handful measures no position where phase {k + 1} carries torque (at most "
            f"{reach[k]:.0%} of it above pulse width 0): its gain cannot be fitted; measure the "
            f"{2 * a_spec.phases} region middles (linearize collect --position-step "
            f"{-(-n // (2 * a_spec.phases))} --step 64)",
            path=few.path,
        )
    surface = _Surface(a_spec, first)
    shift = circular_difference(e1, e2, n)
    top = float(a_spec.actuation_max)
    model = _Model(surface, ramp, e2, n, top)
    pos = few.position.astype(np.float64)
    level = few.level.astype(np.float64)
    tau = few.torque
    scores: dict[str, float] = {n_: held_out_error(model, n_, pos, level, tau) for n_ in MODELS}
    full = model.fit("full", pos, level, tau)
    x, g = full
    if model.on_bound(x):
        scores["full"] = float("inf")
    if scaling == "auto":
        # the simplest scaling within TIE of the best: a richer one must earn its parameters
        # on readings it was not fitted to
        best = min(scores.values())
        chosen: Scaling = next(name for name in MODELS if scores[name] <= best * (1.0 + TIE))
    else:
        chosen = scaling
    scale = float(np.sqrt(np.mean(tau**2))) or 1.0
    residual = float(np.sqrt(np.mean((tau - model.predict(x, g, pos, level)) ** 2))) / scale
    residual_unchanged = float(np.sqrt(np.mean((tau - surface(pos, level)) ** 2))) / scale
    x, g = full if chosen == "full" else model.fit(chosen, pos, level, tau)
    warnings = []
    if chosen == "unchanged":
        torque = g[0] * first.torque
        if scaling == "auto":
            other = min(scores["gains"], scores["full"])
            warnings.append(
                "the handful's held-out readings are predicted as well (within "
                f"{100 * TIE:.0f} %) by the first joint's characterisation unchanged "
                f"({100 * scores['unchanged']:.1f} % mean relative error) as by any scaling of "
                f"it ({100 * other:.1f} %): wrote the first "
                "joint's rows unchanged (its tables apply as they are); is the handful this "
                "joint's, of a motor of the first's type?"
            )
    else:
        p_first = first.position.astype(np.float64)
        torque = model.predict(x, g, p_first, first.level.astype(np.float64), name=chosen)
    if scores[chosen] > MISFIT:
        warnings.append(
            f"no scaling of the first joint's characterisation predicts the handful within "
            f"{100 * MISFIT:.0f} % (held out, each position from the others: {chosen} "
            f"{100 * scores[chosen]:.1f} % mean relative error): is this joint's motor of the "
            "first's type? Its transferred tables may be far from its own; characterise it in "
            "full"
        )
    return TransferResult(
        position=first.position.copy(),
        pulse_width=first.level.copy(),
        torque=torque,
        gain=g,
        pulse_offset=float(x[0]),
        pulse_scale=float(x[1]),
        pulse_curve=float(x[2]),
        position_shift=shift,
        residual=residual,
        residual_unchanged=residual_unchanged,
        measurements=int(tau.size),
        model=chosen,
        held_out=scores,
        warnings=tuple(warnings),
    )


class _Model:
    """``T2(p, w) = a(p) T1(p, v(w))`` and its fits to rows of the handful."""

    def __init__(
        self,
        surface: _Surface,
        ramp: NDArray[np.float64],
        equilibrium: NDArray[np.float64],
        period: int,
        top: float,
    ) -> None:
        self.surface, self.ramp, self.equilibrium = surface, ramp, equilibrium
        self.period, self.top = period, top
        self.bounds = [(-0.15 * top, 0.15 * top), (0.8, 1.25), (-0.3, 0.3)]

    def on_bound(self, x: NDArray[np.float64]) -> bool:
        """Whether an amplifier law sits on a bound of its box (within 0.1 % of its width)."""
        return any(
            min(v - lo, hi - v) <= 1e-3 * (hi - lo)
            for v, (lo, hi) in zip(x.tolist(), self.bounds, strict=True)
        )

    def shares(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        return phase_shares(p, self.ramp, self.equilibrium, self.period)

    def warp(self, x: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
        u = w / self.top
        out: NDArray[np.float64] = x[0] + self.top * (x[1] * u + x[2] * u * (1.0 - u))
        return out

    def predict(
        self,
        x: NDArray[np.float64],
        g: NDArray[np.float64],
        p: NDArray[np.float64],
        w: NDArray[np.float64],
        *,
        name: Scaling = "full",
    ) -> NDArray[np.float64]:
        if name == "unchanged":
            out: NDArray[np.float64] = g[0] * self.surface(p, w)
            return out
        sh = self.shares(p)
        out = (sh @ g) * self.surface(p, self.warp(x, w))
        return out

    def fit(
        self,
        name: Scaling,
        p: NDArray[np.float64],
        w: NDArray[np.float64],
        tau: NDArray[np.float64],
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The scaling's parameters ``(alpha, beta, gamma)`` and phase gains fitted to rows."""
        identity = np.array([0.0, 1.0, 0.0])
        m = self.ramp.shape[1]
        if name == "unchanged":
            t1 = self.surface(p, w)
            common = float(t1 @ tau) / (float(t1 @ t1) or 1.0)
            return identity, np.full(m, common)
        sh = self.shares(p)
        surface = self.surface.at_positions(p)

        def gains(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            design = sh * surface(self.warp(x, w))[:, None]
            g: NDArray[np.float64] = np.asarray(
                np.linalg.lstsq(design, tau, rcond=None)[0], dtype=np.float64
            )
            return g, tau - design @ g

        if name == "gains":
            return identity, gains(identity)[0]
        energy = float(np.sum(tau**2)) or 1.0

        def cost(x: NDArray[np.float64]) -> float:
            # a weak prior on the amplifier law: where the torque is linear in the current
            # (BLDC), a gain and a pulse-width scale trade off, and the plausible amplifier is
            # the first's
            prior: float = PRIOR * energy * ((x[1] - 1.0) ** 2 + x[2] ** 2)
            return float(np.sum(gains(x)[1] ** 2)) + prior

        best = min(
            (
                minimize(cost, np.array([a0, 1.0, 0.0]), method="Nelder-Mead", bounds=self.bounds)
                for a0 in (-10.0, 0.0, 10.0)
            ),
            key=lambda r: float(r.fun),
        )
        x = np.asarray(best.x, dtype=np.float64)
        return x, gains(x)[0]


def held_out_error(
    model: _Model,
    name: Scaling,
    position: NDArray[np.float64],
    pulse_width: NDArray[np.float64],
    torque: NDArray[np.float64],
) -> float:
    """Mean relative error of a scaling on each position of the handful, fitted to the others.

    Leave one position out: the scaling is fitted to the handful's other positions and
    predicts this one's readings; the error is ``|tau - tau_hat| / tau`` over the readings
    above ``READABLE`` of the handful's largest torque (relative, as the tables' APMD weighs
    the low commands). The unchanged surface has one parameter, a common scale (to which the
    tables are blind).
    """
    out = np.full(torque.size, np.nan)
    for b in np.unique(position):
        test = position == b
        x, g = model.fit(name, position[~test], pulse_width[~test], torque[~test])
        out[test] = model.predict(x, g, position[test], pulse_width[test], name=name)
    use = torque > READABLE * float(np.max(torque))
    return float(np.mean(np.abs(torque[use] - out[use]) / torque[use]))


def phase_shares(
    position: NDArray[np.float64],
    ramp: NDArray[np.float64],
    equilibrium: NDArray[np.float64],
    period: int,
) -> NDArray[np.float64]:
    """Each phase's share of the torque at ``position``: ramp proportion times its torque shape.

    The shape is the fundamental of a phase's torque, ``max(sin(2 pi (e_k - p) / P), 0)``,
    positive ahead of the phase's equilibrium; the shares sum to 1 (equal where all vanish).

    Returns
    -------
    ndarray
        Shape (len(position), m).
    """
    p = np.asarray(position, dtype=np.float64)
    r = ramp[np.rint(p).astype(np.int64) % period]
    shape = np.maximum(np.sin(2.0 * np.pi * (equilibrium[None, :] - p[:, None]) / period), 0.0)
    w = r * shape
    total = w.sum(axis=1, keepdims=True)
    m = ramp.shape[1]
    out: NDArray[np.float64] = np.where(total > 0, w / np.where(total > 0, total, 1.0), 1.0 / m)
    return out
