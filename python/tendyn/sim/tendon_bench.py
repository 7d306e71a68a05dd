"""Experiments on the McGill 2N tendon bench twin (S1): stepped sine, swept sine, low-speed loop.

The time stepping runs in C++ (:func:`tendyn._core.run`, one call per experiment run, no
Python loop per step); this module builds command sequences and demodulates the outputs.

Conventions
-----------
* Command u [N at the rim] = the driving force F_τ of S1 eq. (2) (ideal current amplifier, class-B split).
* Step k (k = 0 … n−1) holds u[k] over [k h, (k+1) h]; the outputs of step k are the state at (k+1) h.
  A sine command is sampled at the middle of its step, u[k] = A sin(ω (k + ½) h), so that the held
  staircase has no half-step delay with respect to A sin(ω t).
* Friction on: the response depends on the amplitude. With the bundled bench (F_c ≈ 0.125 N per node at
  rest) a sine command has a dead-band up to ≈ 2 F_c ≈ 0.25 N (class-B half-waves against Coulomb nodes),
  and the open-loop peak of |F_m/F_τ| moves from ≈ 15 Hz (0.31 N) to ≈ 30 Hz (≥ 0.6 N), C22.
* Frequencies in Hz in the arguments (``freqs_hz``); ``omega`` [rad/s] where angular frequency is meant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from .. import _core
from ..device.tendon_bench import BENCH_FIELDS, TendonBench

__all__ = [
    "BenchRun",
    "LowSpeedLoop",
    "PeakSearch",
    "SteppedSine",
    "SweptSine",
    "bench_model",
    "low_speed_loop",
    "resonance_peak",
    "simulate",
    "stepped_sine",
    "swept_sine",
]


def bench_model(bench: TendonBench, rate_hz: float = 20000.0) -> "_core.TendonBenchModel":
    """The C++ model of ``bench`` stepped at ``rate_hz`` [Hz] (raises ValueError if invalid)."""
    if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be a positive number (got {rate_hz!r})")
    m = _core.TendonBenchModel()
    for name in BENCH_FIELDS:  # every file field; each write is validated by the core (ValueError names it)
        value = getattr(bench, name)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"TendonBench.{name} must be a number (got {type(value).__name__} {value!r})")
        setattr(m, name, float(value))
    m.dt = 1.0 / float(rate_hz)
    return m


@dataclass
class BenchRun:
    """Outputs of one run, one sample per step (state at the end of the step), SI units.

    Attributes: ``time`` [s] (end of each step), ``u`` [N] command, ``force`` [N] F_m (with noise),
    ``position`` [m] X_t (with noise), ``x_a``, ``x_b``, ``x_load`` [m] positions along the load axis,
    ``tension_a``, ``tension_b`` [N].
    """

    time: np.ndarray
    u: np.ndarray
    force: np.ndarray
    position: np.ndarray
    x_a: np.ndarray
    x_b: np.ndarray
    x_load: np.ndarray
    tension_a: np.ndarray
    tension_b: np.ndarray
    rate_hz: float
    seed: int

    def to_dict(self) -> dict[str, Any]:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}


def simulate(bench: TendonBench, u: Any, rate_hz: float = 20000.0, seed: int = 0) -> BenchRun:
    """Run the command sequence ``u`` [N] (one value per step) from rest and return all outputs."""
    u = np.ascontiguousarray(np.asarray(u, dtype=np.float64).ravel())
    if not np.all(np.isfinite(u)):
        raise ValueError("u must be finite")
    model = bench_model(bench, rate_hz)
    data = _core.TendonBenchData(model, int(seed))
    n = u.size
    out = [np.empty(n) for _ in range(7)]
    _core.run(model, data, u, *out)
    time = (np.arange(n) + 1.0) / float(rate_hz)
    return BenchRun(time, u, *out, rate_hz=float(rate_hz), seed=int(seed))


def _sine_command(amplitude: float, freq_hz: float, n: int, rate_hz: float) -> np.ndarray:
    h = 1.0 / rate_hz
    return amplitude * np.sin(2.0 * math.pi * freq_hz * (np.arange(n) + 0.5) * h)


@dataclass
class SteppedSine:
    """First-harmonic ratio F_m/F_τ per frequency (stepped sine, lock-in over whole cycles).

    Attributes
    ----------
    freqs_hz : ndarray
    amplitude_N : float
    ratio : ndarray of complex
        First harmonic of F_m divided by the first harmonic of the commanded force.
    """

    freqs_hz: np.ndarray
    amplitude_N: float
    ratio: np.ndarray
    cycles: int
    settle_s: np.ndarray
    rate_hz: float
    seed: int

    @property
    def magnitude(self) -> np.ndarray:
        return np.abs(self.ratio)

    @property
    def phase_deg(self) -> np.ndarray:
        return np.degrees(np.angle(self.ratio))

    @property
    def omega(self) -> np.ndarray:
        return 2.0 * math.pi * self.freqs_hz

    def peak_hz(self) -> float:
        """Grid frequency [Hz] of the largest |F_m/F_τ|."""
        return float(self.freqs_hz[int(np.argmax(self.magnitude))])

    def to_dict(self) -> dict[str, Any]:
        return {"freqs_hz": self.freqs_hz.tolist(), "amplitude_N": self.amplitude_N,
                "magnitude": self.magnitude.tolist(), "phase_deg": self.phase_deg.tolist(),
                "ratio_re": self.ratio.real.tolist(), "ratio_im": self.ratio.imag.tolist(),
                "cycles": self.cycles, "settle_s": self.settle_s.tolist(), "rate_hz": self.rate_hz,
                "seed": self.seed}


def stepped_sine(bench: TendonBench, freqs_hz: Sequence[float], amplitude_N: float, cycles: int = 10,
                 settle_cycles: int = 20, settle_s: float = 1.0, rate_hz: float = 20000.0,
                 seed: int = 0) -> SteppedSine:
    """Stepped-sine FRF of F_m/F_τ.

    Each frequency starts from rest, settles for max(settle_cycles, ceil(settle_s f)) whole cycles, then
    the first harmonic is measured by a single-bin DFT (lock-in) over ``cycles`` whole cycles of both the
    sensed force F_m and the commanded sine (same samples, same timestamps, so leakage cancels).

    Parameters
    ----------
    bench : TendonBench
    freqs_hz : sequence of float
        Test frequencies [Hz], each > 0 and below rate_hz / 4.
    amplitude_N : float
        Sine amplitude of the command [N at the rim].
    cycles, settle_cycles : int
        Measured / settling cycles.
    settle_s : float
        Minimum settling time [s] (the slowest transient decays with ζ ω_n ≈ 9.4 1/s nominally).
    rate_hz : float
        Step rate [Hz].
    seed : int
        Noise seed (a different, deterministic seed is used per frequency: seed + index).
    """
    freqs = np.asarray(freqs_hz, dtype=float).ravel()
    if freqs.size == 0 or not np.all(np.isfinite(freqs)) or np.any(freqs <= 0) or np.any(freqs >= rate_hz / 4):
        raise ValueError("freqs_hz must be finite, > 0 and < rate_hz/4")
    if not (math.isfinite(amplitude_N) and amplitude_N > 0):
        raise ValueError("amplitude_N must be > 0")
    if int(cycles) < 1 or int(settle_cycles) < 0:
        raise ValueError("cycles must be >= 1 and settle_cycles >= 0")
    model = bench_model(bench, rate_hz)
    h = 1.0 / rate_hz
    ratios = np.empty(freqs.size, dtype=complex)
    settles = np.empty(freqs.size)
    for i, f in enumerate(freqs):
        n_settle_cyc = max(int(settle_cycles), int(math.ceil(settle_s * f)))
        n0 = int(round(n_settle_cyc / f * rate_hz))
        n1 = int(round((n_settle_cyc + int(cycles)) / f * rate_hz))
        u = _sine_command(amplitude_N, f, n1, rate_hz)
        data = _core.TendonBenchData(model, int(seed) + i)
        out = [np.empty(n1) for _ in range(7)]
        _core.run(model, data, u, *out)
        force = out[0][n0:n1]
        t_end = (np.arange(n0, n1) + 1.0) * h  # outputs are the state at the end of each step
        kernel = np.exp(-2j * math.pi * f * t_end)
        y = np.dot(force, kernel)
        x = np.dot(amplitude_N * np.sin(2.0 * math.pi * f * t_end), kernel)
        ratios[i] = y / x
        settles[i] = n0 * h
    return SteppedSine(freqs, float(amplitude_N), ratios, int(cycles), settles, float(rate_hz), int(seed))


@dataclass
class PeakSearch:
    """Resonance-peak search of |F_m/F_τ| at one amplitude (coarse grid, then a fine grid)."""

    amplitude_N: float
    peak_hz: float
    peak_magnitude: float
    coarse: SteppedSine
    fine: SteppedSine | None

    def to_dict(self) -> dict[str, Any]:
        return {"amplitude_N": self.amplitude_N, "peak_hz": self.peak_hz, "peak_magnitude": self.peak_magnitude,
                "coarse": self.coarse.to_dict(), "fine": self.fine.to_dict() if self.fine else None}


def resonance_peak(bench: TendonBench, amplitude_N: float, f_lo: float = 8.0, f_hi: float = 40.0,
                   step_hz: float = 1.0, refine_hz: float = 0.25, **kw: Any) -> PeakSearch:
    """Frequency [Hz] of the largest first-harmonic |F_m/F_τ| between f_lo and f_hi.

    A grid of ``step_hz`` first, then (if ``refine_hz`` > 0) a grid of ``refine_hz`` over ±step_hz around
    the coarse maximum. Extra keyword arguments go to :func:`stepped_sine`.
    """
    grid = np.arange(f_lo, f_hi + 0.5 * step_hz, step_hz)
    coarse = stepped_sine(bench, grid, amplitude_N, **kw)
    k = int(np.argmax(coarse.magnitude))
    best_f, best_m, fine = float(grid[k]), float(coarse.magnitude[k]), None
    if refine_hz and refine_hz > 0:
        lo = max(f_lo, best_f - step_hz)
        hi = min(f_hi, best_f + step_hz)
        fgrid = np.arange(lo, hi + 0.5 * refine_hz, refine_hz)
        fine = stepped_sine(bench, fgrid, amplitude_N, **kw)
        j = int(np.argmax(fine.magnitude))
        if fine.magnitude[j] >= best_m:
            best_f, best_m = float(fgrid[j]), float(fine.magnitude[j])
    return PeakSearch(float(amplitude_N), best_f, best_m, coarse, fine)


@dataclass
class SweptSine:
    """FRF estimate F_m/F_τ from one linear chirp (ratio of the DFTs on the swept band)."""

    freqs_hz: np.ndarray
    ratio: np.ndarray
    amplitude_N: float
    run: BenchRun = field(repr=False)

    @property
    def magnitude(self) -> np.ndarray:
        return np.abs(self.ratio)

    @property
    def phase_deg(self) -> np.ndarray:
        return np.degrees(np.angle(self.ratio))

    def to_dict(self) -> dict[str, Any]:
        return {"freqs_hz": self.freqs_hz.tolist(), "magnitude": self.magnitude.tolist(),
                "phase_deg": self.phase_deg.tolist(), "amplitude_N": self.amplitude_N}


def swept_sine(bench: TendonBench, f0_hz: float = 2.0, f1_hz: float = 100.0, duration_s: float = 20.0,
               amplitude_N: float = 1.0, rate_hz: float = 20000.0, seed: int = 0,
               tail_s: float = 1.0) -> SweptSine:
    """Linear chirp from f0 to f1 over ``duration_s`` then ``tail_s`` of zero command; FRF = Y(f)/U(f).

    Accurate only where the plant is linear (friction off, or large amplitudes); with friction the result
    is an amplitude-dependent average. Returns the bins strictly inside (f0, f1).
    """
    n_sweep = int(round(duration_s * rate_hz))
    n = n_sweep + int(round(tail_s * rate_hz))
    t = (np.arange(n) + 0.5) / rate_hz
    k = (f1_hz - f0_hz) / duration_s
    u = amplitude_N * np.sin(2.0 * math.pi * (f0_hz * t + 0.5 * k * t**2))
    u[n_sweep:] = 0.0
    run = simulate(bench, u, rate_hz, seed)
    freqs = np.fft.rfftfreq(n, 1.0 / rate_hz)
    U = np.fft.rfft(u)
    Y = np.fft.rfft(run.force) * np.exp(-1j * math.pi * freqs / rate_hz)  # outputs sit half a step later
    band = (freqs > f0_hz) & (freqs < f1_hz)
    return SweptSine(freqs[band], Y[band] / U[band], float(amplitude_N), run)


@dataclass
class LowSpeedLoop:
    """Input/output record of a slow sine (dead-band and hysteresis-like loop, C21/C24).

    ``u`` [N] command F_τ, ``force`` [N] sensed F_m, ``position`` [m] X_t, ``time`` [s]; the last
    ``cycles`` whole cycles after ``settle_cycles``.
    """

    time: np.ndarray
    u: np.ndarray
    force: np.ndarray
    position: np.ndarray
    freq_hz: float
    amplitude_N: float

    def to_dict(self) -> dict[str, Any]:
        return {"time": self.time.tolist(), "u": self.u.tolist(), "force": self.force.tolist(),
                "position": self.position.tolist(), "freq_hz": self.freq_hz, "amplitude_N": self.amplitude_N}


def low_speed_loop(bench: TendonBench, freq_hz: float = 0.2, amplitude_N: float = 0.31, cycles: int = 2,
                   settle_cycles: int = 1, rate_hz: float = 20000.0, seed: int = 0,
                   decimate: int = 20) -> LowSpeedLoop:
    """Slow sine test (S1 Fig. 10b: 0.2 Hz, 0.31 N): returns the input and output arrays.

    The outputs are kept every ``decimate`` steps (1 kHz by default).
    """
    n0 = int(round(settle_cycles / freq_hz * rate_hz))
    n1 = int(round((settle_cycles + cycles) / freq_hz * rate_hz))
    u = _sine_command(amplitude_N, freq_hz, n1, rate_hz)
    run = simulate(bench, u, rate_hz, seed)
    sl = slice(n0, n1, max(1, int(decimate)))
    return LowSpeedLoop(run.time[sl], run.u[sl], run.force[sl], run.position[sl], float(freq_hz),
                        float(amplitude_N))


def bench_log(bench: TendonBench, run: BenchRun, experiment: str, options: dict | None = None,
              log_every: int = 1):
    """The log a bench records (tendyn.io.logs schema): command, differential tendon force and tendon
    displacement as sensed, every ``log_every`` steps. The truth (bench parameters) goes beside it."""
    from tendyn.io.logs import make_log

    sl = slice(log_every - 1, None, log_every)
    cols = {"time": run.time[sl], "force_cmd": run.u[sl], "force_tendon": run.force[sl],
            "x_tendon": run.position[sl]}
    return make_log(cols, device=bench.name, rate_hz=run.rate_hz / log_every, seed=run.seed,
                    experiment=experiment, options=options or {})
