"""The LuGre bristle friction law of the simulator (:class:`torquemap.sim.scara.Lugre`).

One step of the bristle state is integrated by the backward Euler rule, which is what lets the
engine take it inside its implicit velocity step: for a new velocity ``w`` the deflection solves
``z_new = z + dt (w - sigma_0 |w| z_new / g(w))`` in closed form. The backward rule only adds
dissipation, so the discrete law stays passive where the continuous one is.

References
----------
C. Canudas de Wit, H. Olsson, K. J. Astrom, P. Lischinsky, "A new model for control of systems
with friction", IEEE Trans. Automatic Control 40(3), 1995.
H. Olsson, K. J. Astrom, C. Canudas de Wit, M. Gafvert, P. Lischinsky, "Friction models and
friction compensation", European Journal of Control 4(3), 1998.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.sim.scara import Friction


@dataclass(frozen=True, slots=True, eq=False)
class LugreStep:
    """One backward-Euler step of the LuGre law at the step's final velocity.

    Attributes
    ----------
    torque
        Friction torque over the step [N m], motor side.
    slope
        ``d torque / d w`` [N m s / rad]: the Newton slope of the engine's implicit step.
    deflection
        Bristle deflection at the end of the step [rad].
    """

    torque: float
    slope: float
    deflection: float


def level(velocity: float, friction: Friction) -> float:
    """``g(w)``: Coulomb plus Stribeck level [N m] in the direction of ``velocity`` [rad/s]."""
    coulomb, stribeck, vs, _ = friction.direction_parameters(1 if velocity >= 0 else -1)
    return coulomb + stribeck * math.exp(-(abs(velocity / vs) ** friction.stribeck_exponent))


LugreConstants = tuple[
    float, float, float, float, float, float, float, float, float, float, float, float
]


def lugre_constants(friction: Friction) -> LugreConstants:
    """The scalars of a LuGre law, flat, for the engine's inner loop.

    ``(sigma_0, sigma_1, damping_velocity, exponent, coulomb+, stribeck+, stribeck_velocity+,
    viscous+, coulomb-, stribeck-, stribeck_velocity-, viscous-)``.
    """
    lg = friction.lugre
    if lg is None:
        raise ValueError("friction has no LuGre parameters")
    return (
        lg.bristle_stiffness,
        lg.bristle_damping,
        lg.damping_velocity,
        friction.stribeck_exponent,
        *friction.direction_parameters(1),
        *friction.direction_parameters(-1),
    )


def lugre_update(
    deflection: float, velocity: float, dt: float, c: LugreConstants
) -> tuple[float, float, float]:
    """:func:`lugre_step` on :func:`lugre_constants`: ``(torque, slope, deflection)``."""
    s0, s1_0, vd, p, cp, sp, vsp, vp, cn, sn, vsn, vn = c
    if velocity >= 0:
        sign, coulomb, stribeck, vs, viscous = 1.0, cp, sp, vsp, vp
    else:
        sign, coulomb, stribeck, vs, viscous = -1.0, cn, sn, vsn, vn
    r = abs(velocity) / vs
    e = math.exp(-(r**p)) if r > 0.0 else 1.0
    g = coulomb + stribeck * e
    dg = -stribeck * e * p * r ** (p - 1.0) / vs * sign if r > 0.0 else 0.0
    a = dt * s0 / g
    d = 1.0 + a * abs(velocity)
    z = (deflection + dt * velocity) / d
    dd = dt * s0 * (sign * g - abs(velocity) * dg) / (g * g)
    dz = (dt - z * dd) / d
    x = velocity / vd
    s1 = s1_0 * math.exp(-x * x)
    ds1 = -2.0 * x / vd * s1
    rate = (z - deflection) / dt
    torque = s0 * z + s1 * rate + viscous * velocity
    return torque, (s0 + s1 / dt) * dz + ds1 * rate + viscous, z


def lugre_step(deflection: float, velocity: float, dt: float, friction: Friction) -> LugreStep:
    """Advance the bristle deflection [rad] over ``dt`` [s] to velocity ``velocity`` [rad/s].

    Parameters
    ----------
    deflection
        Bristle deflection at the start of the step [rad], motor side.
    velocity
        Motor velocity at the end of the step [rad/s].
    dt
        Step [s].
    friction
        A friction with ``lugre`` set.

    Returns
    -------
    LugreStep

    Examples
    --------
    >>> from torquemap.sim.scara import Lugre
    >>> f = Friction(0.05, 0.05, 0.0, 0.0, 0.0, lugre=Lugre(10.0, 0.0, 1.0))
    >>> round(lugre_step(0.0, 1e-3, 1.0, f).torque, 6)  # a small, slow move: a spring
    0.008333
    """
    torque, slope, z = lugre_update(deflection, velocity, dt, lugre_constants(friction))
    return LugreStep(torque=torque, slope=slope, deflection=z)


@dataclass(frozen=True, slots=True, eq=False)
class LugreResponse:
    """The LuGre law driven by a velocity history.

    Attributes
    ----------
    torque
        Friction torque [N m], shape (n,).
    deflection
        Bristle deflection [rad], shape (n,).
    """

    torque: NDArray[np.float64]
    deflection: NDArray[np.float64]


def lugre_response(
    t: ArrayLike, velocity: ArrayLike, friction: Friction, *, deflection: float = 0.0
) -> LugreResponse:
    """Friction torque of the LuGre law along a velocity history, step by step.

    Parameters
    ----------
    t
        Time [s], strictly increasing, shape (n,).
    velocity
        Motor velocity [rad/s] at each time, shape (n,); each step ends at its sample's
        velocity (backward Euler, as in the engine).
    friction
        A friction with ``lugre`` set.
    deflection
        Bristle deflection at ``t[0]`` [rad].

    Returns
    -------
    LugreResponse
        Torque and deflection at each sample; the first sample's torque has no damping term.
    """
    tt = np.asarray(t, dtype=np.float64)
    w = np.asarray(velocity, dtype=np.float64)
    lg = friction.lugre
    if lg is None:
        raise ValueError("friction has no LuGre parameters")
    torque = np.empty(tt.size)
    z = np.empty(tt.size)
    z[0] = deflection
    w0 = float(w[0])
    torque[0] = (
        lg.bristle_stiffness * deflection
        + friction.direction_parameters(1 if w0 >= 0 else -1)[3] * w0
    )
    for k in range(1, tt.size):
        step = lugre_step(float(z[k - 1]), float(w[k]), float(tt[k] - tt[k - 1]), friction)
        torque[k] = step.torque
        z[k] = step.deflection
    return LugreResponse(torque=torque, deflection=z)


def bristle_energy(deflection: ArrayLike, friction: Friction) -> NDArray[np.float64]:
    """Elastic energy stored in the bristles, ``sigma_0 z^2 / 2`` [J]."""
    lg = friction.lugre
    if lg is None:
        raise ValueError("friction has no LuGre parameters")
    z = np.asarray(deflection, dtype=np.float64)
    out: NDArray[np.float64] = 0.5 * lg.bristle_stiffness * z * z
    return out
