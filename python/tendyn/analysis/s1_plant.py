"""S1 plant objects and parameter sensitivities (McGill tendon drive, C15–C18).

The plant is the two-mass chain of ERRATA S1 (eq. 2 is right): rim mass m1 = r² I_M with damper r² B driven
by F_τ, spring k_e = k1 k2/(k1 + k2) (eq. 1) to the load I_c, the load grounded by k_z, sensed force
F_m = k_e (x1 − x2). :class:`TendonDrivePlant` returns python-control ``TransferFunction`` (from the sympy
derivation of :mod:`tendyn.analysis.tendon_drive`) and ``StateSpace`` (written from the equations of motion)
objects; a test shows they are the same system.

Sensitivities S_α^G = (α/G) ∂G/∂α for α ∈ {r, k1, k2, B, k_z, I_M, I_c}, two independent routes:

* :func:`symbolic_sensitivities`: closed forms from sympy (G written in the seven parameters, differentiated,
  cancelled). S_k1 and S_kz are the corrected eqs. 4 and 6 (S1 eq. 4, corrected: ERRATA; S1 eq. 6,
  corrected: ERRATA); S_B is eq. 5 as printed.
* :func:`sensitivity`: numbers from the factored form G = k_e Q / (P (Q + k_e) + k_e Q), P = m1 s² + c1 s,
  Q = I_c s² + k_z, with the logarithmic derivatives written by hand and the chain rule through
  m1 = r² I_M, c1 = r² B, k_e(k1, k2); vectorised over any design grid × frequency grid by numpy
  broadcasting (parameters of shape (...), ``omega`` of shape (F,) → sensitivities of shape (..., F)).

Units: r [-]; I_M [kg] and B [N·s/m] are the motor-side values that the ratio scales to the rim
(m1 = r² I_M, c1 = r² B); k1, k2, k_z [N/m]; I_c [kg]. Frequencies: ``omega`` [rad/s].
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, replace
from typing import Any, Mapping

import numpy as np
import sympy as sp

from ..results import Result, format_table
from .tendon_drive import derive_plant

__all__ = ["PARAMETERS", "PlantParams", "TendonDrivePlant", "SensitivityStudy", "RatioTradeoff",
           "sensitivity", "sensitivity_symbolic", "symbolic_sensitivities", "sensitivity_study", "ratio_tradeoff"]

PARAMETERS = ("r", "k1", "k2", "B", "k_z", "I_M", "I_c")
"""The seven parameters of the sensitivity study, in the order of S1 §3."""


@dataclass(frozen=True)
class PlantParams:
    """Physical parameters of one tendon channel (S1 Fig. 2), SI.

    r [-] pulley ratio; I_M [kg] motor inertia before the ratio (rim mass r² I_M); B [N·s/m] motor damping
    before the ratio (rim damping r² B); k1, k2 [N/m] proximal / distal stiffness; I_c [kg] load inertia;
    k_z [N/m] load stiffness (``inf`` = the stiff-load limit).
    """

    r: float = 15.0
    I_M: float = 0.575 / 225.0
    B: float = 10.8 / 225.0
    k1: float = 2.566e4
    k2: float = 1.0e5
    I_c: float = 0.05
    k_z: float = 1.0e9

    @classmethod
    def from_bench(cls, bench: Any) -> "PlantParams":
        """From a :class:`tendyn.device.TendonBench` (its rim values divided by r²)."""
        r = float(bench.ratio)
        return cls(r=r, I_M=bench.mass_motor / r**2, B=bench.damping_motor / r**2, k1=bench.k1, k2=bench.k2,
                   I_c=bench.mass_load, k_z=bench.k_z)

    @property
    def k_e(self) -> float:
        return self.k1 * self.k2 / (self.k1 + self.k2)

    @property
    def m1(self) -> float:
        """Rim mass r² I_M [kg]."""
        return self.r**2 * self.I_M

    @property
    def c1(self) -> float:
        """Rim damping r² B [N·s/m]."""
        return self.r**2 * self.B

    def replace(self, **kw) -> "PlantParams":
        return replace(self, **kw)

    def to_dict(self) -> dict:
        return asdict(self)


def _params(p: Any) -> PlantParams:
    if isinstance(p, PlantParams):
        return p
    if isinstance(p, Mapping):
        return PlantParams(**p)
    if hasattr(p, "mass_motor"):
        return PlantParams.from_bench(p)
    raise TypeError("plant parameters must be PlantParams, a mapping of its fields, or a TendonBench")


class TendonDrivePlant:
    """The parametric two-mass chain G(s) = F_m/F_τ (S1 eq. 2) as python-control objects.

    Parameters
    ----------
    params : PlantParams, mapping or TendonBench
    """

    def __init__(self, params: Any = None):
        self.params = _params(PlantParams() if params is None else params)

    def num_den(self) -> tuple[np.ndarray, np.ndarray]:
        """Coefficients (highest power first) of the sympy derivation at the parameters."""
        p = self.params
        if math.isinf(p.k_z):
            return (np.array([p.k_e]), np.array([p.m1, p.c1, p.k_e]))
        num_f, den_f = _coeff_functions()
        args = (p.r, p.I_M, p.B, p.k_e, p.I_c, p.k_z)
        return np.array(num_f(*args), float), np.array(den_f(*args), float)

    def tf(self):
        """``control.TransferFunction`` G(s) = F_m/F_τ [-]."""
        import control

        num, den = self.num_den()
        return control.tf(num, den)

    def ss(self):
        """``control.StateSpace`` from the equations of motion, state (x1, ẋ1, x2, ẋ2), input F_τ, output F_m.

        r² I_M ẍ1 = F_τ − r² B ẋ1 − k_e (x1 − x2);  I_c ẍ2 = k_e (x1 − x2) − k_z x2;  F_m = k_e (x1 − x2).
        In the stiff-load limit (k_z = inf) the load is fixed: state (x1, ẋ1).
        """
        import control

        p = self.params
        m1, c1, ke = p.m1, p.c1, p.k_e
        if math.isinf(p.k_z):
            A = [[0.0, 1.0], [-ke / m1, -c1 / m1]]
            return control.ss(A, [[0.0], [1.0 / m1]], [[ke, 0.0]], [[0.0]])
        A = [[0.0, 1.0, 0.0, 0.0],
             [-ke / m1, -c1 / m1, ke / m1, 0.0],
             [0.0, 0.0, 0.0, 1.0],
             [ke / p.I_c, 0.0, -(ke + p.k_z) / p.I_c, 0.0]]
        return control.ss(A, [[0.0], [1.0 / m1], [0.0], [0.0]], [[ke, 0.0, -ke, 0.0]], [[0.0]])

    def frequency_response(self, *, omega) -> np.ndarray:
        """G(jω) [-] on ``omega`` [rad/s]."""
        num, den = self.num_den()
        jw = 1j * np.asarray(omega, float)
        return np.polyval(num, jw) / np.polyval(den, jw)


@functools.lru_cache(maxsize=None)
def _coeff_functions():
    d = derive_plant()
    fn = sp.lambdify(d.params, sp.Poly(d.num, d.s).all_coeffs(), modules="math")
    fd = sp.lambdify(d.params, sp.Poly(d.den, d.s).all_coeffs(), modules="math")
    return fn, fd


# ---- symbolic route ---------------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def symbolic_sensitivities() -> dict:
    """Closed forms S_α^G(s) (sympy expressions) for α in :data:`PARAMETERS`, and the symbols.

    G is the derived plant (:func:`tendyn.analysis.tendon_drive.derive_plant`) with k_e = k1 k2/(k1 + k2)
    substituted; S_α = cancel(α ∂G/∂α / G). Returns ``{"symbols": {...}, "s": s, name: expr, ...}``.
    """
    d = derive_plant()
    k1, k2 = sp.symbols("k1 k2", positive=True)
    g = (d.num / d.den).subs(d.k_e, k1 * k2 / (k1 + k2))
    syms = {"r": d.r, "k1": k1, "k2": k2, "B": d.B, "k_z": d.k_z, "I_M": d.I_M, "I_c": d.I_c}
    out: dict = {"symbols": syms, "s": d.s}
    for name, a in syms.items():
        out[name] = sp.factor(sp.cancel(a * sp.diff(g, a) / g))
    return out


@functools.lru_cache(maxsize=None)
def _symbolic_functions():
    ss = symbolic_sensitivities()
    syms = ss["symbols"]
    args = [ss["s"]] + [syms[n] for n in PARAMETERS]
    return {n: sp.lambdify(args, ss[n], modules="numpy") for n in PARAMETERS}


def sensitivity_symbolic(params: Any = None, *, omega, which=PARAMETERS, **grid) -> dict:
    """S_α^G(jω) from the sympy closed forms, broadcast like :func:`sensitivity`."""
    s, vals = _broadcast(params, omega, grid)
    fns = _symbolic_functions()
    return {n: np.asarray(fns[n](s, *[vals[k] for k in PARAMETERS]), complex) * np.ones_like(s) for n in which}


# ---- numeric route ------------------------------------------------------------------------------------

def _broadcast(params, omega, grid):
    p = _params(PlantParams() if params is None else params)
    vals = {k: np.asarray(grid.get(k, getattr(p, k)), float) for k in PARAMETERS}
    w = np.asarray(omega, float)
    s = 1j * w.reshape((1,) * max(v.ndim for v in vals.values()) + w.shape)
    vals = {k: v.reshape(v.shape + (1,) * w.ndim) for k, v in vals.items()}
    return s, vals


def sensitivity(params: Any = None, *, omega, which=PARAMETERS, **grid) -> dict:
    """Sensitivities S_α^G(jω) = (α/G) ∂G/∂α [-], vectorised over frequency and design grids.

    Parameters
    ----------
    params : PlantParams, mapping or TendonBench, optional
        Nominal values (default :class:`PlantParams`).
    omega : array_like
        Frequency grid [rad/s] (keyword-only), shape (F,).
    which : sequence of str
        Parameters to return (default all of :data:`PARAMETERS`).
    **grid : array_like
        Design grids overriding nominal values, e.g. ``k1=np.logspace(3, 7, 1000)``; all grids broadcast
        together (shape (...)).

    Returns
    -------
    dict of str to ndarray of complex, shape (..., F)

    Notes
    -----
    G = k_e Q / D with P = m1 s² + c1 s, Q = I_c s² + k_z, D = P (Q + k_e) + k_e Q. Logarithmic derivatives:
    ∂ln G/∂k_e = 1/k_e − (P + Q)/D, ∂ln G/∂k_z = 1/Q − (P + k_e)/D, ∂ln G/∂I_c = s²/Q − s² (P + k_e)/D,
    ∂ln G/∂m1 = −s² (Q + k_e)/D, ∂ln G/∂c1 = −s (Q + k_e)/D; the first three are evaluated in their
    cancellation-free forms k_e ∂ln G/∂k_e = P Q/D, 1/Q − (P + k_e)/D = k_e P/(Q D). Chain rule: S_IM = m1 ∂ln G/∂m1,
    S_B = c1 ∂ln G/∂c1, S_r = 2 (S_IM + S_B), S_k1 = S_ke k2/(k1 + k2), S_k2 = S_ke k1/(k1 + k2)
    (S1 eq. 4, corrected: ERRATA).

    The evaluation runs in blocks of design rows (``BLOCK_ELEMENTS`` complex values per block) so that the
    temporaries stay in cache; each block is the same broadcast expression.
    """
    s, v = _broadcast(params, omega, grid)
    which = tuple(which)
    shape = np.broadcast_shapes(s.shape, *(x.shape for x in v.values()))
    rows = shape[0] if len(shape) > 1 else 1
    per_row = int(np.prod(shape[1:])) if len(shape) > 1 else int(np.prod(shape))
    step = max(1, BLOCK_ELEMENTS // max(per_row, 1))
    if rows <= step:
        return _sensitivity_kernel(s, v, which, shape)
    out = {n: np.empty(shape, complex) for n in which}
    for i in range(0, rows, step):
        sl = slice(i, min(i + step, rows))
        vb = {k: (x[sl] if x.shape[0] == rows else x) for k, x in v.items()}
        part = _sensitivity_kernel(s, vb, which, (sl.stop - sl.start,) + shape[1:])
        for n in which:
            out[n][sl] = part[n]
    return out


BLOCK_ELEMENTS = 16384
"""Complex values per block of :func:`sensitivity` (256 kB per temporary: L2-resident)."""


def _sensitivity_kernel(s, v, which, shape) -> dict:
    r, I_M, B, k1, k2, I_c, k_z = (v[k] for k in ("r", "I_M", "B", "k1", "k2", "I_c", "k_z"))
    ke = k1 * k2 / (k1 + k2)
    m1, c1 = r * r * I_M, r * r * B
    s2 = s * s
    P = (m1 * s + c1) * s
    Q = I_c * s2 + k_z
    qke = Q + ke
    D = P * qke + ke * Q
    inv_d = 1.0 / D
    out = {}
    need = set(which)
    if need & {"r", "I_M", "B"}:
        qk = qke * inv_d
        s_im = -m1 * s2 * qk
        s_b = -c1 * s * qk
        if "I_M" in need:
            out["I_M"] = s_im
        if "B" in need:
            out["B"] = s_b
        if "r" in need:
            out["r"] = 2.0 * (s_im + s_b)
    if need & {"k1", "k2"}:
        s_ke = P * Q * inv_d          # = 1 − k_e (P + Q)/D, without the cancellation at low frequency
        if "k1" in need:
            out["k1"] = s_ke * (k2 / (k1 + k2))
        if "k2" in need:
            out["k2"] = s_ke * (k1 / (k1 + k2))
    if need & {"k_z", "I_c"}:
        common = ke * P * inv_d / Q   # = 1/Q − (P + k_e)/D
        if "k_z" in need:
            out["k_z"] = k_z * common
        if "I_c" in need:
            out["I_c"] = I_c * s2 * common
    return {n: np.broadcast_to(out[n], shape) if out[n].shape != tuple(shape) else out[n] for n in which}


# ---- figures of S1 §3 (Figs. 3–4) -------------------------------------------------------------------

@dataclass(eq=False)
class SensitivityStudy(Result):
    """|G|, |G(1 + S)|, |G(1 − S)| and |S| for several values of one parameter (S1 Figs. 3–4).

    ``values`` of parameter ``name``; ``G``, ``S`` complex arrays (len(values), F) on ``omega`` [rad/s].
    """

    name: str
    values: np.ndarray
    omega: np.ndarray
    G: np.ndarray
    S: np.ndarray

    @property
    def _panels(self):
        return len(self.values)

    _figsize = (4.2, 3.6)

    reading = ('One panel per parameter value: the plant gain |G| (black), the first-order gains G(1 ± S) of a ±100 % '
               'change of the parameter (dashed), and the sensitivity |S| (dots) against frequency.')

    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        f = self.omega / (2 * math.pi)
        for k, a in enumerate(axes[: len(self.values)]):
            g, s = self.G[k], self.S[k]
            a.loglog(f, np.abs(g), "k-", lw=1.2, label="|G|")
            a.loglog(f, np.abs(g * (1 + s)), "b--", lw=1.0, label="|G(1+S)|")
            a.loglog(f, np.abs(g * (1 - s)), "r-.", lw=1.0, label="|G(1−S)|")
            a.loglog(f, np.abs(s), "o", ms=2, color="g", label=f"|S_{self.name}|")
            a.set_title(f"{self.name} = {self.values[k]:.4g}")
            a.set_xlabel("frequency [Hz]")
            a.set_ylabel("|G| [-], |S| [-]")
            a.grid(alpha=0.3, which="both")
        axes[0].legend(fontsize=7)

    def peak_hz(self) -> np.ndarray:
        """Frequency [Hz] of max |S| per value."""
        return self.omega[np.argmax(np.abs(self.S), axis=-1)] / (2 * math.pi)

    def max_abs(self) -> np.ndarray:
        return np.max(np.abs(self.S), axis=-1)

    def bandwidth_hz(self) -> np.ndarray:
        """Highest grid frequency [Hz] where |G| ≥ |G(0)|/√2 (−3 dB of the DC gain) per value."""
        mag = np.abs(self.G)
        ok = mag >= mag[:, :1] / math.sqrt(2)
        idx = np.array([np.nonzero(row)[0].max() for row in ok])
        return self.omega[idx] / (2 * math.pi)

    def to_dict(self) -> dict:
        return {"name": self.name, "values": self.values.tolist(), "freq_hz": (self.omega / (2 * math.pi)).tolist(),
                "abs_G": np.abs(self.G).tolist(), "abs_S": np.abs(self.S).tolist(),
                "peak_hz": self.peak_hz().tolist(), "max_abs_S": self.max_abs().tolist(),
                "bandwidth_hz": self.bandwidth_hz().tolist()}

    def table(self) -> str:
        rows = [(v, p, m, b) for v, p, m, b in zip(self.values, self.peak_hz(), self.max_abs(), self.bandwidth_hz())]
        return format_table((self.name, "peak of |S| [Hz]", "max |S|", "bandwidth [Hz]"), rows,
                            f"sensitivity of G to {self.name} (S1 §3)")


def sensitivity_study(name: str, values, params: Any = None, *, omega=None) -> SensitivityStudy:
    """G and S_name for each of ``values`` (e.g. k1 ∈ {1e3, 2.566e4, 4.56e6}, S1 Fig. 3)."""
    omega = 2 * math.pi * np.logspace(-2, 3, 600) if omega is None else np.asarray(omega, float)
    values = np.asarray(values, float)
    p = _params(PlantParams() if params is None else params)
    G = np.array([TendonDrivePlant(p.replace(**{name: float(v)})).frequency_response(omega=omega) for v in values])
    S = sensitivity(p, omega=omega, which=(name,), **{name: values})[name]
    return SensitivityStudy(name, values, omega, G, S)


# ---- effect of r (C15) ------------------------------------------------------------------------------

@dataclass(eq=False)
class RatioTradeoff(Result):
    """The effect of the ratio r as S1 §3.1 argues it, computed from G (not from eq. 3, which is
    dimensionally wrong: ERRATA S1).

    For an output F_m of amplitude ``output_N`` at ``freq_hz`` and a friction force ``friction_N`` at the
    motor/tendon node (on the path of F_τ, tension-dependent, independent of r):

    * ``effort_N``: |F_τ| = output/|G(jω)| [N at the rim] the actuator must supply;
    * ``snr``: effort / friction = friction rejection relative to effort (grows with r);
    * ``torque_Nm``: motor torque effort / r over the band up to ``freq_hz`` (max), against
      ``torque_max_Nm`` (saturation);
    * ``peak_force_N``: r τ_max |G(0)|, the largest static force the actuator can produce;
    * ``backdriven_mass_kg``: r² I_M seen from the load open loop, and ÷ (1 + K) with loop gain ``K``.
    """

    r: np.ndarray
    effort_N: np.ndarray
    snr: np.ndarray
    torque_Nm: np.ndarray
    peak_force_N: np.ndarray
    backdriven_mass_kg: np.ndarray
    backdriven_mass_closed_kg: np.ndarray
    torque_max_Nm: float
    freq_hz: float
    loop_gain: float

    _panels = 4
    _figsize = (3.6, 3.2)

    I_M: float = 0.0
    k_e: float = 0.0

    def r_resonance(self) -> float:
        """r at which the stiff-load resonance sqrt(k_e/(r² I_M)) equals ``freq_hz``: above it the drive is
        inertia-dominated at that frequency and effort/friction grows like r²."""
        return math.sqrt(self.k_e / self.I_M) / (2 * math.pi * self.freq_hz)

    def r_saturation(self) -> float:
        """Smallest r of the grid above the torque minimum where the band torque exceeds τ_max (nan if none)."""
        k0 = int(np.argmin(self.torque_Nm))
        over = np.nonzero(self.torque_Nm[k0:] > self.torque_max_Nm)[0]
        return float(self.r[k0 + over[0]]) if over.size else float("nan")

    reading = ('Each panel is one consequence of the pulley ratio r (horizontal): friction rejection, peak force, '
               'motor torque against its limit, and the inertia felt at the load.')

    def _draw(self, ax) -> None:
        a = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        a[0].semilogy(self.r, self.snr, "k-")
        a[0].set_title(f"effort / friction at {self.freq_hz:g} Hz")
        a[0].set_ylabel("effort / friction [-]")
        if len(a) > 1:
            a[1].plot(self.r, self.peak_force_N, "b-")
            a[1].set_title("peak force r τ_max |G(0)|")
            a[1].set_ylabel("peak force [N]")
        if len(a) > 2:
            a[2].semilogy(self.r, self.torque_Nm, "r-", label="needed")
            a[2].axhline(self.torque_max_Nm, color="0.4", ls="--", label="τ_max (saturation)")
            a[2].set_title(f"motor torque, band ≤ {self.freq_hz:g} Hz")
            a[2].set_ylabel("motor torque [N·m]")
            a[2].legend(fontsize=7)
        if len(a) > 3:
            a[3].semilogy(self.r, self.backdriven_mass_kg, "g-", label="open loop r² I_M")
            a[3].semilogy(self.r, self.backdriven_mass_closed_kg, "g--", label=f"÷ (1 + K), K = {self.loop_gain:g}")
            a[3].set_title("back-driven inertia")
            a[3].set_ylabel("back-driven mass [kg]")
            a[3].legend(fontsize=7)
        for x in a:
            x.set_xlabel("ratio r [-]")
            x.grid(alpha=0.3, which="both")
        a[0].text(0.02, 0.02, "eq. (3) not used: dimensionally wrong (ERRATA S1)", transform=a[0].transAxes,
                  fontsize=6, color="0.3")

    def to_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()} | {
            "r_saturation": self.r_saturation(), "r_resonance": self.r_resonance(), "note": "S1 eq. 3 is dimensionally wrong (ERRATA); not used"}

    def table(self) -> str:
        idx = np.unique(np.linspace(0, self.r.size - 1, 8).round().astype(int))
        rows = [(self.r[i], self.snr[i], self.peak_force_N[i], self.torque_Nm[i], self.backdriven_mass_kg[i])
                for i in idx]
        return format_table(("r", "effort/friction", "peak force [N]", "torque [N·m]", "r² I_M [kg]"), rows,
                            "effect of r (S1 §3.1, C15; eq. 3 not used, ERRATA)")


def ratio_tradeoff(params: Any = None, *, r=None, output_N: float = 1.0, freq_hz: float = 40.0,
                   friction_N: float = 0.125, torque_max_Nm: float = 0.05, loop_gain: float = 10.0) -> RatioTradeoff:
    """Evaluate :class:`RatioTradeoff` over a grid of r (default 2…60). I_M, B are motor-side (fixed)."""
    p = _params(PlantParams() if params is None else params)
    r = np.linspace(2.0, 60.0, 117) if r is None else np.asarray(r, float)
    band = 2 * math.pi * np.linspace(0.0, freq_hz, 200)
    effort, torque = np.empty(r.size), np.empty(r.size)
    g0 = np.empty(r.size)
    for k, rk in enumerate(r):
        plant = TendonDrivePlant(p.replace(r=float(rk)))
        g = plant.frequency_response(omega=band)
        effort[k] = output_N / abs(g[-1])
        torque[k] = float(np.max(output_N / np.abs(g))) / rk
        g0[k] = abs(g[0])
    mass = r**2 * p.I_M
    return RatioTradeoff(r, effort, effort / friction_N, torque, r * torque_max_Nm * g0, mass, mass / (1 + loop_gain),
                         float(torque_max_Nm), float(freq_hz), float(loop_gain), float(p.I_M), float(p.k_e))
