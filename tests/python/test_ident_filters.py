"""tendyn.ident.filters (the treatment's Butterworth, zero-phase filtering and FIR without scipy.signal) against
scipy.signal itself, the oracle: same design, same padding and initial conditions, to rounding."""

import numpy as np
import pytest

from tendyn.ident.filters import butter_lowpass_sos, firwin_lowpass, sosfiltfilt

signal = pytest.importorskip("scipy.signal")


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5, 8])
@pytest.mark.parametrize("cutoff", [20.0, 150.0, 900.0])
def test_butterworth_and_zero_phase_filter_equal_scipy(order, cutoff):
    ours, ref = butter_lowpass_sos(order, cutoff, 2000.0), signal.butter(order, cutoff, fs=2000.0, output="sos")
    np.testing.assert_allclose(signal.sosfreqz(ours, worN=64, fs=2000.0)[1],
                               signal.sosfreqz(ref, worN=64, fs=2000.0)[1], rtol=1e-9, atol=1e-12)
    x = np.random.default_rng(order).normal(size=(3000, 3)).cumsum(axis=0)
    y = sosfiltfilt(ours, x)
    np.testing.assert_allclose(y, signal.sosfiltfilt(ref, x, axis=0), rtol=0, atol=1e-10 * np.abs(x).max())
    np.testing.assert_allclose(sosfiltfilt(ours, x.T, axis=1), y.T, rtol=0, atol=1e-12 * np.abs(x).max())


@pytest.mark.parametrize("numtaps, cutoff", [(11, 0.8), (101, 0.08), (501, 0.016)])
def test_fir_equals_scipy_firwin(numtaps, cutoff):
    np.testing.assert_allclose(firwin_lowpass(numtaps, cutoff), signal.firwin(numtaps, cutoff), rtol=0, atol=1e-15)


def test_bad_settings_are_refused():
    for bad in ((0, 10.0, 100.0), (4, 60.0, 100.0), (4, 0.0, 100.0)):
        with pytest.raises(ValueError):
            butter_lowpass_sos(*bad)
    with pytest.raises(ValueError):
        firwin_lowpass(10, 0.5)
    with pytest.raises(ValueError):
        sosfiltfilt(butter_lowpass_sos(4, 10.0, 100.0), np.ones(10))


def test_identify_treatment_does_not_import_scipy_signal():
    import subprocess
    import sys

    code = ("import sys, numpy as np; from tendyn.ident.treatment import butter_zero_phase, parallel_filter_taps; "
            "butter_zero_phase(np.ones((500, 2)), 10.0, 1000.0); parallel_filter_taps(5); "
            "print('scipy.signal' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
