"""New-user QA of the linearisation on motors the family does not draw (stop 36, Q40).

Each test pins one fix of docs/linearize.md, "New-user QA, stop 36 (Q40)": a rig or a file of
another kind gets a working table with an honest APMD, or one line naming the file and the
problem. The rigs are the simulator's motors with other parameters (a hybrid stepper, few
positions per cycle), collected inside the test with a seeded generator.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import write_toml
from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.metrics import apmd_report
from torquemap.linearize.motor import MotorSpec, motor_to_dict, ramped_actuation
from torquemap.linearize.tables import TableSet, build_tables, read_data
from torquemap.sim.motors import Amplifier, BrushlessDcMotor
from torquemap.sim.rig import RigSettings, SimRig

STEPPER_BENCH = RigSettings(
    stiffness=1.0, friction=0.01, noise=0.004, saturation=3.0, bias=0.1, bias_variation=0.05
)


def hybrid_stepper(windings: int, *, rng: int = 1) -> SimRig:
    """A two-phase hybrid stepper, 64 microsteps per electrical cycle (16 per full step),
    sinusoidal torque ~ current and a detent torque of 4 periods a cycle, driven by a chopper
    (linear current). ``windings=4``: each winding's two directions as phases A+ B+ A- B-;
    ``windings=2``: A+ and B+ alone (what a user who counts windings writes)."""
    n = 64
    e = tuple(((k + 1.5) * n / 4) % n for k in range(windings))
    motor = BrushlessDcMotor(
        positions_per_cycle=n,
        cycles_per_revolution=50,
        equilibrium=e,
        phase_offset=(0.0, 0.3, -0.2, 0.1)[:windings],
        phase_gain=(1.0, 0.97, 1.02, 0.99)[:windings],
        peak_torque=1.2,
        current_max=2.0,
        harmonics=(0.0, 0.0),
        cogging=0.04,
        cogging_periods=4,
        mutual_saturation=0.0,
    )
    amp = Amplifier(dead_band=4.0, curve=0.0, current_max=2.0, current_limit=2.0)
    return SimRig(motor, amp, STEPPER_BENCH, rng=rng, name=f"stepper-{windings}")


def collect(rig: SimRig, tmp_path: Path, **settings: object) -> tuple[MotorSpec, Path]:
    spec = rig.motor_spec(ramping="wide")
    tmp_path.mkdir(exist_ok=True)
    data = tmp_path / "data.csv"
    options = {"bias_open": True, "progress": False, **settings}
    collect_characterisation(rig, spec, data, CollectionSettings(**options))  # type: ignore[arg-type]
    write_toml(tmp_path / "motor.toml", motor_to_dict(spec))
    return spec, data


def sensed_apmd(rig: SimRig, spec: MotorSpec, base: np.ndarray) -> float:
    """Eq 1 over every cell of the noise-free sensed torque (motor less friction) for base
    pulse widths ``base`` (P, C + 1) ramped by the motor file."""
    n, width = base.shape
    p = np.arange(n)[:, None]
    act = ramped_actuation(np.rint(base), p, spec.ramp)
    torque = np.maximum(rig.true_torque(p, act) - rig.settings.friction, 0.0)
    pp, cc = np.meshgrid(np.arange(n), np.arange(width), indexing="ij")
    report = apmd_report(
        pp.ravel(), cc.ravel(), torque.ravel(), command_max=width - 1, positions_per_cycle=n
    )
    return report.apmd


def floor_base(rig: SimRig, spec: MotorSpec, tables: TableSet) -> np.ndarray:
    """The best base pulse widths any table could hold, by exhaustive search per cell."""
    n, top = spec.positions_per_cycle, spec.actuation_max
    p = np.arange(n)[:, None]
    act = ramped_actuation(np.arange(top + 1)[None, :], p, spec.ramp)
    surface = np.maximum(rig.true_torque(p, act) - rig.settings.friction, 0.0)
    target = np.arange(tables.command_max + 1) * surface.max(axis=1).min() / tables.command_max
    return np.abs(surface[:, :, None] - target[None, None, :]).argmin(axis=1).astype(float)


# -- a bipolar stepper's windings: one phase per direction ---------------------------------------


def test_two_winding_stepper_is_refused_and_four_phases_build(tmp_path: Path) -> None:
    # given as its 2 windings, pulse widths drive each one way only: no phase pushes the
    # positive way over about a quarter of the cycle; the line said only "position 0"
    spec, data = collect(hybrid_stepper(2), tmp_path / "two")
    rows = read_data(data, spec, kind="characterisation")
    said = r"of 64 positions.*wired in the motor file.s order.*four phases, A\+ B\+ A- B-"
    with pytest.raises(InputError, match=said):
        build_tables(spec, rows.position, rows.level, rows.torque, bias=rows.bias)
    # the same motor as 4 phases (A+ B+ A- B-) builds; its APMD, noise-free over every cell
    # (measured 2.78 % against a floor of 1.28 %), is within the family's range of the floor
    rig = hybrid_stepper(4)
    spec, data = collect(rig, tmp_path / "four")
    rows = read_data(data, spec, kind="characterisation")
    tables = build_tables(spec, rows.position, rows.level, rows.torque, bias=rows.bias)
    apmd = sensed_apmd(rig, spec, tables.base)
    floor = sensed_apmd(rig, spec, floor_base(rig, spec, tables))
    assert floor < apmd < 2.5 * floor  # the family's median is 1.5x to 2.6x (docs)
    assert apmd < 0.035


# -- a force sensor mounted the other way round --------------------------------------------------


def test_reversed_sensor_is_refused_by_build_evaluate_and_figures(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec, data = collect(hybrid_stepper(4), tmp_path)
    table = np.loadtxt(data, delimiter=",", skiprows=1)
    table[:, 2:] *= -1  # torque and bias as a sensor mounted the other way round reads them
    flipped = tmp_path / "flipped.csv"
    np.savetxt(flipped, table, delimiter=",", header="position,pulse_width,torque,bias",
               comments="", fmt=["%d", "%d", "%.10g", "%.10g"])  # fmt: skip
    outputs = {"build": ["-o", str(tmp_path / "t.npz")], "figures": ["-o", str(tmp_path / "f")]}
    for command in ("build", "evaluate", "figures"):
        extra = outputs.get(command, [])
        status = main(["linearize", command, str(tmp_path / "motor.toml"), str(flipped), *extra])
        err = capsys.readouterr().err.strip()
        # before: build asked whether the motor was powered; evaluate printed 21.6 %, exit 0;
        # figures drew the falling surface, exit 0
        assert status == 2
        assert err.startswith(f"torquemap: error: {flipped}: the torque falls as the pulse width")
        assert "negate the torque and bias columns" in err
        assert "\n" not in err
    # the same rows as read build
    assert main(["linearize", "build", str(tmp_path / "motor.toml"), str(data), "-o",
                 str(tmp_path / "t.npz"), "-q"]) == 0  # fmt: skip
    # a verification through them, read by the reversed sensor: figures drew it (exit 0)
    from torquemap.linearize.collect import collect_verification, read_tables_npz

    after = tmp_path / "after.csv"
    tables = read_tables_npz(tmp_path / "t.npz", spec)
    settings = CollectionSettings(progress=False, position_step=8, level_step=8)
    collect_verification(hybrid_stepper(4, rng=2), spec, tables, after, settings)
    table = np.loadtxt(after, delimiter=",", skiprows=1)
    table[:, 2:] *= -1
    flipped = tmp_path / "after-flipped.csv"
    np.savetxt(flipped, table, delimiter=",", header="position,command,torque,bias",
               comments="", fmt=["%d", "%d", "%.10g", "%.10g"])  # fmt: skip
    args = ["--tables", str(tmp_path / "t.npz"), "-o", str(tmp_path / "g")]
    for verification, status in ((after, 0), (flipped, 2)):
        assert main(["linearize", "figures", str(tmp_path / "motor.toml"), str(data), *args,
                     "--verification", str(verification)]) == status  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith(f"torquemap: error: {flipped}: the torque falls as the command rises")


# -- a sign-magnitude drive, a current in amperes -----------------------------------------------


@pytest.mark.parametrize(
    ("level", "top", "said"),
    [
        (-4, 255, r"pulse_width -4 at data row 3 is outside 0 \.\. 255: negative pulse widths "
                  r"\(a sign-magnitude drive\?\).*two phases"),
        (0.25, 2, r"must hold integers \(data row 3: 0\.25\): fractional pulse widths \(a "
                  r"current in amperes\?\)"),
    ],
)  # fmt: skip
def test_pulse_widths_of_other_drives_are_named(
    tmp_path: Path, level: float, top: int, said: str
) -> None:
    spec = dataclasses.replace(
        hybrid_stepper(4).motor_spec(), actuation_max=top, path=str(tmp_path / "motor.toml")
    )
    data = tmp_path / "data.csv"
    data.write_text(f"position,pulse_width,torque\n0,0,0.0\n0,1,0.1\n0,{level},-0.1\n")
    with pytest.raises(InputError, match=said):
        read_data(data, spec, kind="characterisation")


# -- few positions per cycle ---------------------------------------------------------------------


def test_position_without_a_model_is_named(tmp_path: Path) -> None:
    # 6 positions per cycle, every 4th collected: compliance leaves position 0 with pulse widths
    # 0 .. 96 and position 4 with 132 .. 255; position 5 between them had "largest -inf N m"
    offsets = np.random.default_rng(1009).normal(0.0, 0.03, 3)  # phases a little apart
    motor = BrushlessDcMotor(
        positions_per_cycle=6,
        equilibrium=(2.5, 4.5, 0.5),
        phase_offset=tuple(offsets),
        phase_gain=tuple(1 + np.random.default_rng(1009).normal(0.0, 0.03, 3)),
        harmonics=(0.0, 0.0),
        cogging=0.0,
        mutual_saturation=0.05,
    )
    rig = SimRig(motor, Amplifier(dead_band=12.0, curve=0.4), dataclasses.replace(
        STEPPER_BENCH, stiffness=4.0, friction=0.06, noise=0.02, saturation=12.0), rng=1)  # fmt: skip
    spec, data = collect(rig, tmp_path)
    rows = read_data(data, spec, kind="characterisation")
    assert 5 not in rows.position
    with pytest.raises(
        InputError, match=r"no torque can be estimated at position 5: .*--position-step 1"
    ):
        build_tables(spec, rows.position, rows.level, rows.torque, bias=rows.bias, path=data)


# -- what one table position spans ---------------------------------------------------------------


def test_few_positions_per_cycle_warn_of_the_torque_within_a_position(tmp_path: Path) -> None:
    # 12 positions per cycle, every one collected: before, the tables' verification read 1.40 %
    # where the rig settled, without a word, while the motor held at other fractions of a
    # count got 1.9 % to 12.4 %
    rng = np.random.default_rng(1015)
    motor = BrushlessDcMotor(
        positions_per_cycle=12,
        equilibrium=(5.0, 9.0, 1.0),
        phase_offset=tuple(rng.normal(0.0, 0.06, 3)),
        phase_gain=tuple(1 + rng.normal(0.0, 0.03, 3)),
        harmonics=(0.0, 0.0),
        cogging=0.0,
        mutual_saturation=0.05,
    )
    bench = dataclasses.replace(
        STEPPER_BENCH, stiffness=85.0, friction=0.06, noise=0.02, saturation=12.0
    )  # the family's stiffness per electrical degree
    rig = SimRig(motor, Amplifier(dead_band=12.0, curve=0.4), bench, rng=1)
    spec, data = collect(rig, tmp_path, position_step=1)
    rows = read_data(data, spec, kind="characterisation")
    tables = build_tables(spec, rows.position, rows.level, rows.torque, bias=rows.bias)
    said = [w for w in tables.warnings if w.startswith("one table position is 1/12")]
    assert len(said) == 1
    stated = float(said[0].split("deviates by about ")[1].split(" %")[0]) / 100
    # the truth: Eq 1 through the tables with the motor held at fractions of a count
    p = np.arange(12)[:, None]
    act = np.moveaxis(tables.phases[:, :, : tables.command_max + 1], 0, -1)
    pp, cc = np.meshgrid(np.arange(12), np.arange(tables.command_max + 1), indexing="ij")
    apmd = []
    for shift in np.linspace(-0.5, 0.5, 11):
        torque = np.maximum(rig.true_torque(p + shift, act) - bench.friction, 0.0)
        apmd.append(apmd_report(pp.ravel(), cc.ravel(), torque.ravel(), command_max=127,
                                positions_per_cycle=12).apmd)  # fmt: skip
    excess = float(np.mean(apmd) - np.min(apmd))  # the spread a count adds to its best point
    # the figure is a lower bound (a table right at one point, the motor spread evenly)
    assert 0.4 * excess < stated < excess


def test_homing_on_a_coarse_grid_takes_the_right_motor_file() -> None:
    # 12 positions per cycle, 3 phases: an eighth of the phase spacing is half a count, and a
    # rest one count off (the encoder rounds) refused the right file as another motor's
    from torquemap.linearize.homing import home_motor
    from torquemap.linearize.motor import motor_spec
    from torquemap.sim.free_motor import FreeMotorRig

    motor = BrushlessDcMotor(
        positions_per_cycle=12, equilibrium=(5.0, 9.0, 1.0), harmonics=(0.0, 0.0), cogging=0.0
    )
    amp = Amplifier(dead_band=12.0, curve=0.4)
    rig = SimRig(motor, amp, STEPPER_BENCH)
    eq = rig.equilibrium_positions()
    spec = motor_spec("coarse", phases=3, positions_per_cycle=12, equilibrium_positions=eq)
    for seed in range(6):
        hidden = 3.3 + 1.7 * seed
        free = FreeMotorRig(motor, amp, friction=0.06, encoder_offset=hidden,
                            start_position=2.0 * seed, rng=seed)  # fmt: skip
        found = home_motor(free, spec).offset
        assert abs((found - hidden + 6.0) % 12.0 - 6.0) < 0.5  # within the encoder's count
    # a file whose phase 3 sits 2 counts off (half the spacing) is still refused
    other = motor_spec(
        "other", phases=3, positions_per_cycle=12,
        equilibrium_positions=(eq[0], eq[1], (eq[2] + 2) % 12),
    )  # fmt: skip
    free = FreeMotorRig(motor, amp, friction=0.06, encoder_offset=3.3, rng=0)
    with pytest.raises(InputError, match=r"more than 1\.5 counts.*for another motor"):
        home_motor(free, other)


def test_adaptive_levels_no_block_reached_stay_quiet() -> None:
    # an 8-phase VR motor's coarse blocks were all cut short by the sensor's saturation: the
    # top level held NaN in every block and numpy's "Mean of empty slice" reached the terminal
    from torquemap.linearize.adaptive import choose_levels, refine_levels

    levels = np.arange(0, 17, 2)
    curves = np.array([levels * 1.0, levels * 2.0])
    curves[:, -1] = np.nan  # no block reached level 16
    # a straight line: every inner level goes (first and last always kept)
    assert choose_levels(curves, levels, tolerance=0.01).tolist() == [0, 16]
    assert refine_levels(curves, levels, tolerance=0.01, finest=2).tolist() == levels.tolist()


def test_a_finer_encoder_than_the_grid_is_told_what_fits() -> None:
    # 16384 positions per cycle (a 14-bit encoder per electrical cycle) at 8-bit pulse widths:
    # 4.2e6 cells, twice the builder's grid; the refusal did not say what fits
    from torquemap.linearize.motor import motor_spec

    n = 16384
    spec = motor_spec("fine", phases=3, positions_per_cycle=n,
                      equilibrium_positions=(5 * n // 12, 9 * n // 12, n // 12))  # fmt: skip
    pos = np.repeat(np.arange(0, n, n // 64), 2)
    pw = np.tile([0, 255], 64)
    with pytest.raises(InputError, match=r"every 2 encoder counts \(positions_per_cycle 8192"):
        build_tables(spec, pos, pw, pw / 255.0)


def test_a_finer_encoder_than_the_grid_is_refused_before_collecting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the same 16384-position motor file: collecting on a rig of the user's (the API) spent the
    # rig's time on data that build then refused; now the collection refuses it before it
    # touches the rig, with build's line (one shared check, count.check_grid_fits)
    from torquemap.linearize.adaptive import collect_adaptive
    from torquemap.linearize.motor import motor_spec

    n = 16384
    spec = motor_spec("fine", phases=3, positions_per_cycle=n,
                      equilibrium_positions=(5 * n // 12, 9 * n // 12, n // 12))  # fmt: skip
    motor = tmp_path / "motor.toml"
    write_toml(motor, motor_to_dict(spec))
    out = tmp_path / "data.csv"
    # on the CLI's simulated rigs (128 to 512 positions) the motor file was refused already, as
    # another motor's; on a rig of the user's (the API) it was collected
    assert main(["linearize", "collect", str(motor), "--sim", "vr", "-o", str(out)]) == 2
    assert "16384 positions per cycle; the simulated vr motor has 3 and 512" in (
        capsys.readouterr().err
    )

    class Untouched:  # a rig that fails the test if the collection reads it at all
        def __getattr__(self, name: str) -> object:
            raise AssertionError(f"the rig was used ({name}) before the refusal")

    pos = np.repeat(np.arange(0, n, n // 64), 2)
    pw = np.tile([0, 255], 64)
    with pytest.raises(
        InputError, match=r"every 2 encoder counts \(positions_per_cycle 8192"
    ) as build_said:
        build_tables(spec, pos, pw, pw / 255.0)
    for collect_api in (collect_characterisation, collect_adaptive):
        with pytest.raises(InputError) as refused:
            collect_api(Untouched(), spec, out)  # type: ignore[arg-type]
        assert refused.value.message == build_said.value.message  # build's line, word for word
    assert not out.exists()


# -- a DATA.csv edited by hand -------------------------------------------------------------------


def test_a_typed_row_is_refused_and_reordered_rows_get_no_false_step(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, data = collect(hybrid_stepper(4), tmp_path)
    table = np.loadtxt(data, delimiter=",", skiprows=1)
    header = "position,pulse_width,torque,bias"
    fmt = ["%d", "%d", "%.10g", "%.10g"]
    motor = str(tmp_path / "motor.toml")
    # one torque typed ten times too large (before: the tables of a 240-position motor went
    # from 1.30 % to 7.47 % APMD, exit 0)
    typo = table.copy()
    row = int(np.flatnonzero(typo[:, 1] == 200)[3])
    typo[row, 2] *= 10
    np.savetxt(tmp_path / "typo.csv", typo, delimiter=",", header=header, comments="", fmt=fmt)
    assert main(["linearize", "build", motor, str(tmp_path / "typo.csv"), "-o",
                 str(tmp_path / "t.npz")]) == 2  # fmt: skip
    err = capsys.readouterr().err
    said = f"data row {row + 1} (position {int(typo[row, 0])}, pulse width 200) reads"
    assert said in err
    # figures refuse it the same way (before: drawn, exit 0), and write no folder
    figures = tmp_path / "figures"
    assert main(["linearize", "figures", motor, str(tmp_path / "typo.csv"), "-o",
                 str(figures)]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"torquemap: error: {tmp_path / 'typo.csv'}: {said}")
    assert "\n" not in err
    assert not figures.exists()
    # the same rows shuffled (a spreadsheet's sort): no "every Nth pulse width" of the row order
    order = np.random.default_rng(0).permutation(len(table))
    shuffled = tmp_path / "shuffled.csv"
    np.savetxt(shuffled, table[order], delimiter=",", header=header, comments="", fmt=fmt)
    assert main(["linearize", "build", motor, str(shuffled), "-o", str(tmp_path / "s.npz")]) == 0
    err = capsys.readouterr().err
    assert "th pulse width" not in err
    # and the denoiser, which reads the blocks from the row order, skipped with a word
    assert "the rows are not in the collection's order" in err


def test_a_phase_wired_backwards_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Stop 41 (Q49): the default BLDC rig with its phase 2 wired backwards, collected
    through the motor file of the rig wired right: build names the wiring, not a dead phase
    alone."""
    from torquemap.sim.rig import brushless_dc_rig

    spec = brushless_dc_rig(rng=0).motor_spec(ramping="wide")
    motor = BrushlessDcMotor()
    gains = (motor.phase_gain[0], -motor.phase_gain[1], motor.phase_gain[2])
    rig = brushless_dc_rig(rng=0, motor=dataclasses.replace(motor, phase_gain=gains))
    # the truth: where phase 2 alone is driven, the motor pushes the negative way
    alone = np.flatnonzero((spec.ramp[:, 1] == 1.0) & (spec.ramp[:, [0, 2]].max(axis=1) == 0))
    assert alone.size and float(rig.true_torque(int(alone[alone.size // 2]), [0, 200, 0])) < 0
    data = tmp_path / "data.csv"
    settings = CollectionSettings(progress=False, position_step=8, level_step=8)
    collect_characterisation(rig, spec, data, settings)
    write_toml(tmp_path / "motor.toml", motor_to_dict(spec))
    status = main(["linearize", "build", str(tmp_path / "motor.toml"), str(data), "-o",
                   str(tmp_path / "t.npz")])  # fmt: skip
    err = capsys.readouterr().err.strip()
    # before: "phase 2 never produced torque (...)", with no word of the wiring
    assert status == 2 and "\n" not in err
    assert err.startswith(f"torquemap: error: {data}: phase 2 never produced torque")
    assert "wired the way round the others are" in err
