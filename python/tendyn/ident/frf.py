"""Frequency responses of a bench from its logs: H1 and H2 with Welch averaging, coherence, confidence bands.

For an input u and an output y sampled at ``rate_hz`` (Bendat & Piersol, *Random Data*, ch. 9)::

    H1 = S_uy / S_uu      (unbiased by output noise)
    H2 = S_yy / S_yu      (unbiased by input noise)
    γ² = |S_uy|² / (S_uu S_yy) = H1 / H2

with the cross and auto spectra averaged over n_d Welch segments (scipy ``csd`` / ``welch``: window,
segment length, overlap). The normalised random error of |Ĥ| is ε = √(1 − γ²) / (|γ| √(2 n_d)); the
confidence band is |Ĥ|(1 ± z ε) and the phase ± z ε rad, z the normal quantile of the confidence level
(n_d counts the segments: with overlapping windows the segments are not independent and the band is
somewhat optimistic).

Excitations: broadband (PRBS, chirp, multisine, noise; every bin where the input has power), and stepped
sines (one log per frequency: the estimate at the tone only, over segments of whole cycles with a
rectangular window, so there is no leakage). :func:`frf_from_logs` picks the route per log.

Outputs: :class:`MeasuredFRF` (a :class:`tendyn.results.Result`: magnitude with its band, phase and
coherence with units; ``to_frd()`` gives a python-control ``FrequencyResponseData``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.results import Result, format_table

__all__ = ["ESTIMATORS", "MeasuredFRF", "Spectra", "frf_from_logs", "spectra", "tone_frequency", "tone_spectra"]

ESTIMATORS = ("h1", "h2")
EXCITED = 1e-6
"""A broadband bin is kept when its input power is above this fraction of the largest bin's [-]."""
TONE_POWER = 0.9
"""A log is a single tone (a stepped sine) when the 5 bins around its periodogram peak hold this share of the
input power [-] (after the mean is removed)."""


@dataclass
class Spectra:
    """Welch-averaged spectra on a grid: ``freq_hz`` [Hz], ``uu``, ``yy`` (real), ``uy`` (complex, conj(U) Y),
    ``n_avg`` segments averaged per bin (a sum of spectra of several logs weights each by its segments)."""

    freq_hz: np.ndarray
    uu: np.ndarray
    yy: np.ndarray
    uy: np.ndarray
    n_avg: np.ndarray

    def __add__(self, other: "Spectra") -> "Spectra":
        f = np.concatenate([self.freq_hz, other.freq_hz])
        parts = [np.concatenate([getattr(self, k), getattr(other, k)]) for k in ("uu", "yy", "uy", "n_avg")]
        order = np.argsort(f, kind="stable")
        return Spectra(f[order], *(p[order] for p in parts))


def _check(u, y, rate_hz):
    u = np.asarray(u, float).ravel()
    y = np.asarray(y, float).ravel()
    if u.shape != y.shape:
        raise ValueError(f"input and output differ in length ({u.size} vs {y.size})")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be > 0 (got {rate_hz!r})")
    return u, y


def spectra(u, y, rate_hz: float, *, nperseg: int | None = None, window: str = "hann", overlap: float = 0.5,
            detrend: str | bool = "constant") -> Spectra:
    """Welch spectra of a broadband record: segments of ``nperseg`` samples (default: the record split in 8),
    ``window`` (any scipy window name), ``overlap`` fraction [0, 1). Only excited bins (input power above
    :data:`EXCITED` × max, DC excluded) are returned."""
    from scipy import signal

    u, y = _check(u, y, rate_hz)
    if nperseg is None:
        nperseg = max(16, u.size // 8)
    nperseg = int(min(nperseg, u.size))
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be in [0, 1) (got {overlap!r})")
    noverlap = int(round(overlap * nperseg))
    kw = dict(fs=rate_hz, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)
    f, uy = signal.csd(u, y, **kw)
    _, uu = signal.welch(u, **kw)
    _, yy = signal.welch(y, **kw)
    n_seg = 1 + (u.size - nperseg) // (nperseg - noverlap)
    keep = (f > 0) & (uu > EXCITED * uu.max()) if uu.max() > 0 else np.zeros(f.size, bool)
    return Spectra(f[keep], uu[keep], yy[keep], uy[keep], np.full(int(keep.sum()), float(n_seg)))


def tone_frequency(u, rate_hz: float) -> float | None:
    """The frequency [Hz] of a single-tone input (a stepped sine), or None when the input is not one tone.

    The peak of the 8× zero-padded, Hann-windowed periodogram, refined by a parabola through the log power of
    its two neighbours."""
    u = np.asarray(u, float) - np.mean(u)
    if u.size < 16 or not np.any(u):
        return None
    n = 8 * u.size
    P = np.abs(np.fft.rfft(u * np.hanning(u.size), n)) ** 2
    k = int(np.argmax(P[1:])) + 1
    if P[max(1, k - 20):k + 21].sum() < TONE_POWER * P[1:].sum():
        return None
    a, b, c = np.log(P[k - 1:k + 2] + 1e-300) if 1 < k < P.size - 1 else (0.0, 0.0, 0.0)
    shift = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0
    return float((k + shift) * rate_hz / n)


def tone_spectra(u, y, rate_hz: float, freq_hz: float, *, cycles_per_segment: int = 2,
                 skip: float = 0.5, start: int | None = None) -> Spectra:
    """Spectra at one tone ``freq_hz`` [Hz] (a stepped-sine log): the samples before ``start`` (default: the
    first ``skip`` fraction of the record, the transient from rest) are dropped, the rest cut into segments of
    ``cycles_per_segment`` cycles (as many as fit, sharing the samples evenly), no overlap, and the phasors of
    each segment averaged (as ``csd``/``welch`` do: S_uu = ⟨|U|²⟩, S_yy = ⟨|Y|²⟩, S_uy = ⟨conj(U) Y⟩).

    The phasor of a segment of N samples is the three-parameter least-squares sine fit x ≈ a cos ωt + b sin ωt
    + c (IEEE Std 1057), scaled as a DFT bin: X = (N/2)(a − j b). On whole cycles it equals the single-bin DFT
    with a rectangular window; unlike it, it stays exact when the rate is not a multiple of the tone (a segment
    of 2 cycles of 6 Hz at 1 kHz holds 333.3 samples), where the DFT bin leaks the tone's negative-frequency
    image into the estimate."""
    u, y = _check(u, y, rate_hz)
    if start is None:
        start = int(round(skip * u.size))
    start = int(start)
    if not 0 <= start < u.size:
        raise ValueError(f"start must be in [0, {u.size}) (got {start})")
    per = cycles_per_segment * rate_hz / freq_hz
    span = u.size - start
    n_seg = int((span + 1) // per)                    # a record one sample short of whole segments keeps them
    if n_seg < 1:
        raise ValueError(f"the record holds less than {cycles_per_segment} cycles of {freq_hz:g} Hz after its "
                         f"first {start} samples")
    w = 2 * math.pi * freq_hz / rate_hz
    uu = yy = 0.0
    uy = 0.0j
    for s in range(n_seg):
        a = start + int(round(s * span / n_seg))          # the segments share the measured samples evenly
        b = start + int(round((s + 1) * span / n_seg))
        k = np.arange(b - a)
        basis = np.column_stack([np.cos(w * k), np.sin(w * k), np.ones(k.size)])
        coef = np.linalg.lstsq(basis, np.column_stack([u[a:b], y[a:b]]), rcond=None)[0]
        U, Y = 0.5 * (b - a) * (coef[0] - 1j * coef[1])
        uu += abs(U) ** 2
        yy += abs(Y) ** 2
        uy += np.conj(U) * Y
    return Spectra(np.array([freq_hz]), np.array([uu / n_seg]), np.array([yy / n_seg]), np.array([uy / n_seg]),
                   np.array([float(n_seg)]))


@dataclass(eq=False)
class MeasuredFRF(Result):
    """A frequency response estimated from logs: H1, H2, coherence and the confidence band of the chosen one.

    Attributes
    ----------
    freq_hz : ndarray
        Grid [Hz] (the excited bins, or the tones of stepped sines).
    h1, h2 : ndarray of complex
        S_uy/S_uu and S_yy/S_yu [output unit / input unit].
    coherence : ndarray
        γ² [-] in [0, 1].
    n_avg : ndarray
        Segments averaged per frequency.
    estimator : {"h1", "h2"}
        Which one :attr:`ratio`, the band and :meth:`to_frd` use.
    input, output : str
        Signal names; ``input_unit``, ``output_unit`` their units.
    confidence : float
        Level of the band (0.95).
    meta : dict
        How it was obtained (window, segment length, overlap, excitation per log, logs).
    """

    freq_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    n_avg: np.ndarray
    estimator: str = "h1"
    input: str = "input"
    output: str = "output"
    input_unit: str = "-"
    output_unit: str = "-"
    confidence: float = 0.95
    meta: dict = field(default_factory=dict)

    _panels = 3
    _figsize = (4.6, 3.6)

    @classmethod
    def from_spectra(cls, sp: Spectra, **kw) -> "MeasuredFRF":
        with np.errstate(divide="ignore", invalid="ignore"):
            h1 = sp.uy / sp.uu
            h2 = sp.yy / np.conj(sp.uy)
            coh = np.clip(np.abs(sp.uy) ** 2 / (sp.uu * sp.yy), 0.0, 1.0)
        return cls(sp.freq_hz, h1, h2, np.nan_to_num(coh), sp.n_avg, **kw)

    @property
    def omega(self) -> np.ndarray:
        """Grid [rad/s]."""
        return 2 * math.pi * self.freq_hz

    @property
    def ratio(self) -> np.ndarray:
        """The chosen estimate (H1 or H2)."""
        return self.h1 if self.estimator == "h1" else self.h2

    @property
    def unit(self) -> str:
        return "-" if self.input_unit == self.output_unit else f"{self.output_unit}/{self.input_unit}"

    def random_error(self) -> np.ndarray:
        """ε = √(1 − γ²)/(|γ| √(2 n_d)) [-], the normalised random error of |Ĥ| (inf where γ² = 0)."""
        g2 = self.coherence
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(g2 > 0, np.sqrt(1.0 - g2) / np.sqrt(g2 * 2.0 * self.n_avg), np.inf)

    def band(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(|H| low, |H| high, phase half-width [deg]) of the confidence band."""
        from scipy.stats import norm

        z = float(norm.ppf(0.5 + 0.5 * self.confidence))
        e = z * self.random_error()
        mag = np.abs(self.ratio)
        unknown = ~np.isfinite(e)                        # γ² = 0: the data say nothing about |H| there
        low = np.where(unknown, 0.0, mag * np.maximum(1.0 - e, 0.0))
        high = np.where(unknown, np.inf, mag * (1.0 + np.where(unknown, 0.0, e)))
        return low, high, np.degrees(np.minimum(e, math.pi))

    def to_frd(self):
        """The chosen estimate as a python-control ``FrequencyResponseData`` on ω [rad/s]."""
        import control

        return control.frd(self.ratio, self.omega)

    reading = ('Gain (with its confidence band), phase and coherence of the measured frequency response against '
               'frequency; read the gain only where the coherence is close to 1.')

    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        lo, hi, dph = self.band()
        style = "o" if self.freq_hz.size < 80 else "-"
        mag = np.abs(self.ratio)
        axes[0].semilogx(self.freq_hz, mag, style, ms=3, lw=1.0, label=self.estimator.upper())
        axes[0].fill_between(self.freq_hz, lo, np.where(np.isfinite(hi), hi, np.nan), alpha=0.25, lw=0,
                             label=f"{self.confidence:.0%} band")
        if np.all(mag > 0):
            axes[0].set_yscale("log")
        axes[0].set_ylabel(f"|{self.output}/{self.input}| [{self.unit}]")
        axes[0].legend(fontsize=7)
        if len(axes) > 1:
            ph = np.degrees(np.unwrap(np.angle(self.ratio)))
            axes[1].semilogx(self.freq_hz, ph, style, ms=3, lw=1.0)
            axes[1].fill_between(self.freq_hz, ph - dph, ph + dph, alpha=0.25, lw=0)
            axes[1].set_ylabel("phase [deg]")
        if len(axes) > 2:
            axes[2].semilogx(self.freq_hz, self.coherence, style, ms=3, lw=1.0)
            axes[2].set_ylim(0, 1.05)
            axes[2].set_ylabel("coherence γ² [-]")
        from matplotlib.ticker import NullFormatter, ScalarFormatter

        for a in axes[:3]:
            a.set_xlabel("frequency [Hz]")
            a.grid(alpha=0.3, which="both")
            a.xaxis.set_major_formatter(ScalarFormatter())
            a.xaxis.set_minor_formatter(NullFormatter())      # no labels on every minor decade tick

    def to_dict(self) -> dict:
        lo, hi, dph = self.band()
        fl = lambda x: [float(v) if math.isfinite(v) else None for v in np.asarray(x, float)]  # noqa: E731
        return {"input": self.input, "output": self.output, "input_unit": self.input_unit,
                "output_unit": self.output_unit, "unit": self.unit, "estimator": self.estimator,
                "confidence": self.confidence, "freq_hz": fl(self.freq_hz),
                "magnitude": fl(np.abs(self.ratio)), "phase_deg": fl(np.degrees(np.angle(self.ratio))),
                "h1_re": fl(self.h1.real), "h1_im": fl(self.h1.imag), "h2_re": fl(self.h2.real),
                "h2_im": fl(self.h2.imag), "coherence": fl(self.coherence), "n_avg": fl(self.n_avg),
                "magnitude_low": fl(lo), "magnitude_high": fl(hi), "phase_band_deg": fl(dph),
                "meta": self.meta}

    def table(self, max_rows: int = 30) -> str:
        step = max(1, math.ceil(self.freq_hz.size / max_rows))
        lo, hi, _ = self.band()
        rows = list(zip(self.freq_hz, np.abs(self.ratio), np.degrees(np.angle(self.ratio)), self.coherence,
                        lo, hi))[::step]
        return format_table(("freq [Hz]", f"|H| [{self.unit}]", "phase [deg]", "γ²",
                             f"{self.confidence:.0%} low", "high"), rows,
                            f"{self.output}/{self.input} ({self.estimator.upper()}, {self.freq_hz.size} bins)")


def frf_from_logs(logs, input: str, output: str, *, estimator: str = "h1", nperseg: int | None = None,
                  window: str = "hann", overlap: float = 0.5, confidence: float = 0.95, band_hz=None,
                  cycles_per_segment: int = 2, skip: float = 0.5) -> MeasuredFRF:
    """H1/H2 of ``output`` over ``input`` (column names or the names of ``meta.signals``) from one or more logs.

    A log whose input is one tone (:func:`tone_frequency`; a stepped sine) gives the estimate at that tone
    (:func:`tone_spectra`) after its settling: ``meta.options["settle_s"]`` [s] when the log says it (samples
    whose ``time`` exceeds it are measured), else the first ``skip`` fraction; any other log (PRBS, chirp, multisine, noise) every excited Welch bin
    (:func:`spectra`). The spectra of all logs are pooled (bins of the same frequency stay separate points).
    ``band_hz`` = (lo, hi) keeps that band only. All logs must have the same units for the two signals."""
    from tendyn.io import Log, read_log

    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS} (got {estimator!r})")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1) (got {confidence!r})")
    logs = [lg if isinstance(lg, Log) else read_log(lg) for lg in (logs if isinstance(logs, (list, tuple)) else [logs])]
    total, kinds, units = None, [], None
    for lg in logs:
        stops = (lg.meta.get("options") or {}).get("end_stops")
        if stops:          # a twin's log that sat on an end stop: the stop's response, coherent and wrong
            raise ValueError(f"{lg.meta.get('experiment', 'log')}: the arm met its end stop(s) at joint(s) "
                             f"{stops.get('joints')} for {stops.get('contact_s', 0):.3g} s (meta.options.end_stops): "
                             "its response is the stop's, not the device's")
        ci, co = lg.resolve(input), lg.resolve(output)
        u_units = (lg.units[ci], lg.units[co])
        if units is not None and u_units != units:
            raise ValueError(f"the logs disagree on the units of {input}/{output}: {units} vs {u_units}")
        units = u_units
        rate = float(lg.meta["rate_hz"])
        u, y = lg[ci], lg[co]
        f0 = tone_frequency(u, rate)
        given = (lg.meta.get("options") or {}).get("freq_hz")
        if f0 is not None and isinstance(given, (int, float)) and abs(given - f0) < 0.05 * given:
            f0 = float(given)                          # the planned tone, when the log says it
        settle = (lg.meta.get("options") or {}).get("settle_s")
        start = None
        if isinstance(settle, (int, float)) and not isinstance(settle, bool):
            start = int(np.searchsorted(lg.time, float(settle), side="right"))   # the planned settling, not skip
        if f0 is not None:
            sp = tone_spectra(u, y, rate, f0, cycles_per_segment=cycles_per_segment, skip=skip, start=start)
            kinds.append("stepped_sine")
        else:
            sp = spectra(u, y, rate, nperseg=nperseg, window=window, overlap=overlap)
            kinds.append("broadband")
        total = sp if total is None else total + sp
    if band_hz is not None:
        keep = (total.freq_hz >= band_hz[0]) & (total.freq_hz <= band_hz[1])
        total = Spectra(*(getattr(total, k)[keep] for k in ("freq_hz", "uu", "yy", "uy", "n_avg")))
    if total.freq_hz.size == 0:
        raise ValueError("no excited frequency in the logs (inside the band)")
    excitation = kinds[0] if len(set(kinds)) == 1 else "mixed"
    meta = {"excitation": excitation, "window": window if "broadband" in kinds else "boxcar",
            "nperseg": nperseg, "overlap": overlap, "cycles_per_segment": cycles_per_segment,
            "skip": skip, "logs": len(logs), "excitation_per_log": kinds}
    return MeasuredFRF.from_spectra(total, estimator=estimator, input=input, output=output, input_unit=units[0],
                                    output_unit=units[1], confidence=confidence, meta=meta)
