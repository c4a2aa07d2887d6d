"""A piece's second estimate with other reversal masks (``estimate.END_RUNS = "choose"``) and
the task-delay check take what the piece's first estimate computed that the masks do not
change (stop 42, E56): the same numbers, bit for bit, as computing all of it again.

The reference is the code path that recomputes everything (``_estimate_piece`` without
``shared``; :func:`torquemap.uncertainty.joint_sigma` without ``terms``), on the simulated
SCARA bench's circle (two joints, a planar arm's coupling, a whole-log model with PDTV
lines)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from torquemap import estimate as E
from torquemap.io import read_log
from torquemap.model import Model, load_model
from torquemap.uncertainty import joint_sigma

KEYS = ("rest", "filtered", "external", "sigma")


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Bit for bit, NaN equal to NaN."""
    return (
        a.dtype == b.dtype
        and a.shape == b.shape
        and bool(np.all(a.view(np.int64) == b.view(np.int64)))
    )


@pytest.fixture(scope="module")
def bench(scara_bench: Path, scara_model: Path) -> tuple[Model, Any]:
    model = load_model(scara_model)
    return model, read_log(scara_bench / "circle.csv", model.robot)


def _kw(model: Model) -> dict[str, Any]:
    return dict(
        method="model",
        cutoff=2.0,
        window=E.model_window(model),
        notch_width=0.5,
        min_revolutions=1.0,
        bridge_reversals=0.5,
        channel_delay=None,
        reversal_band=None,
        answers_only=True,
    )


@pytest.mark.parametrize("joints", [[0, 1], [1]])
def test_the_second_estimate_from_the_first_ones_terms_is_the_recomputed_one(
    bench: tuple[Model, Any], joints: list[int]
) -> None:
    model, log = bench
    kw = _kw(model)
    first = E._estimate_piece(model, log, **kw)
    assert first.shared is not None
    rest = first.arrays["rest"] > 0
    n = log.t.size
    # masks that differ from the first estimate's: a run at the start and one in the middle
    # (the bridged runs' sigma and low-pass take other paths than the first estimate's)
    masks = {}
    for k in joints:
        mask = rest[:, k].copy()
        mask[:300] = True
        mask[n // 2 : n // 2 + 40] = True
        masks[k] = mask
        assert not np.array_equal(mask, rest[:, k])
    again = E._estimate_piece(model, log, **kw, rest_override=masks).arrays
    reused = E._estimate_piece(
        model, log, **kw, rest_override=masks, shared=first.shared, joints=joints
    ).arrays
    for k in joints:
        for key in KEYS:
            assert _same(reused[key][:, k], again[key][:, k]), (key, k)
        # and the masks moved the answer: the test compares something that changed
        assert not _same(again["sigma"][:, k], first.arrays["sigma"][:, k])
    for k in set(range(len(model.robot.joints))) - set(joints):
        assert np.isnan(reused["external"][:, k]).all()  # not computed
    # the first estimate's kept terms are left as they were by the second
    third = E._estimate_piece(
        model, log, **kw, rest_override=masks, shared=first.shared, joints=joints
    ).arrays
    for k in joints:
        assert _same(third["sigma"][:, k], again["sigma"][:, k])


def test_joint_sigma_from_kept_terms_is_the_recomputed_one(bench: tuple[Model, Any]) -> None:
    model, log = bench
    kw = _kw(model)
    piece = E._estimate_piece(model, log, **kw)
    s = piece.shared
    assert s is not None
    for k, name in enumerate(model.robot.joint_names):
        args: dict[str, Any] = dict(
            t=log.t,
            theta=s.angle[:, k],
            velocity=s.velocity[:, k],
            acceleration=s.acceleration[:, k],
            modulation=s.modulation[:, k],
            cutoff=2.0,
            phasor=s.phasors.get(k),
            support=kw["window"],
        )
        bridged = np.zeros(log.t.size, dtype=bool)
        bridged[1000:1200] = True
        terms: dict[str, Any] = {}
        plain = joint_sigma(model, name, bridged=None, terms=terms, **args)
        assert set(terms) == {"var", "below_sd"} | {k for k in terms if k.startswith("fused@")}
        assert len(terms) == 3
        kept = {key: None if v is None else v.copy() for key, v in terms.items()}
        fresh = joint_sigma(model, name, bridged=bridged, **args)
        reused = joint_sigma(model, name, bridged=bridged, terms=terms, **args)
        assert _same(reused, fresh)
        assert not _same(fresh, plain)
        for key, value in kept.items():  # the kept terms were not written into
            assert value is None or _same(terms[key], value)
