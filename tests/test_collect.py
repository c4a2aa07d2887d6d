"""Automated collection against the Rig protocol (torquemap.linearize.collect)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.errors import InputError
from torquemap.io import read_table
from torquemap.linearize.collect import (
    Rig,
    collect_characterisation,
    collect_verification,
    collection_targets,
    read_tables_npz,
)
from torquemap.linearize.motor import motor_spec, ramped_actuation
from torquemap.sim.rig import variable_reluctance_rig

P = 24
SPEC = motor_spec("fake", phases=3, positions_per_cycle=P, equilibrium_positions=(8, 16, 0))
# narrow ramps sum to 1: the fake's torque then grows with position, so a push is never undone
NARROW = motor_spec(
    "fake", phases=3, positions_per_cycle=P, equilibrium_positions=(8, 16, 0), ramping="narrow"
)


class FakeRig:
    """A rig with known physics: torque = 0.1 * sum(actuation) * (1 + position / P) + bias.

    The secondary joint moves exactly one table position per step; no compliance, no noise.
    ``push`` shifts the position by one while loaded above ``push_at`` (compliance).
    """

    def __init__(self, *, saturation: float | None = None, push_at: float | None = None) -> None:
        self.base = 0
        self.act = [0, 0, 0]
        self.applied: list[tuple[int, list[int]]] = []
        self.push_at = push_at
        self.torque = 0.0
        if saturation is not None:
            self.saturation = saturation

    def bias(self) -> float:
        return 5.0 + 0.25 * self.base  # known, different at each position

    def true(self, position: int) -> float:
        return 0.1 * sum(self.act) * (1 + position / P)

    def read_position(self) -> int:
        loaded = self.push_at is not None and self.torque > self.push_at
        return (self.base + int(loaded)) % P

    def apply(self, actuation: Sequence[int]) -> None:
        self.act = list(actuation)
        self.applied.append((self.read_position(), list(actuation)))

    def settle(self) -> None:
        self.torque = self.true(self.base)
        if self.push_at is not None and self.torque > self.push_at:
            self.torque = self.true(self.base + 1)  # pushed on, and stays pushed

    def read_torque(self) -> float:
        return self.bias() + self.torque

    def step_secondary(self) -> None:
        self.base = (self.base + 1) % P
        self.torque = 0.0


def test_fake_rig_satisfies_protocol() -> None:
    assert isinstance(FakeRig(), Rig)
    assert isinstance(variable_reluctance_rig(rng=0), Rig)


def test_targets_evenly_spaced() -> None:
    assert_array_equal(collection_targets(SPEC, positions=8), np.arange(0, 24, 3))
    assert_array_equal(collection_targets(SPEC), np.arange(24))
    with pytest.raises(ValueError, match=r"positions must be in 1 \.\. 24"):
        collection_targets(SPEC, positions=25)


def test_targets_at_the_ramps_transitions(tmp_path: Path) -> None:
    # SPEC's wide ramp (P = 24) hands over between phases around positions 0, 8 and 16: its
    # rows change between 22 .. 2, 6 .. 10 and 14 .. 18 (read off motor.ramp by hand); every
    # position that differs from a neighbour joins the evenly spaced targets
    hand_over = [0, 1, 2, 6, 7, 8, 9, 10, 14, 15, 16, 17, 18, 22, 23]
    even = [0, 3, 6, 9, 12, 15, 18, 21]
    got = collection_targets(SPEC, positions=8, transitions=True)
    assert_array_equal(got, sorted(set(hand_over) | set(even)))
    out = tmp_path / "d.csv"
    result = collect_characterisation(
        FakeRig(), SPEC, out, readings=1, pulse_step=100, positions=8, transitions=True,
        progress=False,
    )  # fmt: skip
    assert_array_equal(result.targets, got)
    data = read_table(out)
    starts = np.asarray(data["pulse_width"]) == 0  # one block per target, in order
    assert_array_equal(np.asarray(data["position"])[starts], got)


def test_rows_columns_and_bias_free_torque(tmp_path: Path) -> None:
    rig = FakeRig()
    out = tmp_path / "data.csv"
    result = collect_characterisation(rig, SPEC, out, readings=3, pulse_step=50, progress=False)
    data = read_table(out)
    assert list(data) == ["position", "pulse_width", "torque"]
    levels = [0, 50, 100, 150, 200, 250, 255]  # the step grid, then full scale
    assert result.rows == P * len(levels) == data["torque"].size
    assert_array_equal(data["pulse_width"], np.tile(levels, P))
    assert_array_equal(data["position"], np.repeat(np.arange(P), len(levels)))
    # the bias (5 + 0.25 p) is gone: the data equal the known physics of the ramped actuation
    act = ramped_actuation(data["pulse_width"], data["position"], SPEC.ramp)
    expected = 0.1 * act.sum(axis=1) * (1 + data["position"] / P)
    assert_allclose(data["torque"], expected, rtol=1e-9, atol=1e-9)  # 10 significant digits written
    assert result.resumed_targets == 0 and result.saturated_targets == 0


def test_ramp_consulted_at_current_position_after_compliance(tmp_path: Path) -> None:
    rig = FakeRig(push_at=20.0)
    out = tmp_path / "data.csv"
    collect_characterisation(
        rig, NARROW, out, readings=1, pulse_step=40, positions=4, progress=False
    )
    data = read_table(out)
    # loaded rows moved one position on: stored under the moved position ...
    moved = data["position"] != np.repeat(collection_targets(NARROW, positions=4), 8)
    assert moved.any() and (~moved).any()
    # ... and every stored row's actuation is the ramp at the stored position
    act = ramped_actuation(data["pulse_width"], data["position"], NARROW.ramp)
    expected = 0.1 * act.sum(axis=1) * (1 + data["position"] / P)
    assert_allclose(data["torque"], expected, rtol=1e-9, atol=1e-9)  # 10 digits written
    # and each application used the ramp at the position read just before it
    table = [ramped_actuation(np.arange(256), p, NARROW.ramp).tolist() for p in range(P)]
    for position, actuation in rig.applied:
        assert actuation in table[position]


def test_saturation_stops_inner_loop(tmp_path: Path) -> None:
    # readings reach 5 + 0.1 * 255 = 30.5 or more at full scale everywhere: all saturate at 25
    for rig, option in ((FakeRig(saturation=25.0), None), (FakeRig(), 25.0)):
        out = tmp_path / f"data_{option}.csv"
        result = collect_characterisation(
            rig, SPEC, out, readings=2, pulse_step=10, saturation=option, progress=False
        )
        data = read_table(out)
        raw = data["torque"] + 5.0 + 0.25 * data["position"]  # what the sensor read
        assert raw.max() < 25.0  # the saturated reading is not stored
        # each position stops at the first level whose reading reaches 25
        assert result.saturated_targets == P
        last = data["pulse_width"][np.r_[np.flatnonzero(np.diff(data["position"])), -1]]
        assert (last < 255).all()


class Interrupt(Exception):
    pass


class InterruptingRig:
    """Delegates to a rig; raises after ``limit`` torque readings (a power cut)."""

    def __init__(self, rig: Rig, limit: int) -> None:
        self.rig, self.limit, self.count = rig, limit, 0
        self.saturation = getattr(rig, "saturation", None)  # the sensor range travels along

    def read_position(self) -> int:
        return self.rig.read_position()

    def apply(self, actuation: Sequence[int]) -> None:
        self.rig.apply(actuation)

    def settle(self) -> None:
        self.rig.settle()

    def step_secondary(self) -> None:
        self.rig.step_secondary()

    def read_torque(self) -> float:
        self.count += 1
        if self.count > self.limit:
            raise Interrupt
        return self.rig.read_torque()


@pytest.mark.parametrize("cut", [7, 100, 250])
def test_resume_after_interruption_gives_the_same_file(tmp_path: Path, cut: int) -> None:
    def rig() -> Rig:  # noise-free, so two runs can match byte for byte
        return variable_reluctance_rig(rng=0, noise=0.0)

    spec = rig().motor_spec()  # type: ignore[attr-defined]
    options = {
        "readings": 2,
        "bias_readings": 2,
        "pulse_step": 32,
        "positions": 16,
        "progress": False,
    }
    whole = tmp_path / "whole.csv"
    first = collect_characterisation(rig(), spec, whole, **options)  # type: ignore[arg-type]
    part = tmp_path / "part.csv"
    with pytest.raises(Interrupt):
        collect_characterisation(InterruptingRig(rig(), cut), spec, part, **options)  # type: ignore[arg-type]
    with part.open("a") as handle:
        handle.write("37,9")  # a row torn by the power cut
    cut_rows = len(part.read_text().splitlines()) - 1
    assert 0 < cut_rows < first.rows
    again = collect_characterisation(rig(), spec, part, **options)  # type: ignore[arg-type]
    assert part.read_bytes() == whole.read_bytes()
    assert again.rows == first.rows and again.new_rows <= first.rows
    # running again on a complete file only re-measures the last block
    last = collect_characterisation(rig(), spec, part, **options)  # type: ignore[arg-type]
    assert last.resumed_targets == 15 and part.read_bytes() == whole.read_bytes()


def test_resume_refuses_other_files(tmp_path: Path) -> None:
    out = tmp_path / "data.csv"
    out.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(InputError, match="header must be 'position,pulse_width,torque'"):
        collect_characterisation(FakeRig(), SPEC, out, progress=False)
    out.write_text("position,pulse_width,torque\n0,0,0.0\n0,3,1.0\n")
    with pytest.raises(InputError, match="level 3 at line 3 is not on this run's grid"):
        collect_characterisation(FakeRig(), SPEC, out, pulse_step=2, progress=False)
    out.write_text("position,pulse_width,torque\n0,0,x\n0,2,1.0\n")
    with pytest.raises(InputError, match="malformed row at line 2"):
        collect_characterisation(FakeRig(), SPEC, out, pulse_step=2, progress=False)
    out.write_text("position,pulse_width,torque\n0,2,1.0\n")
    with pytest.raises(InputError, match="does not start at level 0"):
        collect_characterisation(FakeRig(), SPEC, out, pulse_step=2, progress=False)
    out.write_text("position,pulse_width,torque\n" + "0,0,0\n" * 5)
    with pytest.raises(InputError, match="holds 4 position blocks, the run has 2 targets"):
        collect_characterisation(FakeRig(), SPEC, out, positions=2, progress=False)
    with pytest.raises(InputError, match="output folder does not exist"):
        collect_characterisation(FakeRig(), SPEC, tmp_path / "no" / "d.csv", progress=False)
    with pytest.raises(ValueError, match="readings must be >= 1"):
        collect_characterisation(FakeRig(), SPEC, tmp_path / "d.csv", readings=0, progress=False)
    with pytest.raises(ValueError, match="pulse_step must be >= 1"):
        collect_characterisation(FakeRig(), SPEC, tmp_path / "d.csv", pulse_step=0, progress=False)


def _tables() -> dict[str, np.ndarray]:
    c = np.arange(256)
    inverse = np.where(c < 128, 2 * c, 0)  # positive commands only
    return {
        f"phase_{k + 1}": np.rint(inverse[None, :] * SPEC.ramp[:, k : k + 1]).astype(np.int64)
        for k in range(3)
    }


def test_verification_looks_up_tables(tmp_path: Path) -> None:
    rig = FakeRig()
    out = tmp_path / "after.csv"
    tables = _tables()
    result = collect_verification(
        rig, SPEC, tables, out, readings=1, command_step=16, positions=6, progress=False
    )
    data = read_table(out)
    assert list(data) == ["position", "command", "torque"]
    commands = [0, 16, 32, 48, 64, 80, 96, 112, 127]
    assert result.rows == 6 * len(commands)
    assert_array_equal(data["command"], np.tile(commands, 6))
    act = np.stack(
        [tables[f"phase_{k + 1}"][data["position"], data["command"]] for k in range(3)], 1
    )
    assert_allclose(data["torque"], 0.1 * act.sum(axis=1) * (1 + data["position"] / P), rtol=1e-9)


def test_tables_validation_and_npz(tmp_path: Path) -> None:
    tables = _tables()
    np.savez(tmp_path / "t.npz", **tables)
    back = read_tables_npz(tmp_path / "t.npz", SPEC)
    assert_array_equal(back["phase_2"], tables["phase_2"])
    bad = {**tables, "phase_3": tables["phase_3"][:, :128]}
    np.savez(tmp_path / "bad.npz", **bad)
    with pytest.raises(InputError, match=r"bad.npz: table 'phase_3' has shape \(24, 128\)"):
        read_tables_npz(tmp_path / "bad.npz", SPEC)
    np.savez(tmp_path / "two.npz", phase_1=tables["phase_1"], phase_2=tables["phase_2"])
    with pytest.raises(InputError, match="tables lack 'phase_3'"):
        read_tables_npz(tmp_path / "two.npz", SPEC)
    with pytest.raises(InputError, match=r"values outside 0 \.\. 255"):
        collect_verification(
            FakeRig(), SPEC, {**tables, "phase_1": tables["phase_1"] + 300}, tmp_path / "x.csv"
        )
    with pytest.raises(InputError, match="must hold integers"):
        collect_verification(
            FakeRig(), SPEC, {**tables, "phase_1": tables["phase_1"] * 0.5}, tmp_path / "x.csv"
        )
    with pytest.raises(InputError, match="file not found"):
        read_tables_npz(tmp_path / "none.npz", SPEC)
    (tmp_path / "junk.npz").write_text("junk")
    with pytest.raises(InputError, match="cannot read tables"):
        read_tables_npz(tmp_path / "junk.npz", SPEC)


@pytest.mark.parametrize(("bias_readings", "expected"), [(None, 30), (7, 7)])
def test_bias_is_averaged_over_its_own_readings(
    tmp_path: Path, bias_readings: int | None, expected: int
) -> None:
    # every reading is counted: per target, the bias readings, then `readings` per level
    counter = InterruptingRig(FakeRig(), limit=10**9)
    result = collect_characterisation(
        counter,  # type: ignore[arg-type]
        SPEC,
        tmp_path / "d.csv",
        readings=3,
        bias_readings=bias_readings,
        pulse_step=50,
        positions=2,
        progress=False,
    )
    assert result.saturated_targets == 0
    assert counter.count == 2 * expected + 3 * result.rows  # default: 10 x readings
    with pytest.raises(ValueError, match="bias_readings must be >= 1"):
        collect_characterisation(
            FakeRig(), SPEC, tmp_path / "e.csv", bias_readings=0, progress=False
        )


def test_bias_read_on_an_open_contact_keeps_the_torque_at_rest(tmp_path: Path) -> None:
    from torquemap.sim.rig import brushless_dc_rig

    # the BLDC's cogging torque (0.12 N m) exceeds the contact's friction (0.06 N m) at some
    # positions: it loads the contact with all phases off. Read at rest, the bias swallows it;
    # read with the contact open, the level-0 rows hold it, as the physics says
    rows = {}
    for bias_open in (False, True):
        rig = brushless_dc_rig(rng=5)
        spec = rig.motor_spec()
        out = tmp_path / f"{bias_open}.csv"
        collect_characterisation(
            rig, spec, out, readings=40, bias_open=bias_open, pulse_step=255, positions=32,
            progress=False,
        )  # fmt: skip
        cols = read_table(out)
        zero = np.asarray(cols["pulse_width"]) == 0
        rows[bias_open] = (np.asarray(cols["position"])[zero], np.asarray(cols["torque"])[zero])
    pos, at_rest = rows[True]
    f = rig.settings.friction
    truth = np.maximum(rig.true_torque(pos, np.zeros((pos.size, 3))) - f, 0.0)
    assert truth.max() > 0.04  # the case is real: cogging loads the contact somewhere
    assert_allclose(at_rest, truth, atol=0.01)  # 40 readings of 0.02 N m, bias over 400
    assert_allclose(rows[False][1], 0.0, atol=0.01)
    with pytest.raises(ValueError, match="open_contact"):
        collect_characterisation(FakeRig(), SPEC, tmp_path / "x.csv", bias_open=True)
