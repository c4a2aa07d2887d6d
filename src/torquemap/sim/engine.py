"""The time-stepping core of the SCARA simulator: servo ticks and physics substeps.

Each servo tick (``1 / servo_rate``) the controller reads the quantised encoders, estimates the
velocity, and commands a current; the drive holds it (plus its ripple) until the next tick. In
between, the rigid-body dynamics are integrated in ``substeps`` steps: velocity implicit in the
friction (two Newton steps on the piecewise friction law, so the steep blend through zero
velocity is stable), position by the trapezoidal rule. The loop is scalar ``math`` on purpose
(a 2 x 2 system per step is far below numpy's per-call overhead).

Per tick it records the true state at the tick and the torques acting over it, plus an energy
ledger (friction dissipation) for the energy-balance test.

A LuGre axis (:mod:`torquemap.sim.lugre`) takes its bristle step inside the same implicit
velocity step (backward Euler); Newton then iterates to convergence rather than to a fixed
piece of the law. Directional PDTV lines act with the weight of
:func:`torquemap.sim.scara.direction_gate` at the velocity at the start of each substep.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.sim.lugre import lugre_constants, lugre_update
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
        Work done against friction from the start to the tick [J], shape (n,): the energy
        dissipated, plus, for a LuGre axis, the energy its bristles hold.
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


def _stribeck(w: float, vs: float, exponent: float) -> tuple[float, float]:
    """``exp(-|w / vs|**exponent)`` and its derivative in ``w``."""
    x = abs(w / vs)
    if x == 0.0:
        return 1.0, 0.0
    s = math.exp(-(x**exponent))
    return s, -exponent * x ** (exponent - 1.0) / vs * s * (1.0 if w > 0 else -1.0)


StaticConstants = tuple[float, float, float, float, float, float, float, float, float, float]


def _static_constants(f: Friction) -> StaticConstants:
    return (
        *f.direction_parameters(1),
        *f.direction_parameters(-1),
        f.zero_velocity,
        f.stribeck_exponent,
    )


def _friction_general(w: float, c: StaticConstants) -> tuple[float, float, int]:
    """:func:`_friction` for a static law of another form (exponent, per-direction terms)."""
    cp, sp, vsp, vp, cn, sn, vsn, vn, w0, p = c
    if w > w0:
        s, ds = _stribeck(w, vsp, p)
        return cp + sp * s + vp * w, sp * ds + vp, 1
    if w < -w0:
        s, ds = _stribeck(w, vsn, p)
        return -cn - sn * s + vn * w, -sn * ds + vn, -1
    s_p, ds_p = _stribeck(w, vsp, p)
    s_n, ds_n = _stribeck(w, vsn, p)
    pos = cp + sp * s_p + vp * w
    neg = -cn - sn * s_n + vn * w
    blend = (w + w0) / (2.0 * w0)
    value = blend * pos + (1.0 - blend) * neg
    slope = (pos - neg) / (2.0 * w0) + blend * (sp * ds_p + vp) + (1.0 - blend) * (-sn * ds_n + vn)
    return value, slope, 0


def _friction(w: float, f: Friction) -> tuple[float, float, int]:
    """Friction torque, its slope d/dw, and the piece (-1, 0, +1) of the static law at ``w``."""
    if not f.is_paper_law:
        return _friction_general(w, _static_constants(f))
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
    ha = [(h.order, h.amplitude, h.phase) for h in ax_a.pdtv if h.direction == "both"]
    hb = [(h.order, h.amplitude, h.phase) for h in ax_b.pdtv if h.direction == "both"]
    # directional lines: (order, amplitude, phase, sign of the direction)
    hda = [
        (h.order, h.amplitude, h.phase, 1.0 if h.direction == "positive" else -1.0)
        for h in ax_a.pdtv
        if h.direction != "both"
    ]
    hdb = [
        (h.order, h.amplitude, h.phase, 1.0 if h.direction == "positive" else -1.0)
        for h in ax_b.pdtv
        if h.direction != "both"
    ]
    gate_a, gate_b = fa.zero_velocity, fb.zero_velocity
    lugre_a, lugre_b = fa.lugre is not None, fb.lugre is not None
    dynamic = lugre_a or lugre_b
    za = zb = 0.0  # bristle deflections [rad, motor side]
    last_fa = last_fb = 0.0  # LuGre torque over the last substep
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

    def pdtv_dir(
        theta: float, w: float, lines: list[tuple[float, float, float, float]], width: float
    ) -> float:
        total = 0.0
        for order, amp, ph, sign in lines:
            gate = min(max(sign * w / width, 0.0), 1.0)
            if gate > 0.0:
                total += gate * amp * math.cos(order * theta + ph)
        return total

    def static(f: Friction) -> Callable[[float], tuple[float, float, int]]:
        """``w -> (torque, slope, piece)`` of a static law."""
        if f.is_paper_law:
            return lambda w: _friction(w, f)
        cs = _static_constants(f)
        return lambda w: _friction_general(w, cs)

    def law(f: Friction) -> Callable[[float, float], tuple[float, float, float]]:
        """``(w, z) -> (torque, slope, new deflection)`` of one axis over a substep."""
        if f.lugre is not None:
            c = lugre_constants(f)
            return lambda w, z: lugre_update(z, w, dt, c)
        st = static(f)

        def out(w: float, z: float) -> tuple[float, float, float]:
            value, slope, _ = st(w)
            return value, slope, z

        return out

    static_a, static_b = static(fa), static(fb)
    fric_a, fric_b = law(fa), law(fb)

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
        rec_f[k, 0] = last_fa if lugre_a else static_a(na * v1)[0]
        rec_f[k, 1] = last_fb if lugre_b else static_b(nb * v2)[0]
        rec_p[k, 0] = pdtv(theta_a, ha)
        rec_p[k, 1] = pdtv(theta_b, hb)
        if hda:
            rec_p[k, 0] += pdtv_dir(theta_a, na * v1, hda, gate_a)
        if hdb:
            rec_p[k, 1] += pdtv_dir(theta_b, nb * v2, hdb, gate_b)
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
            pa = pdtv(na * q1, ha)
            pb = pdtv(nb * q2, hb)
            if hda:
                pa += pdtv_dir(na * q1, na * v1, hda, gate_a)
            if hdb:
                pb += pdtv_dir(nb * q2, nb * v2, hdb, gate_b)
            g1 = na * (tm_a - pa) + te1 + h * (2.0 * v1 * v2 + v2 * v2)
            g2 = nb * (tm_b - pb) + te2 - h * v1 * v1
            # Newton on M x = dt (g - n f(n (v + x))), x the velocity change.
            x1 = x2 = 0.0
            if dynamic:
                # A LuGre axis: iterate to convergence, then apply the law at the final speed.
                for _it in range(12):
                    f1, s1, _ = fric_a(na * (v1 + x1), za)
                    f2, s2, _ = fric_b(nb * (v2 + x2), zb)
                    r1 = m11 * x1 + m12 * x2 - dt * (g1 - na * f1)
                    r2 = m12 * x1 + m22 * x2 - dt * (g2 - nb * f2)
                    a11 = m11 + dt * na * na * s1
                    a22 = m22 + dt * nb * nb * s2
                    det = a11 * a22 - m12 * m12
                    d1 = (a22 * r1 - m12 * r2) / det
                    d2 = (a11 * r2 - m12 * r1) / det
                    x1 -= d1
                    x2 -= d2
                    if abs(d1) + abs(d2) <= 1e-12 * (1.0 + abs(v1 + x1) + abs(v2 + x2)):
                        break
                nv1, nv2 = v1 + x1, v2 + x2
                fe1, _, za = fric_a(na * nv1, za)
                fe2, _, zb = fric_b(nb * nv2, zb)
                last_fa, last_fb = fe1, fe2
                dq1 = 0.5 * dt * (v1 + nv1)
                dq2 = 0.5 * dt * (v2 + nv2)
                work += na * fe1 * dq1 + nb * fe2 * dq2
                q1 += dq1
                q2 += dq2
                v1, v2 = nv1, nv2
                continue
            pieces = None
            for _it in range(3):
                f1, s1, p1 = static_a(na * (v1 + x1))
                f2, s2, p2 = static_b(nb * (v2 + x2))
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
