"""The simulator's true friction law behind the estimator's friction-law interface (oracles only).

A random bench's friction may be of a form no model file holds (a LuGre law, viscous friction
and Stribeck velocity per direction). :class:`TrueFriction` wraps the simulator's
:class:`~torquemap.sim.scara.Friction` as a :class:`torquemap.friction_law.FrictionLaw`, so
that benchmarks can run the estimation pipeline with the true law (the oracle). It is not
registered: no model file can name it, and nothing in the estimation path imports it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.sim.lugre import lugre_response
from torquemap.sim.scara import Friction, friction_torque, stribeck_level


@dataclass(frozen=True, slots=True, eq=False)
class TrueFriction:
    """A simulator friction law as a :class:`torquemap.friction_law.FrictionLaw`.

    ``torque(velocity)`` is the static law (a LuGre law's steady state); with ``t`` a LuGre
    law integrates its bristles along the velocity history from relaxed bristles at ``t[0]``.
    The linear view holds the nonlinear parameters (Stribeck velocities and exponent) fixed.

    Attributes
    ----------
    friction
        The simulator's law.
    """

    kind: ClassVar[str] = "simulator-truth"
    linear_parameter_names: ClassVar[tuple[str, ...]] = (
        "coulomb_positive",
        "coulomb_negative",
        "viscous",
        "viscous_negative",
        "stribeck_positive",
        "stribeck_negative",
    )

    friction: Friction

    @property
    def zero_velocity(self) -> float:
        """Half width of the static law's blend through zero [rad/s]."""
        return self.friction.zero_velocity

    def static_levels(self) -> tuple[float, float]:
        """Coulomb plus Stribeck level of each direction at zero speed [N m]."""
        f = self.friction
        return f.coulomb_positive + f.stribeck_positive, f.coulomb_negative + f.stribeck_negative

    def torque(self, velocity: ArrayLike, *, t: ArrayLike | None = None) -> NDArray[np.float64]:
        """Friction torque [N m] at motor velocity ``velocity`` [rad/s] (``t`` [s]: LuGre)."""
        w = np.asarray(velocity, dtype=np.float64)
        if t is None or self.friction.lugre is None or w.ndim != 1 or w.size < 2:
            return friction_torque(w, self.friction)
        return lugre_response(t, w, self.friction).torque

    def basis(self, velocity: ArrayLike) -> NDArray[np.float64]:
        """Columns (n, 6) of the static law, in ``linear_parameter_names`` order."""
        f = self.friction
        w = np.atleast_1d(np.asarray(velocity, dtype=np.float64))
        w0 = f.zero_velocity
        b = np.clip((w + w0) / (2 * w0), 0.0, 1.0)
        unit = dataclasses.replace(f, coulomb_positive=0.0, coulomb_negative=0.0)
        sp = stribeck_level(w, dataclasses.replace(unit, stribeck_positive=1.0), 1)
        sn = stribeck_level(w, dataclasses.replace(unit, stribeck_negative=1.0), -1)
        return np.stack([b, -(1 - b), b * w, (1 - b) * w, b * sp, -(1 - b) * sn], axis=-1)

    def linear_parameters(self) -> NDArray[np.float64]:
        """Values of the linear parameters [N m, N m, N m s/rad, N m s/rad, N m, N m]."""
        f = self.friction
        visc_neg = f.viscous if f.viscous_negative is None else f.viscous_negative
        return np.array(
            [
                f.coulomb_positive,
                f.coulomb_negative,
                f.viscous,
                visc_neg,
                f.stribeck_positive,
                f.stribeck_negative,
            ]
        )

    def with_linear_parameters(self, values: ArrayLike) -> Self:
        """A copy with the linear parameters replaced."""
        v = [float(x) for x in np.asarray(values, dtype=np.float64).reshape(-1)]
        if len(v) != len(self.linear_parameter_names):
            raise ValueError(f"expected {len(self.linear_parameter_names)} values, got {len(v)}")
        f = dataclasses.replace(
            self.friction,
            coulomb_positive=v[0],
            coulomb_negative=v[1],
            viscous=v[2],
            viscous_negative=v[3],
            stribeck_positive=v[4],
            stribeck_negative=v[5],
        )
        return dataclasses.replace(self, friction=f)

    def to_dict(self) -> dict[str, Any]:
        """A description (not readable back: the law is not registered)."""
        f = self.friction
        out: dict[str, Any] = {"kind": self.kind}
        for field in dataclasses.fields(f):
            value = getattr(f, field.name)
            if value is None:
                continue
            out[field.name] = dataclasses.asdict(value) if field.name == "lugre" else value
        return out
