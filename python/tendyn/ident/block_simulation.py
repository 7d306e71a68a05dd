"""Simulating a block model: the linear part G = B/A (``lfilter``), the Wiener and Hammerstein chains, and
the Lur'e and push-pull recursions (the nonlinearity in G's feedback, finer steps per sample)."""

from __future__ import annotations

import numpy as np

from .block_nonlinearities import LURE_STRUCTURES, LURE_SUBSTEPS, Nonlinearity


def _lfilter(b, a, x):
    """scipy.signal.lfilter, imported on first use (the command line lists identify-bench without scipy.signal)."""
    from scipy.signal import lfilter

    return lfilter(b, a, x)


def _lure_simulate(b, a, level, u, per_output=0.0, sign=1.0) -> np.ndarray:
    """ŷ of the Lur'e model from rest: y = G (u − φ), G(z) = (b_1 z⁻¹ + … + b_n z⁻ⁿ)/A(z) strictly proper
    (``b`` = b_1…b_n, ``a`` = a_1…a_n), φ_t Coulomb friction of level F = ``level`` [u unit] held over the
    sample like u_t, opposing the output's next increment Δ = y_{t+1} − y_t (time stepping at the velocity
    level, as the twins' nodes, ``tendon_bench.hpp``). With Δ₀ the increment without friction:

    * slip, |Δ₀| > |b_1| F:  φ_t = F sgn(b_1 Δ₀), y_{t+1} = y_t + Δ₀ − |b_1| F sgn(Δ₀);
    * stick, |Δ₀| ≤ |b_1| F: y_{t+1} = y_t and the state is put at rest there (the last n outputs y_t, the
      last n − 1 net inputs y_t/G(1)), φ_t = u_t − y_t/G(1) the static balance.

    At rest the free increment is Δ₀ = b_1 (u_t − y_t/G(1)), so the stick test is the static one,
    |u − y/G(1)| ≤ F: F is the half-width of the dead-band seen from u. Resting the state (rather than only
    holding y_{t+1} = y_t, which inverts G's numerator and makes the stuck friction ring on its sampling
    zero near z = −1) is what a stuck mass does: its velocity is zero. One scalar recursion per sample (the
    stick/slip choice depends on the simulated output), in the core (``include/tendyn/lure.hpp``).

    ``per_output`` μ ≠ 0: the level of step t is max(F + μ s y_t, 0), s = ``sign`` (0: |y_t|) — friction linear
    in the tension the branch's output is (``coulomb-tension``)."""
    from tendyn import _core

    f = lambda x: np.ascontiguousarray(x, float)
    u = f(u)
    y = np.empty_like(u)
    _core.lure_simulate(f(b), f(a), float(level), u, float(per_output), float(sign), y)
    return y


def _push_pull_simulate(b, a, level, u, per_output=0.0) -> np.ndarray:
    """ŷ of the push-pull (class-B) Lur'e model: two Lur'e loops of the same G and friction level F, one fed
    the positive half-wave max(u, 0), the other the negative one min(u, 0), outputs added (S1's 2N drive: the
    amplifier's clamping diodes give each motor its half-wave, each motor/tendon node its own Coulomb friction;
    with the load clamped the two halves do not interact). ``b`` = b_1…b_n, ``a`` = a_1…a_n, F [u unit] the
    level of one branch."""
    u = np.asarray(u, float)
    return (_lure_simulate(b, a, level, np.maximum(u, 0.0), per_output, 1.0)
            + _lure_simulate(b, a, level, np.minimum(u, 0.0), per_output, -1.0))


def _fine(b, a, substeps):
    """G(z) = (b_1 z⁻¹ + … + b_n z⁻ⁿ)/A(z) at the sample time h re-sampled at h/r, r = ``substeps``: the
    zero-order-hold state space M = [[A_d, B_d], [0, 1]] of G(z) (observable companion form) is exp(L h)
    of its continuous equivalent, so the step h/r is M^(1/r) = exp(log(M)/r) (the same continuous G(s) as
    :meth:`BlockModelFit.linear_continuous`). Returns (b, a) at h/r, or None when a pole of G(z) lies on the
    non-positive real axis (no continuous equivalent: the fit rejects that point)."""
    from scipy.linalg import expm, logm

    n = len(a)
    Ad = np.zeros((n, n))
    Ad[:, 0] = -np.asarray(a, float)
    Ad[:-1, 1:] = np.eye(n - 1)
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n], M[n, n] = Ad, np.asarray(b, float), 1.0
    poles = np.linalg.eigvals(Ad)
    if not np.all(np.isfinite(poles)) or np.any((np.abs(poles.imag) < 1e-12) & (poles.real <= 0)):
        return None
    with np.errstate(all="ignore"):
        L = logm(M)
    if np.iscomplexobj(L):
        if np.abs(L.imag).max() > 1e-8 * (np.abs(L.real).max() or 1.0):
            return None
        L = L.real
    Mf = expm(L / substeps)
    Af, Bf = Mf[:n, :n], Mf[:n, n]
    af = np.real(np.poly(Af))[1:]
    # numerator of C (zI − A_f)⁻¹ B_f, C = e_1ᵀ: Markov parameters h_k = C A_f^(k−1) B_f, b = (h convolved with A)
    h, x = [], Bf.copy()
    for _ in range(n):
        h.append(x[0])
        x = Af @ x
    bf = np.array([h[k] + sum(af[j] * h[k - 1 - j] for j in range(k)) for k in range(n)])
    return bf, af


def _lure_family_simulate(structure, b, a, p, u, substeps=1):
    """ŷ of a Lur'e structure; ``p`` = (F,) or (F, μ) (``coulomb-tension``, run at ``substeps`` steps per
    sample: u held over the sample, ŷ the fine output at each sample instant)."""
    level = p[0]
    mu = p[1] if len(p) > 1 else 0.0
    r = int(substeps)
    if r > 1:
        fine = _fine(b, a, r)
        if fine is None:
            return np.full(np.size(u), np.nan)
        b, a = fine
        u = np.repeat(np.asarray(u, float), r)
    if structure == "push-pull":
        y = _push_pull_simulate(b, a, level, u, mu)
    else:
        y = _lure_simulate(b, a, level, u, mu, 0.0)
    return y[::r] if r > 1 else y


def simulate(structure: str, nl: Nonlinearity, b, a, p, u) -> np.ndarray:
    """ŷ of the model from rest for the input sequence ``u`` (``a`` without its leading 1; Lur'e: b_0 = 0;
    ``coulomb-tension``: :data:`LURE_SUBSTEPS` recursion steps per sample)."""
    if structure in LURE_STRUCTURES:
        return _lure_family_simulate(structure, b[1:], a, p, u, LURE_SUBSTEPS if nl.name == "coulomb-tension" else 1)
    A = np.concatenate([[1.0], a])
    if structure == "wiener":
        return nl.f(_lfilter(b, A, u), p)
    return _lfilter(b, A, nl.f(u, p))


def _shifted(w, k):
    if k == 0:
        return w
    out = np.zeros_like(w)
    out[k:] = w[:-k]
    return out
