"""One standard deviation of an estimated external torque, from what identification recorded.

A whole-log identification (:mod:`torquemap.identify_whole`) stores, per joint, the names and
covariance of its linear parameters and the low-frequency level of its residual
(``[identification.joints.<j>.uncertainty]``, docs/formats.md). The estimate of the motor torque
that balances the external load is ``T_motor - J acc - f(v) - PDTV(theta)`` through the
low-pass, so its error has three parts, taken as independent:

1. the parameters' error ``G delta`` with ``G`` the regressor row of each sample (acceleration,
   the friction law's basis, the PDTV cosines and sines) through the same low-pass:
   variance ``g^T C g``;
2. the residual noise that passes the low-pass: its low-frequency PSD times the low-pass's
   equivalent noise bandwidth;
3. the sign of friction where the velocity does not tell it (at rest, at a reversal): with
   ``p`` the share of the positive branch at the measured velocity, friction is one branch or
   the other, standard deviation ``sqrt(p (1 - p)) |f+ - f-|`` (half the Coulomb band at rest).
   Neighbouring samples share that error, so it is low-passed as a level, not as noise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.filters import lowpass
from torquemap.identify_whole import LOWPASS_ENB
from torquemap.model import Model


def joint_uncertainty(model: Model, joint: str) -> Mapping[str, Any] | None:
    """The ``uncertainty`` table of a joint's notes, or None when the model has none."""
    joints = model.notes.get("joints", {})
    entry = joints.get(joint) if isinstance(joints, Mapping) else None
    table = entry.get("uncertainty") if isinstance(entry, Mapping) else None
    if not isinstance(table, Mapping):
        return None
    names = table.get("parameters")
    cov = table.get("covariance")
    if not isinstance(names, list) or not isinstance(cov, list):
        return None
    return table


def regressor_columns(
    names: list[str],
    *,
    law: Any,
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The columns (n, p) of the named linear parameters at each sample (motor side)."""
    n = theta.size
    out = np.zeros((n, len(names)))
    basis = law.basis(velocity) if any(s.startswith("friction.") for s in names) else None
    law_names = tuple(getattr(law, "linear_parameter_names", ()))
    pos, neg = velocity > 0, velocity < 0
    for i, name in enumerate(names):
        if name == "inertia.constant":
            out[:, i] = acceleration
        elif name == "inertia.cos_elbow":
            out[:, i] = acceleration * modulation
        elif name.startswith("friction."):
            key = name.split(".", 1)[1]
            if basis is not None and key in law_names:
                out[:, i] = basis[:, law_names.index(key)]
        elif name.startswith("pdtv."):
            body, part = name.rsplit(".", 1)
            order_text, direction = body[len("pdtv.") :].rsplit(".", 1)
            order = float(order_text)
            wave = np.cos(order * theta) if part == "a" else np.sin(order * theta)
            if direction == "positive":
                wave = wave * pos
            elif direction == "negative":
                wave = wave * neg
            out[:, i] = wave
    return out


def sign_sigma(law: Any, velocity: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    """Standard deviation [N m] of friction from not knowing the sign of motion.

    ``sqrt(p (1 - p)) |f+ - f-|`` with ``p = (1 + tanh(v / width)) / 2``: half the band between
    the two branches at rest, vanishing once the velocity is well above ``width``.

    Examples
    --------
    >>> from torquemap.friction_law import StribeckFriction
    >>> f = StribeckFriction(coulomb_positive=0.04, coulomb_negative=0.06)
    >>> sign_sigma(f, np.array([0.0, 1.0]), 0.01).round(6).tolist()
    [0.05, 0.0]
    """
    v = np.asarray(velocity, dtype=np.float64)
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    up, down = law.static_levels()
    shape = np.ones_like(v)
    vs = getattr(law, "stribeck_velocity", None)
    ex = getattr(law, "stribeck_exponent", 2.0)
    cp, cn = getattr(law, "coulomb_positive", up), getattr(law, "coulomb_negative", down)
    if vs is not None:
        shape = np.exp(-((np.abs(v) / vs) ** ex))
        band = cp + cn + (up - cp + down - cn) * shape
    else:
        band = (up + down) * shape
    return np.asarray(np.sqrt(p * (1.0 - p)) * np.abs(band), dtype=np.float64)


def joint_sigma(
    model: Model,
    joint: str,
    *,
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    modulation: NDArray[np.float64],
    cutoff: float,
) -> NDArray[np.float64]:
    """One standard deviation [N m, motor side] of a joint's external-torque estimate.

    NaN everywhere when the model holds no uncertainty for the joint (a model identified by
    the pass method, or written by hand).
    """
    table = joint_uncertainty(model, joint)
    n = t.size
    if table is None:
        return np.full(n, np.nan)
    names = [str(x) for x in table["parameters"]]
    cov = np.asarray(table["covariance"], dtype=np.float64)
    if cov.shape != (len(names), len(names)) or not np.all(np.isfinite(cov)):
        raise InputError(f"[identification.joints.{joint}.uncertainty] covariance is malformed")
    law = model.joints[joint].friction
    g = regressor_columns(
        names,
        law=law,
        theta=theta,
        velocity=velocity,
        acceleration=acceleration,
        modulation=modulation,
    )
    g = lowpass(t, g, cutoff=cutoff) if g.shape[1] else g
    var = np.einsum("ni,ij,nj->n", g, cov, g) if g.shape[1] else np.zeros(n)
    psd = float(table.get("residual_psd", 0.0))
    var = np.maximum(var, 0.0) + max(psd, 0.0) * LOWPASS_ENB * cutoff
    joints = model.notes.get("joints", {})
    entry = joints.get(joint, {}) if isinstance(joints, Mapping) else {}
    resolution = float(entry.get("velocity_resolution", 0.0)) if isinstance(entry, Mapping) else 0.0
    width = max(float(getattr(law, "zero_velocity", 0.0)), resolution, 1e-9)
    sign = lowpass(t, sign_sigma(law, velocity, width), cutoff=cutoff)
    out: NDArray[np.float64] = np.sqrt(var + np.maximum(sign, 0.0) ** 2)
    if not math.isfinite(float(np.max(out, initial=0.0))):
        out = np.where(np.isfinite(out), out, np.nan)
    return out
