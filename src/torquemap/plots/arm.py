"""Charts of an arm's estimated end-effector wrench over time (for the report and the demo)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.estimate_arm import ArmEstimate
from torquemap.plots.chart import Chart, Series, series, spans_from_mask

_UNITS = {"fx": "N", "fy": "N", "fz": "N", "mx": "N m", "my": "N m", "mz": "N m"}


def wrench_charts(
    estimates: Mapping[str, ArmEstimate],
    *,
    truth: Mapping[str, ArrayLike] | None = None,
    truth_t: ArrayLike | None = None,
) -> list[Chart]:
    """One chart per wrench axis: each estimate over time with its one-sigma band (the first
    estimate's), flagged (near-singular) samples shaded, and the truth where it is known.

    Parameters
    ----------
    estimates
        Estimates of the same log by label (``{"acceleration": est, ...}``); the first one's
        flags shade the charts and its sigma is drawn.
    truth
        Optional true wrench by axis name (``fx`` ...), at times ``truth_t`` [s]: only a
        simulator knows it (the demo).
    truth_t
        Times of ``truth`` [s].

    Returns
    -------
    list of Chart
    """
    first = next(iter(estimates.values()))
    spans = spans_from_mask(first.t, first.flag != 0)
    charts = []
    for k, axis in enumerate(first.wrench_axes):
        unit = _UNITS.get(axis, "")
        lines: list[Series] = []
        for i, (label, est) in enumerate(estimates.items()):
            sigma: NDArray[np.float64] | None = est.wrench_sigma[:, k] if i == 0 else None
            lines.append(
                series(
                    f"{axis}, {label}" + (" +/- sigma" if sigma is not None else ""),
                    est.t,
                    est.wrench[:, k],
                    sigma=sigma,
                )
            )
        if truth is not None and truth_t is not None and axis in truth:
            lines.append(series(f"{axis}, true", truth_t, truth[axis], color="#000000"))
        charts.append(
            Chart(
                title=f"{axis} [{unit}]",
                x_label="time [s]",
                y_label=f"{axis} [{unit}]",
                series=tuple(lines),
                spans=spans,
                caption=f"{'Force' if unit == 'N' else 'Moment'} {axis} exerted by the "
                "environment on the end effector (base frame), estimated from motor currents "
                "and encoders"
                + (", against the simulator's truth (black)" if truth is not None else "")
                + "; near-singular poses shaded grey.",
            )
        )
    return charts
