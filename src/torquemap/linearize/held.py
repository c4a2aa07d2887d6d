"""Rows the friction held at the top of its band: read after the rig moved into a falling ramp.

The collection measures a block of rising pulse widths at one target of the secondary joint.
Under load the rig's compliance lets the motor move, and each level's actuation is looked up
again at the position the encoder then reads (:func:`torquemap.linearize.collect.measure_block`).
Where the ramp lowers a phase's share at that new position (a phase switching off), the
re-applied actuation gives less torque than the one the contact force rose under. The static
friction then holds the force: the contact unloads only until the motor's torque plus the
friction balances it, so the row reads up to ``t + F`` (``t`` the motor's torque, ``F`` the
friction) instead of the ``t - F`` every rising row reads. The force stays held at the next
levels until the torque has risen by up to ``2 F``, and the motor may rock between the two
positions while the actuation is looked up again, the row being stored under the last one
consulted.

Such a row is not a reading of the rising curve the tables invert: at a hand-over it lies up to
twice the friction above it. Rows are marked from the data alone: in collection order, a block
is a run of rising pulse widths; a row is marked when its block moved into its position from one
where the ramp's total share was higher (a phase switching off while the others hold: the
torque falls whatever the phases' gains), and so is every later row of the block stored at a
position it entered that way. In a cross-fade (one phase's share rising as another's falls,
the total unchanged) the torque may fall or rise with the phases' gains at that position: given
a model of the torque (the structured surface, :mod:`torquemap.linearize.surface`), a move
counts where the model's torque falls by more than three rows' noise, and the block's rows at
that position are marked until the model's torque there has risen past the fall. Rows in other
orders (a file shuffled or sorted by hand: not blocks of rising pulse widths each starting at
0, :func:`in_blocks`) mark nothing. With the model, a fall
of the total share counts too only where the model's torque falls (a phase switching off where
its torque is small holds nothing).

This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Tolerance on the ramp's shares.
SHARE_TOL = 1e-9
#: With a model of the torque: a move counts where the model's torque falls by more than this
#: many rows' noise (a smaller fall cannot be told from the rows' noise).
FALL_NOISE = 3.0


def in_blocks(pulse_width: ArrayLike) -> bool:
    """Whether the rows are in the collection's order: blocks of rising pulse widths, each
    starting at 0.

    Examples
    --------
    >>> in_blocks([0, 4, 8, 0, 4]), in_blocks([0, 8, 4, 0]), in_blocks([4, 8])
    (True, False, False)
    """
    pw = np.asarray(pulse_width, dtype=np.float64)
    if pw.size == 0 or pw[0] != 0:
        return False
    block = np.cumsum(pw == 0)
    same = block[1:] == block[:-1]
    return not bool(np.any(same & (np.diff(pw) <= 0)))


def held_rows(
    position: ArrayLike,
    pulse_width: ArrayLike,
    ramp: ArrayLike,
    *,
    change: ArrayLike | None = None,
    torque: ArrayLike | None = None,
    noise: float = 0.0,
    compliance: float = 0.0,
) -> NDArray[np.bool_]:
    """Rows read after the block moved into a position where the re-looked-up actuation gives
    less torque.

    Without a model (``change`` None) a move counts where the ramp's total share falls (a
    phase switching off while the others hold); such a row and every later row of its block at
    that position are marked. With a model of the torque (``change``, ``torque``), a move counts
    only where the model's torque falls by more than :data:`FALL_NOISE` rows' noise (also in a
    cross-fade, one phase rising as another falls: the torque may fall or rise). Where the fall
    times ``compliance`` is half a position or more, the unloading moves the motor back across
    the position's edge and it rocks between the two positions at every later level (each
    looks the actuation up again): the row and every later row of its block at that position
    are marked. Otherwise the block's rows there are marked until the model's torque has risen
    past the fall (the friction holds the force by at most the fall).

    Parameters
    ----------
    position
        Table position of each row, in collection order, ``0 .. P - 1``, shape (n,).
    pulse_width
        Base pulse width of each row, shape (n,); a block is a run of rising pulse widths.
    ramp
        The ramping function (each phase's share of the base pulse width), shape (P, m).
    change
        The model's torque at each row's position and pulse width under the row's shares less
        under the previous row's [N m], shape (n,).
    torque
        The model's torque at each row's position, pulse width and shares [N m], shape (n,).
    noise
        One row's noise [N m].
    compliance
        How far the motor moves per unit of contact torque [table positions per N m]
        (:func:`compliance_from_blocks`).

    Returns
    -------
    NDArray[np.bool_]
        True for each row whose reading the friction may have held above the rising curve,
        shape (n,).

    Examples
    --------
    >>> ramp = np.array([[1.0, 1.0], [1.0, 0.5], [1.0, 0.0], [1.0, 0.0]])
    >>> held_rows([0, 0, 1, 1, 2, 0, 0], [0, 4, 8, 12, 16, 0, 4], ramp).tolist()
    [False, False, True, True, True, False, False]
    """
    pos = np.asarray(position, dtype=np.int64)
    pw = np.asarray(pulse_width, dtype=np.float64)
    r = np.asarray(ramp, dtype=np.float64)
    mark = np.zeros(pos.size, dtype=bool)
    if pos.size < 2 or not in_blocks(pw):
        return mark
    same_block = np.r_[False, pw[1:] > pw[:-1]]
    moved = same_block & np.r_[False, pos[1:] != pos[:-1]]
    prev = np.r_[pos[0], pos[:-1]]
    fell = moved & (r[pos].sum(axis=1) < r[prev].sum(axis=1) - SHARE_TOL)
    entered: set[int] = set()
    for i in range(pos.size):
        if not same_block[i]:
            entered = set()
            continue
        if fell[i]:
            entered.add(int(pos[i]))
        mark[i] = int(pos[i]) in entered
    if change is None or torque is None:
        return mark
    drop = -np.asarray(change, dtype=np.float64)
    model = np.asarray(torque, dtype=np.float64)
    falls = moved & (drop > FALL_NOISE * noise)
    # the fall unloads the contact by about itself: where that moves the motor back by half a
    # position or more, it rocks between the two positions at every later level
    rocks = falls & (drop * compliance >= 0.5)
    mark[:] = False
    rocking: set[int] = set()
    held: dict[int, tuple[float, float]] = {}  # position: (model torque at entry, the fall)
    for i in range(pos.size):
        if not same_block[i]:
            rocking, held = set(), {}
            continue
        q = int(pos[i])
        if rocks[i]:
            rocking.add(q)
        elif falls[i]:
            held[q] = (float(model[i]), float(drop[i]))
        if q in rocking:
            mark[i] = True
        elif q in held:
            begin, fall = held[q]
            if model[i] - begin < fall:
                mark[i] = True
            else:
                del held[q]
    return mark


def compliance_from_blocks(
    position: ArrayLike, pulse_width: ArrayLike, torque: ArrayLike, positions_per_cycle: int
) -> float:
    """How far the rig's compliance moves the motor per unit of contact torque [table
    positions per N m], read from the collection's blocks.

    Each block (a run of rising pulse widths, in collection order) starts at its target; its
    rows are stored at the positions the encoder read as the load moved the motor. The least
    squares slope through the origin of each row's offset from its block's first row against
    its torque (the rows that read torque).

    Parameters
    ----------
    position
        Table position of each row, in collection order, shape (n,).
    pulse_width
        Base pulse width of each row, shape (n,).
    torque
        Each row's torque [N m], shape (n,).
    positions_per_cycle
        ``P`` (offsets are taken the short way round the cycle).

    Returns
    -------
    float
        The slope; 0 when no row reads torque.

    Examples
    --------
    >>> round(compliance_from_blocks([4, 4, 5, 6, 8], [0, 4, 8, 12, 0], [0, 1, 2, 4, 0], 16), 3)
    0.476
    """
    pos = np.asarray(position, dtype=np.int64)
    pw = np.asarray(pulse_width, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    n = int(positions_per_cycle)
    if pos.size == 0:
        return 0.0
    start = np.r_[True, pw[1:] <= pw[:-1]]
    target = pos[np.flatnonzero(start)][np.cumsum(start) - 1]
    offset = (pos - target + n // 2) % n - n // 2
    use = tau > 0
    weight = float(tau[use] @ tau[use])
    return float(offset[use] @ tau[use]) / weight if weight > 0 else 0.0
