"""The motor file (MOTOR.toml) and the phase transition ramping function (Adept II paper, §3).

A motor for torque linearisation is described by its number of phases ``m``, the number ``P`` of
table positions in one actuation cycle, the width of the signed torque command, the full-scale
pulse width, one equilibrium table position per phase, and a ramping function: for every table
position, the proportion in [0, 1] of the base actuation (pulse width) that each phase receives.
The paper's Figs 7 and 13 show the two trapezoidal ramping functions written here, ``"narrow"``
and ``"wide"``; any other ramp can be given as a CSV file (docs/linearize-collect.md).

Ramping breakpoints (``W = P / m`` table positions, "a phase's third" for ``m = 3``): phase ``k``
(1-based) owns the interval ``[(k - 1) W, k W)`` and is centred at ``c_k = (k - 1/2) W``; the phase
sequence 1, 2, ..., m is the positive direction. A transition region of half width ``h`` is centred
on every boundary ``k W``, where phase ``k`` hands over to phase ``k + 1`` (and phase ``m`` to
phase 1 at 0). With ``d`` the circular distance of a position from ``c_k``, the proportion is
``clip((a + r - |d|) / r, 0, 1)``: 1.0 on a plateau of half width ``a``, a linear ramp of length
``r``, zero beyond ``a + r = W/2 + h`` (the far edge of the neighbouring transition region).

==========  =======  ==============  ===========  ==========================================
kind        ``h``    plateau ``2a``  ramp ``r``   in the transition regions
==========  =======  ==============  ===========  ==========================================
``narrow``  ``W/4``  ``W/2``         ``W/2``      complementary ramps across the whole
                                                  region; the proportions sum to 1
``wide``    ``W/6``  ``7W/6``        ``W/12``     each phase stays at 1.0 across most of the
                                                  region; both at 1.0 over its middle ``W/6``
==========  =======  ==============  ===========  ==========================================

For ``m = 3``, ``P = 512``: narrow has single-phase regions and transition regions of 85.3
positions each (the ticks of Fig 7), plateaus of 85.3 and ramps of 85.3 positions; wide has
single-phase regions of 113.8 positions, transition regions of 56.9, plateaus of 199.1 and ramps
of 14.2 positions. Both ramps are evaluated at the integer positions ``0 .. P - 1``. A motor with
one phase (brushed) gets 1.0 everywhere.

References
----------
.. [1] The Adept II torque linearisation paper, §3 (Figs 7, 13), §4.3 and §5.2
   (/work/shared/seeds/001_*.txt).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.io import numeric_column, read_table
from torquemap.tomlfile import read_toml

RampKind = Literal["narrow", "wide"]

_MOTOR_KEYS = (
    "name",
    "phases",
    "positions_per_cycle",
    "command_bits",
    "actuation_max",
    "equilibrium_positions",
    "ramping",
    "cogging_periods",
)
_REQUIRED = ("name", "phases", "positions_per_cycle", "equilibrium_positions", "ramping")

#: Largest number of phases a motor file may give.
MAX_PHASES = 64
#: Largest number of table positions in one actuation cycle (16 position bits).
MAX_POSITIONS_PER_CYCLE = 1 << 16
#: Largest table per phase, ``positions_per_cycle * 2**command_bits`` entries (16 Mi).
MAX_TABLE_ENTRIES = 1 << 24
#: Largest full-scale pulse width (a table entry is at most 32 bits).
MAX_ACTUATION = (1 << 32) - 1


@dataclass(frozen=True, slots=True, eq=False)
class MotorSpec:
    """A motor as the torque-linearisation tables see it (the MOTOR.toml file).

    Attributes
    ----------
    name
        Free-form name.
    phases
        Number of phases ``m`` (1 for a brushed motor).
    positions_per_cycle
        Table positions ``P`` in one actuation cycle.
    command_bits
        Width of the signed torque command [bits]; the table has ``2**command_bits`` columns.
    actuation_max
        Full-scale pulse width (the largest actuation value a phase accepts).
    equilibrium_positions
        One table position per phase: where the motor settles with that phase alone energised.
    ramping
        ``"narrow"``, ``"wide"``, or the ramp CSV path as written in the file.
    ramp
        Proportions in [0, 1] actually used, shape (P, m): ``ramp[p, k]`` is the share of the
        base actuation phase ``k + 1`` receives at table position ``p``.
    path
        The file the spec was read from, or None.
    cogging_periods
        Periods of the cogging (detent) torque per actuation cycle, when the file states them
        (optional key; from the motor's slot and pole counts); None when unknown.
    """

    name: str
    phases: int
    positions_per_cycle: int
    command_bits: int
    actuation_max: int
    equilibrium_positions: tuple[int, ...]
    ramping: str
    ramp: NDArray[np.float64]
    path: str | None
    cogging_periods: int | None = None


def ramp_function(kind: RampKind, *, phases: int, positions_per_cycle: int) -> NDArray[np.float64]:
    """The narrow or wide trapezoidal ramping function (paper Figs 7 and 13).

    Parameters
    ----------
    kind
        ``"narrow"`` (short plateaus, long complementary ramps) or ``"wide"`` (long plateaus
        overlapping in the transition regions, short ramps). Breakpoints: module docstring.
    phases
        Number of phases ``m`` (>= 1).
    positions_per_cycle
        Table positions ``P`` per actuation cycle (>= 2 m).

    Returns
    -------
    ndarray
        Proportions in [0, 1], shape (P, m).

    Raises
    ------
    ValueError
        On an unknown kind, or too few positions for the phases.

    Examples
    --------
    >>> r = ramp_function("narrow", phases=3, positions_per_cycle=24)
    >>> r[:12, 0].tolist()
    [0.5, 0.75, 1.0, 1.0, 1.0, 1.0, 1.0, 0.75, 0.5, 0.25, 0.0, 0.0]
    >>> bool(abs(r.sum(axis=1) - 1).max() < 1e-12)
    True
    """
    m, n = int(phases), int(positions_per_cycle)
    if m < 1:
        raise ValueError(f"phases must be >= 1, got {phases}")
    if n < 2 * m:
        raise ValueError(f"positions_per_cycle must be >= 2 * phases, got {positions_per_cycle}")
    if kind not in ("narrow", "wide"):
        raise ValueError(f"ramping must be 'narrow' or 'wide', got {kind!r}")
    if m == 1:
        return np.ones((n, 1))
    w = n / m
    if kind == "narrow":
        h, r = w / 4.0, w / 2.0
    else:
        h, r = w / 6.0, w / 12.0
    a = w / 2.0 + h - r
    p = np.arange(n, dtype=np.float64)[:, None]
    centres = (np.arange(m) + 0.5) * w
    d = np.abs((p - centres[None, :] + n / 2.0) % n - n / 2.0)
    out: NDArray[np.float64] = np.clip((a + r - d) / r, 0.0, 1.0)
    return out


def read_ramp_csv(
    path: str | os.PathLike[str], *, phases: int, positions_per_cycle: int
) -> NDArray[np.float64]:
    """Read a ramping function from CSV (or Parquet).

    Parameters
    ----------
    path
        Columns ``phase_1`` .. ``phase_m`` with ``P`` rows, row ``p`` for table position ``p``;
        an optional ``position`` column holding each of ``0 .. P - 1`` once orders the rows.
    phases
        Number of phases ``m``.
    positions_per_cycle
        Table positions ``P``.

    Returns
    -------
    ndarray
        Proportions in [0, 1], shape (P, m).

    Raises
    ------
    InputError
        On a missing or unknown column, the wrong number of rows, positions that do not cover
        ``0 .. P - 1``, or a value outside [0, 1].
    """
    p = os.fspath(path)
    columns = read_table(p)
    wanted = [f"phase_{k + 1}" for k in range(phases)]
    for name in columns:
        if name not in wanted and name != "position":
            raise InputError(
                f"unknown ramp column {name!r} (expected position, {', '.join(wanted)})", path=p
            )
    ramp = np.column_stack([numeric_column(columns, name, p) for name in wanted])
    n = positions_per_cycle
    if ramp.shape[0] != n:
        raise InputError(
            f"ramp has {ramp.shape[0]} rows, expected one per table position ({n})", path=p
        )
    if "position" in columns:
        pos = numeric_column(columns, "position", p)
        if not np.array_equal(np.sort(pos), np.arange(n)):
            raise InputError(f"ramp column 'position' must hold each of 0 .. {n - 1} once", path=p)
        ramp = ramp[np.argsort(pos)]
    bad = (ramp < 0.0) | (ramp > 1.0)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        raise InputError(
            f"ramp value {ramp[row, col]:g} in {wanted[col]} (data row {row + 1}) is outside [0, 1]",
            path=p,
        )
    return np.ascontiguousarray(ramp, dtype=np.float64)


def ramped_actuation(
    pulse_width: ArrayLike, position: ArrayLike, ramp: NDArray[np.float64]
) -> NDArray[np.int64]:
    """Per-phase actuation: the base pulse width times each phase's proportion, rounded.

    Parameters
    ----------
    pulse_width
        Base actuation (pulse width) before ramping, scalar or any shape broadcasting with
        ``position``.
    position
        Table position(s), wrapped into ``0 .. P - 1``.
    ramp
        Ramping function, shape (P, m).

    Returns
    -------
    ndarray of int64
        ``rint(pulse_width * ramp[position, k])`` (round half to even), shape
        ``broadcast(pulse_width, position).shape + (m,)``.

    Examples
    --------
    >>> r = ramp_function("narrow", phases=3, positions_per_cycle=24)
    >>> ramped_actuation(200, 1, r).tolist()
    [150, 0, 50]
    """
    table = np.asarray(ramp, dtype=np.float64)
    pw = np.asarray(pulse_width, dtype=np.float64)
    pos = np.asarray(position, dtype=np.int64) % table.shape[0]
    out: NDArray[np.int64] = np.rint(pw[..., None] * table[pos]).astype(np.int64)
    return out


def _int(
    value: Any,
    what: str,
    path: str | None,
    *,
    low: int,
    high: int | None = None,
    cap: int | None = None,
) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"[motor] {what} must be an integer, got {value!r}", path=path)
    if value < low or (high is not None and value > high):
        bound = f">= {low}" if high is None else f"in {low} .. {high}"
        raise InputError(f"[motor] {what} must be {bound}, got {value}", path=path)
    if cap is not None and value > cap:
        raise InputError(f"[motor] {what} must be at most {cap}, got {value}", path=path)
    return int(value)


def motor_from_dict(
    document: Mapping[str, Any],
    *,
    path: str | os.PathLike[str] | None = None,
) -> MotorSpec:
    """Build a :class:`MotorSpec` from a parsed MOTOR.toml document.

    Parameters
    ----------
    document
        The parsed TOML, with a ``[motor]`` table.
    path
        The file it came from: error messages name it, and a ramp CSV path is relative to its
        folder (to the working directory when None).

    Returns
    -------
    MotorSpec
        The motor, with its ramp read or computed.

    Raises
    ------
    InputError
        On a missing or unknown key, a wrong type or an out-of-range value, naming it and the
        file; on a bad ramp CSV (see :func:`read_ramp_csv`).
    """
    p = None if path is None else os.fspath(path)
    for key in document:
        if key != "motor":
            raise InputError(f"unknown key {key!r} (the file holds one table, [motor])", path=p)
    if "motor" not in document:
        raise InputError("missing table [motor]", path=p)
    table = document["motor"]
    if not isinstance(table, Mapping):
        raise InputError("[motor] must be a table", path=p)
    for key in table:
        if key not in _MOTOR_KEYS:
            raise InputError(
                f"unknown key {key!r} in [motor] (allowed: {', '.join(_MOTOR_KEYS)})", path=p
            )
    for key in _REQUIRED:
        if key not in table:
            raise InputError(f"[motor] is missing {key}", path=p)
    name = table["name"]
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"[motor] name must be a non-empty string, got {name!r}", path=p)
    m = _int(table["phases"], "phases", p, low=1, cap=MAX_PHASES)
    n = _int(
        table["positions_per_cycle"],
        "positions_per_cycle",
        p,
        low=2 * m,
        cap=MAX_POSITIONS_PER_CYCLE,
    )
    bits = _int(table.get("command_bits", 8), "command_bits", p, low=2, high=16)
    if n << bits > MAX_TABLE_ENTRIES:
        raise InputError(
            f"[motor] positions_per_cycle x 2**command_bits = {n} x {1 << bits} = {n << bits} "
            f"table entries per phase, more than the {MAX_TABLE_ENTRIES} (2**24) allowed",
            path=p,
        )
    top = _int(table.get("actuation_max", 255), "actuation_max", p, low=1, cap=MAX_ACTUATION)
    raw_eq = table["equilibrium_positions"]
    if not isinstance(raw_eq, list) or len(raw_eq) != m:
        raise InputError(
            f"[motor] equilibrium_positions must be a list of {m} integers (one per phase), "
            f"got {raw_eq!r}",
            path=p,
        )
    eq = tuple(
        _int(v, f"equilibrium_positions[{k}]", p, low=0, high=n - 1) for k, v in enumerate(raw_eq)
    )
    for k, e in enumerate(eq):
        if e in eq[:k]:  # each phase alone pulls the rotor to its own position (paper §4.3)
            raise InputError(
                f"[motor] equilibrium_positions: phases {eq.index(e) + 1} and {k + 1} are both "
                f"at table position {e}; each phase settles at its own position (a phase "
                "listed twice?)",
                path=p,
            )
    ramping = table["ramping"]
    if not isinstance(ramping, str) or not ramping.strip():
        raise InputError(
            f"[motor] ramping must be 'narrow', 'wide' or a CSV path, got {ramping!r}", path=p
        )
    if ramping in ("narrow", "wide"):
        ramp = ramp_function(ramping, phases=m, positions_per_cycle=n)  # type: ignore[arg-type]
    else:
        base = Path(p).parent if p is not None else Path()
        csv = base / ramping
        if not csv.exists():
            raise InputError(f"[motor] ramping file {ramping!r} not found (at {csv})", path=p)
        ramp = read_ramp_csv(csv, phases=m, positions_per_cycle=n)
    cogging = table.get("cogging_periods")
    periods = None if cogging is None else _int(cogging, "cogging_periods", p, low=1, high=n)
    return MotorSpec(
        name=name,
        phases=m,
        positions_per_cycle=n,
        command_bits=bits,
        actuation_max=top,
        equilibrium_positions=eq,
        ramping=ramping,
        ramp=ramp,
        path=p,
        cogging_periods=periods,
    )


def load_motor(path: str | os.PathLike[str]) -> MotorSpec:
    """Read a MOTOR.toml file (docs/linearize-collect.md).

    Parameters
    ----------
    path
        The TOML file.

    Returns
    -------
    MotorSpec
        The motor and its ramp.

    Raises
    ------
    InputError
        On a missing, empty or malformed file, and on every bad key or value (naming it and
        the file).
    """
    return motor_from_dict(read_toml(path), path=path)


def motor_to_dict(spec: MotorSpec) -> dict[str, Any]:
    """The TOML document of a motor file; write it with :func:`torquemap.io.write_toml`.

    The ramp itself is not written: ``ramping`` names the kind or the CSV path, as read.

    Examples
    --------
    >>> spec = motor_spec("m", phases=3, positions_per_cycle=12, equilibrium_positions=(5, 9, 1))
    >>> motor_to_dict(spec)["motor"]["ramping"]
    'wide'
    """
    table: dict[str, Any] = {
        "name": spec.name,
        "phases": spec.phases,
        "positions_per_cycle": spec.positions_per_cycle,
        "command_bits": spec.command_bits,
        "actuation_max": spec.actuation_max,
        "equilibrium_positions": list(spec.equilibrium_positions),
        "ramping": spec.ramping,
    }
    if spec.cogging_periods is not None:
        table["cogging_periods"] = spec.cogging_periods
    return {"motor": table}


def motor_spec(
    name: str,
    *,
    phases: int,
    positions_per_cycle: int,
    equilibrium_positions: tuple[int, ...],
    ramping: RampKind = "wide",
    command_bits: int = 8,
    actuation_max: int = 255,
    cogging_periods: int | None = None,
) -> MotorSpec:
    """A :class:`MotorSpec` with a narrow or wide ramp, built in code (no file).

    Values are checked as :func:`motor_from_dict` checks a file's.

    Examples
    --------
    >>> motor_spec("vr", phases=3, positions_per_cycle=512, equilibrium_positions=(213, 384, 43)).ramp.shape
    (512, 3)
    """
    document = {
        "motor": {
            "name": name,
            "phases": phases,
            "positions_per_cycle": positions_per_cycle,
            "command_bits": command_bits,
            "actuation_max": actuation_max,
            "equilibrium_positions": [int(e) for e in equilibrium_positions],
            "ramping": ramping,
        }
    }
    if cogging_periods is not None:
        document["motor"]["cogging_periods"] = cogging_periods
    return motor_from_dict(document)


def command_range(spec: MotorSpec) -> int:
    """The largest positive torque command, ``2**(command_bits - 1) - 1``.

    Examples
    --------
    >>> command_range(motor_spec("m", phases=1, positions_per_cycle=4, equilibrium_positions=(0,)))
    127
    """
    return int(math.ldexp(1, spec.command_bits - 1)) - 1
