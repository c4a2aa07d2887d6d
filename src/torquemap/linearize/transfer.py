"""Tables for a second joint of the same motor type from a handful of measurements (§6.2).

The Adept II paper (§6.2) suggests collecting "a handful of characteristic parameters from a new
motor (e.g., phase equilibrium positions, and the torques at the middle of the three transition
regions and at the middle of the single phase regions)" and applying them "to modify the
existing data of the same motor type by means of systematic scaling". Here the scaling is:

``T2(p, w) = a(p) T1(p + s(p), v(w))``

* ``T1`` is the first joint's torque surface: its full characterisation, denoised
  (:func:`torquemap.linearize.denoise.denoise_blocks`), averaged per (position, pulse width)
  cell, made monotone in pulse width and interpolated linearly in pulse width and (cyclically)
  in position.
* ``s(p)`` registers the phases: the first joint's equilibria minus the second's (both motor
  files), weighted by the phases' shares.
* ``v(w) = alpha + W (beta u + gamma u (1 - u))``, ``u = w / W``, absorbs the amplifiers'
  differences (dead band, gain, curve), common to every phase and position.
* ``a(p) = sum_k g_k w_k(p)`` is the torque ratio: one gain per phase, weighted by each phase's
  share of the torque at ``p`` (:func:`phase_shares`); ``s(p)`` likewise weighs the phases'
  equilibrium shifts.

The handful is ordinary collection data (``position, pulse_width, torque``) of the second joint
at a few positions and pulse widths (``2 m`` targets, pulse widths every 64): with the standard
ramps the ``2 m`` evenly spaced targets are the middles of the single-phase and transition
regions, the paper's suggestion. The phase gains are a linear least-squares fit for given
``alpha, beta, gamma``; the three are found by minimising the profile residual within bounds
(``|alpha| <= 0.15 W``, ``0.8 <= beta <= 1.25``, ``|gamma| <= 0.3``) with a weak prior towards
the first joint's amplifier (where torque is linear in current, gain and pulse-width scale
trade off).

The result is the first joint's rows, re-scaled: DATA.csv for the second joint, which
:func:`torquemap.linearize.tables.build_tables` turns into tables like any other.

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

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
        First joint's equilibrium minus the second's, per phase [table positions], shape (m,).
    residual
        RMS misfit of the handful after the fit, relative to its RMS torque.
    residual_unchanged
        The same for the first joint's surface taken unchanged (``a = 1``, ``alpha = 0``,
        ``beta = 1``, no registration).
    measurements
        Rows of the handful used.
    warnings
        One line each: the transferred surface misfits the handful more than the first
        joint's taken unchanged (the scaling does not describe the second joint: its motor
        file's equilibria, or a handful of another joint).
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
        w = np.clip(pulse_width, self.levels[0], self.levels[-1])
        j = np.clip(np.searchsorted(self.levels, w, side="right") - 1, 0, self.levels.size - 2)
        fw = (w - self.levels[j]) / (self.levels[j + 1] - self.levels[j])
        knots = np.concatenate([self.positions, [self.positions[0] + self.period]])
        p = np.mod(position, self.period)
        p = np.where(p < knots[0], p + self.period, p)
        i = np.clip(np.searchsorted(knots, p, side="right") - 1, 0, knots.size - 2)
        fp = (p - knots[i]) / (knots[i + 1] - knots[i])
        i1 = (i + 1) % self.positions.size

        def at(r: NDArray[np.int64]) -> NDArray[np.float64]:
            out: NDArray[np.float64] = self.grid[r, j] * (1 - fw) + self.grid[r, j + 1] * fw
            return out

        result: NDArray[np.float64] = at(i) * (1 - fp) + at(i1) * fp
        return result


def transfer_characterisation(
    first_spec: MotorSpec,
    first: LinearizeData,
    second_spec: MotorSpec,
    few: LinearizeData,
) -> TransferResult:
    """Characterisation data for a second joint: the first joint's, scaled to a handful.

    Parameters
    ----------
    first_spec
        The first joint's motor file.
    first
        The first joint's full characterisation (DATA.csv rows, in collection order).
    second_spec
        The second joint's motor file (its equilibria register the phases); same phases,
        positions per cycle and full-scale pulse width as the first.
    few
        The second joint's handful: characterisation rows at a few positions (at least 2,
        better ``2 m``) and a few pulse widths (at least 2 above zero).

    Returns
    -------
    TransferResult
        The transferred rows and the fitted scaling.

    Raises
    ------
    InputError
        Motors of another type (phases, cycle, full scale), or a handful too small to fit.

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
    n = a_spec.positions_per_cycle
    blocks = np.unique(few.position)
    if blocks.size < 2 or np.unique(few.level[few.level > 0]).size < 2:
        raise InputError(
            "the handful needs at least 2 positions and 2 pulse widths above zero", path=few.path
        )
    surface = _Surface(a_spec, first)
    e1 = np.asarray(a_spec.equilibrium_positions, dtype=np.float64)
    e2 = np.asarray(b_spec.equilibrium_positions, dtype=np.float64)
    shift = circular_difference(e1, e2, n)
    ramp = np.asarray(b_spec.ramp, dtype=np.float64)

    def shares(p: NDArray[np.float64]) -> NDArray[np.float64]:
        """Each phase's share of the torque at positions ``p``, shape (len(p), m)."""
        return phase_shares(p, ramp, e2, n)

    pos = few.position.astype(np.float64)
    level = few.level.astype(np.float64)
    tau = few.torque
    w_few = shares(pos)
    p1 = pos + w_few @ shift

    def gains(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        t1 = surface(p1, warp(x, level))
        design = w_few * t1[:, None]
        g: NDArray[np.float64] = np.asarray(
            np.linalg.lstsq(design, tau, rcond=None)[0], dtype=np.float64
        )
        return g, tau - design @ g

    energy = float(np.sum(tau**2)) or 1.0

    def cost(x: NDArray[np.float64]) -> float:
        # a weak prior on the amplifier law: where the torque is linear in the current (BLDC),
        # a gain and a pulse-width scale trade off, and the plausible amplifier is the first's
        prior: float = PRIOR * energy * ((x[1] - 1.0) ** 2 + x[2] ** 2)
        return float(np.sum(gains(x)[1] ** 2)) + prior

    top = float(a_spec.actuation_max)

    def warp(x: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
        u = w / top
        out: NDArray[np.float64] = x[0] + top * (x[1] * u + x[2] * u * (1.0 - u))
        return out

    bounds = [(-0.15 * top, 0.15 * top), (0.8, 1.25), (-0.3, 0.3)]
    best = min(
        (
            minimize(cost, np.array([a0, 1.0, 0.0]), method="Nelder-Mead", bounds=bounds)
            for a0 in (-10.0, 0.0, 10.0)
        ),
        key=lambda r: float(r.fun),
    )
    x = np.asarray(best.x, dtype=np.float64)
    g, resid = gains(x)
    scale = float(np.sqrt(np.mean(tau**2))) or 1.0
    unchanged = tau - surface(pos, level)
    residual = float(np.sqrt(np.mean(resid**2))) / scale
    residual_unchanged = float(np.sqrt(np.mean(unchanged**2))) / scale
    warnings = []
    if residual > residual_unchanged:
        # the fit's family holds the unchanged surface only without registration: a worse fit
        # means the equilibria registered (the motor files) do not match the handful
        warnings.append(
            f"the transferred surface misfits the handful more than the first joint's taken "
            f"unchanged ({100 * residual:.1f} % against {100 * residual_unchanged:.1f} % RMS): "
            "the scaling does not describe this joint; are the second motor file's "
            "equilibrium positions this joint's, and the handful its rows?"
        )
    # the second joint's torque at the first joint's (position, pulse width) rows
    p_first = first.position.astype(np.float64)
    w_first = shares(p_first)
    t1 = surface(p_first + w_first @ shift, warp(x, first.level.astype(np.float64)))
    return TransferResult(
        position=first.position.copy(),
        pulse_width=first.level.copy(),
        torque=(w_first @ g) * t1,
        gain=g,
        pulse_offset=float(x[0]),
        pulse_scale=float(x[1]),
        pulse_curve=float(x[2]),
        position_shift=shift,
        residual=residual,
        residual_unchanged=residual_unchanged,
        measurements=int(tau.size),
        warnings=tuple(warnings),
    )


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
