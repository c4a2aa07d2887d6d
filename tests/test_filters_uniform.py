"""The uniform-grid fast path of ``differentiate`` equals the general irregular-time algorithm."""

from __future__ import annotations

import numpy as np

from torquemap.filters import differentiate


def test_uniform_fast_path_matches_the_general_fit() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(20000) * 5e-4
    x = np.sin(3.0 * t) + np.round(rng.normal(size=t.size) * 3.0) / 1000.0  # quantised noise
    fast = differentiate(t, x, window=0.0502)
    # a nanosecond jitter takes the general per-sample normal-equation path; the window
    # (+-50.2 samples) holds the same 101 samples either way
    jittered = t.copy()
    jittered[1::2] += 1e-9
    slow = differentiate(jittered, x, window=0.0502)
    np.testing.assert_allclose(fast.position, slow.position, atol=1e-8)
    np.testing.assert_allclose(fast.velocity, slow.velocity, atol=1e-6)
    np.testing.assert_allclose(fast.acceleration, slow.acceleration, atol=1e-4)
