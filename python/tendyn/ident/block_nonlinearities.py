"""The static nonlinearities of a block model (dead-zone, Coulomb, saturation, polynomial, …) and which
structure takes which: a Wiener or Hammerstein model's φ (:data:`NONLINEARITIES`), a Lur'e feedback's
(:data:`LURE_NONLINEARITIES`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


STRUCTURES = ("wiener", "hammerstein", "lure", "push-pull")
LURE_STRUCTURES = ("lure", "push-pull")
"""Structures whose nonlinearity sits in G's feedback (:data:`LURE_NONLINEARITIES`, simulated by a recursion)."""

# ---- static nonlinearities --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Nonlinearity:
    """A static nonlinearity f(x; p): its parameter names, f, ∂f/∂x, ∂f/∂p (one column per parameter), the
    lower bounds of p, and whether its one parameter is a threshold (found on a grid by the initial
    estimate, :func:`_initial_nonlinear`)."""

    name: str
    params: tuple
    f: Callable
    dfdx: Callable
    dfdp: Callable
    lower: tuple
    description: str
    threshold: bool = False          # one threshold parameter, found by a grid in the initial estimate


def _sgn(x):
    return np.sign(x)


def _dz(x, p):
    return np.sign(x) * np.maximum(np.abs(x) - p[0], 0.0)


def _sat(x, p):
    return np.clip(x, -p[0], p[0])


NONLINEARITIES: dict[str, Nonlinearity] = {n.name: n for n in (
    Nonlinearity("dead-zone", ("width",), _dz,
                 lambda x, p: (np.abs(x) > p[0]).astype(float),
                 lambda x, p: (-np.sign(x) * (np.abs(x) > p[0]))[:, None],
                 (0.0,), "f = sgn(x) max(|x| − δ, 0): dead-band of half-width δ [x unit] (S1 Fig. 8)", True),
    Nonlinearity("coulomb", ("level",), lambda x, p: x + p[0] * _sgn(x),
                 lambda x, p: np.ones_like(x),
                 lambda x, p: _sgn(x)[:, None],
                 (-np.inf,), "f = x + c sgn(x): a relay of height c on the identity (c < 0: a Coulomb loss)"),
    Nonlinearity("saturation", ("limit",), _sat,
                 lambda x, p: (np.abs(x) < p[0]).astype(float),
                 lambda x, p: (np.sign(x) * (np.abs(x) >= p[0]))[:, None],
                 (1e-300,), "f = clip(x, −s, s) [x unit]", True),
    Nonlinearity("abs", (), lambda x, p: np.abs(x),
                 lambda x, p: _sgn(x),
                 lambda x, p: np.zeros((x.size, 0)),
                 (), "f = |x| (a sensor blind to the sign)"),
)}
NONLINEARITIES["dead-band"] = NONLINEARITIES["dead-zone"]
IDENTITY = Nonlinearity("identity", (), lambda x, p: x, lambda x, p: np.ones_like(x),
                        lambda x, p: np.zeros((x.size, 0)), (), "f = x (the linear output-error fit)")
NONLINEARITY_NAMES = ("dead-zone", "dead-band", "coulomb", "coulomb-tension", "saturation", "abs", "polynomial")
LURE_NONLINEARITIES: dict[str, Nonlinearity] = {n.name: n for n in (Nonlinearity(
    "coulomb", ("level",), lambda v, p: p[0] * _sgn(v), lambda v, p: np.zeros_like(v), lambda v, p: _sgn(v)[:, None],
    (0.0,), "φ = F sgn(Δy) fed back to G's input, sticking (Δy = 0, |φ| ≤ F) when it can: Coulomb friction of "
            "level F [input unit] inside the dynamics (Lur'e)"), Nonlinearity(
    "coulomb-tension", ("level", "per_output"), lambda v, p: p[0] * _sgn(v), lambda v, p: np.zeros_like(v),
    lambda v, p: _sgn(v)[:, None], (0.0, -np.inf),
    "φ as coulomb with a level that grows with the branch's own output, F + μ s y (s the branch's sign; the "
    "one-loop model F + μ |y|), μ = per_output [input unit per output unit]: a node's friction linear in its "
    "tendon's tension (S1 §4, F_c = F_c0 + μ_T T); the recursion runs LURE_SUBSTEPS steps per sample"))}
LURE_SUBSTEPS = 4
"""Steps per sample of the ``coulomb-tension`` Lur'e recursion: the friction's stick/slip decisions are taken at
4× the log rate (:mod:`tendyn.ident.blockmodel`'s docstring: why)."""
"""Feedback nonlinearities of the Lur'e structure (:func:`_lure_simulate`)."""


def polynomial(degree: int) -> Nonlinearity:
    """f = x + c_2 x² + … + c_d x^d."""
    if int(degree) < 2:
        raise ValueError(f"degree must be >= 2 (got {degree!r})")
    ks = np.arange(2, int(degree) + 1)
    return Nonlinearity(
        "polynomial", tuple(f"c{k}" for k in ks),
        lambda x, p: x + sum(c * x ** k for c, k in zip(p, ks)),
        lambda x, p: 1.0 + sum(k * c * x ** (k - 1) for c, k in zip(p, ks)),
        lambda x, p: np.column_stack([x ** k for k in ks]),
        tuple(-np.inf for _ in ks), f"f = x + Σ_k c_k x^k, k = 2…{int(degree)}")


def nonlinearity(name: str, degree: int = 3, structure: str = "wiener") -> Nonlinearity:
    """The nonlinearity called ``name`` (:data:`NONLINEARITY_NAMES`; ``degree`` for the polynomial); for the
    ``lure`` structure, one of :data:`LURE_NONLINEARITIES`."""
    if structure in LURE_STRUCTURES:
        if name not in LURE_NONLINEARITIES:
            raise ValueError(f"the lure structure takes the nonlinearity {', '.join(LURE_NONLINEARITIES)} "
                             f"(got {name!r})")
        return LURE_NONLINEARITIES[name]
    if name == "polynomial":
        return polynomial(degree)
    if name not in NONLINEARITIES:
        raise ValueError(f"unknown nonlinearity {name!r} (known: {', '.join(NONLINEARITY_NAMES)})")
    return NONLINEARITIES[name]
