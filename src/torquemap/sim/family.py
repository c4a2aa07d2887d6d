"""A family of simulated SCARA benches: robots and logs drawn at random from wide ranges.

``torquemap simulate scara --random SEED`` writes one of them. Each draws, within the ranges of
:data:`RANGES`: gear ratios, torque constants, rotor inertias, link lengths and masses; per axis
a friction law, often of another form than the one identification fits (a LuGre bristle model,
a Stribeck exponent other than 2, viscous friction and Stribeck velocity that differ between the
directions, on top of per-direction Coulomb and Stribeck levels); PDTV orders and amplitudes,
directional lines included; the servo's gains; the current noise and ripple; a log rate with
jitter, occasional gaps, and a delay of the current channel; the sweeps' speeds, revolutions and
acceleration; and the circle's place, radius, speed and spring force. The draw is a function of
the seed alone, and every bench it gives keeps the circle clear of the elbow singularities.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from torquemap.errors import InputError
from torquemap.sim.scara import (
    Axis,
    Circle,
    Controller,
    Friction,
    Harmonic,
    Links,
    Logging,
    Lugre,
    ScaraBench,
    Sweep,
    motor_inertia,
)
from torquemap.sim.trajectory import circle_reference

Range = tuple[float, float]


@dataclass(frozen=True, slots=True, eq=False)
class Ranges:
    """The ranges a random bench is drawn from (motor side unless said otherwise).

    Attributes
    ----------
    gear_ratio
        [-], log-uniform.
    torque_constant
        [N m / A], log-uniform.
    rotor_inertia
        [kg m^2], log-uniform.
    link_length
        ``l1`` [m]; ``l2`` is ``l1`` times ``link_ratio``.
    link_ratio
        ``l2 / l1`` [-].
    coulomb
        Coulomb level of the positive direction [N m], log-uniform; the negative one is it
        times ``asymmetry``.
    asymmetry
        Ratio of a negative-direction term to its positive-direction one [-].
    stribeck_fraction
        Stribeck level as a fraction of the Coulomb level, per direction [-].
    stribeck_velocity
        [rad/s], log-uniform.
    stribeck_exponent
        Exponent of a law "of another exponent" [-] (2 excluded: drawn below 1.6 or above 2.5).
    viscous
        [N m s / rad], log-uniform.
    zero_velocity
        Half width of the static laws' blend through zero [rad/s].
    presliding
        Bristle deflection at the Coulomb level, ``coulomb / bristle_stiffness`` [rad].
    pdtv_fraction
        Amplitude of a PDTV line as a fraction of the Coulomb level [-].
    current_delay
        Delay of the current channel [s].
    log_rate
        [Hz], log-uniform.
    log_jitter
        Poll jitter, fraction of the log period [-].
    gap_duration
        [s].
    slowest_speed
        Slowest sweep speed [rad/s], log-uniform; the fastest is the circle's fastest motor
        speed times ``fastest_margin``.
    fastest_margin
        [-].
    circle_radius
        [m].
    circle_speed
        Angular speed about the circle's centre [rad/s].
    spring_force
        [N].
    bandwidth
        Position-loop bandwidth [Hz].
    torque_noise
        Current-sensor noise times the torque constant [N m].
    """

    gear_ratio: Range = (30.0, 160.0)
    torque_constant: Range = (0.03, 0.3)
    rotor_inertia: Range = (2e-5, 3e-4)
    link_length: Range = (0.15, 0.40)
    link_ratio: Range = (0.6, 1.0)
    coulomb: Range = (0.01, 0.12)
    asymmetry: Range = (0.7, 1.4)
    stribeck_fraction: Range = (0.0, 0.6)
    stribeck_velocity: Range = (0.2, 5.0)
    stribeck_exponent: Range = (0.6, 3.0)
    viscous: Range = (5e-5, 1e-3)
    zero_velocity: Range = (0.01, 0.08)
    presliding: Range = (2e-3, 2e-2)
    pdtv_fraction: Range = (0.02, 0.4)
    current_delay: Range = (0.0, 0.15)
    log_rate: Range = (250.0, 4000.0)
    log_jitter: Range = (0.0, 0.3)
    gap_duration: Range = (0.01, 0.1)
    slowest_speed: Range = (0.4, 8.0)
    fastest_margin: Range = (1.0, 1.5)
    circle_radius: Range = (0.05, 0.15)
    circle_speed: Range = (0.2, 1.0)
    spring_force: Range = (2.0, 20.0)
    bandwidth: Range = (8.0, 25.0)
    torque_noise: Range = (5e-4, 4e-3)


#: The ranges of :func:`random_bench`.
RANGES = Ranges()

#: Encoder counts per motor revolution a random axis draws from: an ODrive-style 8192 up to
#: 20-bit absolute encoders. Coarser ones (2000 lines) let the servo's quantised velocity
#: estimate chatter the current by a fair share of the friction, and the oracle's error on the
#: circle grows to ~10 % of the spring force: the family would measure the servo, not the
#: estimator.
ENCODERS = (8192, 16384, 65536, 131072, 1048576)

#: Least ``|sin q_b|`` on a random bench's circle (the elbow stays clear of its singularities).
MIN_SIN_ELBOW = 0.4

#: Friction laws a random axis draws from, with their probabilities: the form identification
#: fits (Gaussian Stribeck, per-direction Coulomb and Stribeck levels), a static law of another
#: form, and the LuGre bristle model.
LAWS = (("paper", 0.2), ("static", 0.4), ("lugre", 0.4))


def _uniform(rng: np.random.Generator, r: Range) -> float:
    return float(rng.uniform(r[0], r[1]))


def _log_uniform(rng: np.random.Generator, r: Range) -> float:
    return float(math.exp(rng.uniform(math.log(r[0]), math.log(r[1]))))


def _exponent(rng: np.random.Generator) -> float:
    lo, hi = RANGES.stribeck_exponent
    if rng.uniform() < 0.7:
        return float(rng.uniform(lo, 1.6))
    return float(rng.uniform(2.5, hi))


def _friction(rng: np.random.Generator, inertia: float) -> Friction:
    law = str(rng.choice([name for name, _ in LAWS], p=[p for _, p in LAWS]))
    cp = _log_uniform(rng, RANGES.coulomb)
    cn = cp * _uniform(rng, RANGES.asymmetry)
    sp = cp * _uniform(rng, RANGES.stribeck_fraction)
    sn = cn * _uniform(rng, RANGES.stribeck_fraction)
    vs = _log_uniform(rng, RANGES.stribeck_velocity)
    viscous = _log_uniform(rng, RANGES.viscous)
    w0 = _uniform(rng, RANGES.zero_velocity)
    base = Friction(cp, cn, viscous, sp, sn, stribeck_velocity=vs, zero_velocity=w0)
    if law == "paper":
        return base
    exponent = _exponent(rng) if (law == "static" or rng.uniform() < 0.5) else 2.0
    visc_neg = viscous * _uniform(rng, RANGES.asymmetry) if rng.uniform() < 0.6 else None
    vs_neg = vs * _uniform(rng, RANGES.asymmetry) if rng.uniform() < 0.5 else None
    lugre = None
    if law == "lugre":
        s0 = max(cp, cn) / _log_uniform(rng, RANGES.presliding)
        s1 = 2.0 * _uniform(rng, (0.2, 1.0)) * math.sqrt(s0 * inertia)
        # Olsson et al.'s passivity bound with a margin of 4.6: s1 * vd <= 2 min(g).
        vd = min(_uniform(rng, (0.5, 3.0)), 2.0 * min(cp, cn) / s1)
        lugre = Lugre(bristle_stiffness=s0, bristle_damping=s1, damping_velocity=vd)
    if law == "static" and exponent == 2.0:
        exponent = _exponent(rng)
    return dataclasses.replace(
        base,
        stribeck_exponent=exponent,
        viscous_negative=visc_neg,
        stribeck_velocity_negative=vs_neg,
        lugre=lugre,
    )


def _pdtv(rng: np.random.Generator, coulomb: float) -> tuple[Harmonic, ...]:
    lo, hi = RANGES.pdtv_fraction

    def line(order: float, top: float, direction: str = "both") -> Harmonic:
        amp = coulomb * float(rng.uniform(lo, top))
        return Harmonic(order, amp, float(rng.uniform(-math.pi, math.pi)), direction)

    lines = [line(1.0, 0.1)]
    lines.append(line(2.0, hi if rng.uniform() < 0.7 else 0.15))
    if rng.uniform() < 0.5:
        lines.append(line(3.0, 0.1))
    if rng.uniform() < 0.5:
        lines.append(line(4.0, 0.15))
    cogging = float(rng.integers(6, 41))
    lines.append(line(cogging, 0.15))
    if rng.uniform() < 0.4:
        lines.append(line(float(rng.integers(41, 81)), 0.1))
    if rng.uniform() < 0.5:
        order = float(rng.choice([1.0, 2.0, 4.0, cogging]))
        direction = "positive" if rng.uniform() < 0.5 else "negative"
        lines.append(line(order, 0.15, direction))
    return tuple(lines)


def _circle(rng: np.random.Generator, l1: float, l2: float) -> Circle:
    c = math.sqrt(1.0 - MIN_SIN_ELBOW**2) - 0.02  # |cos q_b| bound, with a margin
    rho_lo = math.sqrt(l1 * l1 + l2 * l2 - 2 * l1 * l2 * c)
    rho_hi = math.sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * c)
    radius = min(_uniform(rng, RANGES.circle_radius), 0.45 * (rho_hi - rho_lo))
    distance = float(rng.uniform(rho_lo + radius, rho_hi - radius))
    heading = float(rng.uniform(math.pi / 4, 3 * math.pi / 4))
    force = _uniform(rng, RANGES.spring_force)
    stretch = radius * float(rng.uniform(0.2, 0.8))
    return Circle(
        centre=(distance * math.cos(heading), distance * math.sin(heading)),
        radius=radius,
        angular_speed=_uniform(rng, RANGES.circle_speed),
        start_angle=float(rng.uniform(0.0, 2 * math.pi)),
        spring_force=force,
        spring_stiffness=force / stretch,
    )


def random_bench(seed: int) -> ScaraBench:
    """Draw a SCARA bench from the family's ranges (:data:`RANGES`).

    Parameters
    ----------
    seed
        >= 0; the bench is a function of the seed alone.

    Returns
    -------
    ScaraBench
        With ``random_seed = seed``.

    Raises
    ------
    ValueError
        On a negative seed.

    Examples
    --------
    >>> b = random_bench(3)
    >>> all(30 <= ax.gear_ratio <= 160 for ax in b.axes), b.random_seed
    (True, 3)
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng([seed, 12])
    l1 = _uniform(rng, RANGES.link_length)
    l2 = l1 * _uniform(rng, RANGES.link_ratio)
    m1 = _uniform(rng, (3.0, 8.0)) * l1 / 0.25
    m2 = _uniform(rng, (1.5, 4.0)) * l2 / 0.2
    lc1, lc2 = l1 * _uniform(rng, (0.35, 0.6)), l2 * _uniform(rng, (0.35, 0.6))
    links = Links(
        lengths=(l1, l2),
        masses=(m1, m2),
        centres_of_mass=(lc1, lc2),
        inertias=(m1 * l1 * l1 / 12 * _uniform(rng, (0.8, 1.5)), m2 * l2 * l2 / 12),
    )
    log_rate = _log_uniform(rng, RANGES.log_rate)
    fast_servo = log_rate > 2000.0
    controller = Controller(
        servo_rate=4000.0 if fast_servo else 2000.0,
        substeps=1 if fast_servo else 2,
        bandwidth=_uniform(rng, RANGES.bandwidth),
        damping=_uniform(rng, (0.6, 1.0)),
        friction_feedforward=_uniform(rng, (0.5, 1.0)),
    )
    axes = []
    for name in ("a", "b"):
        ratio = _log_uniform(rng, RANGES.gear_ratio)
        kt = _log_uniform(rng, RANGES.torque_constant)
        noise = _log_uniform(rng, RANGES.torque_noise) / kt
        axes.append(
            Axis(
                name=name,
                gear_ratio=ratio,
                torque_constant=kt,
                rotor_inertia=_log_uniform(rng, RANGES.rotor_inertia),
                friction=Friction(0.0, 0.0, 0.0, 0.0, 0.0),  # drawn below, with the inertia
                pdtv=(),
                encoder_counts_per_rev=int(rng.choice(ENCODERS)),
                current_noise=noise,
                ripple_amplitude=noise * float(rng.uniform(0.0, 1.5)),
                ripple_frequency=float(rng.uniform(100.0, 400.0)),
                max_current=100.0,
            )
        )
    bench = ScaraBench(
        links=links,
        axes=(axes[0], axes[1]),
        controller=controller,
        name=f"random SCARA {seed} (torquemap simulate scara --random {seed})",
        random_seed=seed,
    )
    inertia = motor_inertia(bench, np.array(math.pi / 2))
    drawn = []
    for k, ax in enumerate(bench.axes):
        friction = _friction(rng, float(inertia[k]))
        drawn.append(
            dataclasses.replace(ax, friction=friction, pdtv=_pdtv(rng, friction.coulomb_positive))
        )
    bench = dataclasses.replace(bench, axes=(drawn[0], drawn[1]))
    circle = _circle(rng, l1, l2)
    bench = dataclasses.replace(bench, circle=circle)
    # The circle's joint motion, sampled at 200 Hz (enough for its peak speed and elbow range).
    coarse = dataclasses.replace(bench.controller, servo_rate=200.0)
    ref = circle_reference(dataclasses.replace(bench, controller=coarse))
    ratios = np.array([ax.gear_ratio for ax in bench.axes])
    peak = float(np.max(np.abs(ref.qd) * ratios))
    fastest = peak * _uniform(rng, RANGES.fastest_margin)
    slowest = min(_log_uniform(rng, RANGES.slowest_speed), fastest / 4)
    count = int(rng.integers(3, 7))
    speeds = tuple(float(v) for v in np.geomspace(slowest, fastest, count))
    revolutions = _uniform(rng, (2.0, 3.0))
    acceleration = max(_log_uniform(rng, (50.0, 400.0)), fastest**2 / (4 * math.pi))
    qb = ref.q[:, 1]
    elbows = np.sort(rng.uniform(qb.min(), qb.max(), size=3))
    sweep = Sweep(
        speeds=speeds,
        revolutions=revolutions,
        acceleration=acceleration,
        elbow_angles=tuple(float(e) for e in elbows),
    )
    delay = 0.0 if rng.uniform() < 0.3 else _uniform(rng, RANGES.current_delay)
    logging = Logging(
        rate=log_rate,
        jitter=_uniform(rng, RANGES.log_jitter),
        gaps=int(rng.integers(1, 4)) if rng.uniform() < 0.4 else 0,
        gap_durations=RANGES.gap_duration,
        current_delay=round(delay * controller.servo_rate) / controller.servo_rate,
    )
    return dataclasses.replace(bench, sweep=sweep, logging=logging)


def random_bench_or_error(seed: int) -> ScaraBench:
    """:func:`random_bench`, with a bad seed reported as an InputError (for the CLI)."""
    try:
        return random_bench(seed)
    except ValueError:
        raise InputError(f"--random SEED must be a non-negative integer, got {seed!r}") from None
