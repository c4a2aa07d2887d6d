"""``torquemap report``: a self-contained HTML report of a model and a user's own logs.

For the model: friction, inertia and PDTV lines per joint, and the notes identification left.
For each log: where it holds constant-speed passes, the PDTV spectrum per joint with the model's
lines marked; the external torques and forces the ``model`` method estimates; and warnings where
the data is thin (too few passes, position bins left empty, passes too fast for the position
Nyquist of the model's orders, samples the estimator flagged).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from torquemap.errors import InputError
from torquemap.estimate import FLAG_LOW_SPEED, FLAG_SINGULAR, estimate_forces
from torquemap.identify import JointIdentification, identify_model, resolvable_order
from torquemap.io import Log, read_log
from torquemap.model import Model, load_model
from torquemap.report import EmbeddedFigure, Report, Section, embed, table, write_report

#: Fewer constant-speed passes per direction than this is thin data for friction.
MIN_PASSES = 2


def _model_section(model: Model, path: str) -> Section:
    rows = []
    lines = []
    for name, jm in model.joints.items():
        f, i = jm.friction.to_dict(), jm.inertia
        keys = (
            "coulomb_positive",
            "coulomb_negative",
            "viscous",
            "stribeck_positive",
            "stribeck_negative",
            "stribeck_velocity",
        )
        rows.append((name, *(f.get(k, float("nan")) for k in keys), i.constant, i.cos_elbow))
        for ln in sorted(jm.pdtv, key=lambda x: -x.amplitude):
            lines.append((name, f"{ln.order:g}", ln.direction, ln.amplitude, ln.phase))
    warnings: list[str] = []
    notes = model.notes.get("warnings", [])
    if isinstance(notes, list):
        warnings.extend(str(w) for w in notes)
    if not lines:
        warnings.append("the model holds no PDTV line (a plain robot file, or none was identified)")
    return Section(
        f"Model: {model.robot.name}",
        paragraphs=(f"From {path}. Motor side; kinematics {model.robot.kinematics}.",),
        tables=(
            table(
                (
                    "joint",
                    "Coulomb + [N m]",
                    "Coulomb - [N m]",
                    "viscous [N m s/rad]",
                    "Stribeck + [N m]",
                    "Stribeck - [N m]",
                    "Stribeck velocity [rad/s]",
                    "inertia [kg m^2]",
                    "inertia cos(q2) [kg m^2]",
                ),
                rows,
                caption="Friction and inertia.",
            ),
            table(
                ("joint", "order [CPR]", "direction", "amplitude [N m]", "phase [rad]"),
                lines,
                caption="PDTV lines: amplitude * cos(order * motor angle + phase).",
            ),
        ),
        warnings=tuple(warnings),
    )


def thin_data_warnings(model: Model, log: Log, joints: dict[str, JointIdentification]) -> list[str]:
    """Warnings where a log is thin for identification (one line each)."""
    out: list[str] = []
    for name, jr in joints.items():
        pos = sum(1 for _, p in jr.passes if p.direction == "positive")
        neg = sum(1 for _, p in jr.passes if p.direction == "negative")
        if pos < MIN_PASSES or neg < MIN_PASSES:
            out.append(
                f"joint {name}: {pos} positive and {neg} negative constant-speed passes; "
                f"friction needs at least {MIN_PASSES} per direction at distinct speeds"
            )
        if jr.signal is not None and jr.bins_per_rev > 0:
            # every angle of one revolution visited? fold the bins modulo a revolution
            k = np.floor(jr.signal.angle / jr.signal.bin_width).astype(np.int64)
            folded = np.bincount(
                np.mod(k, jr.bins_per_rev), weights=jr.signal.count, minlength=jr.bins_per_rev
            )
            empty = float(np.mean(folded == 0))
            if empty > 0:
                out.append(
                    f"joint {name}: {empty:.1%} of the {jr.bins_per_rev} position bins of a "
                    "motor revolution hold no sample (interpolated); a slower or longer sweep "
                    "fills them"
                )
        orders = [ln.order for ln in model.joints[name].pdtv]
        if jr.passes and orders:
            best = max(p.samples_per_rev for _, p in jr.passes)
            limit = resolvable_order(best)
            high = sorted({o for o in orders if o > limit})
            if high:
                out.append(
                    f"joint {name}: the slowest pass gives {best:.0f} samples per motor "
                    f"revolution, too fast for the position Nyquist of the model's orders "
                    f"{', '.join(f'{o:g}' for o in high)} CPR (resolves up to {limit} CPR)"
                )
    return out


def _log_section(model: Model, path: str, window: float | None = None) -> Section:
    from torquemap.plots.force import estimate_figure
    from torquemap.plots.pdtv import spectrum_figure

    log = read_log(path, model.robot)
    figures: list[EmbeddedFigure] = []
    warnings: list[str] = []
    paragraphs = [
        f"{log.t.size} samples over {log.t[-1] - log.t[0]:.3g} s "
        f"(median step {1e3 * float(np.median(np.diff(log.t))):.3g} ms)."
    ]
    try:
        from torquemap.estimate import model_window

        win = model_window(model) if window is None else window
        ident = identify_model(model, [log], window=win, friction="passes")
    except InputError as exc:
        paragraphs.append(f"No PDTV spectrum: {exc.message}.")
        ident = None
    if ident is not None:
        in_passes = (
            sum(p.stop - p.start for jr in ident.joints.values() for _, p in jr.passes) / log.t.size
        )
        if in_passes < 0.3:
            paragraphs.append(
                f"Only {in_passes:.0%} of the samples are constant-speed passes: not treated as "
                "an identification sweep (no spectrum, no thin-data check)."
            )
            ident = None
    if ident is not None:
        warnings.extend(thin_data_warnings(model, log, dict(ident.joints)))
        for name, jr in ident.joints.items():
            if jr.spectrum is None:
                continue
            fig = spectrum_figure(
                jr.spectrum,
                model.joints[name].pdtv,
                threshold=None if jr.picks is None else jr.picks.threshold,
                title=f"joint {name}: PDTV position-frequency spectrum",
            )
            figures.append(
                embed(fig, f"Joint {name}: PDTV spectrum of this log; triangles: model lines.")
            )
    tables = []
    try:
        est = estimate_forces(model, log, method="model", window=window)
    except InputError as exc:
        warnings.append(f"no force estimate: {exc.message}")
    else:
        warnings.extend(est.warnings)
        figures.append(
            embed(
                estimate_figure(est),
                "External joint torques (and force) estimated by the model method; flagged "
                "samples shaded.",
            )
        )
        ok = est.flag == 0
        rows = []
        for k, name in enumerate(est.joint_names):
            tau = est.tau_ext[ok, k]
            if tau.size:
                rows.append((f"tau_ext_{name} [N m]", float(np.mean(tau)), float(np.std(tau))))
        if est.force is not None and ok.any():
            mag = np.hypot(est.force[ok, 0], est.force[ok, 1])
            rows.append(("|F| [N]", float(np.mean(mag)), float(np.std(mag))))
        tables.append(
            table(
                ("estimate (sound samples)", "mean", "std"),
                rows,
                caption=f"{ok.mean():.1%} of samples sound; flagged: "
                f"{np.mean((est.flag & FLAG_LOW_SPEED) > 0):.1%} near zero velocity, "
                f"{np.mean((est.flag & FLAG_SINGULAR) > 0):.1%} singular pose.",
            )
        )
    return Section(
        f"Log: {Path(path).name}",
        paragraphs=tuple(paragraphs),
        tables=tuple(tables),
        figures=tuple(figures),
        warnings=tuple(dict.fromkeys(warnings)),
    )


def write_user_report(
    model_path: str | os.PathLike[str],
    log_paths: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    window: float | None = None,
) -> Report:
    """Build and write the report of a model and logs; returns it.

    ``window`` is the differentiator window [s] (default: the model's).

    Raises
    ------
    InputError
        On a bad model or log file (nothing is written then).
    """
    model = load_model(model_path)
    sections = [_model_section(model, os.fspath(model_path))]
    for path in log_paths:
        sections.append(_log_section(model, os.fspath(path), window))
    report = Report(
        title=f"torquemap report: {model.robot.name}",
        subtitle=f"model {os.fspath(model_path)}; {len(log_paths)} log(s)",
        sections=tuple(sections),
    )
    write_report(out, report)
    return report
