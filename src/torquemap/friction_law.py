"""Friction laws: objects that evaluate themselves, one place for their fields and their file table.

A friction law maps motor velocity [rad/s] to friction torque [N m], motor side. Every law offers
the same small interface (:class:`FrictionLaw`): its torque, a view that is linear in some of its
parameters (for least squares and for the uncertainty of the friction torque), and its table in
a model file (``[joints.<j>.friction]``, whose ``kind`` key names the law). Estimation and
identification only talk to that interface, so a new law (a dynamic LuGre model, say) is added
here, registered with :func:`register_friction_law`, and nothing else changes.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, Protocol, Self, TypeVar, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError

Transition = Literal["linear", "smooth"]


@runtime_checkable
class FrictionLaw(Protocol):
    """The interface every friction law implements.

    Attributes
    ----------
    kind
        The law's name, the ``kind`` key of ``[joints.<j>.friction]`` in a model file.
    """

    kind: ClassVar[str]

    @property
    def linear_parameter_names(self) -> tuple[str, ...]:
        """Names of the parameters the law is linear in, in the order of :meth:`basis` columns
        (a class constant for laws of fixed form, per law for a table)."""
        ...

    @property
    def zero_velocity(self) -> float:
        """Width of the law's transition through zero velocity [rad/s], > 0."""
        ...

    def static_levels(self) -> tuple[float, float]:
        """Friction magnitudes [N m] approached at zero speed from positive and from negative
        motion (Coulomb plus break-away), both >= 0 for a dissipative law."""
        ...

    def torque(self, velocity: ArrayLike, *, t: ArrayLike | None = None) -> NDArray[np.float64]:
        """Friction torque [N m] at motor velocity ``velocity`` [rad/s], shape of ``velocity``.

        ``t`` [s] (same shape) lets a dynamic law integrate its state; static laws ignore it.
        """
        ...

    def basis(self, velocity: ArrayLike) -> NDArray[np.float64]:
        """Columns (n, p) with ``torque(velocity) == basis(velocity) @ linear_parameters()``,
        the nonlinear parameters held at their values."""
        ...

    def linear_parameters(self) -> NDArray[np.float64]:
        """Values (p,) of the parameters named by ``linear_parameter_names``."""
        ...

    def with_linear_parameters(self, values: ArrayLike) -> Self:
        """A copy with the linear parameters replaced by ``values`` (p,)."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """The law's model-file table, ``kind`` included."""
        ...


FRICTION_LAWS: dict[str, type[FrictionLaw]] = {}
"""Registered laws by ``kind``."""


_L = TypeVar("_L", bound=type)


def register_friction_law(cls: _L) -> _L:
    """Class decorator: make a law readable from model files under its ``kind``."""
    FRICTION_LAWS[cls.kind] = cls  # type: ignore[attr-defined]
    return cls


def _finite_floats(
    table: Mapping[str, Any],
    allowed: set[str],
    where: str,
    path: str | None,
    *,
    other_keys: tuple[str, ...] = (),
) -> dict[str, float]:
    """The numbers of ``table``, each a key of ``allowed``; an unknown key's message lists
    ``allowed``, ``kind`` and ``other_keys`` (the law's keys read before: a speed table's
    lists), so that it names every key the table may hold (before, stop 39: a speed table's
    unknown key was told "allowed: viscous, viscous_negative, zero_velocity")."""
    out: dict[str, float] = {}
    for key, value in table.items():
        if key not in allowed:
            listed = ", ".join(sorted(allowed | {"kind", *other_keys}))
            raise InputError(f"unknown key {key!r} in {where} (allowed: {listed})", path=path)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"{where} {key} must be a finite number, got {value!r}", path=path)
        x = float(value)
        if not math.isfinite(x):
            raise InputError(f"{where} {key} must be a finite number, got {value!r}", path=path)
        out[key] = x
    return out


class _LinearLaw:
    """What a static law with named linear parameters and dataclass fields shares."""

    __slots__ = ()
    linear_parameter_names: ClassVar[tuple[str, ...]]
    kind: ClassVar[str]

    def linear_parameters(self) -> NDArray[np.float64]:
        """Values of the linear parameters (``linear_parameter_names`` order; N m, N m s/rad)."""
        return np.array([float(getattr(self, k)) for k in self.linear_parameter_names])

    def with_linear_parameters(self, values: ArrayLike) -> Self:
        """A copy with the linear parameters replaced."""
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        if v.size != len(self.linear_parameter_names):
            raise ValueError(f"expected {len(self.linear_parameter_names)} values, got {v.size}")
        values_by_name: dict[str, Any] = {
            k: float(x) for k, x in zip(self.linear_parameter_names, v, strict=True)
        }
        return dataclasses.replace(self, **values_by_name)  # type: ignore[type-var]

    def to_dict(self) -> dict[str, Any]:
        """The ``[joints.<j>.friction]`` table."""
        out: dict[str, Any] = {"kind": self.kind}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            out[f.name] = value if f.name == "transition" else float(value)
        return out


@register_friction_law
@dataclass(frozen=True, slots=True, eq=False)
class StribeckFriction(_LinearLaw):
    """Coulomb per direction, viscous and Stribeck friction with a transition through zero.

    For motor velocity ``w`` [rad/s], with ``s(w) = exp(-(|w| / stribeck_velocity) **
    stribeck_exponent)``::

        positive branch  f+(w) =  coulomb_positive + stribeck_positive * s(w)
        negative branch  f-(w) = -coulomb_negative - stribeck_negative * s(w)
        f(w) = b(w) f+(w) + (1 - b(w)) f-(w) + viscous * w

    where the blend ``b`` goes from 0 to 1 across zero velocity: ``transition = "linear"``,
    ``b = clip((w + w0) / (2 w0), 0, 1)``; ``transition = "smooth"`` (pre-sliding),
    ``b = (1 + tanh(w / w0)) / 2``, with ``w0 = zero_velocity``.

    Attributes
    ----------
    coulomb_positive, coulomb_negative
        Coulomb friction magnitudes [N m] for positive and negative motion.
    viscous
        Viscous coefficient [N m s / rad].
    stribeck_positive, stribeck_negative
        Extra break-away torque at low speed [N m].
    stribeck_velocity
        Stribeck velocity [rad/s], > 0.
    zero_velocity
        Width ``w0`` of the transition through zero velocity [rad/s], > 0.
    stribeck_exponent
        Exponent of the Stribeck curve [-], > 0 (2 is the Gaussian form).
    transition
        ``"linear"`` or ``"smooth"``.

    Examples
    --------
    >>> f = StribeckFriction(coulomb_positive=0.1, coulomb_negative=0.2, viscous=0.01)
    >>> f.torque([2.0, -2.0]).round(6)
    array([ 0.12, -0.22])
    >>> bool(np.allclose(f.basis([2.0, -2.0]) @ f.linear_parameters(), f.torque([2.0, -2.0])))
    True
    """

    kind: ClassVar[str] = "stribeck"
    linear_parameter_names: ClassVar[tuple[str, ...]] = (
        "coulomb_positive",
        "coulomb_negative",
        "viscous",
        "stribeck_positive",
        "stribeck_negative",
    )

    coulomb_positive: float = 0.0
    coulomb_negative: float = 0.0
    viscous: float = 0.0
    stribeck_positive: float = 0.0
    stribeck_negative: float = 0.0
    stribeck_velocity: float = 1.0
    zero_velocity: float = 1e-3
    stribeck_exponent: float = 2.0
    transition: Transition = "linear"

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name == "transition":
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(f"friction {f.name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise InputError(f"friction {f.name} must be finite, got {value!r}")
        for name in ("stribeck_velocity", "zero_velocity", "stribeck_exponent"):
            if getattr(self, name) <= 0:
                raise InputError(f"friction {name} must be > 0, got {getattr(self, name)!r}")
        if self.transition not in ("linear", "smooth"):
            raise InputError(
                f"friction transition must be 'linear' or 'smooth', got {self.transition!r}"
            )

    def _blend_and_shape(
        self, velocity: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        w = np.asarray(velocity, dtype=np.float64)
        with np.errstate(over="ignore", divide="ignore"):  # a tiny Stribeck velocity: s -> 0
            s = np.exp(-((np.abs(w) / self.stribeck_velocity) ** self.stribeck_exponent))
        w0 = self.zero_velocity
        if self.transition == "linear":
            b = np.clip((w + w0) / (2.0 * w0), 0.0, 1.0)
        else:
            b = 0.5 * (1.0 + np.tanh(w / w0))
        return w, b, s

    def torque(self, velocity: ArrayLike, *, t: ArrayLike | None = None) -> NDArray[np.float64]:
        """Friction torque [N m] at motor velocity [rad/s] (static: ``t`` is ignored)."""
        w, b, s = self._blend_and_shape(velocity)
        pos = self.coulomb_positive + self.stribeck_positive * s
        neg = -(self.coulomb_negative + self.stribeck_negative * s)
        out: NDArray[np.float64] = b * pos + (1.0 - b) * neg + self.viscous * w
        return out

    def static_levels(self) -> tuple[float, float]:
        """``(coulomb_positive + stribeck_positive, coulomb_negative + stribeck_negative)``."""
        return (
            self.coulomb_positive + self.stribeck_positive,
            self.coulomb_negative + self.stribeck_negative,
        )

    def basis(self, velocity: ArrayLike) -> NDArray[np.float64]:
        """Columns (n, 5) for the linear parameters, in ``linear_parameter_names`` order."""
        w, b, s = self._blend_and_shape(velocity)
        w = np.atleast_1d(w)
        b, s = np.atleast_1d(b), np.atleast_1d(s)
        return np.stack([b, -(1.0 - b), w, b * s, -(1.0 - b) * s], axis=-1)

    @classmethod
    def from_dict(
        cls, table: Mapping[str, Any], *, where: str = "friction", path: str | None = None
    ) -> StribeckFriction:
        """Read the law from its table (``kind`` already removed); InputError on bad keys."""
        body = dict(table)
        transition = body.pop("transition", "linear")
        if transition not in ("linear", "smooth"):
            raise InputError(
                f"{where} transition must be 'linear' or 'smooth', got {transition!r}", path=path
            )
        allowed = {f.name for f in dataclasses.fields(cls)} - {"transition"}
        nums = _finite_floats(body, allowed, where, path, other_keys=("transition",))
        # One side may be negative (an offset: identification writes one where a constant
        # load, such as gravity on a vertical prismatic joint, looks like friction), not the band
        cp, cn = nums.get("coulomb_positive", 0.0), nums.get("coulomb_negative", 0.0)
        if not coulomb_levels_valid(cp, cn):
            raise InputError(
                f"{where} Coulomb magnitudes must be >= 0 (one may be negative, an offset, if "
                f"their sum is positive; got {cp:g}, {cn:g})",
                path=path,
            )
        for name in ("stribeck_velocity", "zero_velocity", "stribeck_exponent"):
            if name in nums and nums[name] <= 0:
                raise InputError(f"{where} {name} must be > 0", path=path)
        try:
            return cls(transition=transition, **nums)
        except InputError as exc:
            raise InputError(f"{where} {exc.message}", path=path) from None


def one_direction_note(way: str) -> str:
    """The warning (after ``"joint <name>: "``) of a joint the logs never moved in direction
    ``way`` (``"positive"`` or ``"negative"``), whose table takes the other's levels
    (:mod:`torquemap.identify_whole`); estimation reads it back
    (:func:`torquemap.estimate.one_direction_task_warnings`).

    Examples
    --------
    >>> one_direction_note("negative")
    "never moved in the negative direction: it takes the positive direction's friction"
    """
    other = "positive" if way == "negative" else "negative"
    return f"never moved in the {way} direction: it takes the {other} direction's friction"


def coulomb_levels_valid(positive: float, negative: float) -> bool:
    """Whether a law's Coulomb magnitudes [N m] can be read from a model file: both >= 0, or
    one negative (an offset) with a positive sum (a friction band that dissipates)."""
    if positive >= 0 and negative >= 0:
        return True
    return positive + negative > 0


@register_friction_law
@dataclass(frozen=True, slots=True, eq=False)
class DirectionalViscousFriction(_LinearLaw):
    """:class:`StribeckFriction` with a viscous coefficient per direction.

    ``f(w) = b(w) (f+(w) + viscous w) + (1 - b(w)) (f-(w) + viscous_negative w)`` with the
    branches, blend and fields of :class:`StribeckFriction` (``viscous`` is the positive
    direction's). Whole-log identification uses it when the two directions' viscous slopes
    differ significantly.

    Examples
    --------
    >>> f = DirectionalViscousFriction(coulomb_positive=0.1, coulomb_negative=0.2,
    ...                                viscous=0.01, viscous_negative=0.02)
    >>> f.torque([2.0, -2.0]).round(6)
    array([ 0.12, -0.24])
    >>> bool(np.allclose(f.basis([2.0, -2.0]) @ f.linear_parameters(), f.torque([2.0, -2.0])))
    True
    """

    kind: ClassVar[str] = "stribeck-directional-viscous"
    linear_parameter_names: ClassVar[tuple[str, ...]] = (
        *StribeckFriction.linear_parameter_names,
        "viscous_negative",
    )

    coulomb_positive: float = 0.0
    coulomb_negative: float = 0.0
    viscous: float = 0.0
    stribeck_positive: float = 0.0
    stribeck_negative: float = 0.0
    stribeck_velocity: float = 1.0
    zero_velocity: float = 1e-3
    stribeck_exponent: float = 2.0
    transition: Transition = "linear"
    viscous_negative: float = 0.0

    def __post_init__(self) -> None:
        self._static()  # validates the shared fields
        if isinstance(self.viscous_negative, bool) or not (
            isinstance(self.viscous_negative, int | float) and math.isfinite(self.viscous_negative)
        ):
            raise InputError(
                f"friction viscous_negative must be a finite number, got {self.viscous_negative!r}"
            )

    def _static(self) -> StribeckFriction:
        """The same law without viscous terms."""
        return StribeckFriction(
            coulomb_positive=self.coulomb_positive,
            coulomb_negative=self.coulomb_negative,
            viscous=0.0,
            stribeck_positive=self.stribeck_positive,
            stribeck_negative=self.stribeck_negative,
            stribeck_velocity=self.stribeck_velocity,
            zero_velocity=self.zero_velocity,
            stribeck_exponent=self.stribeck_exponent,
            transition=self.transition,
        )

    def torque(self, velocity: ArrayLike, *, t: ArrayLike | None = None) -> NDArray[np.float64]:
        """Friction torque [N m] at motor velocity [rad/s] (static: ``t`` is ignored)."""
        static = self._static()
        w, b, _ = static._blend_and_shape(velocity)
        out: NDArray[np.float64] = static.torque(velocity) + w * (
            b * self.viscous + (1.0 - b) * self.viscous_negative
        )
        return out

    def static_levels(self) -> tuple[float, float]:
        """``(coulomb_positive + stribeck_positive, coulomb_negative + stribeck_negative)``."""
        return self._static().static_levels()

    def basis(self, velocity: ArrayLike) -> NDArray[np.float64]:
        """Columns (n, 6) for the linear parameters, in ``linear_parameter_names`` order."""
        static = self._static()
        w, b, _ = static._blend_and_shape(velocity)
        w, b = np.atleast_1d(w), np.atleast_1d(b)
        cols = static.basis(velocity)
        cols[..., 2] = w * b
        return np.concatenate([cols, (w * (1.0 - b))[..., None]], axis=-1)

    @classmethod
    def from_dict(
        cls, table: Mapping[str, Any], *, where: str = "friction", path: str | None = None
    ) -> DirectionalViscousFriction:
        """Read the law from its table (``kind`` already removed); InputError on bad keys."""
        body = dict(table)
        negative = body.pop("viscous_negative", 0.0)
        base = StribeckFriction.from_dict(body, where=where, path=path)
        if isinstance(negative, bool) or not (
            isinstance(negative, int | float) and math.isfinite(negative)
        ):
            raise InputError(f"{where} viscous_negative must be a finite number", path=path)
        fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
        return cls(**fields, viscous_negative=float(negative))


def friction_law_from_dict(
    table: Mapping[str, Any], *, where: str = "friction", path: str | os.PathLike[str] | None = None
) -> FrictionLaw:
    """Read a friction law from its model-file table; ``kind`` defaults to ``"stribeck"``.

    Raises
    ------
    InputError
        On an unknown kind, an unknown key or a bad value, naming ``where`` and ``path``.

    Examples
    --------
    >>> friction_law_from_dict({"coulomb_positive": 0.1}).kind
    'stribeck'
    """
    p = None if path is None else os.fspath(path)
    if not isinstance(table, Mapping):
        raise InputError(f"{where} must be a table", path=p)
    body = dict(table)
    kind = body.pop("kind", "stribeck")
    cls = FRICTION_LAWS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise InputError(
            f"{where} kind must be one of {', '.join(sorted(FRICTION_LAWS))}, got {kind!r}", path=p
        )
    reader = getattr(cls, "from_dict", None)
    if reader is None:  # pragma: no cover - every registered law has one
        raise InputError(f"{where}: law {kind!r} cannot be read from a file", path=p)
    law: FrictionLaw = reader(body, where=where, path=p)
    return law


def _float_tuple(values: Any, where: str, path: str | None) -> tuple[float, ...]:
    if not isinstance(values, list | tuple) or not values:
        raise InputError(f"{where} must be a non-empty list of numbers", path=path)
    out = []
    for x in values:
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
            raise InputError(f"{where} must hold finite numbers, got {x!r}", path=path)
        out.append(float(x))
    return tuple(out)


@register_friction_law
@dataclass(frozen=True, slots=True, eq=False)
class SpeedTableFriction:
    """Dry friction tabulated against the logarithm of speed, per direction, plus viscous.

    A law of no fixed form, for friction whose shape the Stribeck curve does not hold (another
    exponent, a LuGre law's steady state, directions that differ in every term). For motor
    velocity ``w`` [rad/s] and speed ``s = |w|``::

        g+(s) = interp(log s, log speeds, positive) + viscous * s
        g-(s) = interp(log s, log speeds, negative) + viscous_negative * s
        f(w) = b(w) g+(s) - (1 - b(w)) g-(s),   b(w) = (1 + tanh(w / zero_velocity)) / 2

    with ``interp`` linear between the knots and constant beyond them (the first knot's level
    is the break-away level approached at rest). The law is linear in the knot levels and the
    two viscous coefficients, so whole-log identification fits it by (penalised) least squares
    with only the transition width searched (:mod:`torquemap.identify_whole`).

    Attributes
    ----------
    speeds
        Knot speeds [rad/s], strictly increasing, > 0, at least two.
    positive, negative
        Dry friction magnitude at each knot for positive and negative motion [N m].
    viscous, viscous_negative
        Viscous coefficient of each direction [N m s / rad].
    zero_velocity
        Half width of the smooth transition through zero [rad/s], > 0.

    Examples
    --------
    >>> f = SpeedTableFriction(speeds=(1.0, 10.0), positive=(0.2, 0.1), negative=(0.3, 0.1),
    ...                        viscous=0.01, viscous_negative=0.01)
    >>> f.torque([10.0, -10.0, 100.0]).round(6)
    array([ 0.2, -0.2,  1.1])
    >>> round(float(f.torque([np.sqrt(10.0)])[0]), 6)  # halfway in log speed
    0.181623
    >>> bool(np.allclose(f.basis([2.0, -3.0]) @ f.linear_parameters(), f.torque([2.0, -3.0])))
    True
    """

    kind: ClassVar[str] = "speed-table"

    speeds: tuple[float, ...]
    positive: tuple[float, ...]
    negative: tuple[float, ...]
    viscous: float = 0.0
    viscous_negative: float = 0.0
    zero_velocity: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("speeds", "positive", "negative"):
            values = getattr(self, name)
            object.__setattr__(self, name, tuple(float(x) for x in values))
            if not all(math.isfinite(x) for x in getattr(self, name)):
                raise InputError(f"friction {name} must be finite numbers")
        k = len(self.speeds)
        if k < 2 or len(self.positive) != k or len(self.negative) != k:
            raise InputError(
                "friction speeds, positive and negative must be lists of one length, at least 2"
            )
        if self.speeds[0] <= 0 or any(b <= a for a, b in itertools.pairwise(self.speeds)):
            raise InputError("friction speeds must be positive and strictly increasing")
        for name in ("viscous", "viscous_negative", "zero_velocity"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(f"friction {name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise InputError(f"friction {name} must be finite, got {value!r}")
        if self.zero_velocity <= 0:
            raise InputError(f"friction zero_velocity must be > 0, got {self.zero_velocity!r}")

    @property
    def linear_parameter_names(self) -> tuple[str, ...]:
        """``positive_0 .. positive_{k-1}, negative_0 .., viscous, viscous_negative``."""
        k = len(self.speeds)
        return (
            *(f"positive_{i}" for i in range(k)),
            *(f"negative_{i}" for i in range(k)),
            "viscous",
            "viscous_negative",
        )

    def _hats(self, speed: NDArray[np.float64]) -> NDArray[np.float64]:
        """Interpolation weights (n, k) of the knots at ``speed`` (linear in log speed)."""
        logs = np.log(np.asarray(self.speeds))
        x = np.log(np.maximum(speed, 1e-300))
        k = logs.size
        i = np.clip(np.searchsorted(logs, x, side="right") - 1, 0, k - 2)
        u = np.clip((x - logs[i]) / (logs[i + 1] - logs[i]), 0.0, 1.0)
        out = np.zeros((speed.size, k))
        rows = np.arange(speed.size)
        out[rows, i] = 1.0 - u
        out[rows, i + 1] += u
        return out

    def basis(self, velocity: ArrayLike) -> NDArray[np.float64]:
        """Columns (n, 2 k + 2) for the linear parameters, in ``linear_parameter_names`` order."""
        w = np.atleast_1d(np.asarray(velocity, dtype=np.float64)).reshape(-1)
        s = np.abs(w)
        b = 0.5 * (1.0 + np.tanh(w / self.zero_velocity))
        hats = self._hats(s)
        return np.hstack(
            (
                b[:, None] * hats,
                -(1.0 - b)[:, None] * hats,
                (b * s)[:, None],
                (-(1.0 - b) * s)[:, None],
            )
        )

    def linear_parameters(self) -> NDArray[np.float64]:
        """Knot levels [N m] of both directions, then the two viscous coefficients."""
        return np.array([*self.positive, *self.negative, self.viscous, self.viscous_negative])

    def with_linear_parameters(self, values: ArrayLike) -> SpeedTableFriction:
        """A copy with the linear parameters replaced."""
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        k = len(self.speeds)
        if v.size != 2 * k + 2:
            raise ValueError(f"expected {2 * k + 2} values, got {v.size}")
        return dataclasses.replace(
            self,
            positive=tuple(float(x) for x in v[:k]),
            negative=tuple(float(x) for x in v[k : 2 * k]),
            viscous=float(v[-2]),
            viscous_negative=float(v[-1]),
        )

    def torque(self, velocity: ArrayLike, *, t: ArrayLike | None = None) -> NDArray[np.float64]:
        """Friction torque [N m] at motor velocity [rad/s] (static: ``t`` is ignored)."""
        w = np.asarray(velocity, dtype=np.float64)
        s = np.abs(w)
        logs = np.log(np.asarray(self.speeds))
        x = np.log(np.maximum(s, 1e-300))
        up = np.interp(x, logs, self.positive) + self.viscous * s
        down = np.interp(x, logs, self.negative) + self.viscous_negative * s
        b = 0.5 * (1.0 + np.tanh(w / self.zero_velocity))
        out: NDArray[np.float64] = np.asarray(b * up - (1.0 - b) * down, dtype=np.float64)
        return out

    def static_levels(self) -> tuple[float, float]:
        """The first knot's levels (break-away, approached at rest) [N m]."""
        return self.positive[0], self.negative[0]

    def levels(self, speed: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Friction magnitudes ``(g+(s), g-(s))`` [N m] at speeds ``speed`` [rad/s] (>= 0)."""
        s = np.abs(np.asarray(speed, dtype=np.float64))
        logs = np.log(np.asarray(self.speeds))
        x = np.log(np.maximum(s, 1e-300))
        return (
            np.interp(x, logs, self.positive) + self.viscous * s,
            np.interp(x, logs, self.negative) + self.viscous_negative * s,
        )

    def to_dict(self) -> dict[str, Any]:
        """The ``[joints.<j>.friction]`` table."""
        return {
            "kind": self.kind,
            "speeds": list(self.speeds),
            "positive": list(self.positive),
            "negative": list(self.negative),
            "viscous": self.viscous,
            "viscous_negative": self.viscous_negative,
            "zero_velocity": self.zero_velocity,
        }

    @classmethod
    def from_dict(
        cls, table: Mapping[str, Any], *, where: str = "friction", path: str | None = None
    ) -> SpeedTableFriction:
        """Read the law from its table (``kind`` already removed); InputError on bad keys."""
        body = dict(table)
        lists = {}
        for name in ("speeds", "positive", "negative"):
            if name not in body:
                raise InputError(f"{where} needs {name} (a list of numbers)", path=path)
            lists[name] = _float_tuple(body.pop(name), f"{where} {name}", path)
        nums = _finite_floats(
            body,
            {"viscous", "viscous_negative", "zero_velocity"},
            where,
            path,
            other_keys=("speeds", "positive", "negative"),
        )
        try:
            return cls(**lists, **nums)  # type: ignore[arg-type]
        except InputError as exc:
            raise InputError(f"{where} {exc.message}", path=path) from None
