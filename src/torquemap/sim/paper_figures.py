"""The figures of Simpson, Cook & Li (Figs 3 to 8) drawn from a simulated SCARA bench folder.

This is where the simulator's truth meets the estimator for display: Fig 3 and the dark
reference lines of Figs 5 to 8 are the true spring torques (truth.csv); everything else comes
from identifying the sweeps and estimating on the circle exactly as a user would.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from torquemap.ctext import file_stem
from torquemap.errors import InputError
from torquemap.estimate import ForceEstimate, estimate_forces
from torquemap.identify import Identification, identify_model
from torquemap.io import Writer, figure_writer, output_folder, read_log, read_table, write_all
from torquemap.model import Model, load_model
from torquemap.plots.force import (
    joint_torque_figure,
    position_domain_figure,
    time_domain_figure,
)
from torquemap.plots.pdtv import spectrum_figure

#: The files of a bench folder the figures read.
BENCH_FILES = ("robot.toml", "sweep.csv", "circle.csv", "truth.csv")


@dataclass(frozen=True, slots=True, eq=False)
class PaperFigures:
    """Figures 3 to 8 and what they were drawn from.

    Attributes
    ----------
    figures
        File stem (``fig3_joint_torques``, ...) to figure, in the paper's order.
    identification
        The identification of the bench's sweeps.
    estimate
        The ``paper`` method's estimate on the circle.
    """

    figures: dict[str, Figure]
    identification: Identification
    estimate: ForceEstimate


def paper_figures(bench_dir: str | os.PathLike[str], *, model: Model | None = None) -> PaperFigures:
    """Draw Figs 3 to 8 of the paper from a bench folder written by ``simulate scara``.

    Parameters
    ----------
    bench_dir
        Folder with robot.toml, sweep.csv, circle.csv and truth.csv.
    model
        An identified model to use (default: identify it from sweep.csv here).

    Returns
    -------
    PaperFigures

    Raises
    ------
    InputError
        If a bench file is missing or malformed.
    """
    d = Path(bench_dir)
    for name in BENCH_FILES:
        if not (d / name).is_file():
            raise InputError(f"not a SCARA bench folder: {name} is missing", path=d)
    robot_model = load_model(d / "robot.toml")
    robot = robot_model.robot
    sweep = read_log(d / "sweep.csv", robot)
    ident = identify_model(robot if model is None else model, [sweep], friction="passes")
    used = ident.model if model is None else model
    circle = read_log(d / "circle.csv", robot)
    truth = read_table(d / "truth.csv")
    names = robot.joint_names
    tau_true = np.column_stack([truth[f"tau_ext_{n}"] for n in names])
    est = estimate_forces(used, circle, method="paper")
    figs: dict[str, Figure] = {}
    figs["fig3_joint_torques"] = joint_torque_figure(
        circle.t, tau_true, names, title="Fig 3: joint torques from the 3.5 N spring (Eq 3)"
    )
    last = names[-1]
    jr = ident.joints.get(last)
    if jr is not None and jr.spectrum is not None:
        figs["fig4_spectrum"] = spectrum_figure(
            jr.spectrum,
            used.joints[last].pdtv,
            threshold=None if jr.picks is None else jr.picks.threshold,
            title=f"Fig 4: joint {last} PDTV position-frequency spectrum",
        )
    for k, name in enumerate(names[:2]):
        gear = robot.joints[k].gear_ratio
        fig = time_domain_figure(est, k, gear_ratio=gear, reference_tau_ext=tau_true)
        fig.suptitle(f"Fig {5 + k}: joint {name}, time-domain force estimation signal")
        figs[f"fig{5 + k}_time_domain_{file_stem(name)}"] = fig
    for k, name in enumerate(names[:2]):
        gear = robot.joints[k].gear_ratio
        fig = position_domain_figure(est, k, gear_ratio=gear, reference_tau_ext=tau_true)
        fig.suptitle(f"Fig {7 + k}: joint {name}, position-domain force estimation signal")
        figs[f"fig{7 + k}_position_domain_{file_stem(name)}"] = fig
    return PaperFigures(figures=figs, identification=ident, estimate=est)


def write_paper_figures(
    bench_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    model_path: str | os.PathLike[str] | None = None,
) -> list[Path]:
    """Write Figs 3 to 8 as PNG files into ``out_dir`` (created); returns the paths."""
    model = None if model_path is None else load_model(model_path)
    result = paper_figures(bench_dir, model=model)
    out = Path(out_dir)
    writers: dict[Path, Writer] = {
        out / f"{stem}.png": figure_writer(fig, kind="png", dpi=120)
        for stem, fig in result.figures.items()
    }
    with output_folder(out):
        return write_all(writers)  # all figures or none


def truth_model(bench_dir: str | os.PathLike[str]) -> Model:
    """The bench's true parameters (truth.toml) as a model: the oracle of the benchmarks."""
    return load_model(Path(bench_dir) / "truth.toml")
