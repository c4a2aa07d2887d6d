"""The simulated SCARA bench: physical parameters, their defaults, and the closed-form dynamics.

A two-axis SCARA after the Hirata ARI350 of Simpson, Cook & Li (joints ``a`` and ``b``, harmonic
drives 100:1 and 80:1, DC motors in current-controlled drives). Every default below is either
taken from the paper or chosen, and the docstrings say which; docs/formats.md lists them for the
bench files. The physics is written here independently of every estimator: this module does not
import :mod:`torquemap.model` (the friction law is written out again on purpose).

Joint side: the rigid planar 2R arm (mass matrix, Coriolis). Motor side: rotor inertia, friction
(Coulomb per direction, viscous, Stribeck, a linear blend through zero velocity) and PDTV
(harmonics of the motor angle). The gears are rigid: motor angle = gear_ratio * joint angle.

Beyond the paper's bench (the defaults), the parameters also describe the random family of
:mod:`torquemap.sim.family`: friction laws of other forms than the one identification fits (a
Stribeck exponent other than 2, viscous friction and Stribeck velocity per direction, a LuGre
bristle model, :mod:`torquemap.sim.lugre`), directional PDTV lines, and logs written at another
rate than the servo's, with jitter, gaps and a delayed current channel (:class:`Logging`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True, slots=True, eq=False)
class Links:
    """Rigid links of the planar arm (joint side).

    Chosen, not measured: the paper gives no link data. The lengths put the paper's 130 mm
    circle far from both elbow singularities (``|sin q_b| >= 0.47`` on the default circle);
    the masses are those of a small SCARA whose B-axis motor and drive sit on link 1 and whose
    Z/W axes and tool sit on link 2.

    Attributes
    ----------
    lengths
        ``(l1, l2)`` [m], base to elbow and elbow to end effector.
    masses
        ``(m1, m2)`` [kg].
    centres_of_mass
        ``(lc1, lc2)`` [m], distance of each centre of mass from the link's own joint.
    inertias
        ``(I1, I2)`` [kg m^2], about each link's centre of mass (z axis).
    """

    lengths: tuple[float, float] = (0.25, 0.20)
    masses: tuple[float, float] = (5.0, 2.5)
    centres_of_mass: tuple[float, float] = (0.12, 0.08)
    inertias: tuple[float, float] = (0.03, 0.012)


@dataclass(frozen=True, slots=True, eq=False)
class Lugre:
    """The bristle (LuGre) dynamics of a friction law (Canudas de Wit et al., 1995).

    With ``z`` the mean bristle deflection [rad, motor side] and ``g(w) > 0`` the steady-state
    Coulomb-plus-Stribeck level of :class:`Friction` in the direction of ``w``::

        dz/dt = w - bristle_stiffness * |w| * z / g(w)
        f = bristle_stiffness * z + sigma_1(w) * dz/dt + viscous(w) * w
        sigma_1(w) = bristle_damping * exp(-(w / damping_velocity)**2)

    At a constant speed ``z`` settles to ``sign(w) g(w) / bristle_stiffness`` and ``f`` to the
    static law of :class:`Friction`; at rest and through reversals the bristles act as a
    spring (pre-sliding, hysteresis, frictional lag). The velocity-dependent damping keeps the
    law dissipative when ``bristle_damping * damping_velocity < 4 sqrt(2 e) min(g)`` (Olsson et
    al., 1998); :func:`torquemap.sim.family.random_bench` draws within that bound.

    Attributes
    ----------
    bristle_stiffness
        ``sigma_0`` [N m / rad], motor side.
    bristle_damping
        ``sigma_1`` at rest [N m s / rad].
    damping_velocity
        [rad/s], motor side.
    """

    bristle_stiffness: float
    bristle_damping: float
    damping_velocity: float


@dataclass(frozen=True, slots=True, eq=False)
class Friction:
    """Motor-side friction of one axis; the defaults are the law of ``torquemap.model``.

    For motor velocity ``w`` [rad/s], with ``s = exp(-|w / stribeck_velocity|**stribeck_exponent)``::

        w >  zero_velocity:  f = coulomb_positive + stribeck_positive * s + viscous * w
        w < -zero_velocity:  f = -coulomb_negative - stribeck_negative * s + viscous_negative * w

    and a linear blend of the two branches for ``|w| < zero_velocity``, which the simulator
    uses as its stiction regularisation (a steep damper that all but holds the rotor). With
    ``lugre`` set, that static law is the steady state of the bristle model and the blend is
    not used.

    Attributes
    ----------
    coulomb_positive, coulomb_negative
        [N m], magnitudes (>= 0).
    viscous
        [N m s / rad].
    stribeck_positive, stribeck_negative
        [N m], extra break-away torque at low speed.
    stribeck_velocity
        [rad/s], motor side.
    zero_velocity
        [rad/s], motor side, half width of the blend through zero.
    stribeck_exponent
        [-]; 2 is the Gaussian Stribeck curve identification fits.
    viscous_negative
        [N m s / rad] for negative motion; None: ``viscous`` in both directions.
    stribeck_velocity_negative
        [rad/s] for negative motion; None: ``stribeck_velocity`` in both directions.
    lugre
        Bristle dynamics; None: the static law.
    """

    coulomb_positive: float
    coulomb_negative: float
    viscous: float
    stribeck_positive: float
    stribeck_negative: float
    stribeck_velocity: float = 1.5
    zero_velocity: float = 0.05
    stribeck_exponent: float = 2.0
    viscous_negative: float | None = None
    stribeck_velocity_negative: float | None = None
    lugre: Lugre | None = None

    @property
    def is_paper_law(self) -> bool:
        """Whether this is the law identification fits (Gaussian Stribeck, symmetric, static)."""
        return (
            self.stribeck_exponent == 2.0
            and self.viscous_negative is None
            and self.stribeck_velocity_negative is None
            and self.lugre is None
        )

    def direction_parameters(self, sign: int) -> tuple[float, float, float, float]:
        """``(coulomb, stribeck, stribeck_velocity, viscous)`` of one direction (+1 or -1)."""
        if sign > 0:
            return (
                self.coulomb_positive,
                self.stribeck_positive,
                self.stribeck_velocity,
                self.viscous,
            )
        return (
            self.coulomb_negative,
            self.stribeck_negative,
            self.stribeck_velocity
            if self.stribeck_velocity_negative is None
            else self.stribeck_velocity_negative,
            self.viscous if self.viscous_negative is None else self.viscous_negative,
        )


@dataclass(frozen=True, slots=True, eq=False)
class Harmonic:
    """One PDTV line: motor-side torque ``amplitude * cos(order * motor_angle + phase)``.

    A directional line (``direction`` ``"positive"`` or ``"negative"``) acts only while the
    motor turns that way, faded in linearly over the friction's ``zero_velocity``: a
    position-dependent friction (a tight tooth, a preload that varies along a screw).

    Attributes
    ----------
    order
        [CPR], cycles per motor revolution (Eq 4 of Simpson et al.).
    amplitude
        [N m], motor side.
    phase
        [rad]; motor angle 0 is the encoder zero, at joint angle 0.
    direction
        ``"both"`` (a torque of position alone), ``"positive"`` or ``"negative"``.
    """

    order: float
    amplitude: float
    phase: float
    direction: str = "both"


@dataclass(frozen=True, slots=True, eq=False)
class Axis:
    """One axis: harmonic drive, DC motor, encoder, current sensor, friction and PDTV.

    Attributes
    ----------
    name
        Joint name (``"a"`` or ``"b"``), the ``<j>`` of the log columns.
    gear_ratio
        Motor revolutions per joint revolution [-] (paper: 100 for A, 80 for B).
    torque_constant
        [N m / A], motor side (chosen: a small DC servo motor).
    rotor_inertia
        Motor rotor plus wave generator [kg m^2] (chosen).
    encoder_counts_per_rev
        Counts per motor revolution, 2000 lines x 4 (chosen).
    friction
        Motor-side friction. Chosen so that Coulomb friction (30-50 mN m) exceeds the spring's
        torque at the motor (at most 3.5 N x 0.25 m / 100 = 8.75 mN m), as the paper stresses.
    pdtv
        PDTV lines. Chosen after the paper's section 3 and Fig 4: the B axis is dominated by
        2 CPR (the harmonic drive's elliptic wave generator turns with the motor); A has
        several smaller lines: 1 CPR (eccentricity), 2 and 4 CPR (wave generator), 3 CPR,
        21 CPR (armature slot cogging of a 21-slot DC motor) and 48 CPR (standing for a gear
        tooth mesh order; illustrative, not a Hirata datum).
    current_noise
        Standard deviation of the current-sensor noise [A], white at the servo rate.
    ripple_amplitude
        Inverter ripple on the motor current [A]: a real current (it makes torque), periodic
        in time and not locked to position.
    ripple_frequency
        [Hz]; 300 Hz is the six-pulse rectifier ripple of a 50 Hz three-phase supply on the DC
        bus that feeds the drives.
    max_current
        Drive current limit [A].
    """

    name: str
    gear_ratio: float
    torque_constant: float
    rotor_inertia: float
    friction: Friction
    pdtv: tuple[Harmonic, ...]
    encoder_counts_per_rev: int = 8000
    current_noise: float = 0.02
    ripple_amplitude: float = 0.03
    ripple_frequency: float = 300.0
    max_current: float = 10.0


def _axis_a() -> Axis:
    return Axis(
        name="a",
        gear_ratio=100.0,
        torque_constant=0.11,
        rotor_inertia=1.2e-4,
        friction=Friction(
            coulomb_positive=0.045,
            coulomb_negative=0.050,
            viscous=3.0e-4,
            stribeck_positive=0.012,
            stribeck_negative=0.010,
        ),
        pdtv=(
            Harmonic(order=1.0, amplitude=0.0015, phase=0.4),
            Harmonic(order=2.0, amplitude=0.0040, phase=-1.1),
            Harmonic(order=3.0, amplitude=0.0010, phase=2.0),
            Harmonic(order=4.0, amplitude=0.0020, phase=0.7),
            Harmonic(order=21.0, amplitude=0.0015, phase=-2.3),
            Harmonic(order=48.0, amplitude=0.0010, phase=1.3),
        ),
    )


def _axis_b() -> Axis:
    return Axis(
        name="b",
        gear_ratio=80.0,
        torque_constant=0.08,
        rotor_inertia=7.0e-5,
        friction=Friction(
            coulomb_positive=0.030,
            coulomb_negative=0.034,
            viscous=2.5e-4,
            stribeck_positive=0.008,
            stribeck_negative=0.009,
        ),
        pdtv=(
            Harmonic(order=1.0, amplitude=0.0010, phase=-0.6),
            Harmonic(order=2.0, amplitude=0.0120, phase=0.9),
            Harmonic(order=4.0, amplitude=0.0015, phase=-2.0),
            Harmonic(order=21.0, amplitude=0.0008, phase=2.7),
        ),
    )


@dataclass(frozen=True, slots=True, eq=False)
class Controller:
    """The joint servo: PD on the motor angle plus feed-forward, at the servo rate.

    ``tau = J_ff * acc_ref + f_ff(w_ref) + Kp (theta_ref - theta_enc) + Kd (w_ref - w_est)``,
    motor side, per axis; ``w_est`` is the encoder difference through a first-order low-pass.
    Gains from the bandwidth: ``Kp = J w_c^2``, ``Kd = 2 zeta J w_c`` with ``J`` the nominal
    motor-side inertia. The feed-forward friction is deliberately imperfect
    (``friction_feedforward`` times the true Coulomb and viscous terms, no Stribeck), as a real
    controller's would be; it never knows the PDTV or the spring.

    Attributes
    ----------
    servo_rate
        [Hz]; the log is written at this rate (about 2 kHz, as a DSP servo).
    substeps
        Physics integration steps per servo period.
    bandwidth
        Position-loop bandwidth [Hz].
    damping
        Damping ratio [-].
    velocity_cutoff
        Cut-off of the velocity estimate's low-pass [Hz].
    friction_feedforward
        Fraction of the true Coulomb and viscous friction fed forward [-].
    """

    servo_rate: float = 2000.0
    substeps: int = 2
    bandwidth: float = 15.0
    damping: float = 0.8
    velocity_cutoff: float = 150.0
    friction_feedforward: float = 0.8


@dataclass(frozen=True, slots=True, eq=False)
class Sweep:
    """Scenario (a): no-load identification sweeps, each axis in turn, the other held.

    Every pass is a trapezoid (acceleration, cruise, deceleration) of ``revolutions`` motor
    revolutions at cruise, forward then back, at each speed. The A axis is swept at every
    speed at the first elbow angle, and at the fastest ``fast_speeds`` speeds at the others
    (its ramps there identify how its inertia depends on ``q_b``); the B axis at every speed.

    Attributes
    ----------
    speeds
        Cruise speeds [rad/s], motor side. The slowest, 0.5 rad/s, gives 25000 samples per
        motor revolution at 2 kHz and, with 1.5 rad/s, places the Stribeck curve (a friction
        law is only known at the speeds it was measured at: the circle's reversals pass through
        every speed below 1.5 rad/s); the fastest, 45 rad/s, still gives 279 samples per
        revolution (Nyquist 140 CPR) and covers the motor speeds of the circle (A: up to
        44 rad/s).
    revolutions
        Motor revolutions at cruise speed per pass.
    acceleration
        Motor-side acceleration of the ramps [rad/s^2].
    elbow_angles
        Angles of ``b`` [rad] at which ``a`` is swept; ``b`` is swept about the second.
    fast_speeds
        How many of the fastest speeds are repeated at the other elbow angles.
    dwell
        Rest between passes [s].
    """

    speeds: tuple[float, ...] = (0.5, 1.5, 5.0, 15.0, 45.0)
    revolutions: float = 3.0
    acceleration: float = 200.0
    elbow_angles: tuple[float, ...] = (0.6, 1.6, 2.6)
    fast_speeds: int = 2
    dwell: float = 0.25


@dataclass(frozen=True, slots=True, eq=False)
class Circle:
    """Scenario (b), the paper's experiment: a circle tracked about a spring's anchor.

    The spring (stiffness ``k``, free length ``L0``, ``k (radius - L0)`` = 3.5 N) pulls the
    end effector toward the anchor at the circle's centre; the paper's circle has a 130 mm
    radius, an angular speed of 0.4 rad/s and a 3.5 N spring force.

    Attributes
    ----------
    centre
        Circle centre and spring anchor [m], base frame (chosen: both joints reverse during a
        circle and ``|sin q_b| >= 0.47`` throughout).
    radius
        [m] (paper: 130 mm).
    angular_speed
        Angular speed about the centre [rad/s] (paper: 0.4 rad/s), counter-clockwise.
    turns
        Circles at speed, ramps included.
    ramp
        Duration of the smooth (raised-cosine) speed ramps at start and end [s].
    hold
        Rest before and after the motion [s].
    start_angle
        Angle of the starting point about the centre [rad].
    spring_force
        Spring tension on the circle [N] (paper: 3.5 N).
    spring_stiffness
        [N/m] (chosen); the free length follows from ``spring_force``.
    """

    centre: tuple[float, float] = (0.0, 0.25)
    radius: float = 0.13
    angular_speed: float = 0.4
    turns: float = 1.75
    ramp: float = 2.5
    hold: float = 0.5
    start_angle: float = 0.0
    spring_force: float = 3.5
    spring_stiffness: float = 50.0

    @property
    def free_length(self) -> float:
        """Spring free length [m], ``radius - spring_force / spring_stiffness``."""
        return self.radius - self.spring_force / self.spring_stiffness


@dataclass(frozen=True, slots=True, eq=False)
class Logging:
    """How the logs are written: which servo ticks they keep, and the current channel's delay.

    The default writes every servo tick with no delay (the paper's DSP). Otherwise the logger
    polls at ``rate`` with a uniform jitter of ``+- jitter / rate``, keeps the servo tick
    nearest each poll (time stamp = that tick's time; a tick is kept once), and drops every
    sample in ``gaps`` random stretches per log whose lengths are drawn from
    ``gap_durations``. The current it stores is the one the drive reported
    ``current_delay`` earlier (current-loop latency plus report delay), rounded to whole
    servo ticks.

    Attributes
    ----------
    rate
        Nominal log rate [Hz]; None: every servo tick.
    jitter
        Poll jitter, fraction of the log period [-], ``< 0.5``.
    gaps
        Number of gaps per log.
    gap_durations
        ``(shortest, longest)`` gap [s].
    current_delay
        Delay of the current channel behind the position channel [s].
    """

    rate: float | None = None
    jitter: float = 0.0
    gaps: int = 0
    gap_durations: tuple[float, float] = (0.02, 0.1)
    current_delay: float = 0.0


@dataclass(frozen=True, slots=True, eq=False)
class ScaraBench:
    """All physical parameters of the simulated SCARA bench, with documented defaults.

    Attributes
    ----------
    links
        The rigid arm.
    axes
        ``(a, b)``: the base axis and the elbow axis.
    controller
        The joint servo.
    sweep
        Scenario (a).
    circle
        Scenario (b).
    name
        Robot name written to robot.toml.
    logging
        How the logs are written (default: every servo tick).
    random_seed
        The seed :func:`torquemap.sim.family.random_bench` drew this bench from; None for a
        bench built by hand (the paper's).
    """

    links: Links = field(default_factory=Links)
    axes: tuple[Axis, Axis] = field(default_factory=lambda: (_axis_a(), _axis_b()))
    controller: Controller = field(default_factory=Controller)
    sweep: Sweep = field(default_factory=Sweep)
    circle: Circle = field(default_factory=Circle)
    name: str = "simulated SCARA after the Hirata ARI350 (Simpson, Cook & Li)"
    logging: Logging = field(default_factory=Logging)
    random_seed: int | None = None


def default_bench() -> ScaraBench:
    """The default bench (every default documented on its dataclass).

    Examples
    --------
    >>> b = default_bench()
    >>> [ax.gear_ratio for ax in b.axes]
    [100.0, 80.0]
    """
    return ScaraBench()


@dataclass(frozen=True, slots=True, eq=False)
class DynamicsConstants:
    """The constants of the planar 2R mass matrix, joint side, motors included.

    ``M = [[alpha + 2 beta cos q_b, delta + beta cos q_b], [delta + beta cos q_b, delta_b]]``
    with ``alpha = I1 + m1 lc1^2 + I2 + m2 (l1^2 + lc2^2) + n_a^2 Jm_a``,
    ``beta = m2 l1 lc2``, ``delta = I2 + m2 lc2^2``, ``delta_b = delta + n_b^2 Jm_b``.

    The rotors are taken to spin about axes fixed in the base (the B rotor's share of the
    A rotation, ``Jm_b * qd_a``, is neglected: it is under 1 % of the coupling term).

    Attributes
    ----------
    alpha, beta, delta, delta_b
        [kg m^2], joint side.
    """

    alpha: float
    beta: float
    delta: float
    delta_b: float


def dynamics_constants(bench: ScaraBench) -> DynamicsConstants:
    """The mass-matrix constants of ``bench`` (see :class:`DynamicsConstants`).

    Examples
    --------
    >>> c = dynamics_constants(default_bench())
    >>> round(c.beta, 6)
    0.05
    """
    lk = bench.links
    l1 = lk.lengths[0]
    m1, m2 = lk.masses
    lc1, lc2 = lk.centres_of_mass
    i1, i2 = lk.inertias
    a, b = bench.axes
    delta = i2 + m2 * lc2**2
    return DynamicsConstants(
        alpha=i1 + m1 * lc1**2 + i2 + m2 * (l1**2 + lc2**2) + a.gear_ratio**2 * a.rotor_inertia,
        beta=m2 * l1 * lc2,
        delta=delta,
        delta_b=delta + b.gear_ratio**2 * b.rotor_inertia,
    )


def mass_matrix(bench: ScaraBench, joint_angles: ArrayLike) -> NDArray[np.float64]:
    """Joint-side mass matrix, reflected rotor inertia included [kg m^2], shape (..., 2, 2).

    Examples
    --------
    >>> m = mass_matrix(default_bench(), [0.0, np.pi / 2])
    >>> bool(np.allclose(m, m.T))
    True
    """
    q = np.asarray(joint_angles, dtype=np.float64)
    c = dynamics_constants(bench)
    c2 = np.cos(q[..., 1])
    out = np.empty((*q.shape[:-1], 2, 2))
    out[..., 0, 0] = c.alpha + 2 * c.beta * c2
    out[..., 0, 1] = out[..., 1, 0] = c.delta + c.beta * c2
    out[..., 1, 1] = c.delta_b
    return out


def coriolis_torque(
    bench: ScaraBench, joint_angles: ArrayLike, joint_velocity: ArrayLike
) -> NDArray[np.float64]:
    """Coriolis and centripetal torques ``C(q, qd) qd`` [N m], joint side, shape (..., 2).

    ``h = m2 l1 lc2 sin q_b``; ``C qd = (-h (2 qd_a qd_b + qd_b^2), h qd_a^2)``.
    """
    q = np.asarray(joint_angles, dtype=np.float64)
    qd = np.asarray(joint_velocity, dtype=np.float64)
    h = dynamics_constants(bench).beta * np.sin(q[..., 1])
    return np.stack(
        [-h * (2 * qd[..., 0] * qd[..., 1] + qd[..., 1] ** 2), h * qd[..., 0] ** 2], axis=-1
    )


def kinetic_energy(
    bench: ScaraBench, joint_angles: ArrayLike, joint_velocity: ArrayLike
) -> NDArray[np.float64]:
    """Kinetic energy of links and rotors ``qd^T M(q) qd / 2`` [J], shape (...)."""
    qd = np.asarray(joint_velocity, dtype=np.float64)
    m = mass_matrix(bench, joint_angles)
    out: NDArray[np.float64] = 0.5 * np.einsum("...i,...ij,...j->...", qd, m, qd)
    return out


def motor_inertia(bench: ScaraBench, elbow_angle: ArrayLike) -> NDArray[np.float64]:
    """Motor-side diagonal inertia of each axis [kg m^2], shape (..., 2).

    ``J_a = Jm_a + M_aa(q_b) / n_a^2 = constant + cos_elbow * cos(q_b)`` and
    ``J_b = Jm_b + (I2 + m2 lc2^2) / n_b^2``: what the paper's model (Eq 5, "the B axis position
    affects the A axis inertia", coupling neglected) sees of this bench.
    """
    q2 = np.asarray(elbow_angle, dtype=np.float64)
    c = dynamics_constants(bench)
    na, nb = (ax.gear_ratio for ax in bench.axes)
    ja = (c.alpha + 2 * c.beta * np.cos(q2)) / na**2
    jb = np.broadcast_to(c.delta_b / nb**2, q2.shape)
    return np.stack([ja, jb], axis=-1)


def stribeck_level(velocity: ArrayLike, friction: Friction, sign: int) -> NDArray[np.float64]:
    """``coulomb + stribeck * exp(-|w / stribeck_velocity|**exponent)`` of one direction [N m].

    The magnitude ``g(w)`` of the dry friction in direction ``sign`` (+1 or -1) at motor
    velocity ``velocity`` [rad/s]; the LuGre model's steady-state level.
    """
    w = np.asarray(velocity, dtype=np.float64)
    coulomb, stribeck, vs, _ = friction.direction_parameters(sign)
    out: NDArray[np.float64] = coulomb + stribeck * np.exp(
        -(np.abs(w / vs) ** friction.stribeck_exponent)
    )
    return out


def friction_torque(velocity: ArrayLike, friction: Friction) -> NDArray[np.float64]:
    """Motor-side static friction [N m] at motor velocity ``velocity`` [rad/s] (:class:`Friction`).

    For a LuGre law this is its steady state at constant speed (outside the blend through
    zero); the dynamic law itself is :func:`torquemap.sim.lugre.lugre_response`.

    Examples
    --------
    >>> f = Friction(0.1, 0.2, 0.01, 0.0, 0.0)
    >>> friction_torque([2.0, -2.0, 0.0], f).round(6)
    array([ 0.12, -0.22, -0.05])
    """
    w = np.asarray(velocity, dtype=np.float64)
    w0 = friction.zero_velocity
    blend = np.clip((w + w0) / (2 * w0), 0.0, 1.0)
    if friction.is_paper_law:
        s = np.exp(-((w / friction.stribeck_velocity) ** 2))
        pos = friction.coulomb_positive + friction.stribeck_positive * s
        neg = -(friction.coulomb_negative + friction.stribeck_negative * s)
        out: NDArray[np.float64] = blend * pos + (1.0 - blend) * neg + friction.viscous * w
        return out
    viscous_neg = friction.direction_parameters(-1)[3]
    pos = stribeck_level(w, friction, 1) + friction.viscous * w
    neg = -stribeck_level(w, friction, -1) + viscous_neg * w
    out = blend * pos + (1.0 - blend) * neg
    return out


def direction_gate(velocity: ArrayLike, direction: str, width: float) -> NDArray[np.float64]:
    """Weight [0, 1] of a directional PDTV line at motor velocity ``velocity`` [rad/s].

    1 for ``"both"``; for ``"positive"`` ``clip(w / width, 0, 1)``, for ``"negative"``
    ``clip(-w / width, 0, 1)``, with ``width`` [rad/s] the friction's ``zero_velocity``.
    """
    w = np.asarray(velocity, dtype=np.float64)
    if direction == "both":
        return np.ones_like(w)
    sign = 1.0 if direction == "positive" else -1.0
    out: NDArray[np.float64] = np.clip(sign * w / width, 0.0, 1.0)
    return out


def pdtv_torque(
    motor_angle: ArrayLike,
    lines: tuple[Harmonic, ...],
    *,
    velocity: ArrayLike | None = None,
    width: float = 0.05,
) -> NDArray[np.float64]:
    """Motor-side PDTV torque [N m] at motor angle ``motor_angle`` [rad].

    Directional lines are weighted by :func:`direction_gate` of ``velocity`` [rad/s] (fade
    width ``width`` [rad/s]) and skipped when ``velocity`` is None.

    Examples
    --------
    >>> pdtv_torque([0.0], (Harmonic(2.0, 0.01, 0.0),))
    array([0.01])
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    out = np.zeros_like(theta)
    for h in lines:
        if h.direction == "both":
            out += h.amplitude * np.cos(h.order * theta + h.phase)
        elif velocity is not None:
            gate = direction_gate(velocity, h.direction, width)
            out += gate * h.amplitude * np.cos(h.order * theta + h.phase)
    return out


def pdtv_energy(motor_angle: ArrayLike, lines: tuple[Harmonic, ...]) -> NDArray[np.float64]:
    """Potential of the PDTV, ``U(theta)`` with ``dU/dtheta = pdtv_torque`` [J].

    Directional lines are not conservative (a position-dependent friction) and are left out.
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    out = np.zeros_like(theta)
    for h in lines:
        if h.direction == "both":
            out += h.amplitude / h.order * np.sin(h.order * theta + h.phase)
    return out


def end_effector(bench: ScaraBench, joint_angles: ArrayLike) -> NDArray[np.float64]:
    """End-effector position [m], base frame, shape (..., 2) (Eq 2 of the paper)."""
    q = np.asarray(joint_angles, dtype=np.float64)
    l1, l2 = bench.links.lengths
    q12 = q[..., 0] + q[..., 1]
    return np.stack(
        [l1 * np.cos(q[..., 0]) + l2 * np.cos(q12), l1 * np.sin(q[..., 0]) + l2 * np.sin(q12)],
        axis=-1,
    )


def spring_force(bench: ScaraBench, position: ArrayLike) -> NDArray[np.float64]:
    """Force of the circle's spring on the end effector at ``position`` [m] -> [N], base frame.

    ``F = -k (L - L0) u`` with ``L`` the distance from the anchor and ``u`` the unit vector
    from the anchor to the end effector: a stretched spring pulls toward the anchor.
    """
    p = np.asarray(position, dtype=np.float64)
    c = bench.circle
    d = p - np.asarray(c.centre)
    length = np.hypot(d[..., 0], d[..., 1])
    scale = -c.spring_stiffness * (length - c.free_length) / length
    out: NDArray[np.float64] = d * scale[..., None]
    return out


def spring_energy(bench: ScaraBench, position: ArrayLike) -> NDArray[np.float64]:
    """Elastic energy of the spring ``k (L - L0)^2 / 2`` [J] at ``position`` [m]."""
    p = np.asarray(position, dtype=np.float64)
    c = bench.circle
    d = p - np.asarray(c.centre)
    length = np.hypot(d[..., 0], d[..., 1])
    out: NDArray[np.float64] = 0.5 * c.spring_stiffness * (length - c.free_length) ** 2
    return out


def joint_torque_from_force(
    bench: ScaraBench, joint_angles: ArrayLike, force: ArrayLike
) -> NDArray[np.float64]:
    """Joint-side torque ``J(q)^T F`` [N m] of a force ``F`` [N] on the end effector."""
    q = np.asarray(joint_angles, dtype=np.float64)
    f = np.asarray(force, dtype=np.float64)
    l1, l2 = bench.links.lengths
    q12 = q[..., 0] + q[..., 1]
    # (x, y) of the elbow-to-tip vector, and of the whole arm: tau = r x F about each joint.
    x2, y2 = l2 * np.cos(q12), l2 * np.sin(q12)
    x = l1 * np.cos(q[..., 0]) + x2
    y = l1 * np.sin(q[..., 0]) + y2
    return np.stack([x * f[..., 1] - y * f[..., 0], x2 * f[..., 1] - y2 * f[..., 0]], axis=-1)


def singular_margin(bench: ScaraBench, joint_angles: ArrayLike) -> NDArray[np.float64]:
    """``|sin q_b|`` [-]: 0 at the elbow singularities (arm straight or folded)."""
    q = np.asarray(joint_angles, dtype=np.float64)
    return np.abs(np.sin(q[..., 1]))


TWO_PI = 2.0 * math.pi
