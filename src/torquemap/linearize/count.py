"""What one table position spans: the torque within a count, which the tables cannot hold.

A table holds one entry per table position (an encoder count of the actuation cycle). The
collection, and a verification through the tables, read the torque where the rig settles within
each count (the secondary joint steps until the encoder reads the target: always near the same
edge of the count). A motor elsewhere within the count gets the same entry and another torque.
On the family's motors (128 to 512 positions per cycle) that is a fraction of a percent; on a
motor with few positions per cycle it is most of the deviation, and the APMD the verification
measures does not see it (QA stop 36: 12 positions per cycle, a sinusoidal three-phase motor,
every position collected and verified: 1.40 % measured where the rig settled, 1.9 % to 12.4 %
with the motor held at other fractions of a count, 6.2 % on average).

The change over one count is read from the data at pairs of neighbouring measured positions
``a``, ``b = a + s`` between which the ramp gives every phase the same share (the actuation is
then the same at both and between): at each pulse width both hold, with the torque above half
the largest read, ``r = |T(b) - T(a)| / (s (T(a) + T(b)) / 2)``, the relative change per
count. A motor spread evenly over a count, the table right at one point of it, deviates by at
least ``r / 4`` on average (``E|x - x0| >= 1/4`` for ``x`` uniform on a unit interval; ``r/2`` if
the point is an edge). The mean of ``r / 4`` over the pairs is the figure; it is named when it
exceeds :data:`WITHIN_COUNT` (1 %) over at least :data:`FEWEST_CELLS` cells. On the QA's motors,
against the truth's mean over fractions of a count less the APMD at the settled points: 12
positions 3.3 % (truth 4.8 %), 24 positions 1.8 % (2.6 %), a hybrid stepper's 64 positions 0.9 %
(1.0 %, 6 cells: silent), a 240-position motor 0.3 % (0.4 %); the family's seeds 1, 3, 4 read
0.11 to 0.24 % (silent), the closed-form surfaces of the gap tests up to 0.95 % (silent). A ramp
that changes at every position (6 positions per cycle for 3 phases) leaves no such pair: that is
named without a figure.

This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from torquemap.errors import InputError

#: Largest ``positions_per_cycle * (actuation_max + 1)`` the tables are built on
#: (:func:`torquemap.linearize.tables.build_tables`): its forward model holds every (position,
#: pulse width) cell of every phase (512 x 4096 x 3 phases measured 1.1 GB and 3 min of CPU;
#: 512 x 100001 was killed for memory).
MAX_GRID_CELLS = 1 << 21
#: The mean deviation within a count (a fraction) above which :func:`within_count_advice` speaks.
WITHIN_COUNT = 0.01
#: Fewest (pair, pulse width) cells the figure must rest on to be named.
FEWEST_CELLS = 16


def within_count_change(
    position: ArrayLike, pulse_width: ArrayLike, torque: ArrayLike, ramp: ArrayLike
) -> tuple[float, int]:
    """The mean of ``r / 4`` over neighbouring measured positions of one ramp share (module
    docstring), and how many (pair, pulse width) cells it rests on.

    Parameters
    ----------
    position
        Table position of each row, shape (n,).
    pulse_width
        Base pulse width of each row, shape (n,).
    torque
        The rows' torques [N m], shape (n,).
    ramp
        The motor file's ramp, shape (P, m).

    Returns
    -------
    tuple of (float, int)
        The mean deviation within a count (a fraction; NaN without a pair) and the cells.

    Examples
    --------
    >>> n = 12
    >>> p, w = np.meshgrid(np.arange(n), np.arange(0, 256, 8), indexing="ij")
    >>> g = 1.0 + 0.1 * (p % 2)  # the torque steps by 10 % from one position to the next
    >>> figure, cells = within_count_change(p.ravel(), w.ravel(), (g * w).ravel(), np.ones((n, 1)))
    >>> round(figure, 4), cells  # |0.1| / 1.05 / 4 on every pair
    (0.0238, 168)
    """
    pos = np.asarray(position, dtype=np.int64)
    pw = np.asarray(pulse_width, dtype=np.int64)
    tau = np.asarray(torque, dtype=np.float64)
    r = np.asarray(ramp, dtype=np.float64)
    n = r.shape[0]
    width = int(pw.max(initial=0)) + 1
    keys, inverse = np.unique(pos * width + pw, return_inverse=True)
    mean = np.bincount(inverse, weights=tau) / np.bincount(inverse)
    measured = np.unique(pos)
    if measured.size < 2:
        return float("nan"), 0
    same = np.all(np.isclose(r, np.roll(r, -1, axis=0)), axis=1)  # p and p + 1 share the ramp
    high = 0.5 * float(tau.max())
    out: list[np.ndarray] = []
    for a, b in zip(measured, np.roll(measured, -1), strict=True):
        s = int((b - a) % n)
        if s == 0 or not same[(a + np.arange(s)) % n].all():
            continue
        lo, hi = np.searchsorted(keys, [a * width, (a + 1) * width])
        levels = keys[lo:hi] - a * width
        there = np.searchsorted(keys, b * width + levels)
        there = np.minimum(there, keys.size - 1)
        both = keys[there] == b * width + levels
        ta, tb = mean[lo:hi][both], mean[there][both]
        keep = np.minimum(ta, tb) >= high
        if keep.any():
            out.append(np.abs(tb - ta)[keep] / (s * 0.5 * (ta + tb)[keep]))
    if not out:
        return float("nan"), 0
    change = np.concatenate(out)
    return float(np.mean(change) / 4.0), int(change.size)


def within_count_advice(
    position: ArrayLike, pulse_width: ArrayLike, torque: ArrayLike, ramp: ArrayLike
) -> str:
    """One line when the torque within one table position matters (module docstring), else "".

    Parameters
    ----------
    position, pulse_width, torque, ramp
        As for :func:`within_count_change`.

    Examples
    --------
    >>> n = 12
    >>> p, w = np.meshgrid(np.arange(n), np.arange(0, 256, 8), indexing="ij")
    >>> g = 1.0 + 0.1 * (p % 2)
    >>> within_count_advice(p.ravel(), w.ravel(), (g * w).ravel(), np.ones((n, 1)))[:58]
    'one table position is 1/12 of the actuation cycle (30 elec'
    >>> within_count_advice(p.ravel(), w.ravel(), w.ravel() * 1.0, np.ones((n, 1)))
    ''
    """
    r = np.asarray(ramp, dtype=np.float64)
    n = r.shape[0]
    degrees = f"{360.0 / n:.3g} electrical degrees"
    span = f"one table position is 1/{n} of the actuation cycle ({degrees})"
    figure, cells = within_count_change(position, pulse_width, torque, r)
    if cells == 0:
        if np.all(~np.all(np.isclose(r, np.roll(r, -1, axis=0)), axis=1)):
            return (
                f"{span} and the ramp changes at every position: the torque within a position "
                "cannot be read from the data, and the APMD measured where the rig settles "
                "(a verification reads the same points) need not hold elsewhere within it; "
                "more positions per cycle (a finer encoder) hold it"
            )
        return ""
    if figure <= WITHIN_COUNT or cells < FEWEST_CELLS:
        return ""
    return (
        f"{span}: at a fixed pulse width the torque changes by {400.0 * figure:.2g} % of itself "
        f"from one position to the next (mean over {cells} cells of neighbouring measured "
        f"positions), so a motor anywhere within a position deviates by about "
        f"{100.0 * figure:.2g} % more than the APMD measured where the rig settles (a "
        "verification reads the same points); more positions per cycle (a finer encoder) hold it"
    )


def coarser_grid_advice(positions_per_cycle: int, actuation_max: int, max_cells: int) -> str:
    """``"; ..."``: the positions per cycle that fit the builder's grid, for a motor file whose
    encoder is finer than the tables can be built on, else "".

    A fine encoder (a 14-bit one on a motor of a few pole pairs: 16384 counts per electrical
    cycle) gives more table positions than ``max_cells / (actuation_max + 1)``. The builder
    refused it without saying what fits (QA stop 36). A table position of ``k`` counts costs
    little where the torque changes little from count to count (:func:`within_count_advice`
    measures it on the data); the smallest power of two ``k`` that fits is named.

    Parameters
    ----------
    positions_per_cycle
        The motor file's ``P``.
    actuation_max
        The motor file's full-scale pulse width.
    max_cells
        The builder's largest grid, ``P (actuation_max + 1)``.

    Examples
    --------
    >>> coarser_grid_advice(16384, 255, 1 << 21)[:61]
    '; with actuation_max 255 at most 8192 positions per cycle fit'
    >>> coarser_grid_advice(512, 255, 1 << 21)
    ''
    """
    n, width = int(positions_per_cycle), int(actuation_max) + 1
    fit = max_cells // width
    if n <= fit:
        return ""
    if fit < 1:
        return f"; lower actuation_max (at most {max_cells - 1})"
    k = 2
    while -(-n // k) > fit:
        k *= 2
    return (
        f"; with actuation_max {actuation_max} at most {fit} positions per cycle fit: count "
        f"one table position every {k} encoder counts (positions_per_cycle {-(-n // k)}, the "
        f"table position the count // {k}), and collect and run with the same"
    )


def check_grid_fits(
    positions_per_cycle: int, actuation_max: int, *, path: str | None = None
) -> None:
    """Refuse a motor file whose grid is larger than the tables are built on
    (:data:`MAX_GRID_CELLS`), saying what fits (:func:`coarser_grid_advice`).

    ``linearize build`` refuses such a file; ``linearize collect`` refuses it as well, before
    any rig time is spent on data no table can be built from (QA stop 36: 16384 positions per
    cycle, a 14-bit encoder per electrical cycle, collected and then refused by build).

    Parameters
    ----------
    positions_per_cycle
        The motor file's ``P``.
    actuation_max
        The motor file's full-scale pulse width.
    path
        The file named in the refusal (the motor file).

    Raises
    ------
    InputError
        Naming ``path``, in one line.

    Examples
    --------
    >>> check_grid_fits(512, 4095)
    >>> check_grid_fits(16384, 255)
    Traceback (most recent call last):
    ...
    torquemap.errors.InputError: positions_per_cycle x (actuation_max + 1) = 4.19e+06 cells, \
more than the 2.1e+06 the tables are built on (for example 512 positions up to actuation_max \
4095); with actuation_max 255 at most 8192 positions per cycle fit: count one table position \
every 2 encoder counts (positions_per_cycle 8192, the table position the count // 2), and \
collect and run with the same
    """
    cells = int(positions_per_cycle) * (int(actuation_max) + 1)
    if cells > MAX_GRID_CELLS:
        # the forward model is dense in (position, pulse width): beyond this it takes GBs
        raise InputError(
            f"positions_per_cycle x (actuation_max + 1) = {cells:.3g} cells, more than the "
            f"{MAX_GRID_CELLS:.3g} the tables are built on (for example 512 positions up to "
            "actuation_max 4095)"
            + coarser_grid_advice(positions_per_cycle, actuation_max, MAX_GRID_CELLS),
            path=path,
        )
