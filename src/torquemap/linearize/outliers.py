"""A row far off its neighbours: a hand edit or a glitch, refused before it bends the tables;
and rows no longer in the collection's order (:func:`row_order_advice`).

At one table position the torque is a smooth function of the pulse width (or, through the
tables, of the command): a row that leaves the line through its neighbouring levels by a
quarter of the data's torque range is no measurement of it. One such row (a torque typed ten
times too large in a hand-edited DATA.csv, QA stop 36) took the tables of a 240-position
sinusoidal motor from 1.30 % to 7.47 % APMD (noise-free), exit 0 and no word: the low-rank
denoiser spent its first singular value on it (rank 8 -> 1). A sign typed away did 1.30 % ->
1.86 %.

Per position, the cells (the mean of the rows at one level) in level order; for each inner
cell the residual ``r`` from the straight line through the cells on either side. A cell is
named when ``|r|`` exceeds both :data:`RANGE_SHARE` of the 99th percentile of the cells'
absolute torque and :data:`NOISE_MULTIPLE` times the residuals' robust spread (1.4826 times
their median absolute deviation): so the knee, the phases' hand-over and the friction's steps
stay far inside: on the QA's 51 collections and verifications (the motors of the QA table,
adaptive runs, the family's seeds 0 to 19: at most 0.028) the largest ``|r|`` read 0.005 to
0.077 of the range, 0.148 on the verification of a compliant 12-position rig (58 spreads),
against 1.39 and 6.2 for the two typos (960 and 4300 spreads). Where a cell is named, the row in it farthest from
the line is given, numbered as a data row.

This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from torquemap.errors import InputError
from torquemap.robust import robust_scale

#: Share of the torque range a cell must leave its neighbours' line by.
RANGE_SHARE = 0.25
#: Robust spreads of the residuals it must leave it by as well.
NOISE_MULTIPLE = 30.0


def outlier_advice(
    position: ArrayLike, level: ArrayLike, torque: ArrayLike, *, what: str = "pulse width"
) -> str:
    """One line naming the row farthest off its neighbours' line (module docstring), else "".

    Parameters
    ----------
    position
        Table position of each row, shape (n,).
    level
        Base pulse width (characterisation) or command (verification), shape (n,).
    torque
        The rows' torques [N m], shape (n,).
    what
        The level's name in the line.

    Examples
    --------
    >>> pos = np.repeat(np.arange(4), 8)
    >>> pw = np.tile(np.arange(0, 256, 32), 4)
    >>> tau = 0.01 * pw + 0.001 * np.random.default_rng(0).standard_normal(pw.size)
    >>> outlier_advice(pos, pw, tau)
    ''
    >>> tau[13] *= 10
    >>> outlier_advice(pos, pw, tau)[:43]
    'data row 14 (position 1, pulse width 160) r'
    """
    pos = np.asarray(position, dtype=np.int64)
    lv = np.asarray(level, dtype=np.int64)
    tau = np.asarray(torque, dtype=np.float64)
    if pos.size < 3:
        return ""
    shift = int(lv.min())
    width = int(lv.max()) - shift + 1
    key = pos * width + (lv - shift)
    keys, inverse = np.unique(key, return_inverse=True)
    mean = np.bincount(inverse, weights=tau) / np.bincount(inverse)
    cp, cl = keys // width, keys % width + shift
    same_before = np.r_[False, cp[1:] == cp[:-1]]
    same_after = np.r_[cp[:-1] == cp[1:], False]
    inner = np.flatnonzero(same_before & same_after)
    if inner.size == 0:
        return ""
    a, b = inner - 1, inner + 1
    f = (cl[inner] - cl[a]) / (cl[b] - cl[a])
    r = mean[inner] - (mean[a] + f * (mean[b] - mean[a]))
    spread = robust_scale(r)
    scale = float(np.quantile(np.abs(mean), 0.99))
    bound = max(RANGE_SHARE * scale, NOISE_MULTIPLE * spread)
    if not bound > 0:
        return ""
    worst = int(np.argmax(np.abs(r)))
    if abs(r[worst]) <= bound:
        return ""
    cell = inner[worst]
    rows = np.flatnonzero(inverse == cell)
    line = mean[a[worst]] + f[worst] * (mean[b[worst]] - mean[a[worst]])
    row = int(rows[np.argmax(np.abs(tau[rows] - line))])
    return (
        f"data row {row + 1} (position {int(pos[row])}, {what} {int(lv[row])}) reads "
        f"{tau[row]:.4g} N m where the {what}s on either side ({int(cl[a[worst]])}, "
        f"{int(cl[b[worst]])}) read {mean[a[worst]]:.4g} and {mean[b[worst]]:.4g} N m: a hand "
        "edit or a glitch? Correct or delete the row and run again"
    )


def check_outliers(
    position: ArrayLike,
    level: ArrayLike,
    torque: ArrayLike,
    *,
    what: str = "pulse width",
    path: str | None = None,
) -> None:
    """Refuse data holding a row far off its neighbours' line (:func:`outlier_advice`).

    Raises
    ------
    InputError
        Naming ``path``, with the line of :func:`outlier_advice`.
    """
    advice = outlier_advice(position, level, torque, what=what)
    if advice:
        raise InputError(advice, path=path)


def check_rows_read(
    position: ArrayLike,
    level: ArrayLike,
    torque: ArrayLike,
    *,
    what: str = "pulse width",
    path: str | None = None,
) -> None:
    """Refuse rows as read that no table or figure should be drawn from: a torque falling as
    the level rises (:func:`torquemap.linearize.sign.check_torque_sign`, a sensor mounted the
    other way round) or a row far off its neighbours' line (:func:`check_outliers`).

    The checks ``linearize evaluate`` and ``linearize figures`` run on the rows as read, in
    that order (``build`` runs the same two, around its bias restoration).

    Parameters
    ----------
    position, level, torque
        The rows: table position, pulse width (characterisation) or command (verification),
        torque [N m], each shape (n,).
    what
        The level's name in the line (``"pulse width"`` or ``"command"``).
    path
        The data file named in the refusal.

    Raises
    ------
    InputError
        Naming ``path``, in one line.
    """
    from torquemap.linearize.sign import check_torque_sign

    check_torque_sign(position, level, torque, what=what, path=path)
    check_outliers(position, level, torque, what=what, path=path)


def row_order_advice(reason: str) -> str:
    """One line when the denoiser was skipped because the rows are not in the collection's
    order, else "".

    :func:`torquemap.linearize.denoise.denoise_blocks` reads the collection's blocks (each
    target's sweep from pulse width 0 upwards) from the row order; a DATA.csv sorted or shuffled
    in a spreadsheet is used as measured, without a word (QA stop 36: a 240-position PMSM's
    tables 1.37 % against 1.30 % from the file as collected).

    Parameters
    ----------
    reason
        :attr:`torquemap.linearize.denoise.Denoised.reason`.

    Examples
    --------
    >>> row_order_advice("rows are not blocks of increasing levels from 0")[:20]
    'the rows are not in '
    >>> row_order_advice("")
    ''
    """
    if not reason.startswith("rows are not blocks"):
        return ""
    return (
        "the rows are not in the collection's order (each target's sweep from pulse width 0 "
        "upwards, as linearize collect writes them): the low-rank denoiser, which reads the "
        "blocks from that order, was skipped; build from the file as collected"
    )
