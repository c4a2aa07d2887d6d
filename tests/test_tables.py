"""Table building (torquemap.linearize.tables) on data simulated in the test from known surfaces."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.errors import InputError
from torquemap.io import write_table
from torquemap.linearize.motor import MotorSpec, motor_spec
from torquemap.linearize.tables import (
    build_tables,
    command_from_torque,
    fill_voids,
    monotonic_filter,
    read_data,
    reflect_negative,
    torque_from_command,
)

#: conftest.py's ``_reused_builds`` (tests/_reuse.py): each distinct table build of this
#: module runs once; two tests build the default tables of ``quadratic_data(spec)``
REUSE_BUILDS = True
# one worker runs the module (pytest -n 2 --dist loadgroup), so the builds are shared
pytestmark = pytest.mark.xdist_group("tables")

A = 255  # full-scale pulse width


def gain(p: np.ndarray, n: int) -> np.ndarray:
    """Torque at full scale per position [N m]: ripple with 3 valleys, minimum 1.0."""
    return 2.0 + np.cos(2 * np.pi * 3 * p / n)


def quadratic_data(
    spec: MotorSpec, *, step: int = 5, pstep: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """tau = g(p) (pw / A)^2 on a grid of positions and base pulse widths (noise free)."""
    n = spec.positions_per_cycle
    p, w = np.meshgrid(np.arange(0, n, pstep), np.arange(0, A + 1, step), indexing="ij")
    p, w = p.ravel(), w.ravel()
    return p, w, gain(p, n) * (w / A) ** 2


def one_phase(n: int = 48) -> MotorSpec:
    return motor_spec("m1", phases=1, positions_per_cycle=n, equilibrium_positions=(0,))


def three_phase(n: int = 48, ramping: str = "wide") -> MotorSpec:
    return motor_spec(
        "m3",
        phases=3,
        positions_per_cycle=n,
        equilibrium_positions=(8, 24, 40),
        ramping=ramping,  # type: ignore[arg-type]
    )


def test_torque_scaling_is_the_deepest_valley() -> None:
    spec = one_phase()
    tab = build_tables(spec, *quadratic_data(spec))
    # min over p of g(p) (A/A)^2 = 2 - 1 = 1 N m exactly (p = P/6 is on the grid)
    assert_allclose(tab.torque_max, 1.0, rtol=1e-12)
    assert_allclose(tab.torque_per_count, 1.0 / 127, rtol=1e-12)


@pytest.mark.parametrize("pstep", [1, 3])
def test_interp_tables_hit_the_target_torque_within_quantisation(pstep: int) -> None:
    spec = one_phase()
    step = 5
    tab = build_tables(spec, *quadratic_data(spec, step=step, pstep=pstep))
    n = spec.positions_per_cycle
    p = np.arange(n)[:, None]
    c = np.arange(1, 128)[None, :]
    entry = tab.phases[0][:, 1:128].astype(float)
    torque = gain(p, n) * (entry / A) ** 2  # the surface, evaluated independently
    target = c * tab.torque_per_count
    # rounding to an integer pulse width: half a count times the slope 2 g pw / A^2; the chord
    # between data points h = 5 apart overestimates g (pw/A)^2 by at most g h^2 / (4 A^2)
    g = gain(p, n)
    tol = g * entry / A**2 + g * step**2 / (4 * A**2)
    # positions between data (pstep apart) interpolate g linearly: error <= max|g''| h^2 / 8
    tol = tol + (2 * np.pi * 3 / n) ** 2 * pstep**2 / 8 * (entry / A) ** 2
    assert np.all(np.abs(torque - target) <= tol + 1e-12)


def test_paper_method_within_one_torque_index() -> None:
    spec = one_phase()
    tab = build_tables(spec, *quadratic_data(spec, step=1), method="paper")
    n = spec.positions_per_cycle
    p = np.arange(n)[:, None]
    entry = tab.phases[0][:, 1:128].astype(float)
    torque = gain(p, n) * (entry / A) ** 2
    target = np.arange(1, 128)[None, :] * tab.torque_per_count
    # a cell holds torques within half an index of its centre, cells between are interpolated
    # from such neighbours (one index in all); the median of an even set (a half pulse width)
    # and the final rounding add at most one pulse width of slope 2 g pw / A^2
    tol = tab.torque_per_count + 2 * gain(p, n) * (entry + 1) / A**2
    assert np.all(np.abs(torque - target) <= tol + 1e-12)
    assert tab.median_cells > 0


def test_log_scaling_inverts_its_law() -> None:
    spec = one_phase()
    tab = build_tables(spec, *quadratic_data(spec, step=1), command_scaling="log")
    assert tab.command_scaling == "log"
    n = spec.positions_per_cycle
    c = np.arange(1, 128)
    target = torque_from_command(
        c, torque_max=tab.torque_max, command_max=127, scaling="log", log_curvature=4.0
    )
    torque = gain(np.arange(n)[:, None], n) * (tab.base[:, 1:] / A) ** 2
    # the base (before rounding) inverts the chord of data 1 pulse width apart: error below
    # g / (4 A^2) <= 3 / (4 * 255^2)
    assert_allclose(torque, np.broadcast_to(target, torque.shape), atol=3 / (4 * A**2) + 1e-12)
    assert target[0] < 0.1 * tab.torque_per_count  # finer steps at low torque than linear
    back = command_from_torque(target, torque_max=tab.torque_max, command_max=127, scaling="log")
    assert_allclose(back, c, rtol=1e-12)


def test_reflection_two_complement_and_zero_command() -> None:
    spec = three_phase()
    tab = build_tables(spec, *quadratic_data(spec))
    n = spec.positions_per_cycle
    for k, e in enumerate(spec.equilibrium_positions):
        table = tab.phases[k]
        assert_array_equal(table[:, 0], 0)
        for c in (1, 2, 50, 127):
            mirror = (2 * e - np.arange(n)) % n
            assert_array_equal(table[:, 256 - c], table[mirror, c])  # column of -c
        assert_array_equal(table[:, 255], table[(2 * e - np.arange(n)) % n, 1])  # c = -1
        assert_array_equal(table[:, 128], table[(2 * e - np.arange(n)) % n, 127])  # c = -128


def test_phase_entries_are_the_ramped_base() -> None:
    spec = three_phase(ramping="narrow")
    tab = build_tables(spec, *quadratic_data(spec), monotonic=False)
    expected = np.rint(tab.base[None, :, 1:] * spec.ramp.T[:, :, None])
    assert_array_equal(tab.phases[:, :, 1:128], expected)


def test_wider_entries_are_rescaled() -> None:
    spec = one_phase()
    data = quadratic_data(spec)
    tab = build_tables(spec, *data, actuation_bits=16, monotonic=False)
    assert tab.actuation_max == 65535
    assert_array_equal(tab.phases[0][:, 1:128], np.rint(tab.base[:, 1:] * 65535 / 255))


@settings(max_examples=50, deadline=None)
@given(
    arrays(np.int64, st.tuples(st.integers(1, 5), st.integers(1, 20)), elements=st.integers(0, 300))
)
def test_monotonic_filter_properties(table: np.ndarray) -> None:
    out = monotonic_filter(table)
    assert np.all(np.diff(out, axis=1) >= 0)
    assert np.all(out >= table)
    assert_array_equal(monotonic_filter(out), out)  # idempotent
    # an entry is changed only if it was smaller than an earlier one
    assert_array_equal(out == table, table >= np.maximum.accumulate(table, axis=1))


@settings(max_examples=30, deadline=None)
@given(arrays(np.int64, (3, 8), elements=st.integers(0, 255)))
def test_monotonic_filter_signed_halves(table: np.ndarray) -> None:
    out = monotonic_filter(table, command_bits=3)
    assert np.all(np.diff(out[:, :4], axis=1) >= 0)
    assert np.all(np.diff(out[:, 4:], axis=1) <= 0)  # -4 .. -1: magnitude decreasing


def test_built_tables_are_monotone_with_noise() -> None:
    spec = three_phase()
    p, w, t = quadratic_data(spec)
    t = t + np.random.default_rng(0).normal(0, 0.02, t.size)
    tab = build_tables(spec, p, w, t)
    assert np.all(np.diff(tab.phases[:, :, :128], axis=2) >= 0)


def test_reflect_negative_small() -> None:
    pos = np.array([[0, 3], [0, 5], [0, 7]])
    full = reflect_negative(pos, equilibrium=0, command_bits=2)
    # p=1 mirrors to 2 and p=2 to 1 (P = 3, e = 0)
    assert_array_equal(full[1], [0, 5, 7, 7])


def test_fill_voids_linear_and_smaller_first() -> None:
    grid = np.tile(np.arange(10.0) * 3 + 1, (6, 1))
    holes = grid.copy()
    holes[2, 3:7] = np.nan
    holes[4, 1] = np.nan
    assert_allclose(fill_voids(holes), grid)  # linear along both axes: exact
    # a single-cell gap across positions is filled before a long gap along the level axis
    g = np.array([[0.0, 10.0, 20.0, 30.0], [0.0, np.nan, np.nan, 30.0], [0.0, 4.0, 8.0, 30.0]])
    out = fill_voids(g)
    assert_allclose(out[1, 1:3], [7.0, 14.0])  # position-wise (cyclic) means, not 10, 20
    # the position axis is cyclic: row 0's gap is bridged by the last row
    c = np.array([[np.nan], [1.0], [np.nan], [np.nan], [4.0]])
    assert_allclose(fill_voids(c).ravel(), [2.5, 1.0, 2.0, 3.0, 4.0])


def test_fill_voids_non_uniform_levels() -> None:
    g = np.array([[0.0, np.nan, 10.0]])
    assert_allclose(fill_voids(g, levels=[0.0, 1.0, 5.0]), [[0.0, 2.0, 10.0]])


# -- errors ---------------------------------------------------------------------------------


def test_bad_rows_raise() -> None:
    spec = one_phase()
    p, w, t = quadratic_data(spec)
    with pytest.raises(InputError, match=r"position 48 at data row 1 is outside 0 \.\. 47"):
        build_tables(spec, np.r_[48, p[1:]], w, t)
    with pytest.raises(InputError, match=r"pulse_width 256 .* outside 0 \.\. 255"):
        build_tables(spec, p, np.r_[256, w[1:]], t)
    with pytest.raises(InputError, match="pulse_width -1"):
        build_tables(spec, p, np.r_[-1, w[1:]], t)
    with pytest.raises(InputError, match="torque holds NaN"):
        build_tables(spec, p, w, np.r_[np.nan, t[1:]])
    with pytest.raises(ValueError, match="method"):
        build_tables(spec, p, w, t, method="best")  # type: ignore[arg-type]


def test_dead_phase_raises() -> None:
    spec = three_phase()
    p, w, t = quadratic_data(spec)
    ramp = spec.ramp[p]
    alone2 = (ramp[:, 1] > 0) & (ramp[:, 0] == 0) & (ramp[:, 2] == 0)
    t = np.where(alone2, 0.001 * np.random.default_rng(1).standard_normal(t.size), t)
    with pytest.raises(InputError, match="phase 2 never produced torque"):
        build_tables(spec, p, w, t, path="d.csv")


def test_uncovered_positions_and_zero_torque_raise() -> None:
    spec = one_phase()
    p, w, t = quadratic_data(spec)
    keep = p < 30  # 18 positions without data: beyond the default gap P // 4 = 12
    with pytest.raises(
        InputError, match=r"no data at positions 30 \.\. 47 \(18 positions; at most 12"
    ):
        build_tables(spec, p[keep], w[keep], t[keep])
    t0 = np.where(p == 5, 0.0, t)
    with pytest.raises(InputError, match="no torque is reachable at position 5"):
        build_tables(spec, p, w, t0, max_gap=0)


def test_constant_torque_and_oversized_grid_raise() -> None:
    spec = one_phase()
    p, w, t = quadratic_data(spec)
    # a sensor that reads the same on every row (unconnected, a wrong column): no curve
    with pytest.raises(InputError, match=r"d\.csv: every row reads torque 0\.01 N m"):
        build_tables(spec, p, w, np.full(t.size, 0.01), path="d.csv")
    # 16-bit pulse widths at 48 positions: 3.1 M cells, refused before any allocation
    wide = motor_spec("m", phases=1, positions_per_cycle=48, equilibrium_positions=(0,),
                      actuation_max=65535)  # fmt: skip
    with pytest.raises(InputError, match=r"= 3\.15e\+06 cells, more than the 2\.1e\+06"):
        build_tables(wide, p, w, t)


def test_read_data_errors(tmp_path) -> None:  # type: ignore[no-untyped-def]
    spec = one_phase()
    f = tmp_path / "d.csv"
    write_table(f, {"position": [0, 1], "pulse_width": [0, 10]})
    with pytest.raises(InputError, match="missing column 'torque'"):
        read_data(f, spec, kind="characterisation")
    write_table(f, {"position": [0, 1.5], "pulse_width": [0, 10], "torque": [0.0, 1.0]})
    with pytest.raises(InputError, match="'position' must hold integers"):
        read_data(f, spec, kind="characterisation")
    write_table(f, {"position": [0, 1], "command": [0, 128], "torque": [0.0, 1.0]})
    with pytest.raises(InputError, match=r"command 128 at data row 2 is outside -128 \.\. 127"):
        read_data(f, spec, kind="verification")
    write_table(f, {"position": [0, 1], "pulse_width": [0, 10], "torque": [0.0, 1.0]})
    d = read_data(f, spec, kind="characterisation")
    assert_array_equal(d.level, [0, 10])


def _reference_fill(grid: np.ndarray, limit: float, levels: np.ndarray) -> np.ndarray:
    """fill_voids written out cell by cell: every pass, each void's gap along the levels (bounded)
    and along the cyclic positions, then the voids of the shortest gap filled."""
    out = grid.copy()
    n, w = out.shape
    while np.isnan(out).any():
        cand = {}
        for p, c in zip(*np.nonzero(np.isnan(out)), strict=True):
            lo = next((j for j in range(c - 1, -1, -1) if not np.isnan(out[p, j])), None)
            hi = next((j for j in range(c + 1, w) if not np.isnan(out[p, j])), None)
            lv = ll = None
            if lo is not None and hi is not None:
                ll = hi - lo - 1
                f = (levels[c] - levels[lo]) / (levels[hi] - levels[lo])
                lv = out[p, lo] + f * (out[p, hi] - out[p, lo])
            back = next((k for k in range(1, n + 1) if not np.isnan(out[(p - k) % n, c])), None)
            fwd = next((k for k in range(1, n + 1) if not np.isnan(out[(p + k) % n, c])), None)
            pv = pl = None
            if back is not None and fwd is not None and back + fwd - 1 <= limit:
                pl = back + fwd - 1
                a, b = out[(p - back) % n, c], out[(p + fwd) % n, c]
                pv = a + (b - a) * back / (back + fwd)
            cand[(p, c)] = (ll, lv, pl, pv)
        lengths = [x for v in cand.values() for x in (v[0], v[2]) if x is not None]
        if not lengths:
            break
        s = min(lengths)
        for (p, c), (ll, lv, pl, pv) in cand.items():
            vals = [v for length, v in ((ll, lv), (pl, pv)) if length == s]
            if vals:
                out[p, c] = float(np.mean(vals))
    return out


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.1, 0.7), st.sampled_from([1.0, 2.0, np.inf]))
def test_fill_voids_matches_a_cell_by_cell_reference(seed: int, share: float, limit: float) -> None:
    rng = np.random.default_rng(seed)
    grid = rng.normal(size=(9, 7))
    grid[rng.random(grid.shape) < share] = np.nan
    levels = np.cumsum(rng.uniform(0.5, 2.0, 7))
    got = fill_voids(grid, max_position_gap=None if np.isinf(limit) else int(limit), levels=levels)
    assert_allclose(got, _reference_fill(grid, limit, levels), rtol=1e-12, atol=1e-12)


def test_data_that_cannot_make_a_table_is_refused() -> None:
    spec = three_phase()
    p, w, t = quadratic_data(spec)
    top = w == A  # all saturated: every row at full scale
    with pytest.raises(InputError, match=r"d\.csv: every row has pulse width 255: no torque curve"):
        build_tables(spec, p[top], w[top], t[top], path="d.csv")
    # a rig that never reads above its noise: the motor off, the sensor on
    noise = 0.05 * np.random.default_rng(3).standard_normal(t.size)
    with pytest.raises(InputError, match=r"never read torque above its noise.*noise of a row"):
        build_tables(spec, p, w, noise, path="d.csv")
    # the same noise on a real surface is fine
    build_tables(spec, p, w, t + noise)
