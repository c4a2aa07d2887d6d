"""The time-stepping core of the SCARA simulator: servo ticks and physics substeps.

Each servo tick (``1 / servo_rate``) the controller reads the quantised encoders, estimates the
velocity, and commands a current; the drive holds it (plus its ripple) until the next tick. In
between, the rigid-body dynamics are integrated in ``substeps`` steps: velocity implicit in the
friction (two Newton steps on the piecewise friction law, so the steep blend through zero
velocity is stable), position by the trapezoidal rule. The loop is scalar ``math`` on purpose
(a 2 x 2 system per step is far below numpy's per-call overhead).

Per tick it records the true state at the tick and the torques acting over it, plus an energy
ledger (friction dissipation) for the energy-balance test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.sim.scara import Friction, ScaraBench, dynamics_constants, motor_inertia
from torquemap.sim.trajectory import Reference


@dataclass(frozen=True, slots=True, eq=False)
class EngineOutput:
    """What one simulated run records at each servo tick ``k`` (time ``t[k]``).

    Attributes
    ----------
    q, qd
        True joint angle [rad] and velocity [rad/s] at the tick, shape (n, 2).
    q_measured
        Encoder reading as joint angle [rad]: quantised motor angle / gear ratio, shape (n, 2).
    current
        Current applied from this tick to the next (command plus ripple) [A], shape (n, 2).
    current_measured
        ``current`` plus current-sensor noise [A], shape (n, 2).
    friction, pdtv
        Motor-side friction and PDTV torque at the tick's state [N m], shape (n, 2).
    force
        External force on the end effector at the tick [N], base frame, shape (n, 2).
    friction_work
        Energy dissipated by friction from the start to the tick [J], shape (n,).
    """

    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    q_measured: NDArray[np.float64]
    current: NDArray[np.float64]
    current_measured: NDArray[np.float64]
    friction: NDArray[np.float64]
    pdtv: NDArray[np.float64]
    force: NDArray[np.float64]
    friction_work: NDArray[np.float64]


def _friction(w: float, f: Friction) -> tuple[float, float, int]:
    """Friction torque, its slope d/dw, and the piece (-1, 0, +1) of the law at ``w``."""
    x = w / f.stribeck_velocity
    s = math.exp(-x * x)
    ds = -2.0 * x / f.stribeck_velocity * s
    w0 = f.zero_velocity
    if w > w0:
        return (
            f.coulomb_positive + f.stribeck_positive * s + f.viscous * w,
            f.stribeck_positive * ds + f.viscous,
            1,
        )
    if w < -w0:
        return (
            -f.coulomb_negative - f.stribeck_negative * s + f.viscous * w,
            -f.stribeck_negative * ds + f.viscous,
            -1,
        )
    pos = f.coulomb_positive + f.stribeck_positive * s
    neg = -f.coulomb_negative - f.stribeck_negative * s
    blend = (w + w0) / (2.0 * w0)
    value = blend * pos + (1.0 - blend) * neg + f.viscous * w
    slope = (
        (pos - neg) / (2.0 * w0)
        + blend * f.stribeck_positive * ds
        - (1.0 - blend) * f.stribeck_negative * ds
        + f.viscous
    )
    return value, slope, 0


def run_engine(
    bench: ScaraBench,
    reference: Reference,
    *,
    spring: bool,
    rng: np.random.Generator,
) -> EngineOutput:
    """Simulate the bench tracking ``reference``, from rest at its first sample.

    Parameters
    ----------
    bench
        Physical parameters.
    reference
        Joint-side reference at the servo rate.
    spring
        Whether the circle's spring acts on the end effector.
    rng
        Source of the current-sensor noise and the ripple phases.

    Returns
    -------
    EngineOutput
        Per-tick records.
    """
    n = reference.t.size
    ax_a, ax_b = bench.axes
    ctl = bench.controller
    dc = dynamics_constants(bench)
    alpha, beta, delta, delta_b = dc.alpha, dc.beta, dc.delta, dc.delta_b
    l1, l2 = bench.links.lengths
    na, nb = ax_a.gear_ratio, ax_b.gear_ratio
    kta, ktb = ax_a.torque_constant, ax_b.torque_constant
    fa, fb = ax_a.friction, ax_b.friction
    ha = [(h.order, h.amplitude, h.phase) for h in ax_a.pdtv]
    hb = [(h.order, h.amplitude, h.phase) for h in ax_b.pdtv]
    step_a = 2.0 * math.pi / ax_a.encoder_counts_per_rev
    step_b = 2.0 * math.pi / ax_b.encoder_counts_per_rev
    imax_a, imax_b = ax_a.max_current, ax_b.max_current

    period = 1.0 / ctl.servo_rate
    dt = period / ctl.substeps
    # Nominal motor-side inertia of the controller: the elbow-averaged diagonal.
    ja_nom, jb_nom = (float(v) for v in motor_inertia(bench, np.array(math.pi / 2)))
    wc = 2.0 * math.pi * ctl.bandwidth
    kpa, kpb = ja_nom * wc * wc, jb_nom * wc * wc
    kda, kdb = 2 * ctl.damping * ja_nom * wc, 2 * ctl.damping * jb_nom * wc
    vel_gain = 1.0 - math.exp(-2.0 * math.pi * ctl.velocity_cutoff * period)
    ff = ctl.friction_feedforward

    cx, cy = bench.circle.centre
    k_spring = bench.circle.spring_stiffness if spring else 0.0
    free_length = bench.circle.free_length

    noise = rng.standard_normal((n, 2)) * np.array([ax_a.current_noise, ax_b.current_noise])
    ripple_phase = rng.uniform(0.0, 2.0 * math.pi, size=2)
    tt = reference.t
    ripple = np.stack(
        [
            ax_a.ripple_amplitude
            * np.sin(2 * math.pi * ax_a.ripple_frequency * tt + ripple_phase[0]),
            ax_b.ripple_amplitude
            * np.sin(2 * math.pi * ax_b.ripple_frequency * tt + ripple_phase[1]),
        ],
        axis=-1,
    ).tolist()

    ref_q = reference.q.tolist()
    ref_qd = reference.qd.tolist()
    ref_qdd = reference.qdd.tolist()

    rec_q = np.empty((n, 2))
    rec_qd = np.empty((n, 2))
    rec_qm = np.empty((n, 2))
    rec_i = np.empty((n, 2))
    rec_f = np.empty((n, 2))
    rec_p = np.empty((n, 2))
    rec_force = np.empty((n, 2))
    rec_work = np.empty(n)

    q1, q2 = ref_q[0]
    v1 = v2 = 0.0
    west_a = west_b = 0.0
    prev_a = math.floor(na * q1 / step_a) * step_a
    prev_b = math.floor(nb * q2 / step_b) * step_b
    work = 0.0

    def pdtv(theta: float, lines: list[tuple[float, float, float]]) -> float:
        total = 0.0
        for order, amp, ph in lines:
            total += amp * math.cos(order * theta + ph)
        return total

    def external(q1: float, q2: float) -> tuple[float, float, float, float]:
        """Spring force (fx, fy) and its joint torques J^T F at (q1, q2)."""
        if k_spring == 0.0:
            return 0.0, 0.0, 0.0, 0.0
        x2 = l2 * math.cos(q1 + q2)
        y2 = l2 * math.sin(q1 + q2)
        x = l1 * math.cos(q1) + x2
        y = l1 * math.sin(q1) + y2
        dx, dy = x - cx, y - cy
        length = math.hypot(dx, dy)
        scale = -k_spring * (length - free_length) / length
        fx, fy = scale * dx, scale * dy
        return fx, fy, x * fy - y * fx, x2 * fy - y2 * fx

    for k in range(n):
        # -- sensors and controller at the tick
        theta_a = na * q1
        theta_b = nb * q2
        meas_a = math.floor(theta_a / step_a) * step_a
        meas_b = math.floor(theta_b / step_b) * step_b
        west_a += vel_gain * ((meas_a - prev_a) / period - west_a)
        west_b += vel_gain * ((meas_b - prev_b) / period - west_b)
        prev_a, prev_b = meas_a, meas_b
        rq1, rq2 = ref_q[k]
        rv1, rv2 = ref_qd[k]
        ra1, ra2 = ref_qdd[k]
        wra, wrb = na * rv1, nb * rv2
        cmd_a = (
            ja_nom * na * ra1
            + ff
            * (
                fa.viscous * wra
                + math.tanh(wra / fa.zero_velocity)
                * (fa.coulomb_positive if wra > 0 else fa.coulomb_negative)
            )
            + kpa * (na * rq1 - meas_a)
            + kda * (wra - west_a)
        ) / kta
        cmd_b = (
            jb_nom * nb * ra2
            + ff
            * (
                fb.viscous * wrb
                + math.tanh(wrb / fb.zero_velocity)
                * (fb.coulomb_positive if wrb > 0 else fb.coulomb_negative)
            )
            + kpb * (nb * rq2 - meas_b)
            + kdb * (wrb - west_b)
        ) / ktb
        cmd_a = min(max(cmd_a, -imax_a), imax_a)
        cmd_b = min(max(cmd_b, -imax_b), imax_b)
        rip_a, rip_b = ripple[k]
        cur_a = cmd_a + rip_a
        cur_b = cmd_b + rip_b
        tm_a = kta * cur_a
        tm_b = ktb * cur_b

        fx, fy, te1, te2 = external(q1, q2)
        rec_q[k, 0] = q1
        rec_q[k, 1] = q2
        rec_qd[k, 0] = v1
        rec_qd[k, 1] = v2
        rec_qm[k, 0] = meas_a / na
        rec_qm[k, 1] = meas_b / nb
        rec_i[k, 0] = cur_a
        rec_i[k, 1] = cur_b
        rec_f[k, 0] = _friction(na * v1, fa)[0]
        rec_f[k, 1] = _friction(nb * v2, fb)[0]
        rec_p[k, 0] = pdtv(theta_a, ha)
        rec_p[k, 1] = pdtv(theta_b, hb)
        rec_force[k, 0] = fx
        rec_force[k, 1] = fy
        rec_work[k] = work

        # -- physics over the servo period
        for _ in range(ctl.substeps):
            c2 = math.cos(q2)
            m11 = alpha + 2.0 * beta * c2
            m12 = delta + beta * c2
            m22 = delta_b
            h = beta * math.sin(q2)
            _, _, te1, te2 = external(q1, q2)
            g1 = na * (tm_a - pdtv(na * q1, ha)) + te1 + h * (2.0 * v1 * v2 + v2 * v2)
            g2 = nb * (tm_b - pdtv(nb * q2, hb)) + te2 - h * v1 * v1
            # Newton on M x = dt (g - n f(n (v + x))), x the velocity change.
            x1 = x2 = 0.0
            pieces = None
            for _it in range(3):
                f1, s1, p1 = _friction(na * (v1 + x1), fa)
                f2, s2, p2 = _friction(nb * (v2 + x2), fb)
                if pieces == (p1, p2):
                    break
                pieces = (p1, p2)
                r1 = m11 * x1 + m12 * x2 - dt * (g1 - na * f1)
                r2 = m12 * x1 + m22 * x2 - dt * (g2 - nb * f2)
                a11 = m11 + dt * na * na * s1
                a22 = m22 + dt * nb * nb * s2
                det = a11 * a22 - m12 * m12
                d1 = (a22 * r1 - m12 * r2) / det
                d2 = (a11 * r2 - m12 * r1) / det
                # Friction actually applied: linearised about the last iterate.
                fe1 = f1 - s1 * na * d1
                fe2 = f2 - s2 * nb * d2
                x1 -= d1
                x2 -= d2
            nv1, nv2 = v1 + x1, v2 + x2
            dq1 = 0.5 * dt * (v1 + nv1)
            dq2 = 0.5 * dt * (v2 + nv2)
            work += na * fe1 * dq1 + nb * fe2 * dq2
            q1 += dq1
            q2 += dq2
            v1, v2 = nv1, nv2

    return EngineOutput(
        q=rec_q,
        qd=rec_qd,
        q_measured=rec_qm,
        current=rec_i,
        current_measured=rec_i + noise,
        friction=rec_f,
        pdtv=rec_p,
        force=rec_force,
        friction_work=rec_work,
    )
