"""Tests that can fail in the blind areas of issue 34 item 7: each checks its quantity against an independent
route (Monte Carlo, a hand formula, another module), and each was seen failing against a planted bug of its kind
(named in each test's docstring)."""

from __future__ import annotations

import functools

import numpy as np
import pytest


# ---- FRF: random error and confidence quantile ------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _frf_realisations(n_real=200, n=2048, nperseg=128, noise=0.6, seed=7, confidence=0.9):
    """Monte Carlo of H1 on a known FIR system with output noise: (|Ĥ| per realisation (n_real, bins), |H| true,
    the first realisation's MeasuredFRF (its ε and band))."""
    from tendyn.ident.frf import MeasuredFRF, spectra

    rng = np.random.default_rng(seed)
    b = np.array([0.6, 0.3, -0.2, 0.1])
    rate = 1000.0
    mags, first = [], []
    for r in range(n_real):
        u = rng.standard_normal(n)
        y = np.convolve(u, b)[:n] + noise * rng.standard_normal(n)
        sp = spectra(u, y, rate, nperseg=nperseg, window="hann", overlap=0.0)   # independent segments: n_d exact
        frf = MeasuredFRF.from_spectra(sp, estimator="h1", input="u", output="y", input_unit="V",
                                       output_unit="V", confidence=confidence)
        mags.append(np.abs(frf.ratio))
        first.append(frf)
    f = first[0].freq_hz
    z = np.exp(-2j * np.pi * f / rate)
    true = np.abs(sum(bk * z ** k for k, bk in enumerate(b)))
    return np.array(mags), true, first


def test_frf_random_error_is_the_spread_of_the_estimate():
    """ε = √(1−γ²)/(|γ|√(2 n_d)) against the Monte-Carlo spread of |Ĥ1|/|H| over 200 independent records (pooled over
    the bins of moderate coherence). Plant seen failing: the factor 2 under the root dropped (ε √2 too large:
    ratio 0.71)."""
    mags, true, frfs = _frf_realisations()
    eps = np.median([fr.random_error() for fr in frfs], axis=0)
    spread = np.std(mags / true, axis=0)
    keep = (eps > 0.05) & (eps < 0.3)                 # the small-error regime the formula is for
    assert keep.sum() >= 10
    ratio = np.median(spread[keep] / eps[keep])
    print(f"FRF random error: Monte-Carlo spread / ε = {ratio:.3f} over {keep.sum()} bins")
    assert 0.85 < ratio < 1.15


@pytest.mark.parametrize("confidence", [0.68, 0.9])
def test_frf_band_covers_the_truth_at_its_confidence(confidence):
    """The band's coverage of the true |H| over 200 records and the bins of moderate error is its confidence level
    (two-sided normal quantile z = Φ⁻¹(½ + ½c)). Plant seen failing: the quantile taken one-sided, Φ⁻¹(c) (coverage
    0.36 at c = 0.68, 0.80 at c = 0.9)."""
    import copy

    mags, true, frfs = _frf_realisations()
    frfs = [copy.copy(fr) for fr in frfs]
    for fr in frfs:
        fr.confidence = confidence
    eps = np.median([fr.random_error() for fr in frfs], axis=0)
    keep = (eps > 0.05) & (eps < 0.3)
    inside = []
    for m, fr in zip(mags, frfs):
        low, high, _ = fr.band()
        inside.append(((true >= low) & (true <= high))[keep])
    coverage = float(np.mean(inside))
    print(f"FRF band at {confidence:.2f}: coverage {coverage:.3f}")
    assert abs(coverage - confidence) < 0.06


# ---- Lur'e model: the stuck state's balance ---------------------------------------------------------------------

def test_lure_stuck_state_breaks_away_at_the_static_dead_band():
    """Brought to rest at y* ≠ 0 (G(1) = 2.5 ≠ 1), the Lur'e model stays stuck for u within y*/G(1) ± F and breaks
    away beyond, at the first sample: the stuck state's net input is y*/G(1) (the static balance). Oracle: the
    dead-band |u − y/G(1)| ≤ F, from G(1) computed here from b, a. Plant seen failing: the rest state's net input
    taken as y* G(1) instead of y*/G(1) (inv_g0 inverted)."""
    from tendyn.ident.block_simulation import _lure_simulate

    b, a, F = [0.3, 0.2], [-0.9, 0.1], 0.4
    g1 = sum(b) / (1.0 + sum(a))
    assert abs(g1 - 2.5) < 1e-12
    u = np.concatenate([np.full(6, 2.0), np.full(200, 0.9)])      # moving, then a level inside the dead-band
    y = _lure_simulate(b, a, F, u)
    ystar = y[-1]
    assert np.all(y[-150:] == ystar) and ystar > 1.0, "the model must stick while still moving (not at rest by slip)"
    assert abs(0.9 - ystar / g1) <= F + 1e-12                      # inside the static dead-band
    for frac, moves in ((0.97, False), (-0.97, False), (1.03, True), (-1.03, True)):
        u2 = np.concatenate([u, np.full(5, ystar / g1 + frac * F)])
        y2 = _lure_simulate(b, a, F, u2)
        assert (y2[207] != ystar) == moves, (frac, y2[204:210], ystar)
        if not moves:
            assert np.all(y2[206:] == ystar), (frac, y2[204:], ystar)


# ---- block model: frequency unit of its response ----------------------------------------------------------------

def test_block_model_frequency_response_is_in_rad_per_s():
    """BlockModelFit.frequency_response(ω [rad/s]) against the steady-state gain and phase of the filter driven by a
    sine of ω (simulated, fitted by least squares) and against python-control's response of linear_tf. Plant seen
    failing: z = exp(j 2π ω dt) (ω read as Hz)."""
    import control
    from scipy.signal import lfilter

    from tendyn.ident.blockmodel import BlockModelFit

    dt = 1e-3
    fit = BlockModelFit(structure="hammerstein", nonlinearity="dead-zone", order=2, b=np.array([0.0, 0.05, 0.03]),
                        a=np.array([-1.5, 0.6]), params={}, dt=dt, fit_rms=0.0, fit_nrms=0.0)
    omega = np.array([2.0, 30.0, 300.0])
    H = fit.frequency_response(omega)
    t = np.arange(20000) * dt
    for w, h in zip(omega, H):
        y = lfilter(fit.b, np.concatenate([[1.0], fit.a]), np.sin(w * t))[10000:]
        X = np.column_stack([np.sin(w * t[10000:]), np.cos(w * t[10000:])])
        s, c = np.linalg.lstsq(X, y, rcond=None)[0]
        np.testing.assert_allclose(h, s + 1j * c, rtol=1e-6, atol=1e-9)
    mag, phase, _ = control.frequency_response(fit.linear_tf(), omega)
    np.testing.assert_allclose(np.abs(H), mag, rtol=1e-9)


# ---- Colgate's passivity bound: the factor 2 ----------------------------------------------------------------------

def test_colgate_bound_is_the_sampled_data_criterion():
    """K of the Colgate–Schenkel bound at B against the general sampled-data criterion computed numerically:
    b > (T/2) max_θ Re{(1 − e^{−jθ}) H(e^{jθ})}/(1 − cos θ), H(z) = K + B (1 − z⁻¹)/T the virtual wall; the largest
    passive K solves it by bisection. Plant seen failing: the bound without its factor 2 (K = (b − |B|)/T)."""
    from tendyn.pipelines.zwidth import ZWidthResult

    rate, b = 1000.0, 2.0
    T = 1.0 / rate
    grid = ZWidthResult(device="x", rate_hz=rate, rows=[], stiffness=np.array([0.0]), damping=np.array([0.0]),
                        modes=("m",), colgate_b={"m": b})
    theta = np.linspace(1e-3, np.pi, 4000)
    z = np.exp(1j * theta)

    def needed(K, B):
        H = K + B * (1 - 1 / z) / T
        return 0.5 * T * np.max(np.real((1 - 1 / z) * H) / (1 - np.cos(theta)))

    for B in (0.0, 0.5, -0.8):
        lo, hi = 0.0, 1e6
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if needed(mid, B) < b else (lo, mid)
        np.testing.assert_allclose(grid.colgate_max_stiffness("m", B), lo, rtol=1e-3)


# ---- c_L from a given η_d ------------------------------------------------------------------------------------------

def test_load_coefficient_from_a_given_reducer_efficiency():
    """A loss model given η_d per transmission holds c_L with C_0/η_d − C_0 = c_L C_0 (driving: the motor supplies
    the load torque over the efficiency), i.e. c_L = 1/η_d − 1, computed here from that balance; and given c_L the
    same η_d comes back. Plant seen failing: c_L = 1 − η_d (the back-driven loss read as the driving one)."""
    from tendyn.devices import bundled
    from tendyn.device import load_device
    from tendyn.ident.loss_model import identified_losses

    dev = load_device(bundled("lexos"))
    n = dev.n_transmissions
    eta = np.array([0.8, 0.9, 0.6, 1.0])[:n]
    losses = identified_losses(dev, {"tau0": np.zeros((n, n)).tolist(), "nu": np.zeros((n, n)).tolist(),
                                     "reducer_efficiency": eta.tolist()})
    C0 = 1.7                                                   # any load torque at the motor [N·m]
    c_l = (C0 / eta - C0) / C0                                 # the driving balance, solved for c_L
    np.testing.assert_allclose(losses.load_coefficient, c_l, rtol=1e-12)
    back = identified_losses(dev, {"tau0": np.zeros((n, n)).tolist(), "nu": np.zeros((n, n)).tolist(),
                                   "load_coefficient": [c if c < 1 else 0.5 for c in c_l]})
    np.testing.assert_allclose(back.reducer_efficiency[c_l < 1], eta[c_l < 1], rtol=1e-12)
