"""APMD, CAPMD, PAPMD (torquemap.linearize.metrics) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.linearize.metrics import (
    apmd_report,
    evaluate_linearity,
    format_report,
    report_to_dict,
)
from torquemap.linearize.motor import motor_spec
from torquemap.linearize.tables import LinearizeData, build_tables

P, C = 32, 20


def grid() -> tuple[np.ndarray, np.ndarray]:
    p, c = np.meshgrid(np.arange(P), np.arange(C + 1), indexing="ij")
    return p.ravel(), c.ravel()


def test_perfect_plane_has_zero_deviation() -> None:
    p, c = grid()
    r = apmd_report(p, c, 0.7 * c, command_max=C, positions_per_cycle=P)
    assert_allclose(r.apmd, 0.0, atol=1e-15)  # exact up to rounding
    assert_allclose(np.nanmax(r.capmd), 0.0, atol=1e-15)
    assert_allclose(r.slope, 0.7, rtol=1e-14)
    assert r.data_density == 1.0 and r.cells == P * C


def test_command_distortion_closed_form() -> None:
    # tau = k c^2 / (C/2): tau_ave at C/2 is k C/2, the plane is k c, PMD = |2c/C - 1|;
    # sum_{c=1}^{C} |2c - C| = C^2 / 2 for even C, so APMD = 1/2 exactly
    p, c = grid()
    r = apmd_report(p, c, 3.0 * c**2 / (C / 2), command_max=C, positions_per_cycle=P)
    assert_allclose(r.apmd, 0.5, rtol=1e-12)
    assert_allclose(r.capmd[1:], np.abs(2 * np.arange(1, C + 1) / C - 1), atol=1e-12)
    # above 10 % command: c = 3 .. 20, mean of |2c/C - 1|
    assert_allclose(r.apmd_above_10, np.mean(np.abs(2 * np.arange(3, C + 1) / C - 1)), rtol=1e-12)


def test_position_ripple_closed_form() -> None:
    # tau = k c (1 + a cos 2 pi p / P): the cosine averages to zero over the cycle, so the
    # plane is k c and PMD = a |cos| (independent of c)
    p, c = grid()
    a = 0.3
    r = apmd_report(
        p, c, 2.0 * c * (1 + a * np.cos(2 * np.pi * p / P)), command_max=C, positions_per_cycle=P
    )
    expected = a * np.abs(np.cos(2 * np.pi * np.arange(P) / P))
    assert_allclose(r.papmd, expected, atol=1e-12)
    assert_allclose(r.apmd, expected.mean(), rtol=1e-12)
    # the smallest of the per-position maxima: 2 C (1 - a)
    assert_allclose(r.position_independent_torque, 2.0 * C * (1 - a), rtol=1e-12)


def test_capmd_and_papmd_average_to_apmd() -> None:
    p, c = grid()
    rng = np.random.default_rng(3)
    tau = c * (1 + 0.2 * rng.standard_normal(p.size))
    r = apmd_report(p, c, tau, command_max=C, positions_per_cycle=P)
    assert_allclose(np.mean(r.capmd[1:]), r.apmd, rtol=1e-12)  # a full grid: equal weights
    assert_allclose(np.mean(r.papmd), r.apmd, rtol=1e-12)
    assert_allclose(r.pmd_density.sum(), 1.0, rtol=1e-12)


def test_repeats_are_averaged_and_empty_cells_skipped() -> None:
    p, c = grid()
    tau = 0.5 * c * (1 + 0.1 * np.sin(p))
    ref = apmd_report(p, c, tau, command_max=C, positions_per_cycle=P)
    # the same cells twice, +-d around the value: the cell means are unchanged
    r = apmd_report(
        np.r_[p, p], np.r_[c, c], np.r_[tau + 0.2, tau - 0.2], command_max=C, positions_per_cycle=P
    )
    assert_allclose(r.apmd, ref.apmd, rtol=1e-12)
    assert r.rows == 2 * P * C and r.cells == P * C
    keep = p % 2 == 0  # half the positions: density halves
    half = apmd_report(p[keep], c[keep], tau[keep], command_max=C, positions_per_cycle=P)
    assert_allclose(half.data_density, 0.5)
    assert np.isnan(half.papmd[1::2]).all()


def test_nominal_apmd() -> None:
    p, c = grid()
    r = apmd_report(p, c, 0.1 * c, command_max=C, positions_per_cycle=P, nominal_torque=0.1 * c)
    assert r.nominal_apmd == pytest.approx(0.0, abs=1e-15)
    r = apmd_report(p, c, 0.1 * c, command_max=C, positions_per_cycle=P, nominal_torque=0.2 * c)
    assert r.nominal_apmd == pytest.approx(0.5)  # |0.2 - 0.1| / 0.2


def test_errors() -> None:
    p, c = grid()
    with pytest.raises(InputError, match=r"no data rows with a command in 1 \.\. 20"):
        apmd_report(p, 0 * c, c, command_max=C, positions_per_cycle=P)
    low = c < 5
    with pytest.raises(InputError, match="half-way command 10"):
        apmd_report(p[low], c[low], c[low] * 1.0, command_max=C, positions_per_cycle=P)


def test_evaluate_with_tables_checks_the_motor() -> None:
    spec = motor_spec("m", phases=1, positions_per_cycle=16, equilibrium_positions=(0,))
    p, w = np.meshgrid(np.arange(16), np.arange(0, 256, 5), indexing="ij")
    tables = build_tables(spec, p.ravel(), w.ravel(), (w * (2 + np.sin(p))).ravel() / 255.0)
    other = motor_spec("m", phases=1, positions_per_cycle=32, equilibrium_positions=(0,))
    data = LinearizeData(
        position=np.zeros(3, dtype=np.int64),
        level=np.arange(3),
        torque=np.ones(3),
        kind="verification",
        path="v.csv",
    )
    with pytest.raises(
        InputError,
        match=r"T.npz: tables are for another motor .*positions per cycle 16 \(the motor: 32\)",
    ):
        evaluate_linearity(other, data, tables=tables, tables_path="T.npz")
    moved = motor_spec("m", phases=1, positions_per_cycle=16, equilibrium_positions=(3,))
    with pytest.raises(InputError, match=r"equilibrium positions \(0,\) \(the motor: \(3,\)\)"):
        evaluate_linearity(moved, data, tables=tables)
    # a verification with exactly the nominal torque: zero deviation against the law
    pp, cc = np.meshgrid(np.arange(16), np.arange(128), indexing="ij")
    ideal = LinearizeData(
        position=pp.ravel(),
        level=cc.ravel(),
        torque=cc.ravel() * tables.torque_per_count,
        kind="verification",
        path=None,
    )
    r = evaluate_linearity(spec, ideal, tables=tables)
    assert r.nominal_apmd == pytest.approx(0.0, abs=1e-12)
    assert r.apmd == pytest.approx(0.0, abs=1e-12)
    d = report_to_dict(r)
    assert d["capmd"][0] is None and d["command_max"] == 127
    assert "overall APMD" in format_report(r)
