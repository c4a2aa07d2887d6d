"""Automated collection against the Rig protocol (torquemap.linearize.collect)."""

from __future__ import annotations

import dataclasses
import os
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.errors import InputError
from torquemap.io import read_table
from torquemap.linearize.collect import (
    CollectionSettings,
    Rig,
    collect_characterisation,
    collect_verification,
    collection_targets,
    read_tables_npz,
)
from torquemap.linearize.motor import motor_spec, ramped_actuation
from torquemap.sim.rig import variable_reluctance_rig

P = 24


def S(**changes: object) -> CollectionSettings:
    """Settings for the fake rig's tests: no progress bar."""
    return CollectionSettings(**{"progress": False, **changes})  # type: ignore[arg-type]


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
        FakeRig(), SPEC, out, S(readings=1, level_step=100, position_step=3, transitions=True)
    )
    assert_array_equal(result.targets, got)
    data = read_table(out)
    starts = np.asarray(data["pulse_width"]) == 0  # one block per target, in order
    assert_array_equal(np.asarray(data["position"])[starts], got)


def test_rows_columns_and_bias_free_torque(tmp_path: Path) -> None:
    rig = FakeRig()
    out = tmp_path / "data.csv"
    result = collect_characterisation(rig, SPEC, out, S(readings=3, level_step=50, position_step=1))
    data = read_table(out)
    assert list(data) == ["position", "pulse_width", "torque", "bias"]
    levels = [0, 50, 100, 150, 200, 250, 255]  # the step grid, then full scale
    assert result.rows == P * len(levels) == data["torque"].size
    assert_array_equal(data["pulse_width"], np.tile(levels, P))
    assert_array_equal(data["position"], np.repeat(np.arange(P), len(levels)))
    # the bias (5 + 0.25 p) is gone: the data equal the known physics of the ramped actuation
    act = ramped_actuation(data["pulse_width"], data["position"], SPEC.ramp)
    expected = 0.1 * act.sum(axis=1) * (1 + data["position"] / P)
    assert_allclose(data["torque"], expected, rtol=1e-9, atol=1e-9)  # 10 significant digits written
    # ... and kept in its column: the fake's known bias at each target (all phases off)
    assert_allclose(data["bias"], 5.0 + 0.25 * data["position"], rtol=1e-9)
    assert result.resumed_targets == 0 and result.saturated_targets == 0 and result.bias_column


def test_ramp_consulted_at_current_position_after_compliance(tmp_path: Path) -> None:
    rig = FakeRig(push_at=20.0)
    out = tmp_path / "data.csv"
    collect_characterisation(rig, NARROW, out, S(readings=1, level_step=40, position_step=6))
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
            rig, SPEC, out, S(readings=2, level_step=10, position_step=1), saturation=option
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


RESUME = CollectionSettings(
    readings=2, bias_readings=2, level_step=32, position_step=3, progress=False
)


@pytest.fixture(scope="module")
def whole_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[bytes, int, int]:
    """One uninterrupted run on the fake rig: its bytes, its rows and the readings it took."""
    whole = tmp_path_factory.mktemp("whole") / "whole.csv"
    counter = InterruptingRig(FakeRig(), 10**9)
    first = collect_characterisation(counter, SPEC, whole, RESUME)  # type: ignore[arg-type]
    # 8 targets: the bias (2 readings), then 9 levels of 2 readings
    assert counter.count == 8 * (2 + 2 * 9) and first.rows == 8 * 9
    return whole.read_bytes(), first.rows, counter.count


def _block_starts(data: bytes) -> list[int]:
    """Line numbers (0 = header) of the level-0 rows."""
    return [i for i, x in enumerate(data.decode().splitlines()) if x.split(",")[1:2] == ["0"]]


# interrupted inside the first bias, at a block's first row, mid-block, at a block's end
# (before the record notes it), twice in a row, three times, and on the very last reading
@pytest.mark.parametrize("cuts", [[1], [2], [3], [20], [21], [50, 37], [7, 7, 7], [159]])
def test_resume_after_interruption_gives_the_same_file(
    tmp_path: Path, whole_run: tuple[bytes, int, int], cuts: list[int]
) -> None:
    whole, rows, readings = whole_run
    part = tmp_path / "part.csv"
    for cut in cuts:
        assert cut < readings
        with pytest.raises(Interrupt):
            collect_characterisation(InterruptingRig(FakeRig(), cut), SPEC, part, RESUME)
        with part.open("a") as handle:
            handle.write("37,9")  # a row torn by the power cut
        assert not (tmp_path / "part.csv.lock").exists()  # the lock goes with the run
    again = collect_characterisation(FakeRig(), SPEC, part, RESUME)
    assert part.read_bytes() == whole
    assert again.rows == rows and again.new_rows <= rows
    # running again on a complete file measures nothing
    last = collect_characterisation(FakeRig(), SPEC, part, RESUME)
    assert (last.resumed_targets, last.new_rows) == (8, 0)
    assert part.read_bytes() == whole


def test_resume_when_cut_between_the_rows_and_the_record(
    tmp_path: Path, whole_run: tuple[bytes, int, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    import torquemap.linearize.collect as collect

    part = tmp_path / "part.csv"
    real = collect.write_record
    calls = {"n": 0}

    def dying(path: Path, record: object) -> None:
        calls["n"] += 1
        if calls["n"] == 5:  # the 4th block's rows are flushed, its record is not written
            raise Interrupt
        real(path, record)  # type: ignore[arg-type]

    monkeypatch.setattr(collect, "write_record", dying)
    with pytest.raises(Interrupt):
        collect_characterisation(FakeRig(), SPEC, part, RESUME)
    monkeypatch.setattr(collect, "write_record", real)
    lines = whole_run[0].decode().splitlines()
    # the 4th block is in the file ...
    assert part.read_text().splitlines() == lines[: _block_starts(whole_run[0])[4]]
    again = collect_characterisation(FakeRig(), SPEC, part, RESUME)
    assert again.resumed_targets == 3  # ... but not in the record: measured again, not twice
    assert part.read_bytes() == whole_run[0]


def test_resume_without_a_record_goes_by_position(
    tmp_path: Path, whole_run: tuple[bytes, int, int]
) -> None:
    # a file from an older run (no record): its blocks are matched to targets by position,
    # the last (perhaps cut short) is measured again
    whole = whole_run[0]
    part = tmp_path / "part.csv"
    lines = whole.decode().splitlines(keepends=True)
    starts = _block_starts(whole)
    part.write_text("".join(lines[: starts[5] + 4]))  # 5 blocks and 4 rows of the 6th
    result = collect_characterisation(FakeRig(), SPEC, part, RESUME)
    assert result.resumed_targets == 5 and part.read_bytes() == whole
    # other settings: blocks land on this run's targets by position; nothing measured twice
    part.write_text("".join(lines[: starts[4]]))  # targets 0, 3, 6, 9
    (tmp_path / "part.csv.collect.json").unlink()
    result = collect_characterisation(FakeRig(), SPEC, part, S(level_step=32, position_step=1))
    data = read_table(part)
    firsts = np.asarray(data["position"])[np.asarray(data["pulse_width"]) == 0]
    assert result.resumed_targets == 3  # 0, 3 and 6 kept (9, the last, measured again)
    assert sorted(firsts.tolist()) == list(range(P))  # every target exactly once
    assert firsts[:3].tolist() == [0, 3, 6]


def test_resume_refuses_other_settings_naming_them(tmp_path: Path) -> None:
    part = tmp_path / "part.csv"
    with pytest.raises(Interrupt):
        collect_characterisation(InterruptingRig(FakeRig(), 100), SPEC, part, RESUME)
    before = part.read_bytes()
    other = dataclasses.replace(RESUME, position_step=1, readings=3)
    with pytest.raises(InputError) as info:
        collect_characterisation(FakeRig(), SPEC, part, other)
    message = str(info.value)
    assert "position_step (this run 1, the file's 3)" in message
    assert "readings (this run 3, the file's 2)" in message
    assert "level_step" not in message and str(part) in message
    with pytest.raises(InputError, match="motor ramp"):
        collect_characterisation(FakeRig(), NARROW, part, RESUME)
    assert part.read_bytes() == before  # refused before any change
    # the progress bar is not a setting of the data
    collect_characterisation(FakeRig(), SPEC, part, dataclasses.replace(RESUME, progress=True))


def test_a_second_run_on_the_same_file_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "d.csv"
    settings = S(readings=1, level_step=100, position_step=6)
    errors: list[str] = []

    class Meddler(FakeRig):
        def read_torque(self) -> float:  # a second run starts while the first collects
            if not errors:
                try:
                    collect_characterisation(FakeRig(), SPEC, out, settings)
                except InputError as exc:
                    errors.append(str(exc))
            return super().read_torque()

    result = collect_characterisation(Meddler(), SPEC, out, settings)
    assert errors and "another collection (pid" in errors[0] and "d.csv" in errors[0]
    assert result.rows == 4 * 4 and len(out.read_text().splitlines()) == 1 + 16
    assert not (tmp_path / "d.csv.lock").exists()
    # a lock held by another live process (here: our parent) refuses; a dead one's is taken
    lock = tmp_path / "d.csv.lock"
    lock.write_text(f"{os.getppid()}\n")
    with pytest.raises(InputError, match=f"another collection \\(pid {os.getppid()}\\)"):
        collect_characterisation(FakeRig(), SPEC, out, settings)
    dead = _dead_pid()
    lock.write_text(f"{dead}\n")
    again = collect_characterisation(FakeRig(), SPEC, out, settings)
    assert again.resumed_targets == 4 and not lock.exists()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
def test_lock_of_a_killed_unreaped_run_is_stale(tmp_path: Path) -> None:
    # a run killed (kill -9) whose parent has not reaped it yet is a zombie: it answers
    # kill(pid, 0) but writes nothing; its lock is stale (refused as 'another collection' before)
    import signal
    import time

    out = tmp_path / "d.csv"
    settings = CollectionSettings(readings=2, position_step=6, level_step=128)
    collect_characterisation(FakeRig(), SPEC, out, settings)
    proc = subprocess.Popen(["sleep", "30"])
    try:
        os.kill(proc.pid, signal.SIGKILL)
        stat = Path(f"/proc/{proc.pid}/stat")
        for _ in range(200):  # the kernel marks it Z within microseconds; not reaped: no wait()
            if stat.read_text().rpartition(")")[2].split()[0] == "Z":
                break
            time.sleep(0.01)
        assert stat.read_text().rpartition(")")[2].split()[0] == "Z"
        lock = tmp_path / "d.csv.lock"
        lock.write_text(f"{proc.pid}\n")
        again = collect_characterisation(FakeRig(), SPEC, out, settings)
        assert again.resumed_targets == 4 and not lock.exists()
    finally:
        proc.wait()


def _dead_pid() -> int:
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def test_resume_refuses_other_files(tmp_path: Path) -> None:
    out = tmp_path / "data.csv"
    out.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(
        InputError,
        match="header must be 'position,pulse_width,torque,bias' or, from an older version, "
        "'position,pulse_width,torque'",
    ):
        collect_characterisation(FakeRig(), SPEC, out, S())
    out.write_text("position,pulse_width,torque,bias\n0,0,0.0,nan\n0,2,1.0,0.5\n")
    with pytest.raises(InputError, match="malformed row at line 2"):  # a NaN bias
        collect_characterisation(FakeRig(), SPEC, out, S(level_step=2))
    out.write_text("position,pulse_width,torque,bias\n0,0,0.0\n0,2,1.0,0.5\n")
    with pytest.raises(InputError, match="malformed row at line 2"):  # the bias missing
        collect_characterisation(FakeRig(), SPEC, out, S(level_step=2))
    out.write_text("position,pulse_width,torque\n0,0,0.0\n0,3,1.0\n")
    with pytest.raises(InputError, match="level 3 at line 3 is not on this run's grid"):
        collect_characterisation(FakeRig(), SPEC, out, S(level_step=2))
    out.write_text("position,pulse_width,torque\n0,0,x\n0,2,1.0\n")
    with pytest.raises(InputError, match="malformed row at line 2"):
        collect_characterisation(FakeRig(), SPEC, out, S(level_step=2))
    out.write_text("position,pulse_width,torque\n0,2,1.0\n")
    with pytest.raises(InputError, match="does not start at level 0"):
        collect_characterisation(FakeRig(), SPEC, out, S(level_step=2))
    out.write_text("position,pulse_width,torque\n" + "0,0,0\n" * 5)
    with pytest.raises(InputError, match="two blocks for target position 0"):
        collect_characterisation(FakeRig(), SPEC, out, S(position_step=12))
    with pytest.raises(InputError, match="output folder does not exist"):
        collect_characterisation(FakeRig(), SPEC, tmp_path / "no" / "d.csv", S())
    for bad in ({"readings": 0}, {"level_step": 0}, {"position_step": -1}, {"readings": 1.5}):
        with pytest.raises(InputError, match="must be a positive integer"):
            S(**bad)
    # a record whose rows are no longer in the file (edited) is refused
    good = tmp_path / "good.csv"
    collect_characterisation(FakeRig(), SPEC, good, S(level_step=100, position_step=6))
    good.write_text("\n".join(good.read_text().splitlines()[:5]) + "\n")
    with pytest.raises(InputError, match="record lists 16 rows, the file holds 4"):
        collect_characterisation(FakeRig(), SPEC, good, S(level_step=100, position_step=6))


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
        rig, SPEC, tables, out, S(readings=1, level_step=16, position_step=4)
    )
    data = read_table(out)
    assert list(data) == ["position", "command", "torque", "bias"]
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
    # a zip archive cut short (zipfile.BadZipFile before)
    whole = (tmp_path / "t.npz").read_bytes()
    (tmp_path / "cut.npz").write_bytes(whole[: len(whole) - 40])
    with pytest.raises(InputError, match=r"cut\.npz: cannot read tables, corrupt or truncated"):
        read_tables_npz(tmp_path / "cut.npz", SPEC)


def test_tables_of_another_motor_are_refused(tmp_path: Path) -> None:
    # TABLES.npz of `linearize build` carries its motor: a verification through tables built
    # for other equilibria is refused before anything is collected
    from torquemap.linearize.export import save_tables
    from torquemap.linearize.tables import build_tables

    p, w = np.meshgrid(np.arange(0, P, 2), np.arange(0, 256, 16), indexing="ij")
    own = build_tables(SPEC, p.ravel(), w.ravel(), (w * (1 + p / P)).ravel() / 255.0)
    other = dataclasses.replace(SPEC, equilibrium_positions=(1, 9, 17), name="other")
    theirs = build_tables(other, p.ravel(), w.ravel(), (w * (1 + p / P)).ravel() / 255.0)
    save_tables(tmp_path / "own.npz", own)
    save_tables(tmp_path / "theirs.npz", theirs)
    back = read_tables_npz(tmp_path / "own.npz", SPEC)
    assert_array_equal(back["phase_1"], own.phases[0])
    with pytest.raises(InputError, match=r"theirs\.npz: tables are for another motor"):
        read_tables_npz(tmp_path / "theirs.npz", SPEC)


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
        S(readings=3, bias_readings=bias_readings, level_step=50, position_step=12),
    )
    assert result.saturated_targets == 0
    assert counter.count == 2 * expected + 3 * result.rows  # default: 10 x readings
    with pytest.raises(InputError, match="bias readings must be a positive integer"):
        S(bias_readings=0)


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
            rig, spec, out, S(readings=40, bias_open=bias_open, level_step=255, position_step=8)
        )
        cols = read_table(out)
        zero = np.asarray(cols["pulse_width"]) == 0
        rows[bias_open] = (np.asarray(cols["position"])[zero], np.asarray(cols["torque"])[zero])
    pos, at_rest = rows[True]
    f = rig.settings.friction
    truth = np.maximum(rig.true_torque(pos, np.zeros((pos.size, 3))) - f, 0.0)
    assert truth.max() > 0.04  # the case is real: cogging loads the contact somewhere
    assert_allclose(at_rest, truth, atol=0.01)  # 40 readings of 0.02 N m, bias over 400
    assert_allclose(rows[False][1], 0.0, atol=0.01)
    with pytest.raises(InputError, match="open_contact"):
        collect_characterisation(FakeRig(), SPEC, tmp_path / "x.csv", S(bias_open=True))


def _without_bias(data: bytes) -> str:
    """A file of the older format: the same rows, the ``bias`` column dropped."""
    return "".join(line.rpartition(",")[0] + "\n" for line in data.decode().splitlines())


@pytest.mark.parametrize("record", [True, False])
def test_an_older_file_without_the_bias_column_is_resumed_in_its_format(
    tmp_path: Path, whole_run: tuple[bytes, int, int], record: bool
) -> None:
    whole = whole_run[0]
    assert whole.decode().startswith("position,pulse_width,torque,bias\n")
    old = _without_bias(whole)
    part = tmp_path / "part.csv"
    with pytest.raises(Interrupt):  # a record (a newer run's) of the first blocks
        collect_characterisation(InterruptingRig(FakeRig(), 70), SPEC, part, RESUME)
    done = len(part.read_text().splitlines())
    part.write_text("".join(old.splitlines(keepends=True)[:done]))  # the older file
    if not record:
        (tmp_path / "part.csv.collect.json").unlink()
    result = collect_characterisation(FakeRig(), SPEC, part, RESUME)
    assert part.read_text() == old and not result.bias_column
    assert result.resumed_targets >= 2  # kept, not measured again
    # an older file with its header alone holds nothing to keep: it gets the column
    part.write_text("position,pulse_width,torque\n")
    (tmp_path / "part.csv.collect.json").unlink()
    result = collect_characterisation(FakeRig(), SPEC, part, RESUME)
    assert part.read_bytes() == whole and result.bias_column
