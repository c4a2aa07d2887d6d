"""Figures of force estimation (Simpson, Cook & Li, Figs 3 and 5 to 8) and of an estimate.

- :func:`joint_torque_figure`: the joint torques an end-effector force implies, Eq 3 (Fig 3).
- Fig 4 is :func:`torquemap.plots.pdtv.spectrum_figure`.
- :func:`time_domain_figure`: one joint's estimation signal of Eq 7 and its low-pass (Figs 5, 6).
- :func:`position_domain_figure`: the low-passed signal of one joint as a discrete-position
  signal per monotonic pass, before and after the PDTV notches (Figs 7, 8).
- :func:`estimate_figure`: external torques and forces against time, with a reference if known.

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from torquemap.estimate import ForceEstimate
from torquemap.pdtv import bins_per_revolution, discrete_position_signal
from torquemap.plots.pdtv import save_figure

__all__ = [
    "estimate_figure",
    "joint_torque_figure",
    "position_domain_figure",
    "save_figure",
    "time_domain_figure",
]

TWO_PI = 2.0 * np.pi


def joint_torque_figure(
    t: NDArray[np.float64],
    tau_ext: NDArray[np.float64],
    joint_names: Sequence[str],
    *,
    title: str = "Joint torques from the end-effector force (Eq 3)",
) -> Figure:
    """Joint-side external torques [N m] against time [s], one panel per joint (paper Fig 3)."""
    fig = Figure(figsize=(8.0, 2.2 * len(joint_names) + 0.6), layout="constrained")
    axes = fig.subplots(len(joint_names), 1, sharex=True, squeeze=False)[:, 0]
    for k, (ax, name) in enumerate(zip(axes, joint_names, strict=True)):
        ax.plot(t, tau_ext[:, k], color="k", lw=1.2)
        ax.set_ylabel(f"tau_ext_{name} [N m]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    return fig


def _motor_reference(
    est: ForceEstimate, joint: int, reference_tau_ext: NDArray[np.float64] | None, gear: float
) -> NDArray[np.float64] | None:
    if reference_tau_ext is None:
        return None
    out: NDArray[np.float64] = -reference_tau_ext[:, joint] / gear
    return out


def time_domain_figure(
    est: ForceEstimate,
    joint: int,
    *,
    gear_ratio: float,
    reference_tau_ext: NDArray[np.float64] | None = None,
) -> Figure:
    """Eq 7's estimation signal (top) and its time-domain low-pass (bottom) for one joint.

    Motor side [N m]. ``reference_tau_ext`` (joint side, shape (n, nj)) is drawn as the motor
    torque it demands, ``-tau_ext / gear_ratio`` (the dark line of the paper's Figs 5 and 6).
    """
    name = est.joint_names[joint]
    ref = _motor_reference(est, joint, reference_tau_ext, gear_ratio)
    fig = Figure(figsize=(8.0, 5.0), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(est.t, est.t_est[:, joint], color="0.65", lw=0.5, label="T_est (Eq 7)")
    bottom.plot(est.t, est.filtered[:, joint], color="tab:blue", lw=0.8, label="low-passed")
    for ax in (top, bottom):
        if ref is not None:
            ax.plot(est.t, ref, color="k", lw=1.2, label="external load (reference)")
        ax.set_ylabel("motor torque [N m]")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    bottom.set_xlabel("time [s]")
    lo = np.percentile(est.filtered[:, joint], 0.5)
    hi = np.percentile(est.filtered[:, joint], 99.5)
    pad = 0.5 * (hi - lo) + 1e-9
    top.set_ylim(lo - pad, hi + pad)
    fig.suptitle(f"Joint {name}: time-domain force estimation signal")
    return fig


def position_domain_figure(
    est: ForceEstimate,
    joint: int,
    *,
    gear_ratio: float,
    reference_tau_ext: NDArray[np.float64] | None = None,
) -> Figure:
    """Discrete-position signal per monotonic pass, before (top) and after (bottom) processing.

    Top: the low-passed estimation signal binned over the motor angle [rad]; bottom: the
    method's output (after the PDTV notches for ``paper``, after subtracting the PDTV model for
    ``model``), both motor side [N m] (the paper's Figs 7 and 8).
    """
    name = est.joint_names[joint]
    ref = _motor_reference(est, joint, reference_tau_ext, gear_ratio)
    fig = Figure(figsize=(8.0, 5.0), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    passes = est.passes[joint]
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")
    for i, p in enumerate(passes):
        sl = slice(p.start, p.stop)
        theta = est.motor_angle[sl, joint]
        bins = max(bins_per_revolution((p.stop - p.start) / p.revolutions), 4)
        bw = TWO_PI / bins
        c = colours[i % len(colours)]
        label = f"pass {i + 1} ({'+' if p.direction > 0 else '-'})"
        before = discrete_position_signal(theta, est.filtered[sl, joint], bin_width=bw)
        after = discrete_position_signal(theta, est.motor_external[sl, joint], bin_width=bw)
        top.plot(before.angle, before.value, color=c, lw=0.6, label=label)
        bottom.plot(after.angle, after.value, color=c, lw=0.8)
        if ref is not None:
            r = discrete_position_signal(theta, ref[sl], bin_width=bw)
            for ax in (top, bottom):
                ax.plot(r.angle, r.value, color="k", lw=1.0)
    top.set_title("low-passed, in the position domain")
    bottom.set_title(f"after PDTV removal ({est.method})")
    for ax in (top, bottom):
        ax.set_ylabel("motor torque [N m]")
        ax.grid(alpha=0.3)
    if passes:
        top.legend(loc="upper right", fontsize=7, ncols=2)
    bottom.set_xlabel("motor angle [rad]")
    fig.suptitle(f"Joint {name}: position-domain force estimation signal")
    return fig


def estimate_figure(
    est: ForceEstimate,
    *,
    reference_tau_ext: NDArray[np.float64] | None = None,
    reference_force: NDArray[np.float64] | None = None,
) -> Figure:
    """External joint torques and (planar2r) force components against time.

    Flagged samples are shaded; references (for example a simulator's truth) drawn in black.
    """
    nj = len(est.joint_names)
    rows = nj + (2 if est.force is not None else 0)
    fig = Figure(figsize=(8.0, 1.8 * rows + 0.6), layout="constrained")
    axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    flagged = est.flag != 0
    series: list[tuple[str, NDArray[np.float64], NDArray[np.float64] | None]] = []
    for k, name in enumerate(est.joint_names):
        ref = None if reference_tau_ext is None else reference_tau_ext[:, k]
        series.append((f"tau_ext_{name} [N m]", est.tau_ext[:, k], ref))
    if est.force is not None:
        for k, comp in enumerate(("fx", "fy")):
            ref = None if reference_force is None else reference_force[:, k]
            series.append((f"{comp} [N]", est.force[:, k], ref))
    for ax, (label, y, ref) in zip(axes, series, strict=True):
        ax.plot(est.t, y, color="tab:blue", lw=0.7, label=est.method)
        if ref is not None:
            ax.plot(est.t, ref, color="k", lw=1.0, label="reference")
        if flagged.any():
            ax.fill_between(
                est.t,
                0,
                1,
                where=flagged,
                color="0.85",
                transform=ax.get_xaxis_transform(),
                label="flagged",
            )
        ok = ~flagged & np.isfinite(y)
        if ok.any():
            lo, hi = np.percentile(y[ok], [0.5, 99.5])
            pad = 0.15 * (hi - lo) + 1e-9
            ax.set_ylim(lo - pad, hi + pad)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"Estimated external torques and forces ({est.method} method)")
    return fig
