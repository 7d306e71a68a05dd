"""Block-oriented nonlinear models of a bench, fitted by output error (simulation error) to its logs.

A linear block G (discrete transfer function of order n, sample time of the logs) and a static nonlinearity
f (:data:`NONLINEARITIES`, :data:`LURE_NONLINEARITIES`) in one of three arrangements:

* Wiener:      x = G u,  ŷ = f(x)     (S1's dead-band plant, §4.2 and Fig. 8: linear tendon dynamics, then
  the single-valued dead-band of the breakaway friction model, which makes the hysteresis-like loops);
* Hammerstein: v = f(u), ŷ = G v;
* Lur'e:       ŷ = G (u − φ), φ a static nonlinearity of the output's motion fed back to G's input — Coulomb
  friction φ = F sgn(Δŷ) that sticks when it can (:func:`_lure_simulate`). This is where the twins' node
  friction acts (inside the dynamics: it damps the motion), which neither a Wiener nor a Hammerstein model
  can hold (their G absorbs it); the level F [input unit] is the half-width of the dead-band seen from u.

G(z) = (b_0 + b_1 z⁻¹ + … + b_n z⁻ⁿ) / (1 + a_1 z⁻¹ + … + a_n z⁻ⁿ). Each nonlinearity has slope one in its
linear part (dead-zone outside the band, saturation inside, polynomial x + c_2 x² + …), so the gain of the
chain lives in G alone and the parameters are identifiable.

Output error: θ = (b, a, p) minimises Σ_records Σ_t (y_t − ŷ_t(θ))², ŷ simulated from rest over the whole
record (not one step ahead). Wiener and Hammerstein: the simulation is ``scipy.signal.lfilter`` (compiled)
and so is the exact Jacobian: ∂x/∂b_k = (z⁻ᵏ/A) u, ∂x/∂a_k = −(z⁻ᵏ/A) x — two filters per record for all of
(b, a) — chained through f′ (Wiener) or filtered through G (the nonlinearity's parameters in Hammerstein
form). The minimiser is Levenberg–Marquardt (:func:`_solve`, bounds on the thresholds) started from a
linear initial estimate: ARX least squares, refined to linear output error, then the nonlinearity's
parameters by linear least squares over a grid of thresholds (the gain of G rescaled at the same time).
Lur'e: the stick/slip choice of each sample depends on the simulated output, so the simulation is one
scalar recursion (:func:`_lure_simulate`) and the Jacobian is by forward differences; G is strictly proper
(b_0 = 0, the friction of sample t acts from sample t + 1 on); the initial estimate is equation error with
the friction's sign read from the measured output (:func:`_initial_lure`), exact at no noise (a linear
output-error G has its damping inflated by the friction; from it the McGill twin's fit ends at a higher
cost, docs/bench-identification.md).

``coulomb-tension`` (Lur'e, push-pull): the level of each branch F + μ s y grows with its output (a node's friction
linear in its tendon's tension, S1 §4) and the recursion runs :data:`LURE_SUBSTEPS` steps a sample on G's
continuous equivalent re-sampled (:func:`_fine`), so stick/slip is decided 4× finer than the log rate: a model
fitted at one amplitude then holds at 0.5× and 1.5× of it within 1.2× its NRMS on generated benches, where the
constant level at the log rate reached 1.35× (docs/bench-identification.md).

RMS [output unit] and NRMS = ‖y − ŷ‖/‖y − ȳ‖ [-] (1: no better than the mean) are reported on the fit and
on validation records. :class:`BlockModel` is the estimator (hyper-parameters in ``__init__``, learned values
with a trailing ``_``, ``fit`` / ``predict`` / ``score``); its ``result_`` a :class:`BlockModelFit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from tendyn.results import Result, format_table


def _lfilter(b, a, x):
    """scipy.signal.lfilter, imported on first use (the command line lists identify-bench without scipy.signal)."""
    from scipy.signal import lfilter

    return lfilter(b, a, x)


__all__ = ["LURE_NONLINEARITIES", "NONLINEARITIES", "STRUCTURES", "BlockModel", "BlockModelFit", "Nonlinearity",
           "Record", "nrms", "records_from_logs", "simulate"]

STRUCTURES = ("wiener", "hammerstein", "lure", "push-pull")
LURE_STRUCTURES = ("lure", "push-pull")
"""Structures whose nonlinearity sits in G's feedback (:data:`LURE_NONLINEARITIES`, simulated by a recursion)."""
AUTO_CANDIDATES = (("wiener", "dead-zone"), ("lure", "coulomb"), ("push-pull", "coulomb"),
                   ("push-pull", "coulomb-tension"))
"""(structure, nonlinearity) pairs tried by ``BlockModel("auto")`` (chosen by the validation NRMS)."""


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
4× the log rate (module docstring: why)."""
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


# ---- records ----------------------------------------------------------------------------------------------

@dataclass
class Record:
    """One input/output record: ``u`` [input unit], ``y`` [output unit], sampled at ``rate_hz`` [Hz]."""

    u: np.ndarray
    y: np.ndarray
    rate_hz: float
    name: str = ""

    def __post_init__(self):
        self.u = np.ascontiguousarray(self.u, float).ravel()
        self.y = np.ascontiguousarray(self.y, float).ravel()
        if self.u.shape != self.y.shape or self.u.size < 10:
            raise ValueError(f"record {self.name or ''}: u and y must have the same length >= 10 "
                             f"(got {self.u.size}, {self.y.size})")
        if not np.all(np.isfinite(self.u)) or not np.all(np.isfinite(self.y)):
            raise ValueError(f"record {self.name}: values must be finite")


def records_from_logs(logs, input: str, output: str, shift: int = 0) -> tuple[list, dict]:
    """Records of ``input`` → ``output`` (column names or ``meta.signals`` names) from logs or paths, and the
    units ``{"input": …, "output": …}`` (the logs must agree).

    ``shift`` pairs y_k with u_{k+shift} [samples]. The model's G(z) is the zero-order-hold sampling of G(s)
    when u_k is the command held from t_k to t_{k+1} (shift 0: a controller that logs what it sends at t_k);
    a log whose u_k was held over the interval that *ends* at t_k (the twins' logs, ``bench_log``) needs
    shift 1."""
    from tendyn.io import Log, read_log

    if int(shift) != shift:
        raise ValueError(f"shift must be a whole number of samples (got {shift!r})")
    shift = int(shift)
    out, units = [], None
    for k, lg in enumerate(logs if isinstance(logs, (list, tuple)) else [logs]):
        name = str(lg) if not isinstance(lg, Log) else f"log {k + 1}"
        lg = lg if isinstance(lg, Log) else read_log(lg)
        ci, co = lg.resolve(input), lg.resolve(output)
        u_units = {"input": lg.units[ci], "output": lg.units[co]}
        if units is not None and u_units != units:
            raise ValueError(f"{name}: units {u_units} differ from the first log's {units}")
        units = u_units
        u, y, n = lg[ci], lg[co], lg.n_samples
        u, y = (u[shift:], y[:n - shift]) if shift >= 0 else (u[:n + shift], y[-shift:])
        out.append(Record(u, y, float(lg.meta["rate_hz"]), name))
    return out, units


def _as_records(data, rate_hz) -> list:
    if isinstance(data, Record):
        return [data]
    if isinstance(data, tuple) and len(data) == 2 and np.ndim(data[0]) == 1:
        return [Record(data[0], data[1], rate_hz)]
    return [d if isinstance(d, Record) else Record(d[0], d[1], rate_hz) for d in data]


def nrms(y, yhat) -> float:
    """‖y − ŷ‖ / ‖y − ȳ‖ [-]."""
    y = np.asarray(y, float)
    d = np.linalg.norm(y - y.mean())
    return float(np.linalg.norm(y - yhat) / d) if d > 0 else math.inf


# ---- simulation and Jacobian ----------------------------------------------------------------------------

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
    stick/slip choice depends on the simulated output): plain floats, ≈ 0.5 µs a sample.

    ``per_output`` μ ≠ 0: the level of step t is max(F + μ s y_t, 0), s = ``sign`` (0: |y_t|) — friction linear
    in the tension the branch's output is (``coulomb-tension``)."""
    n = len(a)
    b = [float(v) for v in b]
    a = [float(v) for v in a]
    b1, F = b[0], max(float(level), 0.0)
    thr, sb = abs(b1) * F, (1.0 if b1 >= 0.0 else -1.0)
    ab1, F0, mu, sgn = abs(b1), float(level), float(per_output), float(sign)
    sum_b = sum(b)
    inv_g0 = (1.0 + sum(a)) / sum_b if sum_b != 0.0 else 0.0        # 1/G(1)
    uu = np.asarray(u, float).tolist()
    N = len(uu)
    out = [0.0] * N
    yh = [0.0] * n              # y_t, y_{t−1}, …, y_{t−n+1}
    wh = [0.0] * (n - 1)        # w_{t−1}, …, w_{t−n+1}  (w = u − φ)
    bw = b[1:]
    for t in range(N - 1):
        ut = uu[t]
        acc = b1 * ut
        for k in range(n - 1):
            acc += bw[k] * wh[k]
        for k in range(n):
            acc -= a[k] * yh[k]
        yt = yh[0]
        if mu != 0.0:
            F = F0 + mu * (sgn * yt if sgn != 0.0 else abs(yt))
            F = F if F > 0.0 else 0.0
            thr = ab1 * F
        d = acc - yt
        if -thr <= d <= thr:                                        # stick: at rest at y_t
            yh = [yt] * n
            wh = [yt * inv_g0] * (n - 1)
            out[t + 1] = yt
            continue
        if d > 0.0:
            f, ynew = F * sb, acc - thr
        else:
            f, ynew = -F * sb, acc + thr
        yh.insert(0, ynew)
        yh.pop()
        if n > 1:
            wh.insert(0, ut - f)
            wh.pop()
        out[t + 1] = ynew
    return np.array(out)


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


LURE_TOL = 1e-7
"""Relative decrease of the cost below which the Lur'e fit stops (its cost is rough at the scale of one
sample's stick/slip change: finer tolerances buy evaluations, not accuracy)."""


def _lure_residual_and_jac(n, theta, records, want_jac, skip, structure="lure", substeps=1):
    """Residual of the Lur'e model and its Jacobian by forward differences (b_0 ≡ 0: its column is zero, so
    the step leaves it at 0). The recursion's stick/slip choice is redone at each perturbed θ; ŷ jumps (by
    about the velocity of one threshold |b_1| F a sample) where a sample changes between stick and slip, a
    set of measure zero that a step of 1e-7 relative seldom meets."""
    def res(th):
        r = np.concatenate([(_lure_family_simulate(structure, th[1:n + 1], th[n + 1:2 * n + 1], th[2 * n + 1:],
                                                   rec.u, substeps) - rec.y)[skip:] for rec in records])
        bad = ~np.isfinite(r)
        return np.where(bad, 1e6, np.clip(r, -1e6, 1e6)) if bad.any() else r

    r = res(theta)
    if not want_jac:
        return r
    J = np.zeros((r.size, theta.size))
    umax = max(float(np.max(np.abs(rec.u))) for rec in records) or 1.0
    scale = np.concatenate([[0.0], np.full(n, np.abs(theta[1:n + 1]).max() or 1.0), np.ones(n), [umax],
                            np.ones(theta.size - 2 * n - 2)])
    for j in range(1, theta.size):
        h = 1e-7 * (abs(theta[j]) + 1e-2 * scale[j])
        th = theta.copy()
        th[j] += h
        J[:, j] = (res(th) - r) / (th[j] - theta[j])
    return r, J


def _residual_and_jac(structure, nl, n, theta, records, want_jac, skip):
    if structure in LURE_STRUCTURES:
        return _lure_residual_and_jac(n, theta, records, want_jac, skip, structure,
                                      LURE_SUBSTEPS if nl.name == "coulomb-tension" else 1)
    b, a, p = theta[:n + 1], theta[n + 1:2 * n + 1], theta[2 * n + 1:]
    A = np.concatenate([[1.0], a])
    res, jacs = [], []
    for r in records:
        v = r.u if structure == "wiener" else nl.f(r.u, p)
        x = _lfilter(b, A, v)
        yhat = nl.f(x, p) if structure == "wiener" else x
        res.append((yhat - r.y)[skip:])
        if not want_jac:
            continue
        wv = _lfilter([1.0], A, v)
        wx = _lfilter([1.0], A, x)
        J = np.empty((r.u.size, theta.size))
        for k in range(n + 1):
            J[:, k] = _shifted(wv, k)
        for k in range(1, n + 1):
            J[:, n + k] = -_shifted(wx, k)
        if structure == "wiener":
            J[:, :2 * n + 1] *= nl.dfdx(x, p)[:, None]
            J[:, 2 * n + 1:] = nl.dfdp(x, p)
        else:
            dp = nl.dfdp(r.u, p)
            for j in range(dp.shape[1]):
                J[:, 2 * n + 1 + j] = _lfilter(b, A, dp[:, j])
        jacs.append(J[skip:])
    r = np.concatenate(res)
    bad = ~np.isfinite(r)
    if bad.any():                                    # an unstable trial point: a large, finite cost
        r = np.where(bad, 1e6, np.clip(r, -1e6, 1e6))
    if not want_jac:
        return r
    J = np.concatenate(jacs)
    return r, np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0)


def _stabilise(a):
    """Reflect the poles of 1 + a_1 z⁻¹ + … outside the unit circle inside it (same magnitude response shape)."""
    roots = np.roots(np.concatenate([[1.0], a]))
    big = np.abs(roots) >= 1.0
    if not big.any():
        return a
    roots[big] = 0.98 / np.conj(roots[big])
    return np.real(np.poly(roots))[1:]


def _arx(records, n, nl_in=None):
    """ARX least squares y_t + Σ a_k y_{t−k} = Σ b_k v_{t−k} (v = u, or f(u) for Hammerstein); stable a."""
    rows, rhs = [], []
    for r in records:
        v = r.u if nl_in is None else nl_in(r.u)
        y = r.y
        cols = [_shifted(v, k) for k in range(n + 1)] + [-_shifted(y, k) for k in range(1, n + 1)]
        rows.append(np.column_stack(cols)[n:])
        rhs.append(y[n:])
    theta, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
    return theta[:n + 1], _stabilise(theta[n + 1:])


@dataclass
class _Solution:
    x: np.ndarray
    cost: float
    nfev: int


def _solve(structure, nl, n, theta0, records, skip, max_nfev, lower_nl, tol=1e-10):
    """Levenberg–Marquardt on the output error with the exact Jacobian: the normal equations JᵀJ are
    (2n + 1 + p)² small, so a step costs the simulation and two filters per record, never a factorisation of
    J (a thin SVD of a 10 000 × 8 Jacobian costs more than the whole simulation); thresholds are kept above
    their lower bounds by projection."""
    with np.errstate(over="ignore", invalid="ignore"):     # unstable trial points are rejected by their cost
        return _lm(structure, nl, n, theta0, records, skip, max_nfev, lower_nl, tol)


def _lm(structure, nl, n, theta0, records, skip, max_nfev, lower_nl, tol):
    lb = np.concatenate([np.full(2 * n + 1, -np.inf), lower_nl])
    theta = np.maximum(np.asarray(theta0, float), lb)
    r, J = _residual_and_jac(structure, nl, n, theta, records, True, skip)
    cost, lam, nfev = float(r @ r), 1e-3, 1
    while nfev < max_nfev:
        g, H = J.T @ r, J.T @ J
        d = np.diag(H).copy()
        d[d <= 0] = 1.0
        while nfev < max_nfev:
            try:
                step = np.linalg.solve(H + lam * np.diag(d), -g)
            except np.linalg.LinAlgError:
                step = np.zeros_like(theta)
            trial = np.maximum(theta + step, lb)
            if structure in LURE_STRUCTURES:     # a Jacobian costs 2n simulations: only at accepted points
                r2 = _residual_and_jac(structure, nl, n, trial, records, False, skip)
            else:                       # the Jacobian shares the simulation: with every trial
                r2, J2 = _residual_and_jac(structure, nl, n, trial, records, True, skip)
            nfev += 1
            c2 = float(r2 @ r2)
            if c2 < cost:
                if structure in LURE_STRUCTURES:
                    r2, J2 = _residual_and_jac(structure, nl, n, trial, records, True, skip)
                break
            lam *= 4.0
            if lam > 1e12:
                return _Solution(theta, cost, nfev)
        else:
            break
        small = (cost - c2 <= tol * cost) or np.linalg.norm(trial - theta) <= tol * (np.linalg.norm(theta) + tol)
        theta, r, J, cost = trial, r2, J2, c2
        lam = max(lam / 3.0, 1e-12)
        if small:
            break
    return _Solution(theta, cost, nfev)


def _initial_nonlinear(structure, nl, n, b, a, records, degree_cols):
    """Rescale G and choose p by linear least squares on the basis of the nonlinearity (module docstring)."""
    A = np.concatenate([[1.0], a])
    z = [_lfilter(b, A, r.u) if structure == "wiener" else r.u for r in records]
    y = np.concatenate([r.y for r in records])

    def design(phis):       # Wiener: Φ(z); Hammerstein: G Φ(u)
        if structure == "wiener":
            return np.column_stack([np.concatenate([phi(zz) for zz in z]) for phi in phis])
        return np.column_stack([np.concatenate([_lfilter(b, A, phi(zz)) for zz in z]) for phi in phis])

    if nl.threshold:
        mag = np.abs(np.concatenate(z))
        best = None
        for q in (0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8):
            t = max(float(np.quantile(mag, q)), 1e-12 * (mag.max() or 1.0))
            X = design([lambda s, t=t: nl.f(s, [t])])
            g = float(X[:, 0] @ y / (X[:, 0] @ X[:, 0])) if X[:, 0] @ X[:, 0] > 0 else 0.0
            cost = float(np.sum((y - g * X[:, 0]) ** 2))
            if g > 0 and (best is None or cost < best[0]):
                best = (cost, g, t)
        if best is None:
            return b, np.array([1e-6 * (mag.max() or 1.0)])
        _, g, t = best
        return g * b, np.array([g * t if structure == "wiener" else t])
    if nl.name == "abs":
        X = design([np.abs])
        g = float(X[:, 0] @ y / (X[:, 0] @ X[:, 0]))
        return g * b, np.zeros(0)
    if nl.name == "coulomb":
        w, *_ = np.linalg.lstsq(design([lambda s: s, np.sign]), y, rcond=None)
        g = w[0] if abs(w[0]) > 1e-12 else 1.0
        return g * b, np.array([w[1] if structure == "wiener" else w[1] / g])
    ks = np.arange(1, degree_cols + 2)
    w, *_ = np.linalg.lstsq(design([lambda s, k=k: s ** k for k in ks]), y, rcond=None)
    g = w[0] if abs(w[0]) > 1e-12 else 1.0
    c = [w[k - 1] / (g ** k if structure == "wiener" else g) for k in ks[1:]]
    return g * b, np.array(c)


def _initial_lure(n, records):
    """Initial Lur'e model by equation error with the friction's sign read from the measured output: where
    the output moved over the n samples a step depends on (|Δy| above round-off: slip), φ_j = F sgn(Δy_{j+1})
    and y_{t+1} + Σ a_k y_{t+1−k} = Σ b_k u_{t+1−k} − Σ c_k sgn(Δy_{t+2−k}) is linear in (a, b, c = b F);
    F = c·b / b·b (≥ 0), a stabilised. Stuck samples are left out (their φ is unknown)."""
    rows, rhs = [], []
    for r in records:
        y, u = r.y, r.u
        dy = np.diff(y, append=y[-1])                  # dy[j] = y_{j+1} − y_j
        s = np.sign(dy)
        moving = np.abs(dy) > 1e-9 * (np.ptp(y) or 1.0)
        ok = np.ones(y.size, bool)                    # row t predicts y_{t+1} from samples t+1−k, k = 1…n
        for k in range(n):
            ok &= _shifted(moving.astype(float), k) > 0
        cols = ([-_shifted(y, k) for k in range(n)] + [_shifted(u, k) for k in range(n)]
                + [-_shifted(s, k) for k in range(n)])
        X = np.column_stack(cols)[n - 1:-1]
        keep = ok[n - 1:-1]
        rows.append(X[keep])
        rhs.append(y[n:][keep])
    X, Y = np.concatenate(rows), np.concatenate(rhs)
    if Y.size < 3 * n + 1:
        raise ValueError(f"too few moving samples ({Y.size}) for a Lur'e model of order {n}")
    th, *_ = np.linalg.lstsq(X, Y, rcond=None)
    a, b, c = th[:n], th[n:2 * n], th[2 * n:]
    F = max(float(c @ b / (b @ b)), 0.0) if b @ b > 0 else 0.0
    return np.concatenate([[0.0], b]), _stabilise(a), np.array([F])


def _kernel_signs(records, lags=24):
    """A sign sequence for x = G u from y = |x|: y² = (g * u)² is a quadratic form in the lagged inputs,
    y²_t ≈ Σ_ij Q_ij u_{t−i} u_{t−j} with Q = g gᵀ (g the first ``lags`` samples of G's impulse response);
    Q by least squares, g (up to its sign) its leading eigenvector, s = sgn(g * u)."""
    rows, rhs = [], []
    iu = np.triu_indices(lags)
    for r in records:
        U = np.column_stack([_shifted(r.u, k) for k in range(lags)])
        rows.append((U[:, iu[0]] * U[:, iu[1]])[lags:])
        rhs.append(r.y[lags:] ** 2)
    q, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
    Q = np.zeros((lags, lags))
    Q[iu] = q
    Q = 0.5 * (Q + Q.T)
    w, V = np.linalg.eigh(Q)
    g = V[:, -1] * math.sqrt(max(w[-1], 0.0))
    return [np.sign(np.convolve(r.u, g)[:r.u.size]) + 0.0 for r in records]


def _abs_sign_recovery(records, n, skip, max_nfev, rounds=4):
    """Linear initial estimate of a Wiener model with f = |x| (its best linear approximation is zero: f is
    even). Two sign sequences are tried for x — sgn(u) and the output's own dips (:func:`_output_signs`) —
    each refined by alternating an ARX fit of s·y on u with s = sgn(G u), then by output error with |·|;
    the one of lower cost is kept (G and −G are the same model)."""
    nl = NONLINEARITIES["abs"]
    best = None
    for signs in ([np.sign(r.u) for r in records], _kernel_signs(records)):
        signs = [s + (s == 0) for s in signs]
        for _ in range(rounds):
            b, a = _arx([Record(r.u, s * r.y, r.rate_hz) for r, s in zip(records, signs)], n)
            signs = [np.sign(_lfilter(b, np.concatenate([[1.0], a]), r.u)) for r in records]
            signs = [s + (s == 0) for s in signs]
        sol = _solve("wiener", nl, n, np.concatenate([b, a]), records, skip, max_nfev, np.zeros(0))
        if best is None or sol.cost < best.cost:
            best = sol
    return best.x[:n + 1], _stabilise(best.x[n + 1:2 * n + 1])


# ---- the result and the estimator -------------------------------------------------------------------------

@dataclass(eq=False)
class BlockModelFit(Result):
    """A fitted Wiener, Hammerstein or Lur'e model: G(z) = B/A at ``dt`` [s], the nonlinearity and its parameters,
    RMS [output unit] and NRMS [-] on the fit and validation records, NRMS per order tried."""

    structure: str
    nonlinearity: str
    order: int
    b: np.ndarray
    a: np.ndarray
    params: dict
    dt: float
    fit_rms: float
    fit_nrms: float
    validation_rms: list = field(default_factory=list)
    validation_nrms: list = field(default_factory=list)
    order_nrms: dict = field(default_factory=dict)
    units: dict = field(default_factory=lambda: {"input": "-", "output": "-"})
    nfev: int = 0
    seconds: float = 0.0
    structure_nrms: dict = field(default_factory=dict)     # "structure nonlinearity" → validation NRMS (auto)
    example: tuple | None = field(default=None, repr=False)     # (title, time, y, ŷ) of one record, ≤ 2 s

    def linear_tf(self):
        """G(z) as a python-control discrete ``TransferFunction`` (dt [s])."""
        import control

        b = np.where(np.abs(self.b) < 1e-12 * np.abs(self.b).max(), 0.0, self.b)   # a round-off b_0 is a delay
        return control.tf(b, np.concatenate([[1.0], self.a]), self.dt)

    def linear_continuous(self):
        """G(s) with the same zero-order-hold samples as G(z) (matrix logarithm of the sampled state
        space), as a python-control ``TransferFunction``. Raises ValueError if a pole of G(z) lies on the
        negative real axis (no real continuous equivalent)."""
        import control
        from scipy.linalg import expm, logm

        sysd = control.ss(self.linear_tf())
        nx = sysd.A.shape[0]
        poles = np.linalg.eigvals(sysd.A)
        if np.any((np.abs(poles.imag) < 1e-12) & (poles.real <= 0)):
            raise ValueError("a pole of G(z) lies on the non-positive real axis: no continuous equivalent")
        M = np.zeros((nx + 1, nx + 1))
        M[:nx, :nx], M[:nx, nx:] = sysd.A, sysd.B
        M[nx, nx] = 1.0
        L = np.real(logm(M)) / self.dt
        assert np.allclose(expm(L * self.dt), M, atol=1e-8 * np.abs(M).max())
        return control.tf(control.ss(L[:nx, :nx], L[:nx, nx:], sysd.C, sysd.D))

    def frequency_response(self, omega) -> np.ndarray:
        """G(e^{jωdt}) on ``omega`` [rad/s]."""
        z = np.exp(1j * np.asarray(omega, float) * self.dt)
        zi = 1.0 / z
        num = np.polyval(self.b[::-1], zi)
        den = np.polyval(np.concatenate([[1.0], self.a])[::-1], zi)
        return num / den

    def predict(self, u) -> np.ndarray:
        nl = nonlinearity(self.nonlinearity, len(self.params) + 1, self.structure)
        return simulate(self.structure, nl, self.b, self.a, np.array(list(self.params.values()), float),
                        np.asarray(u, float))

    reading = ('The measured output and the fitted block model simulated from rest over the same input; where the '
               'dashed curve leaves the measured one, the model misses the dynamics.')

    def _draw(self, ax) -> None:
        if self.example is None:
            ax.text(0.5, 0.5, "no validation record", ha="center")
            return
        title, t, y, yh = self.example
        ax.plot(t, y, lw=1.0, label="measured")
        ax.plot(t, yh, lw=1.0, ls="--", label=f"simulated from rest ({self.structure}, {self.nonlinearity})")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"output [{self.units['output']}]")
        ax.set_title(title)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)

    def to_dict(self) -> dict:
        d = {"structure": self.structure, "nonlinearity": self.nonlinearity, "order": self.order,
             "b": [float(v) for v in self.b], "a": [1.0] + [float(v) for v in self.a], "dt_s": self.dt,
             "nonlinearity_params": {k: float(v) for k, v in self.params.items()},
             "fit_rms": self.fit_rms, "fit_nrms": self.fit_nrms, "validation_rms": list(self.validation_rms),
             "validation_nrms": list(self.validation_nrms),
             "order_nrms": {str(k): v for k, v in self.order_nrms.items()}, "units": dict(self.units),
             "nfev": self.nfev, "seconds": self.seconds,
             "structure_nrms": dict(self.structure_nrms)}
        try:
            G = self.linear_continuous()
            d["continuous"] = {"num": [float(v) for v in np.ravel(G.num[0][0])],
                               "den": [float(v) for v in np.ravel(G.den[0][0])]}
        except ValueError:
            d["continuous"] = None
        return d

    def table(self) -> str:
        rows = [(k, v) for k, v in self.params.items()]
        rows += [("fit RMS [" + self.units["output"] + "]", self.fit_rms), ("fit NRMS", self.fit_nrms)]
        rows += [(f"validation {i + 1} NRMS", v) for i, v in enumerate(self.validation_nrms)]
        rows += [(f"order {k}: NRMS", v) for k, v in self.order_nrms.items()]
        rows += [(f"{k}: validation NRMS", v) for k, v in self.structure_nrms.items()]
        return format_table(("quantity", "value"), rows,
                            f"{self.structure} model, {self.nonlinearity}, order {self.order} "
                            f"({self.nfev} evaluations, {self.seconds:.2f} s)")


class BlockModel:
    """Estimator of a Wiener, Hammerstein or Lur'e model by output error (module docstring).

    Parameters (hyper-parameters, stored as given)
    ----------
    structure : {"wiener", "hammerstein", "lure", "push-pull", "auto"}
        ``push-pull``: two Lur'e loops of one G and one friction level fed max(u, 0) and min(u, 0), outputs added
        (a class-B 2N drive, :func:`_push_pull_simulate`); ``auto``: each of :data:`AUTO_CANDIDATES` fitted, the
        lowest mean NRMS on the validation records kept (``nonlinearity`` is then not used).
    nonlinearity : str
        One of ``dead-zone`` (alias ``dead-band``), ``coulomb``, ``saturation``, ``abs``, ``polynomial``;
        ``lure``: ``coulomb`` (friction of level ``params_["level"]`` [input unit] in G's feedback).
    order : int or None
        Order n of G(z); None chooses it in 1…``max_order`` by the NRMS on the validation records (or, without
        them, on the last third of each fit record, the model fitted on the first two thirds), then refits.
    max_order : int
    degree : int
        Degree of the polynomial nonlinearity.
    skip : int
        Samples at the start of each record left out of the cost (an initial state that is not rest).
    max_nfev : int
        Evaluations allowed to the output-error minimiser per fit.
    rate_hz : float or None
        Sample rate [Hz] of records given as (u, y) arrays (records from logs carry their own).

    Learned attributes
    ------------------
    order_ : int;  b_, a_ : the coefficients of G(z) (``a_`` without its leading 1);  params_ : dict of the
    nonlinearity's parameters [its input's unit];  dt_ : [s];  linear_ : G(z) (python-control);
    structure_, nonlinearity_ : the fitted structure (``auto``: the chosen one);  structure_nrms_ : {"structure
    nonlinearity": validation NRMS} (``auto``);  fit_rms_, fit_nrms_ ;  validation_nrms_ : list;  order_nrms_ : {order: NRMS};  nfev_ ;  result_ :
    :class:`BlockModelFit`.
    """

    def __init__(self, structure: str = "wiener", nonlinearity: str = "dead-zone", order: int | None = None,
                 max_order: int = 4, degree: int = 3, skip: int = 0, max_nfev: int = 200,
                 rate_hz: float | None = None):
        self.structure = structure
        self.nonlinearity = nonlinearity
        self.order = order
        self.max_order = max_order
        self.degree = degree
        self.skip = skip
        self.max_nfev = max_nfev
        self.rate_hz = rate_hz

    def get_params(self, deep: bool = True) -> dict:
        return {k: getattr(self, k) for k in ("structure", "nonlinearity", "order", "max_order", "degree", "skip",
                                              "max_nfev", "rate_hz")}

    # ---- fitting ----
    def _nl(self) -> Nonlinearity:
        if self.structure == "auto":
            return nonlinearity(self.nonlinearity_, self.degree, self.structure_)
        return nonlinearity(self.nonlinearity, self.degree, self.structure)

    def _fit_order(self, records, n, warm=None):
        """θ and evaluations of the order-n model; ``warm``, the order n − 1 solution, is also tried padded
        with a pole and a zero at the origin (the same model), so a higher order never fits worse."""
        nl = self._nl()
        starts = []
        if self.structure in LURE_STRUCTURES and nl.name == "coulomb-tension":
            # the constant-level model first (its G and F), then μ = 0 added and all refined on the fine steps
            th0, nf0 = BlockModel(self.structure, "coulomb", order=n, skip=self.skip,
                                  max_nfev=self.max_nfev)._fit_order(records, n, warm=None if warm is None
                                                                     else warm[:-1])
            b, a, p = th0[:n + 1], th0[n + 1:2 * n + 1], np.concatenate([th0[2 * n + 1:], [0.0]])
        elif self.structure in LURE_STRUCTURES:
            b, a, p = _initial_lure(n, records)
            if self.structure == "push-pull":
                # the one-loop Lur'e model by output error first: its G is the push-pull's, its level the
                # dead-band of both branches (≈ 2 F at rest) or of one; both starts are tried
                one = _solve("lure", nl, n, np.concatenate([b, a, p]), records, self.skip, self.max_nfev,
                             np.array(nl.lower, float), LURE_TOL)
                b, a, p = one.x[:n + 1], one.x[n + 1:2 * n + 1], one.x[2 * n + 1:]
                starts.append(np.concatenate([b, a, p / 2]))
        elif self.structure == "wiener" and nl.name == "abs":
            b, a = _abs_sign_recovery(records, n, self.skip, self.max_nfev)
        else:   # linear output error (identity in place of f) from ARX
            b, a = _arx(records, n)
            sol = _solve("wiener", IDENTITY, n, np.concatenate([b, a]), records, self.skip, self.max_nfev,
                         np.zeros(0))
            b, a = sol.x[:n + 1], _stabilise(sol.x[n + 1:2 * n + 1])
        if self.structure not in LURE_STRUCTURES:
            b, p = _initial_nonlinear(self.structure, nl, n, b, a, records, self.degree - 1)
        tol = LURE_TOL if self.structure in LURE_STRUCTURES else 1e-10
        sol = _solve(self.structure, nl, n, np.concatenate([b, a, p]), records, self.skip, self.max_nfev,
                     np.array(nl.lower, float), tol)
        if warm is not None:
            starts.append(np.concatenate([warm[:n], [0.0], warm[n:2 * n - 1], [0.0], warm[2 * n - 1:]]))
        for start in starts:
            other = _solve(self.structure, nl, n, start, records, self.skip, self.max_nfev, np.array(nl.lower, float),
                           tol)
            if other.cost < sol.cost:
                sol = _Solution(other.x, other.cost, other.nfev + sol.nfev)
        theta = sol.x
        if self.structure == "wiener" and nl.name == "abs" and np.sum(theta[:n + 1]) < 0:
            theta = np.concatenate([-theta[:n + 1], theta[n + 1:]])     # |G u| = |−G u|: G(1) > 0 by convention
        return theta, sol.nfev

    def fit(self, records, validation=None) -> "BlockModel":
        """Fit to records: a :class:`Record`, a ``(u, y)`` pair or a list of either (``rate_hz`` needed for
        arrays); ``validation`` the same kinds. Returns self."""
        import time

        if self.structure == "auto":
            return self._fit_auto(records, validation)
        if self.structure not in STRUCTURES:
            raise ValueError(f"structure must be one of {STRUCTURES} or 'auto' (got {self.structure!r})")
        nl = self._nl()
        self.structure_, self.nonlinearity_ = self.structure, nl.name
        self.structure_nrms_ = {}
        recs = _as_records(records, self.rate_hz)
        val = _as_records(validation, self.rate_hz) if validation is not None else []
        rates = {r.rate_hz for r in recs + val}
        if len(rates) != 1 or None in rates:
            raise ValueError(f"all records need one sample rate (got {sorted(map(str, rates))})")
        if self.order is not None and (int(self.order) < 1 or int(self.order) > 12):
            raise ValueError(f"order must be 1…12 (got {self.order!r})")
        t0 = time.perf_counter()
        self.order_nrms_ = {}
        if self.order is None:
            if val:
                sel_fit, sel_val = recs, val
            else:
                sel_fit = [Record(r.u[:2 * r.u.size // 3], r.y[:2 * r.y.size // 3], r.rate_hz) for r in recs]
                sel_val = [Record(r.u[2 * r.u.size // 3:], r.y[2 * r.y.size // 3:], r.rate_hz) for r in recs]
            fits = {0: (None, 0)}
            for n in range(1, int(self.max_order) + 1):
                fits[n] = self._fit_order(sel_fit, n, warm=fits[n - 1][0])
                self._set(fits[n][0], n, nl, recs[0].rate_hz)
                self.order_nrms_[n] = float(np.mean([self.nrms(r.u, r.y) for r in sel_val]))
            n = min(self.order_nrms_, key=lambda k: (round(self.order_nrms_[k], 3), k))
            # with validation records the selection fitted on all the fit records already
            th, nfev = fits[n] if val else self._fit_order(recs, n, warm=fits[n - 1][0])
        else:
            n = int(self.order)
            th, nfev = self._fit_order(recs, n)
        self._set(th, n, nl, recs[0].rate_hz)
        self.nfev_ = int(nfev)
        yh = [self.predict(r.u) for r in recs]
        err = np.concatenate([(y - r.y)[self.skip:] for y, r in zip(yh, recs)])
        ally = np.concatenate([r.y[self.skip:] for r in recs])
        self.fit_rms_ = float(np.sqrt(np.mean(err ** 2)))
        self.fit_nrms_ = float(np.linalg.norm(err) / np.linalg.norm(ally - ally.mean()))
        self.validation_rms_ = [self.rms(r.u, r.y) for r in val]
        self.validation_nrms_ = [self.nrms(r.u, r.y) for r in val]
        k = int(np.argmin(self.validation_nrms_)) if val else 0     # the validation record the model fits best
        ex = val[k] if val else recs[0]
        m = min(ex.u.size, int(2.0 * ex.rate_hz))
        title = (f"validation record {k + 1} of {len(val)}: NRMS {self.validation_nrms_[k]:.3f} (first {m / ex.rate_hz:g} s)"
                 if val else f"fit: NRMS {self.fit_nrms_:.3f}")
        example = (title, np.arange(m) / ex.rate_hz, ex.y[:m], self.predict(ex.u)[:m])
        self.result_ = BlockModelFit(self.structure, nl.name, n, self.b_.copy(), self.a_.copy(), dict(self.params_),
                                     self.dt_, self.fit_rms_, self.fit_nrms_, self.validation_rms_,
                                     self.validation_nrms_, dict(self.order_nrms_), nfev=self.nfev_,
                                     seconds=time.perf_counter() - t0, example=example)
        return self

    def _fit_auto(self, records, validation):
        """Structure chosen by the validation NRMS (mean over the validation records) among
        :data:`AUTO_CANDIDATES`, each with its order chosen as ``order`` says; the winner's learned values."""
        import time

        t0 = time.perf_counter()
        best, table = None, {}
        for st, nl in AUTO_CANDIDATES:
            m = BlockModel(**(self.get_params() | {"structure": st, "nonlinearity": nl}))
            m.fit(records, validation)
            score = (float(np.mean(m.validation_nrms_)) if m.validation_nrms_
                     else float(min(m.order_nrms_.values())) if m.order_nrms_ else m.fit_nrms_)
            table[f"{st} {nl}"] = score
            if best is None or score < best[0]:
                best = (score, m)
        m = best[1]
        for k, v in vars(m).items():
            if k.endswith("_"):
                setattr(self, k, v)
        self.structure_nrms_ = table
        self.result_.structure_nrms = dict(table)
        self.result_.seconds = time.perf_counter() - t0
        return self

    def _set(self, theta, n, nl, rate_hz):
        self.order_ = n
        self.b_ = np.asarray(theta[:n + 1], float)
        self.a_ = np.asarray(theta[n + 1:2 * n + 1], float)
        self.params_ = {k: float(v) for k, v in zip(nl.params, theta[2 * n + 1:])}
        self.dt_ = 1.0 / float(rate_hz)

    @property
    def linear_(self):
        return self.result_.linear_tf()

    # ---- using the model ----
    def predict(self, u) -> np.ndarray:
        """ŷ [output unit] simulated from rest for the input ``u``."""
        return simulate(self.structure_, self._nl(), self.b_, self.a_, np.array(list(self.params_.values()), float),
                        np.asarray(u, float))

    def rms(self, u, y) -> float:
        """RMS of y − ŷ [output unit] (after ``skip``)."""
        e = (np.asarray(y, float) - self.predict(u))[self.skip:]
        return float(np.sqrt(np.mean(e ** 2)))

    def nrms(self, u, y) -> float:
        """NRMS = ‖y − ŷ‖/‖y − ȳ‖ [-] (after ``skip``)."""
        y = np.asarray(y, float)
        return nrms(y[self.skip:], self.predict(u)[self.skip:])

    def score(self, u, y) -> float:
        """1 − NRMS [-] (1 perfect, 0 no better than the mean; higher is better, as scikit-learn's score)."""
        return 1.0 - self.nrms(u, y)
