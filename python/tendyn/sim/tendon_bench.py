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
* Frequency grids are ``omega`` [rad/s] (keyword-only arguments, ``FrequencyResponse.omega``); a single
  frequency setting is ``*_hz`` [Hz] (``freq_hz``, ``f0_hz``, ``rate_hz``). Results:
  :class:`tendyn.results.FrequencyResponse` (stepped and swept sines), :class:`LowSpeedLoop`.
* Every function takes the bench or its :func:`tendyn.device.compile_device` form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from .. import _core
from ..device import CompiledDevice, compile_device
from ..device.tendon_bench import BENCH_MODEL_FIELDS, TendonBench
from ..io.logs import make_log
from ..results import FrequencyResponse, Result, format_table

__all__ = [
    "BenchRun",
    "ClosedLoopRun",
    "Controller",
    "h1_estimate",
    "loop_io",
    "loop_log",
    "loop_sine_log",
    "loop_stepped_sine_logs",
    "io_record",
    "loop_stepped_sine",
    "simulate_closed_loop",
    "FrequencyResponse",
    "LowSpeedLoop",
    "PeakSearch",
    "bench_log",
    "bench_model",
    "low_speed_loop",
    "resonance_peak",
    "simulate",
    "stepped_sine",
    "swept_sine",
]


def bench_model(bench: TendonBench | CompiledDevice, rate_hz: float = 20000.0) -> "_core.TendonBenchModel":
    """The C++ model of ``bench`` stepped at ``rate_hz`` [Hz] (raises ValueError if invalid)."""
    bench = _bench(bench)
    if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be a positive number (got {rate_hz!r})")
    m = _core.TendonBenchModel()
    for name in BENCH_MODEL_FIELDS:  # every plant field of the file; each write is validated by the core (ValueError names it)
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


def simulate(bench: TendonBench | CompiledDevice, u: Any, rate_hz: float = 20000.0, seed: int = 0) -> BenchRun:
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


def _stepped_sine_plan(omega: Any, amplitude_N: float, cycles: int, settle_cycles: int, settle_s: float,
                       rate_hz: float) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Frequencies [Hz] of a stepped sine at ``omega`` [rad/s] and, per frequency, the steps [n0, n1) measured:
    from rest, max(settle_cycles, ceil(settle_s f)) cycles to settle, then ``cycles`` whole cycles. Raises
    ValueError on a frequency not in (0, rate_hz/4), a non-positive amplitude or cycle counts out of range."""
    freqs = np.asarray(omega, dtype=float).ravel() / (2.0 * math.pi)
    if freqs.size == 0 or not np.all(np.isfinite(freqs)) or np.any(freqs <= 0) or np.any(freqs >= rate_hz / 4):
        raise ValueError("omega must be finite, > 0 and < 2π rate_hz/4")
    if not (math.isfinite(amplitude_N) and amplitude_N > 0):
        raise ValueError("amplitude_N must be > 0")
    if int(cycles) < 1 or int(settle_cycles) < 0:
        raise ValueError("cycles must be >= 1 and settle_cycles >= 0")
    windows = []
    for f in freqs:
        n_settle = max(int(settle_cycles), int(math.ceil(settle_s * f)))
        windows.append((int(round(n_settle / f * rate_hz)), int(round((n_settle + int(cycles)) / f * rate_hz))))
    return freqs, windows


def _sine_command(amplitude: float, freq_hz: float, n: int, rate_hz: float) -> np.ndarray:
    h = 1.0 / rate_hz
    return amplitude * np.sin(2.0 * math.pi * freq_hz * (np.arange(n) + 0.5) * h)


def _bench(bench) -> TendonBench:
    """The TendonBench behind a bench or its compiled form."""
    dev = compile_device(bench).device
    if not isinstance(dev, TendonBench):
        raise TypeError(f"{dev.name} is a {dev.kind} device, not a tendon bench")
    return dev


def stepped_sine(bench: TendonBench | CompiledDevice, *, omega: Sequence[float], amplitude_N: float,
                 cycles: int = 10, settle_cycles: int = 20, settle_s: float = 1.0, rate_hz: float = 20000.0,
                 seed: int = 0) -> FrequencyResponse:
    """Stepped-sine FRF of F_m/F_τ.

    Each frequency starts from rest, settles for max(settle_cycles, ceil(settle_s f)) whole cycles, then
    the first harmonic is measured by a single-bin DFT (lock-in) over ``cycles`` whole cycles of both the
    sensed force F_m and the commanded sine (same samples, same timestamps, so leakage cancels).

    Parameters
    ----------
    bench : TendonBench or CompiledDevice
    omega : sequence of float
        Test frequencies [rad/s], each > 0 and below 2π rate_hz / 4 (keyword-only).
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

    Returns
    -------
    FrequencyResponse
        ``ratio`` = F_m / F_τ [-], ``method = "stepped_sine"``; ``meta`` holds cycles, settle_s (per
        frequency), rate_hz and seed.
    """
    freqs, windows = _stepped_sine_plan(omega, amplitude_N, cycles, settle_cycles, settle_s, rate_hz)
    model = bench_model(bench, rate_hz)
    h = 1.0 / rate_hz
    ratios = np.empty(freqs.size, dtype=complex)
    settles = np.empty(freqs.size)
    for i, (f, (n0, n1)) in enumerate(zip(freqs, windows)):
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
    return FrequencyResponse(2.0 * math.pi * freqs, ratios, output="F_m", input="F_tau", unit="-",
                             method="stepped_sine", amplitude=float(amplitude_N),
                             label=f"twin, {amplitude_N:.2f} N input",
                             meta={"cycles": int(cycles), "settle_s": settles.tolist(), "rate_hz": float(rate_hz),
                                   "seed": int(seed), "amplitude_unit": "N"})


@dataclass
class PeakSearch(Result):
    """Resonance-peak search of |F_m/F_τ| at one amplitude (coarse grid, then a fine grid)."""

    amplitude_N: float
    peak_hz: float
    peak_magnitude: float
    coarse: FrequencyResponse
    fine: FrequencyResponse | None

    reading = ('A coarse stepped sine, then a fine one around its largest gain; the dotted vertical line marks the '
               'resonance found.')

    def _draw(self, ax) -> None:
        self.coarse.plot(ax)
        if self.fine is not None:
            self.fine.plot(ax)
        ax.axvline(self.peak_hz, color="0.5", lw=0.8, ls=":")

    def to_dict(self) -> dict[str, Any]:
        return {"amplitude_N": self.amplitude_N, "peak_hz": self.peak_hz, "peak_magnitude": self.peak_magnitude,
                "coarse": self.coarse.to_dict(), "fine": self.fine.to_dict() if self.fine else None}

    def table(self) -> str:
        return format_table(("input [N]", "peak [Hz]", "|F_m/F_tau| at peak"),
                            [(self.amplitude_N, self.peak_hz, self.peak_magnitude)], "resonance peak")


def resonance_peak(bench: TendonBench | CompiledDevice, amplitude_N: float, f_lo: float = 8.0, f_hi: float = 40.0,
                   step_hz: float = 1.0, refine_hz: float = 0.25, **kw: Any) -> PeakSearch:
    """Frequency [Hz] of the largest first-harmonic |F_m/F_τ| between f_lo and f_hi.

    A grid of ``step_hz`` first, then (if ``refine_hz`` > 0) a grid of ``refine_hz`` over ±step_hz around
    the coarse maximum. Extra keyword arguments go to :func:`stepped_sine`.
    """
    grid = np.arange(f_lo, f_hi + 0.5 * step_hz, step_hz)
    coarse = stepped_sine(bench, omega=2 * math.pi * grid, amplitude_N=amplitude_N, **kw)
    k = int(np.argmax(coarse.magnitude))
    best_f, best_m, fine = float(grid[k]), float(coarse.magnitude[k]), None
    if refine_hz and refine_hz > 0:
        lo = max(f_lo, best_f - step_hz)
        hi = min(f_hi, best_f + step_hz)
        fgrid = np.arange(lo, hi + 0.5 * refine_hz, refine_hz)
        fine = stepped_sine(bench, omega=2 * math.pi * fgrid, amplitude_N=amplitude_N, **kw)
        j = int(np.argmax(fine.magnitude))
        if fine.magnitude[j] >= best_m:
            best_f, best_m = float(fgrid[j]), float(fine.magnitude[j])
    return PeakSearch(float(amplitude_N), best_f, best_m, coarse, fine)


def swept_sine(bench: TendonBench | CompiledDevice, f0_hz: float = 2.0, f1_hz: float = 100.0,
               duration_s: float = 20.0, amplitude_N: float = 1.0, rate_hz: float = 20000.0, seed: int = 0,
               tail_s: float = 1.0) -> FrequencyResponse:
    """Linear chirp from f0 to f1 over ``duration_s`` then ``tail_s`` of zero command; FRF = Y(f)/U(f).

    Accurate only where the plant is linear (friction off, or large amplitudes); with friction the result
    is an amplitude-dependent average. Returns the bins strictly inside (f0, f1) as a
    :class:`FrequencyResponse` (``method = "swept_sine"``) whose ``runs[0]`` is the :class:`BenchRun`.
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
    return FrequencyResponse(2.0 * math.pi * freqs[band], Y[band] / U[band], output="F_m", input="F_tau",
                             unit="-", method="swept_sine", amplitude=float(amplitude_N),
                             label=f"swept sine, {amplitude_N:.2f} N", runs=[run],
                             meta={"f0_hz": float(f0_hz), "f1_hz": float(f1_hz), "duration_s": float(duration_s),
                                   "tail_s": float(tail_s), "rate_hz": float(rate_hz), "seed": int(seed),
                                   "amplitude_unit": "N"})


@dataclass
class LowSpeedLoop(Result):
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
    device: str = ""

    reading = ('The sensed force against the commanded force over a slow cycle: a flat stretch around zero is the '
               'dead band, the dashed diagonal a perfect transmission.')

    def _draw(self, ax) -> None:
        ax.plot(self.u, self.force, lw=1.2, label=f"{self.freq_hz:g} Hz, {self.amplitude_N:.2f} N")
        ax.plot(self.u, self.u, "k--", lw=0.8, label="F_m = F_τ")
        ax.set_xlabel("command F_τ [N]")
        ax.set_ylabel("sensed F_m [N]")
        ax.set_title(f"{self.device}: low-speed loop".lstrip(": "))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)

    def gain(self) -> float:
        """Least-squares slope of F_m against F_τ [-]."""
        return float(np.dot(self.u, self.force) / np.dot(self.u, self.u))

    def dead_band_N(self) -> float:
        """Largest |F_τ| [N] while |F_m| stays below 5 % of the amplitude (the dead-band half-width)."""
        small = np.abs(self.force) < 0.05 * self.amplitude_N
        return float(np.max(np.abs(self.u[small]))) if np.any(small) else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {"device": self.device, "time": self.time.tolist(), "u": self.u.tolist(),
                "force": self.force.tolist(), "position": self.position.tolist(), "freq_hz": self.freq_hz,
                "amplitude_N": self.amplitude_N, "gain": self.gain(), "dead_band_N": self.dead_band_N()}

    def table(self) -> str:
        return format_table(("freq [Hz]", "input [N]", "gain F_m/F_tau", "dead band [N]", "max |F_m| [N]"),
                            [(self.freq_hz, self.amplitude_N, self.gain(), self.dead_band_N(),
                              float(np.max(np.abs(self.force))))], "low-speed loop")


def low_speed_loop(bench: TendonBench | CompiledDevice, freq_hz: float = 0.2, amplitude_N: float = 0.31, cycles: int = 2,
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
                        float(amplitude_N), _bench(bench).name)


def bench_log(bench: TendonBench | CompiledDevice, run: BenchRun, experiment: str, options: dict | None = None,
              log_every: int = 1):
    """The log a bench records (tendyn.io.logs schema): command, differential tendon force and tendon
    displacement as sensed, every ``log_every`` steps. The truth (bench parameters) goes beside it."""
    bench = _bench(bench)
    sl = slice(log_every - 1, None, log_every)
    cols = {"time": run.time[sl], "force_cmd": run.u[sl], "force_tendon": run.force[sl],
            "x_tendon": run.position[sl]}
    return make_log(cols, device=bench.name, rate_hz=run.rate_hz / log_every, seed=run.seed,
                    experiment=experiment, options=options or {})


LOW_SPEED_FREQ_HZ = 0.2
"""Frequency [Hz] of the low-speed loop test (S1 Fig. 10b)."""


def bench_experiment(bench: TendonBench, experiment: str, *, amplitude_N: float, rate_hz: float = 20000.0,
                     log_rate_hz: float = 1000.0, seed: int = 0, omega: Sequence[float] | None = None,
                     cycles: int | None = None, duration_s: float | None = None, clock_hz: float | None = None,
                     progress=None) -> list:
    """One experiment of ``tendyn simulate`` on a bench: a list of (log, truth) pairs.

    ``"stepped-sine"``: ``cycles`` whole cycles of a sine of ``amplitude_N`` [N] from rest at each frequency
    of ``omega`` [rad/s], one log per frequency; ``"swept-sine"``: a linear chirp from min to max of ``omega``
    over ``duration_s`` (then 1 s of zero command); ``"low-speed-loop"``: ``cycles`` cycles at
    :data:`LOW_SPEED_FREQ_HZ`; ``"prbs"``: a maximum-length sequence ±``amplitude_N`` clocked at ``clock_hz``
    for ``duration_s`` (:func:`tendyn.sim.excitation.prbs`, register start from ``seed``), the input of
    ``tendyn identify-bench``. Logs sample every ``rate_hz / log_rate_hz`` steps (must be whole).
    """
    log_every = rate_hz / log_rate_hz
    if abs(log_every - round(log_every)) > 1e-9 * log_every or round(log_every) < 1:
        raise ValueError(f"log_rate_hz ({log_rate_hz:g}) must divide rate_hz ({rate_hz:g})")
    log_every = int(round(log_every))
    truth = bench.to_dict()

    def sine_run(f: float, name: str):
        n = int(round(cycles * rate_hz / f))
        run = simulate(bench, _sine_command(amplitude_N, f, n, rate_hz), rate_hz, seed)
        return bench_log(bench, run, name, {"freq_hz": f, "amplitude_N": amplitude_N, "cycles": cycles}, log_every)

    if experiment == "stepped-sine":
        out = []
        freqs_hz = np.asarray(omega, float) / (2.0 * math.pi)
        for k, f in enumerate(freqs_hz):
            out.append((sine_run(float(f), "stepped_sine"), truth))
            if progress:
                progress(k + 1, len(freqs_hz))
        return out
    if experiment == "swept-sine":
        f0, f1 = float(min(omega)) / (2.0 * math.pi), float(max(omega)) / (2.0 * math.pi)
        res = swept_sine(bench, f0_hz=f0, f1_hz=f1, duration_s=duration_s, amplitude_N=amplitude_N,
                         rate_hz=rate_hz, seed=seed)
        opts = {"f0_hz": f0, "f1_hz": f1, "duration_s": duration_s, "amplitude_N": amplitude_N}
        return [(bench_log(bench, res.runs[0], "swept_sine", opts, log_every), truth)]
    if experiment == "low-speed-loop":
        return [(sine_run(LOW_SPEED_FREQ_HZ, "low_speed_loop"), truth)]
    if experiment == "prbs":
        from tendyn.sim.excitation import prbs

        u = prbs(amplitude_N, duration_s, rate_hz, clock_hz=clock_hz, seed=seed)
        opts = {"amplitude_N": amplitude_N, "clock_hz": clock_hz, "duration_s": duration_s}
        return [(bench_log(bench, simulate(bench, u, rate_hz, seed), "prbs", opts, log_every), truth)]
    raise ValueError(f"unknown bench experiment {experiment!r}")


# ---- closed loop: a discrete controller inside the C++ bench loop (S1 §4) ------------------------------

@dataclass(frozen=True)
class Controller:
    """A discrete-time LTI controller C(z) for the bench loop: x⁺ = A x + B e, u = C x + D e with
    e = r − F_m (the SENSED tendon force, noise included), updated at ``control_hz`` [Hz] (must divide the
    bench step rate), command held in between, |u| ≤ ``u_limit`` [N]. Runs in C++
    (:class:`tendyn._core.BenchControllerModel`, :func:`tendyn._core.run_closed_loop`).
    """

    A: Any = ()
    B: Any = ()
    C: Any = ()
    D: float = 0.0
    control_hz: float = 20000.0
    u_limit: float = math.inf
    label: str = ""

    @classmethod
    def gain(cls, K: float, control_hz: float = 20000.0, **kw) -> "Controller":
        """A proportional controller u = K e."""
        return cls((), (), (), float(K), control_hz, label=kw.pop("label", f"K = {K:g}"), **kw)

    @classmethod
    def from_realisation(cls, real: Any, **kw) -> "Controller":
        """From an object with A, B, C, D, dt (e.g. :class:`tendyn.control.loop_shaping.DiscreteRealisation`)."""
        return cls(np.asarray(real.A, float), np.asarray(real.B, float), np.asarray(real.C, float), float(real.D),
                   1.0 / float(real.dt), **kw)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (a log's ``meta.options["controller"]``): ``A`` (rows), ``B``, ``C`` lists, ``D``,
        ``control_hz`` [Hz], ``u_limit`` [N] (None: unlimited), ``label``. :meth:`from_dict` reads it back."""
        n = len(np.ravel(self.B))
        A = np.asarray(self.A, float).reshape(n, n) if n else np.zeros((0, 0))
        return {"A": A.tolist(), "B": np.ravel(np.asarray(self.B, float)).tolist(),
                "C": np.ravel(np.asarray(self.C, float)).tolist(), "D": float(self.D),
                "control_hz": float(self.control_hz),
                "u_limit": float(self.u_limit) if math.isfinite(self.u_limit) else None, "label": self.label}

    @classmethod
    def from_dict(cls, d: dict) -> "Controller":
        """The controller of :meth:`to_dict` (bit-exact: floats survive JSON)."""
        n = len(d["B"])
        A = np.asarray(d["A"], float).reshape(n, n) if n else ()
        return cls(A, np.asarray(d["B"], float) if n else (), np.asarray(d["C"], float) if n else (), float(d["D"]),
                   float(d["control_hz"]), math.inf if d.get("u_limit") is None else float(d["u_limit"]),
                   str(d.get("label", "")))

    def core_model(self, rate_hz: float) -> "_core.BenchControllerModel":
        dec = rate_hz / self.control_hz
        if abs(dec - round(dec)) > 1e-9 * dec or round(dec) < 1:
            raise ValueError(f"control_hz ({self.control_hz:g}) must divide the step rate ({rate_hz:g})")
        cm = _core.BenchControllerModel()
        A = np.asarray(self.A, float).reshape(len(np.ravel(self.B)), -1) if np.size(self.B) else np.zeros((0, 0))
        cm.set_state_space(np.ascontiguousarray(A), np.ascontiguousarray(np.ravel(self.B), dtype=float),
                           np.ascontiguousarray(np.ravel(self.C), dtype=float), float(self.D))
        cm.decimation = int(round(dec))
        if math.isfinite(self.u_limit):
            cm.u_limit = float(self.u_limit)
        return cm


@dataclass
class ClosedLoopRun:
    """One closed-loop run, per bench step: ``reference`` r [N], ``u`` command [N], ``force`` sensed F_m [N],
    ``force_true`` F_m without noise [N], ``time`` [s] (end of each step)."""

    time: np.ndarray
    reference: np.ndarray
    u: np.ndarray
    force: np.ndarray
    force_true: np.ndarray
    rate_hz: float
    seed: int


def simulate_closed_loop(bench: TendonBench | CompiledDevice, controller: Controller | None, reference: Any,
                         rate_hz: float = 20000.0, seed: int = 0, **changes: Any) -> ClosedLoopRun:
    """Run the reference sequence (one value per step) from rest with ``controller`` in the loop (None =
    open loop, u = r). ``changes`` override bench fields (e.g. ``noise_force=0.01``)."""
    b = _bench(bench)
    if changes:
        b = b.replace(**changes)
    r = np.ascontiguousarray(np.asarray(reference, dtype=np.float64).ravel())
    if not np.all(np.isfinite(r)):
        raise ValueError("reference must be finite")
    model = bench_model(b, rate_hz)
    data = _core.TendonBenchData(model, int(seed))
    n = r.size
    time = (np.arange(n) + 1.0) / float(rate_hz)
    if controller is None:
        out = [np.empty(n) for _ in range(7)]
        _core.run(model, data, r, *out)
        return ClosedLoopRun(time, r, r.copy(), out[0], out[5] - out[6], float(rate_hz), int(seed))
    cm = controller.core_model(rate_hz)
    cd = _core.BenchControllerData(cm)
    fm, u, ft = np.empty(n), np.empty(n), np.empty(n)
    _core.run_closed_loop(model, data, cm, cd, r, fm, u, ft)
    return ClosedLoopRun(time, r, u, fm, ft, float(rate_hz), int(seed))


def loop_log(bench: TendonBench | CompiledDevice, controller: Controller | None, reference: Any, *,
             experiment: str, options: dict | None = None, rate_hz: float = 20000.0, log_every: int = 20,
             seed: int = 0, **changes: Any):
    """A closed-loop run (:func:`simulate_closed_loop`: ``reference`` [N], one value per step, from rest) as the
    log a bench records every ``log_every`` steps (tendyn.io.logs schema): ``force_ref`` r [N] (closed loop
    only), ``force_cmd`` the command u [N] and ``force_tendon`` the sensed F_m [N]; ``time`` [s] is the end of
    the logged step, r and u the values held during it. ``meta.options`` holds ``options`` and the controller
    (:meth:`Controller.to_dict`, None in open loop); ``changes`` (bench fields) belong to the truth, not the log.
    The noise-free F_m is the twin's internal truth and is not logged."""
    run = simulate_closed_loop(bench, controller, reference, rate_hz, seed, **changes)
    every = int(log_every)
    if every < 1:
        raise ValueError(f"log_every must be >= 1 (got {log_every!r})")
    sl = slice(every - 1, None, every)
    cols = {"time": run.time[sl]}
    if controller is not None:
        cols["force_ref"] = run.reference[sl]
    cols |= {"force_cmd": run.u[sl], "force_tendon": run.force[sl]}
    opts = dict(options or {})
    opts["controller"] = None if controller is None else controller.to_dict()
    return make_log(cols, device=_bench(bench).name, rate_hz=run.rate_hz / every, seed=run.seed,
                    experiment=experiment, options=opts)


def h1_estimate(x: np.ndarray, y: np.ndarray, freq_hz: float, rate_hz: float, cycles_per_segment: int = 2) -> complex:
    """H1 = S_xy/S_xx at ``freq_hz`` (scipy ``csd``/``welch``, rectangular segments of whole cycles, no
    overlap): averaged over the segments, so uncorrelated output noise averages out of S_xy."""
    from scipy import signal

    nper = int(round(cycles_per_segment * rate_hz / freq_hz))
    nper = min(nper, x.size)
    kw = dict(fs=rate_hz, window="boxcar", nperseg=nper, noverlap=0, detrend=False, scaling="spectrum")
    f, pxy = signal.csd(x, y, **kw)
    _, pxx = signal.welch(x, **kw)
    k = int(np.argmin(np.abs(f - freq_hz)))
    return complex(pxy[k] / pxx[k])


def loop_stepped_sine(bench: TendonBench | CompiledDevice, controller: Controller | None, *, omega: Sequence[float],
                      amplitude_N: float, cycles: int = 8, settle_cycles: int = 10, settle_s: float = 0.5,
                      rate_hz: float = 20000.0, seed: int = 0, estimator: str = "h1", output: str = "force",
                      **changes: Any) -> FrequencyResponse:
    """Stepped-sine FRF of F_m/r with ``controller`` in the loop (None: open loop, F_m/F_τ).

    Each frequency starts from rest and settles for max(settle_cycles, ceil(settle_s f)) cycles; the first
    harmonic over ``cycles`` whole cycles is estimated by ``estimator``: ``"h1"`` (:func:`h1_estimate`, scipy
    csd/welch) or ``"lockin"`` (single-bin DFT). The half-step offset between the reference (mid-step) and the
    outputs (end of step) is removed. ``output="u"`` gives the command response u/r instead of F_m/r.
    """
    if estimator not in ("h1", "lockin"):
        raise ValueError(f"estimator must be 'h1' or 'lockin' (got {estimator!r})")
    freqs, windows = _stepped_sine_plan(omega, amplitude_N, cycles, settle_cycles, settle_s, rate_hz)
    ratios = np.empty(freqs.size, dtype=complex)
    for i, (f, (n0, n1)) in enumerate(zip(freqs, windows)):
        r = _sine_command(amplitude_N, f, n1, rate_hz)
        run = simulate_closed_loop(bench, controller, r, rate_hz, int(seed) + i, **changes)
        y = (run.force if output == "force" else run.u)[n0:n1]
        x = run.reference[n0:n1]
        if estimator == "h1":
            h = h1_estimate(x, y, f, rate_hz)
        else:
            kernel = np.exp(-2j * math.pi * f * (np.arange(n0, n1) + 0.5) / rate_hz)
            h = np.dot(y, kernel) / np.dot(x, kernel)
        ratios[i] = h * np.exp(1j * math.pi * f / rate_hz)  # outputs sit half a step after the reference sample
    name = controller.label if controller is not None and controller.label else ("closed loop" if controller else "open loop")
    return FrequencyResponse(2.0 * math.pi * freqs, ratios, output="F_m" if output == "force" else "u",
                             input="r" if controller is not None else "F_tau", unit="-", method="stepped_sine",
                             amplitude=float(amplitude_N), label=f"{name}, {amplitude_N:.2f} N",
                             meta={"cycles": int(cycles), "rate_hz": float(rate_hz), "seed": int(seed),
                                   "estimator": estimator, "amplitude_unit": "N",
                                   "controller": None if controller is None else controller.label})


def loop_io(bench: TendonBench | CompiledDevice, controller: Controller | None, *, freq_hz: float, amplitude_N: float,
            cycles: int = 2, settle_cycles: int = 1, rate_hz: float = 20000.0, seed: int = 0, decimate: int = 20,
            **changes: Any) -> LowSpeedLoop:
    """Input/output record r → F_m of a slow sine with ``controller`` in the loop (None: open loop), as a
    :class:`LowSpeedLoop` (S1 Figs. 10b and 13): ``u`` holds the reference r, ``force`` the sensed F_m and
    ``position`` the command applied to the amplifier [N] (in closed loop it differs from r)."""
    n0 = int(round(settle_cycles / freq_hz * rate_hz))
    n1 = int(round((settle_cycles + cycles) / freq_hz * rate_hz))
    r = _sine_command(amplitude_N, freq_hz, n1, rate_hz)
    run = simulate_closed_loop(bench, controller, r, rate_hz, seed, **changes)
    sl = slice(n0, n1, max(1, int(decimate)))
    return LowSpeedLoop(run.time[sl], run.reference[sl], run.force[sl], run.u[sl], float(freq_hz), float(amplitude_N),
                        _bench(bench).name)


def loop_stepped_sine_logs(bench: TendonBench | CompiledDevice, controller: Controller | None, *,
                           omega: Sequence[float], amplitude_N: float, cycles: int = 8, settle_cycles: int = 10,
                           settle_s: float = 0.5, rate_hz: float = 20000.0, log_every: int = 20, seed: int = 0,
                           **changes: Any) -> list:
    """The runs of :func:`loop_stepped_sine` (same plan, references and seeds ``seed + i``) as the logs a bench
    records (:func:`loop_log`), one per frequency of ``omega`` [rad/s], each the whole run from rest.
    ``meta.options``: ``freq_hz`` [Hz], ``amplitude_N`` [N], ``cycles``, ``settle_s`` [s] (the measured cycles
    are the samples whose time exceeds it; :func:`tendyn.ident.frf.frf_from_logs` honours it) and the
    controller. Experiment ``"stepped_sine"`` (open loop) or ``"closed_loop_stepped_sine"``."""
    freqs, windows = _stepped_sine_plan(omega, amplitude_N, cycles, settle_cycles, settle_s, rate_hz)
    experiment = "stepped_sine" if controller is None else "closed_loop_stepped_sine"
    out = []
    for i, (f, (n0, n1)) in enumerate(zip(freqs, windows)):
        opts = {"freq_hz": float(f), "amplitude_N": float(amplitude_N), "cycles": int(cycles),
                "settle_s": n0 / float(rate_hz)}
        out.append(loop_log(bench, controller, _sine_command(amplitude_N, f, n1, rate_hz), experiment=experiment,
                            options=opts, rate_hz=rate_hz, log_every=log_every, seed=int(seed) + i, **changes))
    return out


def loop_sine_log(bench: TendonBench | CompiledDevice, controller: Controller | None, *, freq_hz: float,
                  amplitude_N: float, cycles: int = 2, settle_cycles: int = 1, rate_hz: float = 20000.0,
                  log_every: int = 20, seed: int = 0, **changes: Any):
    """The run of :func:`loop_io` (same plan, reference and seed) as the log a bench records
    (:func:`loop_log`): ``settle_cycles`` then ``cycles`` cycles of a sine of ``freq_hz`` [Hz] and
    ``amplitude_N`` [N]; ``meta.options`` as :func:`loop_stepped_sine_logs` (``settle_s`` [s]: the measured cycles
    start after it). Experiment ``"sine_loop"``; :func:`io_record` reads it back."""
    n0 = int(round(settle_cycles / freq_hz * rate_hz))
    n1 = int(round((settle_cycles + cycles) / freq_hz * rate_hz))
    opts = {"freq_hz": float(freq_hz), "amplitude_N": float(amplitude_N), "cycles": int(cycles),
            "settle_s": n0 / float(rate_hz)}
    return loop_log(bench, controller, _sine_command(amplitude_N, freq_hz, n1, rate_hz), experiment="sine_loop",
                    options=opts, rate_hz=rate_hz, log_every=log_every, seed=seed, **changes)


def io_record(log) -> LowSpeedLoop:
    """The input/output record of a sine log (:func:`loop_sine_log`, or any log with ``force_cmd``,
    ``force_tendon`` and ``meta.options`` ``freq_hz``, ``amplitude_N``): the samples after ``settle_s``, ``u`` the
    reference (``force_ref``, or ``force_cmd`` in open loop), ``force`` the sensed F_m, ``position`` the
    command [N] — the layout of :func:`loop_io`."""
    opts = log.meta.get("options") or {}
    start = int(np.searchsorted(log.time, float(opts.get("settle_s", 0.0)), side="right"))
    ref = log["force_ref"] if "force_ref" in log else log["force_cmd"]
    sl = slice(start, None)
    return LowSpeedLoop(log.time[sl], ref[sl], log["force_tendon"][sl], log["force_cmd"][sl],
                        float(opts["freq_hz"]), float(opts["amplitude_N"]), str(log.meta.get("device", "")))
