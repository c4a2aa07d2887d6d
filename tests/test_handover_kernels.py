"""The hand-over's compiled kernels (torquemap._handover_kernels) against the numpy code they
replaced (torquemap.linearize.handover before stop 44, run here as written then): equal, not
close, since they perform the same operations in the same order."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from torquemap._handover_kernels import check_errors, contribution, interp_unit, pairwise_sum
from torquemap.linearize.handover import SHARE_TOL, check_handover, fill_handover
from torquemap.linearize.motor import motor_spec

pytestmark = pytest.mark.xdist_group("kernels")

# -- the numpy code the kernels replaced ------------------------------------------------------


def _value(row: NDArray[np.float64], v: float) -> float:
    top = row.size - 1
    x = min(max(v, 0.0), float(top))
    i = min(int(x), top - 1)
    f = x - i
    return float(row[i] * (1.0 - f) + row[i + 1] * f)


def _contribution(
    high: NDArray[np.float64], low: NDArray[np.float64], hi: float, lo: float, v: float
) -> float:
    first = v / hi
    if lo <= 0.0 or first < 0.25:
        return _value(high, first) - _value(low, first)
    ratio = lo / hi
    count = min(64, 1 + int(np.ceil(np.log(0.25 / first) / np.log(ratio))))
    arg = np.minimum(first * ratio ** np.arange(max(count, 1)), float(high.size - 1))
    x = np.arange(high.size, dtype=np.float64)
    return float(np.sum(np.interp(arg, x, high) - np.interp(arg, x, low)))


def _changed_phase(
    ra: NDArray[np.float64], rb: NDArray[np.float64], r: NDArray[np.float64]
) -> int | None:
    changed = (np.abs(ra - r) > SHARE_TOL) | (np.abs(rb - r) > SHARE_TOL)
    if int(changed.sum()) != 1:
        return None
    k = int(np.flatnonzero(changed)[0])
    al, be, rho = ra[k], rb[k], r[k]
    if abs(al - be) <= SHARE_TOL:
        return None
    if not min(al, be) - SHARE_TOL <= rho <= max(al, be) + SHARE_TOL:
        return None
    return k


def _estimate(fine, ramp, pa, pb, p, k, sa, sb, u, wb):  # type: ignore[no-untyped-def]
    al, be, rho = float(ramp[pa, k]), float(ramp[pb, k]), float(ramp[p, k])
    high, low = (fine[pb], fine[pa]) if be > al else (fine[pa], fine[pb])
    hi, lo = max(al, be), min(al, be)

    def t(v: float) -> float:
        return _contribution(high, low, hi, lo, v)

    return (1.0 - wb) * (sa - t(al * u)) + wb * (sb - t(be * u)) + t(rho * u)


def _runs(mean: NDArray[np.float64], max_gap: int, skip: int) -> list[tuple[int, int, int, int]]:
    n, levels = mean.shape
    out = []
    for j in range(levels):
        have = np.flatnonzero(np.isfinite(mean[:, j]))
        if have.size < skip + 2:
            continue
        for i, pa in enumerate(have):
            pb = int(have[(i + 1 + skip) % have.size])
            span = (pb - int(pa)) % n
            if 1 < span <= max_gap + 1:
                out.append((j, int(pa), pb, i))
    return out


def _check_errors(mean, levels, fine, ramp, max_gap):  # type: ignore[no-untyped-def]
    n = mean.shape[0]
    lin: list[float] = []
    ray: list[float] = []
    for j, pa, pb, i in _runs(mean, max_gap + 1, 1):
        have = np.flatnonzero(np.isfinite(mean[:, j]))
        p = int(have[(i + 1) % have.size])
        k = _changed_phase(ramp[pa], ramp[pb], ramp[p])
        if k is None:
            continue
        al, be, rho = ramp[pa, k], ramp[pb, k], ramp[p, k]
        if not min(al, be) + SHARE_TOL < rho < max(al, be) - SHARE_TOL:
            continue
        wb = ((p - pa) % n) / ((pb - pa) % n)
        sa, sb, truth = float(mean[pa, j]), float(mean[pb, j]), float(mean[p, j])
        est = _estimate(fine, ramp, pa, pb, p, k, sa, sb, float(levels[j]), wb)
        if not np.isfinite(est):
            continue
        lin.append((1.0 - wb) * sa + wb * sb - truth)
        ray.append(est - truth)
    return np.array(lin), np.array(ray)


def _fill(mean, levels, fine, ramp, max_gap):  # type: ignore[no-untyped-def]
    n = mean.shape[0]
    out = mean.copy()
    filled = 0
    for j, pa, pb, _ in _runs(mean, max_gap, 0):
        span = (pb - pa) % n
        for step in range(1, span):
            p = (pa + step) % n
            k = _changed_phase(ramp[pa], ramp[pb], ramp[p])
            if k is None:
                continue
            est = _estimate(
                fine, ramp, pa, pb, p, k, float(mean[pa, j]), float(mean[pb, j]),
                float(levels[j]), step / span,
            )  # fmt: skip
            if np.isfinite(est):
                out[p, j] = est
                filled += 1
    return out, filled


# -- the kernels against it -------------------------------------------------------------------


def _same(a: float, b: float) -> bool:
    """Equal bit for bit (NaN equal to NaN, 0.0 not equal to -0.0)."""
    return bool(np.float64(a).tobytes() == np.float64(b).tobytes())


def test_pairwise_sum_is_numpys_sum() -> None:
    rng = np.random.default_rng(0)
    for n in range(0, 129):
        for scale in (1.0, 1e8):
            a = rng.normal(size=n) * scale ** rng.uniform(size=n)
            assert _same(pairwise_sum(np.concatenate([a, [9.0]]), n), np.sum(a)), n


def test_interp_unit_is_numpys_interp() -> None:
    rng = np.random.default_rng(1)
    fp = rng.normal(size=40)
    fp[[5, 17, 18]] = np.nan
    fp[30] = fp[31] = np.inf
    x = np.concatenate([rng.uniform(-2.0, 42.0, 400), np.arange(-1.0, 41.0), [30.5, np.nan]])
    want = np.interp(x, np.arange(40.0), fp)
    for xi, wi in zip(x, want, strict=True):
        assert _same(interp_unit(float(xi), fp), wi), xi


def test_contribution_is_the_telescoping_sum_as_numpy_computed_it() -> None:
    rng = np.random.default_rng(2)
    work = np.empty(64)
    for _ in range(3000):
        high = np.cumsum(rng.uniform(0.0, 1.0, 256))
        low = high * rng.uniform(0.2, 1.0) - rng.uniform(0.0, 3.0)
        if rng.uniform() < 0.1:
            high[rng.integers(0, 256, 3)] = np.nan
        hi = float(rng.uniform(0.05, 1.0))
        lo = float(rng.choice([0.0, hi * rng.uniform(0.0, 0.999), hi * 0.9999999]))
        v = float(rng.uniform(0.0, 300.0) * rng.choice([1.0, 1e-3]))
        assert _same(contribution(high, low, hi, lo, v, work), _contribution(high, low, hi, lo, v))


@pytest.mark.parametrize("ramping", ["wide", "narrow"])
@pytest.mark.parametrize("seed", [3, 4])
def test_check_and_fill_equal_the_loops_they_replaced(ramping: str, seed: int) -> None:
    """Random grids (data every 2nd to 5th position, some cells missing, a preliminary model
    with holes) on a wide and a narrow ramp: the same errors, the same grid, bit for bit."""
    rng = np.random.default_rng(seed)
    spec = motor_spec(
        "t", phases=3, positions_per_cycle=96, equilibrium_positions=(0, 32, 64), ramping=ramping
    )
    ramp = np.asarray(spec.ramp, dtype=np.float64)
    n = ramp.shape[0]
    levels = np.arange(0.0, 256.0, 8.0)
    truth = np.cumsum(rng.uniform(0.0, 0.3, (n, 256)), axis=1) + rng.normal(size=(n, 1))
    mean = np.full((n, levels.size), np.nan)
    step = int(rng.integers(2, 6))
    mean[::step] = truth[::step][:, levels.astype(int)]
    mean[rng.uniform(size=mean.shape) < 0.1] = np.nan
    fine = truth + rng.normal(0.0, 0.05, truth.shape)
    fine[rng.uniform(size=fine.shape) < 0.002] = np.nan
    used = 0
    for max_gap in (2, 5, 9):
        lin, ray = _check_errors(mean, levels, fine, ramp, max_gap)
        got_lin, got_ray = check_errors(mean, levels, fine, ramp, max_gap)
        assert lin.tobytes() == got_lin.tobytes() and ray.tobytes() == got_ray.tobytes()
        check = check_handover(mean, levels, fine, ramp, max_gap=max_gap)
        assert check.cells == lin.size
        if lin.size:
            a, b = np.square(lin), np.square(ray)
            assert check.rms_linear == float(np.sqrt(a.mean()))
            assert check.rms_handover == float(np.sqrt(b.mean()))
        want, filled = _fill(mean, levels, fine, ramp, max_gap)
        got, cells = fill_handover(mean, levels, fine, ramp, max_gap=max_gap)
        assert cells == filled
        assert want.tobytes() == got.tobytes()
        used += filled + lin.size
    # the wide ramp changes one phase at a time (cells to estimate); the narrow ramp hands the
    # torque from one phase to the next, two shares changing at once (none)
    assert (used > 0) == (ramping == "wide")
