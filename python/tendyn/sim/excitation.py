"""Excitation signals for identifying a bench: PRBS, multisine, stepped sines (issue 21).

The same sequences drive the twins (:mod:`tendyn.pipelines.s1_logs`) and a real bench (``tendyn plan prbs |
multisine | stepped-sine`` writes them as reference logs). Every function returns the reference sampled at
``rate_hz`` [Hz], sample k at time k / rate_hz, held until the next sample (a controller's zero-order hold);
amplitudes are in the unit of the reference (N for the tendon bench's ``force_cmd``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["multisine", "prbs", "stepped_sines"]


BYTES_PER_SAMPLE = 96
"""Peak memory of one reference sample [bytes]: the signal, its time column, the log's copies and its CSV or
Parquet text (2 columns) — to refuse a plan that cannot fit before building it."""


def _require_memory(n_values: float, what: str) -> None:
    from tendyn.sim.limits import require_memory

    require_memory(n_values, "shorten it or lower the rate", what)


def _check(amplitude, duration_s, rate_hz):
    for name, v in (("amplitude", amplitude), ("duration_s", duration_s), ("rate_hz", rate_hz)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a finite number > 0 (got {v!r})")
    n = int(round(duration_s * rate_hz))
    if n < 2:
        raise ValueError(f"duration_s × rate_hz must give at least 2 samples (got {n})")
    _require_memory(BYTES_PER_SAMPLE * n, f"a reference of {n} samples")
    return n


def prbs(amplitude: float, duration_s: float, rate_hz: float, *, clock_hz: float | None = None, nbits: int = 10,
         seed: int = 0) -> np.ndarray:
    """A maximum-length binary sequence (``scipy.signal.max_len_seq``, ``nbits`` bits, period 2^nbits − 1
    clock periods) of levels ±``amplitude``, one level per clock period 1/``clock_hz`` (default: the sample
    rate), repeated to ``duration_s`` [s]; ``seed`` picks the register's start state. Its power is flat to
    about 0.44 clock_hz."""
    from scipy.signal import max_len_seq

    n = _check(amplitude, duration_s, rate_hz)
    clock_hz = rate_hz if clock_hz is None else float(clock_hz)
    if not (math.isfinite(clock_hz) and 0 < clock_hz <= rate_hz):
        raise ValueError(f"clock_hz must be in (0, rate_hz] (got {clock_hz!r})")
    if not 2 <= int(nbits) <= 24:
        raise ValueError(f"nbits must be 2…24 (got {nbits!r})")
    rng = np.random.default_rng(seed)
    state = rng.integers(0, 2, int(nbits))
    state[rng.integers(0, int(nbits))] = 1                     # not the all-zero state
    bits = max_len_seq(int(nbits), state=state)[0]
    clock = np.floor(np.arange(n) * clock_hz / rate_hz).astype(int)
    return amplitude * (2.0 * bits[clock % bits.size] - 1.0)


def multisine(amplitude: float, duration_s: float, rate_hz: float, *, band_hz=(1.0, 50.0), period_s: float = 2.0,
              seed: int | None = None) -> np.ndarray:
    """Sum of sines at every multiple of 1/``period_s`` inside ``band_hz`` [Hz], equal amplitudes, Schroeder
    phases (low crest factor; ``seed`` adds random phases instead), scaled to a peak of ``amplitude``;
    periodic with ``period_s`` [s] (analyse it with rectangular windows of whole periods)."""
    n = _check(amplitude, duration_s, rate_hz)
    lo, hi = float(band_hz[0]), float(band_hz[1])
    if not (0 <= lo < hi < rate_hz / 2):
        raise ValueError(f"band_hz must satisfy 0 <= lo < hi < rate_hz/2 (got {band_hz!r})")
    if not (math.isfinite(period_s) and period_s * rate_hz >= 2):
        raise ValueError(f"period_s must hold at least 2 samples (got {period_s!r})")
    k0, k1 = max(1, math.ceil(lo * period_s)), math.floor(hi * period_s)
    if k1 < k0:
        raise ValueError(f"no multiple of 1/period_s = {1 / period_s:g} Hz inside band_hz {band_hz!r}")
    m = int(round(period_s * rate_hz))             # the lines x samples table, sized before anything is built
    _require_memory(16.0 * m * (k1 - k0 + 1), f"a multisine of {k1 - k0 + 1} lines over {m} samples per period")
    ks = np.arange(k0, k1 + 1)
    if seed is None:
        phases = -math.pi * ks * (ks - 1) / ks.size                 # Schroeder
    else:
        phases = np.random.default_rng(seed).uniform(0, 2 * math.pi, ks.size)
    t = np.arange(m) / rate_hz
    one = np.sin(2 * math.pi * np.outer(t, ks / period_s) + phases).sum(axis=1)
    one *= amplitude / np.max(np.abs(one))
    return np.resize(one, n)


def stepped_sines(amplitude: float, freqs_hz, rate_hz: float, *, cycles: int = 10, settle_s: float = 1.0,
                  settle_cycles: int = 10) -> list[np.ndarray]:
    """One sine per frequency of ``freqs_hz`` [Hz] from rest: max(settle_cycles, ceil(settle_s f)) cycles to
    settle, then ``cycles`` measured cycles (the same plan as :func:`tendyn.sim.tendon_bench.stepped_sine`);
    :func:`tendyn.ident.frf.frf_from_logs` keeps the second half of each record."""
    freqs = np.asarray(freqs_hz, float).ravel()
    if freqs.size == 0 or not np.all(np.isfinite(freqs)) or np.any(freqs <= 0) or np.any(freqs >= rate_hz / 4):
        raise ValueError("frequencies must be finite, > 0 and < rate_hz/4")
    _check(amplitude, 1.0, rate_hz)
    if int(cycles) < 1 or int(settle_cycles) < 0 or not settle_s >= 0:
        raise ValueError("cycles must be >= 1, settle_cycles >= 0 and settle_s >= 0")
    def length(f):
        total = max(int(settle_cycles), math.ceil(settle_s * f)) + int(cycles)
        total = max(total, 2 * int(cycles))                        # the measured cycles in the second half
        return int(round(total / f * rate_hz))

    n_all = sum(length(f) for f in freqs)
    _require_memory(BYTES_PER_SAMPLE * n_all, f"{freqs.size} stepped sines of {n_all} samples in all")
    out = []
    for f in freqs:
        n = length(f)
        out.append(amplitude * np.sin(2 * math.pi * f * np.arange(n) / rate_hz))
    return out
