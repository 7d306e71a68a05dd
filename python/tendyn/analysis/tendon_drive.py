"""Analytic plant of a tendon drive (S1, McGill bench): G(s) = F_m / F_τ, derived symbolically.

The plant of S1 eq. (2) is a two-mass chain (ERRATA S1): mass m1 = r² I_M with damper c1 = r² B, driven
by F_τ; spring k_e = k1 k2 / (k1 + k2) (eq. 1) to the load mass I_c; the load grounded by a spring k_z;
sensed force F_m = k_e (x1 − x2). :func:`derive_plant` writes these equations of motion, Laplace-transforms
them (zero initial conditions), solves for x1 and x2 with sympy and forms k_e (x1 − x2) / F_τ. Nothing
of eq. (2) is typed in here (C14); the tests compare the derivation with the printed equation.

Units: tendon-linear at the driven-pulley rim, SI. Parameters are passed as a mapping (or an object with
``plant_params()``, e.g. :class:`tendyn.device.tendon_bench.TendonBench`) with keys

``m1`` [kg] (= r² I_M), ``c1`` [N·s/m] (= r² B), ``k1``, ``k2`` [N/m] (or ``k_e`` directly),
``mass_load`` [kg] (I_c), ``k_z`` [N/m] (``math.inf`` gives the stiff-load limit).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import sympy as sp

__all__ = ["PlantSymbolic", "derive_plant", "frequency_response", "k_e", "plant_tf", "stiff_limit_tf"]


def k_e(k1: float, k2: float) -> float:
    """Series stiffness k_e = k1 k2 / (k1 + k2) [N/m] of the proximal and distal sections (S1 eq. 1, C13).

    Works on floats, numpy arrays and sympy expressions.
    """
    return k1 * k2 / (k1 + k2)


@dataclass(frozen=True)
class PlantSymbolic:
    """Symbolic result of :func:`derive_plant`.

    Attributes
    ----------
    s, r, I_M, B, k_e, I_c, k_z : sympy.Symbol
        Laplace variable and parameters (r² I_M is the rim mass, r² B the rim damping).
    num, den : sympy.Expr
        Numerator and denominator of G(s) = F_m / F_τ, polynomials in s, normalised so that the leading
        coefficient of ``den`` is r² I_M I_c (as printed in S1 eq. 2).
    x1, x2 : sympy.Expr
        Transfer functions X1/F_τ and X2/F_τ (motor node and load).
    """

    s: sp.Symbol
    r: sp.Symbol
    I_M: sp.Symbol
    B: sp.Symbol
    k_e: sp.Symbol
    I_c: sp.Symbol
    k_z: sp.Symbol
    num: sp.Expr
    den: sp.Expr
    x1: sp.Expr
    x2: sp.Expr

    @property
    def params(self) -> tuple[sp.Symbol, ...]:
        return (self.r, self.I_M, self.B, self.k_e, self.I_c, self.k_z)


@functools.lru_cache(maxsize=None)
def derive_plant() -> PlantSymbolic:
    """Derive G(s) = F_m/F_τ of the two-mass chain with sympy (cached).

    Equations of motion (x1 motor node at the rim, x2 load):
        r² I_M ẍ1 = F_τ − r² B ẋ1 − k_e (x1 − x2)
        I_c ẍ2   = k_e (x1 − x2) − k_z x2
    Laplace transform with zero initial conditions, solve the linear system for X1, X2, then
    G = k_e (X1 − X2) / F_τ.
    """
    s, r, I_M, B, ke, I_c, kz, F = sp.symbols("s r I_M B k_e I_c k_z F_tau", positive=True)
    X1, X2 = sp.symbols("X1 X2")
    m1 = r**2 * I_M
    c1 = r**2 * B
    eqs = [
        sp.Eq(m1 * s**2 * X1, F - c1 * s * X1 - ke * (X1 - X2)),
        sp.Eq(I_c * s**2 * X2, ke * (X1 - X2) - kz * X2),
    ]
    sol = sp.solve(eqs, [X1, X2], dict=True)[0]
    g = sp.cancel(ke * (sol[X1] - sol[X2]) / F)
    num, den = sp.fraction(g)
    num_p = sp.Poly(sp.expand(num), s)
    den_p = sp.Poly(sp.expand(den), s)
    # Normalise: leading coefficient of the denominator r² I_M I_c (S1's printed form).
    scale = sp.cancel(den_p.LC() / (m1 * I_c))
    num_e = sp.expand(sp.cancel(num_p.as_expr() / scale))
    den_e = sp.expand(sp.cancel(den_p.as_expr() / scale))
    return PlantSymbolic(s=s, r=r, I_M=I_M, B=B, k_e=ke, I_c=I_c, k_z=kz, num=num_e, den=den_e,
                         x1=sp.cancel(sol[X1] / F), x2=sp.cancel(sol[X2] / F))


@functools.lru_cache(maxsize=None)
def _coeff_functions():
    """Numeric functions (r, I_M, B, k_e, I_c, k_z) -> coefficient lists, highest power first."""
    p = derive_plant()
    num_c = sp.Poly(p.num, p.s).all_coeffs()
    den_c = sp.Poly(p.den, p.s).all_coeffs()
    fn = sp.lambdify(p.params, num_c, modules="math")
    fd = sp.lambdify(p.params, den_c, modules="math")
    return fn, fd


def _read(params: Any) -> dict[str, float]:
    if hasattr(params, "plant_params"):
        params = params.plant_params()
    if not isinstance(params, Mapping):
        raise TypeError("params must be a mapping or have plant_params()")
    p = dict(params)
    if "k_e" not in p:
        if "k1" not in p or "k2" not in p:
            raise KeyError("params need k_e or both k1 and k2")
        p["k_e"] = k_e(float(p["k1"]), float(p["k2"]))
    for key in ("m1", "c1", "k_e", "mass_load", "k_z"):
        if key not in p:
            raise KeyError(f"params need {key!r}")
    return {k: float(p[k]) for k in ("m1", "c1", "k_e", "mass_load", "k_z")}


@functools.lru_cache(maxsize=None)
def _stiff_limit_symbolic() -> tuple[sp.Expr, sp.Expr]:
    p = derive_plant()
    n, d = sp.fraction(sp.cancel(sp.limit(p.num / p.den, p.k_z, sp.oo)))
    return sp.expand(n), sp.expand(d)


def stiff_limit_tf(params: Any) -> tuple[np.ndarray, np.ndarray]:
    """Stiff-load limit k_z → ∞ of G (sympy limit of the derived G): k_e / (r² I_M s² + r² B s + k_e).

    Returns numerator and denominator coefficients, highest power first, denominator monic.
    """
    q = _read(params)
    p = derive_plant()
    n, d = _stiff_limit_symbolic()
    subs = {p.r: 1.0, p.I_M: q["m1"], p.B: q["c1"], p.k_e: q["k_e"], p.I_c: q["mass_load"]}
    num = np.array([float(c.subs(subs)) for c in sp.Poly(n, p.s).all_coeffs()])
    den = np.array([float(c.subs(subs)) for c in sp.Poly(d, p.s).all_coeffs()])
    return num / den[0], den / den[0]


def plant_tf(params: Any) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator coefficients (highest power first) of G(s) = F_m / F_τ.

    Parameters
    ----------
    params : mapping or TendonBench
        ``m1`` [kg], ``c1`` [N·s/m], ``k1``/``k2`` or ``k_e`` [N/m], ``mass_load`` [kg], ``k_z`` [N/m].
        ``k_z = inf`` returns the stiff-load limit (2nd order).

    Returns
    -------
    num, den : numpy.ndarray
        Coefficients of the symbolic derivation (:func:`derive_plant`) evaluated at the parameters;
        den has degree 4, leading coefficient r² I_M I_c = m1 I_c.
    """
    q = _read(params)
    if math.isinf(q["k_z"]):
        return stiff_limit_tf(q)
    fn, fd = _coeff_functions()
    args = (1.0, q["m1"], q["c1"], q["k_e"], q["mass_load"], q["k_z"])  # r = 1: m1, c1 are rim values
    num = np.array(fn(*args), dtype=float)
    den = np.array(fd(*args), dtype=float)
    return num, den


def frequency_response(params: Any, omega: Any) -> np.ndarray:
    """G(jω) = F_m/F_τ at the angular frequencies ``omega`` [rad/s] (complex array, same shape)."""
    num, den = plant_tf(params)
    jw = 1j * np.asarray(omega, dtype=float)
    return np.polyval(num, jw) / np.polyval(den, jw)
