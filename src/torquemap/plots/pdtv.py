"""PDTV position-frequency spectrum with the model's lines marked (Simpson et al., Fig 4)."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from torquemap.io import atomic_output
from torquemap.model import PdtvLine
from torquemap.pdtv import Spectrum


def spectrum_figure(
    spectrum: Spectrum,
    lines: Sequence[PdtvLine] = (),
    *,
    threshold: np.ndarray | None = None,
    title: str = "PDTV position-frequency spectrum",
) -> Figure:
    """Amplitude against order [CPR], the model's lines marked, the detection threshold dashed.

    Returns
    -------
    matplotlib.figure.Figure
        Built without pyplot.
    """
    fig = Figure(figsize=(8.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    ax.semilogx(spectrum.order, spectrum.amplitude, lw=0.8, color="0.3", label="spectrum")
    if threshold is not None:
        ax.semilogx(spectrum.order, threshold, "--", lw=0.8, color="tab:orange", label="threshold")
    for k, ln in enumerate(lines):
        ax.plot(
            [ln.order],
            [ln.amplitude],
            "v",
            color="tab:red",
            ms=6,
            label="model lines" if k == 0 else None,
        )
    ax.set_xlabel("position frequency [CPR]")
    ax.set_ylabel("amplitude [N m]")
    ax.set_title(title)
    ax.legend(loc="upper right")
    return fig


def save_figure(fig: Figure, path: str | os.PathLike[str]) -> None:
    """Save a figure atomically (the suffix chooses the format)."""
    suffix = os.path.splitext(os.fspath(path))[1].lstrip(".") or "png"
    with atomic_output(path) as tmp:
        fig.savefig(tmp, format=suffix, dpi=120)
