"""``torquemap demo``: everything torquemap does, on the built-in simulated benches.

1. The SCARA bench of Simpson, Cook & Li: simulate the no-load sweeps and the 130 mm circle about
   a 3.5 N spring; identify friction, inertia and PDTV from the sweeps; estimate the spring force
   on the circle with each method (raw Eq 7, low-pass, paper, model) and with an oracle that knows
   the simulator's true parameters; draw the paper's Figs 3 to 8.
   The Panda in MuJoCo (docs/arm-bench.md): a short free log and a task pressing on a surface;
   identify the arm from its URDF and estimate the end-effector wrench (charts against truth).
2. The linearisation rig of the Adept II paper, for a variable-reluctance and a brushless DC
   motor: collect characterisation data, build the per-phase look-up tables, collect a
   verification run through them, and measure APMD before and after.
3. A self-contained HTML report and a printed summary beside the papers' reference numbers.

The demo is a showcase and may read the simulators' truth (to score the estimates); the
estimators and the table builder never do.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from math import nan
from pathlib import Path
from typing import Any, Literal

import numpy as np

from torquemap.errors import InputError
from torquemap.estimate import METHODS, ForceEstimate, estimate_forces, forces_columns
from torquemap.identify import identify_model
from torquemap.io import read_log, read_table, write_table, write_toml
from torquemap.model import Model, PdtvLine, load_model, model_to_dict
from torquemap.progress import Progress, reporter
from torquemap.progress import steps as hook
from torquemap.report import EmbeddedFigure, Report, Section, embed, table, write_report

#: Table 2 of the Adept II paper: uncompensated and compensated APMD [%] of joints 1 to 4.
PAPER_TABLE_2 = {
    "joint 1 (VR)": (76.1, 4.2),
    "joint 2 (VR)": (58.3, 2.4),
    "joint 3 (BLDC)": (36.0, 13.1),
    "joint 4 (BLDC)": (9.1, 4.6),
}
#: The spring force of Simpson, Cook & Li's experiment [N].
PAPER_FORCE = 3.5


@dataclass(frozen=True, slots=True, eq=False)
class ForceRow:
    """Force error of one method on the circle: RMS [N] and in % of 3.5 N over the samples
    every method answers, and the share of the circle this method answers (not flagged)."""

    label: str
    rms: float
    percent: float
    max_abs: float
    answered: float = 1.0


@dataclass(frozen=True, slots=True, eq=False)
class LineRow:
    """One PDTV line, identified against true (NaN where one side has no such line)."""

    joint: str
    order: float
    direction: str
    amplitude: float
    true_amplitude: float
    phase: float
    true_phase: float


@dataclass(frozen=True, slots=True, eq=False)
class ApmdRow:
    """APMD [fraction] before and after the tables for one simulated motor."""

    motor: str
    before: float
    after: float
    after_above_10: float
    torque_per_count: float


@dataclass(frozen=True, slots=True, eq=False)
class ArmRow:
    """Wrench error of one model and method on the arm's task: RMS force [N], moment [N m]."""

    label: str
    force: float
    moment: float


@dataclass(frozen=True, slots=True, eq=False)
class DemoSummary:
    """What the demo measured, and where it wrote the report."""

    forces: tuple[ForceRow, ...]
    lines: tuple[LineRow, ...]
    apmd: tuple[ApmdRow, ...]
    report: Path
    seconds: float
    arm: tuple[ArmRow, ...] = ()


def _match_lines(
    name: str, found: tuple[PdtvLine, ...], true: tuple[PdtvLine, ...]
) -> list[LineRow]:
    rows = []
    truth = {round(t.order, 6): t for t in true}
    seen = set()
    for ln in sorted(found, key=lambda x: (x.order, x.direction)):
        t = truth.get(round(ln.order, 6))
        seen.add(round(ln.order, 6))
        rows.append(
            LineRow(
                joint=name,
                order=ln.order,
                direction=ln.direction,
                amplitude=ln.amplitude,
                true_amplitude=t.amplitude if t else float("nan"),
                phase=ln.phase,
                true_phase=t.phase if t else float("nan"),
            )
        )
    for key, t in truth.items():
        if key not in seen:
            rows.append(
                LineRow(name, t.order, "missed", float("nan"), t.amplitude, float("nan"), t.phase)
            )
    return rows


def _scara(
    out: Path, seed: int, steps: Progress
) -> tuple[list[ForceRow], list[LineRow], list[Section]]:
    from torquemap.plots.force import estimate_figure
    from torquemap.sim.bench import write_scara_bench
    from torquemap.sim.paper_figures import paper_figures
    from torquemap.sim.score import common_mask, force_error

    bench = out / "scara"
    steps.run(
        "simulate the SCARA bench (sweeps and circle)", lambda: write_scara_bench(bench, seed=seed)
    )
    truth_model = load_model(bench / "truth.toml")
    robot = truth_model.robot
    sweep = read_log(bench / "sweep.csv", robot)
    circle = read_log(bench / "circle.csv", robot)
    # the default identification: every sample of the sweeps (whole-log fit)
    ident = steps.run("identify friction, inertia and PDTV", lambda: identify_model(robot, [sweep]))
    model = ident.model
    write_toml(bench / "model.toml", model_to_dict(model))
    # the paper's own identification (friction from constant-speed passes, Eq 5): its figures,
    # its notch method, and the model method on it for comparison
    passes = steps.run(
        "identify by the paper's pass method",
        lambda: identify_model(robot, [sweep], friction="passes"),
    ).model
    write_toml(bench / "model_passes.toml", model_to_dict(passes))

    runs: list[tuple[str, Model, Any]] = [
        ("raw", passes, "raw"),
        ("lowpass", passes, "lowpass"),
        ("paper", passes, "paper"),
        ("model_passes", passes, "model"),
        ("model", model, "model"),
    ]
    runs.append(("oracle", truth_model, "model"))
    ests: dict[str, ForceEstimate] = {}

    def estimate_all() -> None:
        for label, mdl, method in runs:
            est = estimate_forces(mdl, circle, method=method)
            ests[label] = est
            write_table(bench / f"forces_{label}.csv", forces_columns(est))

    steps.run("estimate the spring force with every method", estimate_all)
    truth = read_table(bench / "truth.csv")
    true_force = np.c_[truth["fx"], truth["fy"]]
    names = robot.joint_names
    tau_true = np.column_stack([truth[f"tau_ext_{n}"] for n in names])
    mask = common_mask([e.flag for e in ests.values()])
    labels = {
        "raw": "raw Eq 7",
        "lowpass": "low-pass only",
        "paper": "paper (notches per pass)",
        "model_passes": "model, pass identification",
        "model": "model (default)",
        "oracle": "oracle (true parameters)",
    }
    force_rows = []
    for key, est in ests.items():
        assert est.force is not None
        s = force_error(est.force, true_force, mask=mask)
        answered = float(np.mean(est.flag == 0))
        force_rows.append(ForceRow(labels[key], s.rms, s.percent, s.max_abs, answered))

    line_rows: list[LineRow] = []
    for name in names:
        line_rows.extend(_match_lines(name, model.joints[name].pdtv, truth_model.joints[name].pdtv))

    figs = steps.run(
        "draw the paper's Figs 3 to 8", lambda: paper_figures(bench, model=passes).figures
    )
    embedded: list[EmbeddedFigure] = []

    def render() -> None:
        captions = {
            "fig3_joint_torques": "Fig 3: joint torques from the 3.5 N spring force (Eq 3).",
            "fig4_spectrum": "Fig 4: PDTV spectrum of the B axis in cycles per motor revolution; "
            "triangles mark the identified lines.",
            "fig5_time_domain_a": "Fig 5: A axis estimation signal (Eq 7), raw and low-passed, "
            "with the true spring torque.",
            "fig6_time_domain_b": "Fig 6: B axis estimation signal, raw and low-passed.",
            "fig7_position_domain_a": "Fig 7: A axis, discrete-position signal per monotonic "
            "pass, before and after the PDTV notches.",
            "fig8_position_domain_b": "Fig 8: B axis, before and after the notches.",
        }
        for stem, fig in figs.items():
            embedded.append(embed(fig, captions.get(stem, stem)))
        embedded.append(
            embed(
                estimate_figure(
                    ests["model"], reference_tau_ext=tau_true, reference_force=true_force
                ),
                "Model method: estimated joint torques and force against the truth "
                "(black); flagged samples shaded.",
            )
        )

    steps.run("render the force figures", render)

    ident_rows = []
    for name in names:
        f = model.joints[name].friction.to_dict()
        tf = truth_model.joints[name].friction.to_dict()
        i, ti = model.joints[name].inertia, truth_model.joints[name].inertia
        ident_rows += [
            (
                name,
                "Coulomb + [N m]",
                f.get("coulomb_positive", nan),
                tf.get("coulomb_positive", nan),
            ),
            (
                name,
                "Coulomb - [N m]",
                f.get("coulomb_negative", nan),
                tf.get("coulomb_negative", nan),
            ),
            (name, "viscous [N m s/rad]", f.get("viscous", nan), tf.get("viscous", nan)),
            (
                name,
                "Stribeck + [N m]",
                f.get("stribeck_positive", nan),
                tf.get("stribeck_positive", nan),
            ),
            (
                name,
                "Stribeck velocity [rad/s]",
                f.get("stribeck_velocity", nan),
                tf.get("stribeck_velocity", nan),
            ),
            (name, "inertia [kg m^2]", i.constant, ti.constant),
        ]
    sections = [
        Section(
            "SCARA bench: identification",
            paragraphs=(
                "The simulated SCARA (after the Hirata ARI350 of Simpson, Cook & Li: harmonic "
                "drives 100:1 and 80:1, current-controlled DC motors, 2 kHz servo) is swept one "
                "axis at a time at constant speeds. torquemap identifies motor-side friction, "
                "inertia and the PDTV lines from these logs alone; the truth is shown beside.",
            ),
            tables=(
                table(("joint", "parameter", "identified", "true"), ident_rows),
                table(
                    (
                        "joint",
                        "order [CPR]",
                        "direction",
                        "amplitude [N m]",
                        "true amplitude",
                        "phase [rad]",
                        "true phase",
                    ),
                    [
                        (
                            r.joint,
                            f"{r.order:g}",
                            r.direction,
                            r.amplitude,
                            r.true_amplitude,
                            r.phase,
                            r.true_phase,
                        )
                        for r in line_rows
                    ],
                    caption="PDTV lines, motor side; 'missed' marks a true line not picked.",
                ),
            ),
            warnings=ident.warnings,
        ),
        Section(
            "SCARA bench: sensorless force estimation",
            paragraphs=(
                "The end effector tracks a 130 mm circle at 0.4 rad/s about the anchor of a "
                "spring that pulls it with 3.5 N (the paper's experiment). The force is "
                "estimated from motor currents and encoders only. RMS error of the force "
                "vector on the samples no method flagged (friction at reversals and standstill "
                f"is undetermined for the pass method): {mask.mean():.1%} of the circle; "
                "'answered' is the share of the circle each method answers. The default model "
                "is identified from every sample of the sweeps (whole-log fit) and answers "
                "everywhere; the pass identification is the paper's.",
            ),
            tables=(
                table(
                    ("method", "RMS error [N]", "% of 3.5 N", "max [N]", "answered"),
                    [
                        (r.label, r.rms, f"{r.percent:.2f}", r.max_abs, f"{r.answered:.1%}")
                        for r in force_rows
                    ],
                    caption="The paper reports good estimates of its 3.5 N force, with no error "
                    "figure; the oracle uses the simulator's true inertia, friction and PDTV.",
                ),
            ),
            figures=tuple(embedded),
            warnings=tuple(dict.fromkeys(ests["model"].warnings)),
        ),
    ]
    return force_rows, line_rows, sections


ARM_FREE = 10.0
"""Length [s] of the demo's exciting (free) log of the simulated Panda."""
ARM_TASK = 6.0
"""Length [s] of the demo's task log (the end effector pressing on a surface)."""


def _arm(out: Path, seed: int, steps: Progress) -> tuple[list[ArmRow], Section]:
    """The MuJoCo Panda: simulate a short bench, identify, estimate the wrench, score."""
    from torquemap.estimate_arm import arm_forces_columns, estimate_arm
    from torquemap.identify_arm import identify_arm
    from torquemap.plots.arm import wrench_charts
    from torquemap.sim.arm import oracle_model, write_arm_bench

    bench = out / "arm"
    steps.run(
        "simulate the Panda in MuJoCo (free motion and task)",
        lambda: write_arm_bench(
            bench, seed=seed, free_duration=ARM_FREE, task_duration=ARM_TASK, iterations=4
        ),
    )
    start = load_model(bench / "robot.toml")
    free = read_log(bench / "free.csv", start.robot)
    task = read_log(bench / "task.csv", start.robot)
    ident = steps.run(
        "identify the arm (inertial parameters, rotor inertia, friction, PDTV)",
        lambda: identify_arm(start, [free], max_samples=4000),
    )
    doc = model_to_dict(ident.model)
    doc["robot"]["urdf"] = "panda.urdf"  # beside model.toml
    write_toml(bench / "model.toml", doc)
    oracle = oracle_model(bench / "robot.toml", bench)
    runs = {
        "URDF as given, acceleration": (start, "acceleration", False),
        "identified, acceleration": (ident.model, "acceleration", False),
        "identified, momentum observer": (ident.model, "momentum", False),
        "identified, momentum zero-phase": (ident.model, "momentum", True),
        "oracle (true arm), acceleration": (oracle, "acceleration", False),
    }
    ests = {}

    def estimate_all() -> None:
        for label, (mdl, method, zero_phase) in runs.items():
            ests[label] = estimate_arm(mdl, task, method=method, zero_phase=zero_phase)  # type: ignore[arg-type]
        write_table(bench / "forces.csv", arm_forces_columns(ests["identified, acceleration"]))

    steps.run("estimate the end-effector wrench", estimate_all)
    truth = read_table(bench / "truth.csv")
    t = np.asarray(truth["t"], dtype=np.float64)
    force = np.column_stack([np.asarray(truth[a], dtype=np.float64) for a in ("fx", "fy", "fz")])
    rows = []
    for label, est in ests.items():
        ok = (est.flag == 0) & (t > 2.0) & (t < t[-1] - 0.5) & np.isfinite(est.wrench).all(axis=1)
        ef = est.wrench[ok, :3] - force[ok]
        em = est.wrench[ok, 3:6]  # the surface exerts no moment about the end effector
        rows.append(
            ArmRow(
                label,
                float(np.sqrt(np.mean(np.sum(ef**2, axis=1)))),
                float(np.sqrt(np.mean(np.sum(em**2, axis=1)))),
            )
        )
    fz = force[t > 2.0, 2]
    charts = wrench_charts(
        {
            "identified, acceleration": ests["identified, acceleration"],
            "URDF as given": ests["URDF as given, acceleration"],
        },
        truth={a: truth[a] for a in ("fx", "fy", "fz", "mx", "my", "mz")},
        truth_t=t,
    )
    masses = [(m.body, m.urdf, m.identified, m.sigma) for m in ident.masses]
    section = Section(
        "Arm with a URDF: the Panda in MuJoCo",
        paragraphs=(
            "MuJoCo (an engine independent of the Pinocchio model torquemap fits) simulates the "
            "Panda of example-robot-data with link masses off by up to 15 % and a 0.8 kg tool "
            "its URDF lacks, gears, rotor inertia, friction of another form than the fitted "
            "law, torque ripple, encoder quantisation and current noise "
            f"(docs/arm-bench.md). torquemap identifies the arm from {ARM_FREE:g} s of "
            "exciting motion (free.csv) and estimates the wrench on the end effector while it "
            f"presses on a compliant surface ({ARM_TASK:g} s, task.csv; normal force "
            f"{fz.min():.0f} to {fz.max():.0f} N after the descent) from motor currents and "
            "encoders alone. RMS errors after the 2 s descent, samples not flagged.",
        ),
        tables=(
            table(
                ("model, method", "force RMS error [N]", "moment RMS error [N m]"),
                [(r.label, r.force, r.moment) for r in rows],
                caption="The oracle is the true arm (tool included), true rotor inertia, "
                "friction and ripple through the same estimator; 2 Hz low-pass or observer "
                "bandwidth. The causal observer's error is mostly its own lag.",
            ),
            table(
                ("body", "URDF mass [kg]", "identified [kg]", "sigma [kg]"),
                masses,
                caption="A body's mass alone is not always identifiable (base parameters are "
                "combinations); the URDF is the prior.",
            ),
        ),
        charts=tuple(charts),
        warnings=ident.warnings,
    )
    return rows, section


def _rig(
    out: Path, motor: Literal["vr", "bldc"], seed: int, steps: Progress
) -> tuple[ApmdRow, Section]:
    from torquemap.linearize.collect import CollectionSettings
    from torquemap.linearize.export import save_tables
    from torquemap.linearize.metrics import evaluate_linearity
    from torquemap.linearize.motor import load_motor
    from torquemap.linearize.tables import build_tables, read_data
    from torquemap.plots.linearize import (
        before_after_figure,
        pmd_figure,
        table_surfaces_figure,
    )
    from torquemap.sim.rig import collect_on_sim, write_rig_data

    kind = {"vr": "variable-reluctance", "bldc": "brushless DC"}[motor]
    d = out / f"rig_{motor}"
    for old in ("verify.csv", "verify.csv.collect.json"):
        (d / old).unlink(missing_ok=True)  # a new run, not a resumed one
    steps.run(
        f"characterise the {kind} motor on the simulated rig",
        lambda: write_rig_data(
            d, motor=motor, seed=seed, settings=CollectionSettings(progress=steps)
        ),
    )
    spec = load_motor(d / "motor.toml")
    data = read_data(d / "data.csv", spec, kind="characterisation")
    tables = steps.run(
        f"build the {kind} look-up tables",
        lambda: build_tables(
            spec, data.position, data.level, data.torque, bias=data.bias, path=str(d / "data.csv")
        ),
    )
    save_tables(d / "TABLES.npz", tables)
    steps.run(
        f"verify the {kind} tables (commands through the tables, fresh sensor noise)",
        lambda: collect_on_sim(
            spec,
            d / "verify.csv",
            sim=motor,
            seed=seed + 100,
            tables=d / "TABLES.npz",
            # the bias on an open contact: the joint's torque, not the torque above the one at
            # rest (which a bias read at rest subtracts where cogging loads the contact)
            settings=CollectionSettings(level_step=2, bias_open=True, progress=steps),
        ),
    )
    verify = read_data(d / "verify.csv", spec, kind="verification")
    before = evaluate_linearity(spec, data)
    after = evaluate_linearity(spec, verify, tables=tables)
    row = ApmdRow(
        motor=kind,
        before=before.apmd,
        after=after.apmd,
        after_above_10=after.apmd_above_10,
        torque_per_count=tables.torque_per_count,
    )
    figs = steps.run(
        f"render the {kind} figures",
        lambda: (
            embed(
                before_after_figure(before, after, title=spec.name),
                f"{kind}: torque vs position vs command, before (pulse width) and after "
                "(torque command through the tables).",
            ),
            embed(table_surfaces_figure(tables), f"{kind}: the look-up-table surfaces per phase."),
            embed(
                pmd_figure({"uncompensated": before, "compensated": after}),
                f"{kind}: PMD distribution, CAPMD (Eq 2) and PAPMD (Eq 3).",
            ),
        ),
    )
    section = Section(
        f"Linearisation: {kind} motor",
        paragraphs=(
            f"{spec.phases} phases, {spec.positions_per_cycle} table positions per actuation "
            f"cycle, {spec.command_bits}-bit signed torque command, {spec.ramping} ramping. "
            f"torque_per_count {tables.torque_per_count:.4g} N m (every command reachable at "
            "every position).",
        ),
        tables=(
            table(
                ("", "uncompensated", "compensated", "compensated, > 10 % command"),
                [
                    (
                        "APMD [%] (Eq 1)",
                        f"{100 * before.apmd:.2f}",
                        f"{100 * after.apmd:.2f}",
                        f"{100 * after.apmd_above_10:.2f}",
                    )
                ],
            ),
        ),
        figures=figs,
    )
    return row, section


def run_demo(
    out_dir: str | os.PathLike[str], *, seed: int = 0, progress: bool | Progress | None = True
) -> DemoSummary:
    """Run the whole demo into ``out_dir`` (created) and write ``out_dir/report.html``.

    Parameters
    ----------
    out_dir
        Output folder: scara/ (bench, model, forces), arm/ (the MuJoCo Panda bench, model,
        forces), rig_vr/ and rig_bldc/ (motor, data, tables, verification), report.html.
    seed
        Noise seed of every simulation (>= 0).
    progress
        Where the steps are reported (:mod:`torquemap.progress`): a hook, ``True`` for the
        default reporter on stderr (a spinner on a terminal, one line per step otherwise),
        ``False`` or ``None`` for none.

    Returns
    -------
    DemoSummary

    Raises
    ------
    InputError
        If ``out_dir`` cannot be created or the seed is invalid.
    """
    from torquemap.plots.linearize import ramps_figure

    start = time.perf_counter()
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder", path=out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder ({exc.strerror})", path=out) from None
    steps = progress if isinstance(progress, Progress) else hook(reporter() if progress else None)
    force_rows, line_rows, scara_sections = _scara(out, seed, steps)
    arm_rows, arm_section = _arm(out, seed, steps)
    apmd_rows = []
    rig_sections = []
    motors: tuple[Literal["vr", "bldc"], ...] = ("vr", "bldc")
    for motor in motors:
        row, section = _rig(out, motor, seed, steps)
        apmd_rows.append(row)
        rig_sections.append(section)
    overview = Section(
        "Summary",
        paragraphs=(
            "Everything below was computed by `torquemap demo` on the built-in simulated "
            "benches: the SCARA of Simpson, Cook & Li (sensorless force estimation) and the "
            "motor rig of the Adept II torque-linearisation paper.",
        ),
        tables=(
            table(
                ("force estimation method", "RMS error [N]", "% of 3.5 N"),
                [(r.label, r.rms, f"{r.percent:.2f}") for r in force_rows],
                caption="Paper 000: a 3.5 N spring force recovered under friction and ripple.",
            ),
            table(
                (
                    "motor",
                    "APMD before [%]",
                    "APMD after [%]",
                    "paper before [%]",
                    "paper after [%]",
                ),
                [
                    (
                        "variable reluctance",
                        f"{100 * apmd_rows[0].before:.2f}",
                        f"{100 * apmd_rows[0].after:.2f}",
                        "76.1 / 58.3",
                        "4.2 / 2.4",
                    ),
                    (
                        "brushless DC",
                        f"{100 * apmd_rows[1].before:.2f}",
                        f"{100 * apmd_rows[1].after:.2f}",
                        "36.0 / 9.1",
                        "13.1 / 4.6",
                    ),
                ],
                caption="Paper 001, Table 2: joints 1/2 (variable reluctance) and 3/4 "
                "(brushless DC).",
            ),
        ),
        figures=(
            embed(ramps_figure(), "The narrow and wide ramping functions (Adept II Figs 7, 13)."),
        ),
    )
    report = Report(
        title="torquemap demo",
        subtitle=f"simulated benches, seed {seed}",
        sections=(overview, *scara_sections, arm_section, *rig_sections),
    )
    path = out / "report.html"
    steps.run("write the report", lambda: write_report(path, report))
    return DemoSummary(
        forces=tuple(force_rows),
        lines=tuple(line_rows),
        apmd=tuple(apmd_rows),
        report=path,
        seconds=time.perf_counter() - start,
        arm=tuple(arm_rows),
    )


def format_summary(summary: DemoSummary) -> str:
    """The printed summary: force errors, PDTV lines, APMD, with the papers' numbers."""
    out = ["", "Sensorless force estimation (paper 000: a 3.5 N spring force on a SCARA)"]
    out.append(f"  {'method':<28}{'RMS [N]':>9}{'% of 3.5 N':>12}{'answered':>10}")
    for r in summary.forces:
        out.append(f"  {r.label:<28}{r.rms:>9.3f}{r.percent:>11.2f}%{r.answered:>9.1%}")
    out.append("")
    out.append("Identified PDTV lines (motor side) against the true ones")
    out.append(
        f"  {'joint':<6}{'CPR':>6}  {'direction':<9}{'amp [mN m]':>11}{'true':>8}{'phase':>8}{'true':>8}"
    )
    for ln in summary.lines:
        out.append(
            f"  {ln.joint:<6}{ln.order:>6g}  {ln.direction:<9}{1e3 * ln.amplitude:>11.2f}"
            f"{1e3 * ln.true_amplitude:>8.2f}{ln.phase:>8.2f}{ln.true_phase:>8.2f}"
        )
    if summary.arm:
        out.append("")
        out.append("Arm with a URDF (the Panda in MuJoCo): end-effector wrench error on the task")
        out.append(f"  {'model, method':<36}{'force [N]':>10}{'moment [N m]':>14}")
        for row in summary.arm:
            out.append(f"  {row.label:<36}{row.force:>10.3f}{row.moment:>14.3f}")
    out.append("")
    out.append(
        "Torque linearisation, APMD (paper 001, Table 2: VR 76.1/58.3 -> 4.2/2.4 %, "
        "BLDC 36.0/9.1 -> 13.1/4.6 %)"
    )
    for a in summary.apmd:
        out.append(
            f"  {a.motor:<22} before {100 * a.before:6.2f} %   after {100 * a.after:5.2f} %"
            f"   (above 10 % command {100 * a.after_above_10:.2f} %)"
        )
    out.append("")
    out.append(f"report: {summary.report}   ({summary.seconds:.0f} s)")
    return "\n".join(out)


__all__ = ["METHODS", "ArmRow", "DemoSummary", "format_summary", "run_demo"]
