"""The three digital filters of Gautier's treatment, without scipy.signal (whose import costs about as much as the
whole TX40 identification: issue 18's benchmark). Same designs and conventions as ``scipy.signal.butter(…,
output="sos")``, ``sosfiltfilt`` (odd padding, steady-state initial conditions) and ``firwin`` (Hamming window,
unit DC gain); the IIR recursion runs in LAPACK's triangular band solver (``?tbtrs``), compiled, on every column
at once. tests/python/test_ident_filters.py compares them with scipy.signal.

Examples
--------
>>> import numpy as np
>>> sos = butter_lowpass_sos(4, 10.0, 1000.0)           # 4th order, 10 Hz at 1 kHz
>>> sos.shape
(2, 6)
>>> y = sosfiltfilt(sos, np.ones(200))                    # unit DC gain, no edge transient on a constant
>>> bool(np.allclose(y, 1.0))
True
"""

from __future__ import annotations

import numpy as np


def butter_lowpass_sos(order: int, cutoff_hz: float, rate_hz: float) -> np.ndarray:
    """Digital Butterworth low-pass of ``order`` with −3 dB at ``cutoff_hz`` [Hz] for a sampling rate ``rate_hz``
    [Hz], as second-order sections (rows b0 b1 b2 1 a1 a2): analog prototype pre-warped, bilinear transform,
    poles paired with their conjugates, unit gain at DC."""
    if order < 1 or not 0 < cutoff_hz < rate_hz / 2:
        raise ValueError(f"order {order} ≥ 1 and cut-off {cutoff_hz} Hz in (0, {rate_hz / 2}) Hz needed")
    fs2 = 2.0 * rate_hz
    wa = fs2 * np.tan(np.pi * cutoff_hz / rate_hz)                  # pre-warped analog cut-off [rad/s]
    k = np.arange(order)
    p = wa * np.exp(1j * np.pi * (2 * k + order + 1) / (2 * order))  # left half-plane poles
    z = (fs2 + p) / (fs2 - p)                                       # bilinear transform; zeros all at z = −1
    upper = z[z.imag > 1e-14 * np.abs(z)]                           # one of each conjugate pair
    upper = upper[np.argsort(np.abs(upper))]
    real = np.sort(z[np.abs(z.imag) <= 1e-14 * np.abs(z)].real)
    rows = [[1.0, 2.0, 1.0, 1.0, -2.0 * zz.real, abs(zz) ** 2] for zz in upper]
    if real.size:                                                   # odd order: one first-order section
        rows.insert(0, [1.0, 1.0, 0.0, 1.0, -real[0], 0.0])
    sos = np.array(rows)
    for s in sos:                                                   # unit DC gain per section
        s[:3] *= s[3:].sum() / s[:3].sum()
    return sos


def _lfilter_zi(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Steady-state state of one second-order section for a unit step (transposed direct form II)."""
    n = 3
    companion = np.zeros((n - 1, n - 1))
    companion[0, :] = -a[1:]
    companion[1:, :-1] += np.eye(n - 2)
    return np.linalg.solve(np.eye(n - 1) - companion.T, b[1:] - a[1:] * b[0])


def _sosfilt(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """Filter the columns of ``x`` (samples × columns) through the sections, section states ``zi``
    (sections × 2 × columns). Each section: A y = B x + r with A unit lower-triangular banded (1, a1, a2), B x the
    FIR part and r the initial state in the first two rows; solved by forward substitution (LAPACK dtbtrs)."""
    from scipy.linalg.lapack import dtbtrs

    y = np.array(x, dtype=float, order="F")
    n = y.shape[0]
    for s, z0 in zip(sos, zi):
        b, a = s[:3], s[3:]
        rhs = b[0] * y
        rhs[1:] += b[1] * y[:-1]
        rhs[2:] += b[2] * y[:-2]
        rhs[0] += z0[0]
        rhs[1] += z0[1]
        band = np.zeros((3, n), order="F")
        band[0] = 1.0
        band[1, :-1] = a[1]
        band[2, :-2] = a[2]
        y, info = dtbtrs(band, np.asfortranarray(rhs), uplo="L", diag="U")
        if info != 0:
            raise np.linalg.LinAlgError(f"band solve failed (info {info})")
    return y


def sosfiltfilt(sos: np.ndarray, x, axis: int = 0) -> np.ndarray:
    """Zero-phase forward-backward filtering along ``axis`` (the response magnitude squared, no phase), with
    odd extension of 3 (2 sections + 1) samples at both ends and steady-state initial conditions."""
    sos = np.asarray(sos, float)
    x = np.moveaxis(np.asarray(x, float), axis, 0)
    shape = x.shape
    x2 = x.reshape(shape[0], -1)
    ntaps = 2 * len(sos) + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    edge = 3 * ntaps
    if shape[0] <= edge:
        raise ValueError(f"{shape[0]} samples: more than {edge} needed to filter")
    ext = np.concatenate([2 * x2[:1] - x2[edge:0:-1], x2, 2 * x2[-1:] - x2[-2:-(edge + 2):-1]])
    zi, scale = np.empty((len(sos), 2)), 1.0
    for i, s in enumerate(sos):
        zi[i] = scale * _lfilter_zi(s[:3], s[3:])
        scale *= s[:3].sum() / s[3:].sum()
    y = _sosfilt(sos, ext, zi[:, :, None] * ext[0][None, None, :])
    y = _sosfilt(sos, y[::-1], zi[:, :, None] * y[-1][None, None, :])[::-1]
    return np.moveaxis(y[edge:-edge].reshape(shape), 0, axis)


def firwin_lowpass(numtaps: int, cutoff: float) -> np.ndarray:
    """Linear-phase FIR low-pass of ``numtaps`` taps (odd), cut-off ``cutoff`` as a fraction of the Nyquist
    frequency: windowed sinc (Hamming), scaled to unit gain at DC."""
    if numtaps % 2 == 0 or not 0 < cutoff < 1:
        raise ValueError("an odd number of taps and a cut-off in (0, 1) of the Nyquist frequency are needed")
    m = np.arange(numtaps) - (numtaps - 1) / 2.0
    h = cutoff * np.sinc(cutoff * m) * np.hamming(numtaps)
    return h / h.sum()


# -- a peer's conventions (the `--treatment janot` preset): MATLAB's butter / filtfilt / decimate ----------------
# These use scipy.signal (imported here only, when a preset asks for them): their designs are the transfer
# functions MATLAB's scripts use, not the sections above.

def matlab_filtfilt(b, a, x, axis: int = 0) -> np.ndarray:
    """Forward-backward filtering as MATLAB's ``filtfilt(b, a, x)``: odd extension of 3 (n − 1) samples (n the
    filter length; scipy's default is 3 n) and steady-state initial conditions."""
    import scipy.signal as ss

    n = max(len(a), len(b))
    return ss.filtfilt(b, a, np.asarray(x, float), axis=axis, padtype="odd", padlen=3 * (n - 1))


def matlab_butter_filtfilt(x, cutoff_hz: float, rate_hz: float, order: int = 4, axis: int = 0) -> np.ndarray:
    """MATLAB's ``filtfilt(butter(order, cutoff / (rate / 2)), x)``: the single-pass design at ``cutoff_hz`` [Hz]
    (the forward-backward response is −6 dB there, not −3 dB as :func:`tendyn.ident.treatment.butter_zero_phase`)."""
    import scipy.signal as ss

    b, a = ss.butter(order, cutoff_hz / (rate_hz / 2.0))
    return matlab_filtfilt(b, a, x, axis=axis)


def matlab_decimate(x, r: int, axis: int = 0) -> np.ndarray:
    """MATLAB's ``decimate(x, r)``: Chebyshev type I low-pass (order 8, 0.05 dB ripple, cut-off 0.8 / r of the
    Nyquist frequency) by :func:`matlab_filtfilt`, then every r-th sample ending on the last one."""
    import scipy.signal as ss

    x = np.moveaxis(np.asarray(x, float), axis, 0)
    if r <= 1:
        return np.moveaxis(x.copy(), 0, axis)
    b, a = ss.cheby1(8, 0.05, 0.8 / r)
    y = matlab_filtfilt(b, a, x)
    nd = x.shape[0]
    nbeg = r - (r * int(np.ceil(nd / r)) - nd)                     # 1-based, as MATLAB's decimate
    return np.moveaxis(y[nbeg - 1::r], 0, axis)


def matlab_decimate_index(n: int, r: int) -> np.ndarray:
    """The input samples (0-based) that :func:`matlab_decimate` keeps out of n."""
    if r <= 1:
        return np.arange(n)
    return np.arange(r - (r * int(np.ceil(n / r)) - n) - 1, n, r)
