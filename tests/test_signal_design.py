"""torquemap's own filter designs against ``scipy.signal``'s, bit for bit, and the commands that
filter without importing ``scipy.signal``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import WHOLE_MODEL
from scipy import signal

from torquemap import _signal_design as design
from torquemap.filters import _butter_lowpass, _initial_state, lowpass


@pytest.mark.parametrize("order", range(1, 9))
def test_butter_and_its_initial_state_are_scipys_bit_for_bit(order: int) -> None:
    # the cut-offs lowpass accepts (MIN_RELATIVE_CUTOFF to just below Nyquist), random and
    # log-spaced, at the rates of our logs and odd ones
    rng = np.random.default_rng(order)
    for fs in (1000.0, 500.0, 2000.0, 1e4, 333.3, 1.0 / 0.00123):
        nyquist = fs / 2
        cuts = np.concatenate(
            [rng.uniform(1e-5, 0.999, 40) * nyquist, np.geomspace(1e-5, 0.99, 12) * nyquist]
        )
        for cutoff in cuts:
            ours = design.butter_lowpass_sos(order, float(cutoff), fs)
            theirs = signal.butter(order, cutoff, btype="low", fs=fs, output="sos")
            assert ours.dtype == theirs.dtype and ours.shape == theirs.shape
            np.testing.assert_array_equal(ours, theirs)
            np.testing.assert_array_equal(design.sosfilt_zi(ours), signal.sosfilt_zi(theirs))


def test_initial_state_of_any_sections_is_scipys() -> None:
    # sections not from a Butterworth: a leading coefficient to normalise, several sections
    rng = np.random.default_rng(5)
    for _ in range(200):
        sos = rng.normal(size=(3, 6))
        sos[:, 3] = rng.uniform(0.5, 2.0, 3)
        np.testing.assert_array_equal(design.sosfilt_zi(sos), signal.sosfilt_zi(sos))


def test_designs_reject_what_they_do_not_cover() -> None:
    with pytest.raises(ValueError):
        design.butter_lowpass_sos(0, 10.0, 1000.0)
    with pytest.raises(ValueError):
        design.butter_lowpass_sos(2, 500.0, 1000.0)


def test_lowpass_filters_as_scipy_does() -> None:
    # the designs in place: lowpass (order 2, the compiled filter; order 4, scipy's
    # sosfiltfilt) against scipy's design and filter
    rng = np.random.default_rng(3)
    t = np.arange(5000) * 1e-3
    x = rng.normal(size=(t.size, 2))
    for order in (2, 4):
        sos = signal.butter(order, 17.0, btype="low", fs=1000.0, output="sos")
        np.testing.assert_array_equal(
            lowpass(t, x, cutoff=17.0, order=order), signal.sosfiltfilt(sos, x, axis=0)
        )
    sos, _ = _butter_lowpass(2, 17.0, 1000.0)
    np.testing.assert_array_equal(_initial_state(sos.tobytes()), signal.sosfilt_zi(sos))


@WHOLE_MODEL
def test_estimate_does_not_import_scipy_signal(
    scara_bench: Path, scara_model: Path, tmp_path: Path
) -> None:
    # the estimate of a clean log in a fresh process: scipy.signal (1.6 s of CPU to import with
    # scipy 1.17.1), and scipy.stats and scipy.ndimage that it and the spike check would import,
    # stay out (before this test's change all three were imported)
    out = tmp_path / "f.csv"
    script = f"""
import sys
from torquemap.cli.main import main
main(["estimate", {str(scara_model)!r}, {str(scara_bench / "circle.csv")!r}, "-o", {str(out)!r},
      "--quiet"])
print(sorted(m for m in ("scipy.signal", "scipy.stats", "scipy.ndimage") if m in sys.modules))
"""
    ran = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert ran.stdout.strip().splitlines()[-1] == "[]", ran.stdout + ran.stderr
    assert out.exists()
