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
