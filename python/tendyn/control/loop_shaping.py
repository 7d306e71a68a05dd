"""S1 controllers: gain and lead loops (C19, C20), Ĝ_L identification (C24), loop shaping C = L/P̂ and
robust performance (C25–C27), discretisation for the C++ bench loop.

All continuous-time objects are python-control ``TransferFunction``; frequency grids are ``omega`` [rad/s].

Loop conventions (ERRATA S1 eq. 7): unity negative feedback on the sensed tendon force, controller C in the
forward path, loop L = C G, T = L/(1 + L), S = S_G^T = 1/(1 + L) = D/(D + K N) for C = K.

Loop shaping (S1 eq. 10, corrected: ERRATA): L(s) = ω_n²/(s² + 2ζω_n s + ω_n²), ω_n = 2π·40 rad/s, ζ = 0.5;
L(0) = 1 so T(0) = 0.5: closed-loop responses are reported normalised by T(0).

Robust-performance weights (documented choice, :func:`default_weights`):

* W1(s) = 0.6 / (s/(2π·30) + 1): nominal performance, |S| ≤ 1/|W1| — the error may be up to 1/0.6 of the
  reference at DC (S(0) = 0.5 with L(0) = 1) and the demand is relaxed above 30 Hz;
* W2(s) = 0.15 (s/(2π·12) + 1)/(s/(2π·600) + 1): multiplicative uncertainty of P̂ — 15 % at DC (amplitude-
  dependent friction inside the loop), growing above 12 Hz (the resonance moves 15 → 30 Hz with amplitude,
  unmodelled load and amplifier dynamics) to ≈ 1 at 80 Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..results import Result, format_table

__all__ = ["LOOP_OMEGA_N", "LOOP_ZETA", "DiscreteRealisation", "PlantFit", "RobustPerformance", "closed_loop",
           "default_weights", "discretise", "fit_plant_frf", "freqresp", "lead_compensator",
           "loop_shaping_controller", "robust_performance", "sensitivity_gain", "target_loop"]

LOOP_OMEGA_N = 2 * math.pi * 40.0
"""ω_n of S1 eq. (10) [rad/s] ("40 Hz" means 2π·40 rad/s, ERRATA)."""
LOOP_ZETA = 0.5


def _ct():
    import control

    return control


def freqresp(sys, *, omega) -> np.ndarray:
    """Complex response of a SISO python-control system on ``omega`` [rad/s]."""
    w = np.asarray(omega, float)
    return np.asarray(sys(1j * w), complex).reshape(w.shape)


def closed_loop(G, C) -> tuple[Any, Any]:
    """(T, S) of unity negative feedback with C in the forward path: T = CG/(1 + CG), S = 1/(1 + CG),
    both ``minreal``-ed (python-control does not cancel common factors by itself)."""
    ct = _ct()
    L = C * G
    T = ct.minreal(ct.feedback(L, 1), verbose=False)
    S = ct.minreal(ct.feedback(ct.tf([1], [1]), L), verbose=False)
    return T, S


def sensitivity_gain(G, K: float):
    """S_G^T = D/(D + K N) for a pure gain K (S1 eq. 7, corrected: ERRATA): a TransferFunction built from
    the numerator and denominator polynomials of G (not through feedback())."""
    ct = _ct()
    num = np.atleast_1d(np.squeeze(G.num[0][0]))
    den = np.atleast_1d(np.squeeze(G.den[0][0]))
    return ct.tf(den, np.polyadd(den, K * num))


def lead_compensator(K: float, zero: float, pole: float):
    """C(s) = K (s + z)/(s + p) [rad/s for z, p] (S1 eq. 8)."""
    return _ct().tf([K, K * zero], [1.0, pole])


def target_loop(omega_n: float = LOOP_OMEGA_N, zeta: float = LOOP_ZETA):
    """L(s) = ω_n²/(s² + 2ζω_n s + ω_n²) of S1 eq. (10), ω_n [rad/s]."""
    return _ct().tf([omega_n**2], [1.0, 2 * zeta * omega_n, omega_n**2])


def default_weights():
    """(W1, W2) of the module docstring."""
    ct = _ct()
    W1 = ct.tf([0.6], [1 / (2 * math.pi * 30.0), 1.0])
    W2 = ct.tf([0.15 / (2 * math.pi * 12.0), 0.15], [1 / (2 * math.pi * 600.0), 1.0])
    return W1, W2


# ---- Ĝ_L: a low-order model fitted to a measured complex FRF (C24) -------------------------------------

@dataclass(eq=False)
class PlantFit(Result):
    """P̂(s) = g/(a s² + b s + 1) fitted to a complex FRF (linear least squares on g − H (a s² + b s) = H,
    re-weighted by 1/|a s² + b s + 1| of the previous pass, Sanathanan–Koerner iterations).

    ``gain`` [-], ``freq_hz`` natural frequency, ``zeta`` damping ratio; ``omega``, ``measured`` the data.
    """

    gain: float
    a: float
    b: float
    omega: np.ndarray
    measured: np.ndarray
    amplitude_N: float | None = None

    @property
    def omega_n(self) -> float:
        return 1.0 / math.sqrt(self.a)

    @property
    def freq_hz(self) -> float:
        return self.omega_n / (2 * math.pi)

    @property
    def zeta(self) -> float:
        return 0.5 * self.b * self.omega_n

    def tf(self):
        return _ct().tf([self.gain], [self.a, self.b, 1.0])

    def response(self, *, omega) -> np.ndarray:
        s = 1j * np.asarray(omega, float)
        return self.gain / (self.a * s * s + self.b * s + 1.0)

    def rel_error(self) -> float:
        """max |P̂ − H|/|H| over the fitted points."""
        return float(np.max(np.abs(self.response(omega=self.omega) - self.measured) / np.abs(self.measured)))

    reading = ("Dots: the measured gain of the twin's stepped sine; line: the fitted second-order plant P̂ whose "
               'resonance and damping the legend gives.')

    def _draw(self, ax) -> None:
        f = self.omega / (2 * math.pi)
        ax.semilogy(f, np.abs(self.measured), "o", ms=3, label="measured (twin)")
        ax.semilogy(f, np.abs(self.response(omega=self.omega)), "k-", label=f"P̂: {self.freq_hz:.1f} Hz, ζ={self.zeta:.3f}")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("|F_m / F_τ| [-]")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3, which="both")

    def to_dict(self) -> dict:
        return {"gain": self.gain, "a": self.a, "b": self.b, "freq_hz": self.freq_hz, "zeta": self.zeta,
                "amplitude_N": self.amplitude_N, "rel_error": self.rel_error()}

    def table(self) -> str:
        return format_table(("gain", "f_n [Hz]", "zeta", "max rel. error"),
                            [(self.gain, self.freq_hz, self.zeta, self.rel_error())], "identified Ĝ_L (S1 §4.4)")


def fit_plant_frf(omega, ratio, amplitude_N: float | None = None, iterations: int = 5) -> PlantFit:
    """Fit P̂ = g/(a s² + b s + 1) to the complex FRF ``ratio`` on ``omega`` [rad/s]."""
    w = np.asarray(omega, float)
    h = np.asarray(ratio, complex)
    s = 1j * w
    weight = np.ones_like(w)
    g = a = b = None
    for _ in range(max(1, iterations)):
        # g − a H s² − b H s = H
        M = np.column_stack([np.ones_like(s), -h * s * s, -h * s]) * weight[:, None]
        rhs = h * weight
        A = np.vstack([M.real, M.imag])
        y = np.concatenate([rhs.real, rhs.imag])
        g, a, b = np.linalg.lstsq(A, y, rcond=None)[0]
        weight = 1.0 / np.abs(a * s * s + b * s + 1.0)
    return PlantFit(float(g), float(a), float(b), w, h, amplitude_N)


# ---- C = L/P̂ made proper, discretised ------------------------------------------------------------------

def loop_shaping_controller(P_hat, L=None, *, extra_pole_hz: float = 500.0):
    """C(s) = L(s)/P̂(s) (S1 §4.4), made strictly proper by first-order poles at ``extra_pole_hz`` [Hz]
    (as many as needed for relative degree ≥ 1; unit DC gain, so T(0) is unchanged)."""
    ct = _ct()
    L = target_loop() if L is None else L
    C = ct.minreal(L / P_hat, verbose=False)
    num = np.trim_zeros(np.atleast_1d(np.squeeze(C.num[0][0])), "f")
    den = np.trim_zeros(np.atleast_1d(np.squeeze(C.den[0][0])), "f")
    deficit = (num.size - 1) - (den.size - 1) + 1   # extra poles for relative degree 1
    tau = 1.0 / (2 * math.pi * extra_pole_hz)
    for _ in range(max(0, deficit)):
        C = C * ct.tf([1.0], [tau, 1.0])
    return C


@dataclass(frozen=True)
class DiscreteRealisation:
    """x⁺ = A x + B e, u = C x + D e at ``dt`` [s] (for :class:`tendyn.sim.tendon_bench.Controller`)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: float
    dt: float


def discretise(C, dt: float, method: str = "tustin") -> DiscreteRealisation:
    """Discretise a continuous SISO controller at ``dt`` [s] (Tustin by default) and realise it in
    state space (balanced-free controllable form of scipy, then a diagonal similarity to equalise norms)."""
    from scipy import signal

    ct = _ct()
    Cd = ct.sample_system(C, dt, method=method)
    num = np.atleast_1d(np.squeeze(Cd.num[0][0]))
    den = np.atleast_1d(np.squeeze(Cd.den[0][0]))
    A, B, Cm, D = signal.tf2ss(num, den)
    return DiscreteRealisation(np.asarray(A, float), np.asarray(B, float).ravel(), np.asarray(Cm, float).ravel(),
                               float(np.squeeze(D)), float(dt))


# ---- robust performance (C25, C27) ---------------------------------------------------------------------

@dataclass(eq=False)
class RobustPerformance(Result):
    """‖ |W1 S| + |W2 T| ‖∞ on a dense grid (S1 eq. 9): ``value`` (< 1: robust performance holds) at
    ``peak_hz``; the curves on ``omega`` [rad/s]."""

    omega: np.ndarray
    S: np.ndarray
    T: np.ndarray
    W1: np.ndarray
    W2: np.ndarray
    label: str = ""

    @property
    def curve(self) -> np.ndarray:
        return np.abs(self.W1 * self.S) + np.abs(self.W2 * self.T)

    @property
    def value(self) -> float:
        return float(np.max(self.curve))

    @property
    def peak_hz(self) -> float:
        return float(self.omega[int(np.argmax(self.curve))] / (2 * math.pi))

    reading = ('The black curve must stay below 1 (grey line) at every frequency for robust performance; the dashed '
               'curves are the sensitivity |S| and complementary sensitivity |T|.')

    def _draw(self, ax) -> None:
        f = self.omega / (2 * math.pi)
        ax.loglog(f, self.curve, "k-", label=f"|W1 S| + |W2 T| ({self.label}), max {self.value:.3f}")
        ax.loglog(f, np.abs(self.S), "b--", lw=0.8, label="|S|")
        ax.loglog(f, np.abs(self.T), "r--", lw=0.8, label="|T|")
        ax.axhline(1.0, color="0.5", lw=0.8)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("gain [-]")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, which="both")

    def to_dict(self) -> dict:
        return {"label": self.label, "value": self.value, "peak_hz": self.peak_hz,
                "freq_hz": (self.omega / (2 * math.pi)).tolist(), "curve": self.curve.tolist()}

    def table(self) -> str:
        return format_table(("loop", "|| |W1 S| + |W2 T| ||_inf", "at [Hz]"), [(self.label, self.value, self.peak_hz)],
                            "robust performance (S1 eq. 9, C25)")


def robust_performance(L, *, omega=None, weights=None, label: str = "") -> RobustPerformance:
    """Evaluate S1 eq. (9) for the loop L (TransferFunction) on ``omega`` [rad/s] (default 0.01 Hz…10 kHz,
    20 000 log-spaced points)."""
    omega = 2 * math.pi * np.logspace(-2, 4, 20000) if omega is None else np.asarray(omega, float)
    W1, W2 = default_weights() if weights is None else weights
    l = freqresp(L, omega=omega)
    S = 1.0 / (1.0 + l)
    T = l * S
    return RobustPerformance(omega, S, T, freqresp(W1, omega=omega), freqresp(W2, omega=omega), label)
